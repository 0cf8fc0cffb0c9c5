/* aff_velocity_input.h -- the velocity input of the friction feedforward near standstill: loop model, sign observer.
 *
 * Inside the stick band the measured velocity is noise and its sign says nothing. Two optional parts of the
 * feedforward (aff_feedforward.h) give its friction map a better input there:
 *  - the loop model: the nominal (frictionless) velocity loop driven by the reference, PI C(z) = Kp + Ki*Tc*z/(z-1)
 *    on the zero-order-hold joint Tc/(J (z-1)): the reference model of MRAC (Astrom & Wittenmark, Adaptive
 *    Control, 2nd ed., 1995, Sec. 5.1), shifted by the low-passed measured deviation; used once the joint is
 *    detected as stuck;
 *  - the sign observer: a Luenberger velocity observer with a constant-disturbance state driven by the applied
 *    torque (Franklin, Powell & Workman, Digital Control of Dynamic Systems, 3rd ed., 1998, Secs. 8.2, 8.5);
 *    its sign replaces the measured one inside the stick band.
 * A zeroed struct (on == 0) is "none". Each is configured from its settings (aff_loop_model_config,
 * aff_sign_observer_config) and the period of the feedforward that holds it. Python:
 * adaptive_ff.compensation.velocity_input.LoopModel / SignObserver (settings), held by
 * adaptive_ff.compensation.feedforward.FrictionFeedforward.
 */
#ifndef AFF_VELOCITY_INPUT_H
#define AFF_VELOCITY_INPUT_H
#include "aff_real.h"
#include "aff_error.h"

/* The loop model's settings: the loop's PI and the design inertia. No defaults: Kp, Ki and J are the loop's. */
typedef struct aff_loop_model_config {
    aff_real Kp;     /* proportional gain of the loop's PI (N*m*s/rad), finite, >= 0: set it; default 0 */
    aff_real Ki;     /* integral gain of the loop's PI (N*m/rad), finite, >= 0 (not both gains 0): set it; default 0 */
    aff_real J;      /* design inertia (kg*m^2), finite, > 0: set it (what you know, not the plant's); default 0 */
    aff_real track;  /* bandwidth at which the model follows the measured deviation (rad/s), finite, >= 0 (0: the
                        model alone); < 0 (default -1): Kp/J */
} aff_loop_model_config;

/* The sign observer's settings. No defaults for J and bandwidth: the joint's and the loop's. */
typedef struct aff_sign_observer_config {
    aff_real J;                  /* design inertia (kg*m^2), finite, > 0: set it; default 0 */
    aff_real bandwidth;          /* observer bandwidth (rad/s), finite, > 0: set it (e.g. 5*Kp/J); default 0 */
    aff_real residual_bandwidth; /* bandwidth of the constant-residual state (rad/s), finite, >= 0 (0: none);
                                    < 0 (default -1): 0.1*bandwidth */
} aff_sign_observer_config;

/* The loop model: configuration, then state. */
typedef struct aff_loop_model {
    int on;          /* 1: configured; 0: none (aff_loop_model_step returns w_ref) */
    aff_real Kp;     /* proportional gain of the loop's PI (N*m*s/rad) */
    aff_real KiTc;   /* integral gain times the period Ki*Tc (N*m*s/rad per step) */
    aff_real TcJ;    /* period over the design inertia Tc/J (rad/s per N*m per step) */
    aff_real a;      /* tracking gain of the deviation, 1 - exp(-track*Tc), in [0, 1) */
    int started;     /* 1 after the first period */
    aff_real w;      /* model velocity (rad/s) */
    aff_real I;      /* model integrator (N*m) */
    aff_real dw;     /* tracked deviation of the joint from the model (rad/s) */
} aff_loop_model;

/* The loop model's defaults (Kp, Ki, J 0: to be set; track -1: Kp/J). */
aff_loop_model_config aff_loop_model_default_config(void);

/* Configure m (on = 1) from *cfg at the period Tc (s) of the feedforward that holds it and clear its state: KiTc
 * = Ki*Tc, TcJ = Tc/J, a = 1 - exp(-bw*Tc) with bw = track (Kp/J for track < 0). Returns AFF_OK, or AFF_ERR_NULL,
 * AFF_ERR_LOOP_MODEL_TC, _KP, _KI, _GAINS (both 0), _J, _TRACK (m untouched). Python: LoopModel. */
aff_error aff_loop_model_init(aff_loop_model *m, const aff_loop_model_config *cfg, aff_real Tc);

/* The checks of aff_loop_model_init alone: AFF_OK or the code it would return for *cfg and Tc (s). */
aff_error aff_loop_model_check_config(const aff_loop_model_config *cfg, aff_real Tc);

/* One period: e = w_ref - w, I += KiTc*e, w += TcJ*(Kp*e + I); returns the model velocity of this period plus
 * the tracked deviation, dw += a*(w0 - w - dw) (a non-finite w0 leaves dw) (rad/s). The model starts at w0 (the
 * controller's measurement; 0 if not finite) with an empty integrator. Without a model (on == 0): w_ref,
 * nothing changes. Python: velocity_input.LoopModel (was loop_model_step). */
aff_real aff_loop_model_step(aff_loop_model *m, aff_real w0, aff_real w_ref);

/* The sign observer: configuration, then state. */
typedef struct aff_sign_observer {
    int on;          /* 1: configured; 0: none */
    aff_real TcJ;    /* period over the design inertia Tc/J (rad/s per N*m per step) */
    aff_real l1;     /* velocity gain 1 - p1*p2 */
    aff_real l2;     /* residual gain (1 - p1)*(1 - p2) */
    int started;     /* 1 after the first measurement */
    aff_real w_hat;  /* a-priori velocity estimate (rad/s) */
    aff_real z_hat;  /* residual estimate d*Tc/J (rad/s per step) */
    aff_real w_ctrl; /* the controller's measurement of this period (rad/s) */
} aff_sign_observer;

/* The sign observer's defaults (J, bandwidth 0: to be set; residual_bandwidth -1: 0.1*bandwidth). */
aff_sign_observer_config aff_sign_observer_default_config(void);

/* Configure o (on = 1) from *cfg at the period Tc (s) of the feedforward that holds it and clear its state: TcJ =
 * Tc/J, the error poles p1 = exp(-bandwidth*Tc), p2 = exp(-residual_bandwidth*Tc) (0.1*bandwidth for a negative
 * one), l1 = 1 - p1*p2, l2 = (1 - p1)*(1 - p2). Returns AFF_OK, or AFF_ERR_NULL, AFF_ERR_SIGN_OBSERVER_TC, _J,
 * _BANDWIDTH, _RESIDUAL_BANDWIDTH (o untouched). Python: SignObserver. */
aff_error aff_sign_observer_init(aff_sign_observer *o, const aff_sign_observer_config *cfg, aff_real Tc);

/* The checks of aff_sign_observer_init alone: AFF_OK or the code it would return for *cfg and Tc (s). */
aff_error aff_sign_observer_check_config(const aff_sign_observer_config *cfg, aff_real Tc);

/* The measurement w_ctrl (rad/s) with the observer's sign if it is finite and inside (-band, band): copysign(|w|,
 * w_hat); else unchanged. Records w_ctrl for aff_sign_observer_step and starts the observer at the first
 * measurement (w_hat = w_ctrl, 0 if not finite). Without an observer: w_ctrl, nothing changes. Python: was
 * velocity_input.signed_measurement. */
aff_real aff_sign_observer_signed(aff_sign_observer *o, aff_real w_ctrl, aff_real band);

/* Correct with the recorded measurement (e = w_ctrl - w_hat; w_hat += l1*e; z_hat -= l2*e), then predict with the
 * applied torque u less the compensator's own output u_c of this period (N*m): w_hat += TcJ*(u - u_c) - z_hat.
 * A non-finite measurement or torque difference skips its part; nothing before the first measurement or
 * without an observer. Python: was velocity_input.sign_observer_step. */
void aff_sign_observer_step(aff_sign_observer *o, aff_real u, aff_real u_c);

#endif
