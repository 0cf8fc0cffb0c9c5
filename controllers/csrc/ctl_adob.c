/* ctl_adob.c -- adaptive feedforward plus disturbance observer on the residual (see ctl_adob.h). */
#include "ctl_adob.h"

void ctl_adob_init(ctl_adob *a, const aff_robust_ff *ff, const ctl_dob *dob, aff_real u_max)
{
    a->u_max = u_max;
    a->u_ff = 0;
    a->ff = *ff;
    a->dob = *dob;
}

double ctl_adob_compensate(void *self, double w_ctrl, double w_meas, double w_ref)
{
    ctl_adob *a = (ctl_adob *)self;
    double uff = aff_robust_ff_compensate(&a->ff, w_ctrl, w_meas, w_ref);
    a->u_ff = (aff_real)uff;
    double d = ctl_dob_compensate(&a->dob, w_ctrl, w_meas, w_ref);
    double out = uff + d;
    double lim = (double)a->u_max;
    double y = -lim > out ? -lim : out; /* Python's min(max(out, -lim), lim) */
    return lim < y ? lim : y;
}

int ctl_adob_observe(void *self, double u, double w_meas, double *theta_out)
{
    ctl_adob *a = (ctl_adob *)self;
    ctl_dob_observe(&a->dob, u - (double)a->u_ff, w_meas, theta_out);
    return aff_robust_ff_observe(&a->ff, u, w_meas, theta_out);
}

const aff_compensator_ops ctl_adob_ops = {"adaptive-dob", ctl_adob_compensate, ctl_adob_observe};
