/* aff_rls.h -- recursive least squares with forgetting (Ruderman eqs. 10-13), windup protection and projection.
 *
 * With phi the regressor and y the output (paper: X and w), per accepted sample
 *   e = y - phi'theta,  s = lam + phi'P phi,  theta += P phi e/s,  P = (P - (P phi)(P phi)'/s)/lam
 * with P held as its factors P = U diag(d) U' (U unit upper triangular, d > 0) and updated by Bierman's algorithm
 * (G. J. Bierman, Factorization Methods for Discrete Sequential Estimation, 1977, Sec. V.3; Grewal & Andrews,
 * Kalman Filtering, 4th ed., 2015, Sec. 7.5.2): P stays symmetric positive definite in float as in double, where
 * the rank-one form P - (P phi)(P phi)'/s loses it at the condition numbers of a first learning transient. The
 * struct holds the factors only; P's entries and phi'P phi are computed from them (aff_rls_P, aff_rls_cov,
 * aff_rls_quad). Three forgetting schemes:
 *   AFF_RLS_EXPONENTIAL  eqs. 10-13; an update whose trace(P) would exceed P_max forgets nothing;
 *   AFF_RLS_DIRECTIONAL  information forgotten along phi only (Kulhavy, Automatica 23(5), 1987; Bittanti,
 *                        Bolzern, Campi, Automatica 26(5), 1990), same trace bound;
 *   AFF_RLS_VECTOR       one factor per parameter: P <- D.P (elementwise, D = d d', d = lam^-1/2) unless that
 *                        exceeds P_max, then a unit-weight update (Saelid & Foss, IEEE CDC 1983).
 * After an update theta is projected onto the box [lower, upper] in the metric of P^-1 (Goodwin & Sin,
 * Adaptive Filtering, Prediction and Control, 1984, Sec. 3.3.7). A sample whose update would overflow is
 * refused before the state changes. Python: adaptive_ff.identification.rls.RecursiveLeastSquares.
 */
#ifndef AFF_RLS_H
#define AFF_RLS_H
#include "aff_real.h"
#include "aff_error.h"

/* Most parameters an aff_rls holds (the Python wrapper refuses more with a ParameterError). */
#define AFF_RLS_NMAX 16

/* Forgetting schemes (field scheme). */
enum { AFF_RLS_EXPONENTIAL = 0, AFF_RLS_DIRECTIONAL = 1, AFF_RLS_VECTOR = 2 };

/* The estimator's settings. The start theta (0 after init), the box of the projection and the per-parameter factors
 * of the vector scheme are set after aff_rls_init: the fields theta, lower/upper with has_bounds = 1, and
 * aff_rls_set_lam_each. */
typedef struct aff_rls_config {
    long n_params;        /* number of parameters p, 1..AFF_RLS_NMAX; default 1 */
    int forgetting;       /* AFF_RLS_EXPONENTIAL (default), AFF_RLS_DIRECTIONAL or AFF_RLS_VECTOR */
    aff_real lam;         /* forgetting factor per update (-), in (0, 1]; default 1 (AFF_RLS_VECTOR: unused, 1) */
    aff_real P0;          /* initial covariance P = P0*I (units of theta squared), finite, > 0; default 1e4 */
    aff_real P_max;       /* bound on trace(P), > 0, INFINITY: none; 0 (default): trace(P0*I), P0 summed p times */
} aff_rls_config;

/* Configuration, then state. Units are those of phi and y (theta: y per unit of phi). Arrays hold p (p*p,
 * row-major with row length p) valid entries at their start. */
typedef struct aff_rls {
    long p;                                      /* number of parameters, 1..AFF_RLS_NMAX */
    int scheme;                                  /* AFF_RLS_EXPONENTIAL, _DIRECTIONAL or _VECTOR */
    aff_real lam;                                /* forgetting factor in (0, 1] (1 for the vector scheme) */
    aff_real P_max;                              /* bound on trace(P), > 0, INFINITY = none */
    int has_bounds;                              /* 1: project theta onto [lower, upper] after each update */
    aff_real lower[AFF_RLS_NMAX];                /* lower bounds of theta (-INFINITY allowed) */
    aff_real upper[AFF_RLS_NMAX];                /* upper bounds of theta (INFINITY allowed) */
    aff_real D[AFF_RLS_NMAX * AFF_RLS_NMAX];     /* vector scheme: inflation factors d_i*d_j (p*p) */
    aff_real theta[AFF_RLS_NMAX];                /* estimate */
    aff_real UD[AFF_RLS_NMAX * AFF_RLS_NMAX];    /* the covariance P = U diag(d) U' as its factors, p*p row-major:
                                                    d_j at (j, j), U_ij (i < j) above the diagonal (U's unit
                                                    diagonal implied), 0 below; set through aff_rls_set_P */
    aff_real v[AFF_RLS_NMAX];                    /* P phi of the last update (the P before it, inflated by the
                                                    vector scheme) */
    int64_t n_updates;                           /* accepted updates */
    int64_t n_projected;                         /* updates after which theta was projected onto the box */
    int64_t n_rejected;                          /* refused samples (non-finite, or an update that would overflow) */
} aff_rls;

/* The defaults of aff_rls_config (one parameter, exponential forgetting with lam 1: ordinary RLS, P0 1e4, the
 * trace bound trace(P0*I)). */
aff_rls_config aff_rls_default_config(void);

/* Configure r from *cfg and clear it: theta = 0, P = P0*I (U = I, d = P0), no bounds (lower -inf, upper +inf),
 * D = 1, counters 0; lam 1 for the vector scheme. A caller with a start theta0 or bounds writes the fields theta,
 * lower/upper (has_bounds = 1) afterwards, a full P0 through aff_rls_set_P; the vector scheme's factors:
 * aff_rls_set_lam_each. Returns AFF_OK, or AFF_ERR_NULL, AFF_ERR_RLS_N_PARAMS, _FORGETTING, _LAM, _P0, _P_MAX
 * (r untouched). Python: RecursiveLeastSquares.__init__. */
aff_error aff_rls_init(aff_rls *r, const aff_rls_config *cfg);

/* Set the covariance to the symmetric positive definite P[0..p*p-1] (row-major): UD becomes its factors (U D U'
 * decomposition, Bierman 1977, Sec. III.2). Returns AFF_OK, or AFF_ERR_NULL, or AFF_ERR_RLS_P (an entry not
 * finite, P not symmetric, or not positive definite: a factor d_j not finite and > 0); r untouched then. Works on
 * a p*p copy on the stack (up to 2 kB in double): a call of a configuration step, not of a drive's period. Python:
 * RecursiveLeastSquares.P = value. */
aff_error aff_rls_set_P(aff_rls *r, const aff_real *P);

/* The checks of aff_rls_init alone: AFF_OK or the code it would return for *cfg. */
aff_error aff_rls_check_config(const aff_rls_config *cfg);

/* The vector scheme's factors, one per parameter, lam[0..p-1] in (0, 1]: D = d d' with d_i = lam_i^(-1/2) (the
 * product of two powers, exactly symmetric). Returns AFF_OK, or AFF_ERR_RLS_FORGETTING (r not of the vector
 * scheme) or AFF_ERR_RLS_LAM_EACH (a factor outside (0, 1]); r untouched then. Python: RecursiveLeastSquares with
 * a vector lam. */
aff_error aff_rls_set_lam_each(aff_rls *r, const aff_real *lam);

/* One update with the finite sample (phi[0..p-1], y) (unchecked: aff_rls_update checks); returns the a-priori
 * error y - phi'theta (unit of y). An update that would overflow (e*e, phi'P phi or |P phi|^2 not finite; the
 * factors' growth: trace(P)/lam not finite; the vector scheme: trace(D.P)^2 |phi|^2 not finite) is refused before
 * the state changes: n_rejected counts it and NAN is returned. Eqs. 10-13 and the schemes above;
 * the covariance by Bierman's update of U, d. */
aff_real aff_rls_step(aff_rls *r, const aff_real *phi, aff_real y);

/* Checked update: NAN (state untouched but n_rejected) if y or an entry of phi[0..p-1] is NaN/inf, else
 * aff_rls_step. Python: RecursiveLeastSquares.update. */
aff_real aff_rls_update(aff_rls *r, const aff_real *phi, aff_real y);

/* A stream of n samples: Phi (n*p, row-major), Y (n). Checks every sample first: returns the index of the first
 * non-finite one with the state untouched; else updates row by row (aff_rls_step), writes theta after sample k
 * into hist[k*p .. k*p+p-1] and returns -1. Python: RecursiveLeastSquares.update_many. */
long aff_rls_update_many(aff_rls *r, const aff_real *Phi, const aff_real *Y, long n, aff_real *hist);

/* Entry (i, j) of P = U diag(d) U' (0 <= i, j < p; not checked), computed from the factors (O(p); (i, j) and
 * (j, i) give the same number). */
aff_real aff_rls_P(const aff_rls *r, long i, long j);

/* P into out[0..p*p-1], row-major, exactly symmetric (the entries of aff_rls_P). Python: RecursiveLeastSquares.P. */
void aff_rls_cov(const aff_rls *r, aff_real *out);

/* x'P x = sum_j d_j ((U' x)_j)^2 >= 0 for x[0..p-1], O(p^2). */
aff_real aff_rls_quad(const aff_rls *r, const aff_real *x);

/* Prior variance per parameter, P_max/p (INFINITY for the unbounded eqs. 10-13): the scale against which the
 * data's reduction of a diagonal entry of P is judged (adaptive_ff.compensation.adaptive_feedforward). */
aff_real aff_rls_prior_variance(const aff_rls *r);

#endif
