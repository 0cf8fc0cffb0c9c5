"""Closed-loop velocity control of the simulated joint with friction compensation modes, and their metrics."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from adaptive_ff.feedforward import AdaptiveFrictionFeedforward, FrictionFeedforward, RobustAdaptiveFeedforward
from adaptive_ff.gate import OutlierGate
from adaptive_ff.regression import FrictionEstimate, RegressionModel
from adaptive_ff.sliding_estimator import SlidingFrictionEstimator
from controllers.canudas import CanudasCompensator
from controllers.dob import DisturbanceObserver
from controllers.pi import PIController
from plant.errors import ParameterError, check_multiple, check_nonnegative, check_positive
from plant.excitation import Reference
from plant.friction import JointParams

__all__ = ["MODES", "ESTIMATORS", "LoopMetrics", "ClosedLoopResult", "run_closed_loop", "loop_metrics"]

#: Compensation modes: no feedforward; fixed offline estimate; online adaptive
#: feedforward; the two peers (Canudas de Wit et al. 1987 adaptive Coulomb +
#: viscous compensation, disturbance observer); the true friction torque fed
#: forward (upper bound); and the frictionless plant (limit).
MODES = ("none", "fixed", "adaptive", "canudas", "dob", "oracle", "frictionless")

#: Estimators of the ``adaptive`` mode: the sliding-regime inverse-dynamics RLS
#: (:class:`adaptive_ff.RobustAdaptiveFeedforward`, default) or the paper's
#: eq. 4 RLS at Ts (:class:`adaptive_ff.AdaptiveFrictionFeedforward`, baseline).
ESTIMATORS = ("sliding", "eq4")


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
        Counters and settings: ``n_rejected`` (samples the estimator refused),
        ``n_sensor_rejected`` (measurements the controller's gate replaced by
        the last valid one), ``diverged`` (the velocity left ``±w_limit``; the
        rest of the run is NaN), estimator counters (``n_updates``,
        ``n_gated``, ``n_implausible``), and the peers' final estimates.
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


def run_closed_loop(p, reference: Reference, *, mode: str, Kp: float, Ki: float,
                    u_max: float = math.inf, Tc: float = 1e-3, Ts: float = 0.01, noise_std: float = 0.0,
                    rng: np.random.Generator | None = None, model: RegressionModel | None = None,
                    estimate: FrictionEstimate | None = None, lam: float | None = None, P0: float = 1e4,
                    warmup: int = 200, lag: bool = True, ff_max: float | None = None,
                    ff_input: str = "measured", reversal_window: float = 0.2, estimator: str = "sliding",
                    Vs: float | None = None, delta: float | None = None, T_filter: float = 0.02,
                    forgetting: str = "exponential", initial: FrictionEstimate | None = None,
                    sign_width: float = 0.0, stick_band: float = 0.0, stick_samples: int = 10,
                    J_n: float | None = None, omega_q: float = 500.0,
                    faults=None, sensor_gate: bool = True, w_limit: float | None = None,
                    dwell_max: float = 0.01, offset: bool = True) -> ClosedLoopResult:
    """Simulate the PI velocity loop on the 1 kHz plant with one friction compensation mode.

    Parameters
    ----------
    p : JointParams or another plant model
        True plant: :class:`plant.JointParams` or a variant of
        :mod:`plant.models` (LuGre, Karnopp, asymmetric), possibly wrapped in
        :class:`plant.drift.FrictionDrift` (re-frozen every ``p.period`` s).
    reference : Reference
        Velocity reference sampled at ``Tc`` (e.g. :func:`plant.multisine_reference`).
    mode : str, keyword-only
        One of :data:`MODES`: ``none``; ``fixed`` feedforward from ``estimate``;
        ``adaptive`` online feedforward (``estimator``); ``canudas``
        (:class:`controllers.canudas.CanudasCompensator`); ``dob``
        (:class:`controllers.dob.DisturbanceObserver`); ``oracle`` (the true
        friction torque, the upper bound); ``frictionless`` (no compensation,
        plant without friction: the limit).
    Kp, Ki : float, keyword-only
        PI gains (N·m·s/rad, N·m/rad), e.g. from :func:`controllers.design_pi`.
    u_max : float, keyword-only
        Torque saturation (N·m), default inf.
    Tc : float, keyword-only
        Controller period = integration step (s), default 1 ms.
    Ts : float, keyword-only
        Estimator sample time (s), a multiple of ``Tc``; default 10 ms (paper).
        For ``estimator="sliding"`` and ``canudas`` the RLS update period, for
        ``"eq4"`` the identification sample time.
    noise_std : float, keyword-only
        White velocity-measurement noise (rad/s) seen by controller and estimator.
    rng : numpy.random.Generator, keyword-only
        Required when ``noise_std > 0``.
    model : RegressionModel, keyword-only
        Regression structure for ``estimator="eq4"``; for ``"sliding"`` its
        ``Vs``, ``delta`` are used when ``Vs``/``delta`` are not given.
    estimate : FrictionEstimate, keyword-only
        Offline estimate for ``fixed``.
    lam : float, keyword-only
        Forgetting factor per update; default 0.995 (``sliding``, ``eq4``),
        0.999 (``canudas``).
    P0, warmup, lag : keyword-only
        Adaptive settings: initial covariance scale, updates before the
        feedforward is switched on, feedforward through the estimated lag.
    ff_max : float, keyword-only
        Bound on |feedforward| (N·m); default ``u_max``.
    ff_input : {"measured", "reference"}, keyword-only
        Velocity the friction feedforward (``fixed``, ``adaptive``,
        ``canudas``) is evaluated at. Default ``"measured"``: measured on the
        ``paper`` preset with the true parameters, eta 0.99 at the measured and
        0.68 at the reference velocity (the joint lags the reference at
        reversals, so the reference-based torque comes early).
    reversal_window : float, keyword-only
        Half-width (s) of the reversal windows for the metrics.
    estimator : {"sliding", "eq4"}, keyword-only
        Estimator of the ``adaptive`` mode, see :data:`ESTIMATORS`.
    Vs, delta : float, keyword-only
        Stribeck factors for the sliding estimator (pre-fit); default from ``model``.
    T_filter, forgetting, initial, dwell_max, offset : keyword-only
        Sliding estimator settings, see :class:`adaptive_ff.SlidingFrictionEstimator`
        (``dwell_max=1`` switches its sliding-regime gate off).
    sign_width : float, keyword-only
        Sign treatment of the feedforward near zero velocity (rad/s), see
        :class:`adaptive_ff.FrictionFeedforward`; default 0 (``sgn``).
    stick_band : float, keyword-only
        With ``ff_input="measured"``: inside ``|w_meas| < stick_band`` (rad/s)
        the feedforward is evaluated at the reference velocity (the intended
        direction of a stuck joint), see :class:`adaptive_ff.FrictionFeedforward`.
    J_n, omega_q : float, keyword-only
        Disturbance observer: nominal inertia (default ``p.J``) and Q-filter
        cut-off (rad/s).
    faults : mapping int -> float, keyword-only
        Measurement faults: the measured velocity of sample ``k`` is replaced by
        ``faults[k]`` (NaN, inf, or an outlier spike). Default none.
    sensor_gate : bool, keyword-only
        Give the controller (and the peers) the last valid measurement when a
        sample is non-finite or a physically impossible jump
        (:class:`adaptive_ff.gate.OutlierGate` with ``max_step =
        2*u_max*Tc/J``); default True. The estimators get the raw sample and
        reject it themselves.
    w_limit : float, keyword-only
        |velocity| (rad/s) beyond which the run is declared diverged; default
        ``100*max|w_ref| + 1``.

    Returns
    -------
    ClosedLoopResult

    Raises
    ------
    ParameterError
        Unknown mode or estimator, missing ``model``/``estimate``/``Vs`` for
        its mode, ``Ts`` not a multiple of ``Tc``, reference step not equal to
        ``Tc``, noise without ``rng``.

    Notes
    -----
    Per period ``Tc``: measure ``w_meas = w + noise`` (or the injected fault);
    the gate yields the controller's measurement; the compensation torque is
    computed; ``u = sat(PI(w_ref - w_meas) + u_comp)`` with anti-windup; the
    estimator (if any) gets ``(u, w_meas)``; the plant advances one RK4 step
    with ``u`` held. The ``eq4`` estimator gets ``(u, w_meas)`` every ``Ts``
    with ``u`` the torque applied over the step that ended at the sample (same
    alignment as :func:`plant.sample`).
    """
    if mode not in MODES:
        raise ParameterError(f"mode must be one of {MODES}, got {mode!r}")
    if estimator not in ESTIMATORS:
        raise ParameterError(f"estimator must be one of {ESTIMATORS}, got {estimator!r}")
    Tc = check_positive("Tc", Tc)
    m = check_multiple("Ts", Ts, "Tc", Tc)
    noise_std = check_nonnegative("noise_std", noise_std)
    t = np.asarray(reference.t)
    if t.shape[0] > 1 and not math.isclose(t[1] - t[0], Tc, rel_tol=1e-9):
        raise ParameterError(f"reference step {t[1] - t[0]!r} s differs from Tc = {Tc!r} s")
    if noise_std > 0 and rng is None:
        raise ParameterError("noise_std > 0 needs rng=np.random.default_rng(seed)")
    ff_max = u_max if ff_max is None else ff_max
    if ff_input not in ("reference", "measured"):
        raise ParameterError(f"ff_input must be 'reference' or 'measured', got {ff_input!r}")
    ff_measured = ff_input == "measured"
    if lam is None:
        lam = 0.999 if mode == "canudas" else 0.995

    drifting = hasattr(p, "at")
    plant = p.frictionless() if mode == "frictionless" else (p.at(0.0) if drifting else p)
    J = float(plant.J)
    step = plant.make_step(Tc)
    friction_is_state = isinstance(plant, JointParams)
    fr_torque = plant.friction_torque
    drift_m = max(int(round(p.period / Tc)), 1) if (drifting and mode != "frictionless") else 0
    ctrl = PIController(Kp=Kp, Ki=Ki, Tc=Tc, u_max=u_max)

    ff: FrictionFeedforward | None = None
    peer = None
    eq4 = robust = False
    if mode == "fixed":
        if estimate is None:
            raise ParameterError("mode 'fixed' needs estimate=FrictionEstimate (an offline LS result)")
        ff = FrictionFeedforward(estimate, dt=Tc, lag=lag, ff_max=ff_max, sign_width=sign_width,
                                 stick_band=stick_band, stick_samples=stick_samples)
    elif mode == "adaptive" and estimator == "eq4":
        if model is None:
            raise ParameterError("mode 'adaptive' with estimator 'eq4' needs model=RegressionModel(Vs, delta, ...)")
        ff = AdaptiveFrictionFeedforward(model, Ts=Ts, dt=Tc, lam=lam, P0=P0, warmup=warmup, lag=lag,
                                         ff_max=ff_max)
        eq4 = True
    elif mode == "adaptive":
        Vs = Vs if Vs is not None else (model.Vs if model is not None else None)
        delta = delta if delta is not None else (model.delta if model is not None else None)
        if Vs is None or delta is None:
            raise ParameterError("mode 'adaptive' needs Vs and delta (from the Stribeck pre-fit) or model=")
        gate_step = 2.0 * u_max * Tc / J if math.isfinite(u_max) else math.inf
        est = SlidingFrictionEstimator(Vs, delta, Tc=Tc, Ts=Ts, T_filter=T_filter, lam=lam, forgetting=forgetting,
                                       P0=P0, initial=initial, J_guess=J, lag=lag, dwell_max=dwell_max,
                                       offset=offset,
                                       gate=OutlierGate(max_step=gate_step))
        ff = RobustAdaptiveFeedforward(est, dt=Tc, lag=lag, ff_max=ff_max, sign_width=sign_width, stick_band=stick_band,
                                       stick_samples=stick_samples, warmup=warmup)
        robust = True
    elif mode == "canudas":
        peer = CanudasCompensator(Tc=Tc, Ts=Ts, lam=lam, forgetting=forgetting, P0=P0, J_guess=J, warmup=warmup,
                                  ff_max=ff_max, ff_input=ff_input)
    elif mode == "dob":
        peer = DisturbanceObserver(J_n=J if J_n is None else J_n, omega_q=omega_q, Tc=Tc, d_max=ff_max)

    n = t.shape[0]
    noise = rng.normal(0.0, noise_std, size=n) if noise_std > 0 else np.zeros(n)
    wr = np.asarray(reference.w, dtype=float)
    if w_limit is None:
        w_limit = 100.0 * float(np.max(np.abs(wr))) + 1.0
    fault_list = None
    if faults:
        fault_list = [None] * n
        for k, v in dict(faults).items():
            if 0 <= int(k) < n:
                fault_list[int(k)] = float(v)
    gate = None
    if sensor_gate:
        gate = OutlierGate(max_step=2.0 * u_max * Tc / J if math.isfinite(u_max) else math.inf)
    W = np.full(n, np.nan)
    WM = np.full(n, np.nan)
    U = np.full(n, np.nan)
    UFF = np.full(n, np.nan)
    F = np.full(n, np.nan)
    th_t: list[float] = []
    th: list[np.ndarray] = []
    w = float(wr[0])
    s = plant.initial_state(w)
    f = s if friction_is_state else fr_torque(w, s)
    u = 0.0
    oracle = mode == "oracle"
    wr_list = wr.tolist()
    noise_list = noise.tolist()
    t_list = t.tolist()
    ctl = ctrl.step
    ff_step = ff.step if ff is not None else None
    est_obj = ff.estimator if robust else None
    ff_observe = ff.observe if robust else None
    peer_comp = peer.compensate if peer is not None else None
    peer_obs = peer.observe if peer is not None else None
    gate_check = gate.check if gate is not None else None
    held = w
    diverged = False
    for k in range(n):
        if drift_m and k % drift_m == 0 and k > 0:
            frozen = p.at(t_list[k])
            step = frozen.make_step(Tc)
            fr_torque = frozen.friction_torque
        wm = w + noise_list[k]
        if fault_list is not None:
            fv = fault_list[k]
            if fv is not None:
                wm = fv
        if gate_check is not None:
            if gate_check(wm):
                held = wm
            wc = held
        else:
            wc = wm
        wrk = wr_list[k]
        if eq4 and k % m == 0 and k > 0:
            ff.observe(u, wm)
            th_t.append(t_list[k])
            th.append(ff.theta.copy())
        if ff_step is not None:
            uff = ff_step(wc, wrk) if ff_measured else ff_step(wrk)
        elif peer_comp is not None:
            uff = peer_comp(wc, wrk)
        elif oracle:
            uff = f
        else:
            uff = 0.0
        u = ctl(wrk - wc, uff)
        if ff_observe is not None:
            ff_observe(u, wm)
            if est_obj.updated:
                th_t.append(t_list[k])
                th.append(est_obj.theta.copy())
        elif peer_obs is not None:
            peer_obs(u, wm)
        W[k], WM[k], U[k], UFF[k], F[k] = w, wm, u, uff, f
        w, s = step(w, s, u)
        f = s if friction_is_state else fr_torque(w, s)
        if not -w_limit < w < w_limit:  # also catches NaN
            diverged = True
            break

    metrics = loop_metrics(t, wr, W, U, reversals=reference.reversals(), window=reversal_window)
    info = {"Tc": Tc, "Ts": Ts, "noise_std": noise_std, "diverged": diverged, "ff_input": ff_input,
            "n_sensor_rejected": gate.n_rejected if gate is not None else 0}
    final = ff.estimate if ff is not None else None
    if eq4:
        info.update(estimator="eq4", n_rejected=ff.n_rejected, n_implausible=ff.n_implausible,
                    n_updates=ff.rls.n_updates, lam=lam, names=list(model.names))
    elif robust:
        e = ff.estimator
        info.update(estimator="sliding", n_rejected=e.n_rejected, n_implausible=ff.n_implausible,
                    n_lag_held=ff.n_lag_held,
                    n_updates=e.n_updates, n_gated=e.n_gated, n_projected=e.rls.n_projected, lam=lam,
                    names=list(e.names), raw_estimate=e.estimate.to_dict(), noise_estimate=e.noise_std)
    elif mode == "canudas":
        info.update(n_rejected=peer.n_rejected, n_updates=peer.rls.n_updates, lam=lam,
                    canudas_estimate=peer.estimate)
    elif mode == "dob":
        info.update(n_rejected=peer.n_rejected, J_n=peer.J_n, omega_q=peer.omega_q)
    return ClosedLoopResult(
        mode=mode, t=t, w_ref=wr, w=W, w_meas=WM, u=U, u_ff=UFF, f=F,
        t_theta=np.asarray(th_t), theta=np.asarray(th).reshape(len(th), -1) if th else np.empty((0, 0)),
        estimate=final, metrics=metrics, info=info)
