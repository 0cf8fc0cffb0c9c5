/* ctl_sensor.h -- the loop's velocity sensor: an ideal velocity, or an encoder's difference quotient, and a delay.
 *
 * Per controller period, from the joint's true velocity w (rad/s) and the noise sample n (rad/s):
 *   velocity sensor (res = 0):  v = w + n;
 *   encoder (res > 0):          q += Tc*(w_prev + w)/2  (the true position, trapezoidal rule over the period),
 *                               qm = res*floor(q/res)   (the counts read, res = 2*pi/counts per revolution),
 *                               v = (qm - qm_prev)/Tc + n  (backward difference; the first period v = w + n);
 *   delay of d periods (0 <= d <= CTL_DELAY_MAX): the loop gets v of period k - d (before the first d periods,
 *   the first v).
 * res = 0 and d = 0 give v = w + n, the loop of a sensor without either (the engine's default).
 * Python: controllers.simulation.sensor_drive.Sensor.
 */
#ifndef CTL_SENSOR_H
#define CTL_SENSOR_H

/* Largest measurement delay (periods). */
#define CTL_DELAY_MAX 32

typedef struct ctl_sensor {
    double res;                       /* encoder resolution (rad per count), 0 = a velocity sensor */
    double Tc;                        /* controller period (s) */
    long delay;                       /* measurement delay (periods), 0..CTL_DELAY_MAX */
    int started;                      /* 0 before the first period */
    double q;                         /* true position integrated by the sensor (rad) */
    double w_prev;                    /* true velocity of the previous period (rad/s) */
    double qm_prev;                   /* counts read in the previous period, as a position (rad) */
    long pos;                         /* next slot of the delay line */
    double buf[CTL_DELAY_MAX + 1];    /* the last delay+1 measurements (rad/s) */
} ctl_sensor;

/* Configure s: resolution res (rad/count, >= 0), period Tc (s, > 0), delay (periods, 0..CTL_DELAY_MAX;
 * clipped into that range), position 0. */
void ctl_sensor_init(ctl_sensor *s, double res, double Tc, long delay);

/* One period: the measurement the loop receives (rad/s) for true velocity w and noise sample n (rad/s). */
double ctl_sensor_measure(ctl_sensor *s, double w, double n);

#endif
