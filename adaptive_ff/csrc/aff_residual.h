/* aff_residual.h -- the disturbance observer on what a friction feedforward leaves (the residual), its switch-in,
 * its slew limit and the bound: the part the composites of mode "adaptive" (aff_adaptive.h) and mode "adaptive-dob"
 * (controllers/csrc/ctl_adob.h) share. The composite holds the feedforward; aff_residual takes its output u_ff each
 * period.
 *
 * Per period: u_ff from the robust adaptive feedforward (aff_robust_ff, 0 before its switch-on, faded in
 * after), d_hat from the disturbance observer (aff_dob), the applied estimate d_app (d_hat through the slew limit,
 * below), output u_ff + g*d_app clipped to +-u_max (g = 1 without the switch-in). The observer is given the torque
 * without the feedforward, u - u_ff, so that with J*dw/dt = u - f its raw sample is (u - u_ff) - J_n*dw/dt =
 * f - u_ff (for J_n = J): it cancels what the feedforward misses within the Q-filter bandwidth; the estimator
 * learns from the total (u, w) as in the "adaptive" mode. The two-degree-of-freedom arrangement of a model-based
 * feedforward with a disturbance observer for the model error (Umeno & Hori 1991; Ohnishi, Shibata, Murakami
 * 1996; for friction: Olsson, Astrom, Canudas de Wit, Gafvert, Lischinsky, "Friction models and friction
 * compensation", Eur. J. Control 4(3), 1998, Sec. 7).
 *
 * The slew limit (aff_residual_config.crossover, .slew_time): d_app moves toward d_hat by at most
 *   slew_time*crossover*ff_peak*a  (N*m per period), a = 1 - exp(-Tc*omega_q) (the Q-filter's lag factor),
 * ff_peak the largest |u_ff| so far (N*m), crossover the loop's Kp/J_n (rad/s, the PI's gain over the observers'
 * nominal inertia J_n: the inertia the PI acts on as far as the loop knows it, the design inertia unless an
 * identification run contradicts it), slew_time in s (default 0.4). Both ways: a step of d_hat, e.g. the raw sample's jump J*dv/Tc when a
 * joint inside a wide stick band stops within one period, reaches the output over at least
 * |step|/(slew_time*crossover*ff_peak*a) periods instead of one, so that the observer does not kick a sticking
 * joint out of its band, while a loop of a higher crossover, which rejects a disturbance faster, lets the
 * estimate through faster. While ff_peak is 0 (the feedforward has not applied a torque) d_app = d_hat; either
 * setting 0 turns the limit off. docs/benchmarks/export_c.md ("The exported mode on the zoo").
 *
 * Residual switch-in (mode "adaptive", aff_residual_config.use_switch_in): d_hat is computed from the start but
 * applied only once a residual test finds that what the feedforward leaves costs tracking. The test predicts two
 * velocity errors with the loop's own linear model (the design inertia J_n and the PI gains Kp, Ki, the
 * backward-Euler PI of ctl_pi; Franklin, Powell & Workman, Digital Control of Dynamic Systems, 3rd ed., 1998,
 * Sec. 6.3, the plant w(k+1) = w(k) + Tc/J_n*u(k) exact for a torque held over the period):
 *   e_l: the frictionless loop's error on the reference, e_l = w_ref - w_l, I_l += Ki*Tc*e_l,
 *        w_l += Tc/J_n*(Kp*e_l + I_l);
 *   w_r: the velocity the residual d (the applied estimate d_app, the observer's estimate of f - u_ff) adds to it,
 *        I_r -= Ki*Tc*w_r, w_r += Tc/J_n*(-Kp*w_r + I_r - d),
 *   w_f: the velocity the whole friction estimate u_ff + d adds, by the same recursion as w_r,
 * and their exponentially weighted means over the window T, m += b*(x - m), b = 1 - exp(-Tc/T): M_l of e_l^2, M_r of
 * w_r^2, M_f of w_f^2, C_r of e_l*w_r, C_f of e_l*w_f, taken over the periods in which the feedforward acts (its
 * own estimate in use, or from 5*T on its provisional start map, below) and the reference moves (w_ref != 0 in
 * this and the previous period: at rest the friction is a reaction, aff_supervisor.h). The loop is linear, so its
 * error with the residual is e_l - w_r (w = w_l + w_r), and what the residual raises the loop's mean square by is
 * X_r = EWMA((e_l - w_r)^2) - M_l = M_r - 2*C_r: the residual's own error and its correlation with the loop's
 * error on the reference (a static map that misses the same phase of every cycle, e.g. the bristles' pre-sliding
 * after each reversal of a LuGre joint, adds its error where the loop already lags); likewise X_f = M_f - 2*C_f for
 * the friction uncompensated. The cross terms count only where they add: R_r = max(M_r, X_r), R_f = max(M_f, X_f)
 * (a correlation that lowers the predicted error rests on the residual's phase against the loop's error, which the
 * linear model gets wrong where the loop is not linear: an encoder, a delay, the hold after rest). The observer is
 * switched in, for good, in the first period with at least 2*round(T/Tc) such periods and (aff_switch_in_fires)
 *   R_r > ratio*M_l (the residual raises the loop's mean-square error by more than ratio over the frictionless
 *        loop's)
 *   or R_r > share*R_f (the feedforward removes less than 1 - share of what the friction would cost in mean
 *        square: a joint whose friction hardly matters next to the loop's own error, where the first test cannot
 *        fire; R_f, the linear prediction for the uncompensated loop, overstates the friction's cost, so this test
 *        errs toward keeping the feedforward alone);
 * and only while M_e > M_l, M_e = EWMA((w_ref - w_ctrl)^2) over the same periods: the loop's measured error with the
 * feedforward alone is above the frictionless loop's predicted one (a loop that already tracks as well as the
 * frictionless one has nothing to gain from the observer; M_e includes the sensor's noise, which M_l does not);
 * if the feedforward has not acted by 5*T the observer is switched in then (the idle switch-in), unless its
 * provisional start map acts: then the periods in which the start map acts enter the means from 5*T on, and the
 * test judges the start map as it judges an estimate. After the switch-in the share g of d_app applied rises from 0
 * to 1 by Tc/fade_in per period (no torque step; the PI's integrator unwinds what the observer takes over).
 * The trial: a switch-in with little to gain must show that the loop tracks no worse with the observer. From the
 * start the test keeps, over the periods the reference moves (w_ref != 0 here and in the previous period), v_e =
 * EWMA((w_ref - w_ctrl)^2) and v_l = EWMA(e_l^2); the model keeps running after the switch-in. A switch-in with
 * M_e <= (1 + ratio)*M_l (the observer, which at best takes the loop to the frictionless loop's error, has at most
 * ratio of it to gain) is on trial: its yardstick is v_e/v_l at the switch-in; once g = 1 both means start again
 * from 0, and after 2*n_evidence such periods, if v_e > (1 + margin)*(v_e/v_l at the switch-in)*v_l, the observer
 * is taken out (k_out: g falls by fade per period to 0, the output again exactly u_ff), else it stays; either way
 * for good. The frictionless loop's error is the yardstick because the two windows see different stretches of the
 * reference: the ratio, not the error, is compared; the margin (default 0.03, ResidualSwitchIn.trial_margin) is for
 * the sampling noise of two ratios over two windows. No trial (ratio at the switch-in INFINITY) after a switch-in
 * with more to gain, where friction clearly costs tracking and the window before holds the feedforward's own
 * evolution, and none after the idle switch-in, whose window before had no feedforward acting.
 * The measurements behind these choices and the alternatives measured are on docs/benchmarks/compensation.md
 * ("The residual switch-in", "The switch-in's test with the cross term", "The switch-in asks the measured error",
 * "The switch-in on trial") and docs/benchmarks/export_c.md ("Alternatives measured").
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
    aff_real KiTc;        /* Ki*Tc of the loop models (N*m*s/rad) */
    aff_real TcJ;         /* Tc/J_n of the loop models (s/(kg*m^2)) */
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
    aff_real crossover;   /* the loop's crossover (rad/s): the PI's Kp over the observers' nominal inertia J_n
                             (never the plant's), finite, >= 0; 0 (default): no slew limit, set it */
    aff_real slew_time;   /* the slew limit's time (s), finite, >= 0: the applied estimate moves by at most
                             slew_time*crossover*ff_peak*(1 - exp(-Tc*omega_q)) per period; default 0.4; 0: no
                             slew limit */
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
    aff_real slew;        /* the slew limit's step per N*m of ff_peak, slew_time*crossover*(1 - exp(-Tc*omega_q))
                             (-); 0: no limit */
    aff_real ff_peak;     /* the largest |u_ff| so far (N*m) */
    aff_real d_app;       /* the observer's estimate as applied, slew-limited (N*m; valid if slew > 0) */
} aff_residual;

/* The switch-in's defaults (ResidualSwitchIn's: window 2 s, ratio 0.1, share 0.1, fade_in 0.5 s, trial_margin
 * 0.03; Tc 0.001 s); J_n, Kp, Ki are 0: set them (the design inertia, the loop's PI). */
aff_switch_in_config aff_switch_in_default_config(void);

/* The residual part's defaults: no bound, the observer's defaults, the switch-in on with its defaults. */
aff_residual_config aff_residual_default_config(void);

/* Configure r from *cfg and clear its state: the bound u_max, u_ff = 0, the observer (aff_dob_init), the slew
 * limit (slew = slew_time*crossover*a, ff_peak = d_app = 0), and with
 * use_switch_in the switch-in (header comment; b = 1 - exp(-Tc/window), fade = Tc/fade_in (1 for fade_in <= Tc),
 * n_evidence = round(window/Tc) (1..1e8), n_wait = 5*n_evidence; g = 0, not switched in), else the observer always
 * applied (g = 1). Returns AFF_OK, or AFF_ERR_NULL, AFF_ERR_RESIDUAL_U_MAX, _USE_SWITCH_IN, an AFF_ERR_SWITCH_IN_
 * code, AFF_ERR_RESIDUAL_CROSSOVER, _SLEW_TIME or the observer's (r untouched). Python: AdaptiveDOBCompensator,
 * ResidualSwitchIn. */
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
 * aff_dob_compensate(w_ctrl, w_meas, w_ref, rad/s), d_app its value through the slew limit (header comment; d_hat
 * without it), which the switch-in test takes; returns u_ff + g*d_app clipped to +-u_max (N*m), g = 1
 * without the switch-in, else aff_switch_in_step's share (before the switch-in exactly u_ff), and keeps u_ff in
 * r->u_ff for the observer. While held after a rest (aff_residual_at_rest) until w_ctrl*w_ref > 0: g*d_app alone
 * and r->u_ff = 0 (the feedforward not applied; before the switch-in 0, r->u_ff = u_ff as at rest); a non-finite
 * w_ctrl keeps the hold. The switch-in test sees u_ff and acting unchanged by the hold. */
aff_real aff_residual_compensate(aff_residual *r, aff_real u_ff, int acting, int started, aff_real w_ctrl,
                                 aff_real w_meas, aff_real w_ref);

/* The observer records the torque without the feedforward, u - u_ff (N*m), and w_meas (rad/s). */
void aff_residual_observe(aff_residual *r, aff_real u, aff_real w_meas, aff_real *theta_out);

/* The loop withheld this period's output because the reference is at rest (the supervisor's rest rule,
 * aff_supervisor.h). While the observer's estimate is applied (g > 0; always without the switch-in) the observer
 * then records the torque as applied, u - 0 (u_ff = 0): it measures the friction itself, as aff_dob does, not the
 * residual f - u_ff of a feedforward that was not applied (at rest that feedforward is the friction map at a
 * measured velocity of noise and quantisation). Before the switch-in u_ff stays: the switch-in test wants the
 * feedforward's residual. Outside rest nothing changes (a supervisor that backed off keeps the candidate's
 * residual, consistent at its restore).
 * The hold: from here on (held = 1) aff_residual_compensate leaves the feedforward part out until the controller's
 * velocity moves in the reference's direction, w_ctrl*w_ref > 0 (the observer's estimate g*d_app applied from the
 * rest's end, the observer told u_ff = 0 as at rest; before the switch-in the output is 0 and the observer keeps
 * u_ff, as at rest): at a rest's end the map's value is that of a velocity of noise and quantisation, or of a joint
 * still moving back from its stop, in either sign. No band: the difference velocity of a stuck joint is exactly 0
 * (the first count in the reference's direction ends the hold), a noisy velocity may only end it early, which is
 * the behaviour without the hold (docs/benchmarks/compensation.md, "The composite's observer at rest"). n_held
 * counts the periods held outside rest (at_rest takes back a period it counted, unless the count saturated at
 * INT64_MAX). */
void aff_residual_at_rest(aff_residual *r);

#endif
