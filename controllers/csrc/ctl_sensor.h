/* ctl_sensor.h -- the loop's velocity sensor: an ideal velocity, or an encoder's difference quotient, and a delay.
 *
 * Per controller period, from the joint's true velocity w (rad/s) and the noise sample n (rad/s):
 *   velocity sensor (res = 0):  v = w + n;
 *   encoder (res > 0):          q += Tc*(w_prev + w)/2  (the true position, trapezoidal rule over the period),
 *                               qm = res*floor(q/res)   (the counts read, res = 2*pi/counts per revolution),
 *                               velocity (kalman = 0): v = (qm - qm_prev)/Tc + n  (backward difference);
 *                               velocity (kalman = 1): a steady-state Kalman filter of the kinematic model of
 *                                 n_x states x = [q, w] (cv) or [q, w, a] (ca) with the constant gain K:
 *                                 predict x = F x (F of the period Tc), correct x += K*(qm - x[0]); v = x[1] + n;
 *                               the first period v = w + n (and the filter starts from x = [qm, w, 0]);
 *   delay of d periods (0 <= d <= CTL_DELAY_MAX): the loop gets v of period k - d (before the first d periods,
 *   the first v).
 * res = 0 and d = 0 give v = w + n, the loop of a sensor without either (the engine's default).
 * Python: controllers.simulation.sensor_drive.Sensor.
 */
#ifndef CTL_SENSOR_H
#define CTL_SENSOR_H

/* Largest measurement delay (periods). */
#define CTL_DELAY_MAX 32

/* Largest number of states of the Kalman velocity filter (ca: q, w, a). */
#define CTL_KALMAN_NMAX 3

typedef struct ctl_sensor {
    double res;                       /* encoder resolution (rad per count), 0 = a velocity sensor */
    double Tc;                        /* controller period (s) */
    long delay;                       /* measurement delay (periods), 0..CTL_DELAY_MAX */
    int started;                      /* 0 before the first period */
    double q;                         /* true position integrated by the sensor (rad) */
    double w_prev;                    /* true velocity of the previous period (rad/s) */
    double qm_prev;                   /* counts read in the previous period, as a position (rad) */
    int kalman;                       /* velocity: 0 = backward difference, 1 = steady-state Kalman filter */
    long n_x;                         /* Kalman states: 2 (cv: q, w) or 3 (ca: q, w, a) */
    double K[CTL_KALMAN_NMAX];        /* steady-state gain: rad/rad, (rad/s)/rad, (rad/s^2)/rad */
    double x[CTL_KALMAN_NMAX];        /* Kalman estimate: q (rad), w (rad/s), a (rad/s^2; 0 for cv) */
    long pos;                         /* next slot of the delay line */
    double buf[CTL_DELAY_MAX + 1];    /* the last delay+1 measurements (rad/s) */
} ctl_sensor;

/* Configure s: resolution res (rad/count, >= 0), period Tc (s, > 0), delay (periods, 0..CTL_DELAY_MAX;
 * clipped into that range), position 0, velocity by backward difference. */
void ctl_sensor_init(ctl_sensor *s, double res, double Tc, long delay);

/* After ctl_sensor_init: the encoder's velocity by the steady-state Kalman filter of n_x states (2: cv, 3: ca;
 * else the backward difference stays) with the gain K0 (rad/rad), K1 ((rad/s)/rad), K2 ((rad/s^2)/rad, used
 * for ca only). The gain comes from the filter's Riccati equation (Python:
 * adaptive_ff.io.kalman_velocity.steady_state_kalman, Anderson & Moore 1979, Sec. 4.4). Without an encoder
 * (res = 0) the velocity stays w + n. Clears the filter's state. */
void ctl_sensor_set_kalman(ctl_sensor *s, long n_x, double K0, double K1, double K2);

/* One period: the measurement the loop receives (rad/s) for true velocity w and noise sample n (rad/s). */
double ctl_sensor_measure(ctl_sensor *s, double w, double n);

#endif
