/* aff_sliding.h -- closed-loop friction estimation in the sliding regime: inverse-dynamics regression with
 * state-variable filters, RLS.
 *
 * Eq. 2 solved for the torque, u = J*w' + J*tau*w'' - tau*u' + Fc*g(w) + Fs*h(w) + sigma*w (+ offset), filtered on
 * both sides by L(s) = 1/(1 + T s)^3 (three cascaded first-order lags x_i += a*(x_{i-1} - x_i), a = 1 -
 * exp(-Tc/T): Young, Automatica 17(1), 1981; Garnier, Mensler, Richard, Int. J. Control 76(13), 2003), is linear
 * in theta = (J, [J*tau, tau], Fc, Fs, sigma, [offset]) with y = L[u] and
 *   phi = (L[s w], [L[s^2 w], -L[s u]], L[g], L[h], L[w], [1]),
 *   L[x] = x3, L[s x] = (x2 - x3)/T, L[s^2 x] = (x1 - 2*x2 + x3)/T^2.
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

typedef struct aff_sliding {
    /* configuration */
    aff_real Vs;              /* Stribeck velocity of g, h (rad/s) */
    aff_real delta;           /* Stribeck shape factor (1) */
    aff_real a;               /* filter gain per stage, 1 - exp(-Tc/T) */
    aff_real T;               /* filter time constant per stage (s) */
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

/* Configure e and clear its state (filters, noise scale and counters 0); gate, u_range, w_range and rls are
 * configured parts (aff_gate_init, aff_range_gate_init, aff_rls_init with its theta0; the Python class gives the
 * RLS no bounds: a projection of its state diverges after one-sided motion, see SlidingFrictionEstimator's Notes)
 * copied into e by value. Returns 0, or -1 (e untouched) if rls->p differs from 4 + 2*lag + offset. Python:
 * SlidingFrictionEstimator.__init__. */
int aff_sliding_init(aff_sliding *e, aff_real Vs, aff_real delta, aff_real a, aff_real T, long m, long settle,
                     aff_real w_band_min, aff_real dwell_max, aff_real e2_rate, int lag, int offset,
                     const aff_gate *gate, const aff_range_gate *u_range, const aff_range_gate *w_range,
                     const aff_rls *rls);

/* One controller-period sample: torque u (N*m) applied over the period, velocity w (rad/s) measured at its
 * start. Returns 1 if accepted, 0 if rejected (only counters change). After an RLS update e->updated is 1 and
 * e->phi, e->rls hold the row and the new estimate. Python: SlidingFrictionEstimator.observe (was
 * sliding_observe). */
int aff_sliding_observe(aff_sliding *e, aff_real u, aff_real w);

#endif
