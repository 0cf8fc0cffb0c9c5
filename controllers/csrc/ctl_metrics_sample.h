/* ctl_metrics_sample.h -- the per-sample steps of ctl_metrics.h as static inline functions: ctl_metrics.c's exported
 * functions call them, and the closed-loop engine (ctl_engine.c) inlines them into its period (one implementation,
 * no call per sample). Not read by cffi: the interface is ctl_metrics.h. */
#ifndef CTL_METRICS_SAMPLE_H
#define CTL_METRICS_SAMPLE_H
#include <math.h>
#include <stddef.h>

#include "ctl_metrics.h"

/* GCC, Clang: inline into every caller (the engine's specialised loops included). */
#if defined(__GNUC__)
#define CTL_SAMPLE_INLINE __attribute__((always_inline))
#else
#define CTL_SAMPLE_INLINE
#endif

/* Neumaier-compensated *sum += x, the compensation in *c. */
static inline CTL_SAMPLE_INLINE void neumaier_add(double *sum, double *c, double x)
{
    double s = *sum;
    double q = s + x;
    *c += fabs(s) >= fabs(x) ? (s - q) + x : (x - q) + s;
    *sum = q;
}

/* *mx = max(*mx, a) with NaN sticky (as the maxima of ctl_metrics_add). */
static inline CTL_SAMPLE_INLINE void max_sticky(double *mx, double a)
{
    if (a > *mx || a != a)
        *mx = *mx == *mx ? a : *mx;
}

/* ctl_metrics_add (ctl_metrics.h). */
static inline CTL_SAMPLE_INLINE void metrics_add_sample(ctl_metrics *m, int where, double e, double u)
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

/* ctl_metrics_add_motion (ctl_metrics.h). */
static inline CTL_SAMPLE_INLINE void metrics_add_motion_sample(ctl_metrics *m, int where, int rest, double e)
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

/* The reversal whose window holds time t: the nearest of revs (the earlier of two equally near, as
 * ctl_metrics_where) if within window, else -1; *ip as in ctl_metrics_where. */
static inline CTL_SAMPLE_INLINE long nearest_reversal(double t, const double *revs, long nrev, double window,
                                                      long *ip)
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

/* ctl_motion_where (ctl_metrics.h). */
static inline CTL_SAMPLE_INLINE void motion_where_sample(ctl_motion *c, const double *t, const double *w_ref,
                                                        long n, long k, const double *revs, long nrev)
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

/* ctl_events_add (ctl_metrics.h). */
static inline CTL_SAMPLE_INLINE void events_add_sample(ctl_events *ev, const ctl_motion *c, double t, double e)
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

#endif
