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
 * A zeroed struct (on == 0) is "none". Python: adaptive_ff.compensation.velocity_input.LoopModel / SignObserver
 * (settings), held by adaptive_ff.compensation.feedforward.FrictionFeedforward.
 */
#ifndef AFF_VELOCITY_INPUT_H
#define AFF_VELOCITY_INPUT_H
#include "aff_real.h"

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

/* Configure m (on = 1) and clear its state. Python computes the gains from LoopModel and the period. */
void aff_loop_model_init(aff_loop_model *m, aff_real Kp, aff_real KiTc, aff_real TcJ, aff_real a);

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

/* Configure o (on = 1) with the gains of SignObserver.gains(Tc) and clear its state. */
void aff_sign_observer_init(aff_sign_observer *o, aff_real TcJ, aff_real l1, aff_real l2);

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
