/* aff_adaptive.c -- mode "adaptive" as one component (see aff_adaptive.h). */
#include <stddef.h>
#include "aff_adaptive.h"

void aff_adaptive_init(aff_adaptive *a, const aff_robust_ff *ff, const aff_residual *res, const aff_supervisor *sup)
{
    a->ff = *ff;
    a->use_residual = res != NULL;
    if (res != NULL)
        a->res = *res;
    a->use_supervisor = sup != NULL;
    if (sup != NULL)
        a->sup = *sup;
    a->w_ctrl = 0;
    a->transfer = 0;
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
