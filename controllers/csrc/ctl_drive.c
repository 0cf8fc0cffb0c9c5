/* ctl_drive.c -- the drive's slew-rate limit (see ctl_drive.h). */
#include <math.h>
#include "ctl_drive.h"

void ctl_drive_init(ctl_drive *d, double slew, double Tc)
{
    d->slew = slew;
    d->Tc = Tc;
    d->u_prev = 0.0;
}

double ctl_drive_apply(ctl_drive *d, double u)
{
    double step = d->slew * d->Tc;
    double du = u - d->u_prev;
    if (-step <= du && du <= step) { /* within the limit: the command itself, exactly */
        d->u_prev = u;
        return u;
    }
    d->u_prev += du > 0.0 ? step : -step; /* a NaN command also lands here and stays NaN */
    if (du != du)
        d->u_prev = u;
    return d->u_prev;
}
