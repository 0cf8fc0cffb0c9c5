/* ctl_adob.h -- the adaptive friction feedforward plus a disturbance observer on the residual (mode
 * "adaptive-dob"): ctl_adob over the sliding estimator's aff_robust_ff, ctl_eq4_dob over the paper's eq. 4
 * feedforward aff_eq4_ff (estimator "eq4" or "eq4-rls"). Both compose their parts through aff_residual
 * (adaptive_ff/csrc/aff_residual.h: the observer, the switch-in, the bound; its header derives the composite). Per
 * period: u_ff from the feedforward, then aff_residual_compensate; observe: aff_residual_observe, then the
 * feedforward. Python: controllers.peers.adaptive_dob.AdaptiveDOBCompensator.
 */
#ifndef CTL_ADOB_H
#define CTL_ADOB_H
#include "aff_real.h"
#include "aff_compensator.h"
#include "aff_robust_ff.h"
#include "aff_eq4_ff.h"
#include "aff_residual.h"

/* The composite over the sliding estimator's robust feedforward. */
typedef struct ctl_adob {
    aff_residual res;     /* the observer, the switch-in, the bound */
    aff_robust_ff ff;     /* the adaptive feedforward with its estimator */
} ctl_adob;

/* The same composite over the paper's eq. 4 feedforward (estimators "eq4", "eq4-rls"). */
typedef struct ctl_eq4_dob {
    aff_residual res;     /* the observer, the switch-in, the bound */
    aff_eq4_ff ff;        /* the eq. 4 adaptive feedforward with its estimator (RLS or IV) */
} ctl_eq4_dob;

/* Configure a from the configured feedforward ff (aff_robust_ff_init), copied by value, and the residual part's
 * settings res (aff_residual_init on a->res: the observer, the bound, the switch-in). Returns AFF_OK, or
 * aff_residual_init's code (a untouched). */
aff_error ctl_adob_init(ctl_adob *a, const aff_robust_ff *ff, const aff_residual_config *res);

/* Compensator interface (aff_compensator.h), self a ctl_adob: u_ff = aff_robust_ff_compensate (w_ctrl, w_meas,
 * w_ref in rad/s), then aff_residual_compensate (acting: the feedforward's own estimate in use; started: its
 * provisional start map in use). */
aff_real ctl_adob_compensate(void *self, aff_real w_ctrl, aff_real w_meas, aff_real w_ref);

/* Compensator interface: aff_residual_observe, then the feedforward observes (u, w_meas); returns
 * aff_robust_ff_observe's result (1 after an RLS update of the estimator, theta then written into
 * theta_out[0..p-1] if not NULL). */
int ctl_adob_observe(void *self, aff_real u, aff_real w_meas, aff_real *theta_out);

/* Compensator interface: aff_residual_at_rest on a->res. */
void ctl_adob_at_rest(void *self);

/* Compensator interface (optional rest_lag): aff_robust_ff_rest_lag of a->ff. */
aff_real ctl_adob_rest_lag(void *self);

/* The ops table of ctl_adob (name "adaptive-dob"). */
extern const aff_compensator_ops ctl_adob_ops;

/* Configure a from the configured feedforward ff (aff_eq4_ff_init), copied by value, and the residual part's settings
 * res (aff_residual_init on a->res). Returns AFF_OK, or aff_residual_init's code (a untouched). */
aff_error ctl_eq4_dob_init(ctl_eq4_dob *a, const aff_eq4_ff *ff, const aff_residual_config *res);

/* Compensator interface, self a ctl_eq4_dob: u_ff = aff_eq4_ff_compensate, then aff_residual_compensate (acting:
 * the feedforward has an estimate in use; started: its provisional start map). */
aff_real ctl_eq4_dob_compensate(void *self, aff_real w_ctrl, aff_real w_meas, aff_real w_ref);

/* Compensator interface: aff_residual_observe, then the feedforward observes (u, w_meas); returns
 * aff_eq4_ff_observe's result (1 in a period that took a sample, theta then written into theta_out[0..p-1] if
 * not NULL). */
int ctl_eq4_dob_observe(void *self, aff_real u, aff_real w_meas, aff_real *theta_out);

/* Compensator interface: aff_residual_at_rest on a->res. */
void ctl_eq4_dob_at_rest(void *self);

/* The ops table of ctl_eq4_dob (name "adaptive-dob"). */
extern const aff_compensator_ops ctl_eq4_dob_ops;

#endif
