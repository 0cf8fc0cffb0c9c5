"""The settings of a closed loop as one nested, frozen :class:`LoopConfig`: one group per part of the loop.

================  ==============================================================================================
group             settings (flat keyword of :meth:`LoopConfig.from_flat` where it differs: ``flat -> field``)
================  ==============================================================================================
``controller``    ``Kp``, ``Ki``, ``Tc``, ``J_design``
``drive``         ``u_max``, ``slew_rate``
``sensor``        ``noise_std``, ``encoder_counts``, ``delay``, ``velocity``, ``velocity_bandwidth``,
                  ``velocity_model``; ``sensor_gate -> gate``
``estimator``     ``estimator -> name``, ``Ts``, ``lam``, ``P0``, ``forgetting``, ``T_filter``, ``initial``,
                  ``dwell_max``, ``offset``, ``Vs``, ``delta``, ``model``, ``iv_Ts``, ``iv_map_stderr``
``feedforward``   ``estimate``, ``warmup``, ``lag``, ``lag_margin``, ``lag_margin_max``, ``max_rel_stderr``,
                  ``lag_memory``, ``lag_zero``, ``project``, ``start``, ``ff_max``, ``ff_input``, ``sign_width``,
                  ``stick_band``, ``stick_samples``, ``stick_input``, ``sign_input``, ``observer_bandwidth``
``observer``      ``J_n``, ``omega_q``, ``omega_r``, ``switch_in``, ``switch_in_ratio``
``supervisor``    ``supervise -> enabled``, ``supervise_X -> X`` (``window``, ``margin``, ``omega``, ``tracking``,
                  ``track_margin``, ``rest_band``)
``run``           ``w_limit``, ``decimate``, ``reversal_window``, ``friction0``
================  ==============================================================================================

A setting that mirrors a component's C setting takes that setting's C default (``aff_X_default_config()``, read
by :func:`adaptive_ff.compensation.defaults.c_defaults`) and leaves its range to the component: the group's
default is the one statement of it. Each group checks its own settings; :class:`LoopConfig` checks those that
tie two groups (a sample time a multiple of ``controller.Tc``, the sensor and the drive at that period).

The flat keywords (the former ``ModeOptions`` fields, the compare CLI's and the TOML files' names) map onto the
paths by :data:`FLAT_PATHS`, the one such map: :meth:`LoopConfig.from_flat` builds a config from them,
:meth:`LoopConfig.replace` changes some, :meth:`LoopConfig.flat` reads one. This module imports no C extension
beyond the defaults' table.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace as _dc_replace

import numpy as np

from adaptive_ff.compensation.adaptive_feedforward import FeedforwardStart
from adaptive_ff.compensation.defaults import c_defaults
from adaptive_ff.compensation.feedforward import FF_INPUTS
from adaptive_ff.compensation.sliding_estimator import FORGETTINGS
from adaptive_ff.identification.regression import FrictionEstimate, RegressionModel
from controllers.simulation.estimators import DEFAULT_ESTIMATOR, check_estimator
from plant.errors import ParameterError, check_multiple, check_nonnegative, check_positive, check_positive_or_inf

__all__ = ["LoopConfig", "ControllerSettings", "DriveSettings", "SensorSettings", "EstimatorSettings",
           "FeedforwardSettings", "ObserverSettings", "SupervisorSettings", "RunSettings", "FLAT_PATHS",
           "GROUPS"]

_FF = c_defaults("aff_fixed_ff_config")
_ROBUST = c_defaults("aff_robust_ff_config")
_SLIDING = c_defaults("aff_sliding_config")
_SUP = c_defaults("aff_supervisor_config")
_DOB = c_defaults("aff_dob_config")
_SWITCH_IN = c_defaults("aff_switch_in_config")


def _check_bool(name: str, value) -> None:
    if not isinstance(value, bool):
        raise ParameterError(f"{name} must be True or False, got {value!r}")


@dataclass(frozen=True)
class ControllerSettings:
    """The PI velocity controller.

    Parameters
    ----------
    Kp, Ki : float
        PI gains (N·m·s/rad, N·m/rad), e.g. from :func:`controllers.design_pi`; default 0 (no loop: a
        comparison designs them).
    Tc : float
        Controller period = integration step (s), > 0; default 1 ms.
    J_design : float or None
        Design inertia (kg·m²) for the estimator start, the gates and the observers' nominal inertia; default
        None = the plant's J (a data-sheet value).
    """

    Kp: float = 0.0
    Ki: float = 0.0
    Tc: float = 1e-3
    J_design: float | None = None

    def __post_init__(self):
        check_positive("Tc", self.Tc)  # the gains and the saturation: checked by the PIController


@dataclass(frozen=True)
class DriveSettings:
    """The drive: torque limits (:class:`controllers.simulation.sensor_drive.Drive`).

    Parameters
    ----------
    u_max : float or None
        Torque saturation (N·m) of the PI and the drive, default inf; None: sized by a comparison
        (:class:`controllers.experiments.compare.CompareOptions`), which a run needs done.
    slew_rate : float
        The drive's torque slew-rate limit (N·m/s), > 0, default inf (none).
    """

    u_max: float | None = math.inf
    slew_rate: float = math.inf

    def __post_init__(self):
        if isinstance(self.slew_rate, bool) or not (isinstance(self.slew_rate, (int, float)) and self.slew_rate > 0):
            raise ParameterError(f"slew_rate must be a number > 0 (N·m/s; inf for none), got {self.slew_rate!r}")


@dataclass(frozen=True)
class SensorSettings:
    """The velocity measurement (:class:`controllers.simulation.sensor_drive.Sensor`).

    Parameters
    ----------
    noise_std : float
        White velocity-measurement noise (rad/s), >= 0; default 0.
    encoder_counts : int or None
        Measure with an encoder of this many counts per joint revolution (quantised position, velocity by
        backward difference); None (default): ``w + noise``.
    delay : int
        Measurement delay (periods), default 0.
    velocity : {"difference", "kalman"}
        The encoder's velocity: backward difference (default) or a causal steady-state Kalman filter on the
        counts; "kalman" needs ``encoder_counts``.
    velocity_bandwidth : float or None
        Bandwidth of the Kalman velocity (Hz); default None: ``0.1/Tc`` (100 Hz at 1 kHz).
    velocity_model : {"cv", "ca"}
        Kinematic model of the Kalman velocity; default "cv".
    gate : bool
        Sensor plausibility gate of the controller's measurement (see ``run_closed_loop``); flat ``sensor_gate``.
    """

    noise_std: float = 0.0
    encoder_counts: int | None = None
    delay: int = 0
    velocity: str = "difference"
    velocity_bandwidth: float | None = None
    velocity_model: str = "cv"
    gate: bool = True

    def __post_init__(self):
        check_nonnegative("noise_std", self.noise_std)
        c = self.encoder_counts
        if c is not None and (isinstance(c, bool) or not isinstance(c, (int, np.integer)) or c < 1):
            raise ParameterError(f"encoder_counts must be an integer >= 1 (counts per joint revolution, the sensor's "
                                 f"counts_per_rev) or None, got {c!r}")
        if self.velocity_model not in ("cv", "ca"):
            raise ParameterError(f"velocity_model must be 'cv' or 'ca', got {self.velocity_model!r}")
        if self.velocity_bandwidth is not None:
            check_positive("velocity_bandwidth", self.velocity_bandwidth)


@dataclass(frozen=True)
class EstimatorSettings:
    """The estimator of mode ``adaptive`` (:data:`controllers.simulation.estimators.ESTIMATORS`).

    Parameters
    ----------
    name : {"sliding", "eq4", "eq4-rls"}
        The estimator (flat ``estimator``): ``sliding`` the sliding-regime inverse-dynamics RLS; ``eq4``: eq. 4 by
        recursive IV with delayed instruments on the samples above ``model.Vs``
        (:class:`adaptive_ff.AdaptiveFrictionFeedforward` with ``iv=True``); ``eq4-rls``: the paper's RLS.
    Ts : float
        Estimator sample time (s), a multiple of ``Tc``; default 10 ms (paper): the RLS update period of
        ``sliding`` and of ``canudas``, the identification sample time of ``eq4-rls`` (``eq4``: ``iv_Ts``).
    lam : float or None
        Forgetting factor per update; default 0.995 (``sliding``, ``eq4-rls``), 0.999 (``canudas``), ``1 - iv_Ts/5``
        for ``eq4`` (a memory of 5 s: the IV estimate's variance exceeds the LS one's).
    P0, forgetting, T_filter, initial, dwell_max, offset
        See :class:`adaptive_ff.SlidingFrictionEstimator`.
    Vs, delta : float or None
        Stribeck factors for the sliding estimator (pre-fit); default those of ``model``.
    model : RegressionModel or None
        Regression structure for ``eq4`` and ``eq4-rls``.
    iv_Ts : float or None
        Sample time (s) of ``eq4``, a multiple of ``Tc``; default None: 2 ms (rounded to a multiple of ``Tc``).
    iv_map_stderr : float
        ``eq4``'s determinacy test in mode ``adaptive`` (> 0; default ``inf``: none): an estimate is put into use
        only once the standard error of its static map is at most this times its ``max(Fc, Fs)``
        (:class:`~adaptive_ff.compensation.eq4_feedforward.AdaptiveFrictionFeedforward` ``map_rel_stderr``;
        docs/benchmarks/compensation.md, "The eq. 4 estimate's determinacy test"). Mode ``adaptive-dob`` uses
        none.
    """

    name: str = DEFAULT_ESTIMATOR
    Ts: float = _SLIDING["Ts"]
    lam: float | None = None
    P0: float = _SLIDING["P0"]
    forgetting: str = FORGETTINGS[_SLIDING["forgetting"]]
    T_filter: float = _SLIDING["T_filter"]
    initial: FrictionEstimate | None = None
    dwell_max: float = _SLIDING["dwell_max"]
    offset: bool = bool(_SLIDING["offset"])
    Vs: float | None = None
    delta: float | None = None
    model: RegressionModel | None = None
    iv_Ts: float | None = None
    iv_map_stderr: float = math.inf

    def __post_init__(self):
        check_estimator("estimator", self.name)
        check_positive_or_inf("iv_map_stderr", self.iv_map_stderr)


@dataclass(frozen=True)
class FeedforwardSettings:
    """The friction feedforward (``fixed``, ``adaptive``, ``canudas``) and the use of an adaptive estimate.

    Parameters
    ----------
    estimate : FrictionEstimate or None
        Offline estimate for ``fixed``.
    warmup : int
        RLS updates before the adaptive feedforward switches on (also ``canudas``, ``eq4``, ``eq4-rls``).
    lag, lag_margin, lag_margin_max, max_rel_stderr, lag_memory, lag_zero, project
        Use of the sliding ``adaptive`` estimate (see :class:`adaptive_ff.RobustAdaptiveFeedforward`): the lag in
        use is the inverse-variance weighted mean of the lag estimates over ``lag_memory`` (s) plus ``lag_margin``
        standard errors, at most ``lag_margin_max`` of it more; an estimate is used once the standard error of
        ``Fc`` is at most ``max_rel_stderr`` of ``max(Fc, Fs)``; a negative lag within ``max(lag_zero`` standard
        errors, ``2*Tc)`` of 0 is 0; ``project``: the estimate projected onto the plausible box.
    start : FeedforwardStart or None
        Provisional start of the adaptive feedforward (``sliding``, ``eq4``) until the first trusted estimate.
    ff_max : float or None
        Bound on |compensation| (N·m); default ``u_max``.
    ff_input : {"measured", "reference"}
        Velocity the friction feedforward is evaluated at.
    sign_width, stick_band, stick_samples
        See :class:`adaptive_ff.FrictionFeedforward`; ``stick_band`` None: sized by a comparison (three times the
        measurement's noise level), which a run needs done.
    stick_input : {"model", "reference"}
        Velocity the measured-velocity feedforward uses while the joint is detected as stuck: the nominal loop's
        (:class:`adaptive_ff.compensation.velocity_input.LoopModel`; default) or the reference itself (measured
        on ``paper``: docs/benchmarks/variants.md).
    sign_input : {"observer", "measured"}
        Sign of the friction map inside ``±stick_band``: a
        :class:`adaptive_ff.compensation.velocity_input.SignObserver` of the design inertia (default) or the
        measurement's own sign.
    observer_bandwidth : float or None
        Bandwidth of that observer (rad/s); default None: ``5*Kp/J_design``, five times the loop's crossover.
    """

    estimate: FrictionEstimate | None = None
    warmup: int = _ROBUST["warmup"]
    lag: bool = bool(_FF["lag"])
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
    stick_band: float | None = _FF["stick_band"]
    stick_samples: int = _FF["stick_samples"]
    stick_input: str = "model"
    sign_input: str = "observer"
    observer_bandwidth: float | None = None

    def __post_init__(self):
        if self.ff_input not in FF_INPUTS:
            raise ParameterError(f"ff_input must be one of {FF_INPUTS}, got {self.ff_input!r}")
        if self.stick_input not in ("model", "reference"):
            raise ParameterError(f"stick_input must be 'model' or 'reference', got {self.stick_input!r}")
        if self.sign_input not in ("observer", "measured"):
            raise ParameterError(f"sign_input must be 'observer' or 'measured', got {self.sign_input!r}")
        if self.observer_bandwidth is not None:
            check_positive("observer_bandwidth", self.observer_bandwidth)


@dataclass(frozen=True)
class ObserverSettings:
    """The disturbance observers: ``dob``'s and the residual observer of ``adaptive`` and ``adaptive-dob``.

    Parameters
    ----------
    J_n : float or None
        Nominal inertia of every observer (kg·m²; default ``J_design``), also the supervisor's statistic's.
    omega_q : float
        Q-filter cut-off of ``dob`` (rad/s).
    omega_r : float
        Q-filter cut-off (rad/s) of the residual observer; default 1000 (measured on ``paper``: RMS deviation from
        the frictionless run 1.46x the oracle's at 500 rad/s, 1.07x at 1000, docs/benchmarks/variants.md).
    switch_in : bool
        Mode ``adaptive`` (``Kp > 0``): run the residual observer from the start and switch it in once the loop's
        model predicts that what the feedforward leaves raises the mean-square tracking error by more than
        ``switch_in_ratio`` (:class:`controllers.peers.adaptive_dob.ResidualSwitchIn`); default True.
    switch_in_ratio : float
        Its threshold (-), > 0.
    """

    J_n: float | None = None
    omega_q: float = _DOB["omega_q"]
    omega_r: float = 1000.0
    switch_in: bool = True
    switch_in_ratio: float = _SWITCH_IN["ratio"]

    def __post_init__(self):
        check_positive("omega_r", self.omega_r)
        if self.J_n is not None:
            check_positive("J_n", self.J_n)
        _check_bool("switch_in", self.switch_in)
        check_positive("switch_in_ratio", self.switch_in_ratio)


@dataclass(frozen=True)
class SupervisorSettings:
    """The supervisor of the adaptive modes (:class:`adaptive_ff.compensation.supervisor.FeedforwardSupervisor`).

    Parameters
    ----------
    enabled : bool
        Pass the compensation of :data:`controllers.simulation.compensators.SUPERVISED_MODES` through the
        supervisor, which backs it off while it makes the torque disturbance the PI sees larger than the friction
        alone (flat ``supervise``; default True).
    window : float
        Time constant of its mean squares (s).
    margin : float
        Its hysteresis (-), in [0, 1).
    omega : float or None
        Cut-off of its Q-filter (rad/s); default None: ``Kp/J_design``, the loop's crossover.
    tracking : bool
        Its tracking test (needs ``Kp > 0``), default True.
    track_margin : float
        That test's margin (-), >= 0.
    rest_band : float or None
        The reference is at rest where ``|w_ref|`` is at most this (rad/s): no compensation there; None: no rest
        rule.
    """

    enabled: bool = True
    window: float = _SUP["window"]
    margin: float = _SUP["margin"]
    omega: float | None = None
    tracking: bool = True
    track_margin: float = _SUP["track_margin"]
    rest_band: float | None = _SUP["rest_band"]

    def __post_init__(self):
        _check_bool("supervise", self.enabled)
        check_positive("supervise_window", self.window)
        _check_bool("supervise_tracking", self.tracking)
        check_nonnegative("supervise_track_margin", self.track_margin)
        if not (0.0 <= self.margin < 1.0):
            raise ParameterError(f"supervise_margin must be in [0, 1), got {self.margin!r}")
        if self.omega is not None:
            check_positive("supervise_omega", self.omega)
        if self.rest_band is not None:
            check_nonnegative("supervise_rest_band", self.rest_band)


@dataclass(frozen=True)
class RunSettings:
    """The run's own settings of :func:`controllers.simulation.closed_loop.run_closed_loop`: divergence bound,
    records, metrics, initial friction.

    Parameters
    ----------
    w_limit : float or None
        |velocity| (rad/s) beyond which the run is declared diverged; default ``100*max|w_ref| + 1``.
    decimate : int
        Keep every ``decimate``-th sample of the signals (1 = all, default; 0 = none and no ``theta``
        history). The metrics always cover every sample.
    reversal_window : float
        Half-width (s) of the reversal windows of the metrics; default 0.2.
    friction0 : float or None
        Initial friction state (N·m) of a lagged plant (``tau > 0``, eq. 3: the ``F`` of ``tau dF/dt = F(w) - F``),
        e.g. 0 for a lag that starts unloaded; default (None) steady motion at ``w_ref[0]``
        (:func:`plant.dynamics.plant_state`). Ignored where ``tau == 0``.
    """

    w_limit: float | None = None
    decimate: int = 1
    reversal_window: float = 0.2
    friction0: float | None = None


#: Group name -> its settings class, in :class:`LoopConfig`'s order.
GROUPS = {"controller": ControllerSettings, "drive": DriveSettings, "sensor": SensorSettings,
          "estimator": EstimatorSettings, "feedforward": FeedforwardSettings, "observer": ObserverSettings,
          "supervisor": SupervisorSettings, "run": RunSettings}

#: The flat keywords whose field has another name in its group: ``flat -> (group, field)``.
_RENAMED = {"estimator": ("estimator", "name"), "sensor_gate": ("sensor", "gate"),
            "supervise": ("supervisor", "enabled"), "supervise_window": ("supervisor", "window"),
            "supervise_margin": ("supervisor", "margin"), "supervise_omega": ("supervisor", "omega"),
            "supervise_tracking": ("supervisor", "tracking"),
            "supervise_track_margin": ("supervisor", "track_margin"),
            "supervise_rest_band": ("supervisor", "rest_band")}

#: Flat keyword -> ``(group, field)``: every setting of every group, by its field's name but for the renamed ones.
#: The one map from the flat names (the CLI's, the TOML files', the former ``ModeOptions`` fields) to the paths.
FLAT_PATHS = {**{f.name: (g, f.name) for g, cls in GROUPS.items() for f in fields(cls)
                 if (g, f.name) not in _RENAMED.values()}, **_RENAMED}


def _path(name: str) -> tuple:
    """``(group, field)`` of the flat keyword ``name`` (ParameterError naming an unknown one)."""
    if name not in FLAT_PATHS:
        raise ParameterError(f"unknown loop setting {name!r}; known: {sorted(FLAT_PATHS)}")
    return FLAT_PATHS[name]


def _flat_groups(knobs: dict) -> dict:
    """``{group: {field: value}}`` of flat ``knobs`` (ParameterError naming an unknown keyword)."""
    out = {g: {} for g in GROUPS}
    for k, v in knobs.items():
        g, name = _path(k)
        out[g][name] = v
    return out


@dataclass(frozen=True)
class LoopConfig:
    """Settings of a closed-loop run in a named mode (:func:`controllers.simulation.closed_loop.run_mode`), one
    group per part of the loop (see the module's table; every group a frozen dataclass with its defaults and its
    checks).

    Parameters
    ----------
    controller : ControllerSettings
    drive : DriveSettings
    sensor : SensorSettings
    estimator : EstimatorSettings
    feedforward : FeedforwardSettings
    observer : ObserverSettings
    supervisor : SupervisorSettings
    run : RunSettings

    Raises
    ------
    ParameterError
        A group of the wrong type, a setting out of range (the group's check), ``estimator.Ts`` or
        ``estimator.iv_Ts`` not a multiple of ``controller.Tc``, a sensor or a drive its component refuses at that
        period.

    Examples
    --------
    >>> o = LoopConfig.from_flat(Kp=0.4, Ki=4.0, estimator="eq4", supervise=False)
    >>> (o.controller.Kp, o.estimator.name, o.supervisor.enabled)
    (0.4, 'eq4', False)
    """

    controller: ControllerSettings = field(default_factory=ControllerSettings)
    drive: DriveSettings = field(default_factory=DriveSettings)
    sensor: SensorSettings = field(default_factory=SensorSettings)
    estimator: EstimatorSettings = field(default_factory=EstimatorSettings)
    feedforward: FeedforwardSettings = field(default_factory=FeedforwardSettings)
    observer: ObserverSettings = field(default_factory=ObserverSettings)
    supervisor: SupervisorSettings = field(default_factory=SupervisorSettings)
    run: RunSettings = field(default_factory=RunSettings)

    def __post_init__(self):
        for g, cls in GROUPS.items():
            if not isinstance(getattr(self, g), cls):
                raise ParameterError(f"{g} must be a {cls.__name__}, got {type(getattr(self, g)).__name__}")
        Tc, est, sensor = self.controller.Tc, self.estimator, self.sensor
        check_multiple("Ts", est.Ts, "Tc", Tc)
        if est.iv_Ts is not None:
            check_multiple("iv_Ts", est.iv_Ts, "Tc", Tc)
        if sensor.velocity_bandwidth is not None and sensor.velocity_bandwidth >= 0.5 / Tc:
            raise ParameterError(f"velocity_bandwidth must be below the Nyquist frequency {0.5 / Tc:.6g} Hz, "
                                 f"got {sensor.velocity_bandwidth!r}")
        from controllers.simulation.sensor_drive import Drive, Sensor  # the checks of the components themselves

        Sensor(Tc=Tc, counts_per_rev=sensor.encoder_counts, delay=sensor.delay, velocity=sensor.velocity,
               bandwidth=sensor.velocity_bandwidth, model=sensor.velocity_model)
        Drive(Tc=Tc, slew_rate=self.drive.slew_rate)

    @classmethod
    def from_flat(cls, **knobs) -> "LoopConfig":
        """The config of flat keywords (:data:`FLAT_PATHS`: ``estimator="eq4"`` is ``estimator.name``); the rest
        the groups' defaults.

        Raises
        ------
        ParameterError
            An unknown keyword (named), or a value a group's check refuses.
        """
        return cls(**{g: GROUPS[g](**kw) for g, kw in _flat_groups(knobs).items()})

    def replace(self, **knobs) -> "LoopConfig":
        """A copy with the flat keywords ``knobs`` changed (:data:`FLAT_PATHS`), checked anew."""
        groups = _flat_groups(knobs)
        return _dc_replace(self, **{g: _dc_replace(getattr(self, g), **kw) for g, kw in groups.items() if kw})

    def flat(self, name: str):
        """The value of the flat keyword ``name`` (:data:`FLAT_PATHS`; ParameterError if unknown)."""
        g, f = _path(name)
        return getattr(getattr(self, g), f)

    def to_flat(self) -> dict:
        """Every setting by its flat keyword (:data:`FLAT_PATHS`), the inverse of :meth:`from_flat`."""
        return {k: getattr(getattr(self, g), f) for k, (g, f) in FLAT_PATHS.items()}
