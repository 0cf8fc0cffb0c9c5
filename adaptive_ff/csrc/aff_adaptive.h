/* aff_adaptive.h -- mode "adaptive" as one component: the robust adaptive feedforward, the residual observer it
 * switches in (with the switch-in's trial), and the feedforward supervisor with its rest rule.
 *
 * Per controller period Tc, in this order (the order of the package's closed-loop engine, ctl_engine.h):
 *   u_c  = aff_robust_ff_compensate(ff, w_ctrl, w_meas, w_ref)           the feedforward (aff_robust_ff.h)
 *   u_c  = aff_residual_compensate(res, u_c, ...)                        + the residual observer's share
 *                                                                          (aff_residual.h; if use_residual)
 *   aff_supervisor_set_rest_lag(sup, aff_robust_ff_rest_lag(ff))         withdrawn at rest through the
 *                                                                          feedforward's lag in use
 *   out  = aff_supervisor_apply(sup, u_c, w_ref)                         0 while backed off; at rest the
 *                                                                          withdrawn torque (aff_supervisor.h;
 *                                                                          if use_supervisor)
 *          at rest: aff_residual_at_rest(res)                            the observer told its output was
 *                                                                          not applied
 *   transfer = sup.transfer                                              what the loop adds to its PI's
 *                                                                          integrator this period (bumpless
 *                                                                          transfer; 0 unless the supervisor
 *                                                                          switched)
 *   ... the loop applies u = PI(w_ref - w_ctrl) + out, saturated ...
 *   aff_residual_observe(res, u, w_meas); aff_robust_ff_observe(ff, u, w_meas); aff_supervisor_observe(sup, u,
 *   w_ctrl)
 * With use_residual = 0 and use_supervisor = 0 the component is the feedforward alone, bit for bit (the export's
 * --feedforward-only). The same struct and functions run in the package's engine (its compensator table,
 * aff_adaptive_ops) and in a drive (aff_drive.h): one implementation. No allocation; bounded work per call.
 * Python: controllers.peers.adaptive_dob.AdaptiveCompensator.
 */
#ifndef AFF_ADAPTIVE_H
#define AFF_ADAPTIVE_H
#include "aff_real.h"
#include "aff_compensator.h"
#include "aff_robust_ff.h"
#include "aff_residual.h"
#include "aff_supervisor.h"
#include "aff_error.h"

/* Mode "adaptive"'s settings: which parts act and each part's (Python: AdaptiveCompensator's parts). */
typedef struct aff_adaptive_config {
    int use_residual;         /* 1 (default): the residual observer res acts; 0: the feedforward alone */
    int use_supervisor;       /* 1 (default): the supervisor sup judges the compensation; 0: none */
    aff_robust_ff_config ff;  /* the adaptive feedforward with its estimator */
    aff_residual_config res;  /* the residual observer with its switch-in (read if use_residual; its u_max always) */
    aff_supervisor_config sup; /* the supervisor (read if use_supervisor) */
} aff_adaptive_config;

/* Configuration (which parts act), then the parts and the state. */
typedef struct aff_adaptive {
    int use_residual;     /* 1: the residual observer res acts (with its switch-in if res.use_switch_in) */
    int use_supervisor;   /* 1: the supervisor sup judges the compensation */
    aff_residual res;     /* the residual observer, its switch-in and the output's bound (valid if use_residual) */
    aff_robust_ff ff;     /* the adaptive feedforward with its estimator */
    aff_supervisor sup;   /* the feedforward supervisor (valid if use_supervisor) */
    aff_real w_ctrl;      /* the controller's velocity of the last compensate (rad/s), for the supervisor */
    aff_real transfer;    /* the torque to add to the loop's PI integrator in this period (N*m), 0 unless the
                             supervisor switched the compensation on or off */
} aff_adaptive;

/* Mode "adaptive"'s defaults: all parts acting, each with its defaults (set the joint's: ff.est.Vs, ff.est.delta,
 * res.dob.J_n, res.switch_in.J_n, .Kp, .Ki, sup.J_n, sup.omega). */
aff_adaptive_config aff_adaptive_default_config(void);

/* Configure a from *cfg and clear its state: the feedforward (aff_robust_ff_init), with use_residual the residual
 * observer (aff_residual_init; else res cleared but its u_max), with use_supervisor the supervisor
 * (aff_supervisor_init; else sup cleared). Returns AFF_OK, or AFF_ERR_NULL, AFF_ERR_ADAPTIVE_USE_RESIDUAL,
 * _USE_SUPERVISOR or a code of the parts' (a untouched). Python: AdaptiveCompensator.__init__. */
aff_error aff_adaptive_init(aff_adaptive *a, const aff_adaptive_config *cfg);

/* The checks of aff_adaptive_init alone: AFF_OK or the code it would return for *cfg. */
aff_error aff_adaptive_check_config(const aff_adaptive_config *cfg);

/* Compensator interface (aff_compensator.h), self an aff_adaptive: this period's compensation (N*m) for the
 * controller's velocity w_ctrl, the raw sample w_meas and the reference w_ref (rad/s), in the order of the header
 * comment; sets a->transfer. */
aff_real aff_adaptive_compensate(void *self, aff_real w_ctrl, aff_real w_meas, aff_real w_ref);

/* Compensator interface: the residual observer, the feedforward and the supervisor observe the applied torque u
 * (N*m) and w_meas (rad/s; the supervisor the w_ctrl of the last compensate). Returns aff_robust_ff_observe's
 * result (1 after an RLS update, theta then written into theta_out[0..p-1] if not NULL). */
int aff_adaptive_observe(void *self, aff_real u, aff_real w_meas, aff_real *theta_out);

/* Compensator interface: a->transfer, the torque (N*m) the loop adds to its PI's integrator in the period of the
 * last compensate (the supervisor's bumpless transfer, aff_supervisor.h). */
aff_real aff_adaptive_transfer(void *self);

/* The ops table of aff_adaptive (name "adaptive"). */
extern const aff_compensator_ops aff_adaptive_ops;

#endif
