/* plant_stiff.h -- implicit, error-controlled steps of stiff plants: the lagged models (eqs. 1-3) and LuGre.
 *
 * plant_step (plant_dynamics.h) hands a step to plant_lagged_stiff_step where the lagged model's own velocity
 * range (plant_lagged_local_rate) would need more than PLANT_LAGGED_RK4_MAX RK4 sub-steps, or where a static map
 * (tau == 0, no Karnopp band) can reach its jump at w = 0 within the step (plant_static_jump_in_reach); and to
 * plant_lugre_stiff_step where a LuGre bristle would need more than PLANT_LUGRE_RK4_MAX. Both are extrapolated
 * backward Euler with step doubling (Hairer & Wanner, Solving ODEs I, Sec. II.4; Solving ODEs II, Sec. IV.2).
 * Python: plant.stiff.
 */
#ifndef PLANT_STIFF_H
#define PLANT_STIFF_H
#include "plant_params.h"

/* The limits of the stiff steps (Python: the constants of plant.stiff). */
typedef enum plant_stiff_limits {
    PLANT_LAGGED_RK4_MAX = 64,          /* lagged-model steps needing more RK4 sub-steps: plant_lagged_stiff_step */
    PLANT_LAGGED_MAX_SUBSTEPS = 200000, /* most sub-steps of plant_lagged_stiff_step in one step (then NaN) */
    PLANT_LUGRE_RK4_MAX = 64,           /* LuGre steps needing more RK4 sub-steps: plant_lugre_stiff_step */
    PLANT_LUGRE_MAX_SUBSTEPS = 200000   /* most sub-steps of plant_lugre_stiff_step in one step (then NaN) */
} plant_stiff_limits;

/* Relative tolerance (to |w| + Vs) of plant_lagged_stiff_step's error control on the velocity (1e-5). */
extern const double plant_lagged_rtol;
/* Tolerance of the same error control on the friction state (tau > 0), relative to the largest level (1e-4). */
extern const double plant_lagged_ftol;
/* Relative tolerance (to |w| + Vs) of plant_lugre_stiff_step's error control on the velocity (1e-5). */
extern const double plant_lugre_rtol;
/* Tolerance on the bristle deflection, relative to max(Fc, Fs)/sigma0 (1e-3). */
extern const double plant_lugre_ztol;

/* Largest friction level (N*m) of a lagged model: max(Fc, Fs) over both directions and Fs_stick (the bound of
 * |F(w)| - sigma*|w|, eq. 3), times 1 + ripple_a with a friction ripple. Python: plant.stiff.lagged_level_max. */
double plant_lagged_level_max(const plant_params *p);

/* Fastest stable mode (1/s) of a lagged model over the velocities it can reach within dt (s) from (w, f)
 * (rad/s, N*m) with u (N*m) held: plant.rows.lagged_rate with the steepest rise of eq. 3 taken over
 * |w| +- D only, D = 2*dt*(|u| + max(|f|, Fmax + sigma*|w|))/J; INFINITY when that range reaches a jump of the
 * map (w = 0, the Karnopp band) or the state is not finite. With a friction ripple the slope times 1 + a and the
 * ripple's position stiffness kq = (Fmax + sigma*(|w| + D))*a*n (N*m/rad) enter: max(s/J, sqrt(kq/J)) (tau == 0),
 * max(1/tau, sqrt(s/(J*tau)), cbrt(kq/(J*tau))) (the roots' bound of J*tau*l^3 + J*l^2 + s*l + kq), and at
 * least 4*n*(|w| + D), the ripple's passing rate (resolved for accuracy). Derivative
 * of eq. 3 (plant_stribeck_slope).
 * Python: plant.stiff.lagged_local_rate. */
double plant_lagged_local_rate(const plant_params *p, double w, double f, double u, double dt);

/* 1 where a step of dt (s) of a static lagged model (tau == 0, dv == 0) from w (rad/s) with u (N*m) held may
 * reach the jump of its map at 0: not |w| > dt*(|u| + Fmax + 2*max(sigma, 0)*|w|)/J; 1 for non-finite w or u.
 * Python: plant.stiff.static_jump_in_reach. */
int plant_static_jump_in_reach(const plant_params *p, double w, double u, double dt);

/* One backward-Euler step of a lagged model over h (s) from (w0, f0) (rad/s, N*m) at the position q0 (rad) with
 * u (N*m) held and the Karnopp direction sgn (the map at the end position q0 + h*w, plant_target_at): *w, *f
 * after the step (tau == 0: f is the friction) and *Fstar, the value of the map the step used (on a jump of the
 * map: the value inside the jump that balances the step, Filippov; Karnopp 1985). One scalar equation
 * c*(w - w0) + k*F(w) = r (a = h/tau, c = J*(1 + a), k = h*a, r = h*((1 + a)*u - f0); tau == 0: c = J, k = h,
 * r = h*u) solved by a bracketed Illinois regula falsi (Dahlquist & Bjorck, Sec. 6.2) across the jumps of F. Eqs. 1-3; Hairer & Wanner, Solving ODEs II, Sec. IV.3.
 * Python: plant.stiff.lagged_implicit_step. */
void plant_lagged_implicit_step(const plant_params *p, double w0, double f0, double q0, double u, double h,
                                double sgn, double *w, double *f, double *Fstar);

/* Advance a stiff lagged model by dt (s) with u (N*m) held, in place: sub-steps of plant_lagged_implicit_step
 * with step doubling (accepted when |w_(h/2) - w_h| <= plant_lagged_rtol*(|w| + Vs) and, tau > 0,
 * |f_(h/2) - f_h| <= plant_lagged_ftol*max level), extrapolated 2*y_(h/2) - y_h on one smooth piece of the map,
 * y_(h/2) across a jump; next sub-step hh*0.9/sqrt(err) clipped to [0.2, 2]*hh; the position q by backward
 * Euler on dq/dt = w alongside (extrapolated with w). s->aux: the last sub-step
 * (in, any value outside (0, dt]: dt; out). NaN state for a non-finite state or input or after
 * PLANT_LAGGED_MAX_SUBSTEPS sub-steps. sgn: Karnopp breakaway direction (plant_target). Python:
 * plant.stiff.lagged_stiff_step. */
void plant_lagged_stiff_step(const plant_params *p, plant_state *s, double u, double dt, double sgn);

/* Right-hand side of the LuGre joint at (w, z) (rad/s, rad) and the position q (rad) with u (N*m) and its Jacobian
 * in (w, z) at fixed q (with a ripple g and sigma2 times R(q), plant_params.h):
 * out = {dw/dt, dz/dt, d(dw/dt)/dw, d(dw/dt)/dz, d(dz/dt)/dw, d(dz/dt)/dz}. Canudas de Wit et al. (1995) with
 * a(w) = sigma0*|w|/g(w), a'(w) = sgn(w)*sigma0*(g - |w|*dg/d|w|)/g^2 (plant_stribeck_slope), a'(0) = 0.
 * Python: plant.stiff.lugre_jacobian. */
void plant_lugre_jacobian(const plant_params *p, double w, double z, double q, double u, double out[6]);

/* One backward-Euler step of the LuGre joint over h (s) from (w0, z0) at the position q0 (rad), Newton's method
 * (at most 30 iterations, to 1e-12 relative to |w| + Vs and to max(Fc, Fs)/sigma0): *w, *z after the step;
 * returns 1 if converged. With a ripple the map sits at the end position q0 + h*w and the Newton matrix leaves
 * out that dependence (a term of order h^2*a*n: converging linearly, or not, which halves the sub-step).
 * Hairer & Wanner, Solving ODEs II, Sec. IV.3. Python: plant.stiff.lugre_implicit_step. */
int plant_lugre_implicit_step(const plant_params *p, double w0, double z0, double q0, double u, double h,
                              double *w, double *z);

/* Advance a stiff LuGre joint by dt (s) with u (N*m) held, in place: extrapolated backward Euler
 * (2*y_(h/2) - y_h; Hairer & Wanner, Solving ODEs II, Sec. IV.9) with step doubling (plant_lugre_rtol on w,
 * plant_lugre_ztol*max(Fc, Fs)/sigma0 on z). s->aux: the last sub-step (in: NaN or outside (0, dt]: dt; out).
 * NaN state for a NaN state or after PLANT_LUGRE_MAX_SUBSTEPS sub-steps. Python: plant.stiff.lugre_stiff_step. */
void plant_lugre_stiff_step(const plant_params *p, plant_state *s, double u, double dt);

#endif
