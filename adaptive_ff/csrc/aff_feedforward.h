/* aff_feedforward.h -- the fixed friction feedforward (a friction estimate fed forward through its lag) and the
 * projection of an estimate onto the physically admissible set.
 *
 * Per period: the static map F_hat(w) (eq. 3 with the estimate in use, no offset, optional linear sign ramp of
 * half-width sign_width), evaluated at the measurement (with stick detection: after stick_samples consecutive
 * samples inside +-stick_band the loop model's velocity or the reference is used; inside the band the sign
 * observer's sign, if any) or at the reference; then the lag of eq. 1, discretised exactly for a held input,
 * u_ff += alpha*(F_hat - u_ff) with alpha = 1 - exp(-dt/tau); then the clip to +-ff_max. A non-finite or
 * implausible velocity (|w| > w_max) or a non-finite map leaves everything but n_rejected unchanged and returns
 * the held output. Python: adaptive_ff.compensation.feedforward.FrictionFeedforward (mode "fixed"); the
 * adaptive feedforwards (aff_robust_ff.h, aff_eq4_ff.h) embed this struct.
 */
#ifndef AFF_FEEDFORWARD_H
#define AFF_FEEDFORWARD_H
#include "aff_real.h"
#include "aff_compensator.h"
#include "aff_velocity_input.h"
#include "aff_regression.h"
#include "aff_error.h"

/* The fixed feedforward's settings (the estimate is put into use after init: aff_fixed_ff_set_estimate). */
typedef struct aff_fixed_ff_config {
    aff_real dt;              /* call period (s), finite, > 0; default 0.001 */
    int lag;                  /* 1 (default): filter the map through the estimated lag tau (eq. 1); 0: no filter */
    aff_real ff_max;          /* bound on |feedforward| (N*m), >= 0; INFINITY (default): none */
    aff_real sign_width;      /* half-width of the sign ramp (rad/s), finite, >= 0; 0 (default): sgn(w) */
    aff_real stick_band;      /* stick-detection band (rad/s), finite, >= 0; 0 (default): off */
    long stick_samples;       /* in-band samples that declare sticking, >= 1; default 10 */
    int at_ref;               /* 1: the map at the reference; 0 (default): at the measurement (ff_input) */
    aff_real w_max;           /* largest plausible speed (rad/s), > 0; INFINITY (default): none */
    int use_loop_model;       /* 1: loop_model is the stick fallback; 0 (default): the reference is */
    aff_loop_model_config loop_model;       /* the loop model (read if use_loop_model) */
    int use_sign_observer;    /* 1: sign_observer signs the map inside the stick band; 0 (default): none */
    aff_sign_observer_config sign_observer; /* the sign observer (read if use_sign_observer) */
} aff_fixed_ff_config;

typedef struct aff_fixed_ff {
    /* configuration */
    aff_real dt;              /* call period (s), > 0 */
    int lag;                  /* 1: filter through the estimated lag tau (eq. 1) */
    aff_real ff_max;          /* bound on |feedforward| (N*m), INFINITY = none */
    aff_real sign_width;      /* half-width of the sign ramp (rad/s), 0 = sgn(w) */
    aff_real stick_band;      /* stick-detection band (rad/s), 0 = off */
    long stick_samples;       /* in-band samples that declare sticking, >= 1 */
    int at_ref;               /* 1: compensate evaluates the map at the reference, 0: at the measurement */
    aff_real w_max;           /* largest plausible speed (rad/s), INFINITY = none */
    aff_loop_model lm;        /* the loop model (lm.on == 0: none; the reference is used while stuck) */
    aff_sign_observer ob;     /* the sign observer (ob.on == 0: none) */
    /* the estimate in use (eq. 3, eq. 1) */
    int has;                  /* 1 once an estimate is in use (else the output is 0) */
    aff_real Fc;              /* Coulomb level (N*m) */
    aff_real dF;              /* Fs - Fc (N*m) */
    aff_real Vs;              /* Stribeck velocity (rad/s) */
    aff_real delta;           /* Stribeck shape factor (1) */
    aff_real sigma;           /* viscous coefficient (N*m*s/rad) */
    int has_vs;               /* 1: the Stribeck term is used; 0: the Coulomb level only */
    aff_real tau;             /* lag (s) */
    aff_real alpha;           /* lag filter gain 1 - exp(-dt/tau), 1 = no filter */
    /* state */
    aff_real u_ff;            /* filter output before the clip (N*m) */
    int64_t n_in_band;        /* consecutive samples inside the stick band */
    int64_t n_rejected;       /* calls whose input was rejected (the output was held) */
    aff_real u_out;           /* the compensator's output of this period (N*m), for the sign observer */
} aff_fixed_ff;

/* The fixed feedforward's defaults (FrictionFeedforward's: dt 0.001 s, with the lag, no bound, sgn(w), no stick
 * detection, 10 samples, at the measurement, no speed bound, no loop model, no sign observer). */
aff_fixed_ff_config aff_fixed_ff_default_config(void);

/* Configure f from *cfg and clear its state (no estimate: output 0, alpha = 1); the loop model and the sign
 * observer (if used) at the period dt (aff_loop_model_init, aff_sign_observer_init). Returns AFF_OK, or AFF_ERR_NULL,
 * AFF_ERR_FIXED_FF_DT, _LAG, _FF_MAX, _SIGN_WIDTH, _STICK_BAND, _STICK_SAMPLES, _AT_REF, _W_MAX, _USE_LOOP_MODEL,
 * _USE_SIGN_OBSERVER, or a code of the loop model's or the sign observer's (f untouched). Python:
 * FrictionFeedforward.__init__. */
aff_error aff_fixed_ff_init(aff_fixed_ff *f, const aff_fixed_ff_config *cfg);

/* The checks of aff_fixed_ff_init alone: AFF_OK or the code it would return for *cfg. */
aff_error aff_fixed_ff_check_config(const aff_fixed_ff_config *cfg);

/* Put an estimate into use: levels Fc, Fs (N*m), Vs (rad/s), delta, sigma (N*m*s/rad), lag tau (s); has_vs 0
 * drops the Stribeck term. alpha = 1 - exp(-dt/tau) if the feedforward filters through the lag and tau > 0,
 * else 1. Python: FrictionFeedforward(estimate) (was ff_set_estimate). */
void aff_fixed_ff_set_estimate(aff_fixed_ff *f, aff_real Fc, aff_real Fs, aff_real Vs, aff_real delta,
                               aff_real sigma, aff_real tau, int has_vs);

/* The static estimate F_hat(w) (N*m) at w (rad/s): eq. 3 at |w| without the viscous term, with the sign
 * (or the ramp w/sign_width for |w| < sign_width), plus sigma*w; 0 at w == 0 or without an estimate.
 * Python: FrictionFeedforward.static (was ff_static). */
aff_real aff_fixed_ff_static(const aff_fixed_ff *f, aff_real w);

/* One period at velocity w (rad/s) with stick detection against w_ref when has_ref (see the header comment);
 * returns the clipped feedforward (N*m). Python: FrictionFeedforward.step (was ff_step). */
aff_real aff_fixed_ff_step(aff_fixed_ff *f, aff_real w, aff_real w_ref, int has_ref);

/* The period's feedforward at the reference (at_ref) or at the measurement w_ctrl (with the sign observer's sign
 * inside the stick band) with stick detection against w_stuck (the loop model's velocity, or the reference).
 * Was ff_at. */
aff_real aff_fixed_ff_at(aff_fixed_ff *f, aff_real w_ctrl, aff_real w_stuck, aff_real w_ref);

/* The period's output of a provisional start map (the estimate in f): at the reference w_ref (at_ref; the sign
 * observer still follows w_ctrl) or as aff_fixed_ff_at with w_stuck, times gain (N*m). The start of both adaptive
 * feedforwards (aff_robust_ff_config.start, aff_eq4_ff_start) until their first estimate. */
aff_real aff_fixed_ff_start_output(aff_fixed_ff *f, aff_real w_ctrl, aff_real w_stuck, aff_real w_ref, int at_ref,
                                   aff_real gain);

/* Compensator interface (aff_compensator.h), self an aff_fixed_ff: the loop model's period, then
 * aff_fixed_ff_at; the output is recorded in u_out. Python: FrictionFeedforward.compensate. */
aff_real aff_fixed_ff_compensate(void *self, aff_real w_ctrl, aff_real w_meas, aff_real w_ref);

/* Compensator interface: nothing to learn (returns 0, theta_out untouched); the sign observer takes the applied
 * torque u (N*m). Python: FrictionFeedforward.observe. */
int aff_fixed_ff_observe(void *self, aff_real u, aff_real w_meas, aff_real *theta_out);

/* The ops table of the fixed feedforward (name "fixed"). */
extern const aff_compensator_ops aff_fixed_ff_ops;

/* Project a raw estimate e (inverse map of eq. 4) onto the admissible set: returns 0 (e untouched) if a value
 * is non-finite, J <= 0 or Fc or Fs exceeds F_max (N*m); else 1 with tau clipped to [0, tau_max] (s) and sigma,
 * Fc, Fs to >= 0 (Ioannou & Sun, Robust Adaptive Control, 1996, Sec. 4.11.3). Python:
 * feedforward.project_estimate / project_levels. */
int aff_project_levels(aff_physical *e, aff_real tau_max, aff_real F_max);

#endif
