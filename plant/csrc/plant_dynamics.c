/* plant_dynamics.c -- RK4, the plant step and the friction torque (see plant_dynamics.h). The operations are
 * those of the former JIT kernels of plant/dynamics.py in the same order (results equal bit for bit). */
#include "plant_dynamics.h"

const double plant_rk4_rate_max = 2.5;

/* (dw/dt, ds/dt) at (w, s) with input u and Fw = plant_target(p, w, .). */
static void rhs(const plant_params *p, double w, double s, double u, double Fw, double *dw, double *ds)
{
    if (p->model == PLANT_LUGRE) {
        double aw = w >= 0.0 ? w : -w;
        double zdot = w - p->sigma0 * aw / Fw * s;
        *dw = (u - p->sigma0 * s - p->sigma1 * zdot - p->pos.sigma * w) / p->J;
        *ds = zdot;
        return;
    }
    if (p->tau == 0.0) {
        *dw = (u - Fw) * p->inv_J;
        *ds = 0.0;
        return;
    }
    *dw = (u - s) * p->inv_J;
    *ds = (Fw - s) * p->inv_tau;
}

void plant_rk4(const plant_params *p, double *w_io, double *s_io, double Fw, double u0, double um, double u1,
               double h, double sgn)
{
    double w = *w_io;
    double s = *s_io;
    double h2 = 0.5 * h;
    double h6 = h / 6.0;
    double k1w, k1s, k2w, k2s, k3w, k3s, k4w, k4s, wa, sa, wb, sb, wc, sc;
    rhs(p, w, s, u0, Fw, &k1w, &k1s);
    wa = w + h2 * k1w;
    sa = s + h2 * k1s;
    rhs(p, wa, sa, um, plant_target(p, wa, sgn), &k2w, &k2s);
    wb = w + h2 * k2w;
    sb = s + h2 * k2s;
    rhs(p, wb, sb, um, plant_target(p, wb, sgn), &k3w, &k3s);
    wc = w + h * k3w;
    sc = s + h * k3s;
    rhs(p, wc, sc, u1, plant_target(p, wc, sgn), &k4w, &k4s);
    *w_io = w + h6 * (k1w + 2.0 * k2w + 2.0 * k3w + k4w);
    *s_io = s + h6 * (k1s + 2.0 * k2s + 2.0 * k3s + k4s);
}

/* True where plant_step takes exactly one RK4 step of dt with sgn = 0: a lagged model, w outside the Karnopp
 * band, no sub-steps (the branch conditions of its general path). */
static int single_rk4(const plant_params *p, double w, double dt)
{
    double dv = p->dv;
    if (p->model == PLANT_LUGRE)
        return 0;
    if (-dv < w && w < dv)
        return 0;
    return !(p->rate * dt > plant_rk4_rate_max);
}

void plant_step(const plant_params *p, plant_state *st, double u, double dt)
{
    double w = st->w;
    double s = st->s;
    double sgn = 0.0;
    double h = dt;
    long n = 1;
    int lugre, stat, cached;
    if (p->tau != 0.0 && single_rk4(p, w, dt)) { /* the common case: a lagged model, one RK4 step */
        plant_rk4(p, &w, &s, plant_target(p, w, 0.0), u, u, u, dt, 0.0);
        st->w = w;
        st->s = s;
        st->aux = NAN;
        return;
    }
    lugre = p->model == PLANT_LUGRE;
    if (lugre) {
        double aw = w >= 0.0 ? w : -w;
        /* bound |w| over the step by its start value plus the largest acceleration */
        double rate = p->sigma0 * (aw + (fabs(u) + p->g_max + p->pos.sigma * aw) * dt / p->J) / p->g_min
                      + p->base_rate;
        double x = rate * dt;
        if (!(x < 1e15)) { /* non-finite state or input: no step count exists */
            st->w = NAN;
            st->s = NAN;
            return;
        }
        n = (long)x + 1;
        h = dt / (double)n;
        if (n > PLANT_LUGRE_RK4_MAX) { /* stiff: implicit, error-controlled */
            plant_lugre_stiff_step(p, st, u, dt);
            return;
        }
    } else {
        double dv = p->dv;
        double x;
        if (-dv < w && w < dv) { /* Karnopp stick band (dv = 0: never) */
            double Fs = p->Fs_stick;
            if (-Fs <= u && u <= Fs) {
                st->w = 0.0;
                st->s = u;
                st->aux = NAN;
                return;
            }
            sgn = u > 0.0 ? 1.0 : -1.0;
        } else if (dv == 0.0 && p->tau == 0.0 && plant_static_jump_in_reach(p, w, u, dt)) { /* set-valued */
            st->aux = NAN;
            plant_lagged_stiff_step(p, st, u, dt, 0.0);
            return;
        }
        x = p->rate * dt;
        if (x > plant_rk4_rate_max) { /* a stiff mode: equal sub-steps with rate*h < 1 */
            if (!(x < PLANT_LAGGED_RK4_MAX) && sgn == 0.0) /* the stiffness of this step alone */
                x = plant_lagged_local_rate(p, w, s, u, dt) * dt;
            if (!(x < PLANT_LAGGED_RK4_MAX)) { /* more than PLANT_LAGGED_RK4_MAX sub-steps: implicit */
                plant_lagged_stiff_step(p, st, u, dt, sgn);
                return;
            }
            if (x > plant_rk4_rate_max) {
                n = (long)x + 1;
                h = dt / (double)n;
            }
        }
    }
    stat = p->tau == 0.0 && !lugre;
    cached = stat && sgn == 0.0 && st->aux == p->key; /* s = F(w) of these parameters */
    for (long i = 0; i < n; i++) {
        double Fw = cached && i == 0 ? s : plant_target(p, w, sgn);
        plant_rk4(p, &w, &s, Fw, u, u, u, h, sgn);
    }
    if (stat) {
        s = plant_target(p, w, sgn);
        st->aux = p->key;
    } else {
        st->aux = NAN;
    }
    st->w = w;
    st->s = s;
}

double plant_friction(const plant_params *p, const plant_state *st)
{
    double w, z, aw, g, zdot;
    if (p->model != PLANT_LUGRE)
        return st->s;
    w = st->w;
    z = st->s;
    aw = fabs(w);
    g = plant_target(p, w, 0.0); /* g(|w|); any positive value at w = 0, where aw/g = 0 */
    zdot = w - p->sigma0 * aw / g * z;
    return p->sigma0 * z + p->sigma1 * zdot + p->pos.sigma * w;
}

void plant_simulate(const plant_params *p, plant_state *st, const double *u, long n, double dt, double *W,
                    double *S)
{
    W[0] = st->w;
    S[0] = st->s;
    for (long k = 0; k < n; k++) {
        plant_step(p, st, u[k], dt);
        W[k + 1] = st->w;
        S[k + 1] = st->s;
    }
}
