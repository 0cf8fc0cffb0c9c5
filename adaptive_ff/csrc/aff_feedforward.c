/* aff_feedforward.c -- the fixed friction feedforward (see aff_feedforward.h). */
#include <stddef.h>
#include <string.h>
#include "aff_feedforward.h"
#include "plant_stribeck.h"

aff_fixed_ff_config aff_fixed_ff_default_config(void)
{
    aff_fixed_ff_config c;
    c.dt = (aff_real)1e-3;
    c.lag = 1;
    c.ff_max = (aff_real)INFINITY;
    c.sign_width = 0;
    c.stick_band = 0;
    c.stick_samples = 10;
    c.at_ref = 0;
    c.w_max = (aff_real)INFINITY;
    c.use_loop_model = 0;
    c.loop_model = aff_loop_model_default_config();
    c.use_sign_observer = 0;
    c.sign_observer = aff_sign_observer_default_config();
    return c;
}

aff_error aff_fixed_ff_check_config(const aff_fixed_ff_config *cfg)
{
    aff_error e;
    if (cfg == NULL)
        return AFF_ERR_NULL;
    if (!aff_positive(cfg->dt))
        return AFF_ERR_FIXED_FF_DT;
    if (!aff_flag(cfg->lag))
        return AFF_ERR_FIXED_FF_LAG;
    if (!aff_nonnegative_or_inf(cfg->ff_max))
        return AFF_ERR_FIXED_FF_FF_MAX;
    if (!aff_nonnegative(cfg->sign_width))
        return AFF_ERR_FIXED_FF_SIGN_WIDTH;
    if (!aff_nonnegative(cfg->stick_band))
        return AFF_ERR_FIXED_FF_STICK_BAND;
    if (cfg->stick_samples < 1)
        return AFF_ERR_FIXED_FF_STICK_SAMPLES;
    if (!aff_flag(cfg->at_ref))
        return AFF_ERR_FIXED_FF_AT_REF;
    if (!aff_positive_or_inf(cfg->w_max))
        return AFF_ERR_FIXED_FF_W_MAX;
    if (!aff_flag(cfg->use_loop_model))
        return AFF_ERR_FIXED_FF_USE_LOOP_MODEL;
    if (!aff_flag(cfg->use_sign_observer))
        return AFF_ERR_FIXED_FF_USE_SIGN_OBSERVER;
    if (cfg->use_loop_model && (e = aff_loop_model_check_config(&cfg->loop_model, cfg->dt)) != AFF_OK)
        return e;
    if (cfg->use_sign_observer && (e = aff_sign_observer_check_config(&cfg->sign_observer, cfg->dt)) != AFF_OK)
        return e;
    return AFF_OK;
}

aff_error aff_fixed_ff_init(aff_fixed_ff *f, const aff_fixed_ff_config *cfg)
{
    aff_error e = f == NULL ? AFF_ERR_NULL : aff_fixed_ff_check_config(cfg);
    if (e != AFF_OK)
        return e;
    memset(f, 0, sizeof *f);
    f->dt = cfg->dt;
    f->lag = cfg->lag;
    f->ff_max = cfg->ff_max;
    f->sign_width = cfg->sign_width;
    f->stick_band = cfg->stick_band;
    f->stick_samples = cfg->stick_samples;
    f->at_ref = cfg->at_ref;
    f->w_max = cfg->w_max;
    if (cfg->use_loop_model)
        aff_loop_model_init(&f->lm, &cfg->loop_model, cfg->dt);
    if (cfg->use_sign_observer)
        aff_sign_observer_init(&f->ob, &cfg->sign_observer, cfg->dt);
    f->alpha = 1.0;
    return AFF_OK;
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
