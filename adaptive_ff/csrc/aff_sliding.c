/* aff_sliding.c -- the sliding-regime estimator (see aff_sliding.h). */
#include <string.h>
#include "aff_sliding.h"
#include "plant_stribeck.h"

/* E|second difference|/sigma for white noise: sqrt(6)*sqrt(2/pi) (the double nearest, as Python computes it). */
static const aff_real NOISE_GAIN = (aff_real)1.9544100476116797;
/* the near-zero band in noise standard deviations */
static const aff_real BAND_SIGMAS = 4.0;

int aff_sliding_init(aff_sliding *e, aff_real Vs, aff_real delta, aff_real a, aff_real T, long m, long settle,
                     aff_real w_band_min, aff_real dwell_max, aff_real e2_rate, int lag, int offset,
                     const aff_gate *gate, const aff_range_gate *u_range, const aff_range_gate *w_range,
                     const aff_rls *rls)
{
    if (rls->p != 4 + 2 * (lag != 0) + (offset != 0))
        return -1;
    memset(e, 0, sizeof *e);
    e->Vs = Vs;
    e->delta = delta;
    e->a = a;
    e->T = T;
    e->m = m;
    e->settle = settle;
    e->w_band_min = w_band_min;
    e->dwell_max = dwell_max;
    e->e2_rate = e2_rate;
    e->lag = lag != 0;
    e->offset = offset != 0;
    e->p = rls->p;
    e->gate = *gate;
    e->u_range = *u_range;
    e->w_range = *w_range;
    e->rls = *rls;
    return 0;
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
    long n = r->p;
    long i, j;
    aff_real acc = 0;
    for (i = 0; i < n; i++) {
        aff_real row = 0;
        for (j = 0; j < n; j++)
            row += r->P[i * n + j] * phi[j];
        acc += phi[i] * row;
    }
    return acc > 0 ? acc : (aff_real)0.0;
}

int aff_sliding_observe(aff_sliding *e, aff_real u, aff_real w)
{
    int uok, wok;
    aff_real band, nb, aw, gg, hh, dz, a, T, s, err;
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
        e->d2 += (aff_real)0.01 * ((dd >= 0 ? dd : -dd) - e->d2);
    }
    e->w2 = e->w1;
    e->w1 = w;
    e->n_acc = aff_count_up(e->n_acc);
    band = e->w_band_min;
    nb = BAND_SIGMAS * e->d2 / NOISE_GAIN;
    if (nb > band)
        band = nb;
    aw = w >= 0 ? w : -w;
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
    T = e->T;
    j = 0;
    e->phi[j++] = (e->xw[1] - e->xw[2]) / T;
    if (e->lag) {
        e->phi[j] = (e->xw[0] - (aff_real)2.0 * e->xw[1] + e->xw[2]) / (T * T);
        e->phi[j + 1] = -(e->xu[1] - e->xu[2]) / T;
        j += 2;
    }
    e->phi[j] = e->xg[2];
    e->phi[j + 1] = e->xh[2];
    e->phi[j + 2] = e->xw[2];
    j += 3;
    if (e->offset)
        e->phi[j] = 1.0;
    s = phi_P_phi(&e->rls, e->phi); /* before the update: the a-priori error's variance is e2*(1 + s) */
    err = aff_rls_update(&e->rls, e->phi, e->xu[2]);
    if (err != err) /* refused by the RLS (an update that would overflow): counted there, nothing else changes */
        return 1;
    e->e2 += e->e2_rate * (err * err / ((aff_real)1.0 + s) - e->e2);
    e->updated = 1;
    return 1;
}
