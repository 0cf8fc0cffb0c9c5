/* ctl_engine.c -- the closed-loop engine (see ctl_engine.h). */
#include <string.h>
#include "ctl_engine.h"
#include "ctl_metrics_sample.h"
#include "aff_adaptive.h"
#include "aff_feedforward.h"

void ctl_scenario_init(ctl_scenario *sc, double w0)
{
    sc->held = w0;
    sc->row = 0;
    sc->k_end = 0;
    sc->diverged = 0;
    sc->n_theta_rec = 0;
    sc->fault_pos = 0;
    sc->smooth = 0;
    sc->use_sensor = 0;
    sc->use_drive = 0;
    sc->use_supervisor = 0;
    for (int i = 0; i < CTL_THETA_NMAX; i++)
        sc->theta_buf[i] = 0.0;
}

void ctl_scenarios_init(ctl_scenario *sc, long n_sc, double w0, double *settle, double *stop_max, long n_stops,
                        double *rev_max, long n_revs)
{
    for (long b = 0; b < n_sc; b++) {
        ctl_scenario_init(sc + b, w0);
        ctl_events_init(&sc[b].events, n_stops ? settle + b * n_stops : NULL, n_stops ? stop_max + b * n_stops : NULL,
                        n_stops, n_revs ? rev_max + b * n_revs : NULL, n_revs);
    }
}

void ctl_scenarios_set_plants(ctl_scenario *sc, long n_sc, const plant_params *rows, const plant_state *states,
                              const int64_t *index, const double *w_limit)
{
    for (long b = 0; b < n_sc; b++) {
        sc[b].rows = rows + index[b];
        sc[b].n_rows = 1;
        sc[b].row_k = NULL;
        sc[b].plant = states[index[b]];
        sc[b].w_limit = w_limit[b];
    }
}

void ctl_scenarios_set_pi(ctl_scenario *sc, long n_sc, const ctl_pi *pi)
{
    for (long b = 0; b < n_sc; b++)
        sc[b].pi = *pi;
}

/* What a scenario uses besides the plant, the PI and the metrics (bits of ctl_features): the period's code for a
 * part no scenario of a chunk uses is left out (ctl_run_chunk picks a specialised loop once per call). */
enum {
    CTL_F_ROWS = 1 << 0,     /* a time-varying plant (more than one parameter row) */
    CTL_F_SENSOR = 1 << 1,   /* a sensor model (use_sensor) */
    CTL_F_FAULTS = 1 << 2,   /* injected faults (the run's) */
    CTL_F_ORACLE = 1 << 3,   /* the oracle feedforward (the run's) */
    CTL_F_OPS = 1 << 4,      /* a compensator */
    CTL_F_TRANSFER = 1 << 5, /* a compensator with its own supervisor (ops->transfer) */
    CTL_F_SUP = 1 << 6,      /* the engine's supervisor (use_supervisor) */
    CTL_F_DRIVE = 1 << 7,    /* a drive model (use_drive) */
    CTL_F_ALL = (1 << 8) - 1
};

/* The parts scenario sc of run uses (CTL_F_ bits). */
static unsigned ctl_features(const ctl_run *run, const ctl_scenario *sc)
{
    unsigned f = 0;
    f |= sc->n_rows > 1 ? CTL_F_ROWS : 0u;
    f |= sc->use_sensor ? CTL_F_SENSOR : 0u;
    f |= run->n_faults > 0 ? CTL_F_FAULTS : 0u;
    f |= run->oracle ? CTL_F_ORACLE : 0u;
    f |= sc->ops != NULL ? CTL_F_OPS : 0u;
    f |= sc->ops != NULL && sc->ops->transfer != NULL ? CTL_F_TRANSFER : 0u;
    f |= sc->use_supervisor ? CTL_F_SUP : 0u;
    f |= sc->use_drive ? CTL_F_DRIVE : 0u;
    return f;
}

/* GCC, Clang: inline the period into each specialised loop (its flags then constants). */
#if defined(__GNUC__)
#define CTL_ALWAYS_INLINE __attribute__((always_inline))
#define CTL_FLATTEN __attribute__((flatten))
#else
#define CTL_ALWAYS_INLINE
#define CTL_FLATTEN
#endif

/* The parameter row of period k (a time-varying plant moves to row j at period row_k[j]). */
static inline CTL_ALWAYS_INLINE const plant_params *row_at(ctl_scenario *sc, long k, unsigned F)
{
    if (!(F & CTL_F_ROWS)) /* no scenario of the chunk has more than row 0 */
        return sc->rows;
    while (sc->row + 1 < sc->n_rows && k >= sc->row_k[sc->row + 1])
        sc->row += 1;
    return sc->rows + sc->row;
}

/* The sensor sample of period k (noise or an injected fault) into *wm; returns the controller's
 * measurement (the held value after a sample the gate rejected). */
static inline CTL_ALWAYS_INLINE double sense(const ctl_run *run, ctl_scenario *sc, long k, double w, double *wm,
                                              unsigned F)
{
    double nk = sc->noise != NULL ? sc->noise[k] : 0.0;
    double m = (F & CTL_F_SENSOR) && sc->use_sensor ? ctl_sensor_measure(&sc->sensor, w, nk) : w + nk;
    if (F & CTL_F_FAULTS) { /* faults sorted by sample index */
        long fp = sc->fault_pos;
        while (fp < run->n_faults && run->fault_k[fp] < k)
            fp++;
        sc->fault_pos = fp;
        if (fp < run->n_faults && run->fault_k[fp] == k)
            m = run->fault_v[fp];
    }
    *wm = m;
    if (sc->use_gate) {
        if (aff_gate_check(&sc->gate, m))
            sc->held = m;
        return sc->held;
    }
    return m;
}

/* The compensator a specialised loop knows (its functions called directly, inlined), else CTL_K_TABLE (through
 * the scenario's table sc->ops). */
enum { CTL_K_TABLE = 0, CTL_K_FIXED = 1, CTL_K_ADAPTIVE = 2 };

/* ops->compensate, ops->observe, ops->transfer of a compensator of kind K (CTL_K_). */
static inline CTL_ALWAYS_INLINE double k_compensate(int K, const aff_compensator_ops *ops, void *c, double wc,
                                                     double wm, double wr)
{
    if (K == CTL_K_FIXED)
        return aff_fixed_ff_compensate(c, wc, wm, wr);
    if (K == CTL_K_ADAPTIVE)
        return aff_adaptive_compensate(c, wc, wm, wr);
    return ops->compensate(c, wc, wm, wr);
}

static inline CTL_ALWAYS_INLINE int k_observe(int K, const aff_compensator_ops *ops, void *c, double u, double wm,
                                               double *theta)
{
    if (K == CTL_K_FIXED)
        return aff_fixed_ff_observe(c, u, wm, theta);
    if (K == CTL_K_ADAPTIVE)
        return aff_adaptive_observe(c, u, wm, theta);
    return ops->observe(c, u, wm, theta);
}

static inline CTL_ALWAYS_INLINE double k_transfer(int K, const aff_compensator_ops *ops, void *c)
{
    if (K == CTL_K_ADAPTIVE)
        return aff_adaptive_transfer(c);
    return ops->transfer(c);
}

/* The feedforward of period k (the compensator's, through the supervisors, or the oracle's f); the transfers of
 * the supervisors go into the PI's integrator. ops: the scenario's compensator table (sc->ops, or the same table
 * known to the loop). */
static inline CTL_ALWAYS_INLINE double feedforward(const ctl_run *run, ctl_scenario *sc, double wc, double wm,
                                                    double wrk, double f, unsigned F, int K)
{
    const aff_compensator_ops *ops = sc->ops;
    double uff = 0.0;
    if ((F & CTL_F_OPS) && ops != NULL) {
        uff = k_compensate(K, ops, sc->comp, wc, wm, wrk);
        /* a compensator with its own supervisor (aff_adaptive) */
        if ((F & CTL_F_TRANSFER) && ops->transfer != NULL) {
            double tr = k_transfer(K, ops, sc->comp);
            if (tr != 0.0)
                sc->pi.I += tr;
        }
    } else if ((F & CTL_F_ORACLE) && run->oracle)
        uff = f;
    if ((F & CTL_F_SUP) && sc->use_supervisor) {
        if (ops != NULL && ops->rest_lag != NULL) /* withdrawn at rest through its lag in use */
            aff_supervisor_set_rest_lag(&sc->sup, ops->rest_lag(sc->comp));
        uff = aff_supervisor_apply(&sc->sup, uff, wrk);
        if (sc->sup.transfer != 0.0) /* bumpless transfer into the PI's integrator (aff_supervisor.h) */
            sc->pi.I += (double)sc->sup.transfer;
        if (sc->sup.rest && ops != NULL && ops->at_rest != NULL) /* nothing applied: tell it */
            ops->at_rest(sc->comp);
    }
    return uff;
}

/* One period of scenario sc; 0 once it diverged (it then stays where it stopped). r: the record index of the
 * period (-1: not recorded). K: the kind of every scenario's compensator where the loop knows it (CTL_K_). */
static inline CTL_ALWAYS_INLINE int period(const ctl_run *restrict run, ctl_scenario *restrict sc, long k, long r,
                                            int where, const ctl_motion *restrict mo, unsigned F, int K)
{
    const plant_params *par = row_at(sc, k, F);
    double w = sc->plant.w;
    double wm;
    double wc = sense(run, sc, k, w, &wm, F);
    double wrk = run->w_ref[k];
    int rec = r >= 0 && sc->rec != NULL;
    double f = (rec || ((F & CTL_F_ORACLE) && run->oracle)) ? plant_friction(par, &sc->plant)
                                                            : 0.0; /* LuGre: eq. 3 only if used */
    double uff = feedforward(run, sc, wc, wm, wrk, f, F, K);
    double u = ctl_pi_step(&sc->pi, wrk - wc, uff);
    if ((F & CTL_F_DRIVE) && sc->use_drive)
        u = ctl_drive_apply(&sc->drive, u);
    if ((F & CTL_F_OPS) && sc->ops != NULL && k_observe(K, sc->ops, sc->comp, u, wm, sc->theta_buf)
        && sc->theta != NULL) {
        long j = sc->n_theta_rec;
        if (j < run->m_theta) {
            for (long i = 0; i < run->n_theta; i++)
                sc->theta[j * run->n_theta + i] = sc->theta_buf[i];
            sc->theta_k[j] = k;
            sc->n_theta_rec += 1;
        }
    }
    if ((F & CTL_F_SUP) && sc->use_supervisor)
        aff_supervisor_observe(&sc->sup, u, wc);
    if (rec) { /* the five records of period r, a stride n_rec apart (loaded once: the stores alias nothing read) */
        double *rp = sc->rec + r;
        long nr = run->n_rec;
        rp[0] = w;
        rp[nr] = wm;
        rp[2 * nr] = u;
        rp[3 * nr] = uff;
        rp[4 * nr] = f;
    }
    metrics_add_sample(&sc->metrics, where, wrk - w, u);
    metrics_add_motion_sample(&sc->metrics, where, mo->rest, wrk - w);
    if (mo->stop >= 0 || mo->rev >= 0) /* else no event in progress: nothing to add */
        events_add_sample(&sc->events, mo, run->t[k], wrk - w);
    if (!(F & CTL_F_ROWS) && sc->smooth) /* the model's tests done once per call (ctl_run_chunk) */
        plant_step_smooth(par, &sc->plant, u, run->dt);
    else
        plant_step(par, &sc->plant, u, run->dt);
    w = sc->plant.w;
    if (!(-sc->w_limit < w && w < sc->w_limit)) {
        sc->diverged = 1;
        sc->k_end = k + 1;
        return 0;
    }
    return 1;
}

/* ctl_run_chunk's loop over the periods with the parts F (CTL_F_ bits: a superset of what each scenario uses) and
 * the kind K of every scenario's compensator (CTL_K_; CTL_K_TABLE: each through its table). */
static inline CTL_ALWAYS_INLINE void run_periods(const ctl_run *run, ctl_scenario *sc, long n_sc, long n_alive,
                                                  unsigned F, int K)
{
    long n = run->n;
    double tmid = n > 0 ? 0.5 * (run->t[0] + run->t[n - 1]) : 0.0;
    long dec = run->decimate;
    long next_rec = 0; /* the next recorded period (k % dec == 0, without a division per period) */
    long n_recs = 0;   /* its record index, k / dec */
    ctl_motion mo;
    ctl_motion_init(&mo, run->settle_share, run->settle_floor, run->window);
    for (long k = 0; k < n && n_alive > 0; k++) {
        long r = -1;
        if (dec > 0 && k == next_rec) {
            r = n_recs++;
            next_rec += dec;
        }
        motion_where_sample(&mo, run->t, run->w_ref, n, k, run->revs, run->n_revs);
        /* ctl_metrics_where's class: its reversal test is mo.rev's (the nearest reversal within the window) */
        int where = !(run->t[k] >= tmid) ? CTL_METRICS_FIRST_HALF
                    : mo.rev >= 0        ? CTL_METRICS_REVERSAL
                                         : CTL_METRICS_SECOND_HALF;
        for (long b = 0; b < n_sc; b++)
            if (sc[b].diverged == 0 && !period(run, sc + b, k, r, where, &mo, F, K))
                n_alive--;
    }
}

/* 1 if every scenario of sc[0..n_sc-1] has the table ops. */
static int same_ops(const ctl_scenario *sc, long n_sc, const aff_compensator_ops *ops)
{
    for (long b = 0; b < n_sc; b++)
        if (sc[b].ops != ops)
            return 0;
    return 1;
}

const aff_compensator_ops *ctl_known_ops(const char *name)
{
    if (name != NULL && strcmp(name, "aff_fixed_ff_ops") == 0)
        return &aff_fixed_ff_ops;
    if (name != NULL && strcmp(name, "aff_adaptive_ops") == 0)
        return &aff_adaptive_ops;
    return NULL;
}

/* GCC, Clang: every call the loops make is inlined (the plant's step, the gate, a known compensator's functions)
 * but those through a table (sc->ops) and the ones kept out on purpose (the plant's rare paths). */
CTL_FLATTEN void ctl_run_chunk(const ctl_run *run, ctl_scenario *sc, long n_sc)
{
    long n_alive = 0;
    unsigned F = 0;
    for (long b = 0; b < n_sc; b++) {
        n_alive += sc[b].diverged == 0;
        sc[b].smooth = sc[b].n_rows == 1 && plant_step_is_smooth(sc[b].rows, run->dt);
        F |= ctl_features(run, sc + b);
    }
    /* the common runs without sensor and drive models, faults, oracle, engine supervisor or plant rows: no
     * compensator, a compensator, one with its own supervisor (mode "fixed"'s and "adaptive"'s called directly
     * where every scenario has it); any other: every part's test in the loop */
    if (F == 0)
        run_periods(run, sc, n_sc, n_alive, 0, CTL_K_TABLE);
    else if (F == CTL_F_OPS && same_ops(sc, n_sc, &aff_fixed_ff_ops))
        run_periods(run, sc, n_sc, n_alive, CTL_F_OPS, CTL_K_FIXED);
    else if (F == CTL_F_OPS)
        run_periods(run, sc, n_sc, n_alive, CTL_F_OPS, CTL_K_TABLE);
    else if (F == (CTL_F_OPS | CTL_F_TRANSFER) && same_ops(sc, n_sc, &aff_adaptive_ops))
        run_periods(run, sc, n_sc, n_alive, CTL_F_OPS | CTL_F_TRANSFER, CTL_K_ADAPTIVE);
    else if (F == (CTL_F_OPS | CTL_F_TRANSFER))
        run_periods(run, sc, n_sc, n_alive, CTL_F_OPS | CTL_F_TRANSFER, CTL_K_TABLE);
    else
        run_periods(run, sc, n_sc, n_alive, CTL_F_ALL, CTL_K_TABLE);
    for (long b = 0; b < n_sc; b++)
        if (sc[b].diverged == 0)
            sc[b].k_end = run->n;
}
