/* plant_stiff.c -- implicit steps of stiff plants (see plant_stiff.h). The operations are those of the former
 * former JIT kernels of plant/stiff.py in the same order (results equal bit for bit). */
#include "plant_stiff.h"

const double plant_lagged_rtol = 1e-5;
const double plant_lagged_ftol = 1e-4;
const double plant_lugre_rtol = 1e-5;
const double plant_lugre_ztol = 1e-3;

/* Python's max(a, b): b if b > a else a (NaN handling as Python's builtin). */
static double pymax(double a, double b)
{
    return b > a ? b : a;
}

double plant_lagged_level_max(const plant_params *p)
{
    double m = pymax(pymax(pymax(p->pos.Fc, p->pos.Fc + p->pos.dF), pymax(p->neg.Fc, p->neg.Fc + p->neg.dF)),
                     p->Fs_stick);
    if (p->ripple_a != 0.0) /* the map times R(q) <= 1 + a */
        m *= 1.0 + p->ripple_a;
    return m;
}

double plant_lagged_local_rate(const plant_params *p, double w, double f, double u, double dt)
{
    double J = p->J;
    double tau = p->tau;
    double aw = w >= 0.0 ? w : -w;
    int pos = w > 0.0;
    double dF = pos ? p->pos.dF : p->neg.dF;
    double sig = pos ? p->pos.sigma : p->neg.sigma;
    double Fmax = plant_lagged_level_max(p);
    double D = 2.0 * dt * (fabs(u) + pymax(fabs(f), Fmax + pymax(p->pos.sigma, p->neg.sigma) * aw)) / J;
    double lo = aw - D;
    double delta, Vs, rise, s;
    if (!(lo > p->dv)) /* reaches the jump at 0 or the Karnopp band (or a NaN state) */
        return INFINITY;
    delta = p->pos.delta;
    Vs = p->pos.Vs;
    rise = 0.0;
    if (dF * delta < 0.0) {
        double x = 0.0, xl, xh;
        if (delta >= 1.0 || delta < 0.0)
            x = pow(1.0 - 1.0 / delta, 1.0 / delta);
        xl = lo / Vs;
        xh = (aw + D) / Vs;
        x = x < xl ? xl : (x > xh ? xh : x);
        rise = plant_stribeck_slope(x, dF, Vs, delta);
    }
    s = (sig > 0.0 ? sig : 0.0) + rise;
    if (p->ripple_a != 0.0) { /* the ripple's position stiffness k = |dF/dq| <= (Fmax + sigma*|w|)*a*n */
        double kq = (Fmax + pymax(pymax(p->pos.sigma, p->neg.sigma), 0.0) * (aw + D)) * p->ripple_a * p->ripple_n;
        double rp = 4.0 * p->ripple_n * (aw + D); /* the ripple's passing rate, resolved (accuracy) */
        s = s * (1.0 + p->ripple_a);
        if (tau > 0.0) /* J*tau*l^3 + J*l^2 + s*l + kq = 0: |l| <= max(1/tau, sqrt(s/(J tau)), cbrt(kq/(J tau))) */
            return pymax(pymax(pymax(1.0 / tau, sqrt(s / (J * tau))), cbrt(kq / (J * tau))), rp);
        return pymax(pymax(s / J, sqrt(kq / J)), rp);
    }
    if (tau > 0.0)
        return pymax(1.0 / tau, sqrt(s / (J * tau)));
    return s / J;
}

int plant_static_jump_in_reach(const plant_params *p, double w, double u, double dt)
{
    double aw = fabs(w);
    double amax = (fabs(u) + plant_lagged_level_max(p) + 2.0 * pymax(pymax(p->pos.sigma, p->neg.sigma), 0.0) * aw)
                  / p->J;
    return !(aw > dt * amax);
}

/* d*(c*(w - w0) + k*F(w, q0 + h*w) - r): the backward-Euler residual of plant_lagged_implicit_step, oriented
 * (the map at the step's end position q0 + h*w, plant_target_at). */
static double be_residual(const plant_params *p, double w, double sgn, double c, double k, double r, double w0,
                          double d, double q0, double h)
{
    return d * (c * (w - w0) + k * plant_target_at(p, w, q0 + h * w, sgn) - r);
}

/* A root of the oriented residual in the bracket (lo, hi) (plo < 0 <= phi): Illinois regula falsi with a
 * bisection after three iterations that did not halve the bracket (Dahlquist & Bjorck, Numerical Methods,
 * Sec. 6.2); returns hi once |hi - lo| <= 1e-13*(|lo| + |hi| + Vs), at most 300 iterations. */
static double be_root(const plant_params *p, double sgn, double c, double k, double r, double w0, double d,
                      double q0, double h, double lo, double plo, double hi, double phi)
{
    double tol = 1e-13 * (fabs(lo) + fabs(hi) + p->pos.Vs);
    int side = 0;
    int stall = 0;
    for (int it = 0; it < 300; it++) {
        double width = fabs(hi - lo);
        double x, px;
        if (!(width > tol))
            break;
        x = hi - phi * (hi - lo) / (phi - plo);
        if (stall >= 3 || !(fabs(x - lo) < width && fabs(x - hi) < width)) {
            x = 0.5 * (lo + hi);
            stall = 0;
        }
        px = be_residual(p, x, sgn, c, k, r, w0, d, q0, h);
        if (px >= 0.0) {
            hi = x;
            phi = px;
            if (side == 1)
                plo *= 0.5;
            side = 1;
            if (px == 0.0)
                break;
        } else {
            lo = x;
            plo = px;
            if (side == -1)
                phi *= 0.5;
            side = -1;
        }
        stall = fabs(hi - lo) > 0.5 * width ? stall + 1 : 0;
    }
    return hi;
}

void plant_lagged_implicit_step(const plant_params *p, double w0, double f0, double q0, double u, double h,
                                double sgn, double *w, double *f, double *Fstar)
{
    double J = p->J;
    double tau = p->tau;
    double dv = p->dv;
    double a, c, k, r, d, start, Fbar, hi, plo, phi, ws, Fs;
    if (tau > 0.0) {
        a = h / tau;
        c = J * (1.0 + a);
        k = h * a;
        r = h * ((1.0 + a) * u - f0);
    } else {
        a = 0.0;
        c = J;
        k = h;
        r = h * u;
    }
    start = w0;
    if ((w0 == 0.0 && dv == 0.0) || (dv > 0.0 && (w0 == dv || w0 == -dv))) { /* on a jump of the map */
        double Flo = plant_target_at(p, nextafter(w0, -INFINITY), q0 + h * w0, sgn);
        double Fhi = plant_target_at(p, nextafter(w0, INFINITY), q0 + h * w0, sgn);
        if (k * Flo <= r && r <= k * Fhi) { /* F(w0) is the interval [Flo, Fhi] and holds the joint: it stays */
            Fs = r / k;
            *w = w0;
            *f = tau > 0.0 ? (f0 + a * Fs) / (1.0 + a) : Fs;
            *Fstar = Fs;
            return;
        }
        d = r > k * Fhi ? 1.0 : -1.0;
        start = nextafter(w0, d * INFINITY);
    } else {
        double g = r - k * plant_target_at(p, w0, q0 + h * w0, sgn);
        if (g == 0.0 || !(g == g)) {
            Fs = g == g ? plant_target_at(p, w0, q0 + h * w0, sgn) : NAN;
            *w = g == g ? w0 : NAN;
            *f = tau > 0.0 ? (f0 + a * Fs) / (1.0 + a) : Fs;
            *Fstar = Fs;
            return;
        }
        d = g > 0.0 ? 1.0 : -1.0;
    }
    Fbar = plant_lagged_level_max(p) + pymax(p->pos.sigma, p->neg.sigma) * fabs(w0);
    if (p->ripple_a != 0.0) /* the viscous part rippled too */
        Fbar = plant_lagged_level_max(p) + pymax(p->pos.sigma, p->neg.sigma) * fabs(w0) * (1.0 + p->ripple_a);
    hi = w0 + d * (fabs(r) + k * Fbar) / c;
    hi = hi + d * 1e-15 * (fabs(hi) + p->pos.Vs); /* strictly past the bound */
    plo = be_residual(p, start, sgn, c, k, r, w0, d, q0, h);
    phi = be_residual(p, hi, sgn, c, k, r, w0, d, q0, h);
    for (int i = 0; i < 2; i++) { /* the jumps of the map ahead of the start, in the direction of motion */
        double q = dv == 0.0 ? (i == 0 ? 0.0 : NAN) : (i == 0 ? -d * dv : d * dv);
        double before, pb, after, pa;
        if (!(d * (q - start) > 0.0 && d * (hi - q) > 0.0))
            continue;
        before = nextafter(q, -d * INFINITY);
        pb = be_residual(p, before, sgn, c, k, r, w0, d, q0, h);
        if (pb >= 0.0) {
            hi = before;
            phi = pb;
            break;
        }
        after = nextafter(q, d * INFINITY);
        pa = be_residual(p, after, sgn, c, k, r, w0, d, q0, h);
        if (pa >= 0.0) { /* the residual jumps across zero: the step ends on the jump */
            Fs = (r - c * (q - w0)) / k;
            *w = q;
            *f = tau > 0.0 ? (f0 + a * Fs) / (1.0 + a) : Fs;
            *Fstar = Fs;
            return;
        }
        start = after;
        plo = pa;
    }
    if (phi <= 0.0)
        ws = hi;
    else if (plo >= 0.0)
        ws = start;
    else
        ws = be_root(p, sgn, c, k, r, w0, d, q0, h, start, plo, hi, phi);
    Fs = (r - c * (ws - w0)) / k;
    *w = ws;
    *f = tau > 0.0 ? (f0 + a * Fs) / (1.0 + a) : Fs;
    *Fstar = Fs;
}

/* Which smooth piece of the lagged map w lies on: -2/2 below/above the jump(s), 0 inside the Karnopp band, odd
 * on a jump point (w = 0, or w = -dv/dv). */
static int region(const plant_params *p, double w)
{
    double dv = p->dv;
    if (dv == 0.0)
        return w < 0.0 ? -2 : (w > 0.0 ? 2 : 1);
    if (w < -dv)
        return -2;
    if (w > dv)
        return 2;
    return w == -dv ? -1 : (w == dv ? 1 : 0);
}

/* Next sub-step after one of length hh with scaled error err: hh*0.9/sqrt(err), the factor kept in [0.2, 2]
 * (Hairer, Norsett & Wanner, Solving ODEs I, Sec. II.4). */
static double next_substep(double hh, double err)
{
    double fac = err > 0.0 ? 0.9 / sqrt(err) : 2.0;
    return hh * (fac > 2.0 ? 2.0 : (fac < 0.2 ? 0.2 : fac));
}

void plant_lagged_stiff_step(const plant_params *p, plant_state *st, double u, double dt, double sgn)
{
    double w = st->w;
    double f = st->s;
    double q = st->q;
    double h = st->aux;
    double tau = p->tau;
    double Vs = p->pos.Vs;
    double tol_f = plant_lagged_ftol * pymax(plant_lagged_level_max(p), 1e-300);
    double t = 0.0;
    long count = 0;
    if (!(h > 0.0 && h <= dt))
        h = dt;
    while (t < dt) {
        int last, reg, smooth;
        double hh, w1, f1, F1, wm, fm, Fm, w2, f2, F2, err, we, q1, qm, q2;
        if (count >= PLANT_LAGGED_MAX_SUBSTEPS || !(w - w == 0.0 && f - f == 0.0 && u - u == 0.0)) {
            st->w = NAN;
            st->s = NAN;
            st->aux = NAN;
            return;
        }
        count++;
        last = h >= dt - t;
        hh = last ? dt - t : h;
        plant_lagged_implicit_step(p, w, f, q, u, hh, sgn, &w1, &f1, &F1);
        plant_lagged_implicit_step(p, w, f, q, u, 0.5 * hh, sgn, &wm, &fm, &Fm);
        qm = q + 0.5 * hh * wm; /* backward Euler on dq/dt = w */
        plant_lagged_implicit_step(p, wm, fm, qm, u, 0.5 * hh, sgn, &w2, &f2, &F2);
        q1 = q + hh * w1;
        q2 = qm + 0.5 * hh * w2;
        err = fabs(w2 - w1) / (plant_lagged_rtol * (fabs(w2) + Vs));
        if (tau > 0.0) {
            double ef = fabs(f2 - f1) / tol_f;
            err = err > ef ? err : ef;
        }
        if (!(err == err))
            err = INFINITY;
        if (err <= 1.0) {
            t = last ? dt : t + hh;
            reg = region(p, w2);
            we = 2.0 * w2 - w1;
            smooth = reg % 2 == 0 && region(p, w) == reg && region(p, w1) == reg && region(p, wm) == reg;
            if (smooth && region(p, we) == reg) {
                w = we;
                q = 2.0 * q2 - q1;
                f = tau > 0.0 ? 2.0 * f2 - f1 : plant_target_at(p, we, q, sgn);
            } else {
                w = w2;
                q = q2;
                f = f2;
            }
        }
        h = next_substep(hh, err);
    }
    st->w = w;
    st->s = f;
    st->q = q;
    st->aux = h;
}

void plant_lugre_jacobian(const plant_params *p, double w, double z, double q, double u, double out[6])
{
    double J = p->J;
    double s0 = p->sigma0;
    double s1 = p->sigma1;
    double s2 = p->pos.sigma;
    double aw = w >= 0.0 ? w : -w;
    double g = plant_target_at(p, w, q, 0.0);
    double R = 1.0;
    double a = s0 * aw / g;
    double fz = w - a * z;
    double fw = (u - s0 * z - s1 * fz - s2 * w) / J;
    double da = 0.0;
    double dzw;
    if (p->ripple_a != 0.0) { /* g*R and sigma2*R (plant_params.h) */
        R = plant_ripple(p, q);
        s2 = s2 * R;
        fw = (u - s0 * z - s1 * fz - s2 * w) / J;
    }
    if (aw > 0.0) {
        double slope = plant_stribeck_slope(aw / p->pos.Vs, p->pos.dF, p->pos.Vs, p->pos.delta);
        if (p->ripple_a != 0.0)
            slope = slope * R;
        da = s0 * (g - aw * slope) / (g * g);
        if (w < 0.0)
            da = -da;
    }
    dzw = 1.0 - da * z;
    out[0] = fw;
    out[1] = fz;
    out[2] = (-s1 * dzw - s2) / J;
    out[3] = (-s0 + s1 * a) / J;
    out[4] = dzw;
    out[5] = -a;
}

int plant_lugre_implicit_step(const plant_params *p, double w0, double z0, double q0, double u, double h,
                              double *w_out, double *z_out)
{
    double w = w0;
    double z = z0;
    double zs = p->g_max / p->sigma0;
    for (int it = 0; it < 30; it++) {
        double jac[6];
        double g1, g2, m11, m12, m21, m22, det, dw, dz;
        plant_lugre_jacobian(p, w, z, q0 + h * w, u, jac);
        g1 = w - w0 - h * jac[0];
        g2 = z - z0 - h * jac[1];
        m11 = 1.0 - h * jac[2];
        m12 = -h * jac[3];
        m21 = -h * jac[4];
        m22 = 1.0 - h * jac[5];
        det = m11 * m22 - m12 * m21;
        dw = (g1 * m22 - m12 * g2) / det;
        dz = (m11 * g2 - m21 * g1) / det;
        w -= dw;
        z -= dz;
        if (fabs(dw) <= 1e-12 * (fabs(w) + p->pos.Vs) && fabs(dz) <= 1e-12 * zs) {
            *w_out = w;
            *z_out = z;
            return 1;
        }
    }
    *w_out = w;
    *z_out = z;
    return 0;
}

void plant_lugre_stiff_step(const plant_params *p, plant_state *st, double u, double dt)
{
    double w = st->w;
    double z = st->s;
    double q = st->q;
    double h = st->aux;
    double tol_z = plant_lugre_ztol * p->g_max / p->sigma0;
    double t = 0.0;
    long count = 0;
    if (!(h > 0.0 && h <= dt))
        h = dt;
    while (t < dt) {
        int last, ok1, ok2, ok3;
        double hh, w1, z1, wm, zm, w2, z2, err, qm;
        if (count >= PLANT_LUGRE_MAX_SUBSTEPS || !(w == w && z == z)) {
            st->w = NAN;
            st->s = NAN;
            st->aux = NAN;
            return;
        }
        count++;
        last = h >= dt - t;
        hh = last ? dt - t : h;
        ok1 = plant_lugre_implicit_step(p, w, z, q, u, hh, &w1, &z1);
        ok2 = plant_lugre_implicit_step(p, w, z, q, u, 0.5 * hh, &wm, &zm);
        qm = q + 0.5 * hh * wm; /* backward Euler on dq/dt = w */
        ok3 = plant_lugre_implicit_step(p, wm, zm, qm, u, 0.5 * hh, &w2, &z2);
        err = INFINITY;
        if (ok1 && ok2 && ok3) {
            double ew = fabs(w2 - w1) / (plant_lugre_rtol * (fabs(w2) + p->pos.Vs));
            double ez = fabs(z2 - z1) / tol_z;
            err = ew > ez ? ew : ez;
        }
        if (err <= 1.0) {
            t = last ? dt : t + hh;
            q = 2.0 * (qm + 0.5 * hh * w2) - (q + hh * w1);
            w = 2.0 * w2 - w1;
            z = 2.0 * z2 - z1;
        }
        h = next_substep(hh, err);
    }
    st->w = w;
    st->s = z;
    st->q = q;
    st->aux = h;
}
