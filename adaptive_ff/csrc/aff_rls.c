/* aff_rls.c -- recursive least squares (see aff_rls.h). */
#include <stddef.h>
#include <string.h>
#include "aff_rls.h"

aff_rls_config aff_rls_default_config(void)
{
    aff_rls_config c;
    c.n_params = 1;
    c.forgetting = AFF_RLS_EXPONENTIAL;
    c.lam = 1;
    c.P0 = (aff_real)1e4;
    c.P_max = 0;
    return c;
}

aff_error aff_rls_check_config(const aff_rls_config *cfg)
{
    int scheme;
    if (cfg == NULL)
        return AFF_ERR_NULL;
    scheme = cfg->forgetting;
    if (cfg->n_params < 1 || cfg->n_params > AFF_RLS_NMAX)
        return AFF_ERR_RLS_N_PARAMS;
    if (scheme != AFF_RLS_EXPONENTIAL && scheme != AFF_RLS_DIRECTIONAL && scheme != AFF_RLS_VECTOR)
        return AFF_ERR_RLS_FORGETTING;
    if (scheme != AFF_RLS_VECTOR && !(cfg->lam > 0 && cfg->lam <= 1))
        return AFF_ERR_RLS_LAM;
    if (!aff_positive(cfg->P0))
        return AFF_ERR_RLS_P0;
    if (!(cfg->P_max == 0 || aff_positive_or_inf(cfg->P_max)))
        return AFF_ERR_RLS_P_MAX;
    return AFF_OK;
}

aff_error aff_rls_init(aff_rls *r, const aff_rls_config *cfg)
{
    long i, k, p;
    int scheme;
    aff_real trace;
    aff_error e = r == NULL ? AFF_ERR_NULL : aff_rls_check_config(cfg);
    if (e != AFF_OK)
        return e;
    p = cfg->n_params;
    scheme = cfg->forgetting;
    trace = cfg->P0; /* trace(P0*I), summed in order (numpy's trace) */
    for (i = 1; i < p; i++)
        trace += cfg->P0;
    memset(r, 0, sizeof *r);
    r->p = p;
    r->scheme = scheme;
    r->lam = scheme == AFF_RLS_VECTOR ? (aff_real)1.0 : cfg->lam;
    r->P_max = cfg->P_max == 0 ? trace : cfg->P_max;
    r->has_bounds = 0;
    for (i = 0; i < AFF_RLS_NMAX; i++) {
        r->lower[i] = -(aff_real)INFINITY;
        r->upper[i] = (aff_real)INFINITY;
        r->theta[i] = 0;
        r->v[i] = 0;
    }
    for (k = 0; k < AFF_RLS_NMAX * AFF_RLS_NMAX; k++) {
        r->D[k] = 1;
        r->UD[k] = 0;
    }
    for (i = 0; i < p; i++)
        r->UD[i * p + i] = cfg->P0; /* P = P0*I: U = I, d = P0 */
    r->n_updates = 0;
    r->n_projected = 0;
    r->n_rejected = 0;
    return AFF_OK;
}

/* GCC, Clang: rls_step and the factor updates inlined into each of aff_rls_step's calls, its p then a constant
 * where the call names one. */
#if defined(__GNUC__)
#define AFF_RLS_INLINE __attribute__((always_inline))
#else
#define AFF_RLS_INLINE
#endif

/* Entry (i, j) of P = U diag(d) U' (either order; (i, j) and (j, i) give the same number): with a <= b,
 * P_ab = U_ab d_b + sum_{k>b} U_ak d_k U_bk (U_bb = 1). */
static inline AFF_RLS_INLINE aff_real ud_entry(const aff_real *UD, long p, long i, long j)
{
    long a = i < j ? i : j;
    long b = i < j ? j : i;
    long k;
    aff_real x = a == b ? UD[b * p + b] : UD[a * p + b] * UD[b * p + b];
    for (k = b + 1; k < p; k++)
        x += UD[a * p + k] * (UD[k * p + k] * UD[b * p + k]);
    return x;
}

/* trace(S P S) with S^2 = diag(D) (D NULL: trace(P)), column by column: sum_k d_k (D_kk + sum_{i<k} D_ii U_ik^2). */
static inline AFF_RLS_INLINE aff_real ud_trace(const aff_real *UD, const aff_real *D, long p)
{
    long i, k;
    aff_real tr = 0;
    for (k = 0; k < p; k++) {
        aff_real col = D == NULL ? (aff_real)1.0 : D[k * p + k];
        for (i = 0; i < k; i++)
            col += (D == NULL ? UD[i * p + k] : D[i * p + i] * UD[i * p + k]) * UD[i * p + k];
        tr += UD[k * p + k] * col;
    }
    return tr;
}

/* The gain's pieces for the regressor phi: g = diag(d) U' phi; *vv = |U g|^2 (= |P phi|^2); returns
 * (U' phi)'g (= phi'P phi). */
static inline AFF_RLS_INLINE aff_real ud_gain(const aff_real *UD, const aff_real *phi, aff_real *g, aff_real *vv,
                                              long p)
{
    long i, j;
    aff_real rr = 0, sum = 0;
    for (j = 0; j < p; j++) {
        aff_real f = phi[j];
        for (i = 0; i < j; i++)
            f += UD[i * p + j] * phi[i];
        g[j] = UD[j * p + j] * f;
        rr += f * g[j];
    }
    for (i = 0; i < p; i++) {
        aff_real x = g[i];
        for (j = i + 1; j < p; j++)
            x += UD[i * p + j] * g[j];
        sum += x * x;
    }
    *vv = sum;
    return rr;
}

/* Bierman's measurement update of the factors of P (Bierman 1977, Sec. V.3, with a weight alpha in place of the
 * measurement variance) followed by the division by div:
 *   P <- (P - (P phi)(P phi)'/(alpha + phi'P phi))/div,
 * alpha != 0 with alpha + phi'P phi of alpha's sign (alpha < 0: the directional scheme's information removal);
 * k: ud_gain's g of phi for these factors on entry, P phi (of the P before the update) on return. */
static inline AFF_RLS_INLINE void ud_update(aff_real *UD, const aff_real *phi, aff_real *k, aff_real alpha,
                                            aff_real div, long p)
{
    long i, j;
    aff_real b = alpha;
    for (j = 0; j < p; j++) {
        aff_real f = phi[j], g = k[j], b_prev = b, mu;
        for (i = 0; i < j; i++) /* (U' phi)_j: column j is not yet updated */
            f += UD[i * p + j] * phi[i];
        b = b + f * g;
        UD[j * p + j] = UD[j * p + j] * (b_prev / (b * div)); /* b_prev/b <= 1 for alpha > 0: no overflow */
        mu = -f / b_prev;
        for (i = 0; i < j; i++) {
            aff_real t = UD[i * p + j];
            UD[i * p + j] = t + k[i] * mu;
            k[i] = k[i] + t * g;
        }
    }
}

aff_error aff_rls_set_P(aff_rls *r, const aff_real *P)
{
    aff_real UD[AFF_RLS_NMAX * AFF_RLS_NMAX];
    long p, i, j, k;
    if (r == NULL || P == NULL)
        return AFF_ERR_NULL;
    p = r->p;
    for (k = 0; k < p * p; k++) {
        UD[k] = 0;
        if (!isfinite(P[k]))
            return AFF_ERR_RLS_P;
    }
    for (i = 0; i < p; i++)
        for (j = i + 1; j < p; j++)
            if (P[i * p + j] != P[j * p + i])
                return AFF_ERR_RLS_P;
    for (j = p - 1; j >= 0; j--) { /* U D U' = P, column by column from the last (Bierman 1977, Sec. III.2) */
        aff_real dj = P[j * p + j];
        for (k = j + 1; k < p; k++)
            dj -= UD[k * p + k] * UD[j * p + k] * UD[j * p + k];
        if (!(dj > 0 && isfinite(dj)))
            return AFF_ERR_RLS_P;
        UD[j * p + j] = dj;
        for (i = 0; i < j; i++) {
            aff_real x = P[i * p + j];
            for (k = j + 1; k < p; k++)
                x -= UD[k * p + k] * UD[i * p + k] * UD[j * p + k];
            UD[i * p + j] = x / dj;
        }
    }
    memcpy(r->UD, UD, sizeof(aff_real) * (size_t)(p * p));
    return AFF_OK;
}

aff_error aff_rls_set_lam_each(aff_rls *r, const aff_real *lam)
{
    long p, i, j;
    if (r == NULL || lam == NULL)
        return AFF_ERR_NULL;
    if (r->scheme != AFF_RLS_VECTOR)
        return AFF_ERR_RLS_FORGETTING;
    p = r->p;
    for (i = 0; i < p; i++)
        if (!(lam[i] > 0 && lam[i] <= 1))
            return AFF_ERR_RLS_LAM_EACH;
    for (i = 0; i < p; i++) { /* d_i*d_j, each d a power of its own (no array of d on a drive's stack) */
        aff_real di = AFF_POW(lam[i], (aff_real)-0.5);
        for (j = 0; j < p; j++)
            r->D[i * p + j] = di * AFF_POW(lam[j], (aff_real)-0.5);
    }
    return AFF_OK;
}

/* How far theta[i] lies outside [lower[i], upper[i]] (0 inside). */
static aff_real violation(const aff_rls *r, long i)
{
    aff_real t = r->theta[i];
    aff_real a = r->lower[i] - t;
    aff_real b = t - r->upper[i];
    return (a > 0 ? a : (aff_real)0.0) + (b > 0 ? b : (aff_real)0.0);
}

/* Project theta onto the box in the metric of P^-1: for the most violated bound (violation over the standard
 * deviation sqrt(P_ii)) theta -= P[:, i]*(theta_i - b_i)/P_ii, at most p times, then a final clip; counts
 * the projection. P is not changed. */
static void project(aff_rls *r)
{
    long p = r->p;
    long i, j, it;
    int any_viol = 0;
    for (i = 0; i < p; i++) {
        if (violation(r, i) != 0) {
            any_viol = 1;
            break;
        }
    }
    if (!any_viol)
        return;
    r->n_projected = aff_count_up(r->n_projected);
    for (it = 0; it < p; it++) {
        aff_real best = -1.0;
        long ib = -1;
        aff_real t, b, c;
        for (i = 0; i < p; i++) {
            aff_real vi = violation(r, i);
            if (vi != 0) {
                aff_real q = vi / AFF_SQRT(ud_entry(r->UD, p, i, i));
                if (ib < 0 || q > best) {
                    best = q;
                    ib = i;
                }
            }
        }
        if (ib < 0)
            break;
        t = r->theta[ib];
        b = t < r->lower[ib] ? r->lower[ib] : r->upper[ib];
        c = (t - b) / ud_entry(r->UD, p, ib, ib);
        for (j = 0; j < p; j++)
            r->theta[j] = r->theta[j] - ud_entry(r->UD, p, j, ib) * c;
        r->theta[ib] = b;
    }
    for (i = 0; i < p; i++) {
        aff_real t = r->theta[i];
        if (t < r->lower[i])
            r->theta[i] = r->lower[i];
        else if (t > r->upper[i])
            r->theta[i] = r->upper[i];
    }
}

/* The usual number of parameters (the sliding estimator with the lag and the offset): a step with this p has its
 * loops of known length (unrolled by the compiler; the same operations in the same order). */
#define AFF_RLS_P_USUAL 7

/* Count a refused sample (its update would overflow; the state is untouched) and return NAN. */
static aff_real refuse(aff_rls *r)
{
    r->n_rejected = aff_count_up(r->n_rejected);
    return (aff_real)NAN;
}

/* aff_rls_step with p = r->p. */
static inline AFF_RLS_INLINE aff_real rls_step(aff_rls *r, const aff_real *phi, aff_real y, long p)
{
    long i, j;
    int scheme = r->scheme;
    aff_real lam = r->lam;
    aff_real P_max = r->P_max;
    aff_real *UD = r->UD;
    aff_real k[AFF_RLS_NMAX]; /* diag(d) U' phi, then P phi */
    aff_real e = y;
    aff_real rr, vv, gain, s;
    for (i = 0; i < p; i++)
        e -= phi[i] * r->theta[i];
    /* the overflow guard: the state is not touched before it */
    if (scheme == AFF_RLS_VECTOR) {
        /* inflate P <- D.P = S P S (unless that exceeds the trace bound), then a unit-weight update; guard:
         * phi'(S P S)phi <= trace(S P S)|phi|^2, |S P S phi|^2 <= trace(S P S)^2 |phi|^2 */
        aff_real trD = ud_trace(UD, r->D, p);
        aff_real phi2 = 0;
        for (i = 0; i < p; i++)
            phi2 += phi[i] * phi[i];
        if (!(isfinite(e * e) && isfinite(trD * phi2) && isfinite((trD * phi2) * trD)))
            return refuse(r);
        if (trD <= P_max) { /* U <- S U S^-1, d <- S^2 d */
            for (j = 0; j < p; j++) {
                aff_real djj = r->D[j * p + j];
                for (i = 0; i < j; i++)
                    UD[i * p + j] = UD[i * p + j] * (r->D[i * p + j] / djj);
                UD[j * p + j] = UD[j * p + j] * djj;
            }
        }
        rr = ud_gain(UD, phi, k, &vv, p);
        s = (aff_real)1.0 + rr;
        ud_update(UD, phi, k, (aff_real)1.0, (aff_real)1.0, p);
        gain = e / s;
    } else {
        rr = ud_gain(UD, phi, k, &vv, p);
        if (!(isfinite(e * e) && isfinite(rr) && isfinite(vv)))
            return refuse(r);
        if (scheme == AFF_RLS_EXPONENTIAL) {
            aff_real div = (aff_real)1.0;
            s = lam + rr;
            if (lam < (aff_real)1.0) {
                aff_real tr = ud_trace(UD, NULL, p);
                if (!isfinite(tr / lam)) /* the factors d/lam would overflow */
                    return refuse(r);
                if ((tr - vv / s) / lam <= P_max) /* trace(P) after the update */
                    div = lam;
                else /* covariance bound reached: this update forgets nothing (ordinary RLS step) */
                    s = (aff_real)1.0 + rr;
            }
            ud_update(UD, phi, k, div, div, p); /* s = div + phi'P phi */
            gain = e / s;
        } else { /* directional forgetting */
            aff_real beta = rr > 0 ? lam - ((aff_real)1.0 - lam) / rr : (aff_real)1.0;
            aff_real den = (aff_real)1.0 + beta * rr;
            if (beta < 0) {
                /* trace after the update: trace(P) - beta*|P phi|^2/den; over the bound -> no forgetting */
                aff_real tr1 = ud_trace(UD, NULL, p) - beta * vv / den;
                if (!isfinite(tr1))
                    return refuse(r);
                if (tr1 > P_max) {
                    beta = (aff_real)1.0;
                    den = (aff_real)1.0 + rr;
                }
            }
            /* P - beta/(1 + beta*rr) (P phi)(P phi)' = P - (P phi)(P phi)'/(1/beta + rr); beta = 0 (or a
             * 1/beta beyond the range) changes nothing */
            if (beta != 0 && isfinite((aff_real)1.0 / beta)) {
                ud_update(UD, phi, k, (aff_real)1.0 / beta, (aff_real)1.0, p);
            } else { /* P unchanged: P phi = U g */
                for (i = 0; i < p; i++) {
                    aff_real x = k[i];
                    for (j = i + 1; j < p; j++)
                        x += UD[i * p + j] * k[j];
                    k[i] = x;
                }
            }
            gain = e / den; /* theta += P_new phi e */
        }
    }
    for (i = 0; i < p; i++) {
        r->v[i] = k[i];
        r->theta[i] += k[i] * gain;
    }
    if (r->has_bounds)
        project(r);
    r->n_updates = aff_count_up(r->n_updates);
    return e;
}

aff_real aff_rls_step(aff_rls *r, const aff_real *phi, aff_real y)
{
    if (r->p == AFF_RLS_P_USUAL)
        return rls_step(r, phi, y, AFF_RLS_P_USUAL);
    return rls_step(r, phi, y, r->p);
}

/* 0 iff y and phi[0..p-1] are all finite (x*0 is NaN exactly for NaN/inf). */
static int nonfinite(const aff_real *phi, aff_real y, long p)
{
    aff_real chk = y * (aff_real)0.0;
    long i;
    for (i = 0; i < p; i++)
        chk += phi[i] * (aff_real)0.0;
    return chk != 0;
}

aff_real aff_rls_update(aff_rls *r, const aff_real *phi, aff_real y)
{
    if (nonfinite(phi, y, r->p)) {
        r->n_rejected = aff_count_up(r->n_rejected);
        return (aff_real)NAN;
    }
    return aff_rls_step(r, phi, y);
}

long aff_rls_update_many(aff_rls *r, const aff_real *Phi, const aff_real *Y, long n, aff_real *hist)
{
    long p = r->p;
    long k, i;
    for (k = 0; k < n; k++) {
        if (nonfinite(Phi + k * p, Y[k], p))
            return k;
    }
    for (k = 0; k < n; k++) {
        aff_rls_step(r, Phi + k * p, Y[k]);
        for (i = 0; i < p; i++)
            hist[k * p + i] = r->theta[i];
    }
    return -1;
}

aff_real aff_rls_P(const aff_rls *r, long i, long j)
{
    return ud_entry(r->UD, r->p, i, j);
}

void aff_rls_cov(const aff_rls *r, aff_real *P)
{
    long p = r->p;
    long i, j;
    for (j = 0; j < p; j++) {
        for (i = 0; i <= j; i++) {
            aff_real x = ud_entry(r->UD, p, i, j);
            P[i * p + j] = x;
            P[j * p + i] = x;
        }
    }
}

aff_real aff_rls_quad(const aff_rls *r, const aff_real *x)
{
    aff_real g[AFF_RLS_NMAX], vv;
    return ud_gain(r->UD, x, g, &vv, r->p); /* (U' x)' diag(d) (U' x) */
}

aff_real aff_rls_prior_variance(const aff_rls *r)
{
    return r->P_max / (aff_real)r->p;
}
