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
 *
 * Motion metrics (a robot's moves: point-to-point with dwell, constant speed with reversals). Definitions, for
 * the reference w_ref sampled at t[0..n-1] and e = w_ref - w (rad/s):
 *  - at standstill: a sample with w_ref[k] == 0 in a run of at least two such samples, or at either end of the
 *    reference (k == 0 or k == n-1); in motion: every other sample (w_ref != 0, or a lone zero sample where the
 *    reference crosses zero on a sample, a reversal);
 *  - a stop: a run of standstill samples that follows motion (plant.excitation.Reference.stops: its first
 *    sample), from that sample to its last one (the sample before the next motion, or the end);
 *  - the settling band of a stop: b = max(share * (the move's peak speed), floor) (rad/s), the move's peak speed
 *    being the largest |w_ref| since the previous standstill; share (e.g. 0.02) and floor (band_floor, rad/s,
 *    e.g. a noise level) are the caller's;
 *  - the settling time of a stop: t[j+1] - t[k0], j the last sample of the stop with |e| > b (0 when none),
 *    k0 its first sample; to one sample. INFINITY when |e| > b at the stop's last sample (it did not settle
 *    before the next move or the end of the run); NaN when the run ended before the stop did (diverged);
 *  - the largest |e| during a stop (the dwell);
 *  - a reversal window: the samples whose nearest reversal (the earlier of two equally near) is within window
 *    (s) of them, the same samples as CTL_METRICS_REVERSAL's but over the whole run; the largest |e| in each;
 *  - second half, at standstill and in motion: sums of e^2 and the largest |e| at standstill (drift while the
 *    reference holds still), of the second-half samples (the samples of e2_half).
 * The velocity error is what the loop tracks; a position error would add the integral of e since the move's
 * start, which the loop does not control. The motion/standstill sums are fields of ctl_metrics
 * (ctl_metrics_add_motion); the per-stop and per-reversal results go to arrays the caller sizes by the counts of
 * the reference (ctl_motion_stops, the reversal times), through ctl_events; the classification of a sample,
 * which depends on the reference alone, is ctl_motion_where (once per period for a batch). Python:
 * controllers.simulation.metrics (MotionMetrics, motion_metrics, stop_intervals).
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
    double e2_move;     /* sum of e^2 over the second-half samples in motion ((rad/s)^2) */
    double e2_move_c;   /* its compensation */
    double e2_rest;     /* sum of e^2 over the second-half samples at standstill ((rad/s)^2) */
    double e2_rest_c;   /* its compensation */
    double e_max_rest;  /* max |e| over the second-half samples at standstill (rad/s) */
    long n_move;        /* second-half samples in motion */
    long n_rest;        /* second-half samples at standstill */
} ctl_metrics;

/* What the reference does at one sample (ctl_motion_where; the definitions above). One per pass over the
 * reference, shared by the scenarios of a batch. */
typedef struct ctl_motion {
    double share;       /* settling band as a share of the move's peak speed (-) */
    double band_floor;  /* the band's lower bound (rad/s) */
    double window;      /* half-width of the reversal windows (s) */
    int rest;           /* 1: the sample is at standstill */
    long stop;          /* the stop it belongs to (0, 1, ... in time order), -1: none */
    int stop_end;       /* 1: it is the stop's last sample */
    double t_stop;      /* the stop's first sample time (s) */
    double band;        /* the stop's settling band (rad/s) */
    long rev;           /* the reversal whose window holds the sample, -1: none */
    int rev_end;        /* 1: it is the window's last sample */
    long n_stops;       /* stops begun so far */
    double peak;        /* largest |w_ref| since the last standstill sample (rad/s) */
    long ip;            /* reversal pointer (index of the first reversal >= t) */
} ctl_motion;

/* One scenario's per-stop and per-reversal results and the state of the events in progress. The output arrays
 * are the caller's (NaN until an event is complete); an event beyond their capacity is not written. */
typedef struct ctl_events {
    double *settle;     /* n_stops settling times (s): INFINITY not settled, NaN not complete */
    double *stop_max;   /* n_stops largest |e| during each stop (rad/s) */
    double *rev_max;    /* n_revs largest |e| in each reversal's window (rad/s) */
    long n_stops;       /* capacity of settle and stop_max */
    long n_revs;        /* capacity of rev_max */
    long stop;          /* the stop in progress, -1: none */
    int out;            /* 1: its last sample was outside the band */
    double t_in;        /* time since which |e| stayed within the band (s) */
    double e_max_stop;  /* its largest |e| so far (rad/s) */
    long rev;           /* the reversal window in progress, -1: none */
    double e_max_rev;   /* its largest |e| so far (rad/s) */
} ctl_events;

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

/* Add the motion sums of one sample of class where (ctl_metrics_where) that is at standstill (rest 1, ctl_motion)
 * or in motion (rest 0): error e (rad/s). First-half samples are not added. The fields of ctl_metrics_add are
 * not touched. */
void ctl_metrics_add_motion(ctl_metrics *m, int where, int rest, double e);

/* Start a pass over a reference: the band's share (-, >= 0) and floor band_floor (rad/s, >= 0), the reversal
 * windows' half-width window (s); no stop, no reversal, peak 0. */
void ctl_motion_init(ctl_motion *c, double share, double band_floor, double window);

/* Classify sample k of the reference (t: n times, s, increasing; w_ref: n velocities, rad/s; revs: nrev sorted
 * reversal times, s): fills c->rest, stop, stop_end, t_stop, band, rev, rev_end (definitions above). Call for
 * k = 0, 1, ..., n-1 in order (c keeps the stop count, the move's peak and the reversal pointer). O(1) amortised. */
void ctl_motion_where(ctl_motion *c, const double *t, const double *w_ref, long n, long k, const double *revs,
                      long nrev);

/* The stops of a reference (t, w_ref: n samples) with the band share and floor: writes the first cap of them
 * (t0: first sample time, t1: last sample time, s; band: rad/s; any of the three may be NULL when cap is 0) and
 * returns how many there are (call with cap 0 to size the arrays). */
long ctl_motion_stops(const double *t, const double *w_ref, long n, double share, double band_floor, double *t0,
                      double *t1, double *band, long cap);

/* Point ev at the caller's arrays (settle, stop_max: n_stops doubles; rev_max: n_revs doubles; NULL with a
 * capacity 0), fill them with NaN and clear the events in progress. */
void ctl_events_init(ctl_events *ev, double *settle, double *stop_max, long n_stops, double *rev_max, long n_revs);

/* Add the error e (rad/s) at time t (s) of the sample c classified (ctl_motion_where): updates the stop and the
 * reversal window in progress and writes each one's result at its last sample. */
void ctl_events_add(ctl_events *ev, const ctl_motion *c, double t, double e);

/* The motion metrics of a recorded run: for k = 0..n-1, ctl_metrics_where (pointer m->ip, start of the second
 * half tmid, s), ctl_motion_where on (t, w_ref), ctl_metrics_add_motion and ctl_events_add with e[k]; c must be
 * initialised (ctl_motion_init), ev too (ctl_events_init). Only the motion fields of m and m->ip change. */
void ctl_motion_accumulate(ctl_metrics *m, ctl_motion *c, ctl_events *ev, const double *t, const double *w_ref,
                           const double *e, long n, double tmid, const double *revs, long nrev);

#endif
