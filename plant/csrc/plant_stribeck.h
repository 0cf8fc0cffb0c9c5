/* plant_stribeck.h -- the static Stribeck map, Ruderman eq. 3, the one implementation.
 *
 *   F(w) = sgn(w)*(Fc + (Fs - Fc)*exp(-|w/Vs|^delta)) + sigma*w
 *
 * Used by the plant models (plant_*.c), the compensator's feedforward
 * (adaptive_ff/csrc) and the Python wrappers (plant.stribeck_map). Written in
 * aff_real (aff_real.h) so the compensator's float build uses it too.
 */
#ifndef PLANT_STRIBECK_H
#define PLANT_STRIBECK_H
#include "aff_real.h"

/* Parameters of eq. 3. Units: Fc, dF in N*m; Vs in rad/s (> 0); delta
 * dimensionless (non-zero); sigma in N*m*s/rad; wcut in rad/s (the speed above
 * which the Stribeck term rounds away, plant.stribeck_map.stribeck_cutoff;
 * INFINITY disables the shortcut). */
typedef struct plant_stribeck {
    aff_real Fc;     /* Coulomb level (N*m) */
    aff_real dF;     /* Fs - Fc (N*m) */
    aff_real Vs;     /* Stribeck velocity (rad/s) */
    aff_real delta;  /* shape factor (1) */
    aff_real sigma;  /* viscous coefficient (N*m*s/rad) */
    aff_real wcut;   /* cut-off speed of the Stribeck term (rad/s) */
} plant_stribeck;

/* x^delta for x >= 0 (the normalised speed |w|/Vs of eq. 3): at delta 1, 2
 * and 0.5 the correctly rounded x, x*x and sqrt(x) (the shapes of the
 * profile grids; NumPy's power takes the same three for an array), else
 * pow(x, delta) (within about half a unit in the last place, not always
 * correctly rounded, and several times the cost). NaN for NaN x. */
aff_real plant_stribeck_power(aff_real x, aff_real delta);

/* exp(-|w/Vs|^delta): the Stribeck decay at velocity w (rad/s), in [0, 1];
 * the limit at w == 0 (1 for delta > 0, 0 for delta < 0); NaN for NaN w.
 * The power by plant_stribeck_power. Source: eq. 3. */
aff_real plant_stribeck_shape(aff_real w, aff_real Vs, aff_real delta);

/* F(w) of eq. 3 (N*m) for the parameters m; F(0) = 0; NaN for NaN w. The
 * operations are those of the plain formula in this order (no fast-math), so
 * the double build equals a Python evaluation with ** and math.exp. */
aff_real plant_stribeck_eval(const plant_stribeck *m, aff_real w);

/* d/d|w| of dF*exp(-x^delta) at the normalised speed x = |w|/Vs >= 0
 * (N*m*s/rad): -dF*delta*x^(delta-1)*exp(-x^delta)/Vs; 0 where the
 * exponential underflows. Derivative of eq. 3 (chain rule). */
aff_real plant_stribeck_slope(aff_real x, aff_real dF, aff_real Vs, aff_real delta);

/* Fill out[i] = F(w[i]) for i < n (arrays of n aff_real). */
void plant_stribeck_array(const plant_stribeck *m, const aff_real *w, aff_real *out, long n);

/* Fill out[i] = plant_stribeck_shape(w[i], Vs, delta) for i < n. */
void plant_stribeck_shape_array(const aff_real *w, aff_real *out, long n, aff_real Vs, aff_real delta);

#endif
