/* aff_residual.h -- the disturbance observer on what a friction feedforward leaves (the residual), its switch-in
 * and the bound: the part the composites of mode "adaptive" (aff_adaptive.h) and mode "adaptive-dob"
 * (controllers/csrc/ctl_adob.h) share. The composite holds the feedforward; aff_residual takes its output u_ff each
 * period.
 *
 * Per period: u_ff from the robust adaptive feedforward (aff_robust_ff, 0 before its switch-on, faded in
 * after), d_hat from the disturbance observer (aff_dob), output u_ff + d_hat clipped to +-u_max. The observer
 * is given the torque without the feedforward, u - u_ff, so that with J*dw/dt = u - f its raw sample is
 * (u - u_ff) - J_n*dw/dt = f - u_ff (for J_n = J): it cancels what the feedforward misses within the Q-filter
 * bandwidth; the estimator learns from the total (u, w) as in the "adaptive" mode. The two-degree-of-freedom
 * arrangement of a model-based feedforward with a disturbance observer for the model error (Umeno & Hori
 * 1991; Ohnishi, Shibata, Murakami 1996; for friction: Olsson, Astrom, Canudas de Wit, Gafvert, Lischinsky,
 * "Friction models and friction compensation", Eur. J. Control 4(3), 1998, Sec. 7).
 * Residual switch-in (mode "adaptive", aff_residual_config.use_switch_in): the same composite with the observer's d_hat
 * computed from the start but applied only once a residual test finds that what the feedforward leaves costs
 * tracking. The test predicts two velocity errors with the loop's own linear model (the design inertia J_n and
 * the PI gains Kp, Ki, the backward-Euler PI of ctl_pi; Franklin, Powell & Workman, Digital Control of Dynamic
 * Systems, 3rd ed., 1998, Sec. 6.3, the plant w(k+1) = w(k) + Tc/J_n*u(k) exact for a torque held over the period):
 *   e_l: the frictionless loop's error on the reference, e_l = w_ref - w_l, I_l += Ki*Tc*e_l,
 *        w_l += Tc/J_n*(Kp*e_l + I_l);
 *   w_r: the velocity the residual d_hat (the observer's estimate of f - u_ff) adds to it, I_r -= Ki*Tc*w_r,
 *        w_r += Tc/J_n*(-Kp*w_r + I_r - d_hat),
 *   w_f: the velocity the whole friction estimate u_ff + d_hat adds, by the same recursion as w_r,
 * and their exponentially weighted means over the window T, m += b*(x - m), b = 1 - exp(-Tc/T): M_l of e_l^2, M_r of
 * w_r^2, M_f of w_f^2, C_r of e_l*w_r, C_f of e_l*w_f, taken over the periods in which the feedforward acts (its
 * own estimate in use, or from 5*T on its provisional start map, below) and the reference moves (w_ref != 0 in
 * this and the previous period: at rest the friction is a reaction, aff_supervisor.h). The loop is linear, so its
 * error with the residual is e_l - w_r (w = w_l + w_r), and what the residual raises the loop's mean square by is
 * X_r = EWMA((e_l - w_r)^2) - M_l = M_r - 2*C_r: the residual's own error and its correlation with the loop's
 * error on the reference (a static map that misses the same phase of every cycle, e.g. the bristles' pre-sliding
 * after each reversal of a LuGre joint, adds its error where the loop already lags); likewise X_f = M_f - 2*C_f for
 * the friction uncompensated. The cross terms count only where they add: R_r = max(M_r, X_r), R_f = max(M_f, X_f).
 * A correlation that lowers the predicted error rests on the residual's phase against the loop's error, which the
 * linear model gets wrong where the loop is not linear (an encoder, a delay, the hold after rest; a feedforward
 * that takes the loop beyond the frictionless one): trusted, it kept the observer out where it was needed and
 * brought it in where the feedforward alone did better (docs/benchmarks/compensation.md, "The switch-in's test
 * with the cross term"). The observer is switched in, for good, in the first period with at least 2*round(T/Tc)
 * such periods and (aff_switch_in_fires)
 *   R_r > ratio*M_l (the residual raises the loop's mean-square error by more than ratio over the frictionless
 *        loop's)
 *   or R_r > share*R_f (the feedforward removes less than 1 - share of what the friction would cost in mean
 *        square: a joint whose friction hardly matters next to the loop's own error, where the first test cannot
 *        fire, but the feedforward is doing little; R_f, the prediction for the uncompensated loop, is too large by
 *        1.5-10 times, so this test errs toward keeping the feedforward alone: the threshold on the true ratio of
 *        the residual's cost to the friction's is share times that factor, 0.15-1 at share 0.1; at 0.25 (0.375-2.5)
 *        it kept the feedforward alone on lightly rubbing LuGre and asymmetric zoo joints that the observer takes to
 *        eta 0.98-1.02, docs/benchmarks/export_c.md);
 * and only while M_e > M_l, M_e = EWMA((w_ref - w_ctrl)^2) over the same periods: the loop's measured error with the
 * feedforward alone is above the frictionless loop's predicted one. A loop that already tracks as well as the
 * frictionless one has nothing to gain from the observer, whatever the residual's predicted rise (counted without
 * the correlations that would lower it, above): the measurement settles what the prediction cannot. It includes
 * the sensor's noise, which M_l does not, so on a noisy sensor the condition holds and the test is the prediction's
 * alone (docs/benchmarks/compensation.md, "The switch-in asks the measured error");
 * if the feedforward has not acted by 5*T the observer is switched in then (the idle switch-in), unless its
 * provisional start map acts: then the periods in which the start map acts enter the means from 5*T on, and the
 * test judges the start map as it judges an estimate (the eq. 4 estimate, held back until determined, may take
 * tens of seconds; an idle switch-in at 5*T kept the observer on zoo joints where the estimate, once in, tracked
 * better alone: docs/benchmarks/compensation.md, "The eq. 4 estimate's determinacy test"). After the
 * switch-in the share g of d_hat applied rises from 0 to 1 by Tc/fade_in per period (no torque step; the PI's
 * integrator unwinds what the observer takes over).
 * The trial: a switch-in with little to gain must show that the loop tracks no worse with the observer. From the
 * start the test keeps, over the periods the reference moves (w_ref != 0 here and in the previous period), v_e =
 * EWMA((w_ref - w_ctrl)^2) and v_l = EWMA(e_l^2); the model keeps running after the switch-in. A switch-in with
 * M_e <= (1 + ratio)*M_l (the observer, which at best takes the loop to the frictionless loop's error, has at most
 * ratio of it to gain) is on trial: its yardstick is v_e/v_l at the switch-in; once g = 1 both means start again
 * from 0, and after 2*n_evidence such periods, if v_e > (1 + margin)*(v_e/v_l at the switch-in)*v_l, the observer
 * is taken out (k_out: g falls by fade per period to 0, the output again exactly u_ff), else it stays; either way
 * for good. The frictionless loop's error is the yardstick because the two windows see different stretches of the
 * reference: the ratio, not the error, is compared. The margin (default 0.03, ResidualSwitchIn.trial_margin) is for
 * the sampling noise of two ratios over two windows: of the observers taken out at 1.02-1.03, as many had helped as
 * had hurt. No trial (ratio at the switch-in INFINITY) after a switch-in
 * with more to gain, where friction clearly costs tracking: there the comparison with the window before conflates
 * the feedforward's own evolution (an eq. 4 estimate still settling, then drifting), and it took out observers the
 * loop needed (on the 1000-joint zoo with eq4, one joint from eta 1.121 to 0.000); and none after the idle switch-in, whose window
 * before had no feedforward acting. Also tried and not kept: a second yardstick, the model's prediction for the
 * feedforward alone EWMA((e_l - w_r)^2) (after the switch-in the observer's d_hat, which drives w_r, changes with
 * the observer applied); and a probe, the observer faded out after its window to measure the feedforward alone in
 * the next (the eq. 4 feedforward alone drifted after the probe, and idle switch-ins the composite needed were
 * taken out; a probe of the switch-ins with more to gain only, with or without the test armed again after an out,
 * and a switch-in held back until the measured error stops falling: docs/benchmarks/compensation.md, "What is left
 * between eq4 and the default on the zoo"). Why the trial: with a design inertia twice the joint's the test
 * switched the observer in on 11 of 183 zoo joints where it made the loop worse than without compensation, 8 of
 * them at M_e/M_l of 1.00-1.03 (docs/benchmarks/compensation.md, "The switch-in on trial").
 * The prediction of the residual's error is linear because with the feedforward on the loop
 * sees the residual, not the friction's braking (a prediction of the uncompensated error this way is too large,
 * aff_supervisor.h): on the variants, multi-sine, 60 s, seed 0, M_r/M_l predicted 1.96, 4.25, 0.25 where the
 * measured (rms^2 - rms_fl^2)/rms_fl^2 of `adaptive` was 2.65 (karnopp), 4.36 (small-inertia), 0.44 (lugre);
 * docs/benchmarks/compensation.md ("The residual switch-in"). The cross terms: on the
 * zoo's light LuGre joints with stiff bristles a static map misses the bristles' pre-sliding at every reversal,
 * where the loop already lags; the residual's own mean square is small there, the rise with the cross term is not,
 * and without it the eq. 4 feedforward was kept alone (docs/benchmarks/compensation.md, "The switch-in's test with
 * the cross term").
 * After a rest the feedforward part is held back until the joint moves in the reference's direction, the
 * observer's estimate applied from the rest's end (aff_residual_at_rest).
 * Python: controllers.peers.adaptive_dob.AdaptiveDOBCompensator (either composite), controllers.peers.adaptive_dob.
 * AdaptiveCompensator (mode "adaptive").
 */
#ifndef AFF_RESIDUAL_H
#define AFF_RESIDUAL_H
#include "aff_real.h"
#include "aff_dob.h"
#include "aff_error.h"

/* The switch-in's settings (Python: ResidualSwitchIn's fields of the same names). */
typedef struct aff_switch_in_config {
    aff_real Tc;          /* controller period (s), finite, > 0; default 0.001 */
    aff_real J_n;         /* design inertia of the loop model (kg*m^2), finite, > 0: set it; default 0 */
    aff_real Kp;          /* the loop's PI: proportional gain (N*m*s/rad), finite, > 0: set it; default 0 */
    aff_real Ki;          /* integral gain (N*m/rad), finite, >= 0: set it; default 0 */
    aff_real window;      /* time constant of the means and the evidence needed (s), finite, > 0; default 2 */
    aff_real ratio;       /* switch in when R_r > ratio*M_l (-), finite, > 0; default 0.1 */
    aff_real share;       /* ... or when R_r > share*R_f (-), finite, > 0; default 0.1 */
    aff_real fade_in;     /* the observer's share rises from 0 to 1 over this time (s), finite, >= 0 (0: a step);
                             default 0.5 */
    aff_real trial_margin; /* the trial takes the observer out where a ratio rose by more than 1 + trial_margin (-),
                              >= 0, INFINITY: no trial; default 0.03 */
} aff_switch_in_config;

/* The residual switch-in test (header comment): configuration, then state. */
typedef struct aff_switch_in {
    aff_real Tc;          /* controller period (s), > 0 */
    aff_real J_n;         /* design inertia of the loop model (kg*m^2), > 0 */
    aff_real Kp;          /* the loop's PI gains: proportional (N*m*s/rad), > 0 */
    aff_real Ki;          /* integral (N*m/rad), >= 0 */
    aff_real ratio;       /* switch in when R_r > ratio*M_l (-), > 0 */
    aff_real share;       /* ... or when R_r > share*R_f (-), > 0 */
    aff_real margin;      /* the trial takes the observer out where a ratio rose by more than 1 + margin (-), >= 0
                             (INFINITY: no trial) */
    aff_real b;           /* EWMA factor, 1 - exp(-Tc/window) */
    aff_real fade;        /* increment of g per period after the switch-in, Tc/fade_in (1: a step) */
    long n_evidence;      /* periods of evidence before a decision, round(window/Tc) (at least 1) */
    long n_wait;          /* periods after which a feedforward that has not acted is replaced, 5*n_evidence */
    aff_real w_l;         /* the frictionless loop model's velocity (rad/s) */
    aff_real I_l;         /* its PI integrator (N*m) */
    aff_real w_r;         /* the velocity the residual adds (rad/s) */
    aff_real I_r;         /* its PI integrator (N*m) */
    aff_real w_f;         /* the velocity the friction estimate u_ff + d_hat adds (rad/s) */
    aff_real I_f;         /* its PI integrator (N*m) */
    aff_real m_r;         /* M_r, EWMA of w_r^2 (rad^2/s^2) */
    aff_real m_l;         /* M_l, EWMA of e_l^2 (rad^2/s^2) */
    aff_real m_f;         /* M_f, EWMA of w_f^2 (rad^2/s^2) */
    aff_real c_r;         /* C_r, EWMA of e_l*w_r (rad^2/s^2) */
    aff_real c_f;         /* C_f, EWMA of e_l*w_f (rad^2/s^2) */
    aff_real m_e;         /* M_e, EWMA of the loop's measured error (w_ref - w_ctrl)^2 (rad^2/s^2) */
    aff_real v_e;         /* the trial's means over the periods the reference moves: of (w_ref - w_ctrl)^2 ... */
    aff_real v_l;         /* ... and of e_l^2 (rad^2/s^2); from the start, again from 0 once the observer is wholly
                             in (g = 1) */
    aff_real ratio_in;    /* v_e/v_l at the switch-in, the trial's yardstick (INFINITY: no trial; v_l = 0, the idle
                             switch-in, or M_e > (1 + ratio)*M_l) */
    int64_t n_trial;      /* periods in the trial's means since the observer is wholly in (g = 1) */
    int decided;          /* 1 once the trial has judged (observer kept, or out), or at a switch-in without trial */
    int64_t k_out;        /* period of the switch-out by the trial, -1: not out */
    int64_t n;            /* periods */
    int64_t n_used;       /* periods that entered the means */
    int64_t k_in;         /* period (index from 0) of the switch-in, -1: not switched in */
    int rest_last;        /* w_ref = 0 in the previous period */
    aff_real g;           /* share of d_hat applied, 0..1 */
} aff_switch_in;

/* The residual part's settings. */
typedef struct aff_residual_config {
    aff_real u_max;       /* bound on |u_ff + d_hat| (N*m), >= 0; INFINITY (default): none */
    aff_dob_config dob;   /* the observer of the residual f - u_ff */
    int use_switch_in;    /* 1 (default): d_hat applied after the switch-in (mode "adaptive"); 0: always */
    aff_switch_in_config switch_in; /* the switch-in (read if use_switch_in) */
} aff_residual_config;

/* The part both composites share: the observer of the residual, the switch-in, the output's bound. Configuration,
 * then state; the parts embedded. */
typedef struct aff_residual {
    aff_real u_max;       /* bound on |u_ff + d_hat| (N*m), INFINITY = none (each part keeps its own bound) */
    aff_real u_ff;        /* feedforward part of the last output as the observer is told it (N*m; 0 at rest and
                             while held once d_hat is applied, aff_residual_at_rest) */
    int held;             /* 1: after a rest the feedforward part is held back until the joint moves in the
                             reference's direction (w_ctrl*w_ref > 0), aff_residual_at_rest */
    int64_t n_held;       /* periods, outside rest, in which the feedforward part was held back */
    int use_switch_in;    /* 1: d_hat applied after the residual switch-in (mode "adaptive"), 0: always */
    aff_switch_in sw;     /* the switch-in test (valid if use_switch_in) */
    aff_dob dob;          /* the observer of the residual f - u_ff */
} aff_residual;

/* The switch-in's defaults (ResidualSwitchIn's: window 2 s, ratio 0.1, share 0.1, fade_in 0.5 s, trial_margin
 * 0.03; Tc 0.001 s); J_n, Kp, Ki are 0: set them (the design inertia, the loop's PI). */
aff_switch_in_config aff_switch_in_default_config(void);

/* The residual part's defaults: no bound, the observer's defaults, the switch-in on with its defaults. */
aff_residual_config aff_residual_default_config(void);

/* Configure r from *cfg and clear its state: the bound u_max, u_ff = 0, the observer (aff_dob_init), and with
 * use_switch_in the switch-in (header comment; b = 1 - exp(-Tc/window), fade = Tc/fade_in (1 for fade_in <= Tc),
 * n_evidence = round(window/Tc) (1..1e8), n_wait = 5*n_evidence; g = 0, not switched in), else the observer always
 * applied (g = 1). Returns AFF_OK, or AFF_ERR_NULL, AFF_ERR_RESIDUAL_U_MAX, _USE_SWITCH_IN, an AFF_ERR_SWITCH_IN_
 * code or the observer's (r untouched). Python: AdaptiveDOBCompensator, ResidualSwitchIn. */
aff_error aff_residual_init(aff_residual *r, const aff_residual_config *cfg);

/* The checks of aff_residual_init alone: AFF_OK or the code it would return for *cfg. */
aff_error aff_residual_check_config(const aff_residual_config *cfg);

/* The rises of the loop's mean-square error the test compares (header comment; rad^2/s^2): *rise_r = R_r =
 * max(M_r, M_r - 2*C_r), *rise_f = R_f = max(M_f, M_f - 2*C_f), from the means in s as last updated. */
void aff_switch_in_rises(const aff_switch_in *s, aff_real *rise_r, aff_real *rise_f);

/* Whether the test's means in s fire (header comment: R_r > ratio*M_l or R_r > share*R_f, R = max(M, M - 2*C), and
 * M_e > M_l; 1/0),
 * whatever the evidence counted so far; aff_switch_in_step asks it once 2*n_evidence periods entered the means. */
int aff_switch_in_fires(const aff_switch_in *s);

/* One period of the switch-in test s with the feedforward u_ff (N*m), the observer's d_hat (N*m), the reference
 * w_ref and the controller's velocity w_ctrl (rad/s; a non-finite one leaves M_e as it is), whether the
 * feedforward's own estimate acts (acting, 0/1) and whether its provisional start map does (started, 0/1: the
 * start's evidence from n_wait on, no idle switch-in; header comment); returns the share g of d_hat to apply
 * (0..1). */
aff_real aff_switch_in_step(aff_switch_in *s, aff_real u_ff, aff_real d_hat, aff_real w_ref, aff_real w_ctrl,
                            int acting, int started);

/* The composite's output for the feedforward's torque u_ff (N*m), whether its own estimate acts and whether its
 * start map does (acting, started, 0/1, for aff_switch_in_step): d_hat =
 * aff_dob_compensate(w_ctrl, w_meas, w_ref, rad/s); returns u_ff + g*d_hat clipped to +-u_max (N*m), g = 1
 * without the switch-in, else aff_switch_in_step's share (before the switch-in exactly u_ff), and keeps u_ff in
 * r->u_ff for the observer. While held after a rest (aff_residual_at_rest) until w_ctrl*w_ref > 0: g*d_hat alone
 * and r->u_ff = 0 (the feedforward not applied; before the switch-in 0, r->u_ff = u_ff as at rest); a non-finite
 * w_ctrl keeps the hold. The switch-in test sees u_ff and acting unchanged by the hold. */
aff_real aff_residual_compensate(aff_residual *r, aff_real u_ff, int acting, int started, aff_real w_ctrl,
                                 aff_real w_meas, aff_real w_ref);

/* The observer records the torque without the feedforward, u - u_ff (N*m), and w_meas (rad/s). */
void aff_residual_observe(aff_residual *r, aff_real u, aff_real w_meas, aff_real *theta_out);

/* The loop withheld this period's output because the reference is at rest (the supervisor's
 * rest rule, aff_supervisor.h). While the observer's estimate is applied (g > 0; always without the switch-in) the
 * observer then records the torque as applied, u - 0 (u_ff = 0): it measures the friction itself, as aff_dob does,
 * not the residual f - u_ff of a feedforward that was not applied. At rest that feedforward is the friction map at
 * a measured velocity of noise and quantisation, and the residual's estimate carried it into the next move's start
 * (two joints of the open bench's zoo, docs/benchmarks/scenarios.md). Before the switch-in u_ff stays: the
 * switch-in test wants the feedforward's residual. Outside rest nothing changes (a supervisor that backed off keeps
 * the candidate's residual, consistent at its restore).
 * The hold: from here on (held = 1) aff_residual_compensate leaves the feedforward part out until the controller's
 * velocity moves in the reference's direction, w_ctrl*w_ref > 0 (the observer's estimate g*d_hat applied from the
 * rest's end, the observer told u_ff = 0 as at rest; before the switch-in the output is 0 and the observer keeps
 * u_ff, as at rest). At a rest's end the map's value is again that of a velocity of noise and quantisation, or of
 * a joint still moving back from its stop, in either sign; applied before the joint follows the reference it
 * pushed against the move or lifted the friction's brake. No band: the difference velocity of a stuck joint is
 * exactly 0 (the first count in the reference's direction ends the hold), a noisy velocity may only end it early,
 * which is the behaviour without the hold; a band of 0.05 rad/s (one count per period of the 2^17 encoder) on
 * the Kalman velocity moved the open bench's variants by -0.008..+0.010, its zoo losses unchanged (none), and
 * would need the sensor's resolution as a setting. Measured on the open bench (docs/benchmarks/compensation.md,
 * "The composite's observer at rest"): no loss above 0.02 and none worse than none with either velocity; holding
 * plain `adaptive` before its switch-in too is part of it. n_held counts the periods held outside rest (at_rest takes back a period it counted, unless the
 * count saturated at INT64_MAX). */
void aff_residual_at_rest(aff_residual *r);

#endif
