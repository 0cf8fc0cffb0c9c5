/* plant_dynamics.c -- RK4, the plant step and the friction torque (see plant_dynamics.h). The operations are
 * those of the former JIT kernels of plant/dynamics.py in the same order (results equal bit for bit). */
#include <stddef.h>

#include "plant_dynamics.h"

const double plant_rk4_rate_max = 2.5;

/* GCC, Clang: inline every call of the function's body (eq. 3 in the RK4 stages), or none (a rare path kept out of
 * its caller); the compiler's own choice where unsupported. Inlining keeps every floating-point operation and its
 * order (plant/_cbuild.py, compile_args). */
#if defined(__GNUC__)
#define PLANT_FLATTEN __attribute__((flatten))
#define PLANT_NOINLINE __attribute__((noinline))
#else
#define PLANT_FLATTEN
#define PLANT_NOINLINE
#endif

/* Sub-steps per unit of rate*dt of a LuGre step with a friction ripple (more than the 1 of stability). */
static const double lugre_ripple_substeps = 4.0;

/* (dw/dt, ds/dt) at (w, s) with input u, Fw = plant_target_at(p, w, q, .) and R = plant_ripple(p, q) (LuGre's
 * viscous part rippled with g, plant_params.h; 1 without a ripple, and sigma2*1*w is sigma2*w exactly). lag: 1 where
 * the caller knows p is a lagged model with tau != 0 (a constant where inlined: no test of the model per stage). */
static void rhs(const plant_params *p, double w, double s, double R, double u, double Fw, double *dw, double *ds,
                int lag)
{
    if (lag) {
        *dw = (u - s) * p->inv_J;
        *ds = (Fw - s) * p->inv_tau;
        return;
    }
    if (p->model == PLANT_LUGRE) {
        double aw = w >= 0.0 ? w : -w;
        double zdot = w - p->sigma0 * aw / Fw * s;
        *dw = (u - p->sigma0 * s - p->sigma1 * zdot - p->pos.sigma * R * w) / p->J;
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

void plant_rk4(const plant_params *p, double *w_io, double *s_io, double Fw, double u0, double um, double u1, double h,
               double sgn)
{
    double q = 0.0;
    plant_rk4_at(p, w_io, s_io, &q, Fw, u0, um, u1, h, sgn);
}

/* The map of an RK4 stage at (w, q): plant_target_at with a ripple, plant_target (the same value) without. */
static double stage_target(const plant_params *p, double w, double q, double sgn, int ripple)
{
    return ripple ? plant_target_at(p, w, q, sgn) : plant_target(p, w, sgn);
}

/* The ripple factor an RK4 stage's right-hand side needs: R(q) for a rippled LuGre joint, else 1. */
static double stage_ripple(const plant_params *p, double q, int ripple)
{
    return ripple && p->model == PLANT_LUGRE ? plant_ripple(p, q) : 1.0;
}

/* plant_rk4_at with ripple = (p->ripple_a != 0) given by the caller: a constant where it is inlined, so the step
 * without a ripple carries none of the ripple's operations (its stage positions qa, qb, qc are then unused); lag as
 * rhs's. */
static void rk4_at(const plant_params *p, double *w_io, double *s_io, double *q_io, double Fw, double u0, double um,
                   double u1, double h, double sgn, int ripple, int lag)
{
    double w = *w_io;
    double s = *s_io;
    double q = *q_io;
    double h2 = 0.5 * h;
    double h6 = h / 6.0;
    double k1w, k1s, k2w, k2s, k3w, k3s, k4w, k4s, wa, sa, qa, wb, sb, qb, wc, sc, qc;
    rhs(p, w, s, stage_ripple(p, q, ripple), u0, Fw, &k1w, &k1s, lag);
    wa = w + h2 * k1w;
    sa = s + h2 * k1s;
    qa = q + h2 * w;
    rhs(p, wa, sa, stage_ripple(p, qa, ripple), um, stage_target(p, wa, qa, sgn, ripple), &k2w, &k2s, lag);
    wb = w + h2 * k2w;
    sb = s + h2 * k2s;
    qb = q + h2 * wa;
    rhs(p, wb, sb, stage_ripple(p, qb, ripple), um, stage_target(p, wb, qb, sgn, ripple), &k3w, &k3s, lag);
    wc = w + h * k3w;
    sc = s + h * k3s;
    qc = q + h * wb;
    rhs(p, wc, sc, stage_ripple(p, qc, ripple), u1, stage_target(p, wc, qc, sgn, ripple), &k4w, &k4s, lag);
    *w_io = w + h6 * (k1w + 2.0 * k2w + 2.0 * k3w + k4w);
    *s_io = s + h6 * (k1s + 2.0 * k2s + 2.0 * k3s + k4s);
    *q_io = q + h6 * (w + 2.0 * wa + 2.0 * wb + wc);
}

void plant_rk4_at(const plant_params *p, double *w_io, double *s_io, double *q_io, double Fw, double u0, double um,
                  double u1, double h, double sgn)
{
    if (p->ripple_a != 0.0)
        rk4_at(p, w_io, s_io, q_io, Fw, u0, um, u1, h, sgn, 1, 0);
    else
        rk4_at(p, w_io, s_io, q_io, Fw, u0, um, u1, h, sgn, 0, 0);
}

/* The fastest mode (1/s) a lagged model's RK4 step at velocity w must resolve: p->rate; with a friction ripple
 * also the ripple's position stiffness kq = (Fmax + sigma*|w|*(1 + a))*a*n (N*m/rad; sqrt(kq/J), tau > 0:
 * cbrt(kq/(J*tau)), the roots' bound of J*tau*l^3 + J*l^2 + s*l + kq) and 4*n*|w|, the rate the ripple passes
 * at times 4 (at most 0.625 rad of ripple phase per RK4 sub-step: accuracy, not stability). */
static double lagged_rate_at(const plant_params *p, double w)
{
    double a = p->ripple_a;
    double aw, sig, kq, rq, rp;
    if (a == 0.0)
        return p->rate;
    aw = fabs(w);
    sig = p->pos.sigma > p->neg.sigma ? p->pos.sigma : p->neg.sigma;
    kq = (plant_lagged_level_max(p) + (sig > 0.0 ? sig : 0.0) * aw * (1.0 + a)) * a * p->ripple_n;
    rq = p->tau > 0.0 ? cbrt(kq / (p->J * p->tau)) : sqrt(kq / p->J);
    rp = 4.0 * p->ripple_n * aw;
    rq = rq > rp ? rq : rp;
    return p->rate > rq ? p->rate : rq;
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
    /* lagged_rate_at's value, without its call where there is no ripple */
    return !((p->ripple_a == 0.0 ? p->rate : lagged_rate_at(p, w)) * dt > plant_rk4_rate_max);
}

/* A step of dt of a Karnopp joint in its band |w| < dv with |u| <= Fs (Fs: the stick limit at the step start,
 * times R(q) with a ripple): the friction opposes the motion with at most Fs, so the joint decelerates at
 * (Fs*sgn(w) - u)/J and sticks once at rest. It stops within the step where the friction that stops it, the
 * step's average u + J*w/dt, is within [-Fs, Fs]: w = 0, s = u (at rest the friction balances u), q advanced by
 * J*w^2/(2*(Fs*sgn(w) - u)) (the distance to the stop); else it slides the whole step: w += dt*(u - f)/J and
 * s = f = Fs*sgn(w), q by dt*(w + w1)/2 (exact for the constant deceleration, as RK4). aux = NaN. */
static void karnopp_hold(const plant_params *p, plant_state *st, double u, double dt, double Fs)
{
    double w = st->w;
    double f_stop = u + p->J * w / dt;
    st->aux = NAN;
    if (-Fs <= f_stop && f_stop <= Fs) { /* it stops within the step: it sticks */
        double d = (w > 0.0 ? Fs : -Fs) - u; /* the net decelerating torque, != 0 where w's term is */
        if (w != 0.0 && d != 0.0)
            st->q += 0.5 * p->J * w * w / d;
        st->w = 0.0;
        st->s = u;
    } else { /* it slides, decelerated by the static limit */
        double f = w > 0.0 ? Fs : -Fs;
        double w1 = w + dt * (u - f) * p->inv_J;
        st->q += 0.5 * dt * (w + w1);
        st->w = w1;
        st->s = f;
    }
}

/* plant_step's common case (a lagged model, one RK4 step of dt, single_rk4) without a friction ripple: the map and
 * RK4 inlined into one body. */
PLANT_FLATTEN static void single_step_smooth(const plant_params *p, plant_state *st, double u, double dt)
{
    double w = st->w;
    double s = st->s;
    double q = st->q;
    rk4_at(p, &w, &s, &q, plant_target(p, w, 0.0), u, u, u, dt, 0.0, 0, 1);
    st->w = w;
    st->s = s;
    st->q = q;
    st->aux = NAN;
}

/* plant_step past its common case without a ripple (plant_step): its own function, so the common case's call does
 * not pay for the registers and the stack frame of the general one. */
PLANT_NOINLINE static void step_general(const plant_params *p, plant_state *st, double u, double dt)
{
    double w = st->w;
    double s = st->s;
    double q = st->q;
    double sgn = 0.0;
    double h = dt;
    long n = 1;
    int lugre, stat, cached;
    if (p->tau != 0.0 && single_rk4(p, w, dt)) { /* a lagged model, one RK4 step, with a ripple (plant_step) */
        rk4_at(p, &w, &s, &q, plant_target_at(p, w, q, 0.0), u, u, u, dt, 0.0, 1, 1);
        st->w = w;
        st->s = s;
        st->q = q;
        st->aux = NAN;
        return;
    }
    lugre = p->model == PLANT_LUGRE;
    if (lugre) {
        double aw = w >= 0.0 ? w : -w;
        /* bound |w| over the step by its start value plus the largest acceleration */
        double rate = p->sigma0 * (aw + (fabs(u) + p->g_max + p->pos.sigma * aw) * dt / p->J) / p->g_min
                      + p->base_rate;
        double x;
        if (p->ripple_a != 0.0) { /* levels within (1 -+ a) of g; the position coupling of the ripple */
            double a = p->ripple_a;
            double an = a * p->ripple_n;
            double wmax = aw + (fabs(u) + (p->g_max + p->pos.sigma * aw) * (1.0 + a)) * dt / p->J;
            rate = p->sigma0 * wmax / (p->g_min * (1.0 - a)) + p->base_rate + p->ripple_n * wmax / (1.0 - a)
                   + sqrt((p->sigma1 + p->pos.sigma * (1.0 + a)) * an * wmax / p->J);
        }
        x = rate * dt;
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
        if (p->ripple_a != 0.0) { /* accuracy: the ripple forces the bristle's fast mode at n*|w|, and RK4's
                                     forced response errs by about (rate*h)^4*(n*|w|*h)/120: a quarter of the
                                     sub-step keeps the friction within 1e-6 of its peak (tests/plant_layer/test_plant_options) */
            n = (long)(lugre_ripple_substeps * x) + 1;
            h = dt / (double)n;
        }
    } else {
        double dv = p->dv;
        double x;
        if (-dv < w && w < dv) { /* Karnopp stick band (dv = 0: never) */
            double Fs = p->Fs_stick;
            if (p->ripple_a != 0.0)
                Fs *= plant_ripple(p, q);
            if (-Fs <= u && u <= Fs) {
                karnopp_hold(p, st, u, dt, Fs);
                return;
            }
            sgn = u > 0.0 ? 1.0 : -1.0;
        } else if (dv == 0.0 && p->tau == 0.0 && plant_static_jump_in_reach(p, w, u, dt)) { /* set-valued */
            st->aux = NAN;
            plant_lagged_stiff_step(p, st, u, dt, 0.0);
            return;
        }
        x = lagged_rate_at(p, w) * dt;
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
    if (p->ripple_a != 0.0) {
        for (long i = 0; i < n; i++) {
            double Fw = cached && i == 0 ? s : plant_target_at(p, w, q, sgn);
            rk4_at(p, &w, &s, &q, Fw, u, u, u, h, sgn, 1, 0);
        }
    } else { /* the same loop without the ripple's operations */
        for (long i = 0; i < n; i++) {
            double Fw = cached && i == 0 ? s : plant_target(p, w, sgn);
            rk4_at(p, &w, &s, &q, Fw, u, u, u, h, sgn, 0, 0);
        }
    }
    if (stat) {
        s = plant_target_at(p, w, q, sgn);
        st->aux = p->key;
    } else {
        st->aux = NAN;
    }
    st->w = w;
    st->s = s;
    st->q = q;
}

void plant_step(const plant_params *p, plant_state *st, double u, double dt)
{
    /* the common case: a lagged model, one RK4 step (single_rk4), no ripple: the same numbers, none of the
     * ripple's operations */
    if (p->tau != 0.0 && p->ripple_a == 0.0 && single_rk4(p, st->w, dt))
        single_step_smooth(p, st, u, dt);
    else
        step_general(p, st, u, dt);
}

int plant_step_is_smooth(const plant_params *p, double dt)
{
    return p->model != PLANT_LUGRE && p->tau != 0.0 && p->ripple_a == 0.0 && !(p->rate * dt > plant_rk4_rate_max);
}

void plant_step_smooth(const plant_params *p, plant_state *st, double u, double dt)
{
    double w = st->w;
    double s = st->s;
    double q = 0.0; /* not carried: without a ripple nothing reads the position (its operations left out) */
    if (-p->dv < w && w < p->dv) { /* within the Karnopp band: the general step (single_rk4) */
        step_general(p, st, u, dt);
        return;
    }
    rk4_at(p, &w, &s, &q, plant_target(p, w, 0.0), u, u, u, dt, 0.0, 0, 1);
    st->w = w;
    st->s = s;
    st->aux = NAN;
}

double plant_friction(const plant_params *p, const plant_state *st)
{
    double w, z, aw, g, zdot;
    if (p->model != PLANT_LUGRE)
        return st->s;
    w = st->w;
    z = st->s;
    aw = fabs(w);
    g = plant_target_at(p, w, st->q, 0.0); /* g(|w|)*R(q); any positive value at w = 0, where aw/g = 0 */
    zdot = w - p->sigma0 * aw / g * z;
    if (p->ripple_a != 0.0)
        return p->sigma0 * z + p->sigma1 * zdot + p->pos.sigma * plant_ripple(p, st->q) * w;
    return p->sigma0 * z + p->sigma1 * zdot + p->pos.sigma * w;
}

void plant_simulate(const plant_params *p, plant_state *st, const double *u, long n, double dt, double *W,
                    double *S, double *Q)
{
    W[0] = st->w;
    S[0] = st->s;
    if (Q != NULL)
        Q[0] = st->q;
    for (long k = 0; k < n; k++) {
        plant_step(p, st, u[k], dt);
        W[k + 1] = st->w;
        S[k + 1] = st->s;
        if (Q != NULL)
            Q[k + 1] = st->q;
    }
}
