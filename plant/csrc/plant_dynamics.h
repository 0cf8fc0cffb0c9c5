/* plant_dynamics.h -- the plant as one component: the RK4 step, the step of every model, the friction torque.
 *
 * plant_step advances a plant_state by one step with the input held, in place (RK4 sub-steps; the implicit
 * steps of plant_stiff.h where the plant is stiff); plant_friction returns the friction torque. The open-loop
 * simulation (plant.joint.simulate), the identification simulator and the closed-loop engine call them with
 * the structs of plant_params.h. Python: plant.dynamics.
 */
#ifndef PLANT_DYNAMICS_H
#define PLANT_DYNAMICS_H
#include "plant_params.h"
#include "plant_stiff.h"

/* Largest rate*dt of a stable mode that one explicit RK4 step of a lagged model accepts (2.5; RK4's stability
 * interval on the negative real axis ends at 2.785; Hairer & Wanner, Solving ODEs II, Sec. IV.2). Python:
 * plant.rows.RK4_RATE_MAX. */
extern const double plant_rk4_rate_max;

/* One classic fourth-order Runge-Kutta step of h (s, > 0) of the plant, in place on *w (rad/s) and *s (f in N*m,
 * LuGre z in rad), with the input torque given at the start, the middle and the end of the step (u0, um, u1,
 * N*m; u0 = um = u1: zero-order hold; um = (u0 + u1)/2: first-order hold). Fw = plant_target(p, *w, sgn),
 * passed in so a caller can reuse a value it has; sgn: Karnopp breakaway direction (plant_target). Lagged
 * models with tau == 0: RK4 on w alone, s unchanged (the caller sets f = F(w)). Right-hand side: eqs. 1-2 with
 * the reciprocals inv_J, inv_tau (lagged models) or the LuGre equations (dividing by J). plant_rk4_at from the
 * position q = 0 (a plant without friction ripple: the identification's simulators). Classic RK4: Hairer,
 * Norsett, Wanner, Solving ODEs I, Sec. II.1. Python: plant.dynamics.plant_rk4. */
void plant_rk4(const plant_params *p, double *w, double *s, double Fw, double u0, double um, double u1, double h,
               double sgn);

/* plant_rk4 with the joint position *q (rad, dq/dt = w) integrated alongside, in place: the stages evaluate the
 * map at their position (plant_target_at; Fw = plant_target_at(p, *w, *q, sgn)); without a friction ripple *q
 * does not enter w, s (the same operations as plant_rk4 on them). Python: plant.dynamics.plant_rk4 (argument q). */
void plant_rk4_at(const plant_params *p, double *w, double *s, double *q, double Fw, double u0, double um, double u1,
                  double h, double sgn);

/* Advance the plant state *st by one step of dt (s, > 0) with the torque u (N*m) held, in place (the position q
 * too; with a friction ripple the map is F(w)*R(q), plant_params.h, and the Karnopp stick limit Fs*R(q)).
 * Lagged models: one RK4 step (tau == 0: RK4 on w, then s = F(w) and aux = p->key, which the next step reuses);
 * tau == 0 without a Karnopp band where the step can reach the jump at w = 0 (plant_static_jump_in_reach): the
 * set-valued plant_lagged_stiff_step (Filippov: at rest while -F(0-) <= u <= F(0+), f = u). Karnopp: in the band
 * |w| < dv with |u| <= Fs the friction balances u up to Fs and opposes the motion with at most Fs (|f| <= Fs,
 * Karnopp 1985): where the step's stopping friction u + J*w/dt lies within [-Fs, Fs] the joint sticks (w = 0,
 * f = u, q advanced to the stop), else it slides the step decelerated by f = Fs*sgn(w) (w += dt*(u - f)/J, exact;
 * q by the trapezoid); with |u| > Fs it breaks away (RK4 with the band target Fs*sgn(u)). A lagged model with rate*dt > plant_rk4_rate_max takes (long)(rate*dt) + 1 equal RK4
 * sub-steps, beyond PLANT_LAGGED_RK4_MAX of them (unless the step's own velocity range is mild,
 * plant_lagged_local_rate) plant_lagged_stiff_step. LuGre: n equal RK4 sub-steps with n chosen from the
 * stiffness at the step start, rate = sigma0*|w|max/g_min + base_rate (rate*h < 1; rate bounds the eigenvalues of
 * the linearised bristle-mass system, the damping sigma1 + sigma2 included, so |l|*h stays inside RK4's interval
 * (-2.78, 0]); n > PLANT_LUGRE_RK4_MAX: plant_lugre_stiff_step (any sigma1, sigma2 >= 0); a non-finite state
 * or input gives NaN. With a friction ripple the lagged models' rate also covers the ripple's position stiffness
 * and 4*n*|w| (its passing rate), LuGre's the levels within (1 -+ a), the position coupling and n*|w|, and LuGre
 * takes 4 times the RK4 sub-steps of that rate (accuracy of its forced bristle mode; the stiff switch unchanged).
 * Eqs. 1-3 of Ruderman; Karnopp (1985); Canudas de Wit et al. (1995).
 * Python: plant.dynamics.plant_step, make_plant_step. */
void plant_step(const plant_params *p, plant_state *st, double u, double dt);

/* 1 if plant_step of p with step dt takes its common case wherever w is outside the Karnopp band (a lagged model
 * with tau != 0, no friction ripple, one RK4 step: rate*dt <= plant_rk4_rate_max), else 0: a loop over many steps of
 * one parameter row tests this once and then calls plant_step_smooth. */
int plant_step_is_smooth(const plant_params *p, double dt);

/* plant_step for a p with plant_step_is_smooth(p, dt): the same w and s, without the per-step tests of the model;
 * outside the Karnopp band the position st->q is left as it is (without a ripple nothing reads it). */
void plant_step_smooth(const plant_params *p, plant_state *st, double u, double dt);

/* Friction torque (N*m) of the plant in state *st: lagged models the friction state s (eq. 1); LuGre
 * sigma0*z + sigma1*dz/dt + sigma2*w (Canudas de Wit et al. 1995, eq. 3; with a ripple g and sigma2 times R(q)).
 * Python: plant.dynamics.plant_friction. */
double plant_friction(const plant_params *p, const plant_state *st);

/* Open loop: plant_step over the n inputs u[k] (N*m, each held for dt s) from *st (advanced in place to the
 * final state), recording W[k], S[k], Q[k] (velocity, internal state, position in rad; Q may be NULL: not
 * recorded) for k = 0..n (n + 1 entries each, the initial state included). Python: plant.dynamics.plant_simulate,
 * plant.joint.simulate. */
void plant_simulate(const plant_params *p, plant_state *st, const double *u, long n, double dt, double *W,
                    double *S, double *Q);

#endif
