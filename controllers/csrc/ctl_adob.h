/* ctl_adob.h -- the adaptive friction feedforward plus a disturbance observer on the residual (mode
 * "adaptive-dob").
 *
 * Per period: u_ff from the robust adaptive feedforward (aff_robust_ff, 0 before its switch-on, faded in
 * after), d_hat from the disturbance observer (ctl_dob), output u_ff + d_hat clipped to +-u_max. The observer
 * is given the torque without the feedforward, u - u_ff, so that with J*dw/dt = u - f its raw sample is
 * (u - u_ff) - J_n*dw/dt = f - u_ff (for J_n = J): it cancels what the feedforward misses within the Q-filter
 * bandwidth; the estimator learns from the total (u, w) as in the "adaptive" mode. The two-degree-of-freedom
 * arrangement of a model-based feedforward with a disturbance observer for the model error (Umeno & Hori
 * 1991; Ohnishi, Shibata, Murakami 1996; for friction: Olsson, Astrom, Canudas de Wit, Gafvert, Lischinsky,
 * "Friction models and friction compensation", Eur. J. Control 4(3), 1998, Sec. 7).
 * Python: controllers.peers.adaptive_dob.AdaptiveDOBCompensator.
 */
#ifndef CTL_ADOB_H
#define CTL_ADOB_H
#include "aff_real.h"
#include "aff_compensator.h"
#include "aff_robust_ff.h"
#include "ctl_dob.h"

/* Configuration, then state; the parts embedded. */
typedef struct ctl_adob {
    aff_real u_max;       /* bound on |u_ff + d_hat| (N*m), INFINITY = none (each part keeps its own bound) */
    aff_real u_ff;        /* feedforward part of the last output (N*m) */
    aff_robust_ff ff;     /* the adaptive feedforward with its estimator */
    ctl_dob dob;          /* the observer of the residual f - u_ff */
} ctl_adob;

/* Configure a from the configured parts ff (aff_robust_ff_init) and dob (ctl_dob_init), both copied by value,
 * with the bound u_max (N*m, >= 0); u_ff = 0. */
void ctl_adob_init(ctl_adob *a, const aff_robust_ff *ff, const ctl_dob *dob, aff_real u_max);

/* Compensator interface (aff_compensator.h), self a ctl_adob: u_ff = aff_robust_ff_compensate, d_hat =
 * ctl_dob_compensate (each with w_ctrl, w_meas, w_ref in rad/s); returns u_ff + d_hat clipped to +-u_max (N*m)
 * and keeps u_ff. */
double ctl_adob_compensate(void *self, double w_ctrl, double w_meas, double w_ref);

/* Compensator interface: the observer records u - u_ff (N*m), then the feedforward observes (u, w_meas);
 * returns aff_robust_ff_observe's result (1 after an RLS update of the estimator, theta then written into
 * theta_out[0..p-1] if not NULL). */
int ctl_adob_observe(void *self, double u, double w_meas, double *theta_out);

/* The ops table of ctl_adob (name "adaptive-dob"). */
extern const aff_compensator_ops ctl_adob_ops;

#endif
