/* ctl_sensor.c -- the loop's velocity sensor (see ctl_sensor.h). */
#include <math.h>
#include "ctl_sensor.h"

void ctl_sensor_init(ctl_sensor *s, double res, double Tc, long delay)
{
    s->res = res > 0.0 ? res : 0.0;
    s->Tc = Tc;
    s->delay = delay < 0 ? 0 : (delay > CTL_DELAY_MAX ? CTL_DELAY_MAX : delay);
    s->started = 0;
    s->q = 0.0;
    s->w_prev = 0.0;
    s->qm_prev = 0.0;
    s->kalman = 0;
    s->n_x = 2;
    for (int i = 0; i < CTL_KALMAN_NMAX; i++) {
        s->K[i] = 0.0;
        s->x[i] = 0.0;
    }
    s->pos = 0;
    for (int i = 0; i <= CTL_DELAY_MAX; i++)
        s->buf[i] = 0.0;
}

void ctl_sensor_set_kalman(ctl_sensor *s, long n_x, double K0, double K1, double K2)
{
    if (n_x != 2 && n_x != 3) {
        s->kalman = 0;
        return;
    }
    s->kalman = 1;
    s->n_x = n_x;
    s->K[0] = K0;
    s->K[1] = K1;
    s->K[2] = n_x == 3 ? K2 : 0.0;
    for (int i = 0; i < CTL_KALMAN_NMAX; i++)
        s->x[i] = 0.0;
}

/* One period of the steady-state Kalman filter on the counts read qm (rad): predict with F of the period Tc
 * (cv: q += Tc*w; ca: q += Tc*w + Tc^2/2*a, w += Tc*a), correct with the constant gain; returns the velocity
 * estimate (rad/s). Bar-Shalom, Li, Kirubarajan 2001, Sec. 6.2-6.3 (the model); Sec. 5.2 (the filter). */
static double kalman_step(ctl_sensor *s, double qm)
{
    double T = s->Tc;
    double q, w, a, y;
    if (s->n_x == 3) {
        q = s->x[0] + T * s->x[1] + (T * T / 2.0) * s->x[2];
        w = s->x[1] + T * s->x[2];
        a = s->x[2];
    } else {
        q = s->x[0] + T * s->x[1];
        w = s->x[1];
        a = 0.0;
    }
    y = qm - q;
    s->x[0] = q + s->K[0] * y;
    s->x[1] = w + s->K[1] * y;
    s->x[2] = a + s->K[2] * y;
    return s->x[1];
}

double ctl_sensor_measure(ctl_sensor *s, double w, double n)
{
    double v = w + n;
    long d = s->delay;
    if (s->res > 0.0) {
        double qm;
        if (s->started)
            s->q += 0.5 * s->Tc * (s->w_prev + w);
        qm = s->res * floor(s->q / s->res);
        if (s->kalman) {
            if (s->started) {
                v = kalman_step(s, qm) + n;
            } else {
                s->x[0] = qm;
                s->x[1] = w;
                s->x[2] = 0.0;
            }
        } else if (s->started) {
            v = (qm - s->qm_prev) / s->Tc + n;
        }
        s->qm_prev = qm;
        s->w_prev = w;
    }
    if (d == 0) {
        s->started = 1;
        return v;
    }
    if (!s->started)
        for (long i = 0; i <= d; i++)
            s->buf[i] = v;
    s->started = 1;
    s->buf[s->pos] = v;
    s->pos = s->pos == d ? 0 : s->pos + 1; /* the slot written d periods ago is read next */
    return s->buf[s->pos];
}
