/* ctl_metrics.c -- tracking metrics of a closed-loop run (see ctl_metrics.h). */
#include <math.h>
#include <stddef.h>

#include "ctl_metrics.h"

/* Neumaier-compensated *sum += x, the compensation in *c. */
static void neumaier_add(double *sum, double *c, double x)
{
    double s = *sum;
    double q = s + x;
    *c += fabs(s) >= fabs(x) ? (s - q) + x : (x - q) + s;
    *sum = q;
}

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
    double e2 = e * e;
    neumaier_add(&m->e2, &m->e2_c, e2);
    double ae = fabs(e);
    if (ae > m->e_max || ae != ae)
        m->e_max = m->e_max == m->e_max ? ae : m->e_max;
    m->n++;
    if (where > 0) {
        neumaier_add(&m->e2_half, &m->e2_half_c, e2);
        m->n_half++;
        if (ae > m->e_max_half || ae != ae)
            m->e_max_half = m->e_max_half == m->e_max_half ? ae : m->e_max_half;
        if (where == CTL_METRICS_REVERSAL) {
            neumaier_add(&m->e2_rev, &m->e2_rev_c, e2);
            m->n_rev++;
        }
    }
    neumaier_add(&m->u2, &m->u2_c, u * u);
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
    if (where == CTL_METRICS_FIRST_HALF)
        return;
    double e2 = e * e;
    if (rest) {
        neumaier_add(&m->e2_rest, &m->e2_rest_c, e2);
        m->n_rest++;
        double ae = fabs(e);
        if (ae > m->e_max_rest || ae != ae)
            m->e_max_rest = m->e_max_rest == m->e_max_rest ? ae : m->e_max_rest;
    } else {
        neumaier_add(&m->e2_move, &m->e2_move_c, e2);
        m->n_move++;
    }
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

/* The reversal whose window holds time t: the nearest of revs (the earlier of two equally near, as
 * ctl_metrics_where) if within window, else -1; *ip as in ctl_metrics_where. */
static long nearest_reversal(double t, const double *revs, long nrev, double window, long *ip)
{
    if (nrev <= 0)
        return -1;
    long i = *ip;
    while (i < nrev && revs[i] < t)
        i++;
    *ip = i;
    long jlo = i >= 1 ? i - 1 : 0;
    long jhi = i < nrev ? i : nrev - 1;
    double dlo = fabs(t - revs[jlo]);
    double dhi = fabs(revs[jhi] - t);
    long j = dhi < dlo ? jhi : jlo;
    double d = dhi < dlo ? dhi : dlo;
    return d <= window ? j : -1;
}

void ctl_motion_where(ctl_motion *c, const double *t, const double *w_ref, long n, long k, const double *revs,
                      long nrev)
{
    double w = w_ref[k];
    int rest = w == 0.0 && (k == 0 || k == n - 1 || w_ref[k - 1] == 0.0 || w_ref[k + 1] == 0.0);
    if (rest) {
        if (k > 0 && !c->rest) { /* the first standstill sample after motion: a stop begins */
            double b = c->share * c->peak;
            c->stop = c->n_stops;
            c->n_stops++;
            c->t_stop = t[k];
            c->band = b > c->band_floor ? b : c->band_floor;
        }
        c->stop_end = c->stop >= 0 && (k == n - 1 || w_ref[k + 1] != 0.0);
        c->peak = 0.0;
    } else {
        double aw = fabs(w);
        c->stop = -1;
        c->stop_end = 0;
        if (aw > c->peak)
            c->peak = aw;
    }
    c->rest = rest;
    c->rev = nearest_reversal(t[k], revs, nrev, c->window, &c->ip);
    if (c->rev >= 0) {
        long ip = c->ip;
        c->rev_end = k == n - 1 || nearest_reversal(t[k + 1], revs, nrev, c->window, &ip) != c->rev;
    } else {
        c->rev_end = 0;
    }
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

/* *mx = max(*mx, a) with NaN sticky (as the maxima of ctl_metrics_add). */
static void max_sticky(double *mx, double a)
{
    if (a > *mx || a != a)
        *mx = *mx == *mx ? a : *mx;
}

void ctl_events_add(ctl_events *ev, const ctl_motion *c, double t, double e)
{
    double ae = fabs(e);
    if (c->stop >= 0) {
        if (c->stop != ev->stop) { /* the stop's first sample */
            ev->stop = c->stop;
            ev->out = 0;
            ev->t_in = c->t_stop;
            ev->e_max_stop = 0.0;
        }
        if (!(ae <= c->band)) {
            ev->out = 1;
        } else if (ev->out) {
            ev->out = 0;
            ev->t_in = t;
        }
        max_sticky(&ev->e_max_stop, ae);
        if (c->stop_end) {
            if (ev->stop < ev->n_stops) {
                ev->settle[ev->stop] = ev->out ? INFINITY : ev->t_in - c->t_stop;
                ev->stop_max[ev->stop] = ev->e_max_stop;
            }
            ev->stop = -1;
        }
    }
    if (c->rev >= 0) {
        if (c->rev != ev->rev) {
            ev->rev = c->rev;
            ev->e_max_rev = 0.0;
        }
        max_sticky(&ev->e_max_rev, ae);
        if (c->rev_end) {
            if (ev->rev < ev->n_revs)
                ev->rev_max[ev->rev] = ev->e_max_rev;
            ev->rev = -1;
        }
    }
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
