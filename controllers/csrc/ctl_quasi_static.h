/* ctl_quasi_static.h -- one constant-velocity ("quasi-static") run of the paper's Sec. V-C / Fig. 8.
 *
 * From rest (w = f = 0) the joint is driven by the discrete PI velocity loop to the setpoint w_ref: at each
 * period the controller reads w + noise[k], its command u = PI(w_ref - (w + noise[k])) is held over the
 * period for the plant (plant_step, each step started without the eq. 3 cache). After n_settle periods the
 * measured velocity and the torque are recorded for n_hold periods; at constant velocity u = F(w) (eqs. 1-3),
 * so their means are support points of the Stribeck curve. Python:
 * controllers.experiments.quasi_static.quasi_static_runs.
 */
#ifndef CTL_QUASI_STATIC_H
#define CTL_QUASI_STATIC_H
#include "plant_dynamics.h"
#include "ctl_pi.h"

/* One run: the PI pi (its integrator as the caller set it, advanced in place) and the plant p from rest with
 * the setpoint w_ref (rad/s) over n_settle + n_hold periods of dt (s), noise[k] (rad/s, n_settle + n_hold
 * samples) added to the measured velocity; writes W[i] (measured velocity, rad/s) and U[i] (torque, N*m) of the
 * periods n_settle + i, i < n_hold. */
void ctl_quasi_static_run(ctl_pi *pi, const plant_params *p, double w_ref, const double *noise, long n_settle,
                          long n_hold, double *W, double *U, double dt);

#endif
