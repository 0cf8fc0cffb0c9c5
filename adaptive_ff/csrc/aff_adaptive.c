/* aff_adaptive.c -- mode "adaptive" as one component (see aff_adaptive.h). */
#include <stddef.h>
#include <string.h>
#include "aff_adaptive.h"

aff_adaptive_config aff_adaptive_default_config(void)
{
    aff_adaptive_config c;
    c.use_residual = 1;
    c.use_supervisor = 1;
    c.ff = aff_robust_ff_default_config();
    c.res = aff_residual_default_config();
    c.sup = aff_supervisor_default_config();
    return c;
}

aff_error aff_adaptive_check_config(const aff_adaptive_config *cfg)
{
    aff_error e;
    if (cfg == NULL)
        return AFF_ERR_NULL;
    if (!aff_flag(cfg->use_residual))
        return AFF_ERR_ADAPTIVE_USE_RESIDUAL;
    if (!aff_flag(cfg->use_supervisor))
        return AFF_ERR_ADAPTIVE_USE_SUPERVISOR;
    if ((e = aff_robust_ff_check_config(&cfg->ff)) != AFF_OK)
        return e;
    if (cfg->use_residual && (e = aff_residual_check_config(&cfg->res)) != AFF_OK)
        return e;
    if (!cfg->use_residual && !aff_nonnegative_or_inf(cfg->res.u_max))
        return AFF_ERR_RESIDUAL_U_MAX;
    if (cfg->use_supervisor && (e = aff_supervisor_check_config(&cfg->sup)) != AFF_OK)
        return e;
    return AFF_OK;
}

aff_error aff_adaptive_init(aff_adaptive *a, const aff_adaptive_config *cfg)
{
    aff_error e = a == NULL ? AFF_ERR_NULL : aff_adaptive_check_config(cfg);
    if (e != AFF_OK)
        return e;
    memset(a, 0, sizeof *a);
    a->use_residual = cfg->use_residual;
    a->use_supervisor = cfg->use_supervisor;
    aff_robust_ff_init(&a->ff, &cfg->ff);
    if (cfg->use_residual) {
        aff_residual_init(&a->res, &cfg->res);
    } else {
        a->res.u_max = cfg->res.u_max; /* reported only (AdaptiveCompensator.u_max) */
    }
    if (cfg->use_supervisor)
        aff_supervisor_init(&a->sup, &cfg->sup);
    a->w_ctrl = 0;
    a->transfer = 0;
    return AFF_OK;
}

aff_real aff_adaptive_compensate(void *self, aff_real w_ctrl, aff_real w_meas, aff_real w_ref)
{
    aff_adaptive *a = (aff_adaptive *)self;
    aff_real out = aff_robust_ff_compensate(&a->ff, w_ctrl, w_meas, w_ref);
    if (a->use_residual) {
        out = aff_residual_compensate(&a->res, out, aff_robust_ff_estimate_in_use(&a->ff), a->ff.provisional, w_ctrl,
                                      w_meas, w_ref);
    }
    a->w_ctrl = w_ctrl;
    a->transfer = 0;
    if (a->use_supervisor) {
        aff_supervisor_set_rest_lag(&a->sup, aff_robust_ff_rest_lag(&a->ff));
        out = aff_supervisor_apply(&a->sup, out, w_ref);
        a->transfer = a->sup.transfer;
        if (a->sup.rest && a->use_residual) /* nothing applied: the observer is told (aff_residual_at_rest) */
            aff_residual_at_rest(&a->res);
    }
    return out;
}

int aff_adaptive_observe(void *self, aff_real u, aff_real w_meas, aff_real *theta_out)
{
    aff_adaptive *a = (aff_adaptive *)self;
    if (a->use_residual)
        aff_residual_observe(&a->res, u, w_meas, theta_out);
    int updated = aff_robust_ff_observe(&a->ff, u, w_meas, theta_out);
    if (a->use_supervisor)
        aff_supervisor_observe(&a->sup, u, a->w_ctrl);
    return updated;
}

aff_real aff_adaptive_transfer(void *self)
{
    return ((const aff_adaptive *)self)->transfer;
}

const aff_compensator_ops aff_adaptive_ops = {"adaptive", aff_adaptive_compensate, aff_adaptive_observe, NULL,
                                              aff_adaptive_transfer, NULL}; /* its supervisor is its own */
