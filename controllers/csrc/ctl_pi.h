/* ctl_pi.h -- the discrete PI velocity controller with saturation, feedforward and anti-windup.
 *
 *   d = Ki*Tc*e,  I' = I + d (backward Euler, C(z) = Kp + Ki*Tc*z/(z-1)),
 *   u = sat(Kp*e + I' + u_ff, +-u_max),
 * with I' clamped where it would drive u past the limit in the direction of d,
 * never moved against d (conditional integration: Astrom & Hagglund, Advanced
 * PID Control, ISA 2006, Sec. 3.5). Python: controllers.design.pi.PIController.
 */
#ifndef CTL_PI_H
#define CTL_PI_H

typedef struct ctl_pi {
    double Kp;       /* proportional gain (N*m*s/rad), >= 0 */
    double KiTc;     /* integral gain times the period Ki*Tc (N*m per rad/s of error per step), >= 0 */
    double u_max;    /* torque limit (N*m), INFINITY = none */
    double I;        /* integrator state (N*m) */
    int saturated;   /* 1 if the last command was clipped */
} ctl_pi;

/* Configure p with its integrator at I0 (N*m). */
void ctl_pi_init(ctl_pi *p, double Kp, double KiTc, double u_max, double I0);

/* One period: error e = r - w (rad/s), feedforward u_ff (N*m); returns the saturated command (N*m). */
double ctl_pi_step(ctl_pi *p, double e, double u_ff);

#endif
