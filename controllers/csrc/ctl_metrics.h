/* ctl_metrics.h -- tracking metrics of a closed-loop run, accumulated sample by sample.
 *
 * Sums of squares of the velocity error e = w_ref - w (rad/s) over the whole
 * run, over its second half and within windows around the reference
 * reversals (second half), of the torque u (N*m), and the maxima of |e|
 * (whole run, second half). Every sum is Neumaier-compensated (Neumaier,
 * "Rundungsfehleranalyse einiger Verfahren zur Summation endlicher Summen",
 * ZAMM 54, 1974): RMS = sqrt((sum + compensation)/count), so a one-hour run
 * at 1 kHz loses no digits and memory does not grow with the run. NaN
 * propagates into the sums and maxima as in numpy. The closed-loop engine
 * holds one ctl_metrics per scenario; classify a sample with
 * ctl_metrics_where (once per period for a batch on one reference), then
 * ctl_metrics_add. Python: controllers.simulation.metrics (metrics_result,
 * metrics_columns read the struct; loop_metrics runs ctl_metrics_accumulate).
 */
#ifndef CTL_METRICS_H
#define CTL_METRICS_H

/* Sample classes of ctl_metrics_where. */
enum { CTL_METRICS_FIRST_HALF = 0, CTL_METRICS_SECOND_HALF = 1, CTL_METRICS_REVERSAL = 2 };

typedef struct ctl_metrics {
    double e2;          /* sum of e^2 over all samples ((rad/s)^2) */
    double e2_c;        /* its Neumaier compensation ((rad/s)^2) */
    double e_max;       /* max |e| over all samples (rad/s); NaN once a NaN was added */
    double e2_half;     /* sum of e^2 over the second half ((rad/s)^2) */
    double e2_half_c;   /* its compensation */
    double e_max_half;  /* max |e| over the second half (rad/s) */
    double e2_rev;      /* sum of e^2 within the reversal windows (second half) ((rad/s)^2) */
    double e2_rev_c;    /* its compensation */
    double u2;          /* sum of u^2 over all samples ((N*m)^2) */
    double u2_c;        /* its compensation */
    long n;             /* samples added */
    long n_half;        /* of them in the second half */
    long n_rev;         /* of them in a reversal window */
    long ip;            /* reversal pointer of ctl_metrics_update (index of the first reversal >= t) */
} ctl_metrics;

/* Clear m (all sums, maxima, counts and the reversal pointer 0). */
void ctl_metrics_init(ctl_metrics *m);

/* Which sums a sample at time t (s) enters: CTL_METRICS_FIRST_HALF if not t >= tmid (s, start of the
 * second half), else CTL_METRICS_REVERSAL if its nearest reversal (revs: nrev sorted times, s) is within
 * window (s), else CTL_METRICS_SECOND_HALF. *ip is the reversal pointer (0 at the start; advanced past the
 * reversals before t), so the work over a run is O(N + R) for non-decreasing t. Depends on the time alone:
 * a batch on one reference calls it once per period. */
int ctl_metrics_where(double t, double tmid, const double *revs, long nrev, double window, long *ip);

/* Add one sample of class where (ctl_metrics_where): error e (rad/s), torque u (N*m). m->ip untouched. */
void ctl_metrics_add(ctl_metrics *m, int where, double e, double u);

/* ctl_metrics_where with the pointer m->ip, then ctl_metrics_add: one sample at time t (s, non-decreasing). */
void ctl_metrics_update(ctl_metrics *m, double t, double tmid, const double *revs, long nrev, double window,
                        double e, double u);

/* ctl_metrics_update for the n samples t[i], e[i], u[i] (arrays of n doubles) in order. */
void ctl_metrics_accumulate(ctl_metrics *m, const double *t, const double *e, const double *u, long n,
                            double tmid, const double *revs, long nrev, double window);

#endif
