/* aff_stribeck_fit.h -- eq. 3 and its parameter Jacobian for the Levenberg-Marquardt pre-fit of the
 * Stribeck curve (Ruderman, Sec. V-C, Fig. 8).
 *
 * The fit works on x = (Fc, Fs, log Vs, delta, sigma). The model values are
 * plant's one eq. 3 (plant_stribeck_eval, no speed shortcut); the Jacobian
 * uses the log-domain shape terms with p = (|w|/Vs)^delta:
 *   log p = min(delta*log(|w|/Vs), AFF_STRIBECK_FIT_LOGP_MAX),
 *   s = exp(-p), s*p = exp(log p - p) (no inf*0).
 * Python: adaptive_ff.identification.stribeck_fit (_model, _jacobian).
 */
#ifndef AFF_STRIBECK_FIT_H
#define AFF_STRIBECK_FIT_H
#include "plant_stribeck.h"

/* Clip of log p (exp(700) ~ 1e304 stays finite); stribeck_fit._LOGP_MAX. */
#define AFF_STRIBECK_FIT_LOGP_MAX 700.0

/* out[i] = F(w[i]) of eq. 3 (N*m) for i < n with Fc (N*m), dF = Fs - Fc (N*m), Vs (rad/s), delta (1),
 * sigma (N*m*s/rad); plant_stribeck_eval with wcut = INFINITY (no shortcut). No argument checks: the
 * optimiser may try any delta (delta < 0 and tiny |w|: the power overflows and the shape is its limit 0);
 * F(0) = 0; NaN for NaN w. Arrays of n doubles. Source: eq. 3. */
void aff_stribeck_fit_values(const double *w, double *out, long n, double Fc, double dF, double Vs,
                             double delta, double sigma);

/* Jacobian of eq. 3 in x = (Fc, Fs, log Vs, delta, sigma): out[5*i + j] = dF(w[i])/dx[j] for i < n
 * (row-major n x 5 doubles). w: speeds (rad/s), w != 0 (the fit drops w == 0, where log|w| = -inf makes
 * column 3 NaN); logaw: log|w| (same length); Fc, Fs (N*m); logVs (log of rad/s); delta (1); no checks.
 * With logx = logaw - logVs, log p clipped at AFF_STRIBECK_FIT_LOGP_MAX, s = exp(-p), sp = exp(log p - p):
 *   (sg*(1 - s), sg*s, sg*(Fs - Fc)*delta*sp, -sg*(Fs - Fc)*sp*logx, w).
 * Source: eq. 3 (chain rule: ds/dlog Vs = s*p*delta, ds/ddelta = -s*p*log(|w|/Vs)). */
void aff_stribeck_fit_jacobian(const double *w, const double *logaw, double *out, long n, double Fc,
                               double Fs, double logVs, double delta);

#endif
