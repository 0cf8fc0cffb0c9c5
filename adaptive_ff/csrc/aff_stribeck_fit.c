/* aff_stribeck_fit.c -- eq. 3 and its parameter Jacobian for the Stribeck pre-fit (see aff_stribeck_fit.h). */
#include "aff_stribeck_fit.h"

void aff_stribeck_fit_values(const double *w, double *out, long n, double Fc, double dF, double Vs,
                             double delta, double sigma)
{
    plant_stribeck m;
    m.Fc = Fc;
    m.dF = dF;
    m.Vs = Vs;
    m.delta = delta;
    m.sigma = sigma;
    m.wcut = INFINITY;
    for (long i = 0; i < n; i++) /* plant_stribeck_eval per element: double here, aff_real in plant */
        out[i] = plant_stribeck_eval(&m, w[i]);
}

void aff_stribeck_fit_jacobian(const double *w, const double *logaw, double *out, long n, double Fc,
                               double Fs, double logVs, double delta)
{
    double d = Fs - Fc;
    for (long i = 0; i < n; i++) {
        double wi = w[i];
        double sg = wi > 0.0 ? 1.0 : (wi < 0.0 ? -1.0 : 0.0);
        double logx = logaw[i] - logVs;
        double a = delta * logx;
        double logp = AFF_STRIBECK_FIT_LOGP_MAX < a ? AFF_STRIBECK_FIT_LOGP_MAX : a; /* min(a, MAX), NaN kept */
        double p = exp(logp);
        double si = exp(-p);
        double sp = exp(logp - p);
        double *row = out + 5 * i;
        row[0] = sg * (1.0 - si);
        row[1] = sg * si;
        row[2] = sg * d * delta * sp;
        row[3] = -sg * d * sp * logx;
        row[4] = wi;
    }
}
