/* aff_gate.h -- plausibility gates of a sampled signal: the outlier gate and the range gate.
 *
 * Outlier gate: a finite sample x is an outlier if
 *   |x - last| > (max_step + n_sigma*scale) * (1 + n_held)
 * (the validation gate of target tracking: Bar-Shalom, Li, Kirubarajan,
 * Estimation with Applications to Tracking and Navigation, Wiley 2001, with a
 * physical bound and a running noise scale updated by accepted samples only).
 * Range gate: |x| > x_max, or |x| > factor*max(env, floor) with env the peak
 * envelope of the accepted |x| (Isermann, Fault-Diagnosis Systems, Springer
 * 2006, Sec. 7.1). A rejected sample changes only the counters.
 * Python: adaptive_ff.compensation.gate.OutlierGate / RangeGate.
 */
#ifndef AFF_GATE_H
#define AFF_GATE_H
#include "aff_real.h"

/* Outlier gate: configuration, then state. */
typedef struct aff_gate {
    aff_real max_step;        /* largest plausible change per sample (signal unit), >= 0, INFINITY = none */
    aff_real n_sigma;         /* noise allowance in units of scale, > 0 */
    aff_real alpha;           /* smoothing factor of scale, in (0, 1] */
    long max_consecutive;     /* outlier rejections after which a sample is accepted again, >= 1 */
    aff_real last;            /* last accepted sample (valid if has_last) */
    int has_last;             /* 1 after the first accepted sample */
    aff_real scale;           /* running mean of |x(k) - x(k-1)| over accepted samples */
    int64_t n_held;           /* samples rejected since the last accepted one */
    int64_t n_rejected;       /* rejections in total */
    int64_t n_nonfinite;      /* of them non-finite */
    int64_t n_outliers;       /* of them outlier spikes */
} aff_gate;

/* Configure g and clear its state (no sample yet, zero scale and counters). */
void aff_gate_init(aff_gate *g, aff_real max_step, aff_real n_sigma, aff_real alpha, long max_consecutive);

/* Judge sample x: 1 (accepted, state advanced) or 0 (rejected, only counters change). */
int aff_gate_check(aff_gate *g, aff_real x);

/* Range gate: configuration, then state. */
typedef struct aff_range_gate {
    aff_real x_max;           /* absolute bound on |x| (signal unit), INFINITY = none */
    aff_real factor;          /* relative bound (times max(env, floor)), > 1 */
    aff_real floor;           /* smallest reference scale (signal unit), >= 0 */
    aff_real decay;           /* envelope release per sample, exp(-1/memory) */
    long max_consecutive;     /* rejections after which a sample is accepted again, >= 1 */
    aff_real env;             /* peak envelope of the accepted |x| */
    int64_t n_held;           /* samples rejected since the last accepted one */
    int64_t n_rejected;       /* rejections in total */
} aff_range_gate;

/* Configure g (decay = exp(-1/memory)) and clear its state. */
void aff_range_gate_init(aff_range_gate *g, aff_real x_max, aff_real factor, aff_real floor, aff_real decay,
                         long max_consecutive);

/* Whether x passes the range gate; reads only. A component checking several signals tests all with this
 * first and then commits each (aff_range_gate_commit), so one rejected signal leaves every state unchanged. */
int aff_range_gate_ok(const aff_range_gate *g, aff_real x);

/* Record the decision ok for x: accepted -> env = max(|x|, decay*env); rejected -> counters only. */
void aff_range_gate_commit(aff_range_gate *g, aff_real x, int ok);

#endif
