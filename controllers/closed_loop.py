"""Closed-loop velocity control of the simulated joint with friction compensation modes, and their metrics."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from adaptive_ff.feedforward import AdaptiveFrictionFeedforward, FrictionFeedforward
from adaptive_ff.regression import FrictionEstimate, RegressionModel
from controllers.pi import PIController
from plant.errors import ParameterError, check_nonnegative, check_positive
from plant.excitation import Reference
from plant.friction import JointParams
from plant.joint import make_rk4_step

__all__ = ["MODES", "LoopMetrics", "ClosedLoopResult", "run_closed_loop", "loop_metrics"]

#: Compensation modes: no feedforward, fixed offline estimate, online RLS,
#: true friction state (upper bound), and the frictionless plant (limit).
MODES = ("none", "fixed", "adaptive", "oracle", "frictionless")


@dataclass(frozen=True)
class LoopMetrics:
    """Tracking metrics of one closed-loop run (velocity error ``e = w_ref - w``, rad/s).

    Attributes
    ----------
    rms, max : float
        RMS and max |e| over the whole run.
    rms_second_half, max_second_half : float
        The same over the second half (after adaptation transients).
    rms_reversal : float
        RMS of e within ``±window`` s of the reference reversals (second half).
    u_rms : float
        RMS control effort (N·m).
    """

    rms: float
    max: float
    rms_second_half: float
    max_second_half: float
    rms_reversal: float
    u_rms: float

    def to_dict(self) -> dict:
        """Plain-float dict."""
        return {k: float(v) for k, v in self.__dict__.items()}


def loop_metrics(t, w_ref, w, u, *, reversals, window: float = 0.2) -> LoopMetrics:
    """Compute :class:`LoopMetrics` from time series.

    Parameters
    ----------
    t, w_ref, w, u : ndarray, shape (N,)
        Time (s), reference and actual velocity (rad/s), control torque (N·m).
    reversals : ndarray, shape (R,)
        Reversal times of the reference (s).
    window : float, keyword-only
        Half-width of the reversal windows (s).

    Returns
    -------
    LoopMetrics
    """
    e = np.asarray(w_ref) - np.asarray(w)
    half = t >= 0.5 * (t[0] + t[-1])
    mask = np.zeros_like(half)
    if len(reversals):
        idx = np.searchsorted(reversals, t)
        lo = np.abs(t - reversals[np.clip(idx - 1, 0, len(reversals) - 1)])
        hi = np.abs(reversals[np.clip(idx, 0, len(reversals) - 1)] - t)
        mask = (np.minimum(lo, hi) <= window) & half
    rms = lambda x: float(np.sqrt(np.mean(x**2))) if x.size else float("nan")  # noqa: E731
    return LoopMetrics(rms=rms(e), max=float(np.max(np.abs(e))), rms_second_half=rms(e[half]),
                       max_second_half=float(np.max(np.abs(e[half]))), rms_reversal=rms(e[mask]),
                       u_rms=rms(np.asarray(u)))


@dataclass(frozen=True)
class ClosedLoopResult:
    """One closed-loop run.

    Attributes
    ----------
    mode : str
        Compensation mode (one of :data:`MODES`).
    t : ndarray, shape (N,)
        Time (s) at the controller rate.
    w_ref, w, w_meas : ndarray, shape (N,)
        Reference, true and measured velocity (rad/s).
    u, u_ff : ndarray, shape (N,)
        Total (saturated) control torque and its feedforward part (N·m).
    f : ndarray, shape (N,)
        True friction torque state of the plant (N·m).
    t_theta : ndarray, shape (M,)
        Times of the RLS updates (adaptive mode; empty otherwise).
    theta : ndarray, shape (M, p)
        RLS parameter history (adaptive mode).
    estimate : FrictionEstimate or None
        Friction estimate used at the end of the run.
    metrics : LoopMetrics
    info : dict
        Counters (e.g. rejected samples), settings.
    """

    mode: str
    t: np.ndarray
    w_ref: np.ndarray
    w: np.ndarray
    w_meas: np.ndarray
    u: np.ndarray
    u_ff: np.ndarray
    f: np.ndarray
    t_theta: np.ndarray
    theta: np.ndarray
    estimate: FrictionEstimate | None
    metrics: LoopMetrics
    info: dict = field(default_factory=dict)


def run_closed_loop(p: JointParams, reference: Reference, *, mode: str, Kp: float, Ki: float,
                    u_max: float = math.inf, Tc: float = 1e-3, Ts: float = 0.01, noise_std: float = 0.0,
                    rng: np.random.Generator | None = None, model: RegressionModel | None = None,
                    estimate: FrictionEstimate | None = None, lam: float = 0.995, P0: float = 1e4,
                    warmup: int = 300, lag: bool = True, ff_max: float | None = None,
                    ff_input: str = "reference", reversal_window: float = 0.2) -> ClosedLoopResult:
    """Simulate the PI velocity loop on the 1 kHz plant with one friction compensation mode.

    Parameters
    ----------
    p : JointParams
        True plant.
    reference : Reference
        Velocity reference sampled at ``Tc`` (e.g. :func:`plant.multisine_reference`).
    mode : {"none", "fixed", "adaptive", "oracle", "frictionless"}, keyword-only
        Compensation: none; fixed feedforward from ``estimate``; adaptive RLS
        feedforward on the loop's own data sampled at ``Ts``; the true friction
        state ``f`` (upper bound); or no compensation on the frictionless plant.
    Kp, Ki : float, keyword-only
        PI gains (N·m·s/rad, N·m/rad), e.g. from :func:`controllers.design_pi`.
    u_max : float, keyword-only
        Torque saturation (N·m), default inf.
    Tc : float, keyword-only
        Controller period = integration step (s), default 1 ms.
    Ts : float, keyword-only
        Identification sample time (s), a multiple of ``Tc``; default 10 ms (paper).
    noise_std : float, keyword-only
        White velocity-measurement noise (rad/s) seen by controller and estimator.
    rng : numpy.random.Generator, keyword-only
        Required when ``noise_std > 0``.
    model : RegressionModel, keyword-only
        Regression structure for ``adaptive`` (Vs, delta from the pre-fit).
    estimate : FrictionEstimate, keyword-only
        Offline estimate for ``fixed``.
    lam, P0, warmup, lag : keyword-only
        Adaptive feedforward settings, see :class:`adaptive_ff.AdaptiveFrictionFeedforward`.
    ff_max : float, keyword-only
        Bound on |feedforward| (N·m); default ``u_max``.
    ff_input : {"reference", "measured"}, keyword-only
        Velocity the friction feedforward is evaluated at: the reference
        (default; no noise is fed back) or the measured velocity.
    reversal_window : float, keyword-only
        Half-width (s) of the reversal windows for the metrics.

    Returns
    -------
    ClosedLoopResult

    Raises
    ------
    ParameterError
        Unknown mode, missing ``model``/``estimate`` for its mode, ``Ts`` not a
        multiple of ``Tc``, reference step not equal to ``Tc``, noise without ``rng``.

    Notes
    -----
    Per period ``Tc``: measure ``w_meas = w + noise``; ``e = w_ref - w_meas``;
    ``u = sat(PI(e) + u_ff)`` with anti-windup; advance the plant one RK4 step
    with ``u`` held. Every ``Ts`` the estimator gets ``(u, w_meas)`` with ``u``
    the torque applied over the step that ended at the sample (same alignment
    as :func:`plant.sample`). The feedforward is evaluated at the reference
    velocity by default (a feedforward should not feed measurement noise back);
    ``ff_input="measured"`` evaluates it at the measured velocity instead.
    """
    if mode not in MODES:
        raise ParameterError(f"mode must be one of {MODES}, got {mode!r}")
    Tc = check_positive("Tc", Tc)
    Ts = check_positive("Ts", Ts)
    noise_std = check_nonnegative("noise_std", noise_std)
    m = Ts / Tc
    if abs(m - round(m)) > 1e-9 * max(m, 1.0):
        raise ParameterError(f"Ts = {Ts!r} s must be a multiple of Tc = {Tc!r} s")
    m = int(round(m))
    t = np.asarray(reference.t)
    if t.shape[0] > 1 and not math.isclose(t[1] - t[0], Tc, rel_tol=1e-9):
        raise ParameterError(f"reference step {t[1] - t[0]!r} s differs from Tc = {Tc!r} s")
    if noise_std > 0 and rng is None:
        raise ParameterError("noise_std > 0 needs rng=np.random.default_rng(seed)")
    ff_max = u_max if ff_max is None else ff_max
    if ff_input not in ("reference", "measured"):
        raise ParameterError(f"ff_input must be 'reference' or 'measured', got {ff_input!r}")
    ff_measured = ff_input == "measured"

    plant = p.frictionless() if mode == "frictionless" else p
    step = make_rk4_step(plant, Tc)
    ctrl = PIController(Kp=Kp, Ki=Ki, Tc=Tc, u_max=u_max)
    ff: FrictionFeedforward | None = None
    if mode == "fixed":
        if estimate is None:
            raise ParameterError("mode 'fixed' needs estimate=FrictionEstimate (an offline LS result)")
        ff = FrictionFeedforward(estimate, dt=Tc, lag=lag, ff_max=ff_max)
    elif mode == "adaptive":
        if model is None:
            raise ParameterError("mode 'adaptive' needs model=RegressionModel(Vs, delta, ...)")
        ff = AdaptiveFrictionFeedforward(model, Ts=Ts, dt=Tc, lam=lam, P0=P0, warmup=warmup, lag=lag,
                                         ff_max=ff_max)

    n = t.shape[0]
    noise = rng.normal(0.0, noise_std, size=n) if noise_std > 0 else np.zeros(n)
    wr = np.asarray(reference.w, dtype=float)
    W = np.empty(n)
    WM = np.empty(n)
    U = np.empty(n)
    UFF = np.empty(n)
    F = np.empty(n)
    th_t: list[float] = []
    th: list[np.ndarray] = []
    w = float(wr[0])
    f = float(plant.friction(w)) if plant.tau == 0 else 0.0
    u = 0.0
    adaptive = mode == "adaptive"
    oracle = mode == "oracle"
    wr_list = wr.tolist()
    noise_list = noise.tolist()
    for k in range(n):
        wm = w + noise_list[k]
        if adaptive and k % m == 0 and k > 0:
            ff.observe(u, wm)
            th_t.append(t[k])
            th.append(ff.theta.copy())
        if ff is not None:
            uff = ff.step(wm if ff_measured else wr_list[k])
        elif oracle:
            uff = f
        else:
            uff = 0.0
        u = ctrl.step(wr_list[k] - wm, uff)
        W[k], WM[k], U[k], UFF[k], F[k] = w, wm, u, uff, f
        w, f = step(w, f, u)

    metrics = loop_metrics(t, wr, W, U, reversals=reference.reversals(), window=reversal_window)
    info = {"Tc": Tc, "Ts": Ts, "noise_std": noise_std}
    if adaptive:
        info.update(n_rejected=ff.n_rejected, n_implausible=ff.n_implausible, n_updates=ff.rls.n_updates,
                    lam=lam, names=list(model.names))
    return ClosedLoopResult(
        mode=mode, t=t, w_ref=wr, w=W, w_meas=WM, u=U, u_ff=UFF, f=F,
        t_theta=np.asarray(th_t), theta=np.asarray(th).reshape(len(th), -1) if th else np.empty((0, 0)),
        estimate=ff.estimate if ff is not None else None, metrics=metrics, info=info)
