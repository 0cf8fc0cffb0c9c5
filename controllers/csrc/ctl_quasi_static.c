/* ctl_quasi_static.c -- one constant-velocity run (see ctl_quasi_static.h). */
#include <math.h>

#include "ctl_quasi_static.h"

void ctl_quasi_static_run(ctl_pi *pi, const plant_params *p, double w_ref, const double *noise, long n_settle,
                          long n_hold, double *W, double *U, double dt)
{
    plant_state st;
    double w = 0.0, f = 0.0;
    st.q = 0.0; /* the joint position (a friction ripple's), carried across the periods */
    for (long k = 0; k < n_settle + n_hold; k++) {
        double wm = w + noise[k];
        double u = ctl_pi_step(pi, w_ref - wm, 0.0);
        if (k >= n_settle) {
            W[k - n_settle] = wm;
            U[k - n_settle] = u;
        }
        st.w = w;
        st.s = f;
        st.aux = NAN; /* no eq. 3 cache (as plant.dynamics.make_plant_step) */
        plant_step(p, &st, u, dt);
        w = st.w;
        f = st.s;
    }
}
