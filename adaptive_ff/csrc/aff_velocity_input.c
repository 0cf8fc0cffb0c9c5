/* aff_velocity_input.c -- loop model and sign observer (see aff_velocity_input.h). */
#include <stddef.h>
#include <string.h>
#include "aff_velocity_input.h"

aff_loop_model_config aff_loop_model_default_config(void)
{
    aff_loop_model_config c;
    c.Kp = 0;
    c.Ki = 0;
    c.J = 0;
    c.track = -1;
    return c;
}

aff_error aff_loop_model_check_config(const aff_loop_model_config *cfg, aff_real Tc)
{
    if (cfg == NULL)
        return AFF_ERR_NULL;
    if (!aff_positive(Tc))
        return AFF_ERR_LOOP_MODEL_TC;
    if (!aff_nonnegative(cfg->Kp))
        return AFF_ERR_LOOP_MODEL_KP;
    if (!aff_nonnegative(cfg->Ki))
        return AFF_ERR_LOOP_MODEL_KI;
    if (cfg->Kp == 0 && cfg->Ki == 0)
        return AFF_ERR_LOOP_MODEL_GAINS;
    if (!aff_positive(cfg->J))
        return AFF_ERR_LOOP_MODEL_J;
    if (!isfinite(cfg->track))
        return AFF_ERR_LOOP_MODEL_TRACK;
    return AFF_OK;
}

aff_error aff_loop_model_init(aff_loop_model *m, const aff_loop_model_config *cfg, aff_real Tc)
{
    aff_real bw;
    aff_error e = m == NULL ? AFF_ERR_NULL : aff_loop_model_check_config(cfg, Tc);
    if (e != AFF_OK)
        return e;
    bw = cfg->track < 0 ? cfg->Kp / cfg->J : cfg->track;
    memset(m, 0, sizeof *m);
    m->on = 1;
    m->Kp = cfg->Kp;
    m->KiTc = cfg->Ki * Tc;
    m->TcJ = Tc / cfg->J;
    m->a = (aff_real)1.0 - AFF_EXP(-bw * Tc);
    m->started = 0;
    m->w = 0;
    m->I = 0;
    m->dw = 0;
    return AFF_OK;
}

aff_real aff_loop_model_step(aff_loop_model *m, aff_real w0, aff_real w_ref)
{
    aff_real wm, e;
    if (!m->on)
        return w_ref;
    if (!m->started) {
        m->w = isfinite(w0) ? w0 : (aff_real)0.0;
        m->I = 0;
        m->started = 1;
    }
    wm = m->w;
    e = w_ref - wm;
    m->I += m->KiTc * e;
    m->w = wm + m->TcJ * (m->Kp * e + m->I);
    if (m->a > 0 && isfinite(w0))
        m->dw += m->a * (w0 - wm - m->dw);
    return wm + m->dw;
}

aff_sign_observer_config aff_sign_observer_default_config(void)
{
    aff_sign_observer_config c;
    c.J = 0;
    c.bandwidth = 0;
    c.residual_bandwidth = -1;
    return c;
}

aff_error aff_sign_observer_check_config(const aff_sign_observer_config *cfg, aff_real Tc)
{
    if (cfg == NULL)
        return AFF_ERR_NULL;
    if (!aff_positive(Tc))
        return AFF_ERR_SIGN_OBSERVER_TC;
    if (!aff_positive(cfg->J))
        return AFF_ERR_SIGN_OBSERVER_J;
    if (!aff_positive(cfg->bandwidth))
        return AFF_ERR_SIGN_OBSERVER_BANDWIDTH;
    if (!isfinite(cfg->residual_bandwidth))
        return AFF_ERR_SIGN_OBSERVER_RESIDUAL_BANDWIDTH;
    return AFF_OK;
}

aff_error aff_sign_observer_init(aff_sign_observer *o, const aff_sign_observer_config *cfg, aff_real Tc)
{
    aff_real p1, p2, rb;
    aff_error e = o == NULL ? AFF_ERR_NULL : aff_sign_observer_check_config(cfg, Tc);
    if (e != AFF_OK)
        return e;
    rb = cfg->residual_bandwidth < 0 ? (aff_real)0.1 * cfg->bandwidth : cfg->residual_bandwidth;
    p1 = AFF_EXP(-cfg->bandwidth * Tc);
    p2 = AFF_EXP(-rb * Tc);
    memset(o, 0, sizeof *o);
    o->on = 1;
    o->TcJ = Tc / cfg->J;
    o->l1 = (aff_real)1.0 - p1 * p2;
    o->l2 = ((aff_real)1.0 - p1) * ((aff_real)1.0 - p2);
    o->started = 0;
    o->w_hat = 0;
    o->z_hat = 0;
    o->w_ctrl = 0;
    return AFF_OK;
}

aff_real aff_sign_observer_signed(aff_sign_observer *o, aff_real w_ctrl, aff_real band)
{
    if (!o->on)
        return w_ctrl;
    o->w_ctrl = w_ctrl;
    if (!o->started) {
        o->w_hat = isfinite(w_ctrl) ? w_ctrl : (aff_real)0.0;
        o->started = 1;
    }
    if (isfinite(w_ctrl) && -band < w_ctrl && w_ctrl < band)
        return AFF_COPYSIGN(AFF_FABS(w_ctrl), o->w_hat);
    return w_ctrl;
}

void aff_sign_observer_step(aff_sign_observer *o, aff_real u, aff_real u_c)
{
    aff_real wc, du;
    if (!o->on || !o->started)
        return;
    wc = o->w_ctrl;
    if (isfinite(wc)) {
        aff_real e = wc - o->w_hat;
        o->w_hat += o->l1 * e;
        o->z_hat -= o->l2 * e;
    }
    du = u - u_c;
    if (isfinite(du))
        o->w_hat += o->TcJ * du - o->z_hat;
}
