/* plant_params.c -- the plant's friction map, steady states and the up-front check (see plant_params.h). */
#include "plant_params.h"

const double plant_lugre_stiff_max = 1e4;

double plant_target(const plant_params *p, double w, double sgn)
{
    const plant_stribeck *m;
    if (p->model == PLANT_LUGRE) {
        double x = w >= 0.0 ? w : -w;
        plant_stribeck g;
        if (!(x > 0.0))
            return p->pos.delta > 0 ? p->pos.Fc + p->pos.dF : p->pos.Fc;
        g = p->pos;
        g.sigma = 0.0; /* g(w): eq. 3 at |w| without the viscous term */
        return plant_stribeck_eval(&g, x);
    }
    if (w > 0.0) {
        if (w < p->dv)
            return p->Fs_stick * sgn;
        m = &p->pos;
    } else {
        if (-w < p->dv)
            return p->Fs_stick * sgn;
        m = &p->neg;
    }
    return plant_stribeck_eval(m, w);
}

double plant_ripple(const plant_params *p, double q)
{
    if (p->ripple_a == 0.0)
        return 1.0;
    return 1.0 + p->ripple_a * sin(p->ripple_n * q + p->ripple_phase);
}

double plant_target_at(const plant_params *p, double w, double q, double sgn)
{
    double F = plant_target(p, w, sgn);
    if (p->ripple_a == 0.0)
        return F;
    return F * plant_ripple(p, q);
}

void plant_steady_state(const plant_params *p, double w0, plant_state *s)
{
    s->w = w0;
    s->q = 0.0;
    if (p->model == PLANT_LUGRE) {
        s->s = w0 != 0.0 ? copysign(plant_target_at(p, w0, 0.0, 0.0), w0) / p->sigma0 : 0.0;
        s->aux = NAN;
        return;
    }
    s->s = plant_stribeck_eval(w0 > 0.0 ? &p->pos : &p->neg, w0);
    if (p->ripple_a != 0.0)
        s->s *= plant_ripple(p, 0.0);
    s->aux = p->tau == 0.0 ? p->key : NAN;
}

void plant_steady_states(const plant_params *p, long n, double w0, plant_state *out)
{
    for (long b = 0; b < n; b++)
        plant_steady_state(&p[b], w0, &out[b]);
}

/* 1 where the ripple fields are usable: a == 0, or 0 < a < 1 with n > 0 and n, phase finite. */
static int ripple_ok(const plant_params *p)
{
    double a = p->ripple_a;
    if (a == 0.0)
        return 1;
    return a > 0.0 && a < 1.0 && p->ripple_n > 0.0 && p->ripple_n < INFINITY && isfinite(p->ripple_phase);
}

int plant_integrable(const plant_params *p, double dt)
{
    double J = p->J;
    if (p->model == PLANT_LUGRE) {
        double wp = sqrt(J != 0.0 ? p->sigma0 / J : INFINITY);
        return wp * dt <= plant_lugre_stiff_max && ripple_ok(p);
    }
    return J > 0.0 && isfinite(J) && p->tau >= 0.0 && p->tau < INFINITY
        && isfinite(p->pos.Fc) && isfinite(p->pos.dF) && isfinite(p->pos.sigma)
        && isfinite(p->neg.Fc) && isfinite(p->neg.dF) && isfinite(p->neg.sigma)
        && isfinite(p->pos.Vs) && isfinite(p->pos.delta) && isfinite(p->neg.Vs) && isfinite(p->neg.delta)
        && isfinite(p->Fs_stick) && isfinite(p->dv) && ripple_ok(p);
}

void plant_integrable_array(const plant_params *p, long n, double dt, int *ok)
{
    for (long b = 0; b < n; b++)
        ok[b] = plant_integrable(&p[b], dt);
}
