/* ctl_drive.h -- the drive between the controller and the joint: a slew-rate limit on the torque.
 *
 * Per controller period the applied torque moves from the previous one by at most slew*Tc:
 *   u_applied = u_prev + clamp(u - u_prev, -slew*Tc, +slew*Tc)   (the first period: u_applied = clamp(u) from 0),
 * after the controller's saturation (ctl_pi's u_max, the drive's torque limit). slew = INFINITY: the command
 * is applied as it is (the engine's default). The compensators observe the applied torque, the one a drive's
 * log holds. Python: controllers.simulation.sensor_drive.Drive.
 */
#ifndef CTL_DRIVE_H
#define CTL_DRIVE_H

typedef struct ctl_drive {
    double slew;     /* torque slew-rate limit (N*m/s), > 0, INFINITY = none */
    double Tc;       /* controller period (s) */
    double u_prev;   /* the torque applied in the previous period (N*m) */
} ctl_drive;

/* Configure d: slew-rate limit slew (N*m/s), period Tc (s); the torque starts at 0. */
void ctl_drive_init(ctl_drive *d, double slew, double Tc);

/* One period: the torque applied (N*m) for the command u (N*m). */
double ctl_drive_apply(ctl_drive *d, double u);

#endif
