/* aff_regression.c -- eq. 4's regressor and inverse map (see aff_regression.h). */
#include "aff_regression.h"
#include "plant_stribeck.h"

/* sgn(w): 1, -1, 0 (also for -0.0), NaN for NaN (numpy's sign). */
static aff_real sgn(aff_real w)
{
    return w > 0 ? (aff_real)1.0 : (w < 0 ? (aff_real)-1.0 : (w == 0 ? (aff_real)0.0 : w));
}

long aff_eq4_phi(aff_real *phi, aff_real u_k, aff_real u_km1, aff_real w_km1, aff_real w_km2, aff_real Vs,
                 aff_real delta, int lag, int stribeck, int offset)
{
    long j = 0;
    aff_real s;
    phi[j++] = w_km1;
    if (lag)
        phi[j++] = -w_km2;
    phi[j++] = u_k;
    if (lag)
        phi[j++] = -u_km1;
    s = sgn(w_km1);
    if (stribeck) {
        aff_real e = plant_stribeck_shape(w_km1, Vs, delta);
        phi[j] = -(s * ((aff_real)1.0 - e));
        phi[j + 1] = -(s * e);
        j += 2;
    } else {
        phi[j++] = -s;
    }
    if (offset)
        phi[j++] = -1.0;
    return j;
}

void aff_eq4_to_physical(const aff_real *theta, aff_real Ts, int lag, int stribeck, int offset, aff_physical *out)
{
    long j = 0;
    aff_real a1, a2 = 0, b0, b1 = 0, c1, d1, o1, gain, inv;
    a1 = theta[j++];
    if (lag)
        a2 = theta[j++];
    b0 = theta[j++];
    if (lag)
        b1 = theta[j++];
    c1 = theta[j++];
    d1 = c1;
    if (stribeck)
        d1 = theta[j++];
    o1 = offset ? theta[j] : (aff_real)0.0;
    gain = b0 - b1;
    inv = gain != 0 ? (aff_real)1.0 / gain : AFF_COPYSIGN((aff_real)INFINITY, gain);
    out->J = Ts * (a1 - (aff_real)2.0 * a2) * inv;
    out->tau = Ts * b1 * inv;
    out->sigma = ((aff_real)1.0 - a1 + a2) * inv;
    out->Fc = c1 * inv;
    out->Fs = d1 * inv;
    out->offset = o1 * inv;
    out->J_alt = b1 != 0 ? Ts * a2 / b1 : (aff_real)NAN;
}

aff_real aff_eq4_static_gradient(const aff_real *theta, int lag, int stribeck, int offset, aff_real w, aff_real shape,
                                 aff_real *grad)
{
    long j = 0, ia1, ia2 = -1, ib0, ib1 = -1, ic1, id1 = -1;
    aff_real a2 = 0, b1 = 0, d1, g, num, inv;
    ia1 = j++;
    if (lag)
        ia2 = j++;
    ib0 = j++;
    if (lag)
        ib1 = j++;
    ic1 = j++;
    if (stribeck)
        id1 = j++;
    if (offset)
        grad[j++] = 0.0;
    if (lag) {
        a2 = theta[ia2];
        b1 = theta[ib1];
    }
    d1 = stribeck ? theta[id1] : theta[ic1];
    g = theta[ib0] - b1;
    num = stribeck ? theta[ic1] * ((aff_real)1.0 - shape) + d1 * shape : theta[ic1];
    num += ((aff_real)1.0 - theta[ia1] + a2) * w;
    inv = (aff_real)1.0 / g;
    grad[ia1] = -w * inv;
    if (lag) {
        grad[ia2] = w * inv;
        grad[ib1] = num * inv * inv;
    }
    grad[ib0] = -num * inv * inv;
    grad[ic1] = (stribeck ? (aff_real)1.0 - shape : (aff_real)1.0) * inv;
    if (stribeck)
        grad[id1] = shape * inv;
    return num * inv;
}
