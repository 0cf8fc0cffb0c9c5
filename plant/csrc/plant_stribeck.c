/* plant_stribeck.c -- Ruderman eq. 3 (see plant_stribeck.h). */
#include "plant_stribeck.h"

aff_real plant_stribeck_power(aff_real x, aff_real delta)
{
    if (delta == (aff_real)1.0)
        return x;
    if (delta == (aff_real)2.0)
        return x * x;
    if (delta == (aff_real)0.5)
        return AFF_SQRT(x);
    return AFF_POW(x, delta);
}

aff_real plant_stribeck_shape(aff_real w, aff_real Vs, aff_real delta)
{
    return AFF_EXP(-plant_stribeck_power(AFF_FABS(w) / Vs, delta));
}

aff_real plant_stribeck_eval(const plant_stribeck *m, aff_real w)
{
    if (w > (aff_real)0.0) {
        if (w > m->wcut)
            return m->Fc + m->sigma * w;
        return m->Fc + m->dF * plant_stribeck_shape(w, m->Vs, m->delta) + m->sigma * w;
    }
    if (w == (aff_real)0.0)
        return (aff_real)0.0;
    if (-w > m->wcut) /* w < 0; a NaN falls through to NaN */
        return -m->Fc + m->sigma * w;
    return -(m->Fc + m->dF * plant_stribeck_shape(w, m->Vs, m->delta)) + m->sigma * w;
}

aff_real plant_stribeck_slope(aff_real x, aff_real dF, aff_real Vs, aff_real delta)
{
    aff_real s = AFF_EXP(-plant_stribeck_power(x, delta));
    if (s == (aff_real)0.0)
        return (aff_real)0.0;
    return -dF * delta * AFF_POW(x, delta - (aff_real)1.0) * s / Vs;
}

void plant_stribeck_array(const plant_stribeck *m, const aff_real *w, aff_real *out, long n)
{
    for (long i = 0; i < n; i++)
        out[i] = plant_stribeck_eval(m, w[i]);
}

void plant_stribeck_shape_array(const aff_real *w, aff_real *out, long n, aff_real Vs, aff_real delta)
{
    for (long i = 0; i < n; i++)
        out[i] = plant_stribeck_shape(w[i], Vs, delta);
}
