/* aff_simulator.c -- the joint on an irregular sample grid (see aff_simulator.h). */
#include "aff_simulator.h"

const long aff_sim_batch_max = AFF_SIM_BATCH_MAX;

/* The simulations inline the RK4 step and eq. 3 (plant_rk4, plant_target: one translation unit, the unity build
 * of _cbuild.py) where the compiler can: GCC and Clang's flatten. The operations and their order are those of the
 * calls (no contraction, no reassociation: plant/_cbuild.py's flags), so the numbers are the same; measured with
 * callgrind on a 20 001-sample grid, 8.5e6 instructions per simulation instead of 13.2e6. */
#if defined(__GNUC__)
#define AFF_SIM_FLATTEN __attribute__((flatten))
#else
#define AFF_SIM_FLATTEN
#endif

AFF_SIM_FLATTEN void aff_simulate_on_grid_batch(const plant_params *p, const double *offset, long K, const double *tg,
                                                const double *ug, const long *idx, long n, double w0, double f0,
                                                double Kw, double Kf, const double *w_meas, int inject, double *out)
{
    double w[AFF_SIM_BATCH_MAX], f[AFF_SIM_BATCH_MAX];
    int live[AFF_SIM_BATCH_MAX];
    long k;
    if (n <= 0 || K <= 0 || K > AFF_SIM_BATCH_MAX)
        return;
    for (k = 0; k < K; k++) {
        w[k] = w0;
        f[k] = f0 - offset[k];
        live[k] = 1;
        out[k * n] = w0;
    }
    for (long s = 1; s < n; s++) {
        long a = idx[s - 1];
        long b = idx[s];
        /* sub-step by sub-step, the K simulations side by side: independent chains the CPU overlaps */
        for (long j = a; j < b; j++) {
            for (k = 0; k < K; k++) {
                double u0, u1;
                if (!live[k])
                    continue;
                u0 = ug[j] - offset[k];
                u1 = ug[j + 1] - offset[k];
                plant_rk4(&p[k], &w[k], &f[k], plant_target(&p[k], w[k], 0.0), u0, 0.5 * (u0 + u1), u1,
                          tg[j + 1] - tg[j], 0.0);
            }
        }
        for (k = 0; k < K; k++) {
            double *o = out + k * n;
            if (!live[k])
                continue;
            if (!(isfinite(w[k]) && isfinite(f[k]))) {
                for (long r = s; r < n; r++)
                    o[r] = NAN;
                live[k] = 0;
                continue;
            }
            o[s] = w[k];
            if (inject) {
                double e = w_meas[s] - w[k];
                w[k] += Kw * e;
                f[k] -= Kf * p[k].J / (tg[b] - tg[a]) * e;
            }
        }
    }
}

void aff_simulate_on_grid(const plant_params *p, const double *tg, const double *ug, const long *idx, long n,
                          double offset, double w0, double f0, double Kw, double Kf, const double *w_meas,
                          int inject, double *out)
{
    aff_simulate_on_grid_batch(p, &offset, 1, tg, ug, idx, n, w0, f0, Kw, Kf, w_meas, inject, out);
}

/* F(w) of eq. 3 (plant_target, the one implementation) and its derivatives: *dw = dF/dw, dp[AFF_SENS_*] = dF/d
 * (Fc, Fs, sigma, Vs, delta) at the stored positions (J, tau, offset: 0). The discrete map's own derivative: 0 at
 * w == 0 (F(0) = 0), the Stribeck term's past the cut-off speed wcut (where the map drops it). */
static double target_derivs(const plant_params *p, double w, double *dw, double *dp)
{
    const plant_stribeck *m = w > 0.0 ? &p->pos : &p->neg;
    double F = plant_target(p, w, 0.0);
    double aw = fabs(w);
    double sg = w > 0.0 ? 1.0 : (w < 0.0 ? -1.0 : 0.0);
    double S = 0.0, x = 0.0, xd = 0.0;
    for (int j = 0; j < AFF_SENS_NP; j++)
        dp[j] = 0.0;
    if (sg == 0.0) {
        *dw = 0.0;
        return F;
    }
    if (aw <= m->wcut) {
        x = aw / m->Vs;
        xd = plant_stribeck_power(x, m->delta);
        S = exp(-xd);
    }
    dp[AFF_SENS_FC] = sg * (1.0 - S);
    dp[AFF_SENS_FS] = sg * S;
    dp[AFF_SENS_SIGMA] = w;
    *dw = m->sigma;
    if (S != 0.0 && x > 0.0) {
        *dw += -m->dF * S * m->delta * xd / x / m->Vs;       /* d/d|w| of dF*S, times sg*sg */
        dp[AFF_SENS_VS] = sg * m->dF * S * m->delta * xd / m->Vs;
        dp[AFF_SENS_DELTA] = -sg * m->dF * S * xd * log(x);
    }
    return F;
}

/* Right-hand side of eqs. 1-2 (state w, f; input u, offset removed) and its tangent along (Dw, Df). */
static void rhs_tangent(const plant_params *p, double w, double f, double u, const double *Dw, const double *Df,
                        double *kw, double *kf, double *Dkw, double *Dkf)
{
    double dFdw, dFp[AFF_SENS_NP];
    double F = target_derivs(p, w, &dFdw, dFp);
    *kw = (u - f) * p->inv_J;
    *kf = (F - f) * p->inv_tau;
    for (int j = 0; j < AFF_SENS_NP; j++) {
        Dkw[j] = -Df[j] * p->inv_J;
        Dkf[j] = (dFdw * Dw[j] - Df[j] + dFp[j]) * p->inv_tau;
    }
    Dkw[AFF_SENS_J] -= (u - f) * p->inv_J * p->inv_J;
    Dkw[AFF_SENS_OFFSET] -= p->inv_J; /* u enters as u - offset */
    Dkf[AFF_SENS_TAU] -= (F - f) * p->inv_tau * p->inv_tau;
}

/* The tangent of an RK4 stage's state, D + h*Dk, for the velocity and the friction state (AFF_SENS_NP each). */
static void stage_tangent(const double *Dw, const double *Df, double h, const double *Dkw, const double *Dkf,
                          double *Daw, double *Daf)
{
    for (int j = 0; j < AFF_SENS_NP; j++) {
        Daw[j] = Dw[j] + h * Dkw[j];
        Daf[j] = Df[j] + h * Dkf[j];
    }
}

AFF_SIM_FLATTEN void aff_simulate_on_grid_sens(const plant_params *p, const double *tg, const double *ug,
                                               const long *idx, long n, double offset, double w0, double f0,
                                               double Kw, double Kf, const double *w_meas, int inject, double *out,
                                               double *dout)
{
    double J = p->J;
    double w = w0;
    double f = f0 - offset;
    double Dw[AFF_SENS_NP], Df[AFF_SENS_NP];
    if (n <= 0)
        return;
    for (int j = 0; j < AFF_SENS_NP; j++) {
        Dw[j] = 0.0;
        Df[j] = 0.0;
        dout[j] = 0.0;
    }
    Df[AFF_SENS_OFFSET] = -1.0; /* the state is f - offset */
    out[0] = w0;
    for (long s = 1; s < n; s++) {
        long a = idx[s - 1];
        long b = idx[s];
        for (long i = a; i < b; i++) {
            double u0 = ug[i] - offset;
            double u1 = ug[i + 1] - offset;
            double um = 0.5 * (u0 + u1);
            double h = tg[i + 1] - tg[i];
            double h2 = 0.5 * h;
            double h6 = h / 6.0;
            double k1w, k1f, k2w, k2f, k3w, k3f, k4w, k4f, wa, fa, wb, fb, wc, fc;
            double D1w[AFF_SENS_NP], D1f[AFF_SENS_NP], D2w[AFF_SENS_NP], D2f[AFF_SENS_NP];
            double D3w[AFF_SENS_NP], D3f[AFF_SENS_NP], D4w[AFF_SENS_NP], D4f[AFF_SENS_NP];
            double Daw[AFF_SENS_NP], Daf[AFF_SENS_NP];
            int j;
            /* the stages of plant_rk4 (plant_dynamics.c) in its order of operations, with their tangents */
            rhs_tangent(p, w, f, u0, Dw, Df, &k1w, &k1f, D1w, D1f);
            wa = w + h2 * k1w;
            fa = f + h2 * k1f;
            stage_tangent(Dw, Df, h2, D1w, D1f, Daw, Daf);
            rhs_tangent(p, wa, fa, um, Daw, Daf, &k2w, &k2f, D2w, D2f);
            wb = w + h2 * k2w;
            fb = f + h2 * k2f;
            stage_tangent(Dw, Df, h2, D2w, D2f, Daw, Daf);
            rhs_tangent(p, wb, fb, um, Daw, Daf, &k3w, &k3f, D3w, D3f);
            wc = w + h * k3w;
            fc = f + h * k3f;
            stage_tangent(Dw, Df, h, D3w, D3f, Daw, Daf);
            rhs_tangent(p, wc, fc, u1, Daw, Daf, &k4w, &k4f, D4w, D4f);
            w = w + h6 * (k1w + 2.0 * k2w + 2.0 * k3w + k4w);
            f = f + h6 * (k1f + 2.0 * k2f + 2.0 * k3f + k4f);
            for (j = 0; j < AFF_SENS_NP; j++) {
                Dw[j] = Dw[j] + h6 * (D1w[j] + 2.0 * D2w[j] + 2.0 * D3w[j] + D4w[j]);
                Df[j] = Df[j] + h6 * (D1f[j] + 2.0 * D2f[j] + 2.0 * D3f[j] + D4f[j]);
            }
        }
        if (!(isfinite(w) && isfinite(f))) {
            for (long r = s; r < n; r++) {
                out[r] = NAN;
                for (int j = 0; j < AFF_SENS_NP; j++)
                    dout[r * AFF_SENS_NP + j] = NAN;
            }
            return;
        }
        out[s] = w;
        for (int j = 0; j < AFF_SENS_NP; j++)
            dout[s * AFF_SENS_NP + j] = Dw[j];
        if (inject) {
            double e = w_meas[s] - w;
            double g = Kf / (tg[b] - tg[a]);
            for (int j = 0; j < AFF_SENS_NP; j++) {
                Df[j] += g * J * Dw[j]; /* f -= g*J*e, de = -Dw */
                Dw[j] *= 1.0 - Kw;
            }
            Df[AFF_SENS_J] -= g * e;
            w += Kw * e;
            f -= Kf * J / (tg[b] - tg[a]) * e;
        }
    }
}
