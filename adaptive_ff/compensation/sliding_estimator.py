r"""Closed-loop friction estimation in the sliding regime: inverse-dynamics regression with state-variable filters.

Why not eq. 4 in the loop
-------------------------
The paper's regression (eq. 4) predicts the *velocity* from its own noisy past
(an ARX structure): measurement noise enters the regressors ``w(k-1), w(k-2)``
and, at Ts = 10 ms against a 20 ms lag, the backward differences bias the
physical parameters. In the velocity loop the estimate drifted to J = 41
kg·m², sigma = 0 (measured on the ``paper`` preset). This module regresses the
*torque* instead, which the controller knows exactly, on filtered velocity
signals — the inverse-dynamics identification model used for industrial
robots in closed loop (Gautier & Khalil; Janot, Vandanjon, Gautier, "A generic
instrumental variable approach for industrial robot identification", IEEE
TCST 22(1), 2014), with the lag of eq. 1 kept.

Model
-----
Multiplying ``J dw/dt = u - f`` by ``(1 + tau s)`` and using eq. 1 gives
eq. 2 solved for the torque::

    u = J*w' + J*tau*w'' - tau*u' + Fc*g(w) + Fs*h(w) + sigma*w (+ offset)

(``g``, ``h`` of eqs. 5-6). Applying one stable low-pass ``L(s) =
1/(1 + T s)**3`` to both sides (a state-variable filter: Young, "Parameter
estimation for continuous-time models — a survey", Automatica 17(1), 1981;
Garnier, Mensler, Richard, "Continuous-time model identification from sampled
data", Int. J. Control 76(13), 2003) gives a model linear in
``theta = (J, J*tau, tau, Fc, Fs, sigma, offset)`` whose regressors need no
numerical differentiation of noisy data::

    y   = L[u]
    phi = (L[s w], L[s^2 w], -L[s u], L[g(w)], L[h(w)], L[w], 1)

``L`` is realised as three cascaded first-order lags ``x1 -> x2 -> x3`` (each
``x_i += a*(x_{i-1} - x_i)``, ``a = 1 - exp(-Tc/T)``) so that ``L[x] = x3``,
``L[s x] = D*(x2 - x3)`` and ``L[s^2 x] = D**2*(x1 - 2*x2 + x3)`` with
``D = a/((1 - a)*Tc) = (exp(Tc/T) - 1)/Tc``: ``D*(x2 - x3)`` is exactly the
backward difference ``(x3(k) - x3(k-1))/Tc`` of the discrete stage (with ``1/T``
in place of ``D`` the fitted J and tau would be ``T*(exp(Tc/T) - 1)/Tc`` times
the joint's, +2.5 % at 1 kHz and ``T`` 20 ms). The difference at sample ``k``
is the motion under the torque held over the period before it, so ``y`` is the
mean of ``L[u]`` before and after the sample (half a period back, as the
difference).

Sliding-regime gate (the closed-loop bias, and its fix)
-------------------------------------------------------
The paper's model covers sliding only (its Sec. I and II-B). Near zero
velocity the sign of the *measured* velocity is decided by the noise, the
joint may creep or stick, and in closed loop the torque reacts to that same
noise (the PI, and a feedforward evaluated at the measured velocity). Rows of
the regression whose filter memory contains near-zero samples are therefore
correlated with the noise in ``g``, ``h``: in closed loop without compensation
plain LS on all rows overestimates Fs and sigma and gets tau's sign wrong on the
``paper`` preset, while the same rows with the noise-free velocity do not
(docs/benchmarks/compensation.md, ``benchmarks/compensation.py``). The estimator
therefore filters the indicator ``d = 1(|w| < w_band)`` with the same ``L`` and
uses a row only while ``L[d] <= dwell_max``: a row whose filter memory held no
near-zero sample (within ``dwell_max``).

``w_band`` adapts to the noise: ``max(w_band_min, 4*sigma_n)`` with the
noise level ``sigma_n`` estimated from the running mean of ``|w(k) - 2 w(k-1)
+ w(k-2)|`` (``= sqrt(6)*sqrt(2/pi)*sigma_n`` for white noise on a smooth signal).

Implementation
--------------
The estimator is the C struct ``aff_sliding`` (``adaptive_ff/csrc/aff_sliding.h``), which embeds its outlier gate,
its two range gates and its RLS (``aff_gate``, ``aff_range_gate``, ``aff_rls``); ``aff_sliding_observe`` is the one
implementation of a sample, called by :meth:`SlidingFrictionEstimator.observe` and by the C adaptive feedforward.
:func:`sliding_regressors` computes the same rows for a whole record with numpy and scipy.
"""

from __future__ import annotations

import functools
import math
import operator
from dataclasses import dataclass

import numpy as np

from adaptive_ff._caff import ffi, lib
from adaptive_ff.compensation.gate import RANGE_DEFAULTS, OutlierGate, RangeGate, range_gate_in
from adaptive_ff.identification.regression import FrictionEstimate
from adaptive_ff.identification.rls import RecursiveLeastSquares
from adaptive_ff.compensation.defaults import c_config_class, c_defaults
from plant.component import Component, struct_field, struct_fields
from plant.errors import ExcitationError, ParameterError, check_positive, check_signal
from plant.stribeck_map import stribeck_shape

__all__ = ["SlidingFrictionEstimator", "SlidingFrictionEstimatorConfig", "SlidingFit", "fit_sliding", "sliding_regressors", "SLIDING_NAMES",
           "estimate_from_theta", "FORGETTINGS"]

#: Parameter names of the full structure (lag and offset), in ``theta`` order.
SLIDING_NAMES = ("J", "J_tau", "tau", "Fc", "Fs", "sigma", "offset")

_NOISE_GAIN = math.sqrt(6.0) * math.sqrt(2.0 / math.pi)  # E|second difference| / sigma for white noise
_BAND_SIGMAS = 4.0


#: The C defaults of the estimator's settings (``aff_sliding_default_config``).
_SLIDING = c_defaults("aff_sliding_config")

#: The forgetting of the RLS by its C code (``AFF_RLS_EXPONENTIAL``, ``AFF_RLS_DIRECTIONAL``).
FORGETTINGS = {lib.AFF_RLS_EXPONENTIAL: "exponential", lib.AFF_RLS_DIRECTIONAL: "directional"}

SlidingFrictionEstimatorConfig = c_config_class(
    "SlidingFrictionEstimatorConfig", "aff_sliding_config", "aff_sliding.h", module=__name__,
    summary="Settings of a :class:`SlidingFrictionEstimator`: the update period, the filters, the RLS, the "
            "parameter structure, the sliding-regime gate, the bounds and the start's inertia. ``lam`` may also be "
            "one factor per parameter (an array, exponential forgetting); ``P_max`` 0 is ``p*P0``, ``w_band_min`` "
            "0 is ``0.1*Vs``; ``initial_J`` is the start's inertia where no ``initial`` estimate is given.",
    exclude=("Vs", "delta", "Tc", "initial_tau", "initial_Fc", "initial_Fs", "initial_sigma", "initial_offset"),
    fields={"forgetting": ("forgetting", FORGETTINGS)})


@functools.lru_cache(maxsize=None)
def _names(lag: bool, offset: bool) -> tuple:
    """The parameter names of the regression with the lag columns (``lag``) and the offset (``offset``), in
    :data:`SLIDING_NAMES` order (four structures, made once)."""
    return tuple(n for n in SLIDING_NAMES if (lag or n not in ("J_tau", "tau")) and (offset or n != "offset"))


def _check_int(name, v, lo):
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
        raise ParameterError(f"{name} must be an integer >= {lo}, got {v!r}")
    return int(v)


def estimate_from_theta(names, theta, Vs, delta, *, box=None) -> FrictionEstimate:
    """Physical parameters from a parameter vector of the sliding-regime regression.

    Parameters
    ----------
    names : sequence of str
        Parameter names of ``theta`` (a subset of :data:`SLIDING_NAMES`).
    theta : array_like, shape (p,)
        Parameter values.
    Vs, delta : float or None
        Stribeck factors attached to the estimate.
    box : tuple (lower, upper) of array_like, shape (p,), keyword-only
        Physical box of ``theta`` (e.g. :attr:`SlidingFrictionEstimator.box`): each parameter is clipped to
        it before the physical parameters are formed (``J_alt`` from the clipped ``J_tau`` and ``tau``).
        Default None: ``theta`` as it is (the unconstrained least-squares estimate of :func:`fit_sliding`).

    Returns
    -------
    FrictionEstimate
        With ``J_alt = J_tau/tau`` (NaN without the lag columns or for ``tau <= 0``) and ``offset`` 0
        without the offset column.

    Notes
    -----
    The clip is a statement about the report, not about the estimator: the
    RLS of :class:`SlidingFrictionEstimator` runs unconstrained (its Notes
    say why), and the clipped values are what it reports.
    """
    theta = list(map(float, theta))
    if box is not None:  # each entry clipped to [lo, hi], the bounds as Python floats
        lo, hi = box
        theta = list(map(min, map(max, theta, map(float, lo)), map(float, hi)))
    d = dict(zip(names, theta))
    tau = d.get("tau", 0.0)
    J_alt = d["J_tau"] / tau if ("J_tau" in d and tau > 0) else float("nan")
    return FrictionEstimate(J=d["J"], tau=tau, sigma=d["sigma"], Fc=d["Fc"], Fs=d["Fs"], offset=d.get("offset", 0.0),
                            Vs=Vs, delta=delta, J_alt=J_alt)


def _gates(gate, u_range, w_range) -> tuple:
    """The estimator's gates, their types checked: ``(gate, u_range, w_range)``, the outlier gate's default built, a
    range gate not given None (made in place in the struct from
    :data:`adaptive_ff.compensation.gate.RANGE_DEFAULTS`, :func:`adaptive_ff.compensation.gate.range_gate_in`;
    ``w_range``'s floor 0 stands for ``Vs``)."""
    gate = OutlierGate() if gate is None else gate
    if not isinstance(gate, OutlierGate):
        raise ParameterError(f"gate must be an OutlierGate, got {type(gate).__name__}")
    for name, g in (("u_range", u_range), ("w_range", w_range)):
        if g is not None and not isinstance(g, RangeGate):
            raise ParameterError(f"{name} must be a RangeGate, got {type(g).__name__}")
    return gate, u_range, w_range



@struct_fields("n_samples", "n_rejected", "n_gated", "updated")
class SlidingFrictionEstimator(Component):
    """Online estimate of ``J, tau, Fc, Fs, sigma`` (and a torque offset) from the controller's ``(u, w)`` stream.

    Parameters
    ----------
    Vs, delta : float
        Stribeck velocity (rad/s) and shape factor, pre-estimated (Sec. V-C).
    Tc : float, keyword-only
        Period (s) at which :meth:`observe` is called (the controller period).
    config : SlidingFrictionEstimatorConfig, keyword-only
        The settings (default: the C defaults, :class:`SlidingFrictionEstimatorConfig`), among them:

        ``Ts``
            Period of the RLS updates (s), a multiple of ``Tc``; default 10 ms
            (the filtered signals have a bandwidth of a few Hz, so faster updates
            add cost, not information).
        ``T_filter``
            Time constant ``T`` of each of the three filter stages (s); default 20 ms
            (about 8 Hz bandwidth for ``L``).
        ``lam``
            Forgetting factor per RLS update, in (0, 1] (an array: one per
            parameter); default 0.995 (memory ``Ts/(1 - lam)`` = 2 s of sliding
            data at Ts = 10 ms); a longer memory lags behind drifting friction
            (measured: docs/benchmarks/compensation.md).
        ``forgetting``
            RLS forgetting scheme (:class:`adaptive_ff.identification.rls.RecursiveLeastSquares`).
        ``P0``
            Initial covariance scale, default 1e4.
        ``P_max``
            Covariance bound ``trace(P) <= P_max`` (windup protection, see
            :class:`adaptive_ff.identification.rls.RecursiveLeastSquares`); default 0: ``trace(P0)``.
        ``initial_J``
            Inertia (kg·m²) of the start when ``initial`` is None, default 1.
        ``J_max``, ``tau_max``
            Upper bounds of the reported ``J`` (kg·m²) and ``tau`` (s) (:attr:`box`); defaults inf, 1.
        ``lag``
            Estimate the friction lag (columns ``L[s^2 w]``, ``-L[s u]``), default True.
        ``offset``
            Estimate a constant torque offset (captures e.g. the mean of
            direction-dependent Coulomb levels), default True.
        ``w_band_min``
            Smallest near-zero band (rad/s); default 0: ``0.1*Vs``.
        ``dwell_max``
            Largest admissible filtered near-zero indicator of a row, in [0, 1];
            default 0.01; 1 switches the sliding-regime gate off.
    initial : FrictionEstimate, keyword-only
        Starting point (e.g. the Stribeck pre-fit's Fc, Fs, sigma and the
        design inertia); default: ``J = config.initial_J``, all friction 0.
    gate : OutlierGate, keyword-only
        Plausibility gate of the velocity samples (jumps); default: non-finite only.
    u_range : RangeGate, keyword-only
        Range gate of the torque samples (N·m); default ``RangeGate()``: ``|u|``
        above 100 times the envelope of the accepted ``|u|`` (10 s memory at
        1 kHz) is out of range. Give ``x_max`` = the drive's torque limit to
        bound it absolutely.
    w_range : RangeGate, keyword-only
        Range gate of the velocity samples (rad/s); default ``RangeGate(floor=Vs)``:

        ``|w|`` above 100 times ``max(envelope of the accepted |w|, Vs)`` is out
        of range (a floor of 0 is replaced by ``Vs``).

    Attributes
    ----------
    rls : RecursiveLeastSquares
        The estimator, with ``theta`` in :attr:`names` order, without bounds
        (unconstrained; see Notes).
    box : tuple (lower, upper) of ndarray, shape (p,)
        The physical box of :attr:`estimate`: ``J in [1e-9, J_max]``, ``tau in
        [0, tau_max]``, ``J*tau in [0, J_max*tau_max]``, ``Fc, Fs, sigma >= 0``
        (the offset is free).
    names : tuple of str
        Parameter names (a subset of :data:`SLIDING_NAMES`).
    n_samples, n_rejected, n_gated : int
        Samples accepted, rejected (non-finite or out-of-range ``u`` or ``w``,
        velocity outliers: they leave the estimator unchanged but the counters)
        and update instants skipped by the sliding-regime gate.
    u_range, w_range : RangeGate
        The range gates (their envelopes and counters are live views).
    updated : bool
        Whether the last :meth:`observe` call updated the RLS.
    noise_std : float
        Current estimate of the velocity noise (rad/s).

    Raises
    ------
    ParameterError
        A setting out of range: C's ``aff_sliding_init`` refuses it, the message its sentence naming the field,
        its unit and range (the one validator); a vector ``lam`` of the wrong length; ``initial_J`` not > 0; a
        part of the wrong class.
    SettingTypeError
        ``Vs``, ``delta``, ``Tc`` or a field of ``config`` of the wrong type (a ParameterError and a TypeError).

    Notes
    -----
    See the module docstring for the model, the filters and the gate.

    The RLS state is not projected onto the physical box; only the reported
    :attr:`estimate` is clipped to it, and the robust feedforward
    (:class:`adaptive_ff.compensation.adaptive_feedforward.RobustAdaptiveFeedforward`)
    decides from the unclipped ``theta`` whether an estimate is plausible and
    determined. A projection of the state, even the one in the metric of
    ``P^-1``, diverges here: during the first move (one direction of motion
    only) ``L[g]``, ``L[h]`` and the offset column are nearly collinear, so
    ``P`` is ~1e4 along that direction and ~1e-4 across it, and a correction
    of one violated bound ``i`` moves every other parameter ``j`` by
    ``P[j, i]/P[i, i]`` times the violation, far along the unexcited
    direction, where it violates other bounds. Measured on the ``paper``
    joint with point-to-point moves (v 0.5 rad/s, a 4 rad/s²): ``theta`` ran
    away to 1e8 within 0.7 s of the first move and decayed over ~30 s, the
    feedforward refused 2056 of 2263 updates as implausible and never
    switched on (eta 0.00); the same log through the unconstrained RLS gives
    J 3.78, Fc 25.03, sigma 39.9 (true 4, 25, 40) from the 100th update on,
    and eta 1.00 in closed loop (docs/benchmarks/compensation.md, "Point-to-point
    moves: the unconstrained estimator"). Where the unconstrained estimate
    leaves the box (a lag-free joint's lag estimate scatters around 0), the
    robust feedforward uses a copy of it projected onto the plausible box in
    the same metric, the least-squares estimate under the bounds, computed
    exactly and once per decision rather than accumulated in the state
    (:func:`adaptive_ff.compensation.adaptive_feedforward.project_box`), and
    refuses a lag estimate clearly below 0 (its ``lag_zero``).
    """

    _ffi = ffi
    _ctype = "aff_sliding"
    _parts = {"gate": "gate", "u_range": "u_range", "w_range": "w_range", "rls": "rls"}

    #: The settings' class.
    Config = SlidingFrictionEstimatorConfig

    _lib = lib

    def __init__(self, Vs: float, delta: float, *, Tc: float, config: SlidingFrictionEstimatorConfig | None = None,
                 initial: FrictionEstimate | None = None, gate: OutlierGate | None = None,
                 u_range: RangeGate | None = None, w_range: RangeGate | None = None):
        cfg, names = self._plan(Vs, delta, Tc=Tc, config=config, initial=initial, gate=gate, u_range=u_range,
                                w_range=w_range)
        self._configure(lib.aff_sliding_init, cfg, lib.aff_error_message, names=names)
        self._built()

    def _plan(self, Vs, delta, *, Tc, config=None, initial=None, gate=None, u_range=None, w_range=None):
        """The constructor's checks and settings (``(cfg, error names)``) and the attributes they give; the parts
        given kept for :meth:`_built`."""
        config = SlidingFrictionEstimatorConfig() if config is None else config
        if not isinstance(config, SlidingFrictionEstimatorConfig):
            raise ParameterError(f"config must be a SlidingFrictionEstimatorConfig, got {type(config).__name__}")
        self.settings = c = config
        gate, u_range, w_range = _gates(gate, u_range, w_range)  # a default range gate is None: made in place
        # the ranges of Vs, delta, Tc and every field of config are aff_sliding_init's to check (the one validator:
        # a ParameterError naming the field, its unit and range); here only what C does not see: a vector lam's
        # length, and an initial_J that C would clip rather than refuse
        vector = type(c.lam) is not float and np.ndim(c.lam) > 0  # a float (the common case) is no vector
        p = len(_names(bool(c.lag), bool(c.offset)))
        if vector and np.size(c.lam) != p:
            raise ParameterError(f"lam must be a number or {p} numbers in (0, 1], got {c.lam!r}")
        if initial is None:
            first = {"J": check_positive("initial_J", c.initial_J), "tau": 0.0, "Fc": 0.0, "Fs": 0.0, "sigma": 0.0,
                     "offset": 0.0}
        else:  # clipped to the box by aff_sliding_init, which refuses a start that is not finite then
            first = {k: float(getattr(initial, k)) for k in ("J", "tau", "Fc", "Fs", "sigma", "offset")}
        cfg = self._settings("aff_sliding_config", lib.aff_sliding_default_config(), {
            "Vs": Vs, "delta": delta, "Tc": Tc, "Ts": c.Ts, "T_filter": c.T_filter,
            "forgetting": lib.AFF_RLS_VECTOR if vector else (lib.AFF_RLS_DIRECTIONAL if c.forgetting == "directional"
                                                             else lib.AFF_RLS_EXPONENTIAL),
            "lam": 1.0 if vector else c.lam, "lam_each": [float(x) for x in np.ravel(c.lam)] if vector else [0.0],
            "P0": c.P0, "P_max": c.P_max, "lag": c.lag, "offset": c.offset, "w_band_min": c.w_band_min,
            "dwell_max": c.dwell_max, "J_max": c.J_max, "tau_max": c.tau_max,
            **{f"initial_{k}": v for k, v in first.items()}})
        # the defaults C resolves, written into the settings kept (C checks Vs and P0 before these fields)
        cfg.P_max = p * cfg.P0 if cfg.P_max == 0 else cfg.P_max
        cfg.w_band_min = 0.1 * cfg.Vs if cfg.w_band_min == 0 else cfg.w_band_min
        cfg.gate = gate.config[0]
        cfg.u_range = RANGE_DEFAULTS if u_range is None else u_range.config[0]
        cfg.w_range = RANGE_DEFAULTS if w_range is None else w_range.config[0]
        if cfg.w_range.floor == 0.0:
            cfg.w_range.floor = cfg.Vs
        self.Vs, self.delta, self.Tc, self.T = float(cfg.Vs), float(cfg.delta), float(cfg.Tc), float(cfg.T_filter)
        self.lag, self.offset = bool(cfg.lag), bool(cfg.offset)
        self.names = _names(self.lag, self.offset)
        self.w_band_min, self.dwell_max, self.tau_max = float(cfg.w_band_min), float(cfg.dwell_max), float(cfg.tau_max)
        J_max = float(cfg.J_max)
        lower = {"J": 1e-9, "J_tau": 0.0, "tau": 0.0, "Fc": 0.0, "Fs": 0.0, "sigma": 0.0, "offset": -math.inf}
        upper = {"J": J_max, "J_tau": J_max * self.tau_max, "tau": self.tau_max, "Fc": math.inf, "Fs": math.inf,
                 "sigma": math.inf, "offset": math.inf}
        pick = operator.itemgetter(*self.names)  # at least four names: a tuple
        self._box = (np.array(pick(lower)), np.array(pick(upper)))
        self._given = (gate, u_range, w_range, float(cfg.P0), float(cfg.P_max), float(cfg.w_range.floor))
        return cfg, {lib.AFF_ERR_SLIDING_INITIAL: f"initial = {initial!r}"}

    def _built(self) -> None:
        """The constructor's steps once the struct is configured: the update period, the parts."""
        gate, u_range, w_range, P0, P_max, w_floor = self._given
        del self._given
        self.m = int(self._c.m)
        self.Ts = self.m * self.Tc
        # the RLS part over its field of the struct, as aff_sliding_init configured it and set its start to the
        # clipped initial estimate (no bounds on its state: the box applies to the reported estimate only, class
        # Notes)
        c = self.settings
        rls = RecursiveLeastSquares.in_place(self, "rls", lam=c.lam, P0=P0, forgetting=c.forgetting, P_max=P_max)
        # a default range gate over its field of the struct, as aff_sliding_init configured it (floor Vs for w)
        u_range = range_gate_in(self, "u_range") if u_range is None else u_range
        if w_range is None:
            w_range = range_gate_in(self, "w_range", w_floor)
        elif w_range.floor == 0.0:
            w_range = w_range.with_floor(self.Vs)
        self._attach(gate=gate, u_range=u_range, w_range=w_range, rls=rls)

    def __repr__(self) -> str:
        return (f"SlidingFrictionEstimator(Vs={self.Vs!r}, delta={self.delta!r}, Ts={self.Ts!r}, "
                f"T_filter={self.T!r}, n_updates={self.rls.n_updates})")

    @property
    def theta(self) -> np.ndarray:
        """Current parameter vector, shape (p,), names in :attr:`names`."""
        return self.rls.theta

    phi = struct_field("phi", doc="Regressor of the last RLS update, shape (p,) (a copy; valid while :attr:`updated` "
                       "is True).", size="p")

    @property
    def y(self) -> float:
        """Output of the last RLS update: the filtered torque ``L[u]`` half a period back (N·m; module docstring)."""
        return float(lib.aff_sliding_regressand(self._c))

    @property
    def n_updates(self) -> int:
        """Accepted RLS updates."""
        return self.rls.n_updates

    noise_std = struct_field("d2", lambda d2: float(d2) / _NOISE_GAIN,
                             "Running estimate of the velocity noise standard deviation (rad/s).")

    @property
    def w_band(self) -> float:
        """Current near-zero band (rad/s): ``max(w_band_min, 4*noise_std)``."""
        return max(self.w_band_min, _BAND_SIGMAS * float(self._c.d2) / _NOISE_GAIN)

    noise_variance = struct_field("e2", float, "Running mean of the normalised squared a-priori errors of the RLS, "
                                  "``err**2/(1 + phi @ P @ phi)`` (N·m²): the noise variance, the scale of "
                                  ":attr:`theta_cov`.")

    @property
    def theta_cov(self) -> np.ndarray:
        """Approximate covariance of ``theta``, shape (p, p): ``P`` times the running noise variance.

        The noise variance is the running mean of the squared a-priori errors, each divided by its own
        predicted variance factor ``1 + phi @ P @ phi`` (the innovation variance of the Kalman-filter form of
        RLS): an error that is large because the estimate was still uncertain in the direction of ``phi``
        (the first reversal after a stretch of one-sided motion) does not inflate the scale for the rest of
        the run. The filtered equation errors are correlated from row to row, so this
        understates the true uncertainty (by a factor of a few); use it for
        relative comparisons.
        """
        return float(self._c.e2) * self.rls.P

    @property
    def box(self) -> tuple:
        """``(lower, upper)`` of the reported estimate, arrays of shape (p,) in :attr:`names` order (copies)."""
        return self._box[0].copy(), self._box[1].copy()

    @property
    def estimate(self) -> FrictionEstimate:
        """Physical parameters of the current ``theta``, each clipped to :attr:`box` (the RLS state itself is
        unconstrained: class Notes)."""
        return estimate_from_theta(self.names, self.rls.theta, self.Vs, self.delta, box=self._box)

    def observe(self, u: float, w: float) -> bool:
        """Feed one controller-period sample (C: ``adaptive_ff/csrc/aff_sliding.c``, ``aff_sliding_observe``).

        Parameters
        ----------
        u : float
            Torque applied by the controller in this period (N·m), computed from ``w``.
        w : float
            Measured velocity at the start of the period (rad/s).

        Returns
        -------
        bool
            True if the sample was used; False if it was rejected (non-finite
            or out-of-range ``u`` or ``w``, see :attr:`u_range`, :attr:`w_range`,
            or a velocity outlier of :attr:`gate`): a rejected sample changes
            nothing but the counters.
        """
        return bool(lib.aff_sliding_observe(self._c, float(u), float(w)))


@dataclass(frozen=True)
class SlidingFit:
    """Result of :func:`fit_sliding` (batch least squares of the sliding-regime regression).

    Attributes
    ----------
    names : tuple of str
        Parameter names, a subset of :data:`SLIDING_NAMES`.
    theta : ndarray, shape (p,)
        Least-squares parameters (unconstrained).
    theta_std : ndarray, shape (p,)
        Standard errors ``sqrt(diag(s**2 (X^T X)^-1))`` (white-residual assumption).
    estimate : FrictionEstimate
        Physical parameters (``J_alt = J_tau/tau``: the redundant inertia).
    n_rows, n_gated : int
        Regression rows used, and rows removed by the sliding-regime gate.
    residual_rms : float
        RMS of the torque equation error over the rows used (N·m).
    """

    names: tuple
    theta: np.ndarray
    theta_std: np.ndarray
    estimate: FrictionEstimate
    n_rows: int
    n_gated: int
    residual_rms: float


def _batch_config(config, Tc) -> SlidingFrictionEstimatorConfig:
    """The settings of a batch fit: ``config``, or (None) the C defaults with a row every sample (``Ts = Tc``)."""
    return SlidingFrictionEstimatorConfig(Ts=Tc) if config is None else config


def sliding_regressors(u, w, *, Tc: float, Vs: float, delta: float,
                       config: SlidingFrictionEstimatorConfig | None = None) -> tuple:
    """The regression rows of :class:`SlidingFrictionEstimator` for a whole record (vectorised, same recursions).

    Parameters
    ----------
    u : array_like, shape (N,)
        Torque (N·m) applied over each period of length ``Tc``.
    w : array_like, shape (N,)
        Velocity (rad/s) measured at the start of each period.
    Tc : float, keyword-only
        Sample period of ``u``, ``w`` (s).
    Vs, delta : float, keyword-only
        Stribeck velocity (rad/s) and shape factor (pre-fit, Sec. V-C).
    config : SlidingFrictionEstimatorConfig, keyword-only, optional
        The estimator's settings whose ``Ts`` (row spacing, s, a multiple of ``Tc``), ``T_filter``, ``lag``,
        ``offset``, ``w_band_min`` and ``dwell_max`` make the rows, as in :class:`SlidingFrictionEstimator`
        (the RLS settings do not enter). Default: the C defaults with ``Ts = Tc`` (a row every sample).

    Returns
    -------
    X : ndarray, shape (M, p)
        Rows ``phi`` at the update instants that pass the sliding-regime gate.
    y : ndarray, shape (M,)
        ``L[u]`` at the same instants (N·m).
    index : ndarray of int, shape (M,)
        Sample index of each row.
    n_gated : int
        Update instants removed by the gate.
    names : tuple of str
        Column names.

    Raises
    ------
    SignalError
        Bad shapes or non-finite values.
    ParameterError
        Invalid settings.
    """
    u = check_signal("u", u, min_len=10)
    w = check_signal("w", w, n=u.shape[0])
    est = SlidingFrictionEstimator(Vs, delta, Tc=Tc, config=_batch_config(config, Tc))
    from scipy import signal  # lazy: scipy.signal is heavy to import

    a, D = float(est.cdata.a), float(est.cdata.D)
    lf = lambda x: signal.lfilter([a], [1.0, -(1.0 - a)], x)  # noqa: E731  x_i += a*(x_{i-1} - x_i)

    def cascade(x):
        x1 = lf(x)
        x2 = lf(x1)
        return x1, x2, lf(x2)

    d2 = np.zeros_like(w)
    d2[2:] = np.abs(w[2:] - 2.0 * w[1:-1] + w[:-2])
    nscale = signal.lfilter([0.01], [1.0, -0.99], d2)  # the estimator's running mean (it starts at sample 2)
    band = np.maximum(est.w_band_min, _BAND_SIGMAS * nscale / _NOISE_GAIN)
    aw = np.abs(w)
    e = np.where(aw > 0, stribeck_shape(np.where(aw > 0, aw, 1.0), est.Vs, est.delta), 1.0)
    sg = np.sign(w)
    w1, w2, w3 = cascade(w)
    u1, u2, u3 = cascade(u)
    *_, g3 = cascade(sg * (1.0 - e))
    *_, h3 = cascade(sg * e)
    *_, d3 = cascade((aw < band).astype(float))
    cols = [D * (w2 - w3)]
    if est.lag:
        cols += [D * D * (w1 - 2.0 * w2 + w3), -D * (u2 - u3)]
    cols += [g3, h3, w3]
    if est.offset:
        cols.append(np.ones_like(w))
    X = np.column_stack(cols)
    k = np.arange(1, w.shape[0] + 1)
    rows = (k % est.m == 0) & (k >= est.cdata.settle)
    keep = rows & (d3 <= est.dwell_max)
    y = 0.5 * (np.concatenate(([0.0], u3[:-1])) + u3)  # L[u] half a period back, as the differences (module doc)
    return X[keep], y[keep], np.flatnonzero(keep), int(np.count_nonzero(rows & ~keep)), est.names


def fit_sliding(u, w, *, Tc: float, Vs: float, delta: float,
                config: SlidingFrictionEstimatorConfig | None = None) -> SlidingFit:
    """Batch least-squares fit of the sliding-regime inverse-dynamics regression (offline twin of the estimator).

    Parameters
    ----------
    u : array_like, shape (N,)
        Torque (N·m) applied over each period of length ``Tc``.
    w : array_like, shape (N,)
        Velocity (rad/s) measured at the start of each period.
    Tc : float, keyword-only
        Sample period of ``u``, ``w`` (s).
    Vs, delta : float, keyword-only
        Stribeck velocity (rad/s) and shape factor (pre-fit, Sec. V-C).
    config : SlidingFrictionEstimatorConfig, keyword-only, optional
        As in :func:`sliding_regressors` (``Ts``, ``T_filter``, ``lag``, ``offset``, ``w_band_min``,
        ``dwell_max``; default the C defaults with ``Ts = Tc``); the rows are those of
        :func:`sliding_regressors`, identical to the estimator's.

    Returns
    -------
    SlidingFit

    Raises
    ------
    SignalError
        Bad shapes or non-finite values.
    ExcitationError
        Fewer rows than ``2*p`` survive the gate, or the rows are rank deficient.
    ParameterError
        Invalid settings.

    Notes
    -----
    Unconstrained least squares via the SVD of the column-scaled rows
    (Golub & Van Loan, *Matrix Computations*, Sec. 5.3); standard errors from
    ``s**2 (X^T X)^-1``.
    """
    X, y, _, n_gated, names = sliding_regressors(u, w, Tc=Tc, Vs=Vs, delta=delta, config=config)
    p = X.shape[1]
    if X.shape[0] < 2 * p:
        raise ExcitationError(f"only {X.shape[0]} regression rows in the sliding regime (need >= {2 * p}); "
                              "the data hardly leave zero velocity")
    scale = np.linalg.norm(X, axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    Xs = X / scale
    U, sv, Vt = np.linalg.svd(Xs, full_matrices=False)
    if sv[-1] <= 1e-12 * sv[0]:
        weak = names[int(np.argmax(np.abs(Vt[-1])))]
        raise ExcitationError(f"sliding-regime rows are rank deficient; {weak!r} is not identifiable")
    theta = (Vt.T @ ((U.T @ y) / sv)) / scale
    resid = y - X @ theta
    s2 = float(resid @ resid) / max(X.shape[0] - p, 1)
    theta_std = np.sqrt(s2 * np.sum((Vt.T / sv) ** 2, axis=1)) / scale
    return SlidingFit(names=names, theta=theta, theta_std=theta_std,
                      estimate=estimate_from_theta(names, theta, float(Vs), float(delta)), n_rows=int(X.shape[0]),
                      n_gated=n_gated, residual_rms=float(np.sqrt(np.mean(resid**2))))
