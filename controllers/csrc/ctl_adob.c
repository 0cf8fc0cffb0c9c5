/* ctl_adob.c -- adaptive feedforward plus disturbance observer on the residual (see ctl_adob.h). */
#include "ctl_adob.h"

aff_error ctl_adob_init(ctl_adob *a, const aff_robust_ff *ff, const aff_residual_config *res)
{
    aff_error e = aff_residual_init(&a->res, res);
    if (e == AFF_OK)
        a->ff = *ff;
    return e;
}

aff_real ctl_adob_compensate(void *self, aff_real w_ctrl, aff_real w_meas, aff_real w_ref)
{
    ctl_adob *a = (ctl_adob *)self;
    double uff = aff_robust_ff_compensate(&a->ff, w_ctrl, w_meas, w_ref);
    return aff_residual_compensate(&a->res, uff, aff_robust_ff_estimate_in_use(&a->ff), a->ff.provisional, w_ctrl,
                                   w_meas, w_ref);
}

int ctl_adob_observe(void *self, aff_real u, aff_real w_meas, aff_real *theta_out)
{
    ctl_adob *a = (ctl_adob *)self;
    aff_residual_observe(&a->res, u, w_meas, theta_out);
    return aff_robust_ff_observe(&a->ff, u, w_meas, theta_out);
}

void ctl_adob_at_rest(void *self)
{
    aff_residual_at_rest(&((ctl_adob *)self)->res);
}

aff_real ctl_adob_rest_lag(void *self)
{
    return aff_robust_ff_rest_lag(&((ctl_adob *)self)->ff);
}

const aff_compensator_ops ctl_adob_ops = {"adaptive-dob", ctl_adob_compensate, ctl_adob_observe, ctl_adob_at_rest,
                                          NULL, ctl_adob_rest_lag};

aff_error ctl_eq4_dob_init(ctl_eq4_dob *a, const aff_eq4_ff *ff, const aff_residual_config *res)
{
    aff_error e = aff_residual_init(&a->res, res);
    if (e == AFF_OK)
        a->ff = *ff;
    return e;
}

aff_real ctl_eq4_dob_compensate(void *self, aff_real w_ctrl, aff_real w_meas, aff_real w_ref)
{
    ctl_eq4_dob *a = (ctl_eq4_dob *)self;
    double uff = aff_eq4_ff_compensate(&a->ff, w_ctrl, w_meas, w_ref);
    return aff_residual_compensate(&a->res, uff, a->ff.has_estimate, a->ff.provisional, w_ctrl, w_meas, w_ref);
}

int ctl_eq4_dob_observe(void *self, aff_real u, aff_real w_meas, aff_real *theta_out)
{
    ctl_eq4_dob *a = (ctl_eq4_dob *)self;
    aff_residual_observe(&a->res, u, w_meas, theta_out);
    return aff_eq4_ff_observe(&a->ff, u, w_meas, theta_out);
}

void ctl_eq4_dob_at_rest(void *self)
{
    aff_residual_at_rest(&((ctl_eq4_dob *)self)->res);
}

const aff_compensator_ops ctl_eq4_dob_ops = {"adaptive-dob", ctl_eq4_dob_compensate, ctl_eq4_dob_observe,
                                             ctl_eq4_dob_at_rest, NULL, NULL};
