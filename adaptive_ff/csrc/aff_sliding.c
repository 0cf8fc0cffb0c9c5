/* aff_sliding.c -- the sliding-regime estimator (see aff_sliding.h). */
#include <stddef.h>
#include <string.h>
#include "aff_sliding.h"
#include "plant_stribeck.h"

/* E|second difference|/sigma for white noise: sqrt(6)*sqrt(2/pi) (the double nearest, as Python computes it). */
static const aff_real NOISE_GAIN = (aff_real)1.9544100476116797;
/* the near-zero band in noise standard deviations */
static const aff_real BAND_SIGMAS = 4.0;

/* Relative tolerance of "Ts is a multiple of Tc" (plant.errors.check_multiple's 1e-9 in double; a float's
 * quotient of two periods is exact to a few 1e-7 only). */
#ifdef AFF_FLOAT
static const aff_real MULTIPLE_TOL = (aff_real)1e-5;
#else
static const aff_real MULTIPLE_TOL = (aff_real)1e-9;
#endif
/* Bound on the counts derived from periods (m, settle): a 32-bit long holds it. */
static const aff_real SLIDING_COUNT_MAX = (aff_real)1e9;

aff_sliding_config aff_sliding_default_config(void)
{
    aff_sliding_config c;
    long i;
    c.Vs = 0;
    c.delta = 0;
    c.Tc = (aff_real)1e-3;
    c.Ts = (aff_real)0.01;
    c.T_filter = (aff_real)0.02;
    c.forgetting = AFF_RLS_EXPONENTIAL;
    c.lam = (aff_real)0.995;
    for (i = 0; i < AFF_RLS_NMAX; i++)
        c.lam_each[i] = 0;
    c.P0 = (aff_real)1e4;
    c.P_max = 0;
    c.lag = 1;
    c.offset = 1;
    c.w_band_min = 0;
    c.dwell_max = (aff_real)0.01;
    c.J_max = (aff_real)INFINITY;
    c.tau_max = (aff_real)1.0;
    c.initial_J = (aff_real)1.0;
    c.initial_tau = 0;
    c.initial_Fc = 0;
    c.initial_Fs = 0;
    c.initial_sigma = 0;
    c.initial_offset = 0;
    c.gate = aff_gate_default_config();
    c.u_range = aff_range_gate_default_config();
    c.w_range = aff_range_gate_default_config();
    return c;
}

/* round(Ts/Tc) if Ts is a positive multiple of Tc within MULTIPLE_TOL (plant.errors.check_multiple), else 0. */
static long sliding_multiple(aff_real Ts, aff_real Tc)
{
    aff_real q = Ts / Tc;
    aff_real r = AFF_FLOOR(q + (aff_real)0.5);
    if (!(AFF_FABS(q - r) <= MULTIPLE_TOL * aff_max2((aff_real)1.0, q)) || !(r >= 1 && r <= SLIDING_COUNT_MAX))
        return 0;
    return (long)r;
}

/* The RLS's start theta of *cfg in theta order (p entries): the clipped start (header comment). */
static void sliding_start(const aff_sliding_config *cfg, aff_real *theta)
{
    long j = 0;
    aff_real J0 = aff_min2(aff_max2(cfg->initial_J, (aff_real)1e-9), cfg->J_max);
    aff_real tau0 = cfg->lag ? aff_min2(aff_max2(cfg->initial_tau, (aff_real)0.0), cfg->tau_max) : (aff_real)0.0;
    theta[j++] = J0;
    if (cfg->lag) {
        theta[j++] = J0 * tau0;
        theta[j++] = tau0;
    }
    theta[j++] = aff_max2(cfg->initial_Fc, (aff_real)0.0);
    theta[j++] = aff_max2(cfg->initial_Fs, (aff_real)0.0);
    theta[j++] = aff_max2(cfg->initial_sigma, (aff_real)0.0);
    if (cfg->offset)
        theta[j] = cfg->initial_offset;
}

aff_error aff_sliding_check_config(const aff_sliding_config *cfg)
{
    long p, i;
    aff_error err;
    aff_real start[7]; /* p <= 7 */
    if (cfg == NULL)
        return AFF_ERR_NULL;
    if (!aff_positive(cfg->Vs))
        return AFF_ERR_SLIDING_VS;
    if (!(isfinite(cfg->delta) && cfg->delta != 0))
        return AFF_ERR_SLIDING_DELTA;
    if (!aff_positive(cfg->Tc))
        return AFF_ERR_SLIDING_TC;
    if (!aff_positive(cfg->Ts) || sliding_multiple(cfg->Ts, cfg->Tc) == 0)
        return AFF_ERR_SLIDING_TS;
    if (!(aff_positive(cfg->T_filter) && cfg->T_filter >= 2 * cfg->Tc))
        return AFF_ERR_SLIDING_T_FILTER;
    if (!aff_flag(cfg->lag))
        return AFF_ERR_SLIDING_LAG;
    if (!aff_flag(cfg->offset))
        return AFF_ERR_SLIDING_OFFSET;
    p = 4 + 2 * cfg->lag + cfg->offset;
    if (cfg->forgetting != AFF_RLS_EXPONENTIAL && cfg->forgetting != AFF_RLS_DIRECTIONAL
        && cfg->forgetting != AFF_RLS_VECTOR)
        return AFF_ERR_SLIDING_FORGETTING;
    if (cfg->forgetting != AFF_RLS_VECTOR && !(cfg->lam > 0 && cfg->lam <= 1))
        return AFF_ERR_SLIDING_LAM;
    if (cfg->forgetting == AFF_RLS_VECTOR)
        for (i = 0; i < p; i++)
            if (!(cfg->lam_each[i] > 0 && cfg->lam_each[i] <= 1))
                return AFF_ERR_SLIDING_LAM_EACH;
    if (!aff_positive(cfg->P0))
        return AFF_ERR_SLIDING_P0;
    if (!(cfg->P_max == 0 || aff_positive_or_inf(cfg->P_max)))
        return AFF_ERR_SLIDING_P_MAX;
    if (!aff_nonnegative(cfg->w_band_min))
        return AFF_ERR_SLIDING_W_BAND_MIN;
    if (!(cfg->dwell_max >= 0 && cfg->dwell_max <= 1))
        return AFF_ERR_SLIDING_DWELL_MAX;
    if (!aff_positive_or_inf(cfg->J_max))
        return AFF_ERR_SLIDING_J_MAX;
    if (!aff_positive(cfg->tau_max))
        return AFF_ERR_SLIDING_TAU_MAX;
    sliding_start(cfg, start);
    for (i = 0; i < p; i++)
        if (!isfinite(start[i]))
            return AFF_ERR_SLIDING_INITIAL;
    if ((err = aff_gate_check_config(&cfg->gate)) != AFF_OK)
        return err;
    if ((err = aff_range_gate_check_config(&cfg->u_range)) != AFF_OK)
        return err;
    return aff_range_gate_check_config(&cfg->w_range);
}

aff_error aff_sliding_init(aff_sliding *e, const aff_sliding_config *cfg)
{
    long p, i;
    aff_real q, lam_min;
    aff_rls_config rc;
    aff_range_gate_config wr;
    aff_error err = e == NULL ? AFF_ERR_NULL : aff_sliding_check_config(cfg);
    if (err != AFF_OK)
        return err;
    p = 4 + 2 * cfg->lag + cfg->offset;
    memset(e, 0, sizeof *e);
    e->Vs = cfg->Vs;
    e->delta = cfg->delta;
    e->a = (aff_real)1.0 - AFF_EXP(-cfg->Tc / cfg->T_filter);
    e->D = e->a / (((aff_real)1.0 - e->a) * cfg->Tc);
    e->m = sliding_multiple(cfg->Ts, cfg->Tc);
    q = AFF_CEIL((aff_real)8.0 * cfg->T_filter / cfg->Tc);
    e->settle = (long)aff_min2(q, SLIDING_COUNT_MAX);
    e->w_band_min = cfg->w_band_min > 0 ? cfg->w_band_min : (aff_real)0.1 * cfg->Vs;
    e->dwell_max = cfg->dwell_max;
    lam_min = cfg->lam;
    if (cfg->forgetting == AFF_RLS_VECTOR) {
        lam_min = cfg->lam_each[0];
        for (i = 1; i < p; i++)
            lam_min = aff_min2(lam_min, cfg->lam_each[i]);
    }
    e->e2_rate = lam_min < 1 ? (aff_real)1.0 - lam_min : (aff_real)0.01;
    e->lag = cfg->lag;
    e->offset = cfg->offset;
    e->p = p;
    aff_gate_init(&e->gate, &cfg->gate);
    aff_range_gate_init(&e->u_range, &cfg->u_range);
    wr = cfg->w_range;
    if (wr.floor == 0)
        wr.floor = cfg->Vs;
    aff_range_gate_init(&e->w_range, &wr);
    rc.n_params = p;
    rc.forgetting = cfg->forgetting;
    rc.lam = cfg->lam;
    rc.P0 = cfg->P0;
    rc.P_max = cfg->P_max == 0 ? (aff_real)p * cfg->P0 : cfg->P_max;
    aff_rls_init(&e->rls, &rc);
    sliding_start(cfg, e->rls.theta);
    if (cfg->forgetting == AFF_RLS_VECTOR)
        aff_rls_set_lam_each(&e->rls, cfg->lam_each);
    return AFF_OK;
}

/* Advance one chain of three first-order lags x[0..2] (gain a) by the input v (the filter L). */
static void svf3(aff_real *x, aff_real a, aff_real v)
{
    aff_real x1 = x[0] + a * (v - x[0]);
    aff_real x2 = x[1] + a * (x1 - x[1]);
    x[2] += a * (x2 - x[2]);
    x[0] = x1;
    x[1] = x2;
}

/* phi'P phi of the RLS (>= 0): with P scaled by the noise variance e2, the a-priori error's variance is
 * e2*(1 + phi'P phi) (the innovation variance of the Kalman-filter form of RLS; Ljung, System Identification,
 * 2nd ed., 1999, Sec. 11.2). */
static aff_real phi_P_phi(const aff_rls *r, const aff_real *phi)
{
    aff_real acc = aff_rls_quad(r, phi);
    return acc > 0 ? acc : (aff_real)0.0;
}

/* phi_P_phi of the P before an accepted update, from the update's own P phi (r->v, summed in the same order:
 * the same number) where the scheme keeps it (exponential, directional; vector forgetting inflates P first). */
static aff_real phi_v(const aff_rls *r, const aff_real *phi)
{
    long i;
    aff_real acc = 0;
    for (i = 0; i < r->p; i++)
        acc += phi[i] * r->v[i];
    return acc > 0 ? acc : (aff_real)0.0;
}

aff_real aff_sliding_regressand(const aff_sliding *e)
{
    /* x3(k-1) = x3(k) - (a/(1 - a))*(x2(k) - x3(k)) of the stage x3 += a*(x2 - x3) */
    return e->xu[2] - (aff_real)0.5 * (e->a / ((aff_real)1.0 - e->a)) * (e->xu[1] - e->xu[2]);
}

int aff_sliding_observe(aff_sliding *e, aff_real u, aff_real w)
{
    int uok, wok;
    aff_real band, nb, aw, gg, hh, dz, a, D, s, err;
    long j;
    e->updated = 0;
    /* input rejection: torque range, velocity range (finite velocities; the gate counts non-finite ones), then
     * the velocity gate; the range gates record their decision only once the whole sample is accepted */
    uok = aff_range_gate_ok(&e->u_range, u);
    if (!uok) {
        aff_range_gate_commit(&e->u_range, u, 0);
        e->n_rejected = aff_count_up(e->n_rejected);
        return 0;
    }
    wok = aff_range_gate_ok(&e->w_range, w);
    if (isfinite(w) && !wok) {
        aff_range_gate_commit(&e->w_range, w, 0);
        e->n_rejected = aff_count_up(e->n_rejected);
        return 0;
    }
    if (!aff_gate_check(&e->gate, w)) {
        e->n_rejected = aff_count_up(e->n_rejected);
        return 0;
    }
    aff_range_gate_commit(&e->u_range, u, 1);
    aff_range_gate_commit(&e->w_range, w, 1);
    if (e->n_acc >= 2) {
        aff_real dd = w - (aff_real)2.0 * e->w1 + e->w2;
        e->d2 += (aff_real)0.01 * (AFF_FABS(dd) - e->d2);
    }
    e->w2 = e->w1;
    e->w1 = w;
    e->n_acc = aff_count_up(e->n_acc);
    band = e->w_band_min;
    nb = BAND_SIGMAS * e->d2 / NOISE_GAIN;
    if (nb > band)
        band = nb;
    aw = AFF_FABS(w);
    if (aw > 0) {
        /* exp(-|w/Vs|^delta), eq. 3's shape (plant.stribeck_map.stribeck_scalar(aw, 0, 1, Vs, delta, 0, inf) is
         * 0 + 1*shape + 0*aw: the same bits for the finite aw > 0 here) */
        aff_real ee = plant_stribeck_shape(aw, e->Vs, e->delta);
        aff_real sg = w > 0 ? (aff_real)1.0 : (aff_real)-1.0;
        gg = sg * ((aff_real)1.0 - ee);
        hh = sg * ee;
    } else {
        gg = 0;
        hh = 0;
    }
    dz = aw < band ? (aff_real)1.0 : (aff_real)0.0;
    a = e->a;
    svf3(e->xw, a, w);
    svf3(e->xu, a, u);
    svf3(e->xg, a, gg);
    svf3(e->xh, a, hh);
    svf3(e->xd, a, dz);
    e->n_samples = aff_count_up(e->n_samples);
    e->n_phase = e->n_phase + 1 < e->m ? e->n_phase + 1 : 0; /* n_samples mod m, also once n_samples saturated */
    if (e->n_phase != 0 || e->n_samples < e->settle)
        return 1;
    if (e->xd[2] > e->dwell_max) {
        e->n_gated = aff_count_up(e->n_gated);
        return 1;
    }
    D = e->D;
    j = 0;
    e->phi[j++] = D * (e->xw[1] - e->xw[2]);
    if (e->lag) {
        e->phi[j] = D * D * (e->xw[0] - (aff_real)2.0 * e->xw[1] + e->xw[2]);
        e->phi[j + 1] = -D * (e->xu[1] - e->xu[2]);
        j += 2;
    }
    e->phi[j] = e->xg[2];
    e->phi[j + 1] = e->xh[2];
    e->phi[j + 2] = e->xw[2];
    j += 3;
    if (e->offset)
        e->phi[j] = 1.0;
    /* phi'P phi before the update: the a-priori error's variance is e2*(1 + s) */
    s = e->rls.scheme == AFF_RLS_VECTOR ? phi_P_phi(&e->rls, e->phi) : (aff_real)0.0;
    err = aff_rls_update(&e->rls, e->phi, aff_sliding_regressand(e));
    if (err != err) /* refused by the RLS (an update that would overflow): counted there, nothing else changes */
        return 1;
    if (e->rls.scheme != AFF_RLS_VECTOR)
        s = phi_v(&e->rls, e->phi);
    e->e2 += e->e2_rate * (err * err / ((aff_real)1.0 + s) - e->e2);
    e->updated = 1;
    return 1;
}
