"""Compiled (numba) batch kernel: B closed-loop scenarios without an online estimator, metrics streamed.

Replicates :func:`controllers.closed_loop.run_closed_loop` with ``sensor_gate=False``
and no faults for the modes ``none``, ``frictionless``, ``oracle`` and ``fixed``
(plant: :func:`plant.joint.make_rk4_step`; PI: :meth:`controllers.pi.PIController.step`;
fixed feedforward: :class:`adaptive_ff.feedforward.FrictionFeedforward` with
``stick_band = 0``). Memory is O(B) apart from optional noise arrays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit, prange

from plant.errors import ParameterError, check_nonnegative, check_positive
from plant.excitation import Reference
from plant.friction import JointParams

__all__ = ["BATCH_MODES", "BatchResult", "run_batch"]

#: Modes supported by the batch kernel (no online estimator).
BATCH_MODES = ("none", "frictionless", "oracle", "fixed")
_MODE_CODE = {"none": 0, "frictionless": 0, "oracle": 1, "fixed": 2}


@dataclass(frozen=True)
class BatchResult:
    """Metrics of B closed-loop runs, each array of shape (B,); definitions of
    :class:`controllers.closed_loop.LoopMetrics` (velocity error ``e = w_ref - w``, rad/s).

    Attributes
    ----------
    mode : str
    rms, max, rms_second_half, max_second_half, rms_reversal : ndarray, shape (B,)
        Error metrics (rad/s); NaN for diverged runs.
    u_rms : ndarray, shape (B,)
        RMS control torque (N·m); NaN for diverged runs.
    diverged : ndarray of bool, shape (B,)
        |w| left ``w_limit``.
    """

    mode: str
    rms: np.ndarray
    max: np.ndarray
    rms_second_half: np.ndarray
    max_second_half: np.ndarray
    rms_reversal: np.ndarray
    u_rms: np.ndarray
    diverged: np.ndarray


@njit(cache=True, inline="always")
def _F(w, Fc, dF, Vs, delta, sigma):
    if w > 0.0:
        return Fc + dF * math.exp(-((w / Vs) ** delta)) + sigma * w
    if w < 0.0:
        return -(Fc + dF * math.exp(-((-w / Vs) ** delta))) + sigma * w
    return 0.0


@njit(cache=True, parallel=True)
def _kernel(P, G, E, wr, half, rev, noise, noise_rows, s0, mode, ff_ref, dt, w_limit, out):
    B = P.shape[0]
    n = wr.shape[0]
    h2 = dt / 2.0
    h6 = dt / 6.0
    for b in prange(B):
        J, Fc, dF, Vs, delta, sigma, tau = P[b, 0], P[b, 1], P[b, 2], P[b, 3], P[b, 4], P[b, 5], P[b, 6]
        Kp, KiTc, umax = G[b, 0], G[b, 1], G[b, 2]
        eFc, edF, eVs, edelta, esig, alpha, ffmax, sw, has_vs = (E[b, 0], E[b, 1], E[b, 2], E[b, 3], E[b, 4],
                                                                 E[b, 5], E[b, 6], E[b, 7], E[b, 8])
        row = np.int64(0)
        if noise_rows > 1:
            row = np.int64(b)
        w = wr[0]
        f = s0[b]
        I = 0.0
        uff_state = 0.0
        se = 0.0
        se2 = 0.0
        ser = 0.0
        su = 0.0
        me = 0.0
        me2 = 0.0
        nh = 0
        nr = 0
        div = False
        for k in range(n):
            wm = w + noise[row, k] if noise_rows > 0 else w
            wrk = wr[k]
            if mode == 1:
                uff = f
            elif mode == 2:
                x = wrk if ff_ref else wm
                if x == 0.0:
                    st = 0.0
                else:
                    ax = abs(x)
                    if has_vs > 0.0:
                        mag = eFc + edF * math.exp(-((ax / eVs) ** edelta))
                    else:
                        mag = eFc
                    if sw > 0.0 and ax < sw:
                        st = mag * (x / sw) + esig * x
                    else:
                        st = math.copysign(mag, x) + esig * x
                uff_state += alpha * (st - uff_state)
                uff = min(max(uff_state, -ffmax), ffmax)
            else:
                uff = 0.0
            # PIController.step
            e = wrk - wm
            Kpe = Kp * e
            d = KiTc * e
            In = I + d
            if d > 0.0:
                lim = umax - Kpe - uff
                if In > lim:
                    In = lim if lim > I else I
            elif d < 0.0:
                lim = -umax - Kpe - uff
                if In < lim:
                    In = lim if lim < I else I
            I = In
            v = Kpe + In + uff
            if v >= umax:
                u = umax
            elif v <= -umax:
                u = -umax
            else:
                u = v
            # metrics (true velocity)
            et = wrk - w
            e2 = et * et
            se += e2
            ae = abs(et)
            if ae > me:
                me = ae
            if half[k]:
                se2 += e2
                nh += 1
                if ae > me2:
                    me2 = ae
                if rev[k]:
                    ser += e2
            if rev[k]:
                nr += 1
            su += u * u
            # RK4 (plant.joint.lagged_rk4_step)
            if tau == 0.0:
                k1 = (u - _F(w, Fc, dF, Vs, delta, sigma)) / J
                k2 = (u - _F(w + h2 * k1, Fc, dF, Vs, delta, sigma)) / J
                k3 = (u - _F(w + h2 * k2, Fc, dF, Vs, delta, sigma)) / J
                k4 = (u - _F(w + dt * k3, Fc, dF, Vs, delta, sigma)) / J
                w = w + h6 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
                f = _F(w, Fc, dF, Vs, delta, sigma)
            else:
                k1w = (u - f) / J
                k1f = (_F(w, Fc, dF, Vs, delta, sigma) - f) / tau
                w2 = w + h2 * k1w
                f2 = f + h2 * k1f
                k2w = (u - f2) / J
                k2f = (_F(w2, Fc, dF, Vs, delta, sigma) - f2) / tau
                w3 = w + h2 * k2w
                f3 = f + h2 * k2f
                k3w = (u - f3) / J
                k3f = (_F(w3, Fc, dF, Vs, delta, sigma) - f3) / tau
                w4 = w + dt * k3w
                f4 = f + dt * k3f
                k4w = (u - f4) / J
                k4f = (_F(w4, Fc, dF, Vs, delta, sigma) - f4) / tau
                w, f = (w + h6 * (k1w + 2.0 * k2w + 2.0 * k3w + k4w),
                        f + h6 * (k1f + 2.0 * k2f + 2.0 * k3f + k4f))
            if not (-w_limit < w < w_limit):
                div = True
                break
        nan = np.nan
        if div:
            for j in range(6):
                out[b, j] = nan
            out[b, 6] = 1.0
        else:
            out[b, 0] = math.sqrt(se / n)
            out[b, 1] = me
            out[b, 2] = math.sqrt(se2 / nh) if nh > 0 else nan
            out[b, 3] = me2
            out[b, 4] = math.sqrt(ser / nr) if nr > 0 else nan
            out[b, 5] = math.sqrt(su / n)
            out[b, 6] = 0.0


def _per_scenario(name, value, B, *, positive=True):
    a = np.asarray(value, dtype=float)
    if a.ndim == 0:
        a = np.full(B, float(a))
    if a.shape != (B,):
        raise ParameterError(f"{name} must be a scalar or have shape ({B},), got shape {a.shape}")
    if positive and not np.all(a > 0.0):
        raise ParameterError(f"{name} must be > 0, got {a[~(a > 0.0)][:3].tolist()}")
    if np.any(np.isnan(a)):
        raise ParameterError(f"{name} must not be NaN")
    return a


def run_batch(plants, reference: Reference, *, mode: str, Kp, Ki, u_max=math.inf, Tc: float = 1e-3,
              noise_std: float = 0.0, seeds=None, noise=None, estimate=None, lag: bool = True, ff_max=None,
              ff_input: str = "measured", sign_width: float = 0.0, reversal_window: float = 0.2,
              w_limit: float | None = None) -> BatchResult:
    """Run B closed loops (one per plant) on a common reference with the compiled kernel.

    Parameters
    ----------
    plants : sequence of JointParams, length B
        True plants (lagged Stribeck, eqs. 1-3 of Ruderman).
    reference : Reference
        Velocity reference sampled at ``Tc``, shared by all scenarios.
    mode : {"none", "frictionless", "oracle", "fixed"}, keyword-only
        Compensation mode, see :func:`controllers.closed_loop.run_closed_loop`.
    Kp, Ki, u_max : float or ndarray, shape (B,), keyword-only
        PI gains (N·m·s/rad, N·m/rad) and torque limit (N·m, inf = none).
    Tc : float, keyword-only
        Controller period = RK4 step (s).
    noise_std : float, keyword-only
        Velocity-noise std (rad/s); with ``seeds`` the noise of scenario b is
        ``np.random.default_rng(seeds[b]).normal(0, noise_std, N)``, exactly as
        ``run_closed_loop(rng=np.random.default_rng(seeds[b]))`` (memory B*N).
    seeds : sequence of int, length B, keyword-only
        Noise seeds (needed when ``noise_std > 0`` and ``noise`` is None).
    noise : ndarray, shape (N,) or (B, N), keyword-only
        Explicit measurement noise (rad/s), overrides ``noise_std``/``seeds``.
    estimate : FrictionEstimate or sequence of them, keyword-only
        Offline estimate(s) for ``fixed``.
    lag, ff_max, ff_input, sign_width : keyword-only
        As in :class:`adaptive_ff.feedforward.FrictionFeedforward` and
        ``run_closed_loop`` (``ff_max`` default ``u_max``).
    reversal_window, w_limit : keyword-only
        As in ``run_closed_loop``.

    Returns
    -------
    BatchResult

    Raises
    ------
    ParameterError
        Bad mode, shapes, values, or a missing estimate/seeds (message names the argument).

    Notes
    -----
    Equals ``run_closed_loop(p, reference, ..., sensor_gate=False)`` (no faults,
    no ``stick_band``) up to floating-point summation order of the metrics.
    """
    if mode not in BATCH_MODES:
        raise ParameterError(f"mode must be one of {BATCH_MODES}, got {mode!r}")
    plants = list(plants)
    B = len(plants)
    if B == 0:
        raise ParameterError("plants must contain at least one JointParams, got an empty sequence")
    for i, p in enumerate(plants):
        if not isinstance(p, JointParams):
            raise ParameterError(f"plants[{i}] must be JointParams, got {type(p).__name__}")
    Tc = check_positive("Tc", Tc)
    noise_std = check_nonnegative("noise_std", noise_std)
    if ff_input not in ("reference", "measured"):
        raise ParameterError(f"ff_input must be 'reference' or 'measured', got {ff_input!r}")
    sign_width = check_nonnegative("sign_width", sign_width)
    t = np.asarray(reference.t, dtype=float)
    wr = np.ascontiguousarray(reference.w, dtype=float)
    n = t.shape[0]
    if n > 1 and not math.isclose(t[1] - t[0], Tc, rel_tol=1e-9):
        raise ParameterError(f"reference step {t[1] - t[0]!r} s differs from Tc = {Tc!r} s")
    Kp = _per_scenario("Kp", Kp, B)
    Ki = _per_scenario("Ki", Ki, B)
    u_max = _per_scenario("u_max", u_max, B)
    ffm = u_max if ff_max is None else _per_scenario("ff_max", ff_max, B, positive=False)
    if np.any(ffm < 0):
        raise ParameterError(f"ff_max must be >= 0, got {ff_max!r}")
    if w_limit is None:
        w_limit = 100.0 * float(np.max(np.abs(wr))) + 1.0
    w_limit = check_positive("w_limit", w_limit)

    if mode == "frictionless":
        plants = [p.frictionless() for p in plants]
    P = np.array([[p.J, p.Fc, p.Fs - p.Fc, p.Vs, p.delta, p.sigma, p.tau] for p in plants], dtype=float)
    s0 = np.array([p.initial_state(float(wr[0])) for p in plants], dtype=float)
    G = np.column_stack([Kp, Ki * Tc, u_max])

    E = np.zeros((B, 9))
    if mode == "fixed":
        if estimate is None:
            raise ParameterError("mode 'fixed' needs estimate=FrictionEstimate (or a sequence of B of them)")
        ests = list(estimate) if isinstance(estimate, (list, tuple)) else [estimate] * B
        if len(ests) != B:
            raise ParameterError(f"estimate must be one FrictionEstimate or {B} of them, got {len(ests)}")
        for b, est in enumerate(ests):
            alpha = 1.0 - math.exp(-Tc / est.tau) if (lag and est.tau > 0) else 1.0
            has = est.Vs is not None
            E[b] = [est.Fc, est.Fs - est.Fc, est.Vs if has else 1.0, est.delta if has else 1.0, est.sigma,
                    alpha, ffm[b], sign_width, 1.0 if has else 0.0]

    if noise is not None:
        nz = np.asarray(noise, dtype=float)
        if nz.ndim == 1:
            nz = nz[None, :]
        if nz.ndim != 2 or nz.shape[1] != n or nz.shape[0] not in (1, B):
            raise ParameterError(f"noise must have shape ({n},) or ({B}, {n}), got {np.shape(noise)}")
        if not np.all(np.isfinite(nz)):
            raise ParameterError("noise must be finite")
        rows = nz.shape[0] if nz.shape[0] > 1 else 1
    elif noise_std > 0:
        if seeds is None or len(seeds) != B:
            raise ParameterError(f"noise_std > 0 needs seeds (length {B}) or noise=, got seeds={seeds!r}")
        nz = np.stack([np.random.default_rng(s).normal(0.0, noise_std, size=n) for s in seeds])
        rows = B
    else:
        nz = np.zeros((1, 1))
        rows = 0
    if rows == 1 and B == 1:
        rows = 1
    nz = np.ascontiguousarray(nz)

    half = t >= 0.5 * (t[0] + t[-1])
    revs = np.asarray(reference.reversals())
    mask = np.zeros_like(half)
    if len(revs):
        idx = np.searchsorted(revs, t)
        lo = np.abs(t - revs[np.clip(idx - 1, 0, len(revs) - 1)])
        hi = np.abs(revs[np.clip(idx, 0, len(revs) - 1)] - t)
        mask = (np.minimum(lo, hi) <= reversal_window) & half
    out = np.empty((B, 7))
    # noise_rows: 0 none, 1 shared row, >1 per-scenario (B == 1 with own row also works as 1)
    _kernel(P, G, E, wr, half, mask, nz, rows if rows <= 1 or B > 1 else 1, s0, _MODE_CODE[mode],
            ff_input == "reference", Tc, w_limit, out)
    return BatchResult(mode=mode, rms=out[:, 0].copy(), max=out[:, 1].copy(), rms_second_half=out[:, 2].copy(),
                       max_second_half=out[:, 3].copy(), rms_reversal=out[:, 4].copy(), u_rms=out[:, 5].copy(),
                       diverged=out[:, 6] > 0.5)
