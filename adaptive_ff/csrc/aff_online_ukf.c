/* aff_online_ukf.c -- the online UKF's process model (see aff_online_ukf.h). */
#include "aff_online_ukf.h"

void aff_ukf_propagate(const plant_params *p, double *w, double *f, double u, double h, long n)
{
    double ww = *w;
    double ff = *f;
    for (long k = 0; k < n; k++)
        plant_rk4(p, &ww, &ff, plant_target(p, ww, 0.0), u, u, u, h, 0.0);
    *w = ww;
    *f = ff;
}
