/* aff_dob.c -- the disturbance observer (see aff_dob.h). */
#include <stddef.h>
#include <string.h>
#include "aff_dob.h"

aff_dob_config aff_dob_default_config(void)
{
    aff_dob_config c;
    c.Tc = (aff_real)1e-3;
    c.J_n = 0;
    c.omega_q = (aff_real)500.0;
    c.order = 2;
    c.d_max = (aff_real)INFINITY;
    c.u_range = aff_range_gate_default_config();
    c.w_range = aff_range_gate_default_config();
    return c;
}

aff_error aff_dob_check_config(const aff_dob_config *cfg)
{
    aff_error e;
    if (cfg == NULL)
        return AFF_ERR_NULL;
    if (!aff_positive(cfg->Tc))
        return AFF_ERR_DOB_TC;
    if (!aff_positive(cfg->J_n))
        return AFF_ERR_DOB_J_N;
    if (!aff_positive(cfg->omega_q))
        return AFF_ERR_DOB_OMEGA_Q;
    if (cfg->order < 1 || cfg->order > AFF_DOB_ORDER_MAX)
        return AFF_ERR_DOB_ORDER;
    if (!aff_nonnegative_or_inf(cfg->d_max))
        return AFF_ERR_DOB_D_MAX;
    if ((e = aff_range_gate_check_config(&cfg->u_range)) != AFF_OK)
        return e;
    return aff_range_gate_check_config(&cfg->w_range);
}

aff_error aff_dob_init(aff_dob *d, const aff_dob_config *cfg)
{
    aff_error e = d == NULL ? AFF_ERR_NULL : aff_dob_check_config(cfg);
    if (e != AFF_OK)
        return e;
    memset(d, 0, sizeof *d);
    d->Tc = cfg->Tc;
    d->J_n = cfg->J_n;
    d->omega_q = cfg->omega_q;
    d->order = cfg->order;
    d->a = (aff_real)1.0 - AFF_EXP(-cfg->Tc * cfg->omega_q);
    d->d_max = cfg->d_max;
    aff_range_gate_init(&d->u_range, &cfg->u_range);
    aff_range_gate_init(&d->w_range, &cfg->w_range);
    d->d_hat = 0;
    d->u_last = 0;
    d->w_last = 0;
    d->has_w_last = 0;
    d->n_rejected = 0;
    for (long i = 0; i < AFF_DOB_ORDER_MAX; i++)
        d->x[i] = 0;
    return AFF_OK;
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
