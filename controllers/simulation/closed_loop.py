"""Closed-loop velocity control of the simulated joint with friction compensation modes, and their metrics."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from adaptive_ff.compensation.feedforward import AdaptiveFrictionFeedforward, FrictionFeedforward, RobustAdaptiveFeedforward
from adaptive_ff.compensation.gate import OutlierGate
from adaptive_ff.identification.regression import FrictionEstimate, RegressionModel
from adaptive_ff.compensation.sliding_estimator import SlidingFrictionEstimator, _to_estimate
from controllers.peers.canudas import CanudasCompensator
from controllers.peers.dob import DisturbanceObserver
from controllers.design.pi import PIController
from plant.errors import ParameterError, check_multiple, check_nonnegative, check_positive
from plant.excitation import Reference
from plant.friction import JointParams

__all__ = ["MODES", "ESTIMATORS", "ENGINES", "LoopMetrics", "ClosedLoopResult", "run_closed_loop", "loop_metrics",
           "kernel_supported"]

#: Compensation modes: no feedforward; fixed offline estimate; online adaptive
#: feedforward; the two peers (Canudas de Wit et al. 1987 adaptive Coulomb +
#: viscous compensation, disturbance observer); the true friction torque fed
#: forward (upper bound); and the frictionless plant (limit).
MODES = ("none", "fixed", "adaptive", "canudas", "dob", "oracle", "frictionless")

#: Estimators of the ``adaptive`` mode: the sliding-regime inverse-dynamics RLS
#: (:class:`adaptive_ff.RobustAdaptiveFeedforward`, default) or the paper's
#: eq. 4 RLS at Ts (:class:`adaptive_ff.AdaptiveFrictionFeedforward`, baseline).
ESTIMATORS = ("sliding", "eq4")

#: Simulation engines of :func:`run_closed_loop`: ``auto`` (the compiled kernel
#: :mod:`controllers.simulation.loop_kernel` where it applies, else Python), ``numba``
#: (the kernel; an error where it does not apply), ``python`` (the reference twin).
ENGINES = ("auto", "numba", "python")
_MODE_CODES = {"none": 0, "frictionless": 0, "oracle": 1, "fixed": 2, "adaptive": 3, "canudas": 4, "dob": 5}


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
    half, mask = _metric_masks(t, reversals, window)
    rms = lambda x: float(np.sqrt(np.mean(x**2))) if x.size else float("nan")  # noqa: E731
    return LoopMetrics(rms=rms(e), max=float(np.max(np.abs(e))), rms_second_half=rms(e[half]),
                       max_second_half=float(np.max(np.abs(e[half]))), rms_reversal=rms(e[mask]),
                       u_rms=rms(np.asarray(u)))


def _reversals(t, w, chunk: int = 1 << 16) -> np.ndarray:
    """:meth:`plant.excitation.Reference.reversals` computed in chunks (no full-length temporaries)."""
    n = w.shape[0]
    out = [t[:0]]
    for i in range(0, n - 1, chunk):
        s = np.sign(w[i:i + chunk + 1])
        out.append(t[i + 1 + np.flatnonzero(s[1:] * s[:-1] < 0)])
    return np.concatenate(out)


def _metric_masks(t, reversals, window):
    """Second-half mask and reversal-window mask (second half only) of :func:`loop_metrics`."""
    half = t >= 0.5 * (t[0] + t[-1])
    mask = np.zeros_like(half)
    if len(reversals):
        idx = np.searchsorted(reversals, t)
        lo = np.abs(t - reversals[np.clip(idx - 1, 0, len(reversals) - 1)])
        hi = np.abs(reversals[np.clip(idx, 0, len(reversals) - 1)] - t)
        mask = (np.minimum(lo, hi) <= window) & half
    return half, mask


@dataclass(frozen=True)
class ClosedLoopResult:
    """One closed-loop run.

    Attributes
    ----------
    mode : str
        Compensation mode (one of :data:`MODES`).
    t : ndarray, shape (N,)
        Time (s) at the controller rate (every ``decimate``-th sample when
        ``run_closed_loop(decimate=k)``; empty for ``decimate=0``).
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
        ``n_gated``, ``n_implausible``), the peers' final estimates, and
        ``engine`` (``"numba"`` or ``"python"``) and ``decimate``.
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
                    dwell_max: float = 0.01, offset: bool = True, decimate: int = 1,
                    engine: str = "auto") -> ClosedLoopResult:
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
        (:class:`controllers.peers.canudas.CanudasCompensator`); ``dob``
        (:class:`controllers.peers.dob.DisturbanceObserver`); ``oracle`` (the true
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
        (:class:`adaptive_ff.compensation.gate.OutlierGate` with ``max_step =
        2*u_max*Tc/J``); default True. The estimators get the raw sample and
        reject it themselves.
    w_limit : float, keyword-only
        |velocity| (rad/s) beyond which the run is declared diverged; default
        ``100*max|w_ref| + 1``.
    decimate : int, keyword-only
        Signal recording: 1 (default) keeps every sample; ``k > 1`` keeps
        every k-th (``t[::k]`` etc.); 0 keeps no signals and no ``theta``
        history (metrics only). With ``decimate != 1`` the metrics are
        streamed over all samples (kernel: compensated sums; Python loop:
        chunks of 2**16 samples), equal to :func:`loop_metrics` of the full
        record to round-off (1e-12 relative), so memory does not grow with
        the run length beyond the reference and the noise (the ``theta``
        history at ``Ts`` is kept unless ``decimate=0``).
    engine : {"auto", "numba", "python"}, keyword-only
        ``"auto"`` (default): the compiled kernel
        (:mod:`controllers.simulation.loop_kernel`) where :func:`kernel_supported` says
        it applies, else the Python loop; ``"numba"``: the kernel (error where
        it does not apply); ``"python"``: the Python loop, the reference twin
        of the kernel (same operations in the same order).

    Returns
    -------
    ClosedLoopResult

    Raises
    ------
    ParameterError
        Unknown mode or estimator, missing ``model``/``estimate``/``Vs`` for
        its mode, ``Ts`` not a multiple of ``Tc``, reference step not equal to
        ``Tc``, noise without ``rng``, bad ``decimate`` or ``engine``, or
        ``engine="numba"`` for a setting the kernel does not cover.

    Notes
    -----
    Per period ``Tc``: measure ``w_meas = w + noise`` (or the injected fault);
    the gate yields the controller's measurement; the compensation torque is
    computed; ``u = sat(PI(w_ref - w_meas) + u_comp)`` with anti-windup; the
    estimator (if any) gets ``(u, w_meas)``; the plant advances one RK4 step
    with ``u`` held. The ``eq4`` estimator gets ``(u, w_meas)`` every ``Ts``
    with ``u`` the torque applied over the step that ended at the sample (same
    alignment as :func:`plant.sample`).

    The compiled kernel (:mod:`controllers.simulation.loop_kernel`) repeats the Python
    loop's floating-point operations in the same order and calls the same RLS
    kernel (:mod:`adaptive_ff.identification.rls`), so both engines give the same numbers
    (tested to 1e-9 relative over random plants, bit-identical on the
    presets); it is about 10-40x faster (``benchmarks/perf.py``). Plant
    variants (LuGre, Karnopp, asymmetric) and the ``eq4`` estimator run in
    Python; a drifting ``JointParams`` plant runs in the kernel.
    """
    if mode not in MODES:
        raise ParameterError(f"mode must be one of {MODES}, got {mode!r}")
    if engine not in ENGINES:
        raise ParameterError(f"engine must be one of {ENGINES}, got {engine!r}")
    if isinstance(decimate, bool) or not isinstance(decimate, (int, np.integer)) or decimate < 0:
        raise ParameterError(f"decimate must be an integer >= 0, got {decimate!r}")
    decimate = int(decimate)
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
    wr = np.asarray(reference.w, dtype=float)
    revs = _reversals(t, wr)
    if w_limit is None:
        w_limit = 100.0 * float(np.max(np.abs(wr))) + 1.0
    noise = rng.normal(0.0, noise_std, size=n) if noise_std > 0 else None
    gate = None
    if sensor_gate:
        gate = OutlierGate(max_step=2.0 * u_max * Tc / J if math.isfinite(u_max) else math.inf)
    use_kernel = engine != "python" and kernel_supported(plant, mode=mode, estimator=estimator, drift=drift_m > 0)
    if engine == "numba" and not use_kernel:
        raise ParameterError(f"engine='numba' does not cover this setting (mode {mode!r}, estimator {estimator!r}, "
                             f"plant {type(p).__name__}); use engine='auto' or 'python'")
    if use_kernel:
        W, WM, U, UFF, F, th_t, th, diverged, streamed = _run_kernel(
            plant, wr, t, revs, p_drift=p if drift_m else None, drift_m=drift_m, mode=mode, Tc=Tc, ctrl=ctrl, ff=ff,
            peer=peer, u_max=u_max, noise=noise, faults=faults, gate=gate, reversal_window=reversal_window,
            decimate=decimate, w_limit=w_limit, ff_measured=ff_measured)
    else:
        W, WM, U, UFF, F, th_t, th, diverged, streamed = _run_python(
            p, plant, t, wr, revs, mode=mode, Tc=Tc, m=m, drift_m=drift_m, ctrl=ctrl, ff=ff, peer=peer, eq4=eq4,
            robust=robust, noise=noise, faults=faults, gate=gate, w_limit=w_limit, ff_measured=ff_measured,
            decimate=decimate, reversal_window=reversal_window)
    if decimate == 1:  # full record: the metrics exactly as before (loop_metrics)
        metrics = loop_metrics(t, wr, W, U, reversals=revs, window=reversal_window)
    else:  # streamed during the run
        metrics = streamed
        t, wr = (t[::decimate], wr[::decimate]) if decimate else (t[:0], wr[:0])

    info = {"Tc": Tc, "Ts": Ts, "noise_std": noise_std, "diverged": diverged, "ff_input": ff_input,
            "engine": "numba" if use_kernel else "python", "decimate": decimate,
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
        t_theta=np.asarray(th_t), theta=np.asarray(th).reshape(len(th), -1) if len(th) else np.empty((0, 0)),
        estimate=final, metrics=metrics, info=info)


def kernel_supported(p, *, mode: str, estimator: str = "sliding", drift: bool = False) -> bool:
    """Whether the compiled kernel (:mod:`controllers.simulation.loop_kernel`) covers a run of :func:`run_closed_loop`.

    Parameters
    ----------
    p : plant model
        The (frozen) plant of the run.
    mode, estimator : str, keyword-only
        As in :func:`run_closed_loop`.
    drift : bool, keyword-only
        The plant drifts (re-frozen during the run; covered when the frozen
        plants are ``JointParams``).

    Returns
    -------
    bool
        True for a :class:`plant.friction.JointParams` plant (possibly drifting) in
        every mode except ``adaptive`` with the ``eq4`` estimator (the
        ``sliding`` estimator with any forgetting scheme, ``canudas``, ``dob``
        and the others are covered).
    """
    if not isinstance(p, JointParams) or mode not in _MODE_CODES:
        return False
    return mode != "adaptive" or estimator == "sliding"


def _max_nan(a: float, b: float) -> float:
    """max like np.max: NaN if either is NaN."""
    return math.nan if (a != a or b != b) else max(a, b)


class _MetricStream:
    """:func:`loop_metrics` accumulated chunk by chunk (sums of squares, maxima; NaN propagates the same way)."""

    def __init__(self, t, revs, window):
        self.tmid = 0.5 * (t[0] + t[-1])
        self.revs, self.window = revs, window
        self.n = 0
        self.s = {"e": [], "h": [], "r": [], "u": []}
        self.nh = self.nr = 0
        self.me = self.mh = -math.inf

    def masks(self, tc):
        half = tc >= self.tmid
        mask = np.zeros_like(half)
        r = self.revs
        if len(r):
            idx = np.searchsorted(r, tc)
            lo = np.abs(tc - r[np.clip(idx - 1, 0, len(r) - 1)])
            hi = np.abs(r[np.clip(idx, 0, len(r) - 1)] - tc)
            mask = (np.minimum(lo, hi) <= self.window) & half
        return half, mask

    def add(self, tc, wrc, wc, uc):
        e = wrc - wc
        e2 = e * e
        half, mask = self.masks(tc)
        self.n += e.size
        self.s["e"].append(float(np.sum(e2)))
        self.s["h"].append(float(np.sum(e2[half])))
        self.s["r"].append(float(np.sum(e2[mask])))
        self.s["u"].append(float(np.sum(uc * uc)))
        self.nh += int(np.count_nonzero(half))
        self.nr += int(np.count_nonzero(mask))
        ae = np.abs(e)
        self.me = _max_nan(self.me, float(np.max(ae)))
        if half.any():
            self.mh = _max_nan(self.mh, float(np.max(ae[half])))

    def result(self) -> LoopMetrics:
        nan = math.nan
        rms = lambda k, c: math.sqrt(math.fsum(self.s[k]) / c) if c else nan  # noqa: E731
        return LoopMetrics(rms=rms("e", self.n), max=self.me, rms_second_half=rms("h", self.nh),
                           max_second_half=self.mh, rms_reversal=rms("r", self.nr), u_rms=rms("u", self.n))


def _run_python(p, plant, t, wr, revs, *, mode, Tc, m, drift_m, ctrl, ff, peer, eq4, robust, noise, faults, gate,
                w_limit, ff_measured, decimate=1, reversal_window=0.2, chunk: int = 1 << 16):
    """The Python loop of :func:`run_closed_loop` (reference twin of the kernel).

    With ``decimate == 1`` one pass over full-length arrays; otherwise the run
    is processed in chunks of ``chunk`` samples, the metrics are streamed
    (:class:`_MetricStream`) and only every ``decimate``-th sample is kept.
    """
    n = t.shape[0]
    full = decimate == 1
    if full:
        chunk = n
    fd = {int(k): float(v) for k, v in dict(faults).items() if 0 <= int(k) < n} if faults else None
    n_rec = n if full else ((n + decimate - 1) // decimate if decimate else 0)
    out = [np.full(n_rec, np.nan) for _ in range(5)]
    stream = None if full else _MetricStream(t, revs, reversal_window)
    step = plant.make_step(Tc)
    friction_is_state = isinstance(plant, JointParams)
    fr_torque = plant.friction_torque
    th_t: list[float] = []
    th: list[np.ndarray] = []
    keep_theta = decimate != 0
    w = float(wr[0])
    s = plant.initial_state(w)
    f = s if friction_is_state else fr_torque(w, s)
    u = 0.0
    oracle = mode == "oracle"
    ctl = ctrl.step
    ff_step = ff.step if ff is not None else None
    est_obj = ff.estimator if robust else None
    ff_observe = ff.observe if robust else None
    peer_comp = peer.compensate if peer is not None else None
    peer_obs = peer.observe if peer is not None else None
    gate_check = gate.check if gate is not None else None
    held = w
    diverged = False
    k_end = n
    for c0 in range(0, n, chunk):
        c1 = min(c0 + chunk, n)
        W, WM, U, UFF, F = out if full else [np.full(c1 - c0, np.nan) for _ in range(5)]
        wr_list = wr[c0:c1].tolist()
        noise_list = noise[c0:c1].tolist() if noise is not None else [0.0] * (c1 - c0)
        t_list = t[c0:c1].tolist()
        for k in range(c0, c1):
            kk = k - c0
            if drift_m and k % drift_m == 0 and k > 0:
                frozen = p.at(t_list[kk])
                step = frozen.make_step(Tc)
                fr_torque = frozen.friction_torque
            wm = w + noise_list[kk]
            if fd is not None:
                fv = fd.get(k)
                if fv is not None:
                    wm = fv
            if gate_check is not None:
                if gate_check(wm):
                    held = wm
                wc = held
            else:
                wc = wm
            wrk = wr_list[kk]
            if eq4 and k % m == 0 and k > 0:
                ff.observe(u, wm)
                if keep_theta:
                    th_t.append(t_list[kk])
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
                if est_obj.updated and keep_theta:
                    th_t.append(t_list[kk])
                    th.append(est_obj.theta.copy())
            elif peer_obs is not None:
                peer_obs(u, wm)
            W[kk], WM[kk], U[kk], UFF[kk], F[kk] = w, wm, u, uff, f
            w, s = step(w, s, u)
            f = s if friction_is_state else fr_torque(w, s)
            if not -w_limit < w < w_limit:  # also catches NaN
                diverged = True
                k_end = k + 1
                break
        if not full:
            stream.add(t[c0:c1], wr[c0:c1], W, U)
            if decimate:
                j0 = (-c0) % decimate
                r0 = (c0 + j0) // decimate
                for dst, src in zip(out, (W, WM, U, UFF, F)):
                    piece = src[j0::decimate]
                    dst[r0:r0 + piece.size] = piece
        if diverged:
            break
    metrics = None
    if not full:
        metrics = stream.result()
        if k_end < n and c1 < n:  # chunks never simulated: NaN like the full record
            _, mask = stream.masks(t[c1:])
            metrics = LoopMetrics(rms=math.nan, max=math.nan, rms_second_half=math.nan, max_second_half=math.nan,
                                  rms_reversal=math.nan if mask.any() else metrics.rms_reversal, u_rms=math.nan)
    W, WM, U, UFF, F = out
    return W, WM, U, UFF, F, th_t, th, diverged, metrics


def _gate_params(g: OutlierGate | None) -> list:
    if g is None:
        return [math.inf, 8.0, 0.01, 20.0]
    return [g.max_step, g.n_sigma, g.alpha, float(g.max_consecutive)]


def _run_kernel(plant, wr, t, revs, *, p_drift, drift_m, mode, Tc, ctrl, ff, peer, u_max, noise, faults, gate,
                reversal_window, decimate, w_limit, ff_measured):
    """Prepare the arrays of :func:`controllers.simulation.loop_kernel.run_loop_kernel`, run it, and write its final state
    back into the controller, feedforward and estimator objects (so that ``info`` and ``estimate`` are the
    same as after the Python loop)."""
    from controllers.simulation.loop_kernel import ST, run_loop_kernel  # numba import only when the kernel is used

    n = t.shape[0]
    row = lambda q: [q.J, q.Fc, q.Fs - q.Fc, q.Vs, q.delta, q.sigma, q.tau]  # noqa: E731
    PL = [row(plant)]
    if drift_m:  # the plant the Python loop re-freezes at every multiple of drift_m (k > 0)
        PL += [row(p_drift.at(tk)) for tk in t[drift_m::drift_m].tolist()]
    PL = np.array(PL, dtype=float)
    G = np.array([ctrl._Kp, ctrl._KiTc, ctrl._u_max, Tc])
    est = ff.estimator if mode == "adaptive" else None
    pp = np.zeros(5)
    if mode == "canudas":
        pp[:] = [float(peer.m), peer.w_dead, float(peer.warmup), peer.ff_max, 1.0 if peer.ff_measured else 0.0]
    elif mode == "dob":
        pp[:] = [float(peer.order), peer._a, peer.J_n, peer.Tc, peer.d_max]
    fixed_est = np.array([0.0, 0.0, 1.0, 1.0, 0.0, 1.0, 0.0])
    ffp = np.zeros(12)
    if ff is not None:
        ffp[:6] = [ff.ff_max, ff.sign_width, ff.stick_band, float(ff.stick_samples), 1.0 if ff.lag else 0.0,
                   1.0 if ff_measured else 0.0]
        if mode == "fixed":
            e = ff.estimate
            has = e.Vs is not None
            fixed_est[:] = [ff._Fc, ff._dF, ff._Vs if has else 1.0, ff._delta if has else 1.0, ff._sigma,
                            ff._alpha, 1.0 if has else 0.0]
    if est is not None:
        ffp[6:] = [float(ff.warmup), ff._fade_step, ff.J_range[0], ff.J_range[1], ff.tau_max, ff.consistency]
        ep = np.array([est.Vs, est.delta, est._a, est.T, float(est.m), float(est._settle), est.w_band_min,
                       est.dwell_max, est._e2_rate, 1.0 if est.lag else 0.0, 1.0 if est.offset else 0.0])
        buf, n_params = est.rls._buf, est.rls.n_params  # the RLS state, advanced in place by its own kernel
        gp = np.array(_gate_params(gate) + _gate_params(est.gate))
        n_theta_max = (n // est.m + 1) if decimate else 0
    else:
        ep = np.zeros(11)
        ep[4] = ep[5] = 1.0
        buf, n_params = (peer.rls._buf, peer.rls.n_params) if mode == "canudas" else (np.zeros(64), 1)
        gp = np.array(_gate_params(gate) * 2)
        n_theta_max = 0
    fk = None
    if faults:
        items = sorted((int(k), float(v)) for k, v in dict(faults).items() if 0 <= int(k) < n)
        fk = (np.array([k for k, _ in items], dtype=np.int64), np.array([v for _, v in items], dtype=float))
    s0 = float(plant.initial_state(float(wr[0])))
    out = run_loop_kernel(wr=np.ascontiguousarray(wr), noise=noise, faults=fk, PL=PL, s0=s0, seg=drift_m, G=G,
                          mode=_MODE_CODES[mode], ffp=ffp, fixed_est=fixed_est, ep=ep, pp=pp, rls_buf=buf,
                          n_params=n_params, gp=gp, use_gate=gate is not None, t=np.ascontiguousarray(t, dtype=float),
                          reversals=revs, window=reversal_window, decimate=decimate, w_limit=w_limit,
                          n_theta_max=n_theta_max)
    st = out["st"]
    g = lambda name: st[ST[name]]  # noqa: E731
    if gate is not None:
        gate.last = g("g_last") if g("g_has") else None
        gate.scale, gate.n_held, gate.n_rejected = g("g_scale"), int(g("g_held")), int(g("g_rej"))
    if est is not None:
        est.n_samples, est.n_rejected, est.n_gated = int(g("n_samples")), int(g("n_rejected")), int(g("n_gated"))
        est._d2, est._e2 = g("d2"), g("e2")
        na = int(g("n_acc"))
        est._w1 = g("w1") if na >= 1 else None
        est._w2 = g("w2") if na >= 2 else None
        est.gate.last = g("e_last") if g("e_has") else None
        est.gate.scale, est.gate.n_held, est.gate.n_rejected = g("e_scale"), int(g("e_held")), int(g("e_rej"))
        ff.n_implausible, ff.n_lag_held = int(g("n_implausible")), int(g("n_lag_held"))
        ff._n_in_band, ff.u_ff, ff._gain = int(g("n_in_band")), g("u_ff"), g("gain")
        if g("has_est"):
            e = _to_estimate(est.names, out["FTH"], est.Vs, est.delta)
            if g("ff_held"):
                e = replace(e, tau=g("ff_tau"), J_alt=float("nan"))
            FrictionFeedforward._set(ff, e)
    elif ff is not None:
        ff._n_in_band, ff.u_ff = int(g("n_in_band")), g("u_ff")
    elif mode == "canudas":
        peer.n_rejected, peer._k, peer._usum = int(g("p_rejected")), int(g("c_k")), g("c_usum")
        peer._ok = bool(g("c_ok"))
        peer._w_prev = g("c_wprev") if g("c_has_prev") else None
        if g("c_on"):
            b, bsp, bsn, bfp, bfn = peer.rls.theta.tolist()
            peer.coef = (bfp / b, bfn / b, bsp / b, bsn / b)
    elif mode == "dob":
        peer.n_rejected, peer.d_hat, peer._u_last = int(g("p_rejected")), g("q_d"), g("q_ulast")
        peer._w_last = g("q_wlast") if g("q_has") else None
    th_t = t[out["TK"]] if out["TK"].size else []
    th = out["TH"]
    diverged = bool(g("diverged"))
    k_end = int(g("k_end"))
    nan = float("nan")
    sq = lambda s_, c_, k_: math.sqrt((s_ + c_) / k_) if k_ > 0 else nan  # noqa: E731
    nh, nr = int(g("nh")), int(g("nr"))
    rms_rev = sq(g("ser"), g("ser_c"), nr)
    if diverged and k_end < n:
        _, mask = _metric_masks(t, revs, reversal_window)
        if mask[k_end:].any():
            rms_rev = nan
        streamed = LoopMetrics(rms=nan, max=nan, rms_second_half=nan, max_second_half=nan, rms_reversal=rms_rev,
                               u_rms=nan)
    else:
        streamed = LoopMetrics(rms=sq(g("se"), g("se_c"), n), max=float(g("me")),
                               rms_second_half=sq(g("se2"), g("se2_c"), nh), max_second_half=float(g("me2")),
                               rms_reversal=rms_rev, u_rms=sq(g("su"), g("su_c"), n))
    return out["W"], out["WM"], out["U"], out["UFF"], out["F"], th_t, th, diverged, streamed
