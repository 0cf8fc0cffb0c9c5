/* aff_online_ukf.h -- the process model of the online UKF: eqs. 1-2 with eq. 3 over one sample, input held.
 *
 * n classic RK4 steps of h (the plant's one step, plant_rk4 of plant_dynamics.h, with plant_target), so the
 * filter predicts with the arithmetic of the simulated joint. Any sign of Fc, Fs, sigma is allowed (sigma
 * points may leave the physical set). Python: adaptive_ff.identification.online_ukf.OnlineUKF (process model).
 */
#ifndef AFF_ONLINE_UKF_H
#define AFF_ONLINE_UKF_H
#include "plant_dynamics.h"

/* Advance (*w, *f) (rad/s, N*m) in place by n >= 0 RK4 steps of h (s, > 0) of the plant p (the lagged
 * Stribeck joint of plant.dynamics.lagged_params) with the torque u (N*m) held; the Karnopp direction 0.
 * n <= 0 leaves them unchanged. No checks: NaN/inf propagate. Source: Ruderman eqs. 1-3; classic RK4. */
void aff_ukf_propagate(const plant_params *p, double *w, double *f, double u, double h, long n);

#endif
