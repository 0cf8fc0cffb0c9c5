/* aff_eq4_ff.c -- the eq. 4 adaptive feedforward (see aff_eq4_ff.h). */
#include <string.h>
#include "aff_eq4_ff.h"

int aff_eq4_ff_init(aff_eq4_ff *e, const aff_fixed_ff *ff, long m, aff_real Ts, long warmup, aff_real tau_max,
                    aff_real F_max, aff_real Vs, aff_real delta, int lag, int stribeck, int offset,
                    const aff_range_gate *u_range, const aff_range_gate *w_range, const aff_rls *rls)
{
    if (rls->p != 3 + 2 * (lag != 0) + (stribeck != 0) + (offset != 0))
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
    e->due = m;
    return 0;
}

/* Map theta to physical parameters, project, and put an admissible estimate into use (else count it). */
static void use_estimate(aff_eq4_ff *e)
{
    aff_physical x;
    aff_eq4_to_physical(e->rls.theta, e->Ts, e->lag, e->stribeck, e->offset, &x);
    if (!aff_project_levels(&x, e->tau_max, e->F_max)) {
        e->n_implausible++;
        return;
    }
    aff_fixed_ff_set_estimate(&e->ff, x.Fc, x.Fs, e->Vs, e->delta, x.sigma, x.tau, e->stribeck);
    e->has_estimate = 1;
    e->est = x;
}

int aff_eq4_ff_sample(aff_eq4_ff *e, aff_real u, aff_real w)
{
    int uok = aff_range_gate_ok(&e->u_range, u);
    int wok = aff_range_gate_ok(&e->w_range, w);
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
        return 1;
    }
    aff_eq4_phi(e->phi, u, e->u1, e->w1, e->w2, e->Vs, e->delta, e->lag, e->stribeck, e->offset);
    n0 = e->rls.n_updates;
    aff_rls_update(&e->rls, e->phi, w);
    if (e->rls.n_updates == n0) { /* non-finite regressor or an update that would overflow: refused */
        e->n_rejected++;
        return 0;
    }
    aff_range_gate_commit(&e->u_range, u, 1);
    aff_range_gate_commit(&e->w_range, w, 1);
    e->w2 = e->w1;
    e->w1 = w;
    e->u1 = u;
    if (e->rls.n_updates >= e->warmup)
        use_estimate(e);
    return 1;
}

double aff_eq4_ff_compensate(void *self, double w_ctrl, double w_meas, double w_ref)
{
    aff_eq4_ff *e = (aff_eq4_ff *)self;
    if (e->due == 0) { /* period k > 0 with k % m == 0 (a countdown: no integer division per period) */
        aff_eq4_ff_sample(e, e->u_prev, (aff_real)w_meas);
        e->sampled = 1;
        e->due = e->m;
    } else {
        e->sampled = 0;
    }
    e->due--;
    return aff_fixed_ff_compensate(&e->ff, w_ctrl, w_meas, w_ref);
}

int aff_eq4_ff_observe(void *self, double u, double w_meas, double *theta_out)
{
    aff_eq4_ff *e = (aff_eq4_ff *)self;
    long i;
    (void)w_meas;
    e->u_prev = (aff_real)u;
    if (!e->sampled)
        return 0;
    if (theta_out)
        for (i = 0; i < e->rls.p; i++)
            theta_out[i] = e->rls.theta[i];
    return 1;
}

const aff_compensator_ops aff_eq4_ff_ops = {"adaptive", aff_eq4_ff_compensate, aff_eq4_ff_observe};
