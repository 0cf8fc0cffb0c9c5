/* aff_feedforward.c -- the fixed friction feedforward (see aff_feedforward.h). */
#include <string.h>
#include "aff_feedforward.h"
#include "plant_stribeck.h"

void aff_fixed_ff_init(aff_fixed_ff *f, aff_real dt, int lag, aff_real ff_max, aff_real sign_width,
                       aff_real stick_band, long stick_samples, int at_ref, aff_real w_max,
                       const aff_loop_model *lm, const aff_sign_observer *ob)
{
    memset(f, 0, sizeof *f);
    f->dt = dt;
    f->lag = lag;
    f->ff_max = ff_max;
    f->sign_width = sign_width;
    f->stick_band = stick_band;
    f->stick_samples = stick_samples;
    f->at_ref = at_ref;
    f->w_max = w_max;
    if (lm)
        f->lm = *lm;
    if (ob)
        f->ob = *ob;
    f->alpha = 1.0;
}

void aff_fixed_ff_set_estimate(aff_fixed_ff *f, aff_real Fc, aff_real Fs, aff_real Vs, aff_real delta,
                               aff_real sigma, aff_real tau, int has_vs)
{
    f->has = 1;
    f->Fc = Fc;
    f->dF = Fs - Fc;
    f->Vs = Vs;
    f->delta = delta;
    f->sigma = sigma;
    f->tau = tau;
    f->has_vs = has_vs;
    f->alpha = (f->lag && tau > 0) ? (aff_real)1.0 - AFF_EXP(-f->dt / tau) : (aff_real)1.0;
}

aff_real aff_fixed_ff_static(const aff_fixed_ff *f, aff_real w)
{
    aff_real aw, mag, sw;
    if (w == 0 || !f->has)
        return 0.0;
    aw = AFF_FABS(w);
    if (f->has_vs) { /* the Stribeck level: eq. 3 at |w| without the viscous term */
        plant_stribeck m;
        m.Fc = f->Fc;
        m.dF = f->dF;
        m.Vs = f->Vs;
        m.delta = f->delta;
        m.sigma = 0.0;
        m.wcut = (aff_real)INFINITY;
        mag = plant_stribeck_eval(&m, aw);
    } else {
        mag = f->Fc;
    }
    sw = f->sign_width;
    if (sw > 0 && aw < sw)
        return mag * (w / sw) + f->sigma * w;
    return AFF_COPYSIGN(mag, w) + f->sigma * w;
}

static aff_real held(const aff_fixed_ff *f)
{
    return aff_min2(aff_max2(f->u_ff, -f->ff_max), f->ff_max);
}

aff_real aff_fixed_ff_step(aff_fixed_ff *f, aff_real w, aff_real w_ref, int has_ref)
{
    aff_real wmax = f->w_max;
    aff_real x, fx;
    int64_t nib;
    if (!(isfinite(w) && -wmax <= w && w <= wmax)
        || (has_ref && !(isfinite(w_ref) && -wmax <= w_ref && w_ref <= wmax))) {
        f->n_rejected = aff_count_up(f->n_rejected);
        return held(f);
    }
    x = w;
    nib = f->n_in_band;
    if (has_ref) {
        if (-f->stick_band < w && w < f->stick_band) {
            nib = aff_count_up(nib);
            if (nib >= f->stick_samples)
                x = w_ref;
        } else {
            nib = 0;
        }
    }
    fx = aff_fixed_ff_static(f, x);
    if (!isfinite(fx)) {
        f->n_rejected = aff_count_up(f->n_rejected);
        return held(f);
    }
    f->n_in_band = nib;
    f->u_ff += f->alpha * (fx - f->u_ff);
    return held(f);
}

aff_real aff_fixed_ff_at(aff_fixed_ff *f, aff_real w_ctrl, aff_real w_stuck, aff_real w_ref)
{
    if (f->at_ref)
        return aff_fixed_ff_step(f, w_ref, w_ref, 0);
    return aff_fixed_ff_step(f, aff_sign_observer_signed(&f->ob, w_ctrl, f->stick_band), w_stuck, 1);
}

aff_real aff_fixed_ff_start_output(aff_fixed_ff *f, aff_real w_ctrl, aff_real w_stuck, aff_real w_ref, int at_ref,
                                   aff_real gain)
{
    if (at_ref) {
        aff_sign_observer_signed(&f->ob, w_ctrl, f->stick_band);
        return aff_fixed_ff_step(f, w_ref, w_ref, 0) * gain;
    }
    return aff_fixed_ff_at(f, w_ctrl, w_stuck, w_ref) * gain;
}

aff_real aff_fixed_ff_compensate(void *self, aff_real w_ctrl, aff_real w_meas, aff_real w_ref)
{
    aff_fixed_ff *f = (aff_fixed_ff *)self;
    aff_real w_stuck = aff_loop_model_step(&f->lm, (aff_real)w_ctrl, (aff_real)w_ref);
    aff_real out = aff_fixed_ff_at(f, (aff_real)w_ctrl, w_stuck, (aff_real)w_ref);
    (void)w_meas;
    f->u_out = out;
    return out;
}

int aff_fixed_ff_observe(void *self, aff_real u, aff_real w_meas, aff_real *theta_out)
{
    aff_fixed_ff *f = (aff_fixed_ff *)self;
    (void)w_meas;
    (void)theta_out;
    aff_sign_observer_step(&f->ob, (aff_real)u, f->u_out);
    return 0;
}

const aff_compensator_ops aff_fixed_ff_ops = {"fixed", aff_fixed_ff_compensate, aff_fixed_ff_observe, NULL, NULL, NULL};

int aff_project_levels(aff_physical *e, aff_real tau_max, aff_real F_max)
{
    aff_real t;
    int fin = isfinite(e->J) && isfinite(e->tau) && isfinite(e->sigma) && isfinite(e->Fc) && isfinite(e->Fs)
              && isfinite(e->offset);
    if (!fin || e->J <= 0 || e->Fc > F_max || e->Fs > F_max)
        return 0;
    t = 0 > e->tau ? (aff_real)0.0 : e->tau; /* Python's max(tau, 0.0), then min(., tau_max) */
    t = tau_max < t ? tau_max : t;
    e->tau = t;
    e->sigma = 0 > e->sigma ? (aff_real)0.0 : e->sigma;
    e->Fc = 0 > e->Fc ? (aff_real)0.0 : e->Fc;
    e->Fs = 0 > e->Fs ? (aff_real)0.0 : e->Fs;
    return 1;
}
