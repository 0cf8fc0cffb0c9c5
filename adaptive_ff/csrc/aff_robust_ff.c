/* aff_robust_ff.c -- the robust adaptive feedforward (see aff_robust_ff.h). */
#include <stddef.h>
#include <string.h>
#include "aff_robust_ff.h"

/* Fraction of the RLS prior variance below which the data have determined Fc (Python: FC_INFO_FRACTION). */
static const aff_real FC_INFO_FRACTION = (aff_real)0.01;

aff_start_config aff_start_default_config(void)
{
    aff_start_config c;
    c.on = 0;
    c.Fc = 0;
    c.Fs = 0;
    c.sigma = 0;
    c.tau = 0;
    c.Vs = 0;
    c.delta = 0;
    c.gain = (aff_real)1.0;
    c.at_ref = 1;
    return c;
}

aff_robust_ff_config aff_robust_ff_default_config(void)
{
    aff_robust_ff_config c;
    c.ff = aff_fixed_ff_default_config();
    c.est = aff_sliding_default_config();
    c.warmup = 200;
    c.fade_in = (aff_real)1.0;
    c.J_lo = 0;
    c.J_hi = (aff_real)INFINITY;
    c.tau_max = (aff_real)1.0;
    c.consistency = (aff_real)0.5;
    c.lag_margin = (aff_real)1.0;
    c.lag_margin_max = (aff_real)0.05;
    c.max_rel_stderr = (aff_real)0.05;
    c.lag_memory = (aff_real)10.0;
    c.lag_zero = (aff_real)3.0;
    c.project = 1;
    c.start = aff_start_default_config();
    return c;
}

/* The checks of the start map (its Vs and delta the estimator's where 0). */
static aff_error robust_start_check(const aff_start_config *s, const aff_sliding_config *est)
{
    if (!aff_flag(s->on))
        return AFF_ERR_START_ON;
    if (!s->on)
        return AFF_OK;
    if (!aff_nonnegative(s->Fc))
        return AFF_ERR_START_FC;
    if (!aff_nonnegative(s->Fs))
        return AFF_ERR_START_FS;
    if (!aff_nonnegative(s->sigma))
        return AFF_ERR_START_SIGMA;
    if (!aff_nonnegative(s->tau))
        return AFF_ERR_START_TAU;
    if (!aff_positive(s->Vs != 0 ? s->Vs : est->Vs))
        return AFF_ERR_START_VS;
    if (!isfinite(s->delta != 0 ? s->delta : est->delta))
        return AFF_ERR_START_DELTA;
    if (!(s->gain > 0 && s->gain <= 1))
        return AFF_ERR_START_GAIN;
    if (!aff_flag(s->at_ref))
        return AFF_ERR_START_AT_REF;
    return AFF_OK;
}

aff_error aff_robust_ff_check_config(const aff_robust_ff_config *cfg)
{
    aff_error e;
    if (cfg == NULL)
        return AFF_ERR_NULL;
    if ((e = aff_fixed_ff_check_config(&cfg->ff)) != AFF_OK)
        return e;
    if ((e = aff_sliding_check_config(&cfg->est)) != AFF_OK)
        return e;
    if (cfg->warmup < 0)
        return AFF_ERR_ROBUST_FF_WARMUP;
    if (!aff_nonnegative(cfg->fade_in))
        return AFF_ERR_ROBUST_FF_FADE_IN;
    if (!(aff_nonnegative(cfg->J_lo) && cfg->J_lo < cfg->J_hi))
        return AFF_ERR_ROBUST_FF_J_RANGE;
    if (!aff_positive(cfg->tau_max))
        return AFF_ERR_ROBUST_FF_TAU_MAX;
    if (!aff_positive(cfg->consistency))
        return AFF_ERR_ROBUST_FF_CONSISTENCY;
    if (!aff_nonnegative(cfg->lag_margin))
        return AFF_ERR_ROBUST_FF_LAG_MARGIN;
    if (!aff_nonnegative_or_inf(cfg->lag_margin_max))
        return AFF_ERR_ROBUST_FF_LAG_MARGIN_MAX;
    if (!aff_positive_or_inf(cfg->max_rel_stderr))
        return AFF_ERR_ROBUST_FF_MAX_REL_STDERR;
    if (!aff_nonnegative(cfg->lag_memory))
        return AFF_ERR_ROBUST_FF_LAG_MEMORY;
    if (!aff_nonnegative_or_inf(cfg->lag_zero))
        return AFF_ERR_ROBUST_FF_LAG_ZERO;
    if (!aff_flag(cfg->project))
        return AFF_ERR_ROBUST_FF_PROJECT;
    return robust_start_check(&cfg->start, &cfg->est);
}

aff_error aff_robust_ff_init(aff_robust_ff *r, const aff_robust_ff_config *cfg)
{
    long i;
    aff_real Ts;
    const aff_start_config *s;
    aff_error e = r == NULL ? AFF_ERR_NULL : aff_robust_ff_check_config(cfg);
    if (e != AFF_OK)
        return e;
    s = &cfg->start;
    memset(r, 0, sizeof *r);
    aff_fixed_ff_init(&r->ff, &cfg->ff);
    aff_sliding_init(&r->est, &cfg->est);
    Ts = (aff_real)r->est.m * cfg->est.Tc; /* the estimator's update period, m*Tc */
    r->warmup = cfg->warmup;
    r->fade = cfg->fade_in == 0 ? (aff_real)1.0 : cfg->ff.dt / cfg->fade_in;
    r->J_lo = cfg->J_lo;
    r->J_hi = cfg->J_hi;
    r->tau_max = cfg->tau_max;
    r->consistency = cfg->consistency;
    r->start_gain = s->on ? s->gain : (aff_real)1.0;
    r->start_at_ref = s->on ? s->at_ref : 0;
    r->lag_margin = cfg->lag_margin;
    r->max_rel_stderr = cfg->max_rel_stderr;
    r->lag_margin_max = cfg->lag_margin_max;
    r->lag_forget = cfg->lag_memory > 0 ? AFF_EXP(-Ts / cfg->lag_memory) : (aff_real)0.0;
    r->lag_zero = cfg->lag_zero;
    r->project = cfg->project;
    for (i = 0; i < AFF_RLS_NMAX; i++)
        r->theta_used[i] = (aff_real)NAN;
    if (s->on) { /* the provisional start map in use from the first period */
        aff_fixed_ff_set_estimate(&r->ff, s->Fc, s->Fs, s->Vs != 0 ? s->Vs : cfg->est.Vs,
                                  s->delta != 0 ? s->delta : cfg->est.delta, s->sigma, s->tau, 1);
        r->provisional = 1;
        r->gain = 1.0;
    }
    return AFF_OK;
}

/* The output of aff_robust_ff_compensate (N*m). */
static aff_real output(aff_robust_ff *r, aff_real w_ctrl, aff_real w_ref)
{
    aff_fixed_ff *f = &r->ff;
    aff_real w_stuck = aff_loop_model_step(&f->lm, w_ctrl, w_ref);
    aff_real out;
    if (!f->has) {
        aff_sign_observer_signed(&f->ob, w_ctrl, f->stick_band); /* the sign observer follows the joint too */
        return 0.0;
    }
    if (r->provisional)
        return aff_fixed_ff_start_output(f, w_ctrl, w_stuck, w_ref, r->start_at_ref, r->start_gain);
    out = aff_fixed_ff_at(f, w_ctrl, w_stuck, w_ref);
    if (r->gain < (aff_real)1.0) {
        r->gain = aff_min2(r->gain + r->fade, 1.0);
        out = out * r->gain;
    }
    return out;
}

aff_real aff_robust_ff_compensate(void *self, aff_real w_ctrl, aff_real w_meas, aff_real w_ref)
{
    aff_robust_ff *r = (aff_robust_ff *)self;
    aff_real out = output(r, (aff_real)w_ctrl, (aff_real)w_ref);
    (void)w_meas;
    r->ff.u_out = out;
    return out;
}

int aff_fc_determined(aff_real max_rel_stderr, aff_real e2, aff_real P_FcFc, aff_real P_prior, aff_real eFc,
                      aff_real eFs)
{
    if (!(max_rel_stderr < (aff_real)INFINITY))
        return 1;
    return AFF_SQRT(aff_max2(e2 * P_FcFc, 0.0)) <= max_rel_stderr * aff_max2(eFc, eFs)
           && P_FcFc <= FC_INFO_FRACTION * P_prior;
}

/* Range checks of an estimate (point (5) of the Python class Notes). */
static int levels_plausible(const aff_robust_ff *r, aff_real eJ, aff_real etau, aff_real eFc, aff_real eFs,
                            aff_real esig)
{
    aff_real ffmax = r->ff.ff_max;
    return isfinite(eJ) && isfinite(etau) && isfinite(esig) && isfinite(eFc) && isfinite(eFs) && r->J_lo < eJ
           && eJ < r->J_hi && 0 <= etau && etau <= r->tau_max && esig >= 0 && 0 <= eFc && eFc <= ffmax
           && 0 <= eFs && eFs <= ffmax;
}

/* The two lag estimates (tau and the J*tau column) agree: within consistency*J*tau, or within three standard
 * deviations of their difference (delta method on e2*P[:3, :3] with the gradient (-tau, 1, -J)); checked only
 * for tau >= 2*dt and a finite J_alt. */
static int lag_consistent(const aff_robust_ff *r, const aff_rls *rls, aff_real eJ, aff_real etau, aff_real eJalt,
                          aff_real e2, aff_real dt, int has_lag)
{
    aff_real diff, g0, g2, v0, v1, v2, var;
    if (!(etau >= (aff_real)2.0 * dt && isfinite(eJalt)))
        return 1;
    diff = AFF_FABS(eJalt * etau - eJ * etau);
    if (diff <= r->consistency * eJ * etau)
        return 1;
    if (!has_lag)
        return 0;
    g0 = -etau;
    g2 = -eJ;
    v0 = g0 * (e2 * aff_rls_P(rls, 0, 0)) + (aff_real)1.0 * (e2 * aff_rls_P(rls, 1, 0))
         + g2 * (e2 * aff_rls_P(rls, 2, 0));
    v1 = g0 * (e2 * aff_rls_P(rls, 0, 1)) + (aff_real)1.0 * (e2 * aff_rls_P(rls, 1, 1))
         + g2 * (e2 * aff_rls_P(rls, 2, 1));
    v2 = g0 * (e2 * aff_rls_P(rls, 0, 2)) + (aff_real)1.0 * (e2 * aff_rls_P(rls, 1, 2))
         + g2 * (e2 * aff_rls_P(rls, 2, 2));
    var = v0 * g0 + v1 * (aff_real)1.0 + v2 * g2;
    return diff <= (aff_real)3.0 * AFF_SQRT(aff_max2(var, 0.0));
}

int aff_robust_ff_plausible(const aff_robust_ff *r, aff_real J, aff_real tau, aff_real J_alt, aff_real Fc,
                            aff_real Fs, aff_real sigma)
{
    if (!levels_plausible(r, J, tau, Fc, Fs, sigma))
        return 0;
    return lag_consistent(r, &r->est.rls, J, tau, J_alt, r->est.e2, r->ff.dt, r->est.lag);
}

aff_real aff_robust_ff_lag_weighted(aff_robust_ff *r, aff_real tau, aff_real sd)
{
    aff_real w, info;
    if (!(r->lag_forget > 0 && sd > 0))
        return tau;
    w = (aff_real)1.0 / (sd * sd);
    info = r->lag_forget * r->lag_info + w;
    r->lag_mean = r->lag_info == 0 ? tau : r->lag_mean + (w / info) * (tau - r->lag_mean);
    r->lag_info = info;
    return r->lag_mean;
}

int aff_project_box(long p, const aff_rls *cov, const aff_real *theta, const aff_real *lo, const aff_real *hi,
                    aff_real *x, aff_real *work)
{
    int side[AFF_RLS_NMAX];      /* working set: 0 free, -1 held at lo, +1 held at hi */
    long W[AFF_RLS_NMAX];        /* indices of the working set */
    aff_real *L = work;          /* Cholesky factor of P[W, W], row-major, row length p (p*p) */
    aff_real *th = L + p * p;    /* theta (x may alias it) */
    aff_real *mu = th + p;       /* multipliers: P[W, W] mu = b_W - theta_W */
    aff_real *z = mu + p;        /* minimiser with W held */
    long i, j, k, nw, it, blk;
    int bside, nact;
    aff_real alpha, worst;
    if (p < 1 || p > AFF_RLS_NMAX)
        return -1;
    nact = 0;
    for (i = 0; i < p; i++) {
        if (!(lo[i] <= hi[i] && lo[i] < (aff_real)INFINITY && hi[i] > -(aff_real)INFINITY))
            return -1;
        th[i] = theta[i];
        x[i] = th[i];
        side[i] = 0;
        if (x[i] < lo[i]) {
            x[i] = lo[i];
            side[i] = -1;
            nact++;
        } else if (x[i] > hi[i]) {
            x[i] = hi[i];
            side[i] = 1;
            nact++;
        }
    }
    if (nact == 0)
        return 0;
    /* x is feasible (theta clipped) and the working set holds the clipped parameters at their bounds */
    for (it = 0; it < 8 * p + 8; it++) {
        nw = 0;
        for (i = 0; i < p; i++)
            if (side[i] != 0)
                W[nw++] = i;
        /* Cholesky of P[W, W], then mu */
        for (j = 0; j < nw; j++) {
            aff_real d = aff_rls_P(cov, W[j], W[j]);
            for (k = 0; k < j; k++)
                d -= L[j * p + k] * L[j * p + k];
            if (!(d > 0) || !isfinite(d))
                return -1;
            L[j * p + j] = AFF_SQRT(d);
            for (i = j + 1; i < nw; i++) {
                aff_real c = aff_rls_P(cov, W[i], W[j]);
                for (k = 0; k < j; k++)
                    c -= L[i * p + k] * L[j * p + k];
                L[i * p + j] = c / L[j * p + j];
            }
        }
        for (j = 0; j < nw; j++) { /* forward: L y = b_W - theta_W */
            aff_real c = (side[W[j]] < 0 ? lo[W[j]] : hi[W[j]]) - th[W[j]];
            for (k = 0; k < j; k++)
                c -= L[j * p + k] * mu[k];
            mu[j] = c / L[j * p + j];
        }
        for (j = nw - 1; j >= 0; j--) { /* backward: L' mu = y */
            aff_real c = mu[j];
            for (k = j + 1; k < nw; k++)
                c -= L[k * p + j] * mu[k];
            mu[j] = c / L[j * p + j];
        }
        for (i = 0; i < p; i++) {
            if (side[i] != 0) {
                z[i] = side[i] < 0 ? lo[i] : hi[i];
            } else {
                aff_real c = th[i];
                for (k = 0; k < nw; k++)
                    c += aff_rls_P(cov, i, W[k]) * mu[k];
                z[i] = c;
            }
        }
        /* the step from x towards z, as far as the first bound it meets */
        alpha = 1.0;
        blk = -1;
        bside = 0;
        for (i = 0; i < p; i++) {
            aff_real a;
            if (side[i] != 0)
                continue;
            if (!isfinite(z[i]))
                return -1;
            if (z[i] < lo[i]) {
                a = (lo[i] - x[i]) / (z[i] - x[i]);
                if (blk < 0 || a < alpha) { /* (a < 1 but for rounding) */
                    alpha = aff_min2(alpha, a);
                    blk = i;
                    bside = -1;
                }
            } else if (z[i] > hi[i]) {
                a = (hi[i] - x[i]) / (z[i] - x[i]);
                if (blk < 0 || a < alpha) {
                    alpha = aff_min2(alpha, a);
                    blk = i;
                    bside = 1;
                }
            }
        }
        if (blk >= 0) { /* blocked: move to the bound, hold it */
            if (!(alpha >= 0))
                alpha = 0.0;
            for (i = 0; i < p; i++) {
                if (side[i] != 0)
                    continue;
                x[i] += alpha * (z[i] - x[i]);
                if (x[i] < lo[i])
                    x[i] = lo[i];
                else if (x[i] > hi[i])
                    x[i] = hi[i];
            }
            x[blk] = bside < 0 ? lo[blk] : hi[blk];
            side[blk] = bside;
            continue;
        }
        for (i = 0; i < p; i++)
            x[i] = z[i];
        /* optimal if every multiplier has its sign (>= 0 at lo, <= 0 at hi); else free the worst */
        worst = 0.0;
        blk = -1;
        for (j = 0; j < nw; j++) {
            aff_real v = side[W[j]] < 0 ? -mu[j] : mu[j];
            if (v > worst) {
                worst = v;
                blk = W[j];
            }
        }
        if (blk < 0)
            return (int)nw;
        side[blk] = 0;
    }
    return -1;
}

/* The plausible box of theta for the projection: J and the offset free; J*tau >= 0; 0 <= tau <= tau_max;
 * 0 <= Fc, Fs <= ff_max; sigma >= 0. */
static void plausible_box(const aff_robust_ff *r, aff_real *lo, aff_real *hi)
{
    long p = r->est.p;
    long i, k = 1;
    for (i = 0; i < p; i++) {
        lo[i] = -(aff_real)INFINITY;
        hi[i] = (aff_real)INFINITY;
    }
    if (r->est.lag) {
        lo[1] = 0.0;
        lo[2] = 0.0;
        hi[2] = r->tau_max;
        k = 3;
    }
    lo[k] = 0.0;
    hi[k] = r->ff.ff_max;
    lo[k + 1] = 0.0;
    hi[k + 1] = r->ff.ff_max;
    lo[k + 2] = 0.0;
}

int aff_robust_ff_estimate_in_use(const aff_robust_ff *r)
{
    return r->ff.has && !r->provisional;
}

int aff_robust_ff_decide(aff_robust_ff *r)
{
    aff_sliding *est = &r->est;
    const aff_rls *rls = &est->rls;
    long p = rls->p;
    long i, iFc;
    int lag;
    aff_real x[AFF_RLS_NMAX];
    aff_real eJ, etau, eJalt, eFc, eFs, esig, e2;
    lag = est->lag;
    e2 = est->e2;
    for (i = 0; i < p; i++)
        x[i] = rls->theta[i];
    if (lag && x[2] < 0 && r->lag_zero > 0) {
        /* a lag estimate below 0 within its noise is lag 0 (its standard error sd = sqrt(e2*P_tautau), the
         * Kalman-filter form of RLS: Ljung, System Identification, 2nd ed., 1999, Sec. 11.2; at least two periods,
         * the shortest lag lag_consistent tests) */
        aff_real sd = AFF_SQRT(aff_max2(e2 * aff_rls_P(rls, 2, 2), 0.0));
        aff_real tol = r->lag_zero < (aff_real)INFINITY ? aff_max2(r->lag_zero * sd, (aff_real)2.0 * r->ff.dt)
                                                        : (aff_real)INFINITY;
        if (!(x[2] >= -tol)) {
            r->n_implausible = aff_count_up(r->n_implausible);
            return 0;
        }
        r->n_lag_zero = aff_count_up(r->n_lag_zero);
        if (!r->project) {
            x[2] = 0.0;
            if (x[1] < 0)
                x[1] = 0.0;
        }
    }
    if (r->project) {
        aff_real lo[AFF_RLS_NMAX], hi[AFF_RLS_NMAX];
        int nb;
        plausible_box(r, lo, hi);
        if (lag && !(r->lag_zero > 0))
            lo[2] = -(aff_real)INFINITY; /* lag_zero 0: a negative lag is refused below, not projected */
        nb = aff_project_box(p, rls, rls->theta, lo, hi, x, r->work);
        if (nb < 0) {
            r->n_implausible = aff_count_up(r->n_implausible);
            return 0;
        }
        if (nb > 0)
            r->n_boxed = aff_count_up(r->n_boxed);
    }
    eJ = x[0];
    if (lag) {
        etau = x[2];
        eJalt = etau > 0 ? x[1] / etau : (aff_real)NAN;
        iFc = 3;
    } else {
        etau = 0.0;
        eJalt = (aff_real)NAN;
        iFc = 1;
    }
    eFc = x[iFc];
    eFs = x[iFc + 1];
    esig = x[iFc + 2];
    if (!levels_plausible(r, eJ, etau, eFc, eFs, esig)) {
        r->n_implausible = aff_count_up(r->n_implausible);
        return 0;
    }
    if (!aff_fc_determined(r->max_rel_stderr, e2, aff_rls_P(rls, iFc, iFc), aff_rls_prior_variance(rls), eFc,
                           eFs)) {
        /* Fc not determined yet (e.g. one direction of motion only: Fc and the offset agree) */
        r->n_undetermined = aff_count_up(r->n_undetermined);
        return 0;
    }
    if (lag_consistent(r, rls, eJ, etau, eJalt, e2, r->ff.dt, lag)) {
        r->held = 0;
        if (lag) { /* the upper confidence bound of the weighted lag, at most lag_margin_max*tau above it */
            aff_real sd = AFF_SQRT(aff_max2(e2 * aff_rls_P(rls, 2, 2), 0.0));
            aff_real m;
            etau = aff_robust_ff_lag_weighted(r, etau, sd);
            m = aff_min2(r->lag_margin * sd, r->lag_margin_max * etau);
            etau = aff_min2(etau + m, r->tau_max);
        }
    } else if (aff_robust_ff_estimate_in_use(r)) {
        r->n_lag_held = aff_count_up(r->n_lag_held);
        etau = r->ff.tau;
        r->held = 1;
    } else {
        r->n_implausible = aff_count_up(r->n_implausible);
        return 0;
    }
    if (r->provisional) { /* hand-over from the provisional start: fade from the start gain to 1 */
        r->provisional = 0;
        r->gain = r->start_gain;
    }
    aff_fixed_ff_set_estimate(&r->ff, eFc, eFs, est->Vs, est->delta, esig, etau, 1);
    for (i = 0; i < p; i++)
        r->theta_used[i] = x[i];
    return r->held ? 2 : 1;
}

int aff_robust_ff_observe(void *self, aff_real u, aff_real w_meas, aff_real *theta_out)
{
    aff_robust_ff *r = (aff_robust_ff *)self;
    aff_sliding *est = &r->est;
    const aff_rls *rls = &est->rls;
    long p = rls->p;
    long i;
    aff_sign_observer_step(&r->ff.ob, (aff_real)u, r->ff.u_out);
    aff_sliding_observe(est, (aff_real)u, (aff_real)w_meas);
    if (!est->updated)
        return 0;
    if (theta_out)
        for (i = 0; i < p; i++)
            theta_out[i] = rls->theta[i];
    if (rls->n_updates < r->warmup)
        return 1;
    aff_robust_ff_decide(r);
    return 1;
}

aff_real aff_robust_ff_rest_lag(void *self)
{
    return ((const aff_robust_ff *)self)->ff.alpha;
}

const aff_compensator_ops aff_robust_ff_ops = {"adaptive", aff_robust_ff_compensate, aff_robust_ff_observe, NULL, NULL,
                                               aff_robust_ff_rest_lag};
