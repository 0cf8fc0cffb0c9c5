/* aff_drive.c -- the adaptive friction feedforward for a drive's velocity loop (see aff_drive.h). */
#include "aff_drive.h"

void aff_init(aff *c, const aff_robust_ff *initial)
{
    c->ff = *initial;
}

aff_real aff_step(aff *c, aff_real w_meas, aff_real w_ref)
{
    return aff_step_gated(c, w_meas, w_meas, w_ref);
}

aff_real aff_step_gated(aff *c, aff_real w_ctrl, aff_real w_meas, aff_real w_ref)
{
    return (aff_real)aff_robust_ff_compensate(&c->ff, (double)w_ctrl, (double)w_meas, (double)w_ref);
}

int aff_observe(aff *c, aff_real u, aff_real w_meas)
{
    long n_rejected = c->ff.est.n_rejected;
    aff_robust_ff_observe(&c->ff, (double)u, (double)w_meas, (double *)0);
    return c->ff.est.n_rejected == n_rejected;
}

int aff_active(const aff *c)
{
    return c->ff.ff.has != 0;
}

int aff_estimate(const aff *c, aff_real *Fc, aff_real *Fs, aff_real *sigma, aff_real *tau)
{
    const aff_fixed_ff *f = &c->ff.ff;
    if (!f->has || c->ff.provisional)
        return 0;
    if (Fc)
        *Fc = f->Fc;
    if (Fs)
        *Fs = f->Fc + f->dF;
    if (sigma)
        *sigma = f->sigma;
    if (tau)
        *tau = f->tau;
    return 1;
}

long aff_n_updates(const aff *c)
{
    return c->ff.est.rls.n_updates;
}

long aff_n_rejected(const aff *c)
{
    return c->ff.est.n_rejected;
}

void aff_replay(aff *c, const double *u, const double *w, const double *w_ref, double *uff, long n)
{
    for (long k = 0; k < n; k++) {
        uff[k] = (double)aff_step(c, (aff_real)w[k], (aff_real)w_ref[k]);
        aff_observe(c, (aff_real)u[k], (aff_real)w[k]);
    }
}
