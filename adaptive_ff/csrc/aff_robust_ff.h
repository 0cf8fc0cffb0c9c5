/* aff_robust_ff.h -- the robust adaptive friction feedforward: the sliding-regime estimator's estimates put into
 * the fixed feedforward after warm-up and plausibility tests, faded in after switch-on.
 *
 * Safety chain (Python class Notes): samples gated by the estimator; rows outside the sliding regime unused;
 * the RLS's covariance bound or directional forgetting; the RLS state itself unconstrained. After warmup RLS
 * updates a lag estimate tau < 0 within its noise (tau >= -max(lag_zero*sd, 2*dt), sd its standard error) is
 * lag 0, a lower one refuses the estimate; then a copy of theta is projected onto the plausible box in the
 * metric of P^-1 (aff_project_box: the box-constrained least-squares estimate), and that copy is used if
 * plausible (finite, J in (J_lo, J_hi), 0 <= tau <= tau_max, sigma >= 0, 0 <= Fc, Fs <= ff_max), with Fc
 * determined (aff_fc_determined) and the two lag estimates (tau and J*tau/J) consistent (else the previous lag
 * is held); the lag in use is the inverse-variance weighted mean of the lag
 * estimates with forgetting (Ljung, System Identification, 2nd ed., 1999, Sec. 11.2) plus lag_margin standard
 * errors (at most lag_margin_max times the lag, at most tau_max: a cautious use of the estimate, Astrom &
 * Wittenmark, Adaptive Control, 2nd ed., 1995, Ch. 7); the output fades in over fade_in and is clipped. An
 * optional provisional start map acts until the first trusted estimate. Python:
 * adaptive_ff.compensation.adaptive_feedforward.RobustAdaptiveFeedforward (mode "adaptive").
 */
#ifndef AFF_ROBUST_FF_H
#define AFF_ROBUST_FF_H
#include "aff_real.h"
#include "aff_compensator.h"
#include "aff_feedforward.h"
#include "aff_sliding.h"
#include "aff_error.h"

/* The provisional start map: eq. 3 with these levels through the lag tau (eq. 1), times gain, in use from the first
 * period until the first trusted estimate (Python: FeedforwardStart). */
typedef struct aff_start_config {
    int on;                   /* 1: a start map; 0 (default): none (the output is 0 until the first estimate) */
    aff_real Fc;              /* Coulomb level (N*m), finite, >= 0; default 0 */
    aff_real Fs;              /* static level (N*m), finite, >= 0; default 0 */
    aff_real sigma;           /* viscous coefficient (N*m*s/rad), finite, >= 0; default 0 */
    aff_real tau;             /* lag (s), finite, >= 0; default 0 */
    aff_real Vs;              /* Stribeck velocity (rad/s), finite, > 0; 0 (default): the estimator's */
    aff_real delta;           /* Stribeck shape factor (1), finite; 0 (default): the estimator's */
    aff_real gain;            /* factor on the start map (-), in (0, 1]; default 1 */
    int at_ref;               /* 1 (default): evaluated at the reference; 0: as the feedforward's at_ref says */
} aff_start_config;

/* The robust adaptive feedforward's settings (Python: RobustAdaptiveFeedforward's arguments of the same names). */
typedef struct aff_robust_ff_config {
    aff_fixed_ff_config ff;   /* the feedforward (its dt the period of the calls) */
    aff_sliding_config est;   /* the online estimator */
    long warmup;              /* RLS updates before switch-on, >= 0; default 200 */
    aff_real fade_in;         /* the output's ramp from 0 to full after switch-on (s), finite, >= 0 (0: a step);
                                 default 1 */
    aff_real J_lo;            /* plausible inertia interval, exclusive (kg*m^2): 0 <= J_lo < J_hi; default 0 */
    aff_real J_hi;            /* its upper end (kg*m^2), INFINITY (default): none */
    aff_real tau_max;         /* largest plausible lag (s), finite, > 0; default 1 */
    aff_real consistency;     /* relative tolerance of the two lag estimates (-), finite, > 0; default 0.5 */
    aff_real lag_margin;      /* standard errors added to the weighted lag (-), finite, >= 0; default 1 */
    aff_real lag_margin_max;  /* largest margin as a fraction of the lag (-), >= 0, INFINITY: no cap; default 0.05 */
    aff_real max_rel_stderr;  /* largest standard error of Fc relative to max(Fc, Fs) (-), > 0, INFINITY: no test;
                                 default 0.05 */
    aff_real lag_memory;      /* memory of the weighted lag (s), finite, >= 0 (0: the latest estimate); default 10 */
    aff_real lag_zero;        /* a lag estimate >= -max(lag_zero*sd, 2*dt) is lag 0 (standard errors), >= 0
                                 (0: none), INFINITY: every negative lag; default 3 */
    int project;              /* 1 (default): the estimate used is theta projected onto the plausible box */
    aff_start_config start;   /* the provisional start map (start.on 0: none) */
} aff_robust_ff_config;

/* Entries of aff_project_box's workspace for p parameters, and for the largest p (AFF_RLS_NMAX). */
#define AFF_PROJECT_WORK(p) ((p) * ((p) + 3))
#define AFF_PROJECT_WORK_NMAX (AFF_RLS_NMAX * (AFF_RLS_NMAX + 3))

typedef struct aff_robust_ff {
    aff_fixed_ff ff;              /* the feedforward; its estimate is the one in use */
    /* configuration */
    long warmup;                  /* RLS updates before switch-on */
    aff_real fade;                /* gain increment per period, dt/fade_in (1 = step) */
    aff_real J_lo;                /* plausible inertia interval, exclusive (kg*m^2) */
    aff_real J_hi;
    aff_real tau_max;             /* largest plausible lag (s) */
    aff_real consistency;         /* relative lag-consistency tolerance */
    aff_real start_gain;          /* factor on the provisional start map, in (0, 1] (1 without a start) */
    int start_at_ref;             /* 1: the start map is evaluated at the reference */
    aff_real lag_margin;          /* standard errors added to the weighted lag */
    aff_real max_rel_stderr;      /* largest standard error of Fc relative to max(Fc, Fs), INFINITY = no test */
    aff_real lag_margin_max;      /* largest margin as a fraction of the lag, INFINITY = no cap */
    aff_real lag_forget;          /* forgetting factor of the weighted lag per update, exp(-Ts/lag_memory), 0 = off */
    aff_real lag_zero;            /* a lag estimate >= -max(lag_zero*sd, 2*dt) is lag 0 (standard errors; 0: none,
                                   * INFINITY: every negative lag) */
    int project;                  /* 1: the estimate used is theta projected onto the plausible box (P^-1 metric) */
    /* state */
    aff_real gain;                /* fade-in gain of the output */
    int provisional;              /* 1 while the start map is in use */
    int held;                     /* 1 if the lag in use was held from the previous estimate */
    int64_t n_implausible;        /* estimates after warm-up that failed the tests */
    int64_t n_lag_held;           /* estimates used with the previous lag */
    int64_t n_undetermined;       /* plausible estimates not used because Fc was not determined */
    int64_t n_lag_zero;           /* estimates whose negative lag estimate was taken as lag 0 */
    int64_t n_boxed;              /* estimates the projection moved onto the box */
    aff_real lag_mean;            /* weighted mean of the lag estimates (s) */
    aff_real lag_info;            /* its total weight (1/s^2) */
    aff_real theta_used[AFF_RLS_NMAX]; /* the estimate in use as a theta (the projected copy; NaN before) */
    aff_real work[AFF_PROJECT_WORK_NMAX]; /* scratch of aff_project_box (not state: off the stack of a drive) */
    aff_sliding est;              /* the online estimator */
} aff_robust_ff;

/* The start map's defaults: off; gain 1, at the reference, the estimator's Vs and delta (FeedforwardStart's). */
aff_start_config aff_start_default_config(void);

/* The robust feedforward's defaults (RobustAdaptiveFeedforward's: warmup 200, fade_in 1 s, J in (0, inf), tau_max
 * 1 s, consistency 0.5, lag_margin 1, lag_margin_max 0.05, max_rel_stderr 0.05, lag_memory 10 s, lag_zero 3,
 * project 1, no start map) with the feedforward's and the estimator's defaults (set est.Vs and est.delta). */
aff_robust_ff_config aff_robust_ff_default_config(void);

/* Configure r from *cfg and clear its state (gain 1, no estimate in use, theta_used NaN): the feedforward
 * (aff_fixed_ff_init) and the estimator (aff_sliding_init), fade = dt/fade_in (1 for fade_in 0), lag_forget =
 * exp(-Ts/lag_memory) (Ts = m*Tc of the estimator; 0 for lag_memory 0); with start.on the start map put into use
 * (the feedforward's estimate, provisional = 1, its Vs and delta the estimator's where 0). Returns AFF_OK, or
 * AFF_ERR_NULL, an AFF_ERR_ROBUST_FF_ or AFF_ERR_START_ code, or a code of the parts' (r untouched). Python:
 * RobustAdaptiveFeedforward.__init__. */
aff_error aff_robust_ff_init(aff_robust_ff *r, const aff_robust_ff_config *cfg);

/* The checks of aff_robust_ff_init alone: AFF_OK or the code it would return for *cfg. */
aff_error aff_robust_ff_check_config(const aff_robust_ff_config *cfg);

/* Projection of theta onto the box lo <= x <= hi in the metric of P^-1: x minimises (x - theta)' P^-1 (x - theta)
 * subject to the bounds (P the covariance of the RLS cov, p its number of parameters, its entries by aff_rls_P;
 * lo[i] = -INFINITY / hi[i] = INFINITY for a free parameter; x may alias theta). With the RLS's own theta this is
 * the least-squares estimate under the
 * bounds (the cost of the RLS data is that quadratic form plus a constant: the constrained least-squares step,
 * Goodwin & Sin, Adaptive Filtering, Prediction and Control, 1984, Sec. 3.3.7; Ljung, System Identification, 2nd
 * ed., 1999, Sec. 11.2). Solved exactly by the primal active-set method for convex QP (Nocedal & Wright, Numerical
 * Optimization, 2nd ed., 2006, Alg. 16.3): with the working set W held at its bounds b_W the minimiser is the
 * conditional mean x = theta + P[:, W] mu, P[W, W] mu = b_W - theta_W (Cholesky), and mu is the bound's multiplier
 * (>= 0 at a lower, <= 0 at an upper bound). Work: at most 8*p + 8 iterations of O(p^3). Returns the number of
 * bounds active at x (0: x = theta), or -1 (x undefined) if p is outside 1..AFF_RLS_NMAX, a bound pair is empty (or lo +inf, hi -inf),
 * a P[W, W] is not numerically positive definite, or the iterations run out. work: scratch of at least
 * AFF_PROJECT_WORK(p) entries (the caller's, so that a drive's stack stays small). Python:
 * adaptive_ff.compensation.adaptive_feedforward.project_box. */
int aff_project_box(long p, const aff_rls *cov, const aff_real *theta, const aff_real *lo, const aff_real *hi,
                    aff_real *x, aff_real *work);

/* The estimator's current theta through the tests of the safety chain (what aff_robust_ff_observe does after an
 * RLS update past warm-up): the lag-zero test, the projection, range checks, determinacy of Fc, lag consistency;
 * an estimate that passes is put into the feedforward (theta_used, the lag in use). Returns 1 if the estimate is
 * in use (2 with the previous lag held), 0 if refused (counted). Python: RobustAdaptiveFeedforward.decide. */
int aff_robust_ff_decide(aff_robust_ff *r);

/* The determinacy test of Fc: 1 if max_rel_stderr is INFINITY, else 1 iff sqrt(max(e2*P_FcFc, 0)) <=
 * max_rel_stderr*max(eFc, eFs) and P_FcFc <= 0.01*P_prior (the data have determined Fc; e2 the noise variance,
 * N*m^2; P_prior aff_rls_prior_variance). Python: adaptive_feedforward.fc_determined. */
int aff_fc_determined(aff_real max_rel_stderr, aff_real e2, aff_real P_FcFc, aff_real P_prior, aff_real eFc,
                      aff_real eFs);

/* The plausibility test of an estimate (J kg*m^2, tau s, J_alt kg*m^2, Fc, Fs N*m, sigma N*m*s/rad): the
 * ranges, then the lag consistency against the estimator's covariance. Python: RobustAdaptiveFeedforward.plausible. */
int aff_robust_ff_plausible(const aff_robust_ff *r, aff_real J, aff_real tau, aff_real J_alt, aff_real Fc,
                            aff_real Fs, aff_real sigma);

/* 1 if the feedforward acts on an estimate of its own estimator (not before switch-on, not while the provisional
 * start map acts), else 0: the condition the composites pass to the switch-in as "acting". */
int aff_robust_ff_estimate_in_use(const aff_robust_ff *r);

/* Take the lag estimate tau (s) with standard error sd (s) into the weighted mean and return the mean:
 * lag_mean += (w/info)*(tau - lag_mean), info = lag_forget*info + w, w = 1/sd^2 (the first: tau itself); tau
 * itself, the mean unchanged, where lag_forget is 0 or sd is not > 0. Python: adaptive_feedforward.lag_weighted. */
aff_real aff_robust_ff_lag_weighted(aff_robust_ff *r, aff_real tau, aff_real sd);

/* Compensator interface (aff_compensator.h), self an aff_robust_ff: the loop model's period; 0 before
 * switch-on; the start map times start_gain during the provisional start; else the feedforward, faded in.
 * Python: RobustAdaptiveFeedforward.compensate. */
aff_real aff_robust_ff_compensate(void *self, aff_real w_ctrl, aff_real w_meas, aff_real w_ref);

/* Compensator interface: the sign observer takes u, the estimator the sample (u N*m, w_meas rad/s), then the
 * tests and the estimate in use. Returns 1 after an RLS update (theta written into theta_out[0..p-1] if not
 * NULL), else 0. Python: RobustAdaptiveFeedforward.observe. */
int aff_robust_ff_observe(void *self, aff_real u, aff_real w_meas, aff_real *theta_out);

/* Compensator interface (aff_compensator.h, optional rest_lag), self an aff_robust_ff: the feedforward's lag filter
 * gain in use, alpha = 1 - exp(-Tc/tau) of the lag in use (1: no lag; aff_fixed_ff_set_estimate). */
aff_real aff_robust_ff_rest_lag(void *self);

/* The ops table of the robust adaptive feedforward (name "adaptive"). */
extern const aff_compensator_ops aff_robust_ff_ops;

#endif
