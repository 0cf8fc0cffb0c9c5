/* aff_eq4_ff.h -- the paper's eq. 4 adaptive feedforward: RLS (eqs. 10-13) or recursive IV on the (u, w) stream
 * sampled at Ts drives the fixed feedforward.
 *
 * At each sample k (every m-th controller period): phi(k) of eq. 4 (aff_regression.h) from the stored u(k-1),
 * w(k-1), w(k-2); an update of the estimator with the output w(k); after warmup updates theta is mapped to physical
 * parameters (inverse map of eq. 4), projected (aff_project_levels) and, if admissible, put into the feedforward.
 * Samples pass a torque and a velocity range gate first. Estimators:
 *  - iv == 0: the RLS of eqs. 10-13 (aff_rls.h), the paper's estimator: biased in the closed loop (docs/theory.md);
 *  - iv == 1: recursive IV (aff_ivrls.h) with the instruments z(k) = phi(k) of eq. 4 evaluated at u(k), u(k-1),
 *    w(k-3), w(k-4): under white measurement noise n (per controller period) the equation error of eq. 4 is
 *    n(k) - a1 n(k-1) + a2 n(k-2) plus the noise in g, h of w(k-1), so w(k-1), w(k-2), g, h are correlated with it
 *    and w(k-3), w(k-4) are not; u(k), u(k-1) react to the noise of samples k-1, k-2 only through one period of
 *    each interval and the PI's integral, negligible against the torque itself, so they are their own instruments. E[z(k) e(k)] = 0 up to that leak (Soderstrom & Stoica, System
 *    Identification, 1989, Ch. 8: delayed outputs as instruments for an equation error of finite moving-average
 *    order; docs/theory.md, "Instrumental variables for eq. 4 in the closed loop"). In the compensator interface
 *    the torque u(k) of a sample is then the mean of the m torques applied since the previous sample (the input
 *    that moved the joint over the interval; the last one alone leads it by Ts/2 and biases tau by about -Ts/2).
 * With w_band > 0 (the sliding-regime gate) only samples with |w(k)|, |w(k-1)|, |w(k-2)| > w_band of one sign update
 * the estimator: eq. 4 describes sliding (the paper's Sec. II-B); stick and creep rows bias it whatever the estimator.
 * Determinacy test (opt-in, with iv; aff_eq4_ff_require_determined): an estimate is used only if the standard error
 * of its static map is within a bound of its level.
 * Provisional start (aff_eq4_ff_start): a prior map (the Stribeck pre-fit's, Sec. V-C, through a lag) acts from the
 * first period, times its gain, until the first estimate is put into use, which then replaces it at once (this
 * feedforward has no fade-in); the same start as the robust feedforward's (aff_start_config, the output by
 * aff_fixed_ff_start_output). Without it the feedforward is 0 until then.
 * The first prototype of the paper's future work, kept as a baseline (iv = 0, w_band = 0, no start).
 * Python: adaptive_ff.compensation.eq4_feedforward.AdaptiveFrictionFeedforward (mode "adaptive").
 */
#ifndef AFF_EQ4_FF_H
#define AFF_EQ4_FF_H
#include "aff_real.h"
#include "aff_compensator.h"
#include "aff_feedforward.h"
#include "aff_gate.h"
#include "aff_regression.h"
#include "aff_rls.h"
#include "aff_ivrls.h"

typedef struct aff_eq4_ff {
    aff_fixed_ff ff;              /* the feedforward (the paper's prototype: no stick detection or sign observer) */
    /* configuration */
    long m;                       /* controller periods per sample, Ts/dt */
    aff_real Ts;                  /* sample time of the stream (s) */
    long warmup;                  /* RLS updates before an estimate is used */
    aff_real tau_max;             /* upper projection bound of tau (s) */
    aff_real F_max;               /* largest admissible Fc, Fs (N*m) */
    aff_real Vs;                  /* Stribeck velocity of the structure (rad/s; 1 without the Stribeck term) */
    aff_real delta;               /* Stribeck shape factor (1 without the Stribeck term) */
    int lag;                      /* the structure of eq. 4 (aff_regression.h) */
    int stribeck;
    int offset;
    aff_range_gate u_range;       /* range gate of the torque samples */
    aff_range_gate w_range;       /* range gate of the velocity samples */
    /* state */
    long due;                     /* periods to the next sample (m at start) */
    aff_real u_prev;              /* torque applied in the previous period (N*m) */
    int sampled;                  /* 1 if this period took a sample */
    int has_past;                 /* 1 once u(k-1), w(k-1), w(k-2) are filled */
    aff_real u1;                  /* u(k-1) (N*m) */
    aff_real w1;                  /* w(k-1) (rad/s) */
    aff_real w2;                  /* w(k-2) (rad/s) */
    long n_rejected;              /* samples refused (range gates, RLS) */
    long n_implausible;           /* estimates the projection refused */
    int has_estimate;             /* 1 once an estimate is in use */
    aff_physical est;             /* the estimate in use (projected) */
    aff_real phi[AFF_RLS_NMAX];   /* regressor of the last sample */
    aff_rls rls;                  /* the estimator of theta with iv == 0 (p = the structure's n_params) */
    int iv;                       /* 1: estimate with ivrls and the instruments z(k) = phi(k-2); 0: with rls */
    aff_real w_band;              /* sliding-regime gate (rad/s): only |w| > w_band of one sign updates, 0 = none */
    long n_past;                  /* samples held in the past, 0..5 */
    aff_real u2;                  /* u(k-2) (N*m) */
    aff_real u3;                  /* u(k-3) (N*m) */
    aff_real w3;                  /* w(k-3) (rad/s) */
    aff_real w4;                  /* w(k-4) (rad/s) */
    long n_gated;                 /* samples the sliding-regime gate kept from the estimator */
    aff_real z[AFF_RLS_NMAX];     /* instruments of the last IV update */
    aff_real u_sum;               /* sum of the torques applied since the last sample (N*m) */
    aff_ivrls ivrls;              /* the estimator of theta with iv == 1 (p = the structure's n_params) */
    int provisional;              /* 1 while the start map is in use (aff_eq4_ff_start), until the first estimate */
    int start_at_ref;             /* 1: the start map is evaluated at the reference */
    aff_real start_gain;          /* factor on the start map, in (0, 1] (1 without a start) */
    aff_real map_rel_stderr;      /* bound on the map's standard error relative to max(Fc, Fs) of an estimate
                                   * put into use (aff_eq4_ff_require_determined), INFINITY = no test */
    aff_real e2;                  /* running mean of e^2/(1 + phi'P z) of the IV updates (rad^2/s^2) */
    aff_real Szz[AFF_RLS_NMAX * AFF_RLS_NMAX]; /* sum of lam^(N-k) z(k) z(k)' of the IV updates (p*p, row-major) */
    aff_real w_max;               /* largest |w(k)| of the IV updates (rad/s) */
    long n_undetermined;          /* admissible estimates not put into use: the map not determined */
} aff_eq4_ff;

/* The settings of an aff_eq4_ff (besides its regression structure and its parts' structs), with their defaults
 * (aff_eq4_ff_default_config: the paper's prototype, the RLS on every sample, no start) and their ranges
 * (aff_eq4_ff_check_config). Python: adaptive_ff.compensation.eq4_feedforward.AdaptiveFrictionFeedforwardConfig. */
typedef struct aff_eq4_ff_config {
    aff_real Ts;              /* sample time of the (u, w) stream (s), finite, > 0, a multiple of ff.dt; default 0.01 */
    aff_real lam;             /* forgetting factor of the RLS (or IV) per sample (-), in (0, 1]; default 0.995 */
    aff_real P0;              /* initial covariance scale of the estimator, finite, > 0; default 1e4 */
    long warmup;              /* accepted samples before the feedforward is switched on, >= 0; default 300 */
    aff_real tau_max;         /* upper projection bound of tau (s), finite, > 0; default 1 */
    int iv;                   /* 1: recursive IV with delayed instruments; 0 (default): the paper's RLS */
    aff_real w_band;          /* sliding-regime gate (rad/s), finite, >= 0; 0 (default): every sample */
    aff_real map_rel_stderr;  /* determinacy test of the estimates (-), > 0 (a finite one needs iv), INFINITY
                                 (default): none */
    aff_fixed_ff_config ff;   /* the feedforward (its dt the period of the calls) */
} aff_eq4_ff_config;

/* The defaults of aff_eq4_ff_config (field comments). */
aff_eq4_ff_config aff_eq4_ff_default_config(void);

/* AFF_OK, or the code of the first field of *cfg out of its range (the feedforward's by aff_fixed_ff_check_config). */
aff_error aff_eq4_ff_check_config(const aff_eq4_ff_config *cfg);

/* Configure e from the configured parts ff (aff_fixed_ff_init), u_range, w_range (aff_range_gate_init), rls
 * (aff_rls_init with p = 3 + 2*lag + stribeck + offset) and ivrls (aff_ivrls_init, same p; read only with iv,
 * may be NULL without), copied by value, the estimator (iv) and the sliding-regime gate w_band (rad/s, >= 0), and
 * clear its state (due = m). Returns 0, or -1 (e untouched) if rls->p (with iv ivrls->p) does not fit the
 * structure. Python: AdaptiveFrictionFeedforward.__init__. */
int aff_eq4_ff_init(aff_eq4_ff *e, const aff_fixed_ff *ff, long m, aff_real Ts, long warmup, aff_real tau_max,
                    aff_real F_max, aff_real Vs, aff_real delta, int lag, int stribeck, int offset,
                    const aff_range_gate *u_range, const aff_range_gate *w_range, const aff_rls *rls, int iv,
                    aff_real w_band, const aff_ivrls *ivrls);

/* Put the provisional start map into use until the first estimate (header comment): levels Fc, Fs (N*m), Vs
 * (rad/s), delta, sigma (N*m*s/rad), lag tau (s) of eq. 3 through eq. 1, times gain (in (0, 1]), evaluated at the
 * reference (at_ref) or as the feedforward's input says. Returns 0, or -1 (e untouched) for a level, sigma or tau
 * not finite and >= 0, Vs not finite and > 0, delta not finite, or gain outside (0, 1]. Python:
 * AdaptiveFrictionFeedforward(start=FeedforwardStart(...)). */
int aff_eq4_ff_start(aff_eq4_ff *e, aff_real Fc, aff_real Fs, aff_real Vs, aff_real delta, aff_real sigma,
                     aff_real tau, aff_real gain, int at_ref);

/* The determinacy test of the estimates (the counterpart of the sliding estimator's "Fc determined",
 * aff_fc_determined), with iv only: an admissible estimate is put into use (the first one replacing the start map,
 * if any; a later one the estimate in use) only if, at w_max, the largest |w| of the IV updates, and, with the
 * Stribeck term and Vs < w_max, at Vs, the standard error of its static map F(w) (aff_eq4_static_gradient) is at
 * most map_rel_stderr times max(Fc, Fs) of the projected estimate, and the projection (aff_project_levels) moved
 * the map there by no more than that either (the map in use is the one tested). Else the estimate in use stays. An
 * IV estimate's first hundreds of updates can swing far from the joint's values (docs/benchmarks/compensation.md,
 * "The eq. 4 estimate's determinacy test", where the test, opt-in, is measured). The covariance of the IV estimate is e2*P*Szz*P'
 * (Soderstrom & Stoica, System Identification, 1989, Sec. 8.2: the asymptotic covariance of the basic IV estimate,
 * sigma^2*R^-1*E[z z']*R^-T with R = E[z phi'], here with the forgetting of the recursion;
 * e2 the running mean of the normalised a-priori errors with the gain max(1 - lam, 1/n), the sliding estimator's
 * e2 for the IV; P the recursion's P, which contains the prior P0 and so keeps an unexcited direction undetermined).
 * Refused estimates count in n_undetermined. Returns 0, or -1 (e untouched) for map_rel_stderr not > 0
 * (INFINITY: no test, the state at init). Python: AdaptiveFrictionFeedforward(map_rel_stderr=...). */
int aff_eq4_ff_require_determined(aff_eq4_ff *e, aff_real map_rel_stderr);

/* One sample (u(k) N*m, w(k) rad/s) of the stream: returns 0 if refused (a range gate, or the RLS refused the
 * update: only counters change; the IV refused the update, phi'P z < 0 or overflow: counters change and the sample
 * enters the past, whose instruments stay consecutive), else 1 (the first sample, with iv the first four, only
 * fill the past; a sample the sliding-regime gate keeps from the estimator only shifts the past and counts in
 * n_gated). Python:
 * AdaptiveFrictionFeedforward.observe (was eq4_sample). */
int aff_eq4_ff_sample(aff_eq4_ff *e, aff_real u, aff_real w);

/* Compensator interface (aff_compensator.h), self an aff_eq4_ff: in every m-th period (from the m-th on) a
 * sample (the previous period's torque, w_meas), then the feedforward (aff_fixed_ff_compensate at w_ctrl/w_ref;
 * during the provisional start aff_fixed_ff_start_output). */
aff_real aff_eq4_ff_compensate(void *self, aff_real w_ctrl, aff_real w_meas, aff_real w_ref);

/* Compensator interface: step the feedforward's sign observer (aff_fixed_ff_observe), store the applied torque u
 * (N*m) for the next sample; returns 1 in a period that took
 * a sample (refused ones included), then theta (of rls, with iv of ivrls) is written into theta_out[0..p-1] (if
 * not NULL), else 0. */
int aff_eq4_ff_observe(void *self, aff_real u, aff_real w_meas, aff_real *theta_out);

/* The ops table of the eq. 4 feedforward (name "adaptive"). */
extern const aff_compensator_ops aff_eq4_ff_ops;

#endif
