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
    s->pos = 0;
    for (int i = 0; i <= CTL_DELAY_MAX; i++)
        s->buf[i] = 0.0;
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
        if (s->started)
            v = (qm - s->qm_prev) / s->Tc + n;
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
