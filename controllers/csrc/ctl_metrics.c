/* ctl_metrics.c -- tracking metrics of a closed-loop run (see ctl_metrics.h). */
#include <math.h>
#include <stddef.h>

#include "ctl_metrics.h"
#include "ctl_metrics_sample.h"

void ctl_metrics_init(ctl_metrics *m)
{
    m->e2 = 0.0;
    m->e2_c = 0.0;
    m->e_max = 0.0;
    m->e2_half = 0.0;
    m->e2_half_c = 0.0;
    m->e_max_half = 0.0;
    m->e2_rev = 0.0;
    m->e2_rev_c = 0.0;
    m->u2 = 0.0;
    m->u2_c = 0.0;
    m->n = 0;
    m->n_half = 0;
    m->n_rev = 0;
    m->ip = 0;
    m->e2_move = 0.0;
    m->e2_move_c = 0.0;
    m->e2_rest = 0.0;
    m->e2_rest_c = 0.0;
    m->e_max_rest = 0.0;
    m->n_move = 0;
    m->n_rest = 0;
}

int ctl_metrics_where(double t, double tmid, const double *revs, long nrev, double window, long *ip)
{
    if (!(t >= tmid))
        return CTL_METRICS_FIRST_HALF;
    if (nrev > 0) {
        long i = *ip;
        while (i < nrev && revs[i] < t)
            i++;
        *ip = i;
        double lo = i >= 1 ? revs[i - 1] : revs[0];
        double hi = i < nrev ? revs[i] : revs[nrev - 1];
        double dlo = fabs(t - lo);
        double dhi = fabs(hi - t);
        double d = dhi < dlo ? dhi : dlo; /* Python's min(dlo, dhi) */
        if (d <= window)
            return CTL_METRICS_REVERSAL;
    }
    return CTL_METRICS_SECOND_HALF;
}

void ctl_metrics_add(ctl_metrics *m, int where, double e, double u)
{
    metrics_add_sample(m, where, e, u);
}

void ctl_metrics_update(ctl_metrics *m, double t, double tmid, const double *revs, long nrev, double window,
                        double e, double u)
{
    int where = ctl_metrics_where(t, tmid, revs, nrev, window, &m->ip);
    ctl_metrics_add(m, where, e, u);
}

void ctl_metrics_accumulate(ctl_metrics *m, const double *t, const double *e, const double *u, long n,
                            double tmid, const double *revs, long nrev, double window)
{
    for (long k = 0; k < n; k++)
        ctl_metrics_update(m, t[k], tmid, revs, nrev, window, e[k], u[k]);
}

void ctl_metrics_add_motion(ctl_metrics *m, int where, int rest, double e)
{
    metrics_add_motion_sample(m, where, rest, e);
}

void ctl_motion_init(ctl_motion *c, double share, double band_floor, double window)
{
    c->share = share;
    c->band_floor = band_floor;
    c->window = window;
    c->rest = 0;
    c->stop = -1;
    c->stop_end = 0;
    c->t_stop = 0.0;
    c->band = 0.0;
    c->rev = -1;
    c->rev_end = 0;
    c->n_stops = 0;
    c->peak = 0.0;
    c->ip = 0;
}


void ctl_motion_where(ctl_motion *c, const double *t, const double *w_ref, long n, long k, const double *revs,
                      long nrev)
{
    motion_where_sample(c, t, w_ref, n, k, revs, nrev);
}

long ctl_motion_stops(const double *t, const double *w_ref, long n, double share, double band_floor, double *t0,
                      double *t1, double *band, long cap)
{
    ctl_motion c;
    ctl_motion_init(&c, share, band_floor, 0.0);
    long prev = -1;
    for (long k = 0; k < n; k++) {
        ctl_motion_where(&c, t, w_ref, n, k, NULL, 0);
        if (c.stop >= 0 && c.stop < cap) {
            if (c.stop != prev) {
                t0[c.stop] = c.t_stop;
                band[c.stop] = c.band;
            }
            if (c.stop_end)
                t1[c.stop] = t[k];
        }
        prev = c.stop;
    }
    return c.n_stops;
}

void ctl_events_init(ctl_events *ev, double *settle, double *stop_max, long n_stops, double *rev_max, long n_revs)
{
    ev->settle = settle;
    ev->stop_max = stop_max;
    ev->rev_max = rev_max;
    ev->n_stops = n_stops;
    ev->n_revs = n_revs;
    for (long i = 0; i < n_stops; i++) {
        settle[i] = NAN;
        stop_max[i] = NAN;
    }
    for (long i = 0; i < n_revs; i++)
        rev_max[i] = NAN;
    ev->stop = -1;
    ev->out = 0;
    ev->t_in = 0.0;
    ev->e_max_stop = 0.0;
    ev->rev = -1;
    ev->e_max_rev = 0.0;
}


void ctl_events_add(ctl_events *ev, const ctl_motion *c, double t, double e)
{
    events_add_sample(ev, c, t, e);
}

void ctl_motion_accumulate(ctl_metrics *m, ctl_motion *c, ctl_events *ev, const double *t, const double *w_ref,
                           const double *e, long n, double tmid, const double *revs, long nrev)
{
    for (long k = 0; k < n; k++) {
        int where = ctl_metrics_where(t[k], tmid, revs, nrev, c->window, &m->ip);
        ctl_motion_where(c, t, w_ref, n, k, revs, nrev);
        ctl_metrics_add_motion(m, where, c->rest, e[k]);
        ctl_events_add(ev, c, t[k], e[k]);
    }
}
