"""The compensation modes: one registry from a mode name to the plant, controller and compensator objects.

================  ==========================================================================================
mode              objects (:func:`build_mode`)
================  ==========================================================================================
``none``          no compensator
``fixed``         :class:`adaptive_ff.FrictionFeedforward` of an offline estimate (``options.feedforward.estimate``)
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

import contextvars
import functools
import math

from adaptive_ff.compensation.eq4_feedforward import AdaptiveFrictionFeedforward, AdaptiveFrictionFeedforwardConfig
from adaptive_ff.compensation.adaptive_feedforward import RobustAdaptiveFeedforward, RobustAdaptiveFeedforwardConfig
from adaptive_ff.compensation.defaults import c_defaults
from adaptive_ff.compensation.feedforward import FrictionFeedforward, FrictionFeedforwardConfig
from adaptive_ff.compensation.velocity_input import LoopModel, SignObserver
from adaptive_ff.compensation.gate import OutlierGate
from adaptive_ff.compensation.sliding_estimator import SlidingFrictionEstimator, SlidingFrictionEstimatorConfig
from adaptive_ff.compensation.supervisor import FeedforwardSupervisor, FeedforwardSupervisorConfig
from adaptive_ff.identification.regression import RegressionModel
from controllers.design.pi import PIController
from controllers.peers.adaptive_dob import AdaptiveCompensator, AdaptiveDOBCompensator, ResidualSwitchIn
from controllers.peers.canudas import CanudasCompensator, CanudasCompensatorConfig
from controllers.peers.dob import DisturbanceObserver
from controllers.simulation.estimators import ESTIMATORS, check_estimator
from controllers.simulation.loop_config import LoopConfig
from plant.errors import ParameterError, check_positive

__all__ = ["MODES", "ESTIMATORS", "ESTIMATOR_BUILDERS", "check_estimator", "LoopConfig", "TrueFriction",
           "build_mode", "build_modes",
           "REGISTRY", "SUPERVISED_MODES", "build_supervisor", "own_supervisor"]

#: Modes whose compensation a :class:`adaptive_ff.compensation.supervisor.FeedforwardSupervisor` watches when
#: ``LoopConfig.supervisor.enabled`` (the adaptive ones: their estimate may be wrong).
SUPERVISED_MODES = ("adaptive", "adaptive-dob")

#: Default sample time (s) and memory (s, ``lam = 1 - Ts/memory``) of the ``eq4`` estimator
#: (``LoopConfig.estimator.iv_Ts``, ``lam``): the IV removes the noise bias that keeps eq. 4's LS at 10 ms, and at
#: 2 ms the backward differences of eq. 4 misstate the lag less (docs/theory.md).
_IV_TS = 0.002
_IV_MEMORY = 5.0
#: The sliding estimator's C defaults (its forgetting factor where ``estimator.lam`` is None).
_SLIDING = c_defaults("aff_sliding_config")


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


def _ctx(plant, o: LoopConfig) -> tuple:
    frozen = plant.at(0.0) if hasattr(plant, "at") else plant
    J = float(frozen.J) if o.controller.J_design is None else check_positive("J_design", o.controller.J_design)
    ff_max = o.drive.u_max if o.feedforward.ff_max is None else o.feedforward.ff_max
    return J, ff_max


def _crossover(o: LoopConfig, J_n: float) -> float:
    """The crossover of the loop the drive runs (rad/s): ``Kp`` over the observers' nominal inertia ``J_n`` (kg·m²,
    :func:`_nominal_inertia`), 0 without a loop (``Kp`` 0).

    The PI's ``Kp`` acts on the joint's inertia, not on the one it was designed with: where the identification run
    contradicts the design inertia (``o.observer.J_n``, :func:`controllers.experiments.observer_design.observer_inertia`)
    the loop crosses over at ``Kp/J_n``, not at its design crossover ``Kp/J_design``; elsewhere the two are one.
    The supervisor's statistic and tracking model and the residual observer run on ``J_n`` too."""
    return max(o.controller.Kp, 0.0) / J_n


def _nominal_inertia(o: LoopConfig, J: float) -> float:
    """The nominal inertia of every observer (kg·m²): ``o.observer.J_n``, else the design inertia ``J`` (kg·m²,
    :func:`_ctx`)."""
    return J if o.observer.J_n is None else float(o.observer.J_n)


# The map from :class:`LoopConfig` onto the components' config objects (the C settings' dataclasses): one builder
# per config, ``(o, J, ff_max) -> config`` with ``J`` the design inertia (kg·m², the sliding estimator's start) and
# ``ff_max`` the compensation's bound (N·m), or of those only the ones it reads (a config made once per options
# object is then shared by scenarios whose plants differ in J); a mode builds only the configs it uses.

#: The settings made from one options object within one :func:`build_modes` call: (builder, id(options)) ->
#: (options, the other arguments, what it made), or None outside such a call. A :class:`LoopConfig` and what is made
#: here (the components' config dataclasses, :class:`LoopModel`, :class:`SignObserver`, :class:`ResidualSwitchIn`) are
#: frozen, so the scenarios of a batch that share one options object share them, made and checked once per call; an
#: entry holds its options object, so the id is not another's. Nothing is kept across calls: a single
#: :func:`build_mode` makes its settings (a context variable, so threads do not share a call's).
_SCOPE: contextvars.ContextVar = contextvars.ContextVar("compensators_made", default=None)


def _once(builder):
    """``builder(o, *args)`` (frozen settings from the options ``o`` and numbers ``args``) made once per options
    object and equal ``args`` of the same types within one :func:`build_modes` call (:data:`_SCOPE`); made each
    time outside one."""
    @functools.wraps(builder)
    def made(o, *args):
        memo = _SCOPE.get()
        if memo is None:
            return builder(o, *args)
        key, kinds = (builder, id(o)), tuple(map(type, args))
        hit = memo.get(key)
        if hit is not None and hit[0] is o and hit[1] == args and hit[2] == kinds:
            return hit[3]
        value = builder(o, *args)
        memo[key] = (o, args, kinds, value)
        return value

    return made


@_once
def _ff_config(o, ff_max) -> FrictionFeedforwardConfig:
    """``fixed``'s feedforward, and the adaptive ones'."""
    ffs = o.feedforward
    return FrictionFeedforwardConfig(lag=ffs.lag, ff_max=ff_max, sign_width=ffs.sign_width,
                                     stick_band=o.sized_stick_band(), stick_samples=ffs.stick_samples,
                                     ff_input=ffs.ff_input)


@_once
def _robust_config(o, ff_max) -> RobustAdaptiveFeedforwardConfig:
    """The sliding estimator's feedforward (with :func:`_ff_config`'s ``ff``)."""
    ffs = o.feedforward
    return RobustAdaptiveFeedforwardConfig(ff=_ff_config(o, ff_max), warmup=ffs.warmup, lag_margin=ffs.lag_margin,
                                           lag_margin_max=ffs.lag_margin_max, max_rel_stderr=ffs.max_rel_stderr,
                                           lag_memory=ffs.lag_memory, lag_zero=ffs.lag_zero, project=ffs.project)


@_once
def _sliding_config(o, J, ff_max) -> SlidingFrictionEstimatorConfig:
    """The sliding-regime estimator."""
    est = o.estimator
    return SlidingFrictionEstimatorConfig(Ts=est.Ts, T_filter=est.T_filter,
                                          lam=_SLIDING["lam"] if est.lam is None else est.lam,
                                          forgetting=est.forgetting, P0=est.P0, initial_J=J, lag=o.feedforward.lag,
                                          dwell_max=est.dwell_max, offset=est.offset)


@_once
def _supervisor_config(o) -> FeedforwardSupervisorConfig:
    """The feedforward supervisor."""
    sup, ctl = o.supervisor, o.controller
    tracking = sup.tracking and ctl.Kp > 0
    return FeedforwardSupervisorConfig(
        window=sup.window, margin=sup.margin, rest_band=-1.0 if sup.rest_band is None else sup.rest_band,
        delay=int(o.sensor.delay), Kp=ctl.Kp if tracking else 0.0, Ki=ctl.Ki if tracking else 0.0,
        track_margin=sup.track_margin)


def _canudas_config(o, J, ff_max) -> CanudasCompensatorConfig:
    """The Canudas peer."""
    est, ffs = o.estimator, o.feedforward
    return CanudasCompensatorConfig(Ts=est.Ts, lam=CanudasCompensatorConfig.lam if est.lam is None else est.lam,
                                    forgetting=est.forgetting, P0=est.P0, J_guess=J, warmup=ffs.warmup,
                                    ff_max=ff_max, ff_input=ffs.ff_input)


def _eq4_rls_config(o, J, ff_max) -> AdaptiveFrictionFeedforwardConfig:
    """Estimator ``eq4-rls``, the paper's prototype: RLS at ``Ts``, the bare feedforward."""
    est, ffs = o.estimator, o.feedforward
    return AdaptiveFrictionFeedforwardConfig(
        Ts=est.Ts, lam=_SLIDING["lam"] if est.lam is None else est.lam, P0=est.P0, warmup=ffs.warmup,
        ff=FrictionFeedforwardConfig(lag=ffs.lag, ff_max=ff_max, ff_input=ffs.ff_input))


def _eq4_config(o, J, ff_max) -> AdaptiveFrictionFeedforwardConfig:
    """Estimator ``eq4``: recursive IV at ``iv_Ts`` on the samples above ``model.Vs`` (:func:`_eq4_model` first)."""
    est, ffs, m = o.estimator, o.feedforward, o.estimator.model
    Tc = o.controller.Tc
    iv_Ts = Tc * max(1, round(_IV_TS / Tc)) if est.iv_Ts is None else est.iv_Ts
    return AdaptiveFrictionFeedforwardConfig(
        Ts=iv_Ts, lam=1.0 - iv_Ts / _IV_MEMORY if est.lam is None else est.lam, P0=est.P0, warmup=ffs.warmup,
        iv=True, w_band=m.Vs if m.stribeck else 0.0, map_rel_stderr=est.iv_map_stderr, ff=_ff_config(o, ff_max))


def build_supervisor(plant, mode: str, options: LoopConfig, *, force: bool = False) -> FeedforwardSupervisor | None:
    """The supervisor of one scenario: a :class:`FeedforwardSupervisor` where ``options.supervisor.enabled`` and
    ``mode`` is one of :data:`SUPERVISED_MODES` (or ``force``: any compensator, e.g. your own in
    :func:`controllers.simulation.closed_loop.run_own`), else None.

    Its settings: ``Tc``, ``J_n`` (``options.observer.J_n``, else the design inertia), ``omega =
    supervise_omega`` (default ``Kp/J_n``, the loop's crossover, :func:`_crossover`; ``10/supervise_window`` rad/s where
    ``Kp`` is 0), ``window = supervise_window``, ``margin = supervise_margin``, ``rest_band = supervise_rest_band``,
    ``delay`` = the options' measurement delay (periods).

    Parameters
    ----------
    plant : plant model
        The true plant (its J is the design inertia where ``options.controller.J_design`` is None).
    mode : str
        The mode's name (the user's compensator of ``run_own``: any name with ``force``).
    options : LoopConfig
        The loop's settings.
    force : bool, keyword-only
        Supervise whatever ``mode`` is (``options.supervisor.enabled`` still has to be True).

    Returns
    -------
    FeedforwardSupervisor or None

    Raises
    ------
    ParameterError
        A measurement delay above :data:`adaptive_ff.compensation.supervisor.DELAY_MAX`.
    """
    if not (options.supervisor.enabled and (force or mode in SUPERVISED_MODES)):
        return None
    J, ff_max = _ctx(plant, options)
    J_n = _nominal_inertia(options, J)
    return _supervisor(options, J, J_n, ff_max, _crossover(options, J_n))


def _supervisor(o: LoopConfig, J: float, J_n: float, ff_max: float, wc: float, *,
                unbuilt: bool = False) -> FeedforwardSupervisor:
    """:func:`build_supervisor`'s supervisor of the design inertia ``J``, the nominal one ``J_n`` (kg·m²), the bound
    ``ff_max`` (N·m) and the crossover ``wc`` (rad/s, :func:`_crossover`), each computed once by the caller;
    ``unbuilt``: for a composite that makes its struct (:meth:`plant.component.Component.unbuilt`)."""
    omega = o.supervisor.omega
    if omega is None:
        omega = wc if o.controller.Kp > 0 else 10.0 / o.supervisor.window
    make = FeedforwardSupervisor.unbuilt if unbuilt else FeedforwardSupervisor
    return make(Tc=o.controller.Tc, J_n=J_n, omega=omega, config=_supervisor_config(o))


def own_supervisor(comp) -> FeedforwardSupervisor | None:
    """The supervisor a compensator carries in its own struct (an :class:`AdaptiveCompensator`'s, which it applies
    itself: the engine then supervises nothing more; also one run by a compiled export,
    :class:`controllers.simulation.exported.ExportedCompensator`, whose ``compensator`` it is), else None."""
    comp = getattr(comp, "compensator", comp)
    return comp.supervisor if isinstance(comp, AdaptiveCompensator) else None


@_once
def _loop_model(o: LoopConfig, J: float) -> LoopModel | None:
    """The nominal loop of the stick-detection fallback (``stick_input`` model), from the PI and the design J."""
    return LoopModel(Kp=o.controller.Kp, Ki=o.controller.Ki, J=J) if o.feedforward.stick_input == "model" else None


@_once
def _sign_observer(o: LoopConfig, J: float) -> SignObserver | None:
    """The velocity observer that signs the friction map inside the stick band (``sign_input`` observer)."""
    if o.feedforward.sign_input != "observer" or o.controller.Kp <= 0.0:
        return None
    bandwidth = o.feedforward.observer_bandwidth
    return SignObserver(J=J, bandwidth=5.0 * o.controller.Kp / J if bandwidth is None else bandwidth)


def _none(plant, o):
    return plant, None


def _frictionless(plant, o):
    return plant.frictionless(), None


def _oracle(plant, o):
    return plant, TrueFriction()


def _fixed(plant, o):
    if o.feedforward.estimate is None:
        raise ParameterError("mode 'fixed' needs estimate=FrictionEstimate (an offline LS result)")
    J, ff_max = _ctx(plant, o)
    return plant, FrictionFeedforward(o.feedforward.estimate, dt=o.controller.Tc, config=_ff_config(o, ff_max),
                                      loop_model=_loop_model(o, J), sign_observer=_sign_observer(o, J))


def _adaptive(plant, o):
    """Mode ``adaptive``: over the sliding estimator one :class:`AdaptiveCompensator` (the feedforward, the residual
    observer it switches in and the supervisor in one C struct, the one a drive runs); over the eq. 4 estimators the
    composite :class:`AdaptiveDOBCompensator` with the switch-in, supervised by the engine."""
    J, ff_max = _ctx(plant, o)  # the design inertia, the bound and the nominal inertia: once
    J_n = _nominal_inertia(o, J)
    wc = _crossover(o, J_n)  # the residual observer's slew limit scales with it
    sliding = o.estimator.name == "sliding"  # one AdaptiveCompensator: its parts made in its struct (unbuilt)
    ff = _sliding(o, J, ff_max, unbuilt=True) if sliding else ESTIMATOR_BUILDERS[o.estimator.name](o, J, ff_max)
    switch_in = o.observer.switch_in and o.controller.Kp > 0.0
    dob = sw = None
    if switch_in:
        dob = _observer(o, J_n, ff_max, o.observer.omega_r, unbuilt=True)
        sw = _switch_in(o, J_n)
    if sliding:
        sup = _supervisor(o, J, J_n, ff_max, wc, unbuilt=True) if o.supervisor.enabled else None  # build_supervisor's
        return plant, AdaptiveCompensator(ff, dob, u_max=ff_max if switch_in else math.inf, switch_in=sw,
                                          supervisor=sup, crossover=wc)
    if not switch_in:
        return plant, ff
    return plant, AdaptiveDOBCompensator(ff, dob, u_max=ff_max, switch_in=sw, crossover=wc)


@_once
def _switch_in(o: LoopConfig, J_n: float) -> ResidualSwitchIn:
    """Mode ``adaptive``'s residual switch-in on the nominal inertia ``J_n`` (kg·m²)."""
    return ResidualSwitchIn(Tc=o.controller.Tc, J_n=J_n, Kp=o.controller.Kp, Ki=o.controller.Ki,
                            ratio=o.observer.switch_in_ratio)


def _adaptive_feedforward(plant, o):
    """The adaptive feedforward alone (the estimator of ``o.estimator.name``, :data:`ESTIMATOR_BUILDERS`): ``adaptive``
    without the switch-in, the feedforward part of ``adaptive-dob``."""
    J, ff_max = _ctx(plant, o)
    return plant, ESTIMATOR_BUILDERS[o.estimator.name](o, J, ff_max)


def _eq4_model(o) -> RegressionModel:
    """The regression structure of the eq. 4 estimators (``o.estimator.model``; ParameterError without it)."""
    if o.estimator.model is None:
        raise ParameterError(f"mode 'adaptive' with estimator {o.estimator.name!r} needs model=RegressionModel(Vs, "
                             f"delta, ...)")
    return o.estimator.model


def _eq4_rls(o, J: float, ff_max: float) -> AdaptiveFrictionFeedforward:
    """Estimator ``eq4-rls``: the paper's prototype, RLS on every sample at ``Ts``, the bare feedforward."""
    return AdaptiveFrictionFeedforward(_eq4_model(o), dt=o.controller.Tc, config=_eq4_rls_config(o, J, ff_max))


def _eq4_iv(o, J: float, ff_max: float) -> AdaptiveFrictionFeedforward:
    """Estimator ``eq4``: eq. 4 by recursive IV at ``iv_Ts`` on the sliding samples, with the constant-torque column
    (offset) as the sliding estimator's."""
    m = _eq4_model(o)
    model = RegressionModel(m.Vs, m.delta, lag=m.lag, stribeck=m.stribeck, offset=bool(o.estimator.offset))
    return AdaptiveFrictionFeedforward(model, dt=o.controller.Tc, config=_eq4_config(o, J, ff_max),
                                       loop_model=_loop_model(o, J), sign_observer=_sign_observer(o, J),
                                       start=o.feedforward.start)


def _sliding(o, J: float, ff_max: float, *, unbuilt: bool = False) -> RobustAdaptiveFeedforward:
    """Estimator ``sliding``: the sliding-regime inverse-dynamics RLS under the robust feedforward (``unbuilt``: for
    a composite that makes its struct, :meth:`plant.component.Component.unbuilt`; the estimator and its gate always
    are, made in the feedforward's struct)."""
    e = o.estimator
    Vs = e.Vs if e.Vs is not None else (e.model.Vs if e.model is not None else None)
    delta = e.delta if e.delta is not None else (e.model.delta if e.model is not None else None)
    if Vs is None or delta is None:
        raise ParameterError("mode 'adaptive' needs Vs and delta (from the Stribeck pre-fit) or model=")
    gate_step = 2.0 * o.drive.u_max * o.controller.Tc / J if math.isfinite(o.drive.u_max) else math.inf
    est = SlidingFrictionEstimator.unbuilt(Vs, delta, Tc=o.controller.Tc, config=_sliding_config(o, J, ff_max),
                                           initial=e.initial, gate=OutlierGate.unbuilt(max_step=gate_step))
    make = RobustAdaptiveFeedforward.unbuilt if unbuilt else RobustAdaptiveFeedforward
    return make(est, dt=o.controller.Tc, config=_robust_config(o, ff_max), start=o.feedforward.start,
                loop_model=_loop_model(o, J), sign_observer=_sign_observer(o, J))


#: Estimator name (:data:`controllers.simulation.estimators.ESTIMATORS`, the one list of names: the options' check,
#: the compare CLI's ``--estimator`` choices) -> builder ``(options, design inertia J, feedforward bound) -> adaptive
#: feedforward`` of mode ``adaptive``.
ESTIMATOR_BUILDERS = {"sliding": _sliding, "eq4": _eq4_iv, "eq4-rls": _eq4_rls}
if tuple(ESTIMATOR_BUILDERS) != ESTIMATORS:  # pragma: no cover - a builder per registered name, in its order
    raise ImportError(f"ESTIMATOR_BUILDERS {tuple(ESTIMATOR_BUILDERS)} differ from ESTIMATORS {ESTIMATORS}")


def _adaptive_dob(plant, o):
    # the eq. 4 estimates without the determinacy test: the observer, always applied, takes what an early estimate
    # misses (docs/benchmarks/compensation.md, "The eq. 4 estimate's determinacy test")
    _, ff = _adaptive_feedforward(plant, o.replace(iv_map_stderr=math.inf))
    J, ff_max = _ctx(plant, o)
    J_n = _nominal_inertia(o, J)
    dob = _observer(o, J_n, ff_max, o.observer.omega_r, unbuilt=True)
    return plant, AdaptiveDOBCompensator(ff, dob, u_max=ff_max, crossover=_crossover(o, J_n))


def _canudas(plant, o):
    J, ff_max = _ctx(plant, o)
    return plant, CanudasCompensator(Tc=o.controller.Tc, config=_canudas_config(o, J, ff_max))


def _dob(plant, o):
    """Mode ``dob``: the observer of ``o.observer`` (its cut-off ``omega_q``)."""
    J, ff_max = _ctx(plant, o)
    return plant, _observer(o, _nominal_inertia(o, J), ff_max, o.observer.omega_q)


def _observer(o: LoopConfig, J_n: float, ff_max: float, omega_q: float, *,
              unbuilt: bool = False) -> DisturbanceObserver:
    """A disturbance observer of the nominal inertia ``J_n`` (kg·m²), the bound ``ff_max`` (N·m) and the cut-off
    ``omega_q`` (rad/s): mode ``dob``'s, and a composite's residual observer (``o.observer.omega_r``, checked where
    ``o`` was built; ``unbuilt``: made in the composite's struct, :meth:`plant.component.Component.unbuilt`)."""
    make = DisturbanceObserver.unbuilt if unbuilt else DisturbanceObserver
    return make(J_n=J_n, omega_q=omega_q, Tc=o.controller.Tc, d_max=ff_max)


#: Mode name -> builder ``(plant, options) -> (plant to simulate, compensator or None)``.
REGISTRY = {"none": _none, "fixed": _fixed, "adaptive": _adaptive, "adaptive-dob": _adaptive_dob,
            "canudas": _canudas, "dob": _dob, "oracle": _oracle, "frictionless": _frictionless}

#: Compensation modes, in table order.
MODES = tuple(REGISTRY)


def build_mode(plant, mode: str, options: LoopConfig) -> tuple:
    """The objects of one compensation mode.

    Parameters
    ----------
    plant : plant model
        True plant (any model of :mod:`plant.models`, possibly drifting).
    mode : str
        One of :data:`MODES`.
    options : LoopConfig
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


def _controller(mode: str, options: LoopConfig) -> PIController:
    """The PI of ``options`` after checking ``mode`` and the type of ``options`` (the start of :func:`build_mode`)."""
    if mode not in REGISTRY:
        raise ParameterError(f"mode must be one of {MODES}, got {mode!r}")
    if not isinstance(options, LoopConfig):
        raise ParameterError(f"options must be LoopConfig, got {type(options).__name__}")
    if options.drive.u_max is None:
        raise ParameterError("u_max is None (a comparison sizes it): a loop run needs a number")
    c = options.controller
    return PIController(Kp=c.Kp, Ki=c.Ki, Tc=c.Tc, u_max=options.drive.u_max)


def build_modes(plants, mode: str, options) -> tuple:
    """:func:`build_mode` for B scenarios, with one controller per distinct options object.

    The PI depends on the options only, so scenarios that share one :class:`LoopConfig` object share one
    (unused, never stepped) :class:`PIController` and the frozen settings a mode makes from them (the components'
    config dataclasses, made once per options object in this call); every scenario gets its own compensator (it
    holds the scenario's state and may depend on the plant).

    Parameters
    ----------
    plants : sequence of plant models, length B
        True plants.
    mode : str
        One of :data:`MODES`.
    options : sequence of LoopConfig, length B
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
    scope = _SCOPE.set({})  # the settings of one options object made once for its scenarios, in this call only
    try:
        for p, o in zip(plants, options):
            c = made.get(id(o))
            if c is None:
                c = made[id(o)] = _controller(mode, o)
            run_plant, comp = REGISTRY[mode](p, o)
            run_plants.append(run_plant)
            controllers.append(c)
            comps.append(comp)
    finally:
        _SCOPE.reset(scope)
    return run_plants, controllers, comps
