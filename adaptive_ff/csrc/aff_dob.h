/* aff_dob.h -- the disturbance observer with a binomial Q-filter (peer "dob" of the comparison).
 *
 * Plant J*dw/dt = u - d (d: friction and load). With the torque u(k-1) held over
 * the last period, the raw disturbance sample is
 *   v(k) = u(k-1) - J_n*(w(k) - w(k-1))/Tc
 * (the mean of d over the last period when J_n = J), and d_hat = Q[v], Q the
 * binomial low-pass 1/(1 + s/omega_q)^order realised as order cascaded
 * first-order lags x += a*(input - x), a = 1 - exp(-Tc*omega_q) (unit gain at
 * zero frequency), d_hat clipped to +-d_max; the loop adds d_hat to its command.
 * Non-finite or out-of-range velocities and torques are refused by two range
 * gates (aff_range_gate) and counted. Sources: K. Ohnishi, M. Shibata,
 * T. Murakami, "Motion control for advanced mechatronics", IEEE/ASME Trans.
 * Mechatronics 1(1), 1996; the discrete binomial design of Umeno & Hori,
 * "Robust speed control of DC servomotors using modern two degrees-of-freedom
 * controller design", IEEE Trans. Ind. Electron. 38(5), 1991.
 * Python: controllers.peers.dob.DisturbanceObserver.
 */
#ifndef AFF_DOB_H
#define AFF_DOB_H
#include "aff_real.h"
#include "aff_gate.h"
#include "aff_compensator.h"
#include "aff_supervisor.h"
#include "aff_error.h"

/* Highest order of the binomial Q-filter (the Python wrapper refuses more with a ParameterError). */
#define AFF_DOB_ORDER_MAX 8

/* The observer's settings (Python: DisturbanceObserver's arguments of the same names). */
typedef struct aff_dob_config {
    aff_real Tc;                    /* controller period (s), finite, > 0; default 0.001 */
    aff_real J_n;                   /* nominal inertia (kg*m^2), finite, > 0: set it (the design inertia); default 0 */
    aff_real omega_q;               /* Q-filter cut-off (rad/s), finite, > 0; default 500 */
    long order;                     /* order of the binomial Q-filter, 1..AFF_DOB_ORDER_MAX; default 2 */
    aff_real d_max;                 /* bound on |d_hat| (N*m), >= 0; INFINITY (default): none */
    aff_range_gate_config u_range;  /* range gate of the torque samples (N*m); default: aff_range_gate_default_config */
    aff_range_gate_config w_range;  /* range gate of the velocity samples (rad/s); the same default */
} aff_dob_config;

/* Configuration, then state. */
typedef struct aff_dob {
    aff_real Tc;                    /* controller period (s), > 0 */
    aff_real J_n;                   /* nominal inertia (kg*m^2), > 0 */
    aff_real omega_q;               /* Q-filter cut-off (rad/s), > 0 */
    long order;                     /* order of the binomial Q-filter, 1..AFF_DOB_ORDER_MAX */
    aff_real a;                     /* smoothing factor of each lag, 1 - exp(-Tc*omega_q) */
    aff_real d_max;                 /* bound on |d_hat| (N*m), INFINITY = none */
    aff_range_gate u_range;         /* range gate of the torque samples (N*m) */
    aff_range_gate w_range;         /* range gate of the velocity samples (rad/s) */
    aff_real d_hat;                 /* disturbance estimate (N*m) */
    aff_real u_last;                /* last accepted torque (N*m) */
    aff_real w_last;                /* last accepted velocity (rad/s; valid if has_w_last) */
    int has_w_last;                 /* 1 after the first accepted velocity */
    int64_t n_rejected;             /* refused velocity and torque samples */
    aff_real x[AFF_DOB_ORDER_MAX];  /* states of the cascaded lags (N*m), order valid */
} aff_dob;

/* The observer's defaults (DisturbanceObserver's: Tc 0.001 s, omega_q 500 rad/s, order 2, no bound, the default
 * range gates); J_n is 0: set it (the design inertia). */
aff_dob_config aff_dob_default_config(void);

/* Configure d from *cfg (a = 1 - exp(-Tc*omega_q), the range gates) and clear its state (d_hat, u_last, x = 0, no
 * velocity yet, counter 0). Returns AFF_OK, or AFF_ERR_NULL, AFF_ERR_DOB_TC, _J_N, _OMEGA_Q, _ORDER, _D_MAX or a
 * range gate's code (d untouched). Python: DisturbanceObserver.__init__. */
aff_error aff_dob_init(aff_dob *d, const aff_dob_config *cfg);

/* The checks of aff_dob_init alone: AFF_OK or the code it would return for *cfg. */
aff_error aff_dob_check_config(const aff_dob_config *cfg);

/* Compensator interface (aff_compensator.h), self a aff_dob: advance the observer with the controller's
 * velocity w_ctrl (rad/s) of this period and return the bounded d_hat (N*m). A w_ctrl refused by w_range is
 * counted and d_hat held; the first accepted one only starts the difference. w_meas, w_ref unused. */
aff_real aff_dob_compensate(void *self, aff_real w_ctrl, aff_real w_meas, aff_real w_ref);

/* Compensator interface: record the torque u (N*m) applied in this period (it drives the next velocity
 * sample); a u refused by u_range is counted and the last one kept. w_meas, theta_out unused; returns 0
 * (no parameter vector). */
int aff_dob_observe(void *self, aff_real u, aff_real w_meas, aff_real *theta_out);

/* The ops table of aff_dob (name "dob"). */
extern const aff_compensator_ops aff_dob_ops;

#endif
