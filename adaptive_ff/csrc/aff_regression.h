/* aff_regression.h -- the regression model of eq. 4: its regressor and its inverse map to physical parameters.
 *
 *   w(k) = a1*w(k-1) - a2*w(k-2) + b0*u(k) - b1*u(k-1) - c1*g(w(k-1)) - d1*h(w(k-1)) - o1
 * with g = sgn(w)*(1 - exp(-|w/Vs|^delta)), h = sgn(w)*exp(-|w/Vs|^delta) (eqs. 5-6) and the coefficients
 * derived in adaptive_ff/identification/regression.py (the printed a1, b0, b1 of the paper corrected):
 *   b0 - b1 = Ts^2/D, tau = Ts*b1/(b0 - b1), J = Ts*(a1 - 2*a2)/(b0 - b1), sigma = (1 - a1 + a2)/(b0 - b1),
 *   Fc = c1/(b0 - b1), Fs = d1/(b0 - b1), offset = o1/(b0 - b1), J_alt = Ts*a2/b1.
 * Structures: lag (columns a2, b1), stribeck (c1, d1; else one column sgn with c1 = d1), offset (o1).
 * Python: adaptive_ff.identification.regression.RegressionModel (phi, to_physical), eq4_phi, eq4_to_physical.
 */
#ifndef AFF_REGRESSION_H
#define AFF_REGRESSION_H
#include "aff_real.h"

/* Physical parameters of a friction estimate (the fields of regression.FrictionEstimate without Vs, delta). */
typedef struct aff_physical {
    aff_real J;       /* inertia (kg*m^2) */
    aff_real tau;     /* friction lag (s) */
    aff_real sigma;   /* viscous coefficient (N*m*s/rad) */
    aff_real Fc;      /* Coulomb level (N*m) */
    aff_real Fs;      /* static level (N*m) */
    aff_real offset;  /* constant torque offset (N*m) */
    aff_real J_alt;   /* the redundant inertia estimate (kg*m^2), NaN where not defined */
} aff_physical;

/* Write the regressor phi(k) of eq. 4 of the structure (lag, stribeck, offset) into phi and return its length p:
 * [w(k-1), -w(k-2), u(k), -u(k-1), -g(w(k-1)), -h(w(k-1)), -1] without the absent columns (-sgn(w(k-1)) for the
 * Coulomb structure). u in N*m, w in rad/s, Vs (rad/s) and delta used with stribeck. phi holds >= 7 entries. */
long aff_eq4_phi(aff_real *phi, aff_real u_k, aff_real u_km1, aff_real w_km1, aff_real w_km2, aff_real Vs,
                 aff_real delta, int lag, int stribeck, int offset);

/* The inverse map of eq. 4 (header comment) of theta (order a1, [a2], b0, [b1], c1, [d1], [o1]) at the sample
 * time Ts (s) into out; +-inf/NaN where b0 == b1, J_alt NaN where b1 == 0. */
void aff_eq4_to_physical(const aff_real *theta, aff_real Ts, int lag, int stribeck, int offset, aff_physical *out);

/* The static friction map of theta (order as aff_eq4_to_physical) at the velocity w (rad/s), through the inverse
 * map: F(w) = Fc*(1 - shape) + Fs*shape + sigma*w = (c1*(1 - shape) + d1*shape + (1 - a1 + a2)*w)/(b0 - b1) (N*m;
 * shape = exp(-|w/Vs|^delta) of the structure's Vs, delta, plant_stribeck_shape; without stribeck d1 = c1, so F =
 * (c1 + (1 - a1 + a2)*w)/(b0 - b1)), and its gradient with respect to theta into grad[0..p-1] (N*m per unit of each
 * parameter; 0 for o1: the offset is not friction). The delta method's Jacobian (Ljung, System Identification,
 * 2nd ed., 1999, Sec. 9.3) for the standard error of the estimated map. Returns F(w); NaN/inf where b0 == b1. */
aff_real aff_eq4_static_gradient(const aff_real *theta, int lag, int stribeck, int offset, aff_real w, aff_real shape,
                                 aff_real *grad);

#endif
