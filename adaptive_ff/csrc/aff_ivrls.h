/* aff_ivrls.h -- recursive instrumental variables (IV) with exponential forgetting and a covariance bound.
 *
 * Model y(k) = phi(k)'theta + e(k) with an equation error e correlated with the regressor phi (closed loop, noisy
 * past outputs in phi: least squares is biased). With instruments z(k) correlated with phi(k) but not with e(k),
 * the weighted IV estimate after N samples is
 *   theta_N = P_N (lam^N P0^-1 theta_0 + sum_k lam^(N-k) z(k) y(k)),
 *   P_N^-1 = lam^N P0^-1 + sum_k lam^(N-k) z(k) phi(k)'
 * and its recursion (Soderstrom & Stoica, System Identification, 1989, Ch. 9, the recursive IV method, with the
 * forgetting factor of its weighted criterion; Ljung, System Identification, 2nd ed., 1999, Ch. 11), per accepted
 * sample:
 *   e = y - phi'theta,  v = P z,  q = P'phi,  s = lam + phi'P z,
 *   theta += v e/s,     P = (P - v q'/s)/lam
 * (P is not symmetric). z = phi gives the RLS of Ruderman's eqs. 10-13 (aff_rls.h). Windup protection as in
 * aff_rls.h: an update whose trace(P) would exceed P_max forgets nothing (lam = 1 for that update). An update with
 * s <= 0 (it would change the sign of det(P^-1)) or one that would overflow is refused before the state changes.
 * With guard, so is one with phi'P z < 0: the instrument opposes the regressor in the metric of P, s < lam, and the
 * gain v/s is unbounded as s -> 0 (the RLS has phi'P phi >= 0 always); the estimate is then the batch IV estimate of
 * the accepted samples. Python: adaptive_ff.compensation.ivrls.RecursiveIV.
 */
#ifndef AFF_IVRLS_H
#define AFF_IVRLS_H
#include "aff_real.h"

/* Most parameters an aff_ivrls holds (the Python wrapper refuses more with a ParameterError). */
#define AFF_IVRLS_NMAX 16

/* Configuration, then state. Units are those of phi and y (theta: y per unit of phi); z any units (its scale
 * cancels). Arrays hold p (p*p, row-major with row length p) valid entries at their start. */
typedef struct aff_ivrls {
    long p;                                         /* number of parameters, 1..AFF_IVRLS_NMAX */
    aff_real lam;                                   /* forgetting factor in (0, 1] */
    aff_real P_max;                                 /* bound on trace(P), > 0, INFINITY = none */
    int guard;                                      /* 1: refuse updates with phi'P z < 0 as well */
    aff_real theta[AFF_IVRLS_NMAX];                 /* estimate */
    aff_real P[AFF_IVRLS_NMAX * AFF_IVRLS_NMAX];    /* inverse of the weighted instrument-regressor moment, p*p */
    aff_real v[AFF_IVRLS_NMAX];                     /* scratch: P z of the last update */
    aff_real q[AFF_IVRLS_NMAX];                     /* scratch: P' phi of the last update */
    long n_updates;                                 /* accepted updates */
    long n_rejected;                                /* refused samples (non-finite, s <= 0, guard, overflow) */
} aff_ivrls;

/* Configure r with p parameters (1..AFF_IVRLS_NMAX), lam in (0, 1], P_max > 0, guard (0/1) and clear it:
 * theta = 0, P = P0*I (P0 > 0), counters 0 (not checked but p: the wrapper checks). A caller with a theta_0 writes
 * the field theta afterwards. Returns 0, or -1 (r untouched) for p outside 1..AFF_IVRLS_NMAX.
 * Python: RecursiveIV.__init__. */
int aff_ivrls_init(aff_ivrls *r, long p, aff_real lam, aff_real P_max, aff_real P0, int guard);

/* One update with the finite sample (phi[0..p-1], z[0..p-1], y) (unchecked: aff_ivrls_update checks); returns the
 * a-priori error y - phi'theta (unit of y), or NAN for a refused update (s <= 0, with guard phi'P z < 0, or e*e, s,
 * |P z|^2, |P'phi|^2 not finite; state untouched but n_rejected). The recursion of the header comment. */
aff_real aff_ivrls_step(aff_ivrls *r, const aff_real *phi, const aff_real *z, aff_real y);

/* Checked update: NAN (state untouched but n_rejected) if y or an entry of phi or z is NaN/inf, else aff_ivrls_step.
 * Python: RecursiveIV.update. */
aff_real aff_ivrls_update(aff_ivrls *r, const aff_real *phi, const aff_real *z, aff_real y);

/* A stream of n samples: Phi, Z (n*p, row-major), Y (n). Checks every sample first: returns the index of the first
 * non-finite one with the state untouched; else updates row by row (aff_ivrls_step; refused rows count in
 * n_rejected), writes theta after sample k into hist[k*p .. k*p+p-1] and returns -1.
 * Python: RecursiveIV.update_many. */
long aff_ivrls_update_many(aff_ivrls *r, const aff_real *Phi, const aff_real *Z, const aff_real *Y, long n,
                           aff_real *hist);

#endif
