/* ctl_pi.c -- the PI controller (see ctl_pi.h). */
#include "ctl_pi.h"

void ctl_pi_init(ctl_pi *p, double Kp, double KiTc, double u_max, double I0)
{
    p->Kp = Kp;
    p->KiTc = KiTc;
    p->u_max = u_max;
    p->I = I0;
    p->saturated = 0;
}

double ctl_pi_step(ctl_pi *p, double e, double u_ff)
{
    double Kpe = p->Kp * e;
    double d = p->KiTc * e;
    double I = p->I;
    double In = I + d;
    double umax = p->u_max;
    if (d > 0.0) {
        double lim = umax - Kpe - u_ff;
        if (In > lim)
            In = lim > I ? lim : I;
    } else if (d < 0.0) {
        double lim = -umax - Kpe - u_ff;
        if (In < lim)
            In = lim < I ? lim : I;
    }
    p->I = In;
    double v = Kpe + In + u_ff;
    if (v >= umax) {
        p->saturated = 1;
        return umax;
    }
    if (v <= -umax) {
        p->saturated = 1;
        return -umax;
    }
    p->saturated = 0;
    return v;
}
