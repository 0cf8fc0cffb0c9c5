/* aff_simulator.h -- the joint (eqs. 1-3) simulated on measured, possibly irregular, sample times.
 *
 * Between the sample instants the grid holds equal sub-steps (adaptive_ff.identification.simulator.input_grid);
 * each sub-step is one plant_rk4 step (the plant's one RK4, plant_dynamics.h) with the input linear over it
 * (first-order hold: u at the start, the mean in the middle, u at the end). A constant torque offset enters as
 * u - offset and f - offset. Optional output injection after each sample (Ljung, System Identification, 2nd ed.,
 * Secs. 3.2, 5.7): with e = w_meas - w, w += Kw*e and f -= Kf*J/h_i*e (h_i the sample interval).
 * Python: adaptive_ff.identification.simulator.simulate_on_grid and simulate_on_grid_batch (several parameter
 * sets in one pass; the inner loop of the output-error fits of adaptive_ff.identification.physical_id).
 */
#ifndef AFF_SIMULATOR_H
#define AFF_SIMULATOR_H
#include "plant_dynamics.h"

/* Velocity (rad/s) of the plant p at the n sample instants into out[0..n-1], out[0] = w0.
 * tg, ug: grid times (s) and input (N*m), idx[n-1] + 1 entries; idx: grid position of each sample (n entries,
 * idx[0] = 0, increasing); offset (N*m); w0 (rad/s), f0 (N*m): state at tg[0]; Kw (1), Kf (1): injection
 * gains, used where inject != 0 with the measured velocity w_meas (n entries; not read when inject == 0, may
 * then be any array of n doubles). Needs p->J > 0, tau > 0 (RK4 stable for tau above about 0.4 times the
 * sub-step). A non-finite state after a sample makes out NaN from that sample on (no error). No checks.
 * Source: Ruderman eqs. 1-3; classic RK4 (plant_rk4). */
void aff_simulate_on_grid(const plant_params *p, const double *tg, const double *ug, const long *idx, long n,
                          double offset, double w0, double f0, double Kw, double Kf, const double *w_meas,
                          int inject, double *out);

/* Largest number of simulations of one aff_simulate_on_grid_batch call (16; Python:
 * adaptive_ff.identification.simulator.BATCH_MAX, read from aff_sim_batch_max). */
#define AFF_SIM_BATCH_MAX 16
extern const long aff_sim_batch_max;

/* K simulations of aff_simulate_on_grid on the same grid, input, initial state and injection, one per plant p[k]
 * and offset offset[k] (k < K, 1 <= K <= AFF_SIM_BATCH_MAX; else nothing is written): out[k*n + s] is
 * simulation k's velocity at sample s (K*n entries), each the same numbers as aff_simulate_on_grid's (the same
 * operations in the same order; the simulations advance side by side, sub-step by sub-step, so that the CPU
 * overlaps their independent dependency chains: about 15 % less CPU time per simulation than one at a time
 * for K = 6, the median of 15 paired timings on a 20 001-sample grid). A simulation whose state turns non-finite is NaN from that sample
 * on and is not advanced further. aff_simulate_on_grid is this with K = 1. Used for the finite-difference
 * Jacobians and the grid searches of the output-error fits (each needs several simulations at once). No checks.
 * Source: as aff_simulate_on_grid. */
void aff_simulate_on_grid_batch(const plant_params *p, const double *offset, long K, const double *tg,
                                const double *ug, const long *idx, long n, double w0, double f0, double Kw,
                                double Kf, const double *w_meas, int inject, double *out);

/* Positions of the parameters in the sensitivities of aff_simulate_on_grid_sens (AFF_SENS_NP of them). */
#define AFF_SENS_NP 8
#define AFF_SENS_J 0
#define AFF_SENS_FC 1
#define AFF_SENS_FS 2
#define AFF_SENS_SIGMA 3
#define AFF_SENS_TAU 4
#define AFF_SENS_OFFSET 5
#define AFF_SENS_VS 6
#define AFF_SENS_DELTA 7

/* aff_simulate_on_grid (the same out, the same operations on w and f) with the forward sensitivities of the
 * discrete simulation: dout[s*AFF_SENS_NP + j] = d out[s] / d theta_j for theta = (J, Fc, Fs, sigma, tau, offset,
 * Vs, delta) (SI units; n*AFF_SENS_NP entries, row s = sample s, row 0 zero). The tangent of each RK4 stage is
 * propagated with the stage (the variational equations of the discretised model, not of the ODE: the exact
 * Jacobian of out, for a Gauss-Newton or trust-region fit). Eq. 3's derivatives are those of the discrete map:
 * zero at w == 0 and for the Stribeck term past its cut-off speed (plant_stribeck.h); delta: d/d delta of
 * exp(-(|w|/Vs)^delta). Output injection: w += Kw*e, f -= Kf*J/h_i*e differentiated alike. A non-finite state
 * makes out and dout NaN from that sample on. Needs p lagged (PLANT_LAGGED_STRIBECK, no Karnopp band, no
 * ripple), J > 0, tau > 0. No checks. Source: Ruderman eqs. 1-3; forward sensitivity analysis of a one-step
 * method (Hairer, Norsett, Wanner, Solving ODEs I, Sec. II.1 and I.14: the derivative of the numerical solution
 * with respect to parameters is the numerical solution of the variational equation by the same RK method). */
void aff_simulate_on_grid_sens(const plant_params *p, const double *tg, const double *ug, const long *idx, long n,
                               double offset, double w0, double f0, double Kw, double Kf, const double *w_meas,
                               int inject, double *out, double *dout);

#endif
