/* aff_drive.c -- mode "adaptive" for a drive's velocity loop (see aff_drive.h). */
#include <stddef.h>
#include "aff_drive.h"

/* Keep what this period's aff_adaptive_compensate will change (aff_saved). */
static void guard_save(aff *c)
{
    c->saved.ff = c->mode.ff.ff;
    c->saved.gain = c->mode.ff.gain;
    c->saved.res = c->mode.res;
    c->saved.sup = c->mode.sup;
    c->saved.w_ctrl = c->mode.w_ctrl;
    c->saved.transfer = c->mode.transfer;
}

/* Put it back: the period is dropped. */
static void guard_restore(aff *c)
{
    c->mode.ff.ff = c->saved.ff;
    c->mode.ff.gain = c->saved.gain;
    c->mode.res = c->saved.res;
    c->mode.sup = c->saved.sup;
    c->mode.w_ctrl = c->saved.w_ctrl;
    c->mode.transfer = c->saved.transfer;
}

aff_guard_config aff_guard_default_config(void)
{
    aff_guard_config g;
    g.Tc = (aff_real)1e-3;
    g.w_max = (aff_real)1e4;
    g.u_max = (aff_real)1e6;
    g.hold_time = (aff_real)0.1;
    return g;
}

aff_config aff_default_config(void)
{
    aff_config c;
    c.mode = aff_adaptive_default_config();
    c.guard = aff_guard_default_config();
    return c;
}

aff_error aff_check_config(const aff_config *cfg)
{
    const aff_guard_config *g;
    const aff_adaptive_config *m;
    aff_real Tc;
    aff_error e;
    if (cfg == NULL)
        return AFF_ERR_NULL;
    g = &cfg->guard;
    m = &cfg->mode;
    if (!aff_positive(g->Tc))
        return AFF_ERR_GUARD_TC;
    if (!aff_positive(g->w_max))
        return AFF_ERR_GUARD_W_MAX;
    if (!aff_positive(g->u_max))
        return AFF_ERR_GUARD_U_MAX;
    if (!(isfinite(g->hold_time) && g->hold_time >= g->Tc))
        return AFF_ERR_GUARD_HOLD_TIME;
    if ((e = aff_adaptive_check_config(m)) != AFF_OK)
        return e;
    Tc = g->Tc;
    if (m->ff.ff.dt != Tc || m->ff.est.Tc != Tc
        || (m->use_residual && (m->res.dob.Tc != Tc || (m->res.use_switch_in && m->res.switch_in.Tc != Tc)))
        || (m->use_supervisor && m->sup.Tc != Tc))
        return AFF_ERR_DRIVE_TC;
    return AFF_OK;
}

aff_error aff_init(aff *c, const aff_config *cfg)
{
    aff_error e = c == NULL ? AFF_ERR_NULL : aff_check_config(cfg);
    if (e != AFF_OK)
        return e;
    aff_adaptive_init(&c->mode, &cfg->mode);
    guard_save(c);
    c->guard = cfg->guard;
    aff_real nh = AFF_FLOOR(c->guard.hold_time / c->guard.Tc + (aff_real)0.5);
    c->n_hold = nh < 1 ? 1u : (nh > (aff_real)4e9 ? 4000000000u : (uint32_t)nh);
    c->out = 0;
    c->fade_step = 0;
    c->dropped = 0;
    c->status.state = AFF_STATE_LEARNING;
    c->status.n_refused_w_meas = 0;
    c->status.n_refused_w_ref = 0;
    c->status.n_refused_u = 0;
    c->status.last_fault = AFF_INPUT_NONE;
    c->status.k_fault = 0;
    c->status.k = 0;
    c->status.n_held = 0;
    c->status.faded = 0;
    return AFF_OK;
}

/* 1 if x is a plausible sample: finite, not subnormal, |x| <= bound. */
static int guard_plausible(aff_real x, aff_real bound)
{
    return isfinite(x) && (x == 0 || isnormal(x)) && AFF_FABS(x) <= bound;
}

static uint32_t guard_count_up(uint32_t n)
{
    return n < UINT32_MAX ? n + 1u : n;
}

/* Count a refused sample of input which in the current period. */
static void guard_refuse(aff *c, aff_input which)
{
    aff_status_report *s = &c->status;
    if (which == AFF_INPUT_W_MEAS)
        s->n_refused_w_meas = guard_count_up(s->n_refused_w_meas);
    else if (which == AFF_INPUT_W_REF)
        s->n_refused_w_ref = guard_count_up(s->n_refused_w_ref);
    else
        s->n_refused_u = guard_count_up(s->n_refused_u);
    s->last_fault = which;
    s->k_fault = s->k > 0 ? s->k - 1 : 0; /* the period of the last aff_step */
}

/* The held output of a dropped period: the last output, after n_hold periods fading by fade_step per period. */
static aff_real guard_hold(aff *c)
{
    aff_status_report *s = &c->status;
    s->n_held = guard_count_up(s->n_held);
    if (s->n_held > c->n_hold) {
        if (!s->faded) {
            s->faded = 1;
            c->fade_step = AFF_FABS(c->out) / (aff_real)c->n_hold;
        }
        aff_real m = AFF_FABS(c->out) - c->fade_step;
        m = m > 0 ? m : (aff_real)0;
        c->out = c->out > 0 ? m : -m;
    }
    return c->out;
}

aff_real aff_step(aff *c, aff_real w_meas, aff_real w_ref)
{
    return aff_step_gated(c, w_meas, w_meas, w_ref);
}

aff_real aff_step_gated(aff *c, aff_real w_ctrl, aff_real w_meas, aff_real w_ref)
{
    c->status.k = c->status.k < UINT64_MAX ? c->status.k + 1u : c->status.k;
    aff_real b = c->guard.w_max;
    int bad_w = !guard_plausible(w_ctrl, b) || !guard_plausible(w_meas, b);
    int bad_ref = !guard_plausible(w_ref, b);
    if (bad_w || bad_ref) {
        if (bad_w)
            guard_refuse(c, AFF_INPUT_W_MEAS);
        if (bad_ref)
            guard_refuse(c, AFF_INPUT_W_REF);
        c->dropped = 1;
        return guard_hold(c);
    }
    c->dropped = 0;
    c->status.n_held = 0;
    c->status.faded = 0;
    guard_save(c);
    c->out = aff_adaptive_compensate(&c->mode, w_ctrl, w_meas, w_ref);
    return c->out;
}

aff_real aff_transfer(const aff *c)
{
    return c->dropped ? (aff_real)0 : c->mode.transfer;
}

/* The guard's half of aff_observe: 1 if the period is taken, else 0 (a refused input of this call, counted, the
 * state put back as before this period's aff_step; or a period aff_step already dropped). */
static int guard_take(aff *c, aff_real u, aff_real w_meas)
{
    if (c->dropped)
        return 0;
    int bad_u = !guard_plausible(u, c->guard.u_max);
    int bad_w = !guard_plausible(w_meas, c->guard.w_max);
    if (bad_u || bad_w) { /* drop the period: the state as before its aff_step */
        if (bad_u)
            guard_refuse(c, AFF_INPUT_U);
        if (bad_w)
            guard_refuse(c, AFF_INPUT_W_MEAS);
        guard_restore(c);
        c->dropped = 1;
        c->status.n_held = guard_count_up(c->status.n_held);
        return 0;
    }
    return 1;
}

int aff_observe(aff *c, aff_real u, aff_real w_meas)
{
    if (!guard_take(c, u, w_meas))
        return 0;
    aff_adaptive_observe(&c->mode, u, w_meas, NULL);
    return 1;
}

/* The drive's calls behind the compensator interface (aff_drive_ops). */
static aff_real drive_compensate(void *self, aff_real w_ctrl, aff_real w_meas, aff_real w_ref)
{
    return aff_step_gated((aff *)self, w_ctrl, w_meas, w_ref);
}

static int drive_observe(void *self, aff_real u, aff_real w_meas, aff_real *theta_out)
{
    aff *c = (aff *)self;
    if (!guard_take(c, u, w_meas))
        return 0;
    return aff_adaptive_observe(&c->mode, u, w_meas, theta_out);
}

static aff_real drive_transfer(void *self)
{
    return aff_transfer((const aff *)self);
}

const aff_compensator_ops aff_drive_ops = {"adaptive", drive_compensate, drive_observe, NULL, drive_transfer, NULL};

aff_status_report aff_status(const aff *c)
{
    aff_status_report s = c->status;
    const aff_adaptive *m = &c->mode;
    if (s.n_held > 0)
        s.state = AFF_STATE_FAULT;
    else if (m->use_supervisor && !m->sup.on)
        s.state = AFF_STATE_BACKED_OFF;
    else if (m->use_residual && (!m->res.use_switch_in || m->res.sw.g > 0))
        s.state = AFF_STATE_OBSERVER;
    else if (m->ff.ff.has)
        s.state = AFF_STATE_FEEDFORWARD;
    else
        s.state = AFF_STATE_LEARNING;
    return s;
}

int aff_active(const aff *c)
{
    return c->mode.ff.ff.has != 0;
}

int aff_estimate(const aff *c, aff_real *Fc, aff_real *Fs, aff_real *sigma, aff_real *tau)
{
    const aff_fixed_ff *f = &c->mode.ff.ff;
    if (!aff_robust_ff_estimate_in_use(&c->mode.ff))
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

int64_t aff_n_updates(const aff *c)
{
    return c->mode.ff.est.rls.n_updates;
}

int64_t aff_n_rejected(const aff *c)
{
    return c->mode.ff.est.n_rejected;
}

void aff_replay(aff *c, const aff_real *u, const aff_real *w, const aff_real *w_ctrl, const aff_real *w_ref,
                aff_real *uff, aff_real *transfer, long n)
{
    for (long k = 0; k < n; k++) {
        uff[k] = aff_step_gated(c, w_ctrl != NULL ? w_ctrl[k] : w[k], w[k], w_ref[k]);
        if (transfer != NULL)
            transfer[k] = aff_transfer(c);
        aff_observe(c, u[k], w[k]);
    }
}
