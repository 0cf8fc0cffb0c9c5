/* ctl_engine.h -- the closed-loop engine: plant o sensor o PI o compensator, one period at a time.
 *
 * Per controller period Tc (Ruderman's 1 kHz), for every scenario:
 *   w_meas = w + noise[k] (or, with a sensor, its measurement: an encoder's difference quotient, a delay:
 *   ctl_sensor), or the injected fault of sample k;
 *   the sensor gate (aff_gate) gives the controller its measurement w_ctrl (the held value after a
 *   rejected sample);
 *   u_ff = ops->compensate(comp, w_ctrl, w_meas, w_ref[k])  (or the plant's true friction: the oracle);
 *   with a supervisor (aff_supervisor) u_ff is applied only while it helps (else 0), a switch moved into the
 *   PI's integrator (bumpless transfer); with the reference at rest (its rest rule, nothing applied) the
 *   compensator is told, ops->at_rest(comp) (aff_compensator.h; if it has one); a compensator that carries its
 *   own supervisor (mode "adaptive", aff_adaptive) reports its transfer through ops->transfer, added to the PI's
 *   integrator the same way;
 *   u = PI(w_ref[k] - w_ctrl, u_ff) (ctl_pi, saturated), then the drive's slew-rate limit (ctl_drive, if any);
 *   ops->observe(comp, u, w_meas, theta) (the estimate recorded after an update);
 *   the supervisor observes (u, w_ctrl);
 *   the metrics take e = w_ref[k] - w and u (ctl_metrics), the motion metrics e (ctl_metrics_add_motion,
 *   ctl_events_add; the reference's stops and reversal windows classified once per period, ctl_motion_where);
 *   the plant advances one step with u held (plant_step); |w| >= w_limit ends the scenario (diverged).
 * A single run is a batch of one. ctl_run_chunk advances scenarios sc[0..n_sc-1] time-major (every scenario
 * of the chunk one period before the next period), which lets the CPU overlap their independent RK4
 * chains; the Python side runs chunks on threads (cffi releases the GIL). A scenario's numbers do not depend
 * on the chunking. No allocation; the work per period is bounded by the plant's sub-steps. The loop is chosen once
 * per call for the parts the chunk's scenarios use (a compensator, its own supervisor, the engine's supervisor,
 * sensor and drive models, faults, the oracle, a time-varying plant): a part none of them uses costs nothing per
 * period.
 * Python: controllers.simulation.engine.run_engine.
 */
#ifndef CTL_ENGINE_H
#define CTL_ENGINE_H
#include <stddef.h>
#include <stdint.h>
#include "plant_dynamics.h"
#include "aff_gate.h"
#include "aff_compensator.h"
#include "ctl_pi.h"
#include "ctl_metrics.h"
#include "ctl_sensor.h"
#include "ctl_drive.h"
#include "aff_supervisor.h"

/* Largest parameter vector a compensator may report through observe. */
#define CTL_THETA_NMAX 32

/* What all scenarios of a run share (read only). */
typedef struct ctl_run {
    const double *t;          /* time (s), n samples */
    const double *w_ref;      /* velocity reference (rad/s), n samples */
    long n;                   /* periods */
    double dt;                /* controller period = integration step Tc (s) */
    const double *revs;       /* reversal times of the reference (s), n_revs, increasing */
    long n_revs;
    double window;            /* half-width of the reversal windows of the metrics (s) */
    const int64_t *fault_k;   /* samples whose measurement is replaced (increasing), n_faults */
    const double *fault_v;    /* their values (rad/s) */
    long n_faults;
    int oracle;               /* 1: the feedforward is the plant's true friction (the oracle mode) */
    long decimate;            /* record every decimate-th period (0: none) */
    long n_rec;               /* records per signal: ceil(n/decimate) */
    long n_theta;             /* length of the compensator's parameter vector (<= CTL_THETA_NMAX) */
    long m_theta;             /* capacity of the estimate history (0: none) */
    double settle_share;      /* settling band of the stops: share of the move's peak speed (-) (ctl_motion) */
    double settle_floor;      /* and its lower bound (rad/s) */
} ctl_run;

/* One scenario: its plant, sensor, controller, compensator, metrics and records. */
typedef struct ctl_scenario {
    const plant_params *rows;   /* n_rows parameter rows; row j from sample row_k[j] on (a time-varying plant:
                                   drift, payload step) */
    long n_rows;
    const long *row_k;          /* start sample of each row: row_k[0] = 0, increasing; NULL where n_rows == 1 */
    plant_state plant;          /* the plant's state, advanced in place */
    double w_limit;             /* divergence bound on |w| (rad/s) */
    const double *noise;        /* n measurement-noise samples (rad/s), or NULL */
    int use_gate;               /* 1: the controller's measurement passes the sensor gate */
    aff_gate gate;
    int use_sensor;             /* 1: the measurement is the sensor's (encoder, delay), else w + noise */
    ctl_sensor sensor;
    int use_drive;              /* 1: the torque passes the drive's slew-rate limit */
    ctl_drive drive;
    int use_supervisor;         /* 1: the compensator's torque passes the supervisor (aff_supervisor) */
    aff_supervisor sup;
    ctl_pi pi;
    void *comp;                 /* the compensator's struct, or NULL (none, oracle) */
    const aff_compensator_ops *ops;
    ctl_metrics metrics;
    ctl_events events;          /* per-stop and per-reversal results (ctl_events_init; zeroed: none) */
    double *rec;                /* 5 x n_rec records (w, w_meas, u, u_ff, f), row-major, or NULL */
    double *theta;              /* m_theta x n_theta estimates after updates, or NULL */
    int64_t *theta_k;           /* the period of each */
    double held;                /* the controller's measurement held after a rejected sample (rad/s) */
    long row;                   /* current parameter row */
    long k_end;                 /* periods run (n unless diverged) */
    int diverged;               /* 1 once |w| left w_limit */
    long n_theta_rec;           /* estimates recorded */
    long fault_pos;             /* next fault to apply */
    int smooth;                 /* 1: one parameter row with plant_step_is_smooth (set by ctl_run_chunk) */
    double theta_buf[CTL_THETA_NMAX];
} ctl_scenario;

/* Prepare sc for a run that starts from the plant state s0 (rad/s, N*m or rad) with the sensor gate holding
 * w0 (rad/s); the other fields (rows, gate, pi, comp/ops, metrics, records) are set by the caller. */
void ctl_scenario_init(ctl_scenario *sc, double w0);

/* ctl_scenario_init(sc + b, w0) and ctl_events_init of sc[b].events on row b of the per-event arrays (settle,
 * stop_max: n_sc x n_stops doubles; rev_max: n_sc x n_revs doubles; row-major, NULL with a count 0) for
 * b = 0..n_sc-1, sc zeroed before (the run's scenarios, the Python side's one call instead of 2*n_sc). */
void ctl_scenarios_init(ctl_scenario *sc, long n_sc, double w0, double *settle, double *stop_max, long n_stops,
                        double *rev_max, long n_revs);

/* Scenario b's plant, for b = 0..n_sc-1: the one parameter row rows + index[b] (a plant that does not vary in
 * time: n_rows 1, row_k NULL), its initial state states[index[b]] (copied) and the divergence bound w_limit[b]
 * (rad/s); index[b] in [0, number of rows), the caller's to ensure. */
void ctl_scenarios_set_plants(ctl_scenario *sc, long n_sc, const plant_params *rows, const plant_state *states,
                              const int64_t *index, const double *w_limit);

/* Copy the PI *pi into scenarios sc[0..n_sc-1] (a common controller, copied by value into each). */
void ctl_scenarios_set_pi(ctl_scenario *sc, long n_sc, const ctl_pi *pi);

/* This module's own ops table of the given name ("aff_fixed_ff_ops", "aff_adaptive_ops"), NULL for any other: a
 * scenario that holds it runs in a loop that calls the compensator's functions directly (inlined, the same results),
 * where every scenario of a chunk has the same one (ctl_run_chunk). */
const aff_compensator_ops *ctl_known_ops(const char *name);

/* Run scenarios sc[0..n_sc-1] over all periods of run (or until each diverged); sets k_end. */
void ctl_run_chunk(const ctl_run *run, ctl_scenario *sc, long n_sc);

#endif
