/* aff_sliding.h -- closed-loop friction estimation in the sliding regime: inverse-dynamics regression with
 * state-variable filters, RLS.
 *
 * Eq. 2 solved for the torque, u = J*w' + J*tau*w'' - tau*u' + Fc*g(w) + Fs*h(w) + sigma*w (+ offset), filtered on
 * both sides by L(s) = 1/(1 + T s)^3 (three cascaded first-order lags x_i += a*(x_{i-1} - x_i), a = 1 -
 * exp(-Tc/T): Young, Automatica 17(1), 1981; Garnier, Mensler, Richard, Int. J. Control 76(13), 2003), is linear
 * in theta = (J, [J*tau, tau], Fc, Fs, sigma, [offset]) with y = L[u] and
 *   phi = (L[s w], [L[s^2 w], -L[s u]], L[g], L[h], L[w], [1]),
 *   L[x] = x3, L[s x] = D*(x2 - x3), L[s^2 x] = D^2*(x1 - 2*x2 + x3), D = a/((1 - a)*Tc) = (exp(Tc/T) - 1)/Tc.
 * D*(x2 - x3) is the backward difference (x3(k) - x3(k-1))/Tc of the discrete stage exactly (and D^2*(...) the
 * second one), so the columns carry no gain of the discretisation (1/T in place of D would make the fitted J
 * and tau T*(exp(Tc/T) - 1)/Tc times the joint's: +2.5 % at Tc 1 ms, T 20 ms). A backward difference at sample
 * k is the motion under the torque held over the period before it: y is the mean of L[u] before and after the
 * sample (the regressand half a period back, as the difference; with L[u] after it the fitted tau is about Tc/2
 * short, before it Tc/2 long).
 * Every m-th accepted sample after the settling time, a row is given to the RLS if its filtered near-zero
 * indicator L[1(|w| < w_band)] is at most dwell_max (the sliding-regime gate); w_band = max(w_band_min,
 * 4*sigma_n) with the noise sigma_n from the running mean of |w(k) - 2 w(k-1) + w(k-2)|. Samples pass the torque
 * and velocity range gates and the velocity outlier gate first; a rejected sample changes only counters.
 * Python: adaptive_ff.compensation.sliding_estimator.SlidingFrictionEstimator (module docstring: the model and
 * the measured closed-loop bias the gate removes).
 */
#ifndef AFF_SLIDING_H
#define AFF_SLIDING_H
#include "aff_real.h"
#include "aff_gate.h"
#include "aff_rls.h"
#include "aff_error.h"

/* The estimator's settings (Python: SlidingFrictionEstimator's arguments of the same names). */
typedef struct aff_sliding_config {
    aff_real Vs;              /* Stribeck velocity of g, h (rad/s), finite, > 0: set it (the identification's);
                                 default 0 */
    aff_real delta;           /* Stribeck shape factor (1), finite, != 0: set it (the identification's); default 0 */
    aff_real Tc;              /* controller period, the period of observe (s), finite, > 0; default 0.001 */
    aff_real Ts;              /* period of the RLS updates (s), a multiple of Tc (at most 1e9 times); default 0.01 */
    aff_real T_filter;        /* time constant T of each filter stage (s), finite, >= 2*Tc; default 0.02 */
    int forgetting;           /* the RLS's scheme: AFF_RLS_EXPONENTIAL (default), _DIRECTIONAL or _VECTOR */
    aff_real lam;             /* forgetting factor per update (-), in (0, 1]; default 0.995 (unused by _VECTOR) */
    aff_real lam_each[AFF_RLS_NMAX]; /* _VECTOR: one factor per parameter in theta order, in (0, 1]; default 0 */
    aff_real P0;              /* initial covariance scale of the RLS, finite, > 0; default 1e4 */
    aff_real P_max;           /* bound on trace(P), > 0, INFINITY: none; 0 (default): p*P0 */
    int lag;                  /* 1 (default): estimate the lag (the columns L[s^2 w], -L[s u]); 0: not */
    int offset;               /* 1 (default): estimate a constant torque offset; 0: not */
    aff_real w_band_min;      /* smallest near-zero band (rad/s), finite, >= 0; 0 (default): 0.1*Vs */
    aff_real dwell_max;       /* largest filtered near-zero indicator of a row (-), in [0, 1]; default 0.01 */
    aff_real J_max;           /* upper bound of the start's J (kg*m^2), > 0; INFINITY (default): none */
    aff_real tau_max;         /* upper bound of the start's tau (s), finite, > 0; default 1 */
    aff_real initial_J;       /* the RLS's start: J (kg*m^2), clipped to [1e-9, J_max]; default 1 (set the design
                                 inertia) */
    aff_real initial_tau;     /* tau (s), clipped to [0, tau_max] (0 without the lag); default 0 */
    aff_real initial_Fc;      /* Fc (N*m), clipped to >= 0; default 0 */
    aff_real initial_Fs;      /* Fs (N*m), clipped to >= 0; default 0 */
    aff_real initial_sigma;   /* sigma (N*m*s/rad), clipped to >= 0; default 0 */
    aff_real initial_offset;  /* offset (N*m); default 0 (the start must be finite after the clips) */
    aff_gate_config gate;            /* the outlier gate of w (rad/s); default aff_gate_default_config() */
    aff_range_gate_config u_range;   /* the range gate of u (N*m); default aff_range_gate_default_config() */
    aff_range_gate_config w_range;   /* the range gate of w (rad/s); default the same, a floor of 0 taken as Vs */
} aff_sliding_config;

typedef struct aff_sliding {
    /* configuration */
    aff_real Vs;              /* Stribeck velocity of g, h (rad/s) */
    aff_real delta;           /* Stribeck shape factor (1) */
    aff_real a;               /* filter gain per stage, 1 - exp(-Tc/T) */
    aff_real D;               /* the filtered derivative's gain (1/s), a/((1 - a)*Tc) = (exp(Tc/T) - 1)/Tc */
    long m;                   /* samples per RLS update (Ts/Tc) */
    long settle;              /* samples before the first update (filter transients) */
    aff_real w_band_min;      /* smallest near-zero band (rad/s) */
    aff_real dwell_max;       /* largest admissible filtered near-zero indicator, in [0, 1] */
    aff_real e2_rate;         /* gain of the running mean of the normalised squared errors */
    int lag;                  /* 1: the columns L[s^2 w], -L[s u] (J*tau, tau) */
    int offset;               /* 1: the offset column */
    long p;                   /* number of parameters, 4 + 2*lag + offset (= rls.p) */
    /* state */
    aff_real xw[3];           /* filter stages of w (rad/s) */
    aff_real xu[3];           /* of u (N*m) */
    aff_real xg[3];           /* of g(w) */
    aff_real xh[3];           /* of h(w) */
    aff_real xd[3];           /* of the near-zero indicator */
    aff_real w1;              /* last accepted velocity (rad/s) */
    aff_real w2;              /* the one before (rad/s) */
    int64_t n_acc;            /* accepted samples (noise scale starts at 2) */
    aff_real d2;              /* running mean of |w(k) - 2 w(k-1) + w(k-2)| (rad/s) */
    aff_real e2;              /* running mean of err^2/(1 + phi'P phi) of the RLS (N*m^2) */
    int64_t n_samples;        /* samples accepted */
    int64_t n_rejected;       /* samples rejected (range gates, outlier gate) */
    int64_t n_gated;          /* update instants skipped by the sliding-regime gate */
    long n_phase;             /* n_samples mod m (0..m-1; 0: an update instant), counted on its own so that the
                                 updates go on every m-th sample after n_samples saturated at INT64_MAX */
    int updated;              /* 1 if the last observe updated the RLS */
    aff_real phi[AFF_RLS_NMAX]; /* regressor of the last update (p entries) */
    aff_gate gate;            /* outlier gate of w */
    aff_range_gate u_range;   /* range gate of u */
    aff_range_gate w_range;   /* range gate of w */
    aff_rls rls;              /* the estimator of theta */
} aff_sliding;

/* The estimator's defaults (SlidingFrictionEstimator's: Ts 10 ms, T_filter 20 ms, exponential forgetting 0.995,
 * P0 1e4, the lag and the offset estimated, dwell_max 0.01, a start J of 1 kg*m^2, the default gates); Vs and
 * delta are 0: set them (the identification's). */
aff_sliding_config aff_sliding_default_config(void);

/* Configure e from *cfg and clear its state (filters, noise scale and counters 0): p = 4 + 2*lag + offset, m =
 * round(Ts/Tc), filter gain a = 1 - exp(-Tc/T_filter), settle = ceil(8*T_filter/Tc) samples (the filters' start
 * transient, an Erlang-3 tail below 1.5 %), w_band_min (0.1*Vs for 0), e2_rate = 1 - lam (the smallest lam_each
 * for _VECTOR; 0.01 for lam 1), the gates, the RLS (P = P0*I, no bounds: a projection of its state diverges after
 * one-sided motion, see SlidingFrictionEstimator's Notes) started at theta = (J, [J*tau, tau], Fc, Fs, sigma,
 * [offset]) of the clipped start. Returns AFF_OK, or AFF_ERR_NULL, an AFF_ERR_SLIDING_ code, or a code of the
 * gates' (e untouched). Python: SlidingFrictionEstimator.__init__. */
aff_error aff_sliding_init(aff_sliding *e, const aff_sliding_config *cfg);

/* The checks of aff_sliding_init alone: AFF_OK or the code it would return for *cfg. */
aff_error aff_sliding_check_config(const aff_sliding_config *cfg);

/* One controller-period sample: torque u (N*m) applied over the period, velocity w (rad/s) measured at its
 * start. Returns 1 if accepted, 0 if rejected (only counters change). After an RLS update e->updated is 1 and
 * e->phi, e->rls hold the row and the new estimate. Python: SlidingFrictionEstimator.observe (was
 * sliding_observe). */
int aff_sliding_observe(aff_sliding *e, aff_real u, aff_real w);

/* The regressand y of the row the filters now hold (N*m): L[u] half a period back, the mean of the filtered torque
 * before and after the last accepted sample, as the backward differences of the derivative columns (above).
 * Python: SlidingFrictionEstimator.y. */
aff_real aff_sliding_regressand(const aff_sliding *e);

#endif
