"""Compiled (numba) single-run closed-loop kernel: PI + RK4 joint + compensation + online estimators, streamed metrics.

One run of :func:`controllers.simulation.closed_loop.run_closed_loop` for a
:class:`plant.friction.JointParams` plant (also drifting, re-frozen every
period as :class:`plant.drift.FrictionDrift` prescribes) in every mode but
``adaptive`` with the ``eq4`` estimator: ``none``, ``frictionless``,
``oracle``, ``fixed``, ``adaptive`` with the default ``"sliding"`` estimator
(:class:`adaptive_ff.compensation.sliding_estimator.SlidingFrictionEstimator` with its
outlier gate, state-variable filters, noise-adaptive near-zero band,
sliding-regime gate and RLS with forgetting, covariance bound and projection,
driving :class:`adaptive_ff.compensation.feedforward.RobustAdaptiveFeedforward` with
warm-up, plausibility and lag-consistency tests, fade-in and stick detection),
and the peers ``canudas`` (:class:`controllers.peers.canudas.CanudasCompensator`)
and ``dob`` (:class:`controllers.peers.dob.DisturbanceObserver`); with the
controller's sensor gate (:class:`adaptive_ff.compensation.gate.OutlierGate`) and
measurement faults. The RLS updates call the compiled kernel of
:mod:`adaptive_ff.identification.rls` on the estimator's own state buffer (one RLS
implementation), the plant uses :func:`controllers.simulation.batch._F`.

The Python loop of ``run_closed_loop(engine="python")`` is the reference
twin: the kernel repeats its floating-point operations in the same order
(bit-identical on the presets; ``tests/test_kernel_adaptive.py`` checks <=
1e-9 over random plants and settings).

Why numba: it is already a dependency (``controllers.simulation.batch``), compiles the
plain-float loop to machine code with ``cache=True`` (compiled once per
machine, loaded from ``__pycache__`` afterwards) and keeps the kernel in
Python syntax next to its reference twin. Measured in ``benchmarks/perf.py``.
"""

from __future__ import annotations

import math

import numpy as np
from plant.jit import kernel

from adaptive_ff.identification.rls import _HDR, _NPROJ, _NUPD, _update
from controllers.simulation.batch import _F, _pi_step, _rk4_step, _wcut

__all__ = ["ST", "run_loop_kernel"]



#: Slots of the kernel's state/result vector ``st`` (floats).
ST = {name: i for i, name in enumerate((
    "k_end", "diverged",
    # streamed metrics
    "se", "se_c", "me", "se2", "se2_c", "me2", "nh", "ser", "ser_c", "nr", "su", "su_c",
    # sensor gate: last, has_last, scale, n_held, n_rejected
    "g_last", "g_has", "g_scale", "g_held", "g_rej",
    # estimator gate
    "e_last", "e_has", "e_scale", "e_held", "e_rej",
    # estimator
    "n_samples", "n_rejected", "n_gated", "n_updates", "n_projected", "d2", "e2", "w1", "w2", "n_acc",
    # feedforward
    "has_est", "u_ff", "gain", "n_in_band", "n_implausible", "n_lag_held", "ff_tau", "ff_held",
    "n_theta",
    # peers
    "p_rejected", "c_on", "c_k", "c_usum", "c_wprev", "c_has_prev", "c_ok", "q_d", "q_ulast", "q_wlast", "q_has",
))}
_NST = len(ST)

_NOISE_GAIN = math.sqrt(6.0) * math.sqrt(2.0 / math.pi)  # as adaptive_ff.compensation.sliding_estimator
_BAND_SIGMAS = 4.0


@kernel(inline="always")
def _svf3(sf, o, a, x):
    """Advance one chain of three first-order low-passes ``sf[o:o+3]`` (gain ``a``) by input ``x``.

    The state-variable filter of :class:`adaptive_ff.compensation.sliding_estimator.SlidingFrictionEstimator`
    (same operations in the same order as its unrolled Python stages).
    """
    x1 = sf[o] + a * (x - sf[o])
    x2 = sf[o + 1] + a * (x1 - sf[o + 1])
    sf[o + 2] += a * (x2 - sf[o + 2])
    sf[o] = x1
    sf[o + 1] = x2


@kernel
def _gate_check(st, o, x, max_step, n_sigma, alpha, max_consec):
    """OutlierGate.check on state slots st[o:o+5] = last, has_last, scale, n_held, n_rejected."""
    if not math.isfinite(x):
        st[o + 4] += 1.0
        st[o + 3] += 1.0
        return False
    if st[o + 1] == 0.0:
        st[o] = x
        st[o + 1] = 1.0
        return True
    last = st[o]
    d = x - last if x >= last else last - x
    bound = (max_step + n_sigma * st[o + 2]) * (1.0 + st[o + 3])
    if d > bound:
        if st[o + 3] < max_consec:
            st[o + 4] += 1.0
            st[o + 3] += 1.0
            return False
    else:
        st[o + 2] += alpha * (d - st[o + 2])
    st[o] = x
    st[o + 3] = 0.0
    return True


@kernel
def _kernel(wr, noise, has_noise, fk, fv, PL, seg, s0, G, mode, ffp, fixed_est, ep, pp, buf, npar, gp, use_gate, tt,
            revs, window, tmid, dec, w_limit, W, WM, U, UFF, FF, TH, TK, FTH, st):
    """One closed-loop run; arguments as prepared by :func:`run_loop_kernel` (outputs written in place).

    ``ffp`` = ff_max, sign_width, stick_band, stick_samples, lag, ff at measured velocity, warmup, fade
    step, J_lo, J_hi, tau_max, consistency; ``fixed_est`` = Fc, Fs - Fc, Vs, delta, sigma, alpha,
    has Vs; ``ep`` = Vs, delta, filter gain a, T, m, settle, w_band_min, dwell_max, e2 rate, lag,
    offset; ``gp`` = (max_step, n_sigma, alpha, max_consecutive) of the sensor and estimator gates;
    ``pp`` = peer settings: canudas (mode 4) m, w_dead, warmup, ff_max, ff at measured velocity;
    disturbance observer (mode 5) order, filter gain a, J_n, Tc, d_max.
    """
    n = wr.shape[0]
    dt = G[3]
    h2 = dt / 2.0
    h6 = dt / 6.0
    # plant parameters: row 0 of the table; with drift (seg > 0) row j from sample j*seg on
    J, Fc, dF, Vs, delta, sigma, tau = PL[0, 0], PL[0, 1], PL[0, 2], PL[0, 3], PL[0, 4], PL[0, 5], PL[0, 6]
    d1, wcut = PL[0, 7] > 0.0, PL[0, 8]  # exact shortcuts of controllers.simulation.batch._F
    prow = 0
    Kp, KiTc, umax = G[0], G[1], G[2]
    g_step, g_nsig, g_alpha, g_cons = gp[0], gp[1], gp[2], gp[3]
    e_step, e_nsig, e_alpha, e_cons = gp[4], gp[5], gp[6], gp[7]
    ffmax, sw, sband, ssamp, fflag, ff_meas = ffp[0], ffp[1], ffp[2], ffp[3], ffp[4] > 0.0, ffp[5] > 0.0
    warmup, fade, J_lo, J_hi, tau_max, consist = ffp[6], ffp[7], ffp[8], ffp[9], ffp[10], ffp[11]
    # feedforward estimate in use
    fFc, fdF, fVs, fdel, fsig, falpha, fhas_vs = (fixed_est[0], fixed_est[1], fixed_est[2], fixed_est[3],
                                                  fixed_est[4], fixed_est[5], fixed_est[6] > 0.0)
    has_est = mode == 2
    ftau = 0.0
    # estimator settings
    eVs, edel, a, T, m, settle, wbmin, dwell, e2rate = (ep[0], ep[1], ep[2], ep[3], int(ep[4]), int(ep[5]), ep[6],
                                                        ep[7], ep[8])
    elag, eoff = ep[9] > 0.0, ep[10] > 0.0
    # RLS state: adaptive_ff.identification.rls buffer, theta at buf[th0:th0+p], P (row-major) after it
    th0 = _HDR
    P0 = _HDR + npar
    phi = np.empty(npar)
    sf = np.zeros(15)
    iFc = 3 if elag else 1
    d2s = 0.0
    e2 = 0.0
    w1 = 0.0
    w2 = 0.0
    nacc = 0
    n_samples = 0
    n_rej = 0
    n_gated = 0
    n_upd = int(buf[_NUPD])
    n_impl = 0
    n_held_lag = 0
    ff_held = 0.0
    nth = 0
    u_ff = 0.0
    gain = 0.0
    nib = 0.0
    # peers: Canudas de Wit et al. (controllers.peers.canudas), disturbance observer (controllers.peers.dob)
    c_on = False
    cFcp = cFcn = csp = csn = 0.0
    c_k = 0
    c_usum = 0.0
    c_wprev = 0.0
    c_has_prev = False
    c_ok = True
    c_m = int(pp[0]) if mode == 4 else 1
    c_wd, c_warm, c_ffmax, c_meas = pp[1], pp[2], pp[3], pp[4] > 0.0
    q_order = int(pp[0]) if mode == 5 else 1
    q_a, q_Jn, q_Tc, q_dmax = pp[1], pp[2], pp[3], pp[4]
    q_x = np.zeros(q_order)
    q_wlast = 0.0
    q_has = False
    q_ulast = 0.0
    q_d = 0.0
    p_rej = 0
    # fault pointer
    fp = 0
    nf = fk.shape[0]

    w = wr[0]
    f = s0
    I = 0.0
    u = 0.0
    held = w
    se = 0.0
    se_c = 0.0
    se2 = 0.0
    se2_c = 0.0
    ser = 0.0
    ser_c = 0.0
    su = 0.0
    su_c = 0.0
    me = 0.0
    me2 = 0.0
    nh = 0
    nr = 0
    div = False
    k_end = n
    nrev = revs.shape[0]
    ip = 0
    for k in range(n):
        if seg > 0 and k % seg == 0 and k > 0:  # drifting plant re-frozen (FrictionDrift.at)
            prow += 1
            J, Fc, dF, Vs, delta, sigma, tau = (PL[prow, 0], PL[prow, 1], PL[prow, 2], PL[prow, 3], PL[prow, 4],
                                                PL[prow, 5], PL[prow, 6])
            d1, wcut = PL[prow, 7] > 0.0, PL[prow, 8]
        wm = w + noise[k] if has_noise else w + 0.0
        while fp < nf and fk[fp] < k:
            fp += 1
        if fp < nf and fk[fp] == k:
            wm = fv[fp]
        if use_gate:
            if _gate_check(st, 14, wm, g_step, g_nsig, g_alpha, g_cons):
                held = wm
            wc = held
        else:
            wc = wm
        wrk = wr[k]
        # ---- compensation torque
        if mode == 2 or mode == 3:
            if mode == 3 and not has_est:
                uff = 0.0
            else:
                x = wc
                if ff_meas:
                    if -sband < x < sband:
                        nib += 1.0
                        if nib >= ssamp:
                            x = wrk
                    else:
                        nib = 0.0
                else:
                    x = wrk
                if x == 0.0:
                    stc = 0.0
                else:
                    ax = abs(x)
                    if fhas_vs:
                        mag = fFc + fdF * math.exp(-((ax / fVs) ** fdel))
                    else:
                        mag = fFc
                    if sw > 0.0 and ax < sw:
                        stc = mag * (x / sw) + fsig * x
                    else:
                        stc = math.copysign(mag, x) + fsig * x
                u_ff += falpha * (stc - u_ff)
                out = min(max(u_ff, -ffmax), ffmax)
                if mode == 3 and gain < 1.0:
                    gain = min(gain + fade, 1.0)
                    out = out * gain
                uff = out
        elif mode == 1:
            uff = f
        elif mode == 4:  # CanudasCompensator.compensate
            if not c_on:
                uff = 0.0
            else:
                x = wc if c_meas else wrk
                if x > 0.0:
                    cc = cFcp + csp * x
                elif x < 0.0:
                    cc = -cFcn + csn * x
                else:
                    cc = 0.0
                uff = min(max(cc, -c_ffmax), c_ffmax)
        elif mode == 5:  # DisturbanceObserver.compensate
            if not math.isfinite(wc):
                p_rej += 1
            elif not q_has:
                q_wlast = wc
                q_has = True
            else:
                vq = q_ulast - q_Jn * (wc - q_wlast) / q_Tc
                q_wlast = wc
                for i in range(q_order):
                    q_x[i] += q_a * (vq - q_x[i])
                    vq = q_x[i]
                q_d = min(max(vq, -q_dmax), q_dmax)
            uff = q_d
        else:
            uff = 0.0
        # ---- PIController.step
        I, u = _pi_step(I, wrk - wc, Kp, KiTc, umax, uff)
        # ---- estimator (SlidingFrictionEstimator.observe + RobustAdaptiveFeedforward.observe)
        if mode == 3:
            upd = False
            if not math.isfinite(u):
                n_rej += 1
            elif not _gate_check(st, 19, wm, e_step, e_nsig, e_alpha, e_cons):
                n_rej += 1
            else:
                wx = wm
                if nacc >= 2:
                    dd = wx - 2.0 * w1 + w2
                    d2s += 0.01 * ((dd if dd >= 0.0 else -dd) - d2s)
                w2 = w1
                w1 = wx
                nacc += 1
                band = wbmin
                nb = _BAND_SIGMAS * d2s / _NOISE_GAIN
                if nb > band:
                    band = nb
                aw = wx if wx >= 0.0 else -wx
                if aw > 0.0:
                    ee = math.exp(-((aw / eVs) ** edel))
                    sg = 1.0 if wx > 0.0 else -1.0
                    gg = sg * (1.0 - ee)
                    hh = sg * ee
                else:
                    gg = 0.0
                    hh = 0.0
                dz = 1.0 if aw < band else 0.0
                _svf3(sf, 0, a, wx)  # SlidingFrictionEstimator's five third-order filter chains
                _svf3(sf, 3, a, u)
                _svf3(sf, 6, a, gg)
                _svf3(sf, 9, a, hh)
                _svf3(sf, 12, a, dz)
                n_samples += 1
                if n_samples % m == 0 and n_samples >= settle:
                    if sf[14] > dwell:
                        n_gated += 1
                    else:
                        j = 0
                        phi[j] = (sf[1] - sf[2]) / T
                        j += 1
                        if elag:
                            phi[j] = (sf[0] - 2.0 * sf[1] + sf[2]) / (T * T)
                            phi[j + 1] = -(sf[4] - sf[5]) / T
                            j += 2
                        phi[j] = sf[8]
                        phi[j + 1] = sf[11]
                        phi[j + 2] = sf[2]
                        j += 3
                        if eoff:
                            phi[j] = 1.0
                        err = _update(buf, phi, sf[5])  # RecursiveLeastSquares.update, the same kernel
                        n_upd = int(buf[_NUPD])
                        e2 += e2rate * (err * err - e2)
                        upd = True
            if upd and n_upd >= warmup:
                eJ = buf[th0]
                if elag:
                    etau = buf[th0 + 2]
                    eJalt = buf[th0 + 1] / etau if etau > 0.0 else np.nan
                else:
                    etau = 0.0
                    eJalt = np.nan
                eFc = buf[th0 + iFc]
                eFs = buf[th0 + iFc + 1]
                esig = buf[th0 + iFc + 2]
                levels = (math.isfinite(eJ) and math.isfinite(etau) and math.isfinite(esig)
                          and math.isfinite(eFc) and math.isfinite(eFs) and J_lo < eJ < J_hi
                          and 0.0 <= etau <= tau_max and esig >= 0.0 and 0.0 <= eFc <= ffmax
                          and 0.0 <= eFs <= ffmax)
                use = False
                if not levels:
                    n_impl += 1
                else:
                    cons = True
                    if etau >= 2.0 * dt and math.isfinite(eJalt):
                        diff = abs(eJalt * etau - eJ * etau)
                        if not diff <= consist * eJ * etau:
                            # delta method on theta_cov[:3, :3] = e2 * P[:3, :3]
                            g0 = -etau
                            g2 = -eJ
                            r1 = P0 + npar
                            r2 = P0 + 2 * npar
                            v0 = g0 * (e2 * buf[P0]) + 1.0 * (e2 * buf[r1]) + g2 * (e2 * buf[r2])
                            v1 = g0 * (e2 * buf[P0 + 1]) + 1.0 * (e2 * buf[r1 + 1]) + g2 * (e2 * buf[r2 + 1])
                            v2 = g0 * (e2 * buf[P0 + 2]) + 1.0 * (e2 * buf[r1 + 2]) + g2 * (e2 * buf[r2 + 2])
                            var = v0 * g0 + v1 * 1.0 + v2 * g2
                            cons = diff <= 3.0 * math.sqrt(max(var, 0.0))
                    if cons:
                        use = True
                        ff_held = 0.0
                    elif has_est:
                        n_held_lag += 1
                        etau = ftau
                        use = True
                        ff_held = 1.0
                    else:
                        n_impl += 1
                if use:
                    has_est = True
                    ftau = etau
                    falpha = 1.0 - math.exp(-dt / etau) if (fflag and etau > 0.0) else 1.0
                    fFc = eFc
                    fdF = eFs - eFc
                    fsig = esig
                    fVs = eVs
                    fdel = edel
                    fhas_vs = True
                    for i in range(npar):
                        FTH[i] = buf[th0 + i]
            if upd and TH.shape[0] > 0:
                for i in range(npar):
                    TH[nth, i] = buf[th0 + i]
                TK[nth] = k
                nth += 1
        elif mode == 4:  # CanudasCompensator.observe
            if not (math.isfinite(u) and math.isfinite(wm)):
                p_rej += 1
                c_ok = False
            else:
                if c_k % c_m == 0:
                    if c_has_prev and c_ok:
                        w0 = c_wprev
                        ubar = c_usum / c_m
                        use_row = False
                        if w0 > c_wd and wm > c_wd:
                            phi[0] = ubar
                            phi[1] = -w0
                            phi[2] = 0.0
                            phi[3] = -1.0
                            phi[4] = 0.0
                            use_row = True
                        elif w0 < -c_wd and wm < -c_wd:
                            phi[0] = ubar
                            phi[1] = 0.0
                            phi[2] = -w0
                            phi[3] = 0.0
                            phi[4] = 1.0
                            use_row = True
                        if use_row:
                            _update(buf, phi, wm - w0)
                            if buf[_NUPD] >= c_warm:
                                b = buf[th0]
                                cFcp = buf[th0 + 3] / b
                                cFcn = buf[th0 + 4] / b
                                csp = buf[th0 + 1] / b
                                csn = buf[th0 + 2] / b
                                c_on = True
                    c_wprev = wm
                    c_has_prev = True
                    c_usum = 0.0
                    c_ok = True
                c_usum += u
                c_k += 1
        elif mode == 5:  # DisturbanceObserver.observe
            if math.isfinite(u):
                q_ulast = u
        # ---- record and metrics (true velocity)
        if dec > 0 and k % dec == 0:
            r = k // dec
            W[r] = w
            WM[r] = wm
            U[r] = u
            UFF[r] = uff
            FF[r] = f
        et = wrk - w
        e2t = et * et
        # Neumaier-compensated sums
        q_ = se + e2t
        se_c += (se - q_) + e2t if abs(se) >= e2t else (e2t - q_) + se
        se = q_
        ae = abs(et)
        if ae > me:
            me = ae
        hk = tt[k] >= tmid
        rk = False
        if hk and nrev > 0:
            # loop_metrics: searchsorted(reversals, t), nearest reversal within the window
            while ip < nrev and revs[ip] < tt[k]:
                ip += 1
            i_lo = ip - 1 if ip >= 1 else 0
            i_hi = ip if ip < nrev else nrev - 1
            dlo = abs(tt[k] - revs[i_lo])
            dhi = abs(revs[i_hi] - tt[k])
            rk = min(dlo, dhi) <= window
        if hk:
            q_ = se2 + e2t
            se2_c += (se2 - q_) + e2t if abs(se2) >= e2t else (e2t - q_) + se2
            se2 = q_
            nh += 1
            if ae > me2:
                me2 = ae
            if rk:
                q_ = ser + e2t
                ser_c += (ser - q_) + e2t if abs(ser) >= e2t else (e2t - q_) + ser
                ser = q_
                nr += 1
        u2 = u * u
        q_ = su + u2
        su_c += (su - q_) + u2 if abs(su) >= u2 else (u2 - q_) + su
        su = q_
        # ---- plant: RK4 (plant.joint.lagged_rk4_step)
        w, f = _rk4_step(w, f, _F(w, Fc, dF, Vs, delta, sigma, d1, wcut), u, J, tau, dt, h2, h6,
                         Fc, dF, Vs, delta, sigma, d1, wcut)
        if not (-w_limit < w < w_limit):
            div = True
            k_end = k + 1
            break
    st[0] = k_end
    st[1] = 1.0 if div else 0.0
    st[2] = se
    st[3] = se_c
    st[4] = me
    st[5] = se2
    st[6] = se2_c
    st[7] = me2
    st[8] = nh
    st[9] = ser
    st[10] = ser_c
    st[11] = nr
    st[12] = su
    st[13] = su_c
    st[24] = n_samples
    st[25] = n_rej
    st[26] = n_gated
    st[27] = n_upd
    st[28] = buf[_NPROJ]
    st[29] = d2s
    st[30] = e2
    st[31] = w1
    st[32] = w2
    st[33] = nacc
    st[34] = 1.0 if has_est else 0.0
    st[35] = u_ff
    st[36] = gain
    st[37] = nib
    st[38] = n_impl
    st[39] = n_held_lag
    st[40] = ftau
    st[41] = ff_held
    st[42] = nth
    st[43] = p_rej
    st[44] = 1.0 if c_on else 0.0
    st[45] = c_k
    st[46] = c_usum
    st[47] = c_wprev
    st[48] = 1.0 if c_has_prev else 0.0
    st[49] = 1.0 if c_ok else 0.0
    st[50] = q_d
    st[51] = q_ulast
    st[52] = q_wlast
    st[53] = 1.0 if q_has else 0.0


def run_loop_kernel(*, wr, noise, faults, PL, s0, seg=0, G, mode, ffp, fixed_est, ep, pp, rls_buf, n_params, gp,
                    use_gate, t, reversals, window, decimate, w_limit, n_theta_max):
    """Run :func:`_kernel` on prepared arrays (internal; called by ``run_closed_loop``).

    Parameters
    ----------
    wr : ndarray, shape (N,)
        Reference velocity (rad/s).
    noise : ndarray, shape (N,) or None
        Measurement noise (rad/s).
    faults : tuple (ndarray int, ndarray float) or None
        Sorted sample indices and the measured values injected there.
    PL : ndarray, shape (7,) or (K, 7)
        Plant ``J, Fc, Fs - Fc, Vs, delta, sigma, tau`` (two columns are
        appended here: ``delta == 1`` and the cut-off speed of
        :func:`controllers.simulation.batch._wcut`); K rows for a drifting plant.
    s0 : float
        Initial friction state (N·m).
    seg : int
        Drift: row ``j`` of ``PL`` is used from sample ``j*seg`` on; 0 = one row.
    G : ndarray, shape (4,)
        ``Kp, Ki*Tc, u_max, Tc``.
    mode : int
        0 ``none``/``frictionless`` (on the frictionless plant), 1 ``oracle``, 2 ``fixed``, 3 ``adaptive``,
        4 ``canudas``, 5 ``dob``.
    ffp, fixed_est, ep, pp : ndarray
        Feedforward settings, fixed estimate, estimator settings, peer settings (see :func:`_kernel`).
    rls_buf : ndarray
        State buffer of the estimator's (or the Canudas peer's) :class:`adaptive_ff.identification.rls.RecursiveLeastSquares`
        (updated in place by the RLS kernel of that module).
    n_params : int
        Number of RLS parameters ``p``.
    gp : ndarray, shape (8,)
        Sensor gate and estimator gate settings (max_step, n_sigma, alpha, max_consecutive).
    use_gate : bool
        Sensor gate on.
    t : ndarray, shape (N,)
        Time (s).
    reversals : ndarray, shape (R,)
        Reference reversal times (s), sorted.
    window : float
        Half-width of the reversal windows (s).
    decimate : int
        Keep every ``decimate``-th sample of the signals; 0 keeps none.
    w_limit : float
        Divergence bound (rad/s).
    n_theta_max : int
        Capacity of the theta history (0: none kept).

    Returns
    -------
    dict
        Signals (``W, WM, U, UFF, F``), theta history (``TH``, ``TK``), final
        estimate in use (``FTH``) and the state vector ``st`` (slots :data:`ST`).
    """
    n = wr.shape[0]
    PL = np.atleast_2d(np.asarray(PL, dtype=float))
    extra = [[1.0 if row[4] == 1.0 else 0.0, _wcut(row[1], row[2], row[3], row[4])] for row in PL.tolist()]
    PL = np.ascontiguousarray(np.hstack([PL, np.array(extra).reshape(-1, 2)]))
    n_rec = (n + decimate - 1) // decimate if decimate > 0 else 0
    sig = [np.full(n_rec, np.nan) for _ in range(5)]
    npar = int(n_params)
    TH = np.empty((n_theta_max, npar))
    TK = np.empty(n_theta_max, dtype=np.int64)
    FTH = np.full(npar, np.nan)
    st = np.zeros(_NST)
    has_noise = noise is not None
    nz = noise if has_noise else np.zeros(1)
    if faults is None:
        fk, fv = np.empty(0, dtype=np.int64), np.empty(0)
    else:
        fk, fv = faults
    _kernel(wr, nz, has_noise, fk, fv, PL, int(seg), float(s0), G, mode, ffp, fixed_est, ep, pp, rls_buf, npar, gp,
            bool(use_gate), t, np.asarray(reversals, dtype=float), float(window), 0.5 * (t[0] + t[-1]),
            int(decimate), float(w_limit), sig[0], sig[1], sig[2], sig[3], sig[4], TH, TK, FTH, st)
    nth = int(st[ST["n_theta"]])
    return dict(W=sig[0], WM=sig[1], U=sig[2], UFF=sig[3], F=sig[4], TH=TH[:nth], TK=TK[:nth], FTH=FTH, st=st)
