/* aff_drive.h -- the adaptive friction feedforward for a drive's velocity loop: four calls.
 *
 * The feedforward of the package's "adaptive" mode (aff_robust_ff: the sliding-regime estimator's estimates
 * fed forward through the estimated lag, after warm-up and plausibility tests), behind the calls a drive's
 * periodic task makes. It is the feedforward alone: the residual observer that mode "adaptive" switches in
 * (controllers/csrc/ctl_adob.h) and the supervisor that backs the compensation off (aff_supervisor.h) run in
 * the package's engine around it, not here. Per controller period Tc, in this order (docs/your_loop.md):
 *   u_ff = aff_step(&c, w, w_ref);      feedforward torque of this period (N*m), 0 until switch-on
 *   u    = your controller(w_ref - w) + u_ff, saturated: the torque applied in this period (N*m)
 *   aff_observe(&c, u, w);              learn from the applied torque and the measured velocity
 * with w the raw velocity sample (rad/s; NaN, inf or a spike is rejected by the compensator's own gates) and
 * w_ref the velocity reference (rad/s). The configured struct comes from the package (its Python constructors
 * validate the settings and compute the derived fields): `adaptive-ff export-c` writes it as AFF_INITIAL.
 * No allocation, no I/O, no global state; every call does a bounded amount of work (one RLS update of at most
 * AFF_RLS_NMAX parameters every Ts/Tc calls at most). Python: the same functions through cffi
 * (adaptive_ff._caff), RobustAdaptiveFeedforward.compensate / observe.
 */
#ifndef AFF_DRIVE_H
#define AFF_DRIVE_H
#include "aff_real.h"
#include "aff_robust_ff.h"

/* The compensator a drive holds (a few kB: give it static storage on a small MCU). */
typedef struct aff {
    aff_robust_ff ff;  /* the robust adaptive feedforward (aff_robust_ff.h), configuration and state */
} aff;

/* Start c from the configured struct *initial (copied; e.g. &AFF_INITIAL of an export, or the cdata of a
 * RobustAdaptiveFeedforward before it observed anything). Re-initialising restarts the learning. */
void aff_init(aff *c, const aff_robust_ff *initial);

/* The feedforward torque (N*m) of this period for the raw measured velocity w_meas (rad/s) and the reference
 * w_ref (rad/s), the measurement used as the controller's (w_ctrl = w_meas): aff_step_gated(c, w_meas, w_meas,
 * w_ref). 0 before switch-on; bounded by +-ff_max; a non-finite or implausible w_meas holds the last output.
 * Python: RobustAdaptiveFeedforward.compensate. */
aff_real aff_step(aff *c, aff_real w_meas, aff_real w_ref);

/* aff_step with the loop's own gated measurement w_ctrl (rad/s, e.g. after the drive's sensor plausibility
 * check) beside the raw sample w_meas: the compensator interface of aff_compensator.h, as the package's
 * closed-loop engine calls it. Source: aff_robust_ff_compensate. */
aff_real aff_step_gated(aff *c, aff_real w_ctrl, aff_real w_meas, aff_real w_ref);

/* Learn from the torque u applied in this period (N*m, after saturation) and the velocity w_meas measured at its
 * start (rad/s, the raw sample given to aff_step). Returns 1 if the estimator accepted the sample, 0 if its
 * gates rejected it (non-finite, out of range, an outlier: only counters change). Every Ts/Tc accepted samples
 * in the sliding regime the RLS updates and, after warm-up and the plausibility tests, the estimate in use.
 * Python: RobustAdaptiveFeedforward.observe. Source: aff_robust_ff_observe. */
int aff_observe(aff *c, aff_real u, aff_real w_meas);

/* 1 once the feedforward acts (a plausible estimate or the provisional start map is in use), else 0.
 * Python: RobustAdaptiveFeedforward.active. */
int aff_active(const aff *c);

/* The friction estimate in use (eq. 3 levels Fc, Fs in N*m, viscous sigma in N*m*s/rad, lag tau in s, the lag
 * with its margin): 1 and the values written (each pointer may be NULL) once an estimate of the estimator is in
 * use; 0 and nothing written before that (also while the provisional start map acts). For a drive's telemetry.
 * Python: RobustAdaptiveFeedforward.estimate (Fs here is Fc + (Fs - Fc), as the map holds it). */
int aff_estimate(const aff *c, aff_real *Fc, aff_real *Fs, aff_real *sigma, aff_real *tau);

/* RLS updates of the estimator so far. Python: SlidingFrictionEstimator.n_updates. */
long aff_n_updates(const aff *c);

/* Samples the estimator rejected so far. Python: RobustAdaptiveFeedforward.n_rejected. */
long aff_n_rejected(const aff *c);

/* Replay a log of n periods through c: for k < n, uff[k] = aff_step(c, w[k], w_ref[k]) and then
 * aff_observe(c, u[k], w[k]). u (N*m), w, w_ref (rad/s), uff (N*m): arrays of n doubles (converted to aff_real
 * in a float build). For testing an export against the package and for offline runs on recorded logs. */
void aff_replay(aff *c, const double *u, const double *w, const double *w_ref, double *uff, long n);

#endif
