/* ctl_canudas.h -- adaptive Coulomb + viscous friction compensation (peer "canudas" of the comparison).
 *
 * C. Canudas de Wit, K. J. Astrom, K. Braun, "Adaptive friction compensation in DC-motor drives", IEEE J.
 * Robotics and Automation 3(6), 1987, pp. 681-685 (Ruderman's ref. [1]): direction-dependent Coulomb and
 * viscous friction, estimated by RLS from the sampled motor model over an estimator period Ts = m*Tc
 * (Euler, torque averaged over the period),
 *   w(k+1) - w(k) = b*u_bar(k) - b*sigma_d*w(k) - b*Fc_d*sgn(w(k)),   b = Ts/J,
 * d the direction of w(k): regressor phi = (u_bar, -w*1(w>0), -w*1(w<0), -1(w>0), +1(w<0)), output
 * w(k+1) - w(k), theta = (b, b*sigma_pos, b*sigma_neg, b*Fc_pos, b*Fc_neg); an interval is used only when
 * both velocities lie beyond +-w_dead with one sign. Compensation u_c = Fc_d*sgn(w) + sigma_d*w at the
 * measured (or reference) velocity, clipped to +-ff_max, after warmup RLS updates (eq. 2 of the paper).
 * The RLS (aff_rls, directional or exponential forgetting, theta projected onto b >= 1e-12, the other
 * entries >= 0) and two range gates (aff_range_gate) of the torque and velocity samples are embedded.
 * Python: controllers.peers.canudas.CanudasCompensator.
 */
#ifndef CTL_CANUDAS_H
#define CTL_CANUDAS_H
#include "aff_real.h"
#include "aff_gate.h"
#include "aff_rls.h"
#include "aff_compensator.h"

/* Configuration, then state. */
typedef struct ctl_canudas {
    aff_real Tc;              /* controller period (s) */
    aff_real Ts;              /* estimator period m*Tc (s) */
    long m;                   /* controller periods per estimator period, >= 1 */
    aff_real w_dead;          /* estimation dead zone (rad/s), >= 0 */
    long warmup;              /* RLS updates before the compensation switches on, >= 0 */
    aff_real ff_max;          /* bound on |compensation| (N*m), INFINITY = none */
    int ff_measured;          /* 1: compensate at the controller's velocity w_ctrl; 0: at the reference */
    aff_range_gate u_range;   /* range gate of the torque samples (N*m) */
    aff_range_gate w_range;   /* range gate of the velocity samples (rad/s) */
    aff_rls rls;              /* theta = (b, b*sigma_pos, b*sigma_neg, b*Fc_pos, b*Fc_neg), b = Ts/J */
    int on;                   /* 1 once the coefficients below are in use */
    aff_real Fc_pos;          /* Coulomb level, positive direction (N*m) */
    aff_real Fc_neg;          /* Coulomb level, negative direction (N*m, as a magnitude) */
    aff_real sigma_pos;       /* viscous coefficient, positive direction (N*m*s/rad) */
    aff_real sigma_neg;       /* viscous coefficient, negative direction (N*m*s/rad) */
    long k;                   /* accepted samples (observe calls that passed both gates) */
    aff_real u_sum;           /* torque sum over the current interval (N*m) */
    aff_real w_prev;          /* velocity at the start of the current interval (rad/s; valid if has_prev) */
    int has_prev;             /* 1 once an interval was started */
    int ok;                   /* 0 once a refused sample spoiled the current interval */
    long n_rejected;          /* refused samples and refused RLS rows */
    long phase;               /* k mod m */
} ctl_canudas;

/* The settings of a ctl_canudas, with their defaults (ctl_canudas_default_config) and ranges
 * (ctl_canudas_check_config). Python: controllers.peers.canudas.CanudasCompensatorConfig. */
typedef struct ctl_canudas_config {
    aff_real Tc;              /* controller period (s), finite, > 0; default 0.001 */
    aff_real Ts;              /* estimator period (s), finite, > 0, a multiple of Tc; default 0.01 */
    int forgetting;           /* the RLS's scheme: AFF_RLS_DIRECTIONAL (default) or AFF_RLS_EXPONENTIAL */
    aff_real lam;             /* forgetting factor per RLS update (-), in (0, 1]; default 0.999 */
    aff_real P0;              /* initial covariance scale, finite, > 0; default 1e4 */
    aff_real J_guess;         /* initial inertia of theta0 (kg*m^2), finite, > 0; default 1 */
    aff_real w_dead;          /* estimation dead zone (rad/s), finite, >= 0; default 5e-3 */
    long warmup;              /* RLS updates before the compensation switches on, >= 0; default 300 */
    aff_real ff_max;          /* bound on |compensation| (N*m), >= 0; INFINITY (default): none */
    int ff_measured;          /* 1 (default): compensate at the controller's velocity; 0: at the reference */
} ctl_canudas_config;

/* The defaults of ctl_canudas_config (field comments). */
ctl_canudas_config ctl_canudas_default_config(void);

/* AFF_OK, or the code (aff_error.h, AFF_ERR_CANUDAS_*) of the first field of *cfg out of its range. */
aff_error ctl_canudas_check_config(const ctl_canudas_config *cfg);

/* Configure c and clear its state: Ts = m*Tc; the RLS with 5 parameters, scheme (AFF_RLS_DIRECTIONAL or
 * AFF_RLS_EXPONENTIAL), lam, P = P0*I, P_max = trace(P), theta = (Ts/J_guess, 0, 0, 0, 0), bounds
 * [1e-12, inf) x [0, inf)^4; the gates with the defaults of RangeGate() and RangeGate(floor=w_dead);
 * not on, no interval started, counters 0. Returns 0, or -1 (c untouched) for m < 1, a w_dead the gate refuses
 * (aff_range_gate_init) or an RLS setting out of range (aff_rls_init). */
int ctl_canudas_init(ctl_canudas *c, aff_real Tc, long m, aff_real w_dead, long warmup, aff_real ff_max,
                     int ff_measured, int scheme, aff_real lam, aff_real P0, aff_real J_guess);

/* Compensator interface (aff_compensator.h), self a ctl_canudas: the compensation torque (N*m) of this
 * period, Fc_pos + sigma_pos*w (w > 0), -Fc_neg + sigma_neg*w (w < 0), 0 at w = 0, clipped to +-ff_max, at
 * w = w_ctrl (ff_measured) or w_ref (rad/s); 0 before switch-on, for a non-finite w or where the map
 * overflows. w_meas unused. */
aff_real ctl_canudas_compensate(void *self, aff_real w_ctrl, aff_real w_meas, aff_real w_ref);

/* Compensator interface: record the torque u (N*m) applied in this period and the velocity w_meas (rad/s)
 * measured at its start. Every m-th accepted call closes an interval: the row of its mean torque and end
 * velocities updates the RLS (a refused row, e.g. an overflowing torque sum, is counted), and after warmup
 * updates the coefficients follow theta. A sample refused by a range gate is counted (in the failing
 * gate(s) and n_rejected) and spoils the current interval. Returns 1 after an RLS update, then writes theta
 * (5 entries) into theta_out (if not NULL); else 0. */
int ctl_canudas_observe(void *self, aff_real u, aff_real w_meas, aff_real *theta_out);

/* The ops table of ctl_canudas (name "canudas"). */
extern const aff_compensator_ops ctl_canudas_ops;

#endif
