/* aff_simulator.c -- the joint on an irregular sample grid (see aff_simulator.h). */
#include "aff_simulator.h"

void aff_simulate_on_grid(const plant_params *p, const double *tg, const double *ug, const long *idx, long n,
                          double offset, double w0, double f0, double Kw, double Kf, const double *w_meas,
                          int inject, double *out)
{
    double J = p->J;
    double w = w0;
    double f = f0 - offset;
    if (n <= 0)
        return;
    out[0] = w0;
    for (long s = 1; s < n; s++) {
        long a = idx[s - 1];
        long b = idx[s];
        for (long j = a; j < b; j++) {
            double u0 = ug[j] - offset;
            double u1 = ug[j + 1] - offset;
            plant_rk4(p, &w, &f, plant_target(p, w, 0.0), u0, 0.5 * (u0 + u1), u1, tg[j + 1] - tg[j], 0.0);
        }
        if (!(isfinite(w) && isfinite(f))) {
            for (long r = s; r < n; r++)
                out[r] = NAN;
            return;
        }
        out[s] = w;
        if (inject) {
            double e = w_meas[s] - w;
            w += Kw * e;
            f -= Kf * J / (tg[b] - tg[a]) * e;
        }
    }
}
