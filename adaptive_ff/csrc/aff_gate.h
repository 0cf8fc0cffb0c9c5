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
 * Each gate is configured from its config struct (aff_gate_config, aff_range_gate_config; aff_error.h).
 * Python: adaptive_ff.compensation.gate.OutlierGate / RangeGate.
 */
#ifndef AFF_GATE_H
#define AFF_GATE_H
#include "aff_real.h"
#include "aff_error.h"

/* The outlier gate's settings (signal unit: the gated signal's). */
typedef struct aff_gate_config {
    aff_real max_step;        /* largest plausible change per sample (signal unit), >= 0; INFINITY (default): none */
    aff_real n_sigma;         /* noise allowance in units of the running scale (-), finite, > 0; default 8 */
    aff_real alpha;           /* smoothing factor of the running scale (-), in (0, 1]; default 0.01 */
    long max_consecutive;     /* outlier rejections after which a sample is accepted again, >= 1; default 20 */
} aff_gate_config;

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
    int64_t n_nonfinite;      /* rejections of non-finite samples */
    int64_t n_outliers;       /* rejections of outlier spikes */
} aff_gate;

/* The outlier gate's defaults: max_step INFINITY (non-finite samples only), n_sigma 8, alpha 0.01,
 * max_consecutive 20 (Python: OutlierGate()). */
aff_gate_config aff_gate_default_config(void);

/* Configure g from *cfg and clear its state (no sample yet, zero scale and counters). Returns AFF_OK, or
 * AFF_ERR_NULL, AFF_ERR_GATE_MAX_STEP, _N_SIGMA, _ALPHA, _MAX_CONSECUTIVE for a field outside its range (g
 * untouched). Python: OutlierGate.__init__. */
aff_error aff_gate_init(aff_gate *g, const aff_gate_config *cfg);

/* The checks of aff_gate_init alone: AFF_OK or the code it would return for *cfg. */
aff_error aff_gate_check_config(const aff_gate_config *cfg);

/* Judge sample x: 1 (accepted, state advanced) or 0 (rejected, only counters change). */
int aff_gate_check(aff_gate *g, aff_real x);

/* The range gate's settings (signal unit: the gated signal's). */
typedef struct aff_range_gate_config {
    aff_real x_max;           /* absolute bound on |x| (signal unit), > 0; INFINITY (default): none */
    aff_real factor;          /* relative bound, times max(envelope, floor) (-), finite, > 1; default 100 */
    aff_real floor;           /* smallest reference scale (signal unit), finite, >= 0; default 0 */
    aff_real memory;          /* decay time of the envelope (samples), finite, > 0; default 10000 */
    long max_consecutive;     /* rejections after which a sample is accepted again, >= 1; default 20 */
} aff_range_gate_config;

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

/* The range gate's defaults: x_max INFINITY, factor 100, floor 0, memory 10000 samples, max_consecutive 20
 * (Python: RangeGate()). */
aff_range_gate_config aff_range_gate_default_config(void);

/* Configure g from *cfg (decay = exp(-1/memory)) and clear its state. Returns AFF_OK, or AFF_ERR_NULL,
 * AFF_ERR_RANGE_GATE_X_MAX, _FACTOR, _FLOOR, _MEMORY, _MAX_CONSECUTIVE (g untouched). Python: RangeGate.__init__. */
aff_error aff_range_gate_init(aff_range_gate *g, const aff_range_gate_config *cfg);

/* The checks of aff_range_gate_init alone: AFF_OK or the code it would return for *cfg. */
aff_error aff_range_gate_check_config(const aff_range_gate_config *cfg);

/* Whether x passes the range gate; reads only. A component checking several signals tests all with this
 * first and then commits each (aff_range_gate_commit), so one rejected signal leaves every state unchanged. */
int aff_range_gate_ok(const aff_range_gate *g, aff_real x);

/* Record the decision ok for x: accepted -> env = max(|x|, decay*env); rejected -> counters only. */
void aff_range_gate_commit(aff_range_gate *g, aff_real x, int ok);

#endif
