/* aff_eq4_ff.c -- the eq. 4 adaptive feedforward (see aff_eq4_ff.h). */
#include <math.h>
#include <string.h>
#include "aff_eq4_ff.h"

int aff_eq4_ff_init(aff_eq4_ff *e, const aff_fixed_ff *ff, long m, aff_real Ts, long warmup, aff_real tau_max,
                    aff_real F_max, aff_real Vs, aff_real delta, int lag, int stribeck, int offset,
                    const aff_range_gate *u_range, const aff_range_gate *w_range, const aff_rls *rls, int iv,
                    aff_real w_band, const aff_ivrls *ivrls)
{
    long p = 3 + 2 * (lag != 0) + (stribeck != 0) + (offset != 0);
    if (rls->p != p || (iv && (ivrls == NULL || ivrls->p != p)))
        return -1;
    memset(e, 0, sizeof *e);
    e->ff = *ff;
    e->m = m;
    e->Ts = Ts;
    e->warmup = warmup;
    e->tau_max = tau_max;
    e->F_max = F_max;
    e->Vs = Vs;
    e->delta = delta;
    e->lag = lag != 0;
    e->stribeck = stribeck != 0;
    e->offset = offset != 0;
    e->u_range = *u_range;
    e->w_range = *w_range;
    e->rls = *rls;
    e->iv = iv != 0;
    e->w_band = w_band;
    if (ivrls != NULL)
        e->ivrls = *ivrls;
    e->due = m;
    e->start_gain = 1;
    return 0;
}

int aff_eq4_ff_start(aff_eq4_ff *e, aff_real Fc, aff_real Fs, aff_real Vs, aff_real delta, aff_real sigma,
                     aff_real tau, aff_real gain, int at_ref)
{
    if (!(isfinite(Fc) && Fc >= 0 && isfinite(Fs) && Fs >= 0 && isfinite(sigma) && sigma >= 0 && isfinite(tau)
          && tau >= 0 && aff_positive(Vs) && isfinite(delta) && gain > 0 && gain <= 1))
        return -1;
    aff_fixed_ff_set_estimate(&e->ff, Fc, Fs, Vs, delta, sigma, tau, 1);
    e->provisional = 1;
    e->start_at_ref = at_ref != 0;
    e->start_gain = gain;
    return 0;
}

/* Map theta to physical parameters, project, and put an admissible estimate into use (else count it). */
static void use_estimate(aff_eq4_ff *e)
{
    aff_physical x;
    aff_eq4_to_physical(e->iv ? e->ivrls.theta : e->rls.theta, e->Ts, e->lag, e->stribeck, e->offset, &x);
    if (!aff_project_levels(&x, e->tau_max, e->F_max)) {
        e->n_implausible++;
        return;
    }
    aff_fixed_ff_set_estimate(&e->ff, x.Fc, x.Fs, e->Vs, e->delta, x.sigma, x.tau, e->stribeck);
    e->has_estimate = 1;
    e->provisional = 0; /* the estimate replaces the start map */
    e->est = x;
}

/* 1 if the sliding-regime gate keeps sample (w, w1, w2) from the estimator: one of them within w_band of zero, or
 * a sign change among them. */
static int eq4_in_stick(const aff_eq4_ff *e, aff_real w)
{
    aff_real b = e->w_band;
    if (!(b > 0))
        return 0;
    if (!(AFF_FABS(w) > b && AFF_FABS(e->w1) > b && AFF_FABS(e->w2) > b))
        return 1;
    return (w > 0) != (e->w1 > 0) || (w > 0) != (e->w2 > 0);
}

int aff_eq4_ff_sample(aff_eq4_ff *e, aff_real u, aff_real w)
{
    int uok = aff_range_gate_ok(&e->u_range, u);
    int wok = aff_range_gate_ok(&e->w_range, w);
    int updated = 0, refused = 0;
    long n0;
    if (!(uok && wok)) {
        if (!uok)
            aff_range_gate_commit(&e->u_range, u, 0);
        if (!wok)
            aff_range_gate_commit(&e->w_range, w, 0);
        e->n_rejected++;
        return 0;
    }
    if (!e->has_past) {
        aff_range_gate_commit(&e->u_range, u, 1);
        aff_range_gate_commit(&e->w_range, w, 1);
        e->u1 = u;
        e->w1 = w;
        e->w2 = w;
        e->has_past = 1;
        e->n_past = 1;
        return 1;
    }
    if (eq4_in_stick(e, w)) {
        e->n_gated++;
    } else if (!e->iv) {
        aff_eq4_phi(e->phi, u, e->u1, e->w1, e->w2, e->Vs, e->delta, e->lag, e->stribeck, e->offset);
        n0 = e->rls.n_updates;
        aff_rls_update(&e->rls, e->phi, w);
        if (e->rls.n_updates == n0) { /* non-finite regressor or an update that would overflow: refused */
            e->n_rejected++;
            return 0;
        }
        updated = 1;
    } else if (e->n_past >= 4) { /* the instruments need u(k-3), w(k-4) */
        aff_eq4_phi(e->phi, u, e->u1, e->w1, e->w2, e->Vs, e->delta, e->lag, e->stribeck, e->offset);
        aff_eq4_phi(e->z, u, e->u1, e->w3, e->w4, e->Vs, e->delta, e->lag, e->stribeck, e->offset);
        n0 = e->ivrls.n_updates;
        aff_ivrls_update(&e->ivrls, e->phi, e->z, w);
        if (e->ivrls.n_updates == n0) /* guard, s <= 0 or overflow: the sample still enters the past */
            e->n_rejected++;
        else
            updated = 1;
        refused = !updated;
    }
    aff_range_gate_commit(&e->u_range, u, 1);
    aff_range_gate_commit(&e->w_range, w, 1);
    e->w4 = e->w3;
    e->w3 = e->w2;
    e->w2 = e->w1;
    e->w1 = w;
    e->u3 = e->u2;
    e->u2 = e->u1;
    e->u1 = u;
    if (e->n_past < 5)
        e->n_past++;
    if (updated && (e->iv ? e->ivrls.n_updates : e->rls.n_updates) >= e->warmup)
        use_estimate(e);
    return !refused;
}

double aff_eq4_ff_compensate(void *self, double w_ctrl, double w_meas, double w_ref)
{
    aff_eq4_ff *e = (aff_eq4_ff *)self;
    if (e->due == 0) { /* period k > 0 with k % m == 0 (a countdown: no integer division per period) */
        /* with iv the torque of the sample is the mean over the m periods since the previous one */
        aff_eq4_ff_sample(e, e->iv ? e->u_sum / (aff_real)e->m : e->u_prev, (aff_real)w_meas);
        e->u_sum = 0;
        e->sampled = 1;
        e->due = e->m;
    } else {
        e->sampled = 0;
    }
    e->due--;
    if (e->provisional) {
        aff_fixed_ff *f = &e->ff;
        aff_real w_stuck = aff_loop_model_step(&f->lm, (aff_real)w_ctrl, (aff_real)w_ref);
        f->u_out = aff_fixed_ff_start_output(f, (aff_real)w_ctrl, w_stuck, (aff_real)w_ref, e->start_at_ref,
                                             e->start_gain);
        return f->u_out;
    }
    return aff_fixed_ff_compensate(&e->ff, w_ctrl, w_meas, w_ref);
}

int aff_eq4_ff_observe(void *self, double u, double w_meas, double *theta_out)
{
    aff_eq4_ff *e = (aff_eq4_ff *)self;
    long i;
    aff_fixed_ff_observe(&e->ff, u, w_meas, NULL); /* the feedforward's sign observer, if it has one */
    e->u_prev = (aff_real)u;
    e->u_sum += (aff_real)u;
    if (!e->sampled)
        return 0;
    if (theta_out)
        for (i = 0; i < e->rls.p; i++)
            theta_out[i] = e->iv ? e->ivrls.theta[i] : e->rls.theta[i];
    return 1;
}

const aff_compensator_ops aff_eq4_ff_ops = {"adaptive", aff_eq4_ff_compensate, aff_eq4_ff_observe, NULL};
