/* aff_drive.h -- the package's mode "adaptive" for a drive's velocity loop: init, two calls a period, a status.
 *
 * The compensator is aff_adaptive (aff_adaptive.h): the robust adaptive feedforward, the residual observer it
 * switches in (with the switch-in's trial) and the feedforward supervisor (with its rest rule), the same struct and
 * functions the package's closed-loop engine runs for mode "adaptive" (`adaptive-ff export-c --feedforward-only`:
 * the same struct with the observer and the supervisor turned off, the feedforward alone). Per controller period Tc,
 * in this order (docs/your_loop.md):
 *   u_ff = aff_step(&c, w, w_ref);      compensation torque of this period (N*m)
 *   I   += aff_transfer(&c);            the supervisor's bumpless transfer into your PI's integrator (N*m; 0 except
 *                                       in a period the supervisor switches the compensation on or off)
 *   u    = your controller(w_ref - w) + u_ff, saturated: the torque applied in this period (N*m)
 *   aff_observe(&c, u, w);              learn from the applied torque and the measured velocity
 * with w the raw velocity sample (rad/s) and w_ref the velocity reference (rad/s).
 *
 * The input guard (drive-grade inputs). Every input of both calls (w, w_ref, u) is checked before it touches the
 * compensator's state: a non-finite or subnormal value, or one beyond its plausible bound (|w|, |w_ref| > w_max,
 * |u| > u_max of aff_guard_config), is refused and counted, and the whole period is dropped: aff_step returns the
 * last output and changes nothing, or aff_observe puts back the state from before this period's aff_step. After the
 * last bad sample the state is therefore what it would be had the bad periods never happened. A held output older
 * than hold_time fades linearly to 0 over another hold_time (aff_status: AFF_STATE_FAULT, faded). With clean inputs
 * the guard changes nothing: aff_step/aff_observe give the engine's numbers bit for bit (double build).
 *
 * No allocation, no I/O, no global state; every call does a bounded amount of work (one RLS update of at most
 * AFF_RLS_NMAX parameters every Ts/Tc calls at most; one copy of aff_saved). The compensator is configured from an
 * aff_config (settings in SI units; aff_default_config, or AFF_CONFIG of `adaptive-ff export-c`): aff_init checks
 * every field and computes the derived ones (filter coefficients, forgetting factors, counts), the same functions the
 * package's Python classes call with the same settings. Python: the same functions through cffi (adaptive_ff._caff);
 * controllers.peers.adaptive_dob.AdaptiveCompensator wraps aff_adaptive.
 */
#ifndef AFF_DRIVE_H
#define AFF_DRIVE_H
#include <stdint.h>
#include "aff_real.h"
#include "aff_adaptive.h"
#include "aff_error.h"

/* The input guard's settings (SI units). */
typedef struct aff_guard_config {
    aff_real Tc;          /* controller period (s), finite, > 0; default 0.001 */
    aff_real w_max;       /* largest plausible |w|, |w_ref| (rad/s), finite, > 0; default 1e4 (a few times your top
                             speed) */
    aff_real u_max;       /* largest plausible |u| (N*m), finite, > 0; default 1e6 (twice your torque limit) */
    aff_real hold_time;   /* a held output older than this fades to 0 over the same time (s), finite, >= Tc;
                             default 0.1 */
} aff_guard_config;

/* The drive's settings: mode "adaptive" and the input guard. `adaptive-ff export-c` writes them as AFF_CONFIG
 * (aff_config.c, a designated initializer of this struct). */
typedef struct aff_config {
    aff_adaptive_config mode; /* mode "adaptive" (aff_adaptive.h): the feedforward, the residual observer, the
                                 supervisor */
    aff_guard_config guard;   /* the input guard */
} aff_config;

/* The compensator's state as a drive reports it. */
typedef enum aff_state {
    AFF_STATE_LEARNING = 0,    /* nothing applied yet: the estimator learns, the output is 0 */
    AFF_STATE_FEEDFORWARD = 1, /* the feedforward acts (an estimate or the provisional start map) */
    AFF_STATE_OBSERVER = 2,    /* the residual observer acts too (switched in) */
    AFF_STATE_BACKED_OFF = 3,  /* the supervisor withholds the compensation (it made things worse) */
    AFF_STATE_FAULT = 4        /* the last input was refused: the output is held (or fading) */
} aff_state;

/* Which input a fault was in. */
typedef enum aff_input {
    AFF_INPUT_NONE = 0,
    AFF_INPUT_W_MEAS = 1, /* the measured velocity (aff_step, aff_observe) */
    AFF_INPUT_W_REF = 2,  /* the reference (aff_step) */
    AFF_INPUT_U = 3       /* the applied torque (aff_observe) */
} aff_input;

/* What aff_status reports. Counters saturate at UINT32_MAX; periods count to 2^64 - 1. */
typedef struct aff_status_report {
    aff_state state;
    uint32_t n_refused_w_meas;  /* refused samples of w */
    uint32_t n_refused_w_ref;   /* ... of w_ref */
    uint32_t n_refused_u;       /* ... of u */
    aff_input last_fault;       /* the input of the last refused sample (AFF_INPUT_NONE: none yet) */
    uint64_t k_fault;           /* the period (aff_step calls from 0) of the last refused sample */
    uint64_t k;                 /* aff_step calls so far */
    uint32_t n_held;            /* periods the output has been held in a row (0: the last period was clean) */
    int faded;                  /* 1 while the held output fades (held longer than hold_time) */
} aff_status_report;

/* What aff_adaptive_compensate changes (the parts of mode "adaptive" but its estimator ff.est, the estimate in use
 * and the projection's scratch: tests/adaptive_ff_layer/test_drive_guard.py checks that nothing else changes), saved by aff_step and
 * put back by an aff_observe that refuses its period. */
typedef struct aff_saved {
    aff_fixed_ff ff;            /* mode.ff.ff: the feedforward's filters, sign observer, loop model */
    aff_real gain;              /* mode.ff.gain: its fade-in */
    aff_residual res;           /* mode.res: the residual observer and its switch-in */
    aff_supervisor sup;         /* mode.sup: the supervisor */
    aff_real w_ctrl;            /* mode.w_ctrl */
    aff_real transfer;          /* mode.transfer */
} aff_saved;

/* The compensator a drive holds (a few kB: give it static storage on a small MCU). */
typedef struct aff {
    aff_adaptive mode;          /* mode "adaptive" (aff_adaptive.h), configuration and state */
    aff_saved saved;            /* what this period's aff_step changed, as before it (aff_observe's rollback) */
    aff_guard_config guard;     /* the input guard's settings */
    uint32_t n_hold;            /* hold_time in periods, round(hold_time/Tc) >= 1 */
    aff_real out;               /* the last output (N*m) */
    aff_real fade_step;         /* the held output's decrement per period once it fades (N*m) */
    int dropped;                /* 1: this period's aff_step refused an input (aff_observe does nothing) */
    aff_status_report status;
} aff;

/* The guard's defaults: Tc 0.001 s, w_max 1e4 rad/s, u_max 1e6 N*m, hold_time 0.1 s (set u_max and w_max to your
 * drive's: twice its torque limit, a few times its top speed). */
aff_guard_config aff_guard_default_config(void);

/* The drive's defaults: aff_adaptive_default_config() and aff_guard_default_config(). Set the joint's fields
 * (aff_adaptive_default_config's comment) before aff_init. */
aff_config aff_default_config(void);

/* Configure c from *cfg: check every field (aff_check_config), then build mode "adaptive" (aff_adaptive_init: the
 * derived fields computed from the settings) and clear the learning and the guard's state. Returns AFF_OK, or the
 * code of the first field out of its range (aff_error.h; aff_error_message: a sentence), c untouched.
 * Re-initialising restarts the learning. Python: AdaptiveCompensator (mode), adaptive_ff._caff.lib.aff_init. */
aff_error aff_init(aff *c, const aff_config *cfg);

/* The checks of aff_init alone: the guard (AFF_ERR_GUARD_TC, _W_MAX, _U_MAX, _HOLD_TIME), mode "adaptive"
 * (aff_adaptive_check_config) and one controller period for all (AFF_ERR_DRIVE_TC: guard.Tc, mode.ff.ff.dt,
 * mode.ff.est.Tc and, where the part acts, mode.res.dob.Tc, mode.res.switch_in.Tc, mode.sup.Tc equal). */
aff_error aff_check_config(const aff_config *cfg);

/* The compensation torque (N*m) of this period for the raw measured velocity w_meas (rad/s), used as the
 * controller's too, and the reference w_ref (rad/s): aff_step_gated(c, w_meas, w_meas, w_ref). */
aff_real aff_step(aff *c, aff_real w_meas, aff_real w_ref);

/* aff_step with the loop's own gated measurement w_ctrl (rad/s, e.g. after the drive's sensor plausibility check)
 * beside the raw sample w_meas, as the package's closed-loop engine calls the compensator. A refused input (header
 * comment) returns the held output (fading after hold_time) and drops the period. Source: aff_adaptive_compensate. */
aff_real aff_step_gated(aff *c, aff_real w_ctrl, aff_real w_meas, aff_real w_ref);

/* The supervisor's bumpless transfer of this period (N*m): add it to your PI's integrator after aff_step (0 unless
 * the supervisor switched the compensation on or off, and in a dropped period). Source: aff_adaptive_transfer. */
aff_real aff_transfer(const aff *c);

/* Learn from the torque u applied in this period (N*m, after saturation) and the velocity w_meas measured at its
 * start (rad/s, the sample given to aff_step). Returns 1 if the period was taken, 0 if it was dropped (a refused
 * input of this call or of this period's aff_step). Source: aff_adaptive_observe. */
int aff_observe(aff *c, aff_real u, aff_real w_meas);

/* The state, the refused-sample counts per input and the last fault (for a drive's log and watchdog). */
aff_status_report aff_status(const aff *c);

/* 1 once the feedforward acts (a plausible estimate or the provisional start map is in use), else 0. */
int aff_active(const aff *c);

/* The friction estimate in use (eq. 3 levels Fc, Fs in N*m, viscous sigma in N*m*s/rad, lag tau in s, the lag
 * with its margin): 1 and the values written (each pointer may be NULL) once an estimate of the estimator is in
 * use; 0 and nothing written before that (also while the provisional start map acts). */
int aff_estimate(const aff *c, aff_real *Fc, aff_real *Fs, aff_real *sigma, aff_real *tau);

/* RLS updates of the estimator so far (saturating at INT64_MAX, as every counter of the compensator). */
int64_t aff_n_updates(const aff *c);

/* Samples the estimator's own gates rejected so far (the guard's refusals: aff_status), saturating at INT64_MAX. */
int64_t aff_n_rejected(const aff *c);

/* Replay a log of n periods through c: for k < n, uff[k] = aff_step_gated(c, w_ctrl[k], w[k], w_ref[k]) (w_ctrl
 * NULL: w), transfer[k] = aff_transfer(c) (transfer may be NULL), then aff_observe(c, u[k], w[k]). u (N*m), w, w_ref
 * (rad/s), uff (N*m): arrays of n aff_real. For testing an export against the package and for offline runs on
 * recorded logs. */
void aff_replay(aff *c, const aff_real *u, const aff_real *w, const aff_real *w_ctrl, const aff_real *w_ref,
                aff_real *uff, aff_real *transfer, long n);

/* The drive's compensator (self an aff, configured by aff_init) behind the compensator interface
 * (aff_compensator.h), for a simulation that calls compensators through that table, as the package's closed-loop
 * engine does: compensate is aff_step_gated, observe the guard's check of aff_observe and then aff_adaptive_observe
 * (its return value and theta_out: 1 after an RLS update of the estimator, 0 also for a dropped period), transfer
 * aff_transfer. Python: controllers.simulation.exported.ExportedLibrary runs a compiled export through it. */
extern const aff_compensator_ops aff_drive_ops;

#endif
