/* ctl_engine.c -- the closed-loop engine (see ctl_engine.h). */
#include "ctl_engine.h"

void ctl_scenario_init(ctl_scenario *sc, double w0)
{
    sc->held = w0;
    sc->row = 0;
    sc->k_end = 0;
    sc->diverged = 0;
    sc->n_theta_rec = 0;
    sc->fault_pos = 0;
    sc->use_sensor = 0;
    sc->use_drive = 0;
    sc->use_supervisor = 0;
    for (int i = 0; i < CTL_THETA_NMAX; i++)
        sc->theta_buf[i] = 0.0;
}

/* The parameter row of period k (a time-varying plant moves to row j at period row_k[j]). */
static const plant_params *row_at(ctl_scenario *sc, long k)
{
    while (sc->row + 1 < sc->n_rows && k >= sc->row_k[sc->row + 1])
        sc->row += 1;
    return sc->rows + sc->row;
}

/* The sensor sample of period k (noise or an injected fault) into *wm; returns the controller's
 * measurement (the held value after a sample the gate rejected). */
static double sense(const ctl_run *run, ctl_scenario *sc, long k, double w, double *wm)
{
    double nk = sc->noise != NULL ? sc->noise[k] : 0.0;
    double m = sc->use_sensor ? ctl_sensor_measure(&sc->sensor, w, nk) : w + nk;
    if (run->n_faults > 0) { /* faults sorted by sample index */
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

/* One period of scenario sc; 0 once it diverged (it then stays where it stopped). */
static int period(const ctl_run *run, ctl_scenario *sc, long k, int where, const ctl_motion *mo)
{
    const plant_params *par = row_at(sc, k);
    double w = sc->plant.w;
    double wm;
    double wc = sense(run, sc, k, w, &wm);
    double wrk = run->w_ref[k];
    int rec = sc->rec != NULL && run->decimate > 0 && k % run->decimate == 0;
    double f = (rec || run->oracle) ? plant_friction(par, &sc->plant) : 0.0; /* LuGre: eq. 3 only if used */
    double uff = 0.0;
    if (sc->ops != NULL) {
        uff = sc->ops->compensate(sc->comp, wc, wm, wrk);
        if (sc->ops->transfer != NULL) { /* a compensator with its own supervisor (aff_adaptive) */
            double tr = sc->ops->transfer(sc->comp);
            if (tr != 0.0)
                sc->pi.I += tr;
        }
    } else if (run->oracle)
        uff = f;
    if (sc->use_supervisor) {
        if (sc->ops != NULL && sc->ops->rest_lag != NULL) /* withdrawn at rest through its lag in use */
            aff_supervisor_set_rest_lag(&sc->sup, sc->ops->rest_lag(sc->comp));
        uff = aff_supervisor_apply(&sc->sup, uff, wrk);
        if (sc->sup.transfer != 0.0) /* bumpless transfer into the PI's integrator (aff_supervisor.h) */
            sc->pi.I += (double)sc->sup.transfer;
        if (sc->sup.rest && sc->ops != NULL && sc->ops->at_rest != NULL) /* nothing applied: tell it */
            sc->ops->at_rest(sc->comp);
    }
    double u = ctl_pi_step(&sc->pi, wrk - wc, uff);
    if (sc->use_drive)
        u = ctl_drive_apply(&sc->drive, u);
    if (sc->ops != NULL && sc->ops->observe(sc->comp, u, wm, sc->theta_buf) && sc->theta != NULL) {
        long j = sc->n_theta_rec;
        if (j < run->m_theta) {
            for (long i = 0; i < run->n_theta; i++)
                sc->theta[j * run->n_theta + i] = sc->theta_buf[i];
            sc->theta_k[j] = k;
            sc->n_theta_rec += 1;
        }
    }
    if (sc->use_supervisor)
        aff_supervisor_observe(&sc->sup, u, wc);
    if (rec) {
        long r = k / run->decimate;
        sc->rec[0 * run->n_rec + r] = w;
        sc->rec[1 * run->n_rec + r] = wm;
        sc->rec[2 * run->n_rec + r] = u;
        sc->rec[3 * run->n_rec + r] = uff;
        sc->rec[4 * run->n_rec + r] = f;
    }
    ctl_metrics_add(&sc->metrics, where, wrk - w, u);
    ctl_metrics_add_motion(&sc->metrics, where, mo->rest, wrk - w);
    if (mo->stop >= 0 || mo->rev >= 0) /* else no event in progress: nothing to add */
        ctl_events_add(&sc->events, mo, run->t[k], wrk - w);
    plant_step(par, &sc->plant, u, run->dt);
    w = sc->plant.w;
    if (!(-sc->w_limit < w && w < sc->w_limit)) {
        sc->diverged = 1;
        sc->k_end = k + 1;
        return 0;
    }
    return 1;
}

void ctl_run_chunk(const ctl_run *run, ctl_scenario *sc, long n_sc)
{
    long n = run->n;
    long n_alive = 0;
    for (long b = 0; b < n_sc; b++)
        n_alive += sc[b].diverged == 0;
    double tmid = n > 0 ? 0.5 * (run->t[0] + run->t[n - 1]) : 0.0;
    ctl_motion mo;
    ctl_motion_init(&mo, run->settle_share, run->settle_floor, run->window);
    for (long k = 0; k < n && n_alive > 0; k++) {
        ctl_motion_where(&mo, run->t, run->w_ref, n, k, run->revs, run->n_revs);
        /* ctl_metrics_where's class: its reversal test is mo.rev's (the nearest reversal within the window) */
        int where = !(run->t[k] >= tmid) ? CTL_METRICS_FIRST_HALF
                    : mo.rev >= 0        ? CTL_METRICS_REVERSAL
                                         : CTL_METRICS_SECOND_HALF;
        for (long b = 0; b < n_sc; b++)
            if (sc[b].diverged == 0 && !period(run, sc + b, k, where, &mo))
                n_alive--;
    }
    for (long b = 0; b < n_sc; b++)
        if (sc[b].diverged == 0)
            sc[b].k_end = n;
}
