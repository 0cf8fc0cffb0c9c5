/* aff_supervisor.h -- the feedforward supervisor: applies a compensator's torque only while it helps.
 *
 * Per controller period Tc the loop hands the compensator's candidate torque u_c (N*m) and the velocity
 * reference w_ref (rad/s) to aff_supervisor_apply, which returns u_c while the supervisor is on, 0 (no
 * compensation) while it is backed off and the withdrawn torque while the reference is at rest; after the PI
 * (and the drive) the loop hands the applied torque u (N*m) and the controller's velocity w (rad/s) to
 * aff_supervisor_observe.
 *
 * Test statistic (a disturbance observer of the design inertia J_n, Ohnishi, Shibata, Murakami, "Motion
 * control for advanced mechatronics", IEEE/ASME Trans. Mechatronics 1(1), 1996; the discrete form of aff_dob:
 * with u(k-1) held over the last period the raw disturbance sample is
 *   v(k) = u(k-1-d) - J_n*(w(k) - w(k-1))/Tc            (aff_dob_raw; d: the measurement delay in periods)
 * and Q the first-order lag x += a*(input - x), a = 1 - exp(-Tc*omega), the exact (zero-order-hold)
 * discretisation of 1/(1 + s/omega) with unit gain at zero frequency (aff_lag_step; Franklin, Powell &
 * Workman, Digital Control of Dynamic Systems, 3rd ed., 1998, Sec. 6.3)):
 *   f_hat(k) = Q[v](k)                      the disturbance of the plant: the friction the PI would face alone;
 *   r_hat(k) = Q[v - u_c(k-1-d)](k)         what the PI faces with the candidate applied: f - u_c.
 * Exponentially weighted mean squares over the window T (s), m += b*(x^2 - m), b = 1 - exp(-Tc/T), from 0
 * at period (index from 0) n_start = ceil(5/(omega*Tc)) on (the Q-filters start from 0: their start transient,
 * e^-5 of it left then, is not evidence):
 *   M_f = EWMA(f_hat^2), M_r = EWMA(r_hat^2).
 * Because J*dw/dt = u - f whatever torque was applied, f_hat is the friction both while the candidate is
 * applied and while it is not, and r_hat is the residual the candidate leaves (r_hat = f_hat - Q[u_c] by
 * linearity); sample noise and the inertia error (J - J_n)*dw/dt enter both equally. Decision, once per
 * period from n_decide = n_start + round(settle/Tc) on (settle: the evidence the first decision waits for): on
 * and M_r > M_f (the feedforward makes the disturbance the PI sees larger than no compensation):
 * back off (n_backoff += 1); off and M_r < (1 - margin)*M_f, with the joint moving in the reference's direction at
 * half its speed or more (w*w_ref > 0, |w| >= |w_ref|/2; any w where w_ref is not finite): switch back on
 * (n_restore += 1). The hysteresis band [(1 - margin)*M_f, M_f] keeps it from chattering. The motion condition:
 * a friction feedforward evaluated at a joint that sticks at a reversal takes the sign of the sensor's noise, and
 * switched on there, the transfer below moves one noise-signed sample into the integrator while the next period's
 * flips the command. Bumpless transfer (Astrom & Hagglund, Advanced PID
 * Control, ISA 2006, Sec. 3.5, between manual and automatic modes): in the period the applied torque switches,
 * transfer = (the torque the old mode would apply) - (the new mode's), +u_c off, -u_c on, is what the loop adds
 * to its PI integrator, so the total command does not jump (0 in every other period). While on, the applied
 * torque is the candidate itself, so a supervisor that never backs off leaves the loop bit for bit unchanged.
 * The reference at rest (|w_ref| <= rest_band for n_hold periods in a row, n_hold = max(2, ceil(1/(omega*Tc))): one
 * time constant of the loop after the reference stopped, the joint has stopped behind it; a shorter hold withdraws
 * the feedforward while a long lag's friction still decays; docs/benchmarks/compensation.md, "The rest rule's
 * hold"): a velocity loop's friction then
 * brakes the joint toward its setpoint w = 0 (the error is -w and friction opposes w), so a friction
 * feedforward can only lift that brake; the supervisor withdraws it (no transfer: the brake is wanted) through
 * the compensator's lag in use (aff_supervisor_set_rest_lag: u(k) = (1 - alpha)*u(k-1) from the last applied
 * torque, eq. 2's lag with the model friction F(0) = 0 as its input; at once without a lag: a lagged friction
 * withdrawn in one period keeps acting for its lag and drives the stopped joint backward) and those periods do not
 * enter
 * M_f, M_r (friction there is a reaction, not a disturbance); rest = 1 tells the loop,
 * which tells the compensator (aff_compensator_ops.at_rest: the composite ctl_adob's residual observer then
 * records the torque as applied, without the feedforward it did not get, ctl_adob.h). The measurements behind
 * these rules: docs/benchmarks/compensation.md, "The supervisor".
 * The tracking test (the config's Kp, Ki: the loop's PI gains; off with Kp = 0). The torque test weighs
 * every frequency of the residual alike; the loop's tracking weighs it by its disturbance sensitivity: a constant
 * the PI's integrator rejects costs no tracking, a ripple at the loop's bandwidth costs most. The nominal loop (the
 * PI on the error, its integrator first, and J_n over Tc) turns a torque d into the velocity error G[d]:
 *   y(k+1) = y(k) + (Tc/J_n)*(Kp*e + I(k+1) + d(k)),  I(k+1) = I(k) + Ki*Tc*e,  e = -y(k)
 * (Franklin, Powell & Workman, Sec. 8.2, the disturbance response of a sampled PI loop), so that
 *   e0 = G[v]              the velocity error the loop would make from the disturbance without compensation;
 *   e1 = G[v - u_c] = e0 - G[u_c]   ... with the candidate applied,
 * (two such models, fed with v and with the candidate of the same period), M_e0 = EWMA(e0^2), M_e1 = EWMA(e1^2)
 * as M_f, M_r. On and M_e1 > (1 + track_margin)*M_e0 (the compensation makes the loop's velocity error clearly
 * larger than none would: by default twice its mean square): back off too (n_backoff_tracking counts the back-offs
 * the torque test alone would not have made); off: switch back on only when both tests clear their margin
 * (M_e1 < (1 - margin)*M_e0 too). Without track_margin the test would back a joint off in its feedforward's
 * fade-in, while the models' integrators still hold the friction's rejection. The measured error itself is not
 * compared: it holds the reference's
 * own tracking error, which dwarfs the friction's share on a joint whose friction costs little, and its prediction
 * without the feedforward by superposition predicts the uncompensated error too large where friction brakes the
 * joint (the linear model lacks the friction's braking); G[v] compares the same
 * disturbance, which needs no such prediction. Neither test sees every harm: a feedforward whose residual is small in mean square can still cost tracking where friction
 * was helping (at rest, hence the rest rule, or where the PI's integrator rejected the friction anyway, a joint
 * whose friction raises the uncompensated error by 2 %), or change the loop's motion (the eq. 4 feedforward's
 * limit cycle on the static and small-inertia variants, docs/benchmarks/compensation.md).
 * A non-finite u or w is skipped (the statistics hold; n_skipped counted); the first finite w only starts the
 * difference. No allocation, bounded work. Python: adaptive_ff.compensation.supervisor.FeedforwardSupervisor.
 */
#ifndef AFF_SUPERVISOR_H
#define AFF_SUPERVISOR_H
#include "aff_real.h"
#include "aff_error.h"

/* Largest measurement delay (periods) the statistic aligns (the Python wrapper refuses more). */
#define AFF_SUPERVISOR_DELAY_MAX 32

/* The supervisor's settings (Python: FeedforwardSupervisor's arguments of the same names). */
typedef struct aff_supervisor_config {
    aff_real Tc;          /* controller period (s), finite, > 0; default 0.001 */
    aff_real J_n;         /* design inertia of the statistic's disturbance observer (kg*m^2), finite, > 0: set it;
                             default 0 */
    aff_real omega;       /* Q-filter cut-off (rad/s), finite, > 0: set it (e.g. the loop's crossover Kp/J_n);
                             default 0 */
    aff_real window;      /* EWMA time constant T of the mean squares (s), finite, > 0; default 2 */
    aff_real margin;      /* hysteresis: back on when M_r < (1 - margin)*M_f (-), in [0, 1); default 0.1 */
    aff_real settle;      /* evidence the first decision waits for after the Q-filter's start (s), finite, >= 0;
                             < 0 (default -1): window/2 */
    aff_real rest_band;   /* the reference is at rest where |w_ref| <= rest_band (rad/s), finite, >= 0 (default 0);
                             -1: no rest rule (>= -1) */
    long delay;           /* measurement delay of the velocity (periods), 0..AFF_SUPERVISOR_DELAY_MAX; default 0 */
    aff_real Kp;          /* the loop's PI proportional gain for the tracking test (N*m*s/rad), finite, >= 0;
                             default 0: no tracking test */
    aff_real Ki;          /* its integral gain (N*m/rad), finite, >= 0; default 0 */
    aff_real track_margin; /* the tracking test backs off where M_e1 > (1 + track_margin)*M_e0 (-), finite, >= 0;
                              default 1 */
} aff_supervisor_config;

/* Configuration, then state. */
typedef struct aff_supervisor {
    aff_real Tc;          /* controller period (s), > 0 */
    aff_real J_n;         /* design inertia (kg*m^2), > 0 */
    aff_real omega;       /* Q-filter cut-off (rad/s), > 0 */
    aff_real window;      /* EWMA time constant T (s), > 0 */
    aff_real margin;      /* hysteresis: back on when M_r < (1 - margin)*M_f (-), in [0, 1) */
    aff_real settle;      /* time from n_start to the first decision (s), >= 0 */
    aff_real rest_band;   /* the reference is at rest where |w_ref| <= rest_band (rad/s), >= 0; -1: never */
    long delay;           /* measurement delay d (periods), 0..AFF_SUPERVISOR_DELAY_MAX */
    aff_real a;           /* Q-filter factor 1 - exp(-Tc*omega) */
    aff_real b;           /* EWMA factor 1 - exp(-Tc/window) */
    long n_start;         /* first period (index from 0) whose filtered samples enter the mean squares,
                             ceil(5/(omega*Tc)) */
    long n_decide;        /* first period (index from 0) that decides, n_start + round(settle/Tc) */
    int on;               /* 1: the candidate is applied (decided by the last observe) */
    int applied_on;       /* the mode of the last apply outside rest */
    int rest;             /* 1: the reference is at rest in this period (the candidate not applied) */
    long n_hold;          /* periods with |w_ref| <= rest_band before the reference counts as at rest,
                             max(2, ceil(1/(omega*Tc))) */
    int64_t n_still;      /* periods in a row with |w_ref| <= rest_band, up to this one, at most n_hold */
    int64_t n_rest;       /* periods at rest */
    aff_real transfer;    /* torque to add to the PI integrator in this period (N*m), 0 unless the mode switched */
    aff_real u_c;         /* the candidate of this period (N*m) */
    aff_real w_ref;       /* the reference of this period (rad/s) */
    aff_real rest_alpha;  /* the rest lag's alpha (aff_supervisor_set_rest_lag; 1 until set): at rest the applied
                             torque decays by 1 - rest_alpha per period (alpha outside [0, 1]: withdrawn at once) */
    aff_real u_applied;   /* the torque returned by the last apply (N*m) */
    aff_real w_last;      /* last finite velocity (rad/s; valid if has_w_last) */
    int has_w_last;
    aff_real x_f;         /* f_hat (N*m) */
    aff_real x_r;         /* r_hat (N*m) */
    aff_real m_f;         /* M_f, EWMA of f_hat^2 (N^2*m^2) */
    aff_real m_r;         /* M_r, EWMA of r_hat^2 (N^2*m^2) */
    int64_t n;            /* periods observed */
    int64_t n_backoff;    /* switches on -> off */
    int64_t n_restore;    /* switches off -> on */
    int64_t n_off;        /* periods backed off */
    int64_t n_skipped;    /* non-finite samples skipped */
    int track;            /* 1: the tracking test acts too (Kp > 0) */
    aff_real track_margin; /* it backs off where M_e1 > (1 + track_margin)*M_e0 (-), >= 0 */
    aff_real keep;        /* 1 - margin (-): the restore test's factor, derived at init */
    aff_real track_keep;  /* 1 + track_margin (-): the tracking test's back-off factor, derived at init */
    aff_real Kp;          /* the loop's PI: proportional gain (N*m*s/rad), of the tracking test's loop model */
    aff_real KiTc;        /* its integral gain times Tc (N*m/rad) */
    aff_real TcJ;         /* Tc/J_n (s/(kg*m^2)) */
    aff_real y_a;         /* the loop model fed with the disturbance v: its velocity error e0 = G[v] (rad/s) */
    aff_real I_a;         /* ... and its integrator (N*m) */
    aff_real y_c;         /* the loop model fed with the candidate: G[u_c] (rad/s) */
    aff_real I_c;         /* ... and its integrator (N*m) */
    aff_real m_e0;        /* M_e0, EWMA of e0^2: the velocity error without compensation ((rad/s)^2) */
    aff_real m_e1;        /* M_e1, EWMA of e1^2 = (e0 - G[u_c])^2: ... with the candidate applied ((rad/s)^2) */
    int64_t n_backoff_tracking; /* back-offs the tracking test decided (the torque test did not) */
    long pos;             /* ring position of the torque history */
    aff_real u_hist[AFF_SUPERVISOR_DELAY_MAX + 1];   /* applied torques u(k-1-d..k-1) (N*m) */
    aff_real c_hist[AFF_SUPERVISOR_DELAY_MAX + 1];   /* candidates of the same periods (N*m) */
} aff_supervisor;

/* The raw disturbance sample of a disturbance observer of inertia J_n (kg*m^2): u_last - J_n*(w - w_last)/Tc
 * (N*m), u_last (N*m) the torque held over the period Tc (s) from w_last to w (rad/s). Source: Ohnishi et al.
 * 1996 (above); the one implementation, also aff_dob's. */
aff_real aff_dob_raw(aff_real u_last, aff_real J_n, aff_real w, aff_real w_last, aff_real Tc);

/* One step of the first-order lag x += a*(input - x) (a in (0, 1], 1 - exp(-Tc*omega)); returns the new x.
 * The one implementation of the Q-filter's stage, also aff_dob's. */
aff_real aff_lag_step(aff_real *x, aff_real a, aff_real input);

/* The supervisor's defaults (FeedforwardSupervisor's: Tc 0.001 s, window 2 s, margin 0.1, settle window/2,
 * rest_band 0, delay 0, no tracking test (Kp 0, Ki 0), track_margin 1); J_n and omega are 0: set them (the design
 * inertia, the loop's crossover), and Kp, Ki for the tracking test (the loop's PI). */
aff_supervisor_config aff_supervisor_default_config(void);

/* Configure s from *cfg and clear its state (on, statistics and counters 0, no velocity yet, the previous reference
 * moving): a = 1 - exp(-Tc*omega), b = 1 - exp(-Tc/window), n_start = ceil(5/(omega*Tc)), n_decide = n_start +
 * round(settle/Tc), n_hold = max(2, ceil(1/(omega*Tc))) (header comment; the counts at most 1e9); the tracking
 * test with Kp > 0 (KiTc = Ki*Tc, TcJ = Tc/J_n). Returns AFF_OK, or AFF_ERR_NULL, AFF_ERR_SUPERVISOR_TC, _J_N,
 * _OMEGA, _WINDOW, _MARGIN, _SETTLE, _REST_BAND, _DELAY, _KP, _KI, _TRACK_MARGIN (s untouched). Python: FeedforwardSupervisor.__init__. */
aff_error aff_supervisor_init(aff_supervisor *s, const aff_supervisor_config *cfg);

/* The checks of aff_supervisor_init alone: AFF_OK or the code it would return for *cfg. */
aff_error aff_supervisor_check_config(const aff_supervisor_config *cfg);

/* This period's compensation: keeps the candidate u_c (N*m); returns it while on and the reference w_ref
 * (rad/s) is moving, else 0; sets transfer (N*m; bumpless transfer, header comment): outside rest, u_c when it
 * switched off since the last apply outside rest, -u_c when on, else 0. */
aff_real aff_supervisor_apply(aff_supervisor *s, aff_real u_c, aff_real w_ref);

/* The lag through which the compensation is withdrawn at rest: alpha = 1 - exp(-Tc/tau) of the compensator's lag
 * in use tau (s; 1: no lag, withdrawn at once); at rest the applied torque then decays as
 * u(k) = (1 - alpha)*u(k-1), the first-order lag of eq. 2 with the model friction F(0) = 0 as its input. An
 * alpha outside [0, 1] (or NaN) withdraws at once. */
void aff_supervisor_set_rest_lag(aff_supervisor *s, aff_real alpha);

/* After the PI: advance the statistics with the applied torque u (N*m) and the controller's velocity w (rad/s)
 * of this period and decide (header comment). Non-finite u or w: skipped (counted). */
void aff_supervisor_observe(aff_supervisor *s, aff_real u, aff_real w);

/* Run s over n periods: apply(u_c[k], w_ref[k]) into applied[k] (may be NULL), then observe(u[k], w[k]); the
 * state after each period into f_hat, r_hat, m_f, m_r (each may be NULL) and on[k] (may be NULL). For tests and offline
 * replay of a log. */
void aff_supervisor_run(aff_supervisor *s, const aff_real *u_c, const aff_real *w_ref, const aff_real *u,
                        const aff_real *w, long n,
                        aff_real *applied, aff_real *f_hat, aff_real *r_hat, aff_real *m_f, aff_real *m_r, int *on);

#endif
