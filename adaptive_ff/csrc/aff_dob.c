/* aff_dob.c -- the disturbance observer (see aff_dob.h). */
#include <stddef.h>
#include "aff_dob.h"

int aff_dob_init(aff_dob *d, aff_real Tc, aff_real J_n, aff_real omega_q, long order, aff_real d_max)
{
    if (order < 1 || order > AFF_DOB_ORDER_MAX)
        return -1;
    d->Tc = Tc;
    d->J_n = J_n;
    d->omega_q = omega_q;
    d->order = order;
    d->a = (aff_real)1.0 - AFF_EXP(-Tc * omega_q);
    d->d_max = d_max;
    aff_range_gate_init(&d->u_range, (aff_real)INFINITY, (aff_real)100.0, (aff_real)0.0,
                        AFF_EXP((aff_real)-1.0 / (aff_real)10000.0), 20);
    d->w_range = d->u_range;
    d->d_hat = 0;
    d->u_last = 0;
    d->w_last = 0;
    d->has_w_last = 0;
    d->n_rejected = 0;
    for (long i = 0; i < AFF_DOB_ORDER_MAX; i++)
        d->x[i] = 0;
    return 0;
}

aff_real aff_dob_compensate(void *self, aff_real w_ctrl, aff_real w_meas, aff_real w_ref)
{
    aff_dob *d = (aff_dob *)self;
    aff_real w = (aff_real)w_ctrl;
    (void)w_meas;
    (void)w_ref;
    int ok = aff_range_gate_ok(&d->w_range, w);
    aff_range_gate_commit(&d->w_range, w, ok);
    if (!ok) {
        d->n_rejected = aff_count_up(d->n_rejected);
        return d->d_hat;
    }
    if (!d->has_w_last) {
        d->w_last = w;
        d->has_w_last = 1;
        return d->d_hat;
    }
    aff_real v = aff_dob_raw(d->u_last, d->J_n, w, d->w_last, d->Tc);
    d->w_last = w;
    for (long i = 0; i < d->order; i++)
        v = aff_lag_step(&d->x[i], d->a, v);
    aff_real dmax = d->d_max;
    aff_real y = -dmax > v ? -dmax : v;
    d->d_hat = dmax < y ? dmax : y;
    return d->d_hat;
}

int aff_dob_observe(void *self, aff_real u, aff_real w_meas, aff_real *theta_out)
{
    aff_dob *d = (aff_dob *)self;
    aff_real uu = (aff_real)u;
    (void)w_meas;
    (void)theta_out;
    int ok = aff_range_gate_ok(&d->u_range, uu);
    aff_range_gate_commit(&d->u_range, uu, ok);
    if (ok)
        d->u_last = uu;
    else
        d->n_rejected = aff_count_up(d->n_rejected);
    return 0;
}

const aff_compensator_ops aff_dob_ops = {"dob", aff_dob_compensate, aff_dob_observe, NULL, NULL, NULL};
