/* aff_compensator.h -- the interface every friction compensator offers a velocity loop.
 *
 * Per controller period, in this order (docs/your_loop.md):
 *   uff = ops->compensate(self, w_ctrl, w_meas, w_ref);   friction torque to add (N*m)
 *   u   = the loop's PI(w_ref - w_ctrl, uff);             the applied, saturated torque
 *   ops->observe(self, u, w_meas, theta_out);              learn from (u, w_meas)
 * w_ctrl: the measurement the controller uses (after the loop's sensor gate; rad/s), w_meas: the raw
 * sensor sample (rad/s, may be NaN or a spike: the compensator gates it itself), w_ref: the velocity
 * reference (rad/s). observe returns 1 after an update of the estimate and then writes the estimate
 * (the compensator's own parameter vector, its length known to the caller) into theta_out (may be
 * NULL), else 0. The values are aff_real (aff_real.h): double in the package, float in a drive's float build.
 * With the feedforward supervisor's rest rule (aff_supervisor.h) the loop applies none of the output while the
 * reference is at rest (it withdraws the last applied torque through the compensator's lag in use,
 * ops->rest_lag(self) before each apply: alpha = 1 - exp(-Tc/tau), NULL: at once); it then calls ops->at_rest(self)
 * between compensate and observe (NULL: nothing to do), so that a compensator whose observe assumes its output was
 * applied can correct that (ctl_adob).
 * A compensator that carries its own supervisor (aff_adaptive) reports the supervisor's bumpless transfer through
 * ops->transfer(self) after compensate: the torque the loop adds to its PI's integrator in this period (NULL: none).
 * The closed-loop engine (controllers/csrc/ctl_engine.h) holds a (self, ops) pair per scenario;
 * each compensator's header declares its const ops table (aff_fixed_ff_ops, aff_robust_ff_ops,
 * aff_eq4_ff_ops, aff_adaptive_ops; the peers ctl_canudas_ops, aff_dob_ops, ctl_adob_ops).
 */
#ifndef AFF_COMPENSATOR_H
#define AFF_COMPENSATOR_H
#include "aff_real.h"

typedef struct aff_compensator_ops {
    const char *name;  /* the mode's name, e.g. "adaptive" */
    aff_real (*compensate)(void *self, aff_real w_ctrl, aff_real w_meas, aff_real w_ref);
    int (*observe)(void *self, aff_real u, aff_real w_meas, aff_real *theta_out);
    void (*at_rest)(void *self);  /* optional (NULL: none): this period's output was withheld at rest */
    aff_real (*transfer)(void *self); /* optional (NULL: none): this period's bumpless transfer into the PI (N*m) */
    aff_real (*rest_lag)(void *self); /* optional (NULL: none): the gain 1 - exp(-Tc/tau) of its lag in use */
} aff_compensator_ops;

#endif
