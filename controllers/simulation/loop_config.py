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
default is the one statement of it. One differs: ``feedforward.stick_band`` None, sized from the configured
sensor's velocity noise (:meth:`LoopConfig.sized_stick_band`; 0, the C default, for a noiseless sensor). Each
group checks its own settings but the sensor's and the drive's ranges, which their components check (the
:class:`controllers.simulation.sensor_drive.Sensor` and ``Drive`` a :class:`LoopConfig` builds, its error naming the
setting and its path); :class:`LoopConfig` checks those that tie two groups (a sample time a multiple of
``controller.Tc``).

The flat keywords (the former ``ModeOptions`` fields, the compare CLI's and the TOML files' names) map onto the
paths by :data:`FLAT_PATHS`, the one such map: :meth:`LoopConfig.from_flat` builds a config from them,
:meth:`LoopConfig.replace` changes some, :meth:`LoopConfig.flat` reads one. This module imports no C extension
beyond the defaults' table.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, fields, replace as _dc_replace

from adaptive_ff.compensation.adaptive_feedforward import FeedforwardStart
from adaptive_ff.compensation.defaults import c_defaults
from adaptive_ff.compensation.feedforward import FF_INPUTS
from adaptive_ff.compensation.sliding_estimator import FORGETTINGS
from adaptive_ff.identification.regression import FrictionEstimate, RegressionModel
from controllers.simulation.estimators import DEFAULT_ESTIMATOR, check_estimator
from plant.errors import ParameterError, check_multiple, check_nonnegative, check_positive, check_positive_or_inf

__all__ = ["LoopConfig", "ControllerSettings", "DriveSettings", "SensorSettings", "EstimatorSettings",
           "FeedforwardSettings", "ObserverSettings", "SupervisorSettings", "RunSettings", "FLAT_PATHS",
           "GROUPS", "STICK_BAND_NOISE", "stick_band_for"]

_FF = c_defaults("aff_fixed_ff_config")
_ROBUST = c_defaults("aff_robust_ff_config")
_SLIDING = c_defaults("aff_sliding_config")
_SUP = c_defaults("aff_supervisor_config")
_DOB = c_defaults("aff_dob_config")
_SWITCH_IN = c_defaults("aff_switch_in_config")


#: The stick band per unit standard deviation of the velocity measurement's noise (-): the one rule that sizes it
#: (:func:`stick_band_for`), for a loop's configured sensor and for a noise a user estimated (an identification's).
STICK_BAND_NOISE = 3.0


def stick_band_for(noise: float) -> float:
    """The stick-detection band (rad/s) for a velocity measurement of noise standard deviation ``noise`` (rad/s):
    :data:`STICK_BAND_NOISE` times it, so that the noise alone leaves the band on about 0.3 % of the samples.

    The noise is what a user knows of the sensor (its data sheet, :meth:`LoopConfig.velocity_noise`, or an
    identification's noise estimate), never the simulated truth.

    Raises
    ------
    ParameterError
        ``noise`` not a finite number >= 0.
    """
    check_nonnegative("noise", noise)
    if not math.isfinite(noise):
        raise ParameterError(f"noise must be finite (rad/s), got {noise!r}")
    return STICK_BAND_NOISE * float(noise)


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

    # its range: the Drive's check (LoopConfig builds one, naming the setting)


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
        check_nonnegative("noise_std", self.noise_std)  # the run's noise; the rest: the Sensor's checks


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
    sign_width, stick_samples
        See :class:`adaptive_ff.FrictionFeedforward`.
    stick_band : float or None
        Stick-detection band (rad/s), see :class:`adaptive_ff.FrictionFeedforward`; a number is used as given;
        None (default): sized from the sensor the loop is configured with, :func:`stick_band_for` of its velocity
        noise (:meth:`LoopConfig.velocity_noise`: the white noise and an encoder's quantisation), 0 for a
        noiseless sensor (the C component's default). A measured velocity's sign flips with its noise inside
        that band: with a band of 0 the friction map follows it.
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
    stick_band: float | None = None
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
        Cut-off of its Q-filter (rad/s); default None: ``Kp/J_n``, the loop's crossover with the observers'
        nominal inertia.
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


#: A keyword of the components a config builds (:class:`controllers.simulation.sensor_drive.Sensor`, ``Drive``)
#: -> the flat name of the setting that feeds it (:data:`FLAT_PATHS`).
_COMPONENT_KEYWORDS = {"counts_per_rev": "encoder_counts", "delay": "delay", "velocity": "velocity",
                       "bandwidth": "velocity_bandwidth", "model": "velocity_model", "slew_rate": "slew_rate"}


def _as_setting(exc: ParameterError, component: str) -> ParameterError:
    """The component's error ``exc`` (its message opens with its keyword, ``counts_per_rev must ...``) naming the
    setting the user gives instead: its flat name in front, its path and the component's keyword after."""
    msg = str(exc)
    key = re.match(r"\w*", msg).group(0)
    flat = _COMPONENT_KEYWORDS.get(key)
    if flat is None:
        return ParameterError(f"{msg} ({component})")
    g, f = FLAT_PATHS[flat]
    whose = "" if key == flat else f"; the {component}'s {key}"
    return ParameterError(f"{flat}{msg[len(key):]} ({g}.{f}{whose})")


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
        period (the component's message with the setting's flat name in front and its path after:
        ``encoder_counts must be an integer >= 1 ... (sensor.encoder_counts; the Sensor's counts_per_rev)``).

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
        from controllers.simulation.sensor_drive import Drive, Sensor  # the checks of the components themselves

        try:
            Sensor(Tc=Tc, counts_per_rev=sensor.encoder_counts, delay=sensor.delay, velocity=sensor.velocity,
                   bandwidth=sensor.velocity_bandwidth, model=sensor.velocity_model)
        except ParameterError as exc:
            raise _as_setting(exc, "Sensor") from None
        try:
            Drive(Tc=Tc, slew_rate=self.drive.slew_rate)
        except ParameterError as exc:
            raise _as_setting(exc, "Drive") from None

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

    def velocity_noise(self) -> float:
        """Standard deviation (rad/s) of the velocity measurement's error that the sensor's settings imply.

        ``sqrt(noise_std**2 + 2*(res**2/12)/Tc**2)`` with ``res = 2*pi/encoder_counts`` (rad): the white noise plus
        the backward difference of two independent, uniformly distributed quantisation errors of variance
        ``res**2/12`` each (Widrow & Kollar, *Quantization Noise*, 2008, ch. 4); ``noise_std`` without an encoder.
        A 2^17-count encoder at 1 kHz: 0.0196 rad/s. With the Kalman velocity (``velocity="kalman"``) the
        quantisation part is the filter's own steady-state velocity variance ``P[1, 1]`` for white position noise
        ``res**2/12`` (:func:`adaptive_ff.io.kalman_velocity.steady_state_kalman`; 0.0043 rad/s for 2^17 counts,
        cv, 100 Hz). What a user knows of their sensor (its resolution, its filter), not a field of the plant.
        """
        s, Tc = self.sensor, self.controller.Tc
        if s.encoder_counts is None:
            return float(s.noise_std)
        res = 2.0 * math.pi / s.encoder_counts
        if s.velocity == "kalman":
            from adaptive_ff.io.kalman_velocity import steady_state_kalman
            from controllers.simulation.sensor_drive import default_velocity_bandwidth

            bw = s.velocity_bandwidth if s.velocity_bandwidth is not None else default_velocity_bandwidth(Tc)
            kf = steady_state_kalman(s.velocity_model, bandwidth=bw, position_noise=res / math.sqrt(12.0), T=Tc)
            return math.sqrt(s.noise_std ** 2 + float(kf.P[1, 1]))
        return math.sqrt(s.noise_std ** 2 + res * res / (6.0 * Tc * Tc))

    def sized_stick_band(self) -> float:
        """The stick band (rad/s) a run uses: ``feedforward.stick_band`` as given, or where it is None
        :func:`stick_band_for` of :meth:`velocity_noise` (the one rule, used by every run and experiment)."""
        band = self.feedforward.stick_band
        return stick_band_for(self.velocity_noise()) if band is None else float(band)

    def to_flat(self) -> dict:
        """Every setting by its flat keyword (:data:`FLAT_PATHS`), the inverse of :meth:`from_flat`."""
        return {k: getattr(getattr(self, g), f) for k, (g, f) in FLAT_PATHS.items()}
