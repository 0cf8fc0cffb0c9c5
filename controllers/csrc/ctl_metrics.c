/* ctl_metrics.c -- tracking metrics of a closed-loop run (see ctl_metrics.h). */
#include <math.h>

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
