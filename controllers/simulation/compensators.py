"""The compensation modes: one registry from a mode name to the plant, controller and compensator objects.

================  ==========================================================================================
mode              objects (:func:`build_mode`)
================  ==========================================================================================
``none``          no compensator
``fixed``         :class:`adaptive_ff.FrictionFeedforward` of an offline estimate (``options.estimate``)
``adaptive``      :class:`adaptive_ff.RobustAdaptiveFeedforward` on a
                  :class:`adaptive_ff.SlidingFrictionEstimator` (``estimator="sliding"``), or the paper's eq. 4
                  RLS feedforward (``estimator="eq4-rls"``) or eq. 4 by instrumental variables (``"eq4"``)
``adaptive-dob``  :class:`controllers.peers.adaptive_dob.AdaptiveDOBCompensator`: the sliding ``adaptive``
                  feedforward plus a :class:`controllers.DisturbanceObserver` on the residual
``canudas``       :class:`controllers.CanudasCompensator` (Canudas de Wit, Åström, Braun 1987)
``dob``           :class:`controllers.DisturbanceObserver`
``oracle``        :class:`TrueFriction`: the plant's true friction torque (the upper bound)
``frictionless``  no compensator, the plant without friction (the limit)
================  ==========================================================================================

A new compensator is a component class (:class:`plant.component.Component`
over a C struct that implements ``adaptive_ff/csrc/aff_compensator.h``, named
by its ``C_OPS`` attribute, see :mod:`controllers.simulation.engine`) and one
entry of :data:`REGISTRY`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from adaptive_ff.compensation.eq4_feedforward import AdaptiveFrictionFeedforward, AdaptiveFrictionFeedforwardConfig
from adaptive_ff.compensation.adaptive_feedforward import (FeedforwardStart, RobustAdaptiveFeedforward,
                                                            RobustAdaptiveFeedforwardConfig)
from adaptive_ff.compensation.defaults import c_defaults
from adaptive_ff.compensation.feedforward import FF_INPUTS, FrictionFeedforward, FrictionFeedforwardConfig
from adaptive_ff.compensation.velocity_input import LoopModel, SignObserver
from adaptive_ff.compensation.gate import OutlierGate
from adaptive_ff.compensation.sliding_estimator import (FORGETTINGS, SlidingFrictionEstimator,
                                                         SlidingFrictionEstimatorConfig)
from adaptive_ff.compensation.supervisor import FeedforwardSupervisor, FeedforwardSupervisorConfig
from adaptive_ff.identification.regression import FrictionEstimate, RegressionModel
from controllers.design.pi import PIController
from controllers.peers.adaptive_dob import AdaptiveCompensator, AdaptiveDOBCompensator, ResidualSwitchIn
from controllers.peers.canudas import CanudasCompensator, CanudasCompensatorConfig
from controllers.peers.dob import DisturbanceObserver
from controllers.simulation.estimators import DEFAULT_ESTIMATOR, ESTIMATORS
from plant.errors import ParameterError, check_multiple, check_nonnegative, check_positive, check_positive_or_inf

__all__ = ["MODES", "ESTIMATORS", "ESTIMATOR_BUILDERS", "check_estimator", "ModeOptions", "TrueFriction",
           "build_mode", "build_modes",
           "REGISTRY", "SUPERVISED_MODES", "build_supervisor", "own_supervisor"]

#: Modes whose compensation a :class:`adaptive_ff.compensation.supervisor.FeedforwardSupervisor` watches when
#: ``ModeOptions.supervise`` (the adaptive ones: their estimate may be wrong).
SUPERVISED_MODES = ("adaptive", "adaptive-dob")

#: The C defaults (``aff_X_default_config()``) of the components whose settings :class:`ModeOptions` carries: the
#: one statement of those knobs' defaults (the experiment's own choices are :class:`controllers.experiments.compare.
#: CompareOptions`'s, named there as its overrides).
_FF = c_defaults("aff_fixed_ff_config")
_ROBUST = c_defaults("aff_robust_ff_config")
_SLIDING = c_defaults("aff_sliding_config")
_SUP = c_defaults("aff_supervisor_config")
_DOB = c_defaults("aff_dob_config")
_SWITCH_IN = c_defaults("aff_switch_in_config")

#: Default sample time (s) and memory (s, ``lam = 1 - Ts/memory``) of the ``eq4`` estimator
#: (``ModeOptions.iv_Ts``, ``lam``): the IV removes the noise bias that keeps eq. 4's LS at 10 ms, and at 2 ms the
#: backward differences of eq. 4 misstate the lag less (docs/theory.md).
_IV_TS = 0.002
_IV_MEMORY = 5.0

def check_estimator(name: str, value) -> None:
    """Raise :class:`plant.errors.ParameterError` naming ``name`` unless ``value`` is one of :data:`ESTIMATORS`;
    the former name ``"eq4-iv"`` (the instrumental-variable estimator, now ``"eq4"``; the paper's RLS is
    ``"eq4-rls"``) is refused with its new name."""
    if value == "eq4-iv":
        raise ParameterError(f"{name}: the estimator 'eq4-iv' is now 'eq4' (and the paper's RLS as printed, "
                             f"formerly 'eq4', is 'eq4-rls')")
    if value not in ESTIMATORS:
        raise ParameterError(f"{name} must be one of {ESTIMATORS}, got {value!r}")


class TrueFriction:
    """The oracle compensator: feeds the plant's true friction torque forward (the upper bound of compensation).

    Not an estimator: it is the reference a compensator is measured against, and the only "component" that
    reads the true plant: it has no C struct, the engine feeds the friction torque of the plant state forward
    (``ctl_run.oracle``).
    """

    MODE = "oracle"
    n_theta = 0

    def __repr__(self) -> str:
        return "TrueFriction()"


@dataclass(frozen=True)
class ModeOptions:
    """Settings of a closed-loop run in a named mode (:func:`controllers.simulation.closed_loop.run_mode`).

    A field that sets a component's C setting takes that setting's C default (``aff_X_default_config()``, read by
    :func:`adaptive_ff.compensation.defaults.c_defaults`) and leaves its range to the component; ``estimator`` is a
    name of :data:`ESTIMATORS`, built by :data:`ESTIMATOR_BUILDERS`.

    Parameters
    ----------
    Kp, Ki : float
        PI gains (N·m·s/rad, N·m/rad), e.g. from :func:`controllers.design_pi`.
    u_max : float
        Torque saturation (N·m), default inf.
    Tc : float
        Controller period = integration step (s), default 1 ms.
    Ts : float
        Estimator sample time (s), a multiple of ``Tc``; default 10 ms (paper): the RLS update period of the
        ``sliding`` estimator and of ``canudas``, the identification sample time of ``eq4-rls`` (``eq4``: ``iv_Ts``).
    noise_std : float
        White velocity-measurement noise (rad/s).
    J_design : float or None
        Design inertia (kg·m²) for the estimator start, the gates and the DOB's nominal inertia; default
        None = the plant's J (a data-sheet value).
    estimate : FrictionEstimate or None
        Offline estimate for ``fixed``.
    model : RegressionModel or None
        Regression structure for ``estimator="eq4"`` and ``"eq4-rls"``; for ``"sliding"`` its Vs, delta are used
        when ``Vs``/``delta`` are not given.
    estimator : {"sliding", "eq4", "eq4-rls"}
        Estimator of the ``adaptive`` mode; ``eq4``: eq. 4 by recursive IV with delayed instruments on the
        samples above ``model.Vs`` (:class:`adaptive_ff.AdaptiveFrictionFeedforward` with ``iv=True``,
        ``w_band=model.Vs``).
    Vs, delta : float or None
        Stribeck factors for the sliding estimator (pre-fit).
    lam : float or None
        Forgetting factor per update; default 0.995 (``sliding``, ``eq4-rls``), 0.999 (``canudas``), ``1 - iv_Ts/5``
        for ``eq4`` (a memory of 5 s: the IV estimate's variance exceeds the LS one's).
    P0, warmup, lag, forgetting, T_filter, initial, dwell_max, offset
        Estimator settings (see :class:`adaptive_ff.SlidingFrictionEstimator`,
        :class:`adaptive_ff.RobustAdaptiveFeedforward`).
    lag_margin, lag_margin_max, max_rel_stderr, lag_memory : float
        Use of the sliding ``adaptive`` estimate (see :class:`adaptive_ff.RobustAdaptiveFeedforward`): the lag in
        use is the inverse-variance weighted mean of the lag estimates over ``lag_memory`` (s, default 10; 0: the
        latest estimate) plus ``lag_margin`` standard errors (default 1), at most ``lag_margin_max`` (default
        0.05) of it more, and an estimate is used once the standard error of ``Fc`` is at most
        ``max_rel_stderr`` (default 0.05) of ``max(Fc, Fs)``.
    lag_zero : float
        A negative lag estimate within ``max(lag_zero`` standard errors, ``2*Tc)`` of 0 is lag 0 (default 3).
    project : bool
        Use the estimate projected onto the plausible box (P^-1 metric) instead of refusing it (default True).
    start : FeedforwardStart or None
        Provisional start of the adaptive feedforward with estimator ``"sliding"`` or ``"eq4"`` (e.g. the pre-fit
        map at the reference): it acts from the first period until the estimator's first trusted (``sliding``) or
        admissible (``eq4``) estimate; default None. ``"eq4-rls"``, the paper's bare prototype, has none.
    ff_max : float or None
        Bound on |compensation| (N·m); default ``u_max``.
    ff_input : {"measured", "reference"}
        Velocity the friction feedforward (``fixed``, ``adaptive``, ``canudas``) is evaluated at.
    sign_width, stick_band, stick_samples
        Feedforward settings (see :class:`adaptive_ff.FrictionFeedforward`).
    stick_input : {"model", "reference"}
        Velocity the measured-velocity feedforward (``fixed``, ``adaptive``, ``adaptive-dob``) uses while the
        joint is detected as stuck: the nominal loop's (:class:`adaptive_ff.compensation.velocity_input.LoopModel`
        of ``Kp``, ``Ki`` and the design inertia, driven by the reference; default) or the reference itself.
        Measured on ``paper``: RMS deviation from the frictionless run of ``adaptive`` over the second half
        0.0024 rad/s with the model, 0.0036 with the reference (docs/benchmarks/variants.md).
    sign_input : {"observer", "measured"}
        Sign of the friction map of the measured-velocity feedforward (``fixed``, ``adaptive``, ``adaptive-dob``)
        inside ``±stick_band``: a :class:`adaptive_ff.compensation.velocity_input.SignObserver` of the design inertia
        (default) or the measurement's own sign.
    observer_bandwidth : float or None
        Bandwidth of that observer (rad/s); default None: ``5*Kp/J_design``, five times the loop's crossover
        (observer poles a few times faster than the loop's, Franklin, Powell & Workman, *Digital Control of
        Dynamic Systems*, 3rd ed., 1998, Sec. 8.3).
    J_n, omega_q : float or None, float
        Nominal inertia of every observer (kg·m²; default ``J_design``): the disturbance observer of ``dob``, the
        residual observer of ``adaptive`` and ``adaptive-dob`` with the switch-in's loop model, and the supervisor's
        statistic; an observer enforces its nominal inertia (docs/benchmarks/compensation.md, "A design inertia off
        by a factor"). ``omega_q``: the Q-filter cut-off of ``dob`` (rad/s).
    omega_r : float
        Q-filter cut-off (rad/s) of the residual observer of ``adaptive-dob``; default 1000 (its input is
        the small residual ``f - u_ff``; measured on ``paper``: RMS deviation from the frictionless run
        1.46x the oracle's at 500 rad/s, 1.07x at 1000, docs/benchmarks/variants.md).
    sensor_gate : bool
        Sensor plausibility gate of the controller's measurement (see ``run_closed_loop``).
    w_limit : float or None
        Divergence bound (rad/s).
    decimate : int
        Signal recording (see ``run_closed_loop``).
    reversal_window : float
        Half-width (s) of the reversal windows of the metrics.
    encoder_counts : int or None
        The loop measures with an encoder of this many counts per joint revolution (quantised position,
        velocity by backward difference; :class:`controllers.simulation.sensor_drive.Sensor`); None (default):
        ``w + noise``.
    velocity : {"difference", "kalman"}
        The encoder's velocity: backward difference (default) or a causal steady-state Kalman filter on the
        counts (:class:`controllers.simulation.sensor_drive.Sensor`); "kalman" needs ``encoder_counts``.
    velocity_bandwidth : float or None
        Bandwidth of the Kalman velocity (Hz); default None: ``0.1/Tc`` (100 Hz at 1 kHz).
    velocity_model : {"cv", "ca"}
        Kinematic model of the Kalman velocity; default "cv".
    delay : int
        Measurement delay (periods), default 0.
    slew_rate : float
        The drive's torque slew-rate limit (N·m/s), default inf (none;
        :class:`controllers.simulation.sensor_drive.Drive`). The torque limit is ``u_max``.
    supervise : bool
        Pass the compensation of the modes of :data:`SUPERVISED_MODES` (``adaptive`` with either estimator,
        ``adaptive-dob``) through a :class:`adaptive_ff.compensation.supervisor.FeedforwardSupervisor`, which backs
        it off to none while it makes the torque disturbance the PI sees larger than the friction alone (default
        True; the result's ``info`` then has ``n_backoff``, ``n_restore`` and ``t_off``, s). Other modes ignore it.
    switch_in : bool
        Mode ``adaptive`` (any estimator, ``Kp > 0``): run the residual observer of ``adaptive-dob`` (cut-off
        ``omega_r``) from the start and switch it in once the loop's model predicts that what the feedforward
        leaves raises the mean-square tracking error by more than ``switch_in_ratio`` over the frictionless loop's,
        then keep it unless its trial finds the loop tracking worse with it
        (:class:`controllers.peers.adaptive_dob.ResidualSwitchIn`, window 2 s, fade-in 0.5 s; the result's
        ``info["t_switch_in"]`` and ``info["t_switch_out"]`` say when); default True. False: the feedforward
        alone.
    switch_in_ratio : float
        Its threshold (-), > 0; default 0.1 (5 % in RMS).
    supervise_window : float
        Time constant of the supervisor's mean squares (s), default 2.
    supervise_margin : float
        Its hysteresis (-), in [0, 1): back on below ``(1 - margin)`` times the friction's mean square; default 0.1.
    supervise_omega : float or None
        Cut-off of its Q-filter (rad/s); default None: ``Kp/J_design``, the loop's crossover (``omega`` of
        :func:`build_supervisor`).
    supervise_tracking : bool
        The supervisor's tracking test (:class:`adaptive_ff.compensation.supervisor.FeedforwardSupervisor` ``Kp``,
        ``Ki``): it also backs the compensation off while the loop's velocity error with it is larger in mean square
        than ``1 + supervise_track_margin`` times the error the loop's nominal model (PI, ``J_design``) makes from the
        disturbance without it; default True (needs ``Kp > 0``).
    supervise_track_margin : float
        That margin (-), >= 0; default 1 (twice the mean square).
    iv_Ts : float or None
        Sample time (s) of the ``eq4`` estimator, a multiple of ``Tc``; default None: 2 ms (rounded to a multiple
        of ``Tc``, at least ``Tc``). ``Ts`` is that of the other estimators.
    iv_map_stderr : float
        The ``eq4`` estimator's determinacy test in mode ``adaptive`` (> 0; default ``inf``: none): an estimate is
        put into use (the first replacing the start map) only once the standard error of its static map is at most
        this times its ``max(Fc, Fs)`` (:class:`~adaptive_ff.compensation.eq4_feedforward.AdaptiveFrictionFeedforward`
        ``map_rel_stderr``). Opt-in; measured on docs/benchmarks/compensation.md, "The eq. 4 estimate's
        determinacy test". Mode ``adaptive-dob`` uses no test: its observer, always applied, takes what an early
        estimate misses.
    supervise_rest_band : float or None
        The reference is at rest where ``|w_ref|`` is at most this (rad/s): the supervisor applies no compensation
        there once it has been for one loop time constant (a velocity loop's friction then brakes the joint toward
        ``w = 0``); default 0 (exactly at rest, the
        dwells of a point-to-point reference); None: no rest rule.

    Raises
    ------
    ParameterError
        ``Kp``/``Ki`` missing or negative, ``Ts`` not a multiple of ``Tc``, unknown ``estimator`` or
        ``ff_input``.
    """

    Kp: float
    Ki: float
    u_max: float = math.inf
    Tc: float = 1e-3
    Ts: float = _SLIDING["Ts"]
    noise_std: float = 0.0
    J_design: float | None = None
    estimate: FrictionEstimate | None = None
    model: RegressionModel | None = None
    estimator: str = DEFAULT_ESTIMATOR
    Vs: float | None = None
    delta: float | None = None
    lam: float | None = None
    P0: float = _SLIDING["P0"]
    warmup: int = _ROBUST["warmup"]
    lag: bool = bool(_FF["lag"])
    forgetting: str = FORGETTINGS[_SLIDING["forgetting"]]
    T_filter: float = _SLIDING["T_filter"]
    initial: FrictionEstimate | None = None
    dwell_max: float = _SLIDING["dwell_max"]
    offset: bool = bool(_SLIDING["offset"])
    lag_margin: float = _ROBUST["lag_margin"]
    lag_margin_max: float = _ROBUST["lag_margin_max"]
    max_rel_stderr: float = _ROBUST["max_rel_stderr"]
    lag_memory: float = _ROBUST["lag_memory"]
    lag_zero: float = _ROBUST["lag_zero"]
    project: bool = bool(_ROBUST["project"])
    start: FeedforwardStart | None = None
    ff_max: float | None = None
    ff_input: str = FF_INPUTS[_FF["at_ref"]]
    sign_width: float = _FF["sign_width"]
    stick_band: float = _FF["stick_band"]
    stick_samples: int = _FF["stick_samples"]
    J_n: float | None = None
    omega_q: float = _DOB["omega_q"]
    omega_r: float = 1000.0
    sensor_gate: bool = True
    w_limit: float | None = None
    decimate: int = 1
    reversal_window: float = 0.2
    stick_input: str = "model"
    sign_input: str = "observer"
    observer_bandwidth: float | None = None
    encoder_counts: int | None = None
    delay: int = 0
    slew_rate: float = math.inf
    velocity: str = "difference"
    velocity_bandwidth: float | None = None
    velocity_model: str = "cv"
    switch_in: bool = True
    switch_in_ratio: float = _SWITCH_IN["ratio"]
    supervise: bool = True
    supervise_window: float = _SUP["window"]
    supervise_margin: float = _SUP["margin"]
    supervise_omega: float | None = None
    supervise_tracking: bool = True
    supervise_track_margin: float = _SUP["track_margin"]
    supervise_rest_band: float | None = _SUP["rest_band"]
    iv_Ts: float | None = None
    iv_map_stderr: float = math.inf

    def __post_init__(self):
        check_positive("Tc", self.Tc)
        check_multiple("Ts", self.Ts, "Tc", self.Tc)
        check_nonnegative("noise_std", self.noise_std)
        c = self.encoder_counts
        if c is not None and (isinstance(c, bool) or not isinstance(c, (int, np.integer)) or c < 1):
            raise ParameterError(f"encoder_counts must be an integer >= 1 (counts per joint revolution, the sensor's "
                                 f"counts_per_rev) or None, got {c!r}")
        if isinstance(self.slew_rate, bool) or not (isinstance(self.slew_rate, (int, float)) and self.slew_rate > 0):
            raise ParameterError(f"slew_rate must be a number > 0 (N·m/s; inf for none), got {self.slew_rate!r}")
        check_positive("omega_r", self.omega_r)
        if self.J_n is not None:
            check_positive("J_n", self.J_n)
        if self.iv_Ts is not None:
            check_multiple("iv_Ts", self.iv_Ts, "Tc", self.Tc)
        check_positive_or_inf("iv_map_stderr", self.iv_map_stderr)
        check_estimator("estimator", self.estimator)
        if self.ff_input not in FF_INPUTS:
            raise ParameterError(f"ff_input must be one of {FF_INPUTS}, got {self.ff_input!r}")
        if self.stick_input not in ("model", "reference"):
            raise ParameterError(f"stick_input must be 'model' or 'reference', got {self.stick_input!r}")
        if self.sign_input not in ("observer", "measured"):
            raise ParameterError(f"sign_input must be 'observer' or 'measured', got {self.sign_input!r}")
        if self.observer_bandwidth is not None:
            check_positive("observer_bandwidth", self.observer_bandwidth)
        if not isinstance(self.switch_in, bool):
            raise ParameterError(f"switch_in must be True or False, got {self.switch_in!r}")
        check_positive("switch_in_ratio", self.switch_in_ratio)
        if not isinstance(self.supervise, bool):
            raise ParameterError(f"supervise must be True or False, got {self.supervise!r}")
        check_positive("supervise_window", self.supervise_window)
        if not isinstance(self.supervise_tracking, bool):
            raise ParameterError(f"supervise_tracking must be True or False, got {self.supervise_tracking!r}")
        check_nonnegative("supervise_track_margin", self.supervise_track_margin)
        if not (0.0 <= self.supervise_margin < 1.0):
            raise ParameterError(f"supervise_margin must be in [0, 1), got {self.supervise_margin!r}")
        if self.supervise_omega is not None:
            check_positive("supervise_omega", self.supervise_omega)
        if self.supervise_rest_band is not None:
            check_nonnegative("supervise_rest_band", self.supervise_rest_band)
        from controllers.simulation.sensor_drive import Drive, Sensor  # the checks of the components themselves

        if self.velocity_model not in ("cv", "ca"):
            raise ParameterError(f"velocity_model must be 'cv' or 'ca', got {self.velocity_model!r}")
        if self.velocity_bandwidth is not None and check_positive("velocity_bandwidth",
                                                                  self.velocity_bandwidth) >= 0.5 / self.Tc:
            raise ParameterError(f"velocity_bandwidth must be below the Nyquist frequency {0.5 / self.Tc:.6g} Hz, "
                                 f"got {self.velocity_bandwidth!r}")
        Sensor(Tc=self.Tc, counts_per_rev=self.encoder_counts, delay=self.delay, velocity=self.velocity,
               bandwidth=self.velocity_bandwidth, model=self.velocity_model)
        Drive(Tc=self.Tc, slew_rate=self.slew_rate)


def _ctx(plant, o: ModeOptions) -> tuple:
    frozen = plant.at(0.0) if hasattr(plant, "at") else plant
    J = float(frozen.J) if o.J_design is None else check_positive("J_design", o.J_design)
    ff_max = o.u_max if o.ff_max is None else o.ff_max
    return J, ff_max


def _nominal_inertia(plant, o: ModeOptions) -> float:
    """The nominal inertia of every observer (kg·m²): ``o.J_n``, else the design inertia (``ModeOptions.J_n``)."""
    return _ctx(plant, o)[0] if o.J_n is None else float(o.J_n)


def _configs(o: ModeOptions, J: float, ff_max: float) -> dict:
    """The one map from :class:`ModeOptions` onto the components' config objects (the C settings' dataclasses).

    Parameters
    ----------
    o : ModeOptions
        The loop's settings.
    J : float
        The design inertia (kg·m²): the sliding estimator's start.
    ff_max : float
        The compensation's bound (N·m).

    Returns
    -------
    dict
        ``"ff"`` (:class:`FrictionFeedforwardConfig`: ``fixed``'s, the adaptive ones' feedforward), ``"robust"``
        (:class:`RobustAdaptiveFeedforwardConfig`, with that ``ff``), ``"sliding"``
        (:class:`SlidingFrictionEstimatorConfig`), ``"supervisor"`` (:class:`FeedforwardSupervisorConfig`),
        ``"canudas"`` (:class:`CanudasCompensatorConfig`) and, with ``o.model``, ``"eq4-rls"`` (the paper's
        prototype: RLS at ``Ts``, the bare feedforward) and ``"eq4"`` (recursive IV at ``iv_Ts`` on the samples
        above ``model.Vs``, with that ``ff``) (:class:`AdaptiveFrictionFeedforwardConfig`).
    """
    ff = FrictionFeedforwardConfig(lag=o.lag, ff_max=ff_max, sign_width=o.sign_width, stick_band=o.stick_band,
                                   stick_samples=o.stick_samples, ff_input=o.ff_input)
    robust = RobustAdaptiveFeedforwardConfig(ff=ff, warmup=o.warmup, lag_margin=o.lag_margin,
                                             lag_margin_max=o.lag_margin_max, max_rel_stderr=o.max_rel_stderr,
                                             lag_memory=o.lag_memory, lag_zero=o.lag_zero, project=o.project)
    sliding = SlidingFrictionEstimatorConfig(Ts=o.Ts, T_filter=o.T_filter, lam=_SLIDING["lam"] if o.lam is None
                                             else o.lam, forgetting=o.forgetting, P0=o.P0, initial_J=J, lag=o.lag,
                                             dwell_max=o.dwell_max, offset=o.offset)
    tracking = o.supervise_tracking and o.Kp > 0
    supervisor = FeedforwardSupervisorConfig(
        window=o.supervise_window, margin=o.supervise_margin,
        rest_band=-1.0 if o.supervise_rest_band is None else o.supervise_rest_band, delay=int(o.delay),
        Kp=o.Kp if tracking else 0.0, Ki=o.Ki if tracking else 0.0, track_margin=o.supervise_track_margin)
    canudas = CanudasCompensatorConfig(Ts=o.Ts, lam=CanudasCompensatorConfig.lam if o.lam is None else o.lam,
                                       forgetting=o.forgetting, P0=o.P0, J_guess=J, warmup=o.warmup, ff_max=ff_max,
                                       ff_input=o.ff_input)
    out = {"ff": ff, "robust": robust, "sliding": sliding, "supervisor": supervisor, "canudas": canudas}
    if o.model is not None:
        m = o.model
        iv_Ts = o.Tc * max(1, round(_IV_TS / o.Tc)) if o.iv_Ts is None else o.iv_Ts
        out["eq4-rls"] = AdaptiveFrictionFeedforwardConfig(
            Ts=o.Ts, lam=sliding.lam, P0=o.P0, warmup=o.warmup,
            ff=FrictionFeedforwardConfig(lag=o.lag, ff_max=ff_max, ff_input=o.ff_input))
        out["eq4"] = AdaptiveFrictionFeedforwardConfig(
            Ts=iv_Ts, lam=1.0 - iv_Ts / _IV_MEMORY if o.lam is None else o.lam, P0=o.P0, warmup=o.warmup, iv=True,
            w_band=m.Vs if m.stribeck else 0.0, map_rel_stderr=o.iv_map_stderr, ff=ff)
    return out


def build_supervisor(plant, mode: str, options: ModeOptions, *, force: bool = False) -> FeedforwardSupervisor | None:
    """The supervisor of one scenario: a :class:`FeedforwardSupervisor` where ``options.supervise`` and ``mode`` is
    one of :data:`SUPERVISED_MODES` (or ``force``: any compensator, e.g. your own in
    :func:`controllers.simulation.closed_loop.run_own`), else None.

    Its settings: ``Tc``, ``J_n`` (``options.J_n``, else the design inertia), ``omega =
    supervise_omega`` (default ``Kp/J_design``, the loop's design crossover; ``10/supervise_window`` rad/s where
    ``Kp`` is 0), ``window = supervise_window``, ``margin = supervise_margin``, ``rest_band = supervise_rest_band``,
    ``delay`` = the options' measurement delay (periods).

    Parameters
    ----------
    plant : plant model
        The true plant (its J is the design inertia where ``options.J_design`` is None).
    mode : str
        The mode's name (the user's compensator of ``run_own``: any name with ``force``).
    options : ModeOptions
        The loop's settings.
    force : bool, keyword-only
        Supervise whatever ``mode`` is (``options.supervise`` still has to be True).

    Returns
    -------
    FeedforwardSupervisor or None

    Raises
    ------
    ParameterError
        A measurement delay above :data:`adaptive_ff.compensation.supervisor.DELAY_MAX`.
    """
    if not (options.supervise and (force or mode in SUPERVISED_MODES)):
        return None
    J, ff_max = _ctx(plant, options)
    omega = options.supervise_omega
    if omega is None:
        omega = options.Kp / J if options.Kp > 0 else 10.0 / options.supervise_window
    return FeedforwardSupervisor(Tc=options.Tc, J_n=_nominal_inertia(plant, options), omega=omega,
                                 config=_configs(options, J, ff_max)["supervisor"])


def own_supervisor(comp) -> FeedforwardSupervisor | None:
    """The supervisor a compensator carries in its own struct (an :class:`AdaptiveCompensator`'s, which it applies
    itself: the engine then supervises nothing more; also one run by a compiled export,
    :class:`controllers.simulation.exported.ExportedCompensator`, whose ``compensator`` it is), else None."""
    comp = getattr(comp, "compensator", comp)
    return comp.supervisor if isinstance(comp, AdaptiveCompensator) else None


def _loop_model(J: float, o: ModeOptions) -> LoopModel | None:
    """The nominal loop of the stick-detection fallback (``stick_input`` model), from the PI and the design J."""
    return LoopModel(Kp=o.Kp, Ki=o.Ki, J=J) if o.stick_input == "model" else None


def _sign_observer(J: float, o: ModeOptions) -> SignObserver | None:
    """The velocity observer that signs the friction map inside the stick band (``sign_input`` observer)."""
    if o.sign_input != "observer" or o.Kp <= 0.0:
        return None
    return SignObserver(J=J, bandwidth=5.0 * o.Kp / J if o.observer_bandwidth is None else o.observer_bandwidth)


def _none(plant, o):
    return plant, None


def _frictionless(plant, o):
    return plant.frictionless(), None


def _oracle(plant, o):
    return plant, TrueFriction()


def _fixed(plant, o):
    if o.estimate is None:
        raise ParameterError("mode 'fixed' needs estimate=FrictionEstimate (an offline LS result)")
    J, ff_max = _ctx(plant, o)
    return plant, FrictionFeedforward(o.estimate, dt=o.Tc, config=_configs(o, J, ff_max)["ff"],
                                      loop_model=_loop_model(J, o), sign_observer=_sign_observer(J, o))


def _adaptive(plant, o):
    """Mode ``adaptive``: over the sliding estimator one :class:`AdaptiveCompensator` (the feedforward, the residual
    observer it switches in and the supervisor in one C struct, the one a drive runs); over the eq. 4 estimators the
    composite :class:`AdaptiveDOBCompensator` with the switch-in, supervised by the engine."""
    _, ff = _adaptive_feedforward(plant, o)
    switch_in = o.switch_in and o.Kp > 0.0
    J, ff_max = _ctx(plant, o)
    wc = max(o.Kp, 0.0) / J  # the slew limit's crossover: the PI's Kp over the design inertia
    dob = sw = None
    if switch_in:
        _, dob = _dob(plant, replace(o, omega_q=o.omega_r))
        sw = ResidualSwitchIn(Tc=o.Tc, J_n=_nominal_inertia(plant, o), Kp=o.Kp, Ki=o.Ki, ratio=o.switch_in_ratio)
    if isinstance(ff, RobustAdaptiveFeedforward):
        return plant, AdaptiveCompensator(ff, dob, u_max=ff_max if switch_in else math.inf, switch_in=sw,
                                          supervisor=build_supervisor(plant, "adaptive", o), crossover=wc)
    if not switch_in:
        return plant, ff
    return plant, AdaptiveDOBCompensator(ff, dob, u_max=ff_max, switch_in=sw, crossover=wc)


def _adaptive_feedforward(plant, o):
    """The adaptive feedforward alone (the estimator of ``o.estimator``, :data:`ESTIMATOR_BUILDERS`): ``adaptive``
    without the switch-in, the feedforward part of ``adaptive-dob``."""
    J, ff_max = _ctx(plant, o)
    return plant, ESTIMATOR_BUILDERS[o.estimator](o, J, ff_max)


def _eq4_model(o) -> RegressionModel:
    """The regression structure of the eq. 4 estimators (``o.model``; ParameterError without it)."""
    if o.model is None:
        raise ParameterError(f"mode 'adaptive' with estimator {o.estimator!r} needs model=RegressionModel(Vs, "
                             f"delta, ...)")
    return o.model


def _eq4_rls(o, J: float, ff_max: float) -> AdaptiveFrictionFeedforward:
    """Estimator ``eq4-rls``: the paper's prototype, RLS on every sample at ``Ts``, the bare feedforward."""
    return AdaptiveFrictionFeedforward(_eq4_model(o), dt=o.Tc, config=_configs(o, J, ff_max)["eq4-rls"])


def _eq4_iv(o, J: float, ff_max: float) -> AdaptiveFrictionFeedforward:
    """Estimator ``eq4``: eq. 4 by recursive IV at ``iv_Ts`` on the sliding samples, with the constant-torque column
    (offset) as the sliding estimator's."""
    m = _eq4_model(o)
    model = RegressionModel(m.Vs, m.delta, lag=m.lag, stribeck=m.stribeck, offset=bool(o.offset))
    return AdaptiveFrictionFeedforward(model, dt=o.Tc, config=_configs(o, J, ff_max)["eq4"],
                                       loop_model=_loop_model(J, o), sign_observer=_sign_observer(J, o),
                                       start=o.start)


def _sliding(o, J: float, ff_max: float) -> RobustAdaptiveFeedforward:
    """Estimator ``sliding``: the sliding-regime inverse-dynamics RLS under the robust feedforward."""
    Vs = o.Vs if o.Vs is not None else (o.model.Vs if o.model is not None else None)
    delta = o.delta if o.delta is not None else (o.model.delta if o.model is not None else None)
    if Vs is None or delta is None:
        raise ParameterError("mode 'adaptive' needs Vs and delta (from the Stribeck pre-fit) or model=")
    gate_step = 2.0 * o.u_max * o.Tc / J if math.isfinite(o.u_max) else math.inf
    configs = _configs(o, J, ff_max)
    est = SlidingFrictionEstimator(Vs, delta, Tc=o.Tc, config=configs["sliding"], initial=o.initial,
                                   gate=OutlierGate(max_step=gate_step))
    return RobustAdaptiveFeedforward(est, dt=o.Tc, config=configs["robust"], start=o.start,
                                     loop_model=_loop_model(J, o), sign_observer=_sign_observer(J, o))


#: Estimator name (:data:`controllers.simulation.estimators.ESTIMATORS`, the one list of names: the options' check,
#: the compare CLI's ``--estimator`` choices) -> builder ``(options, design inertia J, feedforward bound) -> adaptive
#: feedforward`` of mode ``adaptive``.
ESTIMATOR_BUILDERS = {"sliding": _sliding, "eq4": _eq4_iv, "eq4-rls": _eq4_rls}
if tuple(ESTIMATOR_BUILDERS) != ESTIMATORS:  # pragma: no cover - a builder per registered name, in its order
    raise ImportError(f"ESTIMATOR_BUILDERS {tuple(ESTIMATOR_BUILDERS)} differ from ESTIMATORS {ESTIMATORS}")


def _adaptive_dob(plant, o):
    # the eq. 4 estimates without the determinacy test: the observer, always applied, takes what an early estimate
    # misses (docs/benchmarks/compensation.md, "The eq. 4 estimate's determinacy test")
    _, ff = _adaptive_feedforward(plant, replace(o, iv_map_stderr=math.inf))
    _, dob = _dob(plant, replace(o, omega_q=o.omega_r))
    J, ff_max = _ctx(plant, o)  # the slew limit's crossover: the PI's Kp over the design inertia
    return plant, AdaptiveDOBCompensator(ff, dob, u_max=ff_max, crossover=max(o.Kp, 0.0) / J)


def _canudas(plant, o):
    J, ff_max = _ctx(plant, o)
    return plant, CanudasCompensator(Tc=o.Tc, config=_configs(o, J, ff_max)["canudas"])


def _dob(plant, o):
    _, ff_max = _ctx(plant, o)
    return plant, DisturbanceObserver(J_n=_nominal_inertia(plant, o), omega_q=o.omega_q, Tc=o.Tc, d_max=ff_max)


#: Mode name -> builder ``(plant, options) -> (plant to simulate, compensator or None)``.
REGISTRY = {"none": _none, "fixed": _fixed, "adaptive": _adaptive, "adaptive-dob": _adaptive_dob,
            "canudas": _canudas, "dob": _dob, "oracle": _oracle, "frictionless": _frictionless}

#: Compensation modes, in table order.
MODES = tuple(REGISTRY)


def build_mode(plant, mode: str, options: ModeOptions) -> tuple:
    """The objects of one compensation mode.

    Parameters
    ----------
    plant : plant model
        True plant (any model of :mod:`plant.models`, possibly drifting).
    mode : str
        One of :data:`MODES`.
    options : ModeOptions
        Settings.

    Returns
    -------
    plant : plant model
        The plant to simulate (the frictionless twin for ``frictionless``).
    controller : PIController
        The PI of ``options``.
    compensator : component or None

    Raises
    ------
    ParameterError
        Unknown mode, or settings missing for it.
    """
    controller = _controller(mode, options)
    run_plant, comp = REGISTRY[mode](plant, options)
    return run_plant, controller, comp


def _controller(mode: str, options: ModeOptions) -> PIController:
    """The PI of ``options`` after checking ``mode`` and the type of ``options`` (the start of :func:`build_mode`)."""
    if mode not in REGISTRY:
        raise ParameterError(f"mode must be one of {MODES}, got {mode!r}")
    if not isinstance(options, ModeOptions):
        raise ParameterError(f"options must be ModeOptions, got {type(options).__name__}")
    return PIController(Kp=options.Kp, Ki=options.Ki, Tc=options.Tc, u_max=options.u_max)


def build_modes(plants, mode: str, options) -> tuple:
    """:func:`build_mode` for B scenarios, with one controller per distinct options object.

    The PI depends on the options only, so scenarios that share one :class:`ModeOptions` object share one
    (unused, never stepped) :class:`PIController`; every scenario gets its own compensator (it holds the
    scenario's state and may depend on the plant).

    Parameters
    ----------
    plants : sequence of plant models, length B
        True plants.
    mode : str
        One of :data:`MODES`.
    options : sequence of ModeOptions, length B
        Settings of each scenario.

    Returns
    -------
    run_plants : list, length B
        The plants to simulate.
    controllers : list of PIController, length B
        The PI of each scenario (the same object where the options object is the same).
    compensators : list, length B
        Compensator or None of each scenario.

    Raises
    ------
    ParameterError
        As :func:`build_mode`, for the first scenario whose settings are bad.
    """
    made, run_plants, controllers, comps = {}, [], [], []
    for p, o in zip(plants, options):
        c = made.get(id(o))
        if c is None:
            c = made[id(o)] = _controller(mode, o)
        run_plant, comp = REGISTRY[mode](p, o)
        run_plants.append(run_plant)
        controllers.append(c)
        comps.append(comp)
    return run_plants, controllers, comps
