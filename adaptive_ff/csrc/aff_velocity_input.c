/* aff_velocity_input.c -- loop model and sign observer (see aff_velocity_input.h). */
#include "aff_velocity_input.h"

void aff_loop_model_init(aff_loop_model *m, aff_real Kp, aff_real KiTc, aff_real TcJ, aff_real a)
{
    m->on = 1;
    m->Kp = Kp;
    m->KiTc = KiTc;
    m->TcJ = TcJ;
    m->a = a;
    m->started = 0;
    m->w = 0;
    m->I = 0;
    m->dw = 0;
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

void aff_sign_observer_init(aff_sign_observer *o, aff_real TcJ, aff_real l1, aff_real l2)
{
    o->on = 1;
    o->TcJ = TcJ;
    o->l1 = l1;
    o->l2 = l2;
    o->started = 0;
    o->w_hat = 0;
    o->z_hat = 0;
    o->w_ctrl = 0;
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
