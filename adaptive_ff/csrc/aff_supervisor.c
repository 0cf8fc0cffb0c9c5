/* aff_supervisor.c -- the feedforward supervisor (see aff_supervisor.h). */
#include <stddef.h>
#include <string.h>
#include "aff_supervisor.h"

aff_real aff_dob_raw(aff_real u_last, aff_real J_n, aff_real w, aff_real w_last, aff_real Tc)
{
    return u_last - J_n * (w - w_last) / Tc;
}

aff_real aff_lag_step(aff_real *x, aff_real a, aff_real input)
{
    *x += a * (input - *x);
    return *x;
}

aff_supervisor_config aff_supervisor_default_config(void)
{
    aff_supervisor_config c;
    c.Tc = (aff_real)1e-3;
    c.J_n = 0;
    c.omega = 0;
    c.window = (aff_real)2.0;
    c.margin = (aff_real)0.1;
    c.settle = -1;
    c.rest_band = 0;
    c.delay = 0;
    c.Kp = 0;
    c.Ki = 0;
    c.track_margin = (aff_real)1.0;
    return c;
}

aff_error aff_supervisor_check_config(const aff_supervisor_config *cfg)
{
    if (cfg == NULL)
        return AFF_ERR_NULL;
    if (!aff_positive(cfg->Tc))
        return AFF_ERR_SUPERVISOR_TC;
    if (!aff_positive(cfg->J_n))
        return AFF_ERR_SUPERVISOR_J_N;
    if (!aff_positive(cfg->omega))
        return AFF_ERR_SUPERVISOR_OMEGA;
    if (!aff_positive(cfg->window))
        return AFF_ERR_SUPERVISOR_WINDOW;
    if (!(cfg->margin >= 0 && cfg->margin < 1))
        return AFF_ERR_SUPERVISOR_MARGIN;
    if (!isfinite(cfg->settle))
        return AFF_ERR_SUPERVISOR_SETTLE;
    if (!(isfinite(cfg->rest_band) && cfg->rest_band >= -1))
        return AFF_ERR_SUPERVISOR_REST_BAND;
    if (cfg->delay < 0 || cfg->delay > AFF_SUPERVISOR_DELAY_MAX)
        return AFF_ERR_SUPERVISOR_DELAY;
    if (!(isfinite(cfg->Kp) && cfg->Kp >= 0))
        return AFF_ERR_SUPERVISOR_KP;
    if (!(isfinite(cfg->Ki) && cfg->Ki >= 0))
        return AFF_ERR_SUPERVISOR_KI;
    if (!(isfinite(cfg->track_margin) && cfg->track_margin >= 0))
        return AFF_ERR_SUPERVISOR_TRACK_MARGIN;
    return AFF_OK;
}

aff_error aff_supervisor_init(aff_supervisor *s, const aff_supervisor_config *cfg)
{
    aff_error e = s == NULL ? AFF_ERR_NULL : aff_supervisor_check_config(cfg);
    if (e != AFF_OK)
        return e;
    aff_real Tc = cfg->Tc, omega = cfg->omega, window = cfg->window;
    aff_real settle = cfg->settle < 0 ? (aff_real)0.5 * window : cfg->settle;
    memset(s, 0, sizeof *s);
    s->Tc = Tc;
    s->J_n = cfg->J_n;
    s->omega = omega;
    s->window = window;
    s->margin = cfg->margin;
    s->settle = settle;
    s->rest_band = cfg->rest_band;
    s->rest = 0;
    s->n_still = 0;
    s->n_rest = 0;
    s->delay = cfg->delay;
    s->a = (aff_real)1.0 - AFF_EXP(-Tc * omega);
    s->b = (aff_real)1.0 - AFF_EXP(-Tc / window);
    const aff_real big = (aff_real)1e9; /* bounded: a 32-bit long holds it (never reached in practice) */
    aff_real ns = AFF_CEIL((aff_real)5.0 / (omega * Tc));
    aff_real nd = AFF_FLOOR(settle / Tc + (aff_real)0.5);
    s->n_start = (long)(ns < big ? ns : big);
    aff_real nh = AFF_CEIL((aff_real)1.0 / (omega * Tc));
    s->n_hold = nh < 2 ? 2 : (long)(nh < big ? nh : big);
    s->n_decide = s->n_start + (long)(nd < big ? nd : big);
    s->on = 1;
    s->applied_on = 1;
    s->transfer = 0;
    s->u_c = 0;
    s->rest_alpha = 1;
    s->u_applied = 0;
    s->w_last = 0;
    s->has_w_last = 0;
    s->x_f = 0;
    s->x_r = 0;
    s->m_f = 0;
    s->m_r = 0;
    s->n = 0;
    s->n_backoff = 0;
    s->n_restore = 0;
    s->n_off = 0;
    s->n_skipped = 0;
    s->track = cfg->Kp > 0;
    s->track_margin = cfg->track_margin;
    s->keep = (aff_real)1.0 - cfg->margin;
    s->track_keep = (aff_real)1.0 + cfg->track_margin;
    s->Kp = cfg->Kp;
    s->KiTc = cfg->Ki * Tc;
    s->TcJ = Tc / cfg->J_n;
    s->y_a = 0;
    s->I_a = 0;
    s->y_c = 0;
    s->I_c = 0;
    s->m_e0 = 0;
    s->m_e1 = 0;
    s->n_backoff_tracking = 0;
    s->pos = 0;
    for (long i = 0; i <= AFF_SUPERVISOR_DELAY_MAX; i++) {
        s->u_hist[i] = 0;
        s->c_hist[i] = 0;
    }
    return AFF_OK;
}

aff_real aff_supervisor_apply(aff_supervisor *s, aff_real u_c, aff_real w_ref)
{
    int still = AFF_FABS((aff_real)w_ref) <= s->rest_band;
    s->n_still = still ? (s->n_still < s->n_hold ? s->n_still + 1 : s->n_hold) : 0;
    s->rest = s->n_still >= s->n_hold;
    s->u_c = (aff_real)u_c;
    s->w_ref = w_ref;
    s->transfer = 0;
    if (s->rest) {
        s->n_rest = aff_count_up(s->n_rest);
        aff_real alpha = s->rest_alpha; /* the decay factor worked out here, the only place that reads it */
        s->u_applied *= alpha >= 0 && alpha <= 1 ? 1 - alpha : 0;
        return s->u_applied;
    }
    if (s->on != s->applied_on) {
        s->transfer = s->on ? -s->u_c : s->u_c;
        s->applied_on = s->on;
    }
    s->u_applied = s->on ? s->u_c : 0;
    return s->u_applied;
}

void aff_supervisor_set_rest_lag(aff_supervisor *s, aff_real alpha)
{
    s->rest_alpha = alpha;
}

/* One period of the nominal loop's response to an added torque d (N*m): the PI on the error -y (its integrator
 * first, as the loop's PI), then the inertia J_n over Tc; y the velocity (rad/s), I the integrator (N*m). */
static void loop_model_step(aff_real *y, aff_real *I, aff_real Kp, aff_real KiTc, aff_real TcJ, aff_real d)
{
    aff_real e = -*y;
    *I += KiTc * e;
    *y += TcJ * (Kp * e + *I + d);
}

void aff_supervisor_observe(aff_supervisor *s, aff_real u, aff_real w)
{
    aff_real uu = (aff_real)u;
    aff_real ww = (aff_real)w;
    int64_t k = s->n; /* this period's index, from 0 (INT64_MAX once s->n saturated) */
    s->n = aff_count_up(s->n);
    if (!s->on && !s->rest)
        s->n_off = aff_count_up(s->n_off);
    if (!isfinite(uu) || !isfinite(ww)) {
        s->n_skipped = aff_count_up(s->n_skipped);
        return;
    }
    /* ring of the last delay+1 torques: slot pos holds u(k-1-d), the oldest */
    long len = s->delay + 1;
    aff_real u_old = s->u_hist[s->pos];
    aff_real c_old = s->c_hist[s->pos];
    s->u_hist[s->pos] = uu;
    s->c_hist[s->pos] = s->u_c;
    s->pos = s->pos + 1 < len ? s->pos + 1 : 0;
    if (!s->has_w_last) {
        s->w_last = ww;
        s->has_w_last = 1;
        return;
    }
    aff_real v = aff_dob_raw(u_old, s->J_n, ww, s->w_last, s->Tc);
    s->w_last = ww;
    aff_real f = aff_lag_step(&s->x_f, s->a, v);
    aff_real r = aff_lag_step(&s->x_r, s->a, v - c_old);
    /* the tracking test: the velocity error the nominal loop makes from the disturbance v without the compensation,
     * e0 = G[v], and with the candidate, e1 = G[v - u_c] = e0 - G[u_c] (two loop models, v and the candidate as
     * their inputs) */
    aff_real e0 = 0, e1 = 0;
    if (s->track) {
        loop_model_step(&s->y_a, &s->I_a, s->Kp, s->KiTc, s->TcJ, v);
        loop_model_step(&s->y_c, &s->I_c, s->Kp, s->KiTc, s->TcJ, c_old);
        e0 = s->y_a;
        e1 = s->y_a - s->y_c;
    }
    if (k < s->n_start || s->rest)
        return;
    aff_lag_step(&s->m_f, s->b, f * f);
    aff_lag_step(&s->m_r, s->b, r * r);
    if (s->track) {
        aff_lag_step(&s->m_e0, s->b, e0 * e0);
        aff_lag_step(&s->m_e1, s->b, e1 * e1);
    }
    if (k < s->n_decide)
        return;
    aff_real keep = s->keep;
    int worse_torque = s->m_r > s->m_f;
    int worse_tracking = s->track && s->m_e1 > s->track_keep * s->m_e0;
    if (s->on && (worse_torque || worse_tracking)) {
        if (!worse_torque)
            s->n_backoff_tracking = aff_count_up(s->n_backoff_tracking);
        s->on = 0;
        s->n_backoff = aff_count_up(s->n_backoff);
    } else if (!s->on && s->m_r < keep * s->m_f && (!s->track || s->m_e1 < keep * s->m_e0)
               && (!isfinite(s->w_ref) || (ww * s->w_ref > 0 && AFF_FABS(ww) >= (aff_real)0.5 * AFF_FABS(s->w_ref)))) {
        s->on = 1;
        s->n_restore = aff_count_up(s->n_restore);
    }
}

void aff_supervisor_run(aff_supervisor *s, const aff_real *u_c, const aff_real *w_ref, const aff_real *u,
                        const aff_real *w, long n, aff_real *applied, aff_real *f_hat, aff_real *r_hat, aff_real *m_f,
                        aff_real *m_r, int *on)
{
    for (long k = 0; k < n; k++) {
        aff_real y = aff_supervisor_apply(s, u_c[k], w_ref[k]);
        if (applied != NULL)
            applied[k] = y;
        aff_supervisor_observe(s, u[k], w[k]);
        if (f_hat != NULL)
            f_hat[k] = (aff_real)s->x_f;
        if (r_hat != NULL)
            r_hat[k] = (aff_real)s->x_r;
        if (m_f != NULL)
            m_f[k] = (aff_real)s->m_f;
        if (m_r != NULL)
            m_r[k] = (aff_real)s->m_r;
        if (on != NULL)
            on[k] = s->on;
    }
}
