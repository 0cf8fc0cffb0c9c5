"""Compiled (numba) batch kernel: B closed-loop scenarios without an online estimator, metrics streamed.

Replicates :func:`controllers.simulation.closed_loop.run_closed_loop` with ``sensor_gate=False``
and no faults for the modes ``none``, ``frictionless``, ``oracle`` and ``fixed``
(plant: :func:`plant.joint.make_rk4_step`; PI: :meth:`controllers.design.pi.PIController.step`;
fixed feedforward: :class:`adaptive_ff.compensation.feedforward.FrictionFeedforward` with
``stick_band = 0``). Memory is O(B) apart from optional noise arrays.

Speed (issue 5): the scenarios are cut into chunks (prange over chunks); a chunk
is stepped time-major, i.e. at every step each scenario of the chunk advances
once, so the CPU overlaps the independent, latency-bound RK4 chains of several
scenarios. Eq. 3 skips ``pow`` for ``delta == 1`` and ``pow``/``exp`` where the
Stribeck term is below half an ulp of ``Fc`` (:func:`_wcut`); both shortcuts are
bit-exact, and the state update performs the same floating-point operations in
the same order as the Python loop (only the metrics are summed differently), so
the results equal ``run_closed_loop`` to rounding (tested to 1e-9). ``fastmath``
is not used: it would reorder the operations, and round-off differences grow
where the velocity chatters around zero.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numba import prange

from plant.jit import kernel

from plant.errors import ParameterError, check_nonnegative, check_positive
from plant.excitation import Reference
from plant.friction import JointParams

__all__ = ["BATCH_MODES", "BatchResult", "run_batch"]

#: Modes supported by the batch kernel (no online estimator).
BATCH_MODES = ("none", "frictionless", "oracle", "fixed")
_MODE_CODE = {"none": 0, "frictionless": 0, "oracle": 1, "fixed": 2}
#: Scenarios per chunk (at most; at least _CHUNK_MIN, else B / threads): a chunk is stepped
#: time-major by one thread (see :func:`_chunk`).
_CHUNK = 64
_CHUNK_MIN = 8


@dataclass(frozen=True)
class BatchResult:
    """Metrics of B closed-loop runs, each array of shape (B,); definitions of
    :class:`controllers.simulation.closed_loop.LoopMetrics` (velocity error ``e = w_ref - w``, rad/s).

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


@kernel(inline="always")
def _F(w, Fc, dF, Vs, delta, sigma, d1, wcut):
    """Eq. 3, bit for bit as :func:`plant.joint._friction_scalar`, with two exact shortcuts.

    ``d1``: ``delta == 1``, where ``x**1.0 == x`` exactly, so ``pow`` is skipped.
    ``|w| > wcut``: ``|dF|*exp(-(|w|/Vs)**delta)`` is below half an ulp of ``Fc``
    (or ``exp`` underflows to 0), so ``Fc + dF*exp(...)`` rounds to ``Fc`` and the
    ``pow``/``exp`` are skipped (see :func:`_wcut`).
    """
    if w > 0.0:
        if w > wcut:
            return Fc + sigma * w
        x = w / Vs
        if not d1:
            x = x ** delta
        return Fc + dF * math.exp(-x) + sigma * w
    if w < 0.0:
        if -w > wcut:
            return -Fc + sigma * w
        x = -w / Vs
        if not d1:
            x = x ** delta
        return -(Fc + dF * math.exp(-x)) + sigma * w
    return 0.0


@kernel(inline="always")
def _rk4_step(w, f, Fw, u, J, tau, dt, h2, h6, Fc, dF, Vs, delta, sigma, d1, wcut):
    """One classic RK4 step of ``J*dw/dt = u - f``, ``tau*df/dt + f = F(w)`` (eqs. 1-3), bit for bit as
    :func:`plant.joint.lagged_rk4_step`; the one RK4 step of every compiled kernel.

    ``Fw`` is ``F(w)`` (eq. 3, :func:`_F`) at the start of the step, passed in so a caller can reuse
    the value from the previous step; ``h2 = dt/2``, ``h6 = dt/6``. With ``tau == 0`` the friction is
    algebraic (RK4 on ``w`` alone) and the returned ``f`` is ``F`` at the new ``w``. Returns ``(w, f)``.
    """
    if tau == 0.0:
        k1 = (u - Fw) / J
        k2 = (u - _F(w + h2 * k1, Fc, dF, Vs, delta, sigma, d1, wcut)) / J
        k3 = (u - _F(w + h2 * k2, Fc, dF, Vs, delta, sigma, d1, wcut)) / J
        k4 = (u - _F(w + dt * k3, Fc, dF, Vs, delta, sigma, d1, wcut)) / J
        w = w + h6 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        return w, _F(w, Fc, dF, Vs, delta, sigma, d1, wcut)
    k1w = (u - f) / J
    k1f = (Fw - f) / tau
    wa = w + h2 * k1w
    fa = f + h2 * k1f
    k2w = (u - fa) / J
    k2f = (_F(wa, Fc, dF, Vs, delta, sigma, d1, wcut) - fa) / tau
    wb = w + h2 * k2w
    fb = f + h2 * k2f
    k3w = (u - fb) / J
    k3f = (_F(wb, Fc, dF, Vs, delta, sigma, d1, wcut) - fb) / tau
    wc = w + dt * k3w
    fc = f + dt * k3f
    k4w = (u - fc) / J
    k4f = (_F(wc, Fc, dF, Vs, delta, sigma, d1, wcut) - fc) / tau
    return (w + h6 * (k1w + 2.0 * k2w + 2.0 * k3w + k4w),
            f + h6 * (k1f + 2.0 * k2f + 2.0 * k3f + k4f))


@kernel(inline="always")
def _pi_step(I, e, Kp, KiTc, umax, uff):
    """One step of :meth:`controllers.design.pi.PIController.step` (clamping anti-windup), bit for bit.

    ``I``: integrator state (N·m); ``e``: velocity error (rad/s); ``KiTc = Ki*Tc``; ``uff``:
    feedforward (N·m). The integrator moves only as far as keeps ``Kp*e + I + uff`` inside
    ``±umax`` (never past its old value). Returns ``(I_new, u)`` with ``u`` saturated to ``±umax``.
    """
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
    v = Kpe + In + uff
    if v >= umax:
        return In, umax
    if v <= -umax:
        return In, -umax
    return In, v


def _wcut(Fc: float, dF: float, Vs: float, delta: float) -> float:
    """Speed above which ``Fc + dF*exp(-(|w|/Vs)**delta)`` equals ``Fc`` exactly in float64.

    ``Fc + d == Fc`` when ``|d| < ulp(Fc)/2``, and ``ulp(Fc)/2 >= Fc*2**-54``; so
    ``(|w|/Vs)**delta > log(|dF|/Fc) + 54*log(2)`` suffices (plus a margin of 1).
    With ``Fc == 0`` only an underflow of ``exp`` (argument > 745.2) is exact.
    """
    if not (Vs > 0.0 and 0.0 < delta < math.inf and math.isfinite(Fc) and math.isfinite(dF)):
        return math.inf  # (an odd estimate) never take the shortcut
    if dF == 0.0:
        return 0.0
    xcut = 746.0 if Fc == 0.0 else max(math.log(abs(dF) / abs(Fc)) + 54.0 * math.log(2.0) + 1.0, 0.0)
    return Vs * xcut ** (1.0 / delta) * (1.0 + 1e-9)


@kernel(parallel=True)
def _kernel(P, G, E, wr, half, rev, noise, noise_rows, s0, mode, ff_ref, dt, w_limit, out, chunk):
    """Run all scenarios: prange over chunks of ``chunk`` scenarios (see :func:`_chunk`)."""
    B = P.shape[0]
    nchunks = (B + chunk - 1) // chunk
    for c in prange(nchunks):
        b0 = c * chunk
        _chunk(P, G, E, wr, half, rev, noise, noise_rows, s0, mode, ff_ref, dt, w_limit, out, b0,
               min(B, b0 + chunk))


@kernel
def _kernel_serial(P, G, E, wr, half, rev, noise, noise_rows, s0, mode, ff_ref, dt, w_limit, out, chunk):
    """:func:`_kernel` on the calling thread (one chunk, or one numba thread: no parallel-region cost)."""
    B = P.shape[0]
    nchunks = (B + chunk - 1) // chunk
    for c in range(nchunks):
        b0 = c * chunk
        _chunk(P, G, E, wr, half, rev, noise, noise_rows, s0, mode, ff_ref, dt, w_limit, out, b0,
               min(B, b0 + chunk))


@kernel
def _chunk(P, G, E, wr, half, rev, noise, noise_rows, s0, mode, ff_ref, dt, w_limit, out, b0, b1):
    """Scenarios b0..b1-1, time-major: at each step every scenario of the chunk advances once.

    One RK4 step is a long chain of dependent divisions, ``pow`` and ``exp`` (latency
    bound); stepping the independent scenarios of a chunk one after the other lets
    the CPU overlap their chains. The state of the chunk lives in small contiguous
    arrays (scenario-major).
    """
    L = b1 - b0
    n = wr.shape[0]
    h2 = dt / 2.0
    h6 = dt / 6.0
    W = np.empty(L)
    Fst = np.empty(L)
    Ist = np.zeros(L)
    U = np.zeros(L)  # feedforward filter state
    FW = np.empty(L)  # F(w) at the current w (tau == 0: the f of the previous step)
    SE = np.zeros(L)
    SE2 = np.zeros(L)
    SER = np.zeros(L)
    SU = np.zeros(L)
    ME = np.zeros(L)
    ME2 = np.zeros(L)
    alive = np.ones(L, dtype=np.bool_)
    D1 = np.empty(L, dtype=np.bool_)
    WC = np.empty(L)
    ED1 = np.empty(L, dtype=np.bool_)
    EWC = np.empty(L)
    for l in range(L):
        b = b0 + l
        W[l] = wr[0]
        Fst[l] = s0[b]
        D1[l] = P[b, 4] == 1.0
        WC[l] = P[b, 7]
        ED1[l] = E[b, 3] == 1.0
        EWC[l] = E[b, 9]
    nh = 0
    nr = 0
    n_alive = L
    for k in range(n):
        if n_alive == 0:
            break
        wrk = wr[k]
        hk = half[k]
        rk = rev[k]
        if hk:
            nh += 1
        if rk:
            nr += 1
        for l in range(L):
            if not alive[l]:
                continue
            b = b0 + l
            J, Fc, dF, Vs, delta, sigma, tau = P[b, 0], P[b, 1], P[b, 2], P[b, 3], P[b, 4], P[b, 5], P[b, 6]
            d1 = D1[l]
            wcut = WC[l]
            w = W[l]
            f = Fst[l]
            if noise_rows > 1:
                wm = w + noise[b, k]
            elif noise_rows == 1:
                wm = w + noise[0, k]
            else:
                wm = w
            if mode == 1:
                uff = f
            elif mode == 2:
                x = wrk if ff_ref else wm
                if x == 0.0:
                    st = 0.0
                else:
                    ax = abs(x)
                    eFc = E[b, 0]
                    if E[b, 8] > 0.0 and ax <= EWC[l]:
                        xx = ax / E[b, 2]
                        if not ED1[l]:
                            xx = xx ** E[b, 3]
                        mag = eFc + E[b, 1] * math.exp(-xx)
                    else:
                        mag = eFc
                    sw = E[b, 7]
                    if sw > 0.0 and ax < sw:
                        st = mag * (x / sw) + E[b, 4] * x
                    else:
                        st = math.copysign(mag, x) + E[b, 4] * x
                us = U[l]
                us += E[b, 5] * (st - us)
                U[l] = us
                ffmax = E[b, 6]
                uff = min(max(us, -ffmax), ffmax)
            else:
                uff = 0.0
            # PIController.step
            Kp, KiTc, umax = G[b, 0], G[b, 1], G[b, 2]
            Ist[l], u = _pi_step(Ist[l], wrk - wm, Kp, KiTc, umax, uff)
            # metrics (true velocity)
            et = wrk - w
            e2 = et * et
            SE[l] += e2
            ae = abs(et)
            if ae > ME[l]:
                ME[l] = ae
            if hk:
                SE2[l] += e2
                if ae > ME2[l]:
                    ME2[l] = ae
                if rk:
                    SER[l] += e2
            SU[l] += u * u
            # RK4 (plant.joint.lagged_rk4_step); with tau = 0 F(w) is the friction of the previous step's end
            if tau == 0.0 and k > 0:
                Fw = FW[l]
            else:
                Fw = _F(w, Fc, dF, Vs, delta, sigma, d1, wcut)
            w, f = _rk4_step(w, f, Fw, u, J, tau, dt, h2, h6, Fc, dF, Vs, delta, sigma, d1, wcut)
            if tau == 0.0:
                FW[l] = f
            W[l] = w
            Fst[l] = f
            if not (-w_limit < w < w_limit):
                alive[l] = False
                n_alive -= 1
    nan = np.nan
    for l in range(L):
        b = b0 + l
        if not alive[l]:
            for j in range(6):
                out[b, j] = nan
            out[b, 6] = 1.0
        else:
            out[b, 0] = math.sqrt(SE[l] / n)
            out[b, 1] = ME[l]
            out[b, 2] = math.sqrt(SE2[l] / nh) if nh > 0 else nan
            out[b, 3] = ME2[l]
            out[b, 4] = math.sqrt(SER[l] / nr) if nr > 0 else nan
            out[b, 5] = math.sqrt(SU[l] / n)
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
        Compensation mode, see :func:`controllers.simulation.closed_loop.run_closed_loop`.
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
        As in :class:`adaptive_ff.compensation.feedforward.FrictionFeedforward` and
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
    Scenarios run in chunks of at most 64 (``prange`` over chunks on all numba
    threads; one chunk or one thread runs serially); each scenario's result does
    not depend on B or the chunking (bit for bit).
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
    P = np.array([[p.J, p.Fc, p.Fs - p.Fc, p.Vs, p.delta, p.sigma, p.tau, _wcut(p.Fc, p.Fs - p.Fc, p.Vs, p.delta)]
                  for p in plants], dtype=float)
    s0 = np.array([p.initial_state(float(wr[0])) for p in plants], dtype=float)
    G = np.column_stack([Kp, Ki * Tc, u_max])

    E = np.zeros((B, 10))
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
                    alpha, ffm[b], sign_width, 1.0 if has else 0.0,
                    _wcut(est.Fc, est.Fs - est.Fc, est.Vs, est.delta) if has else 0.0]

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

    # the masks of controllers.simulation.closed_loop.loop_metrics (imported here: closed_loop imports this module)
    from controllers.simulation.closed_loop import _metric_masks

    half, mask = _metric_masks(t, np.asarray(reference.reversals()), reversal_window)
    out = np.empty((B, 7))
    # noise_rows: 0 none, 1 shared row, >1 per-scenario (B == 1 with own row also works as 1)
    threads = numba.get_num_threads()
    chunk = max(_CHUNK_MIN, min(_CHUNK, -(-B // threads)))
    kernel = _kernel_serial if (threads == 1 or B <= chunk) else _kernel
    kernel(P, G, E, wr, half, mask, nz, rows if rows <= 1 or B > 1 else 1, s0, _MODE_CODE[mode],
           ff_input == "reference", Tc, w_limit, out, chunk)
    return BatchResult(mode=mode, rms=out[:, 0].copy(), max=out[:, 1].copy(), rms_second_half=out[:, 2].copy(),
                       max_second_half=out[:, 3].copy(), rms_reversal=out[:, 4].copy(), u_rms=out[:, 5].copy(),
                       diverged=out[:, 6] > 0.5)
