/* aff_residual.c -- the disturbance observer on the residual, its switch-in and the bound (see aff_residual.h). */
#include <math.h>
#include <stddef.h>
#include <string.h>
#include "aff_residual.h"

aff_switch_in_config aff_switch_in_default_config(void)
{
    aff_switch_in_config c;
    c.Tc = (aff_real)1e-3;
    c.J_n = 0;
    c.Kp = 0;
    c.Ki = 0;
    c.window = (aff_real)2.0;
    c.ratio = (aff_real)0.1;
    c.share = (aff_real)0.1;
    c.fade_in = (aff_real)0.5;
    c.trial_margin = (aff_real)0.03;
    return c;
}

aff_residual_config aff_residual_default_config(void)
{
    aff_residual_config c;
    c.u_max = (aff_real)INFINITY;
    c.dob = aff_dob_default_config();
    c.use_switch_in = 1;
    c.switch_in = aff_switch_in_default_config();
    c.crossover = 0;
    c.slew_time = (aff_real)0.4;
    return c;
}

/* The checks of the switch-in's settings. */
static aff_error switch_in_check(const aff_switch_in_config *c)
{
    if (!aff_positive(c->Tc))
        return AFF_ERR_SWITCH_IN_TC;
    if (!aff_positive(c->J_n))
        return AFF_ERR_SWITCH_IN_J_N;
    if (!aff_positive(c->Kp))
        return AFF_ERR_SWITCH_IN_KP;
    if (!aff_nonnegative(c->Ki))
        return AFF_ERR_SWITCH_IN_KI;
    if (!aff_positive(c->window))
        return AFF_ERR_SWITCH_IN_WINDOW;
    if (!aff_positive(c->ratio))
        return AFF_ERR_SWITCH_IN_RATIO;
    if (!aff_positive(c->share))
        return AFF_ERR_SWITCH_IN_SHARE;
    if (!aff_nonnegative(c->fade_in))
        return AFF_ERR_SWITCH_IN_FADE_IN;
    if (!aff_nonnegative_or_inf(c->trial_margin))
        return AFF_ERR_SWITCH_IN_TRIAL_MARGIN;
    return AFF_OK;
}

/* Configure the switch-in s from *cfg (checked) and clear its state (g = 0, not switched in). */
static void switch_in_init(aff_switch_in *s, const aff_switch_in_config *cfg)
{
    aff_real Tc = cfg->Tc, window = cfg->window, fade_in = cfg->fade_in;
    s->Tc = Tc;
    s->J_n = cfg->J_n;
    s->Kp = cfg->Kp;
    s->Ki = cfg->Ki;
    s->KiTc = cfg->Ki * Tc;
    s->TcJ = Tc / cfg->J_n;
    s->ratio = cfg->ratio;
    s->share = cfg->share;
    s->margin = cfg->trial_margin;
    s->b = (aff_real)1.0 - AFF_EXP(-Tc / window);
    s->fade = fade_in > Tc ? Tc / fade_in : (aff_real)1.0;
    aff_real ne = AFF_FLOOR(window / Tc + (aff_real)0.5);
    /* bounded: 5*n_evidence fits a 32-bit long */
    ne = ne < 1 ? (aff_real)1 : (ne > (aff_real)1e8 ? (aff_real)1e8 : ne);
    s->n_evidence = (long)ne;
    s->n_wait = 5 * s->n_evidence;
    s->w_l = 0;
    s->I_l = 0;
    s->w_r = 0;
    s->I_r = 0;
    s->w_f = 0;
    s->I_f = 0;
    s->m_f = 0;
    s->m_r = 0;
    s->c_f = 0;
    s->c_r = 0;
    s->m_l = 0;
    s->m_e = 0;
    s->v_e = 0;
    s->v_l = 0;
    s->ratio_in = (aff_real)INFINITY;
    s->n_trial = 0;
    s->decided = 0;
    s->k_out = -1;
    s->n = 0;
    s->n_used = 0;
    s->k_in = -1;
    s->rest_last = 0;
    s->g = 0;
}

aff_error aff_residual_check_config(const aff_residual_config *cfg)
{
    aff_error e;
    if (cfg == NULL)
        return AFF_ERR_NULL;
    if (!aff_nonnegative_or_inf(cfg->u_max))
        return AFF_ERR_RESIDUAL_U_MAX;
    if ((e = aff_dob_check_config(&cfg->dob)) != AFF_OK)
        return e;
    if (!aff_flag(cfg->use_switch_in))
        return AFF_ERR_RESIDUAL_USE_SWITCH_IN;
    if (!aff_nonnegative(cfg->crossover))
        return AFF_ERR_RESIDUAL_CROSSOVER;
    if (!aff_nonnegative(cfg->slew_time))
        return AFF_ERR_RESIDUAL_SLEW_TIME;
    return cfg->use_switch_in ? switch_in_check(&cfg->switch_in) : AFF_OK;
}

aff_error aff_residual_init(aff_residual *r, const aff_residual_config *cfg)
{
    aff_error e = r == NULL ? AFF_ERR_NULL : aff_residual_check_config(cfg);
    if (e != AFF_OK)
        return e;
    memset(r, 0, sizeof *r);
    r->u_max = cfg->u_max;
    r->u_ff = 0;
    r->held = 0;
    r->n_held = 0;
    r->use_switch_in = cfg->use_switch_in;
    if (cfg->use_switch_in) {
        switch_in_init(&r->sw, &cfg->switch_in);
    } else { /* the observer always applied */
        r->sw.g = 1;
        r->sw.k_in = -1;
        r->sw.k_out = -1;
        r->sw.decided = 0;
    }
    aff_dob_init(&r->dob, &cfg->dob);
    r->slew = cfg->slew_time * cfg->crossover * r->dob.a; /* 0: no limit */
    r->ff_peak = 0;
    r->d_app = 0;
    return AFF_OK;
}

/* One period of the loop model's response to a disturbance torque d (N*m): the velocity w it adds (rad/s) and the
 * PI integrator I (N*m), I -= Ki*Tc*w, w += Tc/J_n*(-Kp*w + I - d) (header comment); returns w before the step. */
static aff_real disturbance_step(const aff_switch_in *s, aff_real *w, aff_real *I, aff_real d)
{
    aff_real w0 = *w;
    *I -= s->KiTc * w0;
    *w += s->TcJ * (-s->Kp * w0 + *I - d);
    return w0;
}

void aff_switch_in_rises(const aff_switch_in *s, aff_real *rise_r, aff_real *rise_f)
{
    aff_real x_r = s->m_r - 2 * s->c_r, x_f = s->m_f - 2 * s->c_f; /* what each raises the loop's mean square by */
    *rise_r = x_r > s->m_r ? x_r : s->m_r;                           /* the cross terms only where they add */
    *rise_f = x_f > s->m_f ? x_f : s->m_f;
}

int aff_switch_in_fires(const aff_switch_in *s)
{
    aff_real rise_r, rise_f;
    aff_switch_in_rises(s, &rise_r, &rise_f);
    return (rise_r > s->ratio * s->m_l || rise_r > s->share * rise_f) && s->m_e > s->m_l;
}

/* One period of the frictionless loop model on the reference w_ref (finite): returns its error e_l before the step
 * (header comment). */
static aff_real frictionless_step(aff_switch_in *s, aff_real w_ref)
{
    aff_real e_l = (aff_real)w_ref - s->w_l;
    s->I_l += s->KiTc * e_l;
    s->w_l += s->TcJ * (s->Kp * e_l + s->I_l);
    return e_l;
}

/* The trial's means over a period in which the reference moves: v_e of the measured error, v_l of the frictionless
 * loop's error e_l; a non-finite w_ctrl enters neither. Returns 1 if the period entered them. */
static int trial_means(aff_switch_in *s, aff_real e_l, aff_real w_ref, aff_real w_ctrl)
{
    aff_real e_m = (aff_real)w_ref - (aff_real)w_ctrl;
    if (!isfinite(e_m))
        return 0;
    aff_lag_step(&s->v_e, s->b, e_m * e_m);
    aff_lag_step(&s->v_l, s->b, e_l * e_l);
    return 1;
}

/* The share g rises by fade per period to 1; the period it reaches 1 the trial's means start again from 0. */
static void fade_in_step(aff_switch_in *s)
{
    s->g = s->g + s->fade < 1 ? s->g + s->fade : (aff_real)1.0;
    if (s->g >= 1) {
        s->v_e = 0;
        s->v_l = 0;
        s->n_trial = 0;
    }
}

/* The share g falls by fade per period to 0 (the observer out, as it came in). */
static void fade_out_step(aff_switch_in *s)
{
    s->g = s->g > s->fade ? s->g - s->fade : (aff_real)0.0;
}

/* A period after the switch-in, k its index (header comment, "The trial"); a switch-in without a trial is decided
 * at once. */
static aff_real trial_step(aff_switch_in *s, aff_real w_ref, aff_real w_ctrl, int rest, int64_t k)
{
    if (s->k_out >= 0) {
        fade_out_step(s);
        return (aff_real)s->g;
    }
    if (s->decided) {
        if (s->g < 1)
            fade_in_step(s);
        return (aff_real)s->g;
    }
    if (!isfinite(w_ref))
        return (aff_real)s->g;
    aff_real e_l = frictionless_step(s, w_ref);
    if (s->g < 1) {
        fade_in_step(s);
        return (aff_real)s->g;
    }
    if (!rest && trial_means(s, e_l, w_ref, w_ctrl))
        s->n_trial = aff_count_up(s->n_trial);
    if (s->n_trial >= 2 * s->n_evidence) {
        s->decided = 1;
        if (s->v_e > (1 + s->margin) * s->ratio_in * s->v_l) { /* the loop tracks worse with the observer */
            s->k_out = k;
            fade_out_step(s);
        }
    }
    return (aff_real)s->g;
}

aff_real aff_switch_in_step(aff_switch_in *s, aff_real u_ff, aff_real d_hat, aff_real w_ref, aff_real w_ctrl,
                            int acting, int started)
{
    int64_t k = s->n; /* this period's index, from 0 (INT64_MAX once s->n saturated) */
    s->n = aff_count_up(s->n);
    int still = w_ref == 0;
    int rest = still && s->rest_last;
    s->rest_last = still;
    if (s->k_in >= 0)
        return trial_step(s, w_ref, w_ctrl, rest, k);
    if (!isfinite(d_hat) || !isfinite(u_ff) || !isfinite(w_ref))
        return 0;
    aff_real e_l = frictionless_step(s, w_ref); /* the frictionless loop on the reference */
    aff_real w_r = disturbance_step(s, &s->w_r, &s->I_r, (aff_real)d_hat); /* the residual's */
    aff_real w_f = disturbance_step(s, &s->w_f, &s->I_f, (aff_real)(u_ff + d_hat)); /* the whole estimate's */
    int late = started && k >= s->n_wait - 1; /* the start map has acted alone for 5*T: its evidence from now */
    if ((acting || late) && !rest) {
        aff_lag_step(&s->m_f, s->b, w_f * w_f);
        aff_lag_step(&s->m_r, s->b, w_r * w_r);
        aff_lag_step(&s->m_l, s->b, e_l * e_l);
        aff_lag_step(&s->c_f, s->b, e_l * w_f);
        aff_lag_step(&s->c_r, s->b, e_l * w_r);
        aff_real e_m = (aff_real)w_ref - (aff_real)w_ctrl; /* the loop's measured error */
        if (isfinite(e_m))
            aff_lag_step(&s->m_e, s->b, e_m * e_m);
        s->n_used = aff_count_up(s->n_used);
    }
    if (!rest)
        trial_means(s, e_l, w_ref, w_ctrl);
    int residual = s->n_used >= 2 * s->n_evidence && aff_switch_in_fires(s);
    int idle = s->n_used == 0 && k >= s->n_wait - 1 && !started;
    if (residual || idle) {
        s->k_in = k;
        int marginal = !idle && s->m_e <= (1 + s->ratio) * s->m_l; /* at most ratio to gain: on trial */
        s->ratio_in = s->v_l > 0 && marginal ? s->v_e / s->v_l : (aff_real)INFINITY;
        s->decided = !isfinite(s->ratio_in); /* no trial: the observer stays */
        s->g = 0;
        fade_in_step(s);
    }
    return (aff_real)s->g;
}

/* The slew limit (header comment): the peak |u_ff| so far takes this period's u_ff (a non-finite one is left out);
 * once it is above 0 the applied estimate d_app moves toward the observer's d by at most slew*ff_peak (N*m), before
 * it d_app = d. Returns d_app; without the limit (slew 0) or for a non-finite d, d itself (d_app as it was). */
static aff_real slew_step(aff_residual *r, aff_real u_ff, aff_real d)
{
    if (!(r->slew > 0) || !isfinite(d))
        return d;
    aff_real m = AFF_FABS(u_ff);
    if (isfinite(m) && m > r->ff_peak)
        r->ff_peak = m;
    aff_real step = r->slew * r->ff_peak, x = d - r->d_app;
    r->d_app = !(step > 0) ? d : r->d_app + (x > step ? step : (x < -step ? -step : x));
    return r->d_app;
}

aff_real aff_residual_compensate(aff_residual *r, aff_real u_ff, int acting, int started, aff_real w_ctrl,
                                 aff_real w_meas, aff_real w_ref)
{
    aff_real d = slew_step(r, u_ff, aff_dob_compensate(&r->dob, w_ctrl, w_meas, w_ref));
    aff_real g = r->use_switch_in ? aff_switch_in_step(&r->sw, u_ff, d, w_ref, w_ctrl, acting, started)
                                : (aff_real)1;
    if (r->held && w_ctrl * w_ref > 0) /* the joint moves in the reference's direction: the hold ends */
        r->held = 0;
    aff_real out;
    if (r->held) {
        r->n_held = aff_count_up(r->n_held);
        r->u_ff = g > 0 ? 0 : u_ff; /* not applied; before the switch-in the residual as at rest */
        out = g > 0 ? g * d : 0;
    } else {
        r->u_ff = (aff_real)u_ff;
        out = g > 0 ? u_ff + g * d : u_ff; /* before the switch-in exactly the feedforward */
    }
    aff_real lim = (aff_real)r->u_max;
    aff_real y = -lim > out ? -lim : out; /* Python's min(max(out, -lim), lim) */
    return lim < y ? lim : y;
}

void aff_residual_observe(aff_residual *r, aff_real u, aff_real w_meas, aff_real *theta_out)
{
    aff_dob_observe(&r->dob, u - (aff_real)r->u_ff, w_meas, theta_out);
}

void aff_residual_at_rest(aff_residual *r)
{
    if (r->held && r->n_held < INT64_MAX)
        r->n_held -= 1; /* this period is a rest, not a hold (a saturated count stays at the maximum) */
    if (!r->use_switch_in || r->sw.g > 0)
        r->u_ff = 0;
    r->held = 1;
}

