/* aff_eq4_ff.c -- the eq. 4 adaptive feedforward (see aff_eq4_ff.h). */
#include <math.h>
#include <stddef.h>
#include <string.h>
#include "aff_eq4_ff.h"
#include "plant_stribeck.h"

aff_eq4_ff_config aff_eq4_ff_default_config(void)
{
    aff_eq4_ff_config c;
    c.Ts = 0.01;
    c.lam = 0.995;
    c.P0 = 1e4;
    c.warmup = 300;
    c.tau_max = 1;
    c.iv = 0;
    c.w_band = 0;
    c.map_rel_stderr = INFINITY;
    c.ff = aff_fixed_ff_default_config();
    return c;
}

aff_error aff_eq4_ff_check_config(const aff_eq4_ff_config *cfg)
{
    if (cfg == NULL)
        return AFF_ERR_NULL;
    if (!aff_positive(cfg->Ts))
        return AFF_ERR_EQ4_FF_TS;
    if (!(cfg->lam > 0 && cfg->lam <= 1))
        return AFF_ERR_EQ4_FF_LAM;
    if (!aff_positive(cfg->P0))
        return AFF_ERR_EQ4_FF_P0;
    if (cfg->warmup < 0)
        return AFF_ERR_EQ4_FF_WARMUP;
    if (!aff_positive(cfg->tau_max))
        return AFF_ERR_EQ4_FF_TAU_MAX;
    if (!aff_flag(cfg->iv))
        return AFF_ERR_EQ4_FF_IV;
    if (!aff_nonnegative(cfg->w_band))
        return AFF_ERR_EQ4_FF_W_BAND;
    if (!aff_positive_or_inf(cfg->map_rel_stderr) || (isfinite(cfg->map_rel_stderr) && !cfg->iv))
        return AFF_ERR_EQ4_FF_MAP_REL_STDERR;
    return aff_fixed_ff_check_config(&cfg->ff);
}

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
    e->map_rel_stderr = INFINITY;
    return 0;
}

int aff_eq4_ff_require_determined(aff_eq4_ff *e, aff_real map_rel_stderr)
{
    if (!(map_rel_stderr > 0))
        return -1;
    e->map_rel_stderr = map_rel_stderr;
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

/* The standard error of the IV estimate's static map at w > 0 (rad/s) is at most bound (N*m): the delta method on
 * the covariance e2*P*Szz*P' (aff_eq4_ff_require_determined), g'P Szz P'g = q'Szz q with q = P'g. The map in use,
 * eq. 3 of the projected levels x (plant_stribeck_eval; without the Stribeck term Fs = Fc, so dF = 0), first. */
static int map_sd_within(const aff_eq4_ff *e, const aff_physical *x, aff_real w, aff_real bound)
{
    const aff_ivrls *r = &e->ivrls;
    long p = r->p, i, j;
    aff_real g[AFF_RLS_NMAX], q[AFF_RLS_NMAX], var = 0;
    aff_real shape = e->stribeck ? plant_stribeck_shape(w, e->Vs, e->delta) : (aff_real)0.0;
    aff_real F = aff_eq4_static_gradient(r->theta, e->lag, e->stribeck, e->offset, w, shape, g);
    plant_stribeck m;
    m.Fc = x->Fc;
    m.dF = x->Fs - x->Fc;
    m.Vs = e->Vs;
    m.delta = e->delta;
    m.sigma = x->sigma;
    m.wcut = INFINITY;
    if (!(AFF_FABS(plant_stribeck_eval(&m, w) - F) <= bound)) /* the projection moved the map: not the estimate's */
        return 0;
    for (i = 0; i < p; i++) {
        aff_real acc = 0;
        for (j = 0; j < p; j++)
            acc += r->P[j * p + i] * g[j];
        q[i] = acc;
    }
    for (i = 0; i < p; i++)
        for (j = 0; j < p; j++)
            var += q[i] * e->Szz[i * p + j] * q[j];
    return AFF_SQRT(aff_max2(e->e2 * var, 0.0)) <= bound; /* NaN: not within */
}

/* The determinacy test of an estimate (aff_eq4_ff_require_determined) with the projected levels x. */
static int map_determined(const aff_eq4_ff *e, const aff_physical *x)
{
    aff_real bound;
    if (!(e->map_rel_stderr < INFINITY) || !e->iv)
        return 1;
    bound = e->map_rel_stderr * aff_max2(x->Fc, x->Fs);
    if (!(bound > 0) || !(e->w_max > 0) || !map_sd_within(e, x, e->w_max, bound)) /* no motion: nothing determined */
        return 0;
    return !(e->stribeck && e->Vs < e->w_max) || map_sd_within(e, x, e->Vs, bound);
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
    if (!map_determined(e, &x)) {
        e->n_undetermined++;
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

/* After an accepted IV update with the a-priori error err (rad/s) of the sample w(k): the moments of the
 * determinacy test, e2 (gain max(1 - lam, 1/n)), Szz (forgetting lam) and w_max. phi'P z of the update is phi'v
 * (v = P z before the update, aff_ivrls.h), >= 0 under the guard. */
static void track_moments(aff_eq4_ff *e, aff_real err, aff_real w)
{
    const aff_ivrls *r = &e->ivrls;
    long p = r->p, i, j;
    aff_real rr = 0, lam = r->lam, gain = (aff_real)1.0 / (aff_real)r->n_updates;
    for (i = 0; i < p; i++)
        rr += e->phi[i] * r->v[i];
    if (gain < (aff_real)1.0 - lam)
        gain = (aff_real)1.0 - lam;
    e->e2 += gain * (err * err / ((aff_real)1.0 + aff_max2(rr, 0.0)) - e->e2);
    for (i = 0; i < p; i++)
        for (j = 0; j < p; j++)
            e->Szz[i * p + j] = lam * e->Szz[i * p + j] + e->z[i] * e->z[j];
    if (AFF_FABS(w) > e->w_max)
        e->w_max = AFF_FABS(w);
}

int aff_eq4_ff_sample(aff_eq4_ff *e, aff_real u, aff_real w)
{
    int uok = aff_range_gate_ok(&e->u_range, u);
    int wok = aff_range_gate_ok(&e->w_range, w);
    int updated = 0, refused = 0;
    int64_t n0;
    aff_real err;
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
        err = aff_ivrls_update(&e->ivrls, e->phi, e->z, w);
        if (e->ivrls.n_updates == n0) { /* guard, s <= 0 or overflow: the sample still enters the past */
            e->n_rejected++;
        } else {
            updated = 1;
            if (e->map_rel_stderr < INFINITY)
                track_moments(e, err, w);
        }
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

aff_real aff_eq4_ff_compensate(void *self, aff_real w_ctrl, aff_real w_meas, aff_real w_ref)
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

int aff_eq4_ff_observe(void *self, aff_real u, aff_real w_meas, aff_real *theta_out)
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

const aff_compensator_ops aff_eq4_ff_ops = {"adaptive", aff_eq4_ff_compensate, aff_eq4_ff_observe, NULL, NULL, NULL};
