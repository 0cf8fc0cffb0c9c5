/* ctl_canudas.c -- Canudas de Wit et al.'s adaptive friction compensation (see ctl_canudas.h). */
#include <math.h>
#include <stddef.h>

#include "ctl_canudas.h"

ctl_canudas_config ctl_canudas_default_config(void)
{
    ctl_canudas_config c;
    c.Tc = 0.001;
    c.Ts = 0.01;
    c.forgetting = AFF_RLS_DIRECTIONAL;
    c.lam = 0.999;
    c.P0 = 1e4;
    c.J_guess = 1;
    c.w_dead = 5e-3;
    c.warmup = 300;
    c.ff_max = INFINITY;
    c.ff_measured = 1;
    return c;
}

aff_error ctl_canudas_check_config(const ctl_canudas_config *cfg)
{
    if (cfg == NULL)
        return AFF_ERR_NULL;
    if (!aff_positive(cfg->Tc))
        return AFF_ERR_CANUDAS_TC;
    if (!aff_positive(cfg->Ts))
        return AFF_ERR_CANUDAS_TS;
    if (cfg->forgetting != AFF_RLS_DIRECTIONAL && cfg->forgetting != AFF_RLS_EXPONENTIAL)
        return AFF_ERR_CANUDAS_FORGETTING;
    if (!(cfg->lam > 0 && cfg->lam <= 1))
        return AFF_ERR_CANUDAS_LAM;
    if (!aff_positive(cfg->P0))
        return AFF_ERR_CANUDAS_P0;
    if (!aff_positive(cfg->J_guess))
        return AFF_ERR_CANUDAS_J_GUESS;
    if (!aff_nonnegative(cfg->w_dead))
        return AFF_ERR_CANUDAS_W_DEAD;
    if (cfg->warmup < 0)
        return AFF_ERR_CANUDAS_WARMUP;
    if (!aff_nonnegative_or_inf(cfg->ff_max))
        return AFF_ERR_CANUDAS_FF_MAX;
    if (!aff_flag(cfg->ff_measured))
        return AFF_ERR_CANUDAS_FF_MEASURED;
    return AFF_OK;
}

int ctl_canudas_init(ctl_canudas *c, aff_real Tc, long m, aff_real w_dead, long warmup, aff_real ff_max,
                     int ff_measured, int scheme, aff_real lam, aff_real P0, aff_real J_guess)
{
    aff_range_gate_config ug = aff_range_gate_default_config(); /* RangeGate() */
    aff_range_gate_config wg = ug;                               /* RangeGate(floor=w_dead) */
    aff_rls_config rc = aff_rls_default_config();
    wg.floor = w_dead;
    rc.n_params = 5;
    rc.forgetting = scheme;
    rc.lam = lam;
    rc.P0 = P0;
    rc.P_max = 0; /* trace(P0*I), P0 summed in order (numpy's trace) */
    if (m < 1 || aff_range_gate_check_config(&wg) != AFF_OK || aff_rls_check_config(&rc) != AFF_OK)
        return -1;
    c->Tc = Tc;
    c->Ts = (aff_real)m * Tc;
    c->m = m;
    c->w_dead = w_dead;
    c->warmup = warmup;
    c->ff_max = ff_max;
    c->ff_measured = ff_measured;
    aff_range_gate_init(&c->u_range, &ug);
    aff_range_gate_init(&c->w_range, &wg);
    aff_rls_init(&c->rls, &rc);
    c->rls.theta[0] = c->Ts / J_guess;
    c->rls.has_bounds = 1;
    for (int i = 0; i < 5; i++) {
        c->rls.lower[i] = i == 0 ? (aff_real)1e-12 : (aff_real)0.0;
        c->rls.upper[i] = (aff_real)INFINITY;
    }
    c->on = 0;
    c->Fc_pos = 0;
    c->Fc_neg = 0;
    c->sigma_pos = 0;
    c->sigma_neg = 0;
    c->k = 0;
    c->u_sum = 0;
    c->w_prev = 0;
    c->has_prev = 0;
    c->ok = 1;
    c->n_rejected = 0;
    c->phase = 0;
    return 0;
}

aff_real ctl_canudas_compensate(void *self, aff_real w_ctrl, aff_real w_meas, aff_real w_ref)
{
    const ctl_canudas *c = (const ctl_canudas *)self;
    (void)w_meas;
    if (!c->on)
        return 0.0;
    aff_real w = (aff_real)(c->ff_measured ? w_ctrl : w_ref);
    if (!isfinite(w))
        return 0.0;
    aff_real v;
    if (w > 0)
        v = c->Fc_pos + c->sigma_pos * w;
    else if (w < 0)
        v = -c->Fc_neg + c->sigma_neg * w;
    else
        v = 0;
    if (!isfinite(v)) /* a velocity so large that the map overflows: no compensation */
        return 0.0;
    aff_real lo = -c->ff_max;
    aff_real y = lo > v ? lo : v;
    return c->ff_max < y ? c->ff_max : y;
}

/* One RLS update on the interval w0 -> w1 with mean torque ubar if it lies beyond the dead zone; 1 when used. */
static int canudas_update(ctl_canudas *c, aff_real w0, aff_real w1, aff_real ubar)
{
    aff_real wd = c->w_dead;
    aff_real phi[5];
    if (w0 > wd && w1 > wd) {
        phi[0] = ubar;
        phi[1] = -w0;
        phi[2] = 0;
        phi[3] = -1;
        phi[4] = 0;
    } else if (w0 < -wd && w1 < -wd) {
        phi[0] = ubar;
        phi[1] = 0;
        phi[2] = -w0;
        phi[3] = 0;
        phi[4] = 1;
    } else {
        return 0;
    }
    int64_t n0 = c->rls.n_updates;
    aff_rls_update(&c->rls, phi, w1 - w0);
    int64_t n1 = c->rls.n_updates;
    if (n1 == n0) { /* a non-finite row (overflow of finite samples) is refused and counted */
        c->n_rejected++;
        return 0;
    }
    if (n1 >= c->warmup) {
        const aff_real *th = c->rls.theta;
        aff_real b = th[0];
        c->Fc_pos = th[3] / b;
        c->Fc_neg = th[4] / b;
        c->sigma_pos = th[1] / b;
        c->sigma_neg = th[2] / b;
        c->on = 1;
    }
    return 1;
}

int ctl_canudas_observe(void *self, aff_real u, aff_real w_meas, aff_real *theta_out)
{
    ctl_canudas *c = (ctl_canudas *)self;
    aff_real uu = (aff_real)u;
    aff_real w = (aff_real)w_meas;
    int uok = aff_range_gate_ok(&c->u_range, uu);
    int wok = aff_range_gate_ok(&c->w_range, w);
    if (!(uok && wok)) { /* a rejected sample counts in the failing gate(s) only */
        if (!uok)
            aff_range_gate_commit(&c->u_range, uu, 0);
        if (!wok)
            aff_range_gate_commit(&c->w_range, w, 0);
        c->n_rejected++;
        c->ok = 0;
        return 0;
    }
    aff_range_gate_commit(&c->u_range, uu, 1);
    aff_range_gate_commit(&c->w_range, w, 1);
    int upd = 0;
    if (c->phase == 0) { /* k % m == 0, kept as a counter (no integer division per period) */
        if (c->has_prev && c->ok)
            upd = canudas_update(c, c->w_prev, w, c->u_sum / (aff_real)c->m);
        c->w_prev = w;
        c->has_prev = 1;
        c->u_sum = 0;
        c->ok = 1;
    }
    c->u_sum += uu;
    c->k++;
    long ph = c->phase + 1;
    c->phase = ph >= c->m ? 0 : ph;
    if (upd && theta_out != NULL) {
        for (int i = 0; i < 5; i++)
            theta_out[i] = (double)c->rls.theta[i];
    }
    return upd;
}

const aff_compensator_ops ctl_canudas_ops = {"canudas", ctl_canudas_compensate, ctl_canudas_observe, NULL, NULL, NULL};
