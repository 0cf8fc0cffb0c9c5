/* aff_ivrls.c -- recursive instrumental variables (see aff_ivrls.h). */
#include "aff_ivrls.h"

int aff_ivrls_init(aff_ivrls *r, long p, aff_real lam, aff_real P_max, aff_real P0, int guard)
{
    long i, k;
    if (p < 1 || p > AFF_IVRLS_NMAX)
        return -1;
    r->p = p;
    r->lam = lam;
    r->P_max = P_max;
    r->guard = guard != 0;
    for (i = 0; i < AFF_IVRLS_NMAX; i++) {
        r->theta[i] = 0;
        r->v[i] = 0;
        r->q[i] = 0;
    }
    for (k = 0; k < AFF_IVRLS_NMAX * AFF_IVRLS_NMAX; k++)
        r->P[k] = 0;
    for (i = 0; i < p; i++)
        r->P[i * p + i] = P0;
    r->n_updates = 0;
    r->n_rejected = 0;
    return 0;
}

aff_real aff_ivrls_step(aff_ivrls *r, const aff_real *phi, const aff_real *z, aff_real y)
{
    long p = r->p;
    long i, j;
    aff_real *P = r->P;
    aff_real *v = r->v;
    aff_real *q = r->q;
    aff_real e = y;
    aff_real rr = 0, vv = 0, qq = 0, s, div = 1.0, g;
    for (i = 0; i < p; i++)
        e -= phi[i] * r->theta[i];
    /* v = P z, q = P' phi and phi'P z, then the guards: the state is not touched before them */
    for (i = 0; i < p; i++) {
        aff_real acc = 0, acc2 = 0;
        for (j = 0; j < p; j++) {
            acc += P[i * p + j] * z[j];
            acc2 += P[j * p + i] * phi[j];
        }
        v[i] = acc;
        q[i] = acc2;
        rr += phi[i] * acc;
        vv += acc * acc;
        qq += acc2 * acc2;
    }
    s = r->lam + rr;
    if (!(isfinite(e * e) && isfinite(s) && isfinite(vv) && isfinite(qq)) || !(s > 0)
        || (r->guard && !(rr >= 0))) {
        r->n_rejected++;
        return NAN;
    }
    if (r->lam < (aff_real)1.0) {
        aff_real tr1 = 0;
        for (i = 0; i < p; i++)
            tr1 += P[i * p + i] - (v[i] * q[i]) / s;
        if (tr1 / r->lam <= r->P_max)
            div = r->lam;
        else /* covariance bound reached: this update forgets nothing */
            s = (aff_real)1.0 + rr;
    }
    for (i = 0; i < p; i++) {
        for (j = 0; j < p; j++) {
            aff_real x = P[i * p + j] - (v[i] * q[j]) / s;
            if (div != (aff_real)1.0)
                x = x / div;
            P[i * p + j] = x;
        }
    }
    g = e / s;
    for (i = 0; i < p; i++)
        r->theta[i] += v[i] * g;
    r->n_updates++;
    return e;
}

/* 0 iff y, phi[0..p-1] and z[0..p-1] are all finite (x*0 is NaN exactly for NaN/inf). */
static int ivrls_nonfinite(const aff_real *phi, const aff_real *z, aff_real y, long p)
{
    aff_real chk = y * (aff_real)0.0;
    long i;
    for (i = 0; i < p; i++)
        chk += phi[i] * (aff_real)0.0 + z[i] * (aff_real)0.0;
    return chk != 0;
}

aff_real aff_ivrls_update(aff_ivrls *r, const aff_real *phi, const aff_real *z, aff_real y)
{
    if (ivrls_nonfinite(phi, z, y, r->p)) {
        r->n_rejected++;
        return NAN;
    }
    return aff_ivrls_step(r, phi, z, y);
}

long aff_ivrls_update_many(aff_ivrls *r, const aff_real *Phi, const aff_real *Z, const aff_real *Y, long n,
                           aff_real *hist)
{
    long p = r->p;
    long k, i;
    for (k = 0; k < n; k++) {
        if (ivrls_nonfinite(Phi + k * p, Z + k * p, Y[k], p))
            return k;
    }
    for (k = 0; k < n; k++) {
        aff_ivrls_step(r, Phi + k * p, Z + k * p, Y[k]);
        for (i = 0; i < p; i++)
            hist[k * p + i] = r->theta[i];
    }
    return -1;
}
