"""Adaptive friction feedforward (online RLS, the paper's future work): the recommended component for a running machine.

:class:`RobustAdaptiveFeedforward` (compensator mode ``adaptive``) puts the estimates of a
:class:`~adaptive_ff.compensation.sliding_estimator.SlidingFrictionEstimator` (sliding-regime inverse-dynamics RLS
with directional forgetting and an outlier gate, see :mod:`adaptive_ff.compensation.sliding_estimator`)
into the fixed feedforward of :mod:`adaptive_ff.compensation.feedforward`, each only after the warm-up and the
plausibility tests, faded in after switch-on; optionally a provisional start map, :class:`FeedforwardStart`, acts
until its first trusted estimate.

Its configuration and state are the C struct ``aff_robust_ff`` (``adaptive_ff/csrc/aff_robust_ff.h``), which
embeds the fixed feedforward's struct and the estimator's (with its gates and RLS), configured from the settings
``aff_robust_ff_config`` (the parts' settings and the provisional start) by ``aff_robust_ff_init``. C is the one
implementation, called by the class's methods and by the closed-loop engine: the compensator interface
``aff_robust_ff_compensate`` / ``aff_robust_ff_observe`` (ops table ``aff_robust_ff_ops``), the plausibility test
``aff_robust_ff_plausible``, the determinacy test ``aff_fc_determined`` (:func:`fc_determined`) and the weighted
lag ``aff_robust_ff_lag_weighted`` (:func:`lag_weighted`). The paper's eq. 4 RLS feedforward, kept as a baseline,
is :mod:`adaptive_ff.compensation.eq4_feedforward`.
"""

from __future__ import annotations

import functools
import math
import operator
from dataclasses import dataclass, fields, replace

import numpy as np

from adaptive_ff._caff import ffi, lib
from adaptive_ff.compensation.feedforward import FF_INPUTS, FrictionFeedforward, FrictionFeedforwardConfig
from adaptive_ff.compensation.sliding_estimator import SlidingFrictionEstimator, estimate_from_theta
from adaptive_ff.compensation.velocity_input import LoopModel, SignObserver
from adaptive_ff.identification.regression import FrictionEstimate
from adaptive_ff.identification.rls import RLS_NMAX
from adaptive_ff.compensation.defaults import c_config_class, c_defaults
from plant.component import struct_field, struct_fields
from plant.errors import ParameterError, check_optional
from plant.results import json_safe

__all__ = ["RobustAdaptiveFeedforward", "RobustAdaptiveFeedforwardConfig", "FeedforwardStart", "start_output", "lag_weighted", "fc_determined",
           "project_box", "FC_INFO_FRACTION"]

#: The C defaults of the provisional start (``aff_start_default_config``): :class:`FeedforwardStart`'s defaults.
_START = c_defaults("aff_start_config")
#: The fields of a :class:`FrictionEstimate`, in order: the keys of its ``to_dict()``.
_ESTIMATE_FIELDS = tuple(f.name for f in fields(FrictionEstimate))
_estimate_values = operator.attrgetter(*_ESTIMATE_FIELDS)


def _estimate_dict(est: FrictionEstimate) -> dict:
    """``est.to_dict()`` of an estimate whose fields are numbers or None (the estimator's: the same strict-JSON dict,
    without ``dataclasses.asdict``'s deep copy)."""
    return dict(zip(_ESTIMATE_FIELDS, map(json_safe, _estimate_values(est))))

RobustAdaptiveFeedforwardConfig = c_config_class(
    "RobustAdaptiveFeedforwardConfig", "aff_robust_ff_config", "aff_robust_ff.h", module=__name__,
    summary="Settings of a :class:`RobustAdaptiveFeedforward`: its feedforward's (``ff``) and the use of the "
            "estimates (warm-up, fade-in, plausibility, the lag in use, the projection).",
    fields={"ff": FrictionFeedforwardConfig})

#: Fraction of the RLS prior variance below which the data have determined ``Fc`` (see :func:`fc_determined`;
#: ``FC_INFO_FRACTION`` of ``adaptive_ff/csrc/aff_robust_ff.c``).
FC_INFO_FRACTION = 0.01


def fc_determined(max_rel_stderr, e2, P_FcFc, P_prior, eFc, eFs) -> bool:
    """The determinacy test of ``Fc`` (class Notes of :class:`RobustAdaptiveFeedforward`; C ``aff_fc_determined``):
    True if both

    - its standard error ``sqrt(e2*P_FcFc)`` is at most ``max_rel_stderr*max(Fc, Fs)`` (``e2`` the estimator's
      noise variance, N·m²), and
    - the data have reduced its entry of ``P`` to at most :data:`FC_INFO_FRACTION` of the prior variance
      ``P_prior`` (:attr:`adaptive_ff.identification.rls.RecursiveLeastSquares.prior_variance`): a direction the
      data do not excite (one direction of motion only: the ``Fc`` and offset columns are the same) keeps ``P``
      at the prior's order however small the noise, where the standard error alone would pass on clean data.

    ``max_rel_stderr = inf`` disables the test (always True).
    """
    return bool(lib.aff_fc_determined(max_rel_stderr, e2, P_FcFc, P_prior, eFc, eFs))


def lag_weighted(ff: "RobustAdaptiveFeedforward", etau: float, sd: float) -> float:
    """Take one lag estimate into the weighted mean of a :class:`RobustAdaptiveFeedforward` and return the mean
    (C ``aff_robust_ff_lag_weighted``).

    Parameters
    ----------
    ff : RobustAdaptiveFeedforward
        The feedforward (its struct holds the mean and its total weight, updated).
    etau : float
        The lag estimate (s).
    sd : float
        Its standard error (s).

    Returns
    -------
    float
        ``sum(l**(n-k) * x_k / sd_k**2) / sum(l**(n-k) / sd_k**2)`` over the estimates ``x_k`` taken so far
        (``l = exp(-Ts/lag_memory)``, recursively: the weighted least-squares mean with forgetting, Ljung,
        *System Identification*, 2nd ed., 1999, Sec. 11.2); ``etau`` itself, the mean unchanged, where
        ``lag_memory`` is 0 or ``sd`` is not > 0.
    """
    return float(lib.aff_robust_ff_lag_weighted(ff.cdata, float(etau), float(sd)))


def project_box(P, theta, lower, upper) -> tuple:
    """Projection of ``theta`` onto a box in the metric of ``P^-1`` (C ``aff_project_box``).

    Solves ``min (x - theta)' P^-1 (x - theta)`` subject to ``lower <= x <= upper`` exactly (primal active-set
    method for convex QP, Nocedal & Wright, *Numerical Optimization*, 2nd ed., 2006, Alg. 16.3; with the working
    set ``W`` at its bounds the minimiser is ``theta + P[:, W] mu``, ``P[W, W] mu = b_W - theta_W``). With ``P``
    the covariance of a least-squares estimate ``theta`` this is the least-squares estimate under the bounds
    (Goodwin & Sin, *Adaptive Filtering, Prediction and Control*, 1984, Sec. 3.3.7).

    Parameters
    ----------
    P : array_like, shape (p, p)
        Symmetric positive definite matrix (the RLS covariance), 1 <= p <= ``AFF_RLS_NMAX``.
    theta : array_like, shape (p,)
        The unconstrained estimate.
    lower, upper : array_like, shape (p,)
        Bounds (``-inf``/``inf`` for a free parameter), ``lower <= upper``, ``lower < inf``, ``upper > -inf``.

    Returns
    -------
    x : ndarray, shape (p,)
        The projection (``theta`` itself where it lies in the box).
    n_active : int
        Bounds active at ``x``.

    Raises
    ------
    ParameterError
        Shapes that do not match, non-finite ``P`` or ``theta``, an empty bound pair, or a ``P`` not symmetric
        positive definite.
    """
    P = np.ascontiguousarray(P, dtype=float)
    theta = np.ascontiguousarray(theta, dtype=float)
    lo = np.ascontiguousarray(lower, dtype=float)
    hi = np.ascontiguousarray(upper, dtype=float)
    p = theta.size
    if theta.ndim != 1 or not 1 <= p <= RLS_NMAX:
        raise ParameterError(f"theta must be a vector of 1..{RLS_NMAX} entries, got shape {theta.shape}")
    if P.shape != (p, p) or lo.shape != (p,) or hi.shape != (p,):
        raise ParameterError(f"P must have shape {(p, p)} and lower, upper {(p,)}, got {P.shape}, {lo.shape}, "
                             f"{hi.shape}")
    if not (np.all(np.isfinite(P)) and np.all(np.isfinite(theta))):
        raise ParameterError("P and theta must be finite")
    if not (np.all(lo <= hi) and np.all(lo < np.inf) and np.all(hi > -np.inf)):
        raise ParameterError(f"bounds must satisfy lower <= upper, got {lo!r}, {hi!r}")
    cov = ffi.new("aff_rls *")  # P as an RLS covariance (its factors): the form aff_project_box reads
    cfg = lib.aff_rls_default_config()
    cfg.n_params = p
    lib.aff_rls_init(cov, ffi.new("aff_rls_config *", cfg))
    if lib.aff_rls_set_P(cov, ffi.from_buffer("double[]", P)) != lib.AFF_OK:
        raise ParameterError("project_box: P must be symmetric positive definite")
    x = np.empty(p)
    n = lib.aff_project_box(p, cov, ffi.from_buffer("double[]", theta),
                            ffi.from_buffer("double[]", lo), ffi.from_buffer("double[]", hi),
                            ffi.from_buffer("double[]", x), ffi.new("double[]", p * (p + 3)))
    if n < 0:
        raise ParameterError("project_box: P is not positive definite on the active bounds")
    return x, int(n)


@dataclass(frozen=True)
class FeedforwardStart:
    """Provisional start of :class:`RobustAdaptiveFeedforward`: a prior friction map in use from the first
    period until the estimator's first trusted estimate.

    Parameters
    ----------
    estimate : FrictionEstimate
        The prior map: ``Fc``, ``Fs`` (N·m), ``sigma`` (N·m·s/rad), ``Vs`` (rad/s) and ``delta`` of eq. 3 (e.g.
        the quasi-static Stribeck pre-fit, Sec. V-C), and the lag ``tau`` (s) its output is filtered
        through (eq. 1). ``Vs``/``delta`` None: the estimator's. ``J`` and ``offset`` are not used.
    gain : float
        Factor on the start map, in (0, 1], default 1. At the hand-over the output fades from ``gain`` to
        1 over the feedforward's ``fade_in``.
    ff_input : {"reference", "measured"}
        Velocity the start map is evaluated at: the reference (default) or as the feedforward's
        ``ff_input`` says. At the reference the start map is an exogenous input, not a feedback: a wrong
        lag or level cannot form a stick-slip cycle with the joint (a friction map fed back from the
        measured velocity through a lag shorter than the joint's kicks the joint by about ``2*Fs*dtau/J``
        at every reversal).

    Raises
    ------
    ParameterError
        ``gain`` outside (0, 1], unknown ``ff_input``, or a non-finite or negative level or lag.
    """

    estimate: FrictionEstimate
    gain: float = _START["gain"]
    ff_input: str = FF_INPUTS[_START["at_ref"]]

    def __post_init__(self):
        if not isinstance(self.estimate, FrictionEstimate):
            raise ParameterError(f"estimate must be a FrictionEstimate, got {type(self.estimate).__name__}")
        e = self.estimate
        for name in ("Fc", "Fs", "sigma", "tau"):
            v = getattr(e, name)
            if not (math.isfinite(v) and v >= 0.0):
                raise ParameterError(f"start estimate: {name} must be finite and >= 0, got {v!r}")
        if not (0.0 < self.gain <= 1.0):
            raise ParameterError(f"start gain must be in (0, 1], got {self.gain!r}")
        if self.ff_input not in FF_INPUTS:
            raise ParameterError(f"start ff_input must be one of {FF_INPUTS}, got {self.ff_input!r}")

    def map_args(self, Vs: float | None, delta: float | None) -> tuple:
        """``(Fc, Fs, Vs, delta, sigma, tau)`` of the start map for the C start of a feedforward
        (``aff_start_config`` of ``aff_robust_ff_config``, ``aff_eq4_ff_start``): its own ``Vs`` and ``delta``, else
        the feedforward's ``Vs``, ``delta`` given here (rad/s, -).

        Raises
        ------
        ParameterError
            Neither gives ``Vs`` and ``delta`` (a feedforward without the Stribeck term and a start without them).
        """
        e = self.estimate
        Vs, delta = (Vs if e.Vs is None else e.Vs), (delta if e.delta is None else e.delta)
        if Vs is None or delta is None:
            raise ParameterError("start: a start map needs Vs and delta, its own or the model's (the model has no "
                                 "Stribeck term)")
        return e.Fc, e.Fs, Vs, delta, e.sigma, e.tau


def start_output(step, w: float, w_ref: float | None, *, at_ref: bool, gain: float) -> float:
    """One period of a provisional start map in a feedforward's Python ``step`` (N·m): ``step(w_ref)`` for a start
    at the reference (``at_ref``) when ``w_ref`` is given, else ``step(w, w_ref)``, times ``gain``; ``step`` is the
    feedforward's :meth:`FrictionFeedforward.step` with the start map in use, ``at_ref`` and ``gain`` its struct's
    ``start_at_ref`` and ``start_gain`` (the Python side of C ``aff_fixed_ff_start_output``)."""
    if at_ref and w_ref is not None:
        return step(w_ref) * gain
    return step(w, w_ref) * gain


@struct_fields(
    "warmup", "tau_max", "consistency", "n_implausible", "n_lag_held", "n_undetermined", "lag_margin",
    "lag_margin_max", "max_rel_stderr", "lag_zero", "project", "n_lag_zero", "n_boxed", "provisional"
)
class RobustAdaptiveFeedforward(FrictionFeedforward):
    """Adaptive friction feedforward for a running machine: safe online estimation plus the lagged feedforward.

    Parameters
    ----------
    estimator : SlidingFrictionEstimator
        The online estimator (sliding-regime inverse-dynamics RLS with
        directional forgetting and an outlier gate);
        :meth:`observe` feeds it.
    dt : float, keyword-only
        Call period of :meth:`step` (s), normally the estimator's ``Tc``.
    config : RobustAdaptiveFeedforwardConfig, keyword-only
        The settings (default: the C defaults, :class:`RobustAdaptiveFeedforwardConfig`): its field ``ff`` holds
        the feedforward's (:class:`~adaptive_ff.compensation.feedforward.FrictionFeedforwardConfig`), the others
        the use of the estimates:

        ``warmup``
            RLS updates in the sliding regime before the feedforward is switched
            on (excitation gate), default 200 (2 s of sliding at Ts = 10 ms).
        ``fade_in``
            After switch-on the output is ramped from 0 to full over this time
            (s), so that the PI integrator, which carried the friction so far,
            unloads smoothly (bumpless transfer); default 1 s, 0 = step.
        ``J_lo``, ``J_hi``
            Plausible inertia interval (kg·m²), exclusive; an estimate outside it is not
            used. Default ``(0, inf)``.
        ``tau_max``
            Largest plausible lag (s), default 1.
        ``consistency``
            The lag is identified twice (``tau`` and ``J*tau``): the lag of an
            estimate whose two values differ by more than ``consistency*J*tau``
            and by more than three standard deviations (delta method on
            :attr:`SlidingFrictionEstimator.theta_cov`) is not used (for
            ``tau >= 2*dt``); default 0.5.
        ``lag_margin``
            The lag in use is the estimated ``tau`` plus this many of its
            standard errors (``sqrt`` of the ``tau`` diagonal element of
            :attr:`SlidingFrictionEstimator.theta_cov`), at most
            ``lag_margin_max*tau`` more, clipped to ``tau_max``: a one-sided
            upper confidence bound (see Notes). Default 1; 0: the estimate
            itself.
        ``lag_margin_max``
            Largest margin as a fraction of the estimated lag (inf: no cap),
            default 0.05: the cost of a lag error is lopsided only for small
            errors (a lag far too long under-compensates every reversal), and
            ``theta_cov`` of a weakly excited lag can exceed the lag itself.
        ``max_rel_stderr``
            An estimate is used only once ``Fc`` is determined (:func:`fc_determined`): its
            standard error (from :attr:`SlidingFrictionEstimator.theta_cov`) at most this
            fraction of ``max(Fc, Fs)``, and its entry of the RLS ``P`` reduced by the data
            to at most 1 % of the prior variance. Default 0.05; inf: no test.
        ``lag_memory``
            Memory (s) of the lag in use: the lag estimates put in use are
            averaged with the weights ``1/sd**2`` (``sd`` the standard error of
            each, see ``lag_margin``), each weight forgotten by
            ``exp(-Ts/lag_memory)`` per estimator update (see Notes); the margin
            is added to that mean. Default 10 s (five memories of the default
            RLS); 0: the latest estimate itself.
        ``lag_zero``
            A lag estimate below 0 by at most ``max(lag_zero*sd, 2*dt)`` (``sd``
            its standard error, see ``lag_margin``; in standard errors) is lag
            0: a lag-free joint's estimate scatters around 0 and half of it
            falls below. A lower lag estimate refuses the estimate. Default 3;
            inf: every negative lag is 0; 0: a negative lag refuses the
            estimate.
        ``project``
            Use the projection of a copy of the estimator's ``theta`` onto the
            plausible box in the metric of ``P^-1`` (:func:`project_box`: the
            least-squares estimate under the bounds ``J*tau >= 0``, ``0 <= tau
            <= tau_max``, ``0 <= Fc, Fs <= ff_max``, ``sigma >= 0``) instead of
            refusing an estimate outside it; the RLS state stays unconstrained.
            Default True.

        The feedforward's, ``config.ff``:

        ``lag``
            Filter the feedforward through the estimated lag ``tau`` (eq. 1);
            default True. Without the lag a static map at the measured velocity
            jumps by ``2*Fs`` at every reversal while the real friction takes
            ``tau`` to follow (measured: docs/benchmarks/compensation.md).
        ``ff_max``
            Bound on |feedforward| (N·m); estimates with ``Fc`` or ``Fs`` above it
            are implausible. Default inf.
        ``sign_width``
            Sign treatment near zero velocity, see :class:`FrictionFeedforward`.
        ``stick_band``, ``stick_samples``
            Stick detection, see :class:`FrictionFeedforward`.
        ``ff_input``, ``w_max``
            See :class:`FrictionFeedforward`.
    loop_model, sign_observer : keyword-only
        See :class:`FrictionFeedforward`.
    start : FeedforwardStart or None, keyword-only
        Provisional start: the prior map acts from the first period (times its gain) until the first
        estimate that passes warm-up and the plausibility tests, then that estimate takes over and the
        output fades from the start gain to 1 over ``fade_in``. Default None: no feedforward before
        switch-on.

    Attributes
    ----------
    estimator : SlidingFrictionEstimator
        Its struct is embedded in this component's (:attr:`cdata`, ``aff_robust_ff``): a copy of the struct is a
        complete, independent compensator.
    n_implausible : int
        Estimates (after warm-up) that failed the plausibility test; the
        feedforward kept the previous one.
    n_lag_held : int
        Estimates whose friction levels were used with the previous lag
        (the two lag estimates disagreed), see :meth:`observe`.
    n_undetermined : int
        Plausible estimates not used because ``Fc`` was not determined yet
        (``max_rel_stderr``).
    n_lag_zero : int
        Estimates whose lag estimate below 0 was taken as lag 0 (``lag_zero``).
    n_boxed : int
        Estimates the projection moved onto the plausible box (``project``).
    active : bool
        Whether the feedforward is switched on.

    Raises
    ------
    ParameterError
        Invalid settings (the message quotes the value).

    Notes
    -----
    Safety chain: (1) samples with non-finite values or velocity outliers are
    rejected by the estimator and leave it unchanged; (2) rows outside the
    sliding regime are not used (excitation/validity gate); (3) the
    covariance bound (or directional forgetting) of the estimator's RLS keeps
    ``P`` bounded when the motion does not excite (windup protection);
    (4) the RLS state ``theta`` is not projected onto physical bounds (a
    projection of the state diverges after one-sided motion:
    :class:`~adaptive_ff.compensation.sliding_estimator.SlidingFrictionEstimator`,
    Notes); instead (5) after ``warmup`` updates a lag estimate below 0
    within ``lag_zero`` standard errors is lag 0 (a lower one refuses the
    estimate), a copy of ``theta`` is projected onto the plausible box
    (``project``, :func:`project_box`), and that estimate is used only if
    plausible (finite, ``J`` in ``J_range``, ``0 <= tau <= tau_max``,
    ``sigma >= 0``, ``0 <= Fc, Fs <= ff_max``), determined (the standard error of ``Fc`` at most
    ``max_rel_stderr*max(Fc, Fs)``) and with consistent lag estimates,
    otherwise the last usable one is held (an inconsistent lag alone keeps
    the previous ``tau`` and takes the new friction levels); (6) the output
    fades in after switch-on and is clipped to ``±ff_max``.

    The projection of (5) is the box-constrained least-squares estimate: the
    RLS minimises a cost that is ``(x - theta)' P^-1 (x - theta)`` (times
    the noise variance) plus a constant, so its minimiser under the bounds is
    the projection of ``theta`` in that metric (Goodwin & Sin, *Adaptive
    Filtering, Prediction and Control*, 1984, Sec. 3.3.7). A parameter pushed
    onto a bound moves the others along their correlation with it (a joint
    without lag: ``tau`` to 0 and the levels to their best fit without the
    lag columns). Deciding on the raw ``theta`` refused such estimates for
    whole runs (docs/benchmarks/compensation.md, "the unconstrained
    estimator").

    The determinacy test of (5) matters after motion in one direction only:
    there the Coulomb column ``sgn(w)`` equals the offset column, the RLS
    fits ``Fc + offset`` and not ``Fc``, and the map (which has no offset)
    would over-compensate the first motion in the other direction by the
    offset; the covariance says so (the standard error of ``Fc`` stays large
    until both directions are seen).

    The lag in use is an upper confidence bound, not the point estimate
    (a cautious rather than a certainty-equivalence use of the estimate:
    Åström & Wittenmark, *Adaptive Control*, 2nd ed., 1995, Ch. 7), because
    the two signs of a small lag error do not cost the same. A feedforward
    at the measured velocity through a lag shorter than the joint's reverses
    before the friction does and over-compensates at every reversal, which
    pushes the joint on in the new direction and is fed back through the
    measurement (over-compensation of friction drives the loop towards
    hunting: Armstrong-Hélouvry, Dupont & Canudas de Wit, *Automatica*
    30(7), 1994); a slightly longer lag under-compensates for a moment, a
    disturbance the PI removes. A lag far too long under-compensates every
    reversal and costs as well, hence ``lag_margin_max``. The measured cost
    of both signs is on docs/benchmarks/compensation.md.

    The lag in use is also an information-weighted mean of the lag estimates
    (``lag_memory``), not the latest one. Through a stretch of slow, smooth
    motion the regressor's acceleration columns carry little more than the
    measurement noise, and a least-squares estimate with noise in its
    regressors is biased towards zero (attenuation, errors in variables:
    Söderström & Stoica, *System Identification*, 1989, Sec. 7.2), so the
    estimated ``J`` and ``J*tau`` and with them ``tau`` drift down while
    the forgetting RLS forgets the better-excited past. The covariance
    shows it (the standard error of ``tau`` grows several-fold) but the
    bias can be several of those standard errors, more than the margin
    covers. Weighting each estimate by its inverse variance keeps the lag
    of the well-excited data until the motion excites the lag again; a
    steady change of the lag is followed within about ``lag_memory``.

    Which velocity the feedforward is evaluated at (reference or measured) is the caller's choice; measured on
    the ``paper`` preset the measured velocity is the better one (the joint
    lags the reference at reversals), see ``benchmarks/compensation.py`` and
    docs/benchmarks/compensation.md.
    """

    #: The C ops table (``aff_compensator_ops``) the closed-loop engine calls with :attr:`cdata`.
    C_OPS = "aff_robust_ff_ops"
    MODE = "adaptive"
    _ctype = "aff_robust_ff"
    _parts = {"estimator": "est"}

    #: The settings' class.
    Config = RobustAdaptiveFeedforwardConfig

    _lib = lib

    def __init__(self, estimator: SlidingFrictionEstimator, *, dt: float,
                 config: RobustAdaptiveFeedforwardConfig | None = None, start: FeedforwardStart | None = None,
                 loop_model: LoopModel | None = None, sign_observer: SignObserver | None = None):
        cfg, _ = self._plan(estimator, dt=dt, config=config, start=start, loop_model=loop_model,
                            sign_observer=sign_observer)
        self._configure(lib.aff_robust_ff_init, cfg, lib.aff_error_message)
        self._built()

    def _plan(self, estimator, *, dt, config=None, start=None, loop_model=None, sign_observer=None):
        """The constructor's checks and settings (``(cfg, None)``) and the attributes they give."""
        if not isinstance(estimator, SlidingFrictionEstimator):
            raise TypeError(f"estimator must be a SlidingFrictionEstimator, got {type(estimator).__name__}")
        config = RobustAdaptiveFeedforwardConfig() if config is None else config
        if not isinstance(config, RobustAdaptiveFeedforwardConfig):
            raise ParameterError(f"config must be a RobustAdaptiveFeedforwardConfig, got {type(config).__name__}")
        ff = FrictionFeedforward.checked_settings(dt=dt, config=config.ff, loop_model=loop_model,
                                                  sign_observer=sign_observer)  # its struct: this one's field ff
        self.loop_model = loop_model
        self.sign_observer = sign_observer
        check_optional("start", start, FeedforwardStart)
        self.estimator = estimator
        self.n_theta = len(estimator.names)
        own = config.c_fields()  # a new dict: the feedforward's settings are the checked ones above
        del own["ff"]
        cfg = self._settings("aff_robust_ff_config", lib.aff_robust_ff_default_config(), own, counts=("warmup",))
        cfg.ff, cfg.est = ff[0], estimator.config[0]
        if start is not None:
            Fc, Fs, Vs, delta, sigma, tau = start.map_args(estimator.Vs, estimator.delta)
            cfg.start = {"on": True, "Fc": Fc, "Fs": Fs, "Vs": Vs, "delta": delta, "sigma": sigma, "tau": tau,
                         "gain": start.gain, "at_ref": start.ff_input == "reference"}  # else off, the C defaults
        self.settings = config
        self.start = start
        return cfg, None

    def _built(self) -> None:
        """The constructor's step once the struct is configured: the parts point into it."""
        self._attached()

    def _attached(self) -> None:
        """The feedforward part and the estimator (with its parts) point into this component's struct."""
        super()._attached()
        self._f = ffi.addressof(self._c, "ff")

    J_range = property(lambda self: (float(self._c.J_lo), float(self._c.J_hi)),
                       doc="Plausible inertia interval (kg·m²).")

    @property
    def lag_memory(self) -> float:
        """Memory (s) of the inverse-variance weighted lag in use; 0: the latest estimate; inf where the forgetting
        factor ``exp(-Ts/lag_memory)`` rounds to 1."""
        lam = float(self._c.lag_forget)
        if not lam > 0.0:
            return 0.0
        return math.inf if lam >= 1.0 else -self.estimator.Ts / math.log(lam)

    @property
    def estimate(self) -> FrictionEstimate | None:
        """The estimator's estimate in use (None before switch-on and during the provisional start; projected onto
        the plausible box with ``project``), with the lag in use: the weighted mean of the lag estimates (``lag_memory``) plus ``lag_margin`` standard errors, or the
        previous lag where the lag estimates disagreed (then ``J_alt`` is NaN)."""
        if not self._f.has or self._c.provisional:
            return None
        e = estimate_from_theta(self.estimator.names, ffi.unpack(self._c.theta_used, self.n_theta),
                                self.estimator.Vs, self.estimator.delta)
        return replace(e, tau=float(self._f.tau), J_alt=float("nan") if self._c.held else e.J_alt)

    @estimate.setter
    def estimate(self, value) -> None:
        if value is not None:
            raise ParameterError("the estimate of a RobustAdaptiveFeedforward is set by its estimator only")

    def step(self, w: float, w_ref: float | None = None) -> float:
        """Advance one period; return the bounded feedforward (N·m), 0 before switch-on.

        See :meth:`FrictionFeedforward.step`; after switch-on the output fades in over ``fade_in``. During the
        provisional start the start map times its gain, at ``w_ref`` (when given) for a start at the reference.
        """
        c = self._c
        if not self._f.has:
            return 0.0
        if c.provisional:  # the start map, at the reference when the start says so (as in compensate)
            return start_output(functools.partial(FrictionFeedforward.step, self), w, w_ref,
                                at_ref=bool(c.start_at_ref), gain=float(c.start_gain))
        out = FrictionFeedforward.step(self, w, w_ref)
        if c.gain < 1.0:
            c.gain = min(c.gain + c.fade, 1.0)
            return out * float(c.gain)
        return out

    def compensate(self, w_meas: float, w_ref: float) -> float:
        """Compensator protocol: the faded-in feedforward for this period (N·m), C ``aff_robust_ff_compensate``."""
        return float(lib.aff_robust_ff_compensate(self._c, float(w_meas), float(w_meas), float(w_ref)))

    def decide(self) -> bool:
        """Take the estimator's current ``theta`` through the tests of point (5) of the class Notes and put it into
        use if it passes (what :meth:`observe` does after each RLS update past the warm-up; C
        ``aff_robust_ff_decide``).

        Returns
        -------
        bool
            True if the estimate is in use (possibly with the previous lag held), False if refused (counted in
            :attr:`n_implausible` or :attr:`n_undetermined`).
        """
        return bool(lib.aff_robust_ff_decide(self._c))

    def plausible(self, est: FrictionEstimate) -> bool:
        """The plausibility test of point (5) of the class Notes: range checks and lag consistency (C
        ``aff_robust_ff_plausible``)."""
        return bool(lib.aff_robust_ff_plausible(self._c, est.J, est.tau, est.J_alt, est.Fc, est.Fs, est.sigma))

    active = struct_field("has", bool, "True once the feedforward acts: a plausible estimate, or the provisional "
                          "start map, is in use.", via="_f")

    @property
    def theta(self) -> np.ndarray:
        """The estimator's current parameter vector."""
        return self.estimator.theta

    @property
    def n_rejected(self) -> int:
        """Samples rejected by the estimator (non-finite or outliers)."""
        return self.estimator.n_rejected

    def info(self) -> dict:
        """Counters and settings of the estimator and the plausibility tests (for run reports)."""
        e = self.estimator
        return {"estimator": "sliding", "n_rejected": e.n_rejected, "n_implausible": self.n_implausible,
                "n_undetermined": self.n_undetermined, "n_lag_held": self.n_lag_held, "n_updates": e.n_updates,
                "n_gated": e.n_gated,
                "n_projected": e.rls.n_projected, "lam": e.rls.lam, "names": list(e.names),
                "raw_estimate": _estimate_dict(e.estimate), "noise_estimate": e.noise_std}

    def observe(self, u: float, w: float) -> bool:
        """Feed one controller-period sample to the estimator; refresh the estimate in use (C
        ``aff_robust_ff_observe``).

        Parameters
        ----------
        u : float
            Torque applied in this period (N·m).
        w : float
            Measured velocity (rad/s).

        Returns
        -------
        bool
            False if the sample was rejected (state unchanged, counted).

        Notes
        -----
        An estimate that passes the range checks but whose two lag estimates
        disagree updates the friction levels (``Fc, Fs, sigma``) and keeps the
        lag ``tau`` in use (counted in ``n_lag_held``); one that fails the range
        checks is not used at all (``n_implausible``).
        """
        n_rej = self.estimator.n_rejected
        lib.aff_robust_ff_observe(self._c, float(u), float(w), ffi.NULL)
        return self.estimator.n_rejected == n_rej
