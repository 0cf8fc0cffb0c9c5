"""The main job: run every friction-compensation mode on the same scenario and compare tracking.

:func:`compare` prepares the comparison from what a user has (:func:`prepare_comparison`: the reference, the PI
design, the quasi-static runs and the Stribeck pre-fit, the identification run) and runs every mode on it. Its
result, :class:`controllers.experiments.comparison.Comparison`, with eta and the notes, is in
:mod:`controllers.experiments.comparison`; the observers' nominal inertia and the residual observer's cut-off in
:mod:`controllers.experiments.observer_design` (both names are importable from here too).
"""

from __future__ import annotations

import math
import dataclasses
from dataclasses import dataclass, field

import numpy as np
from tqdm.auto import tqdm

from adaptive_ff.compensation.adaptive_feedforward import FeedforwardStart
from adaptive_ff.compensation.feedforward import FF_INPUTS, project_estimate
from adaptive_ff.identification.ls import fit_ls
from adaptive_ff.identification.regression import FrictionEstimate, RegressionModel
from adaptive_ff.identification.stribeck_fit import placeholder_shape
from adaptive_ff.compensation.sliding_estimator import SlidingFrictionEstimatorConfig, fit_sliding
from controllers.simulation.closed_loop import run_mode, run_own
from controllers.simulation.compensators import ESTIMATORS, MODES, check_estimator
from controllers.simulation.loop_config import FLAT_PATHS, LoopConfig
from controllers.simulation.memory import MODE_SIGNALS, PREPARATION_SIGNALS, SHARED_SIGNALS, check_run_memory
from controllers.simulation.user_compensator import CompensatorContext, CompensatorError
from controllers.design.pi import PIDesign, design_pi
from controllers.experiments.first_inertia import InertiaDesign, InertiaExperiment, inertia_experiment
from controllers.experiments.comparison import (WORSE_THAN_NONE, Comparison, beyond_frictionless_notes,
                                                diverged_notes, eta, eta_or_none, options_with_changes,
                                                mode_width, number_text, run_notes, whole_run_metrics,
                                                worse_than_none_notes)
from controllers.experiments.observer_design import (J_CONTRADICTED, friction_level, observer_inertia, observer_max,
                                                     residual_cutoff, residual_share)
from controllers.experiments.quasi_static import (StribeckDesign, StribeckExperiment, prefit_stribeck,
                                                  stribeck_experiment)
from plant.errors import (ExcitationError, ParameterError, check_finite_scalar, check_multiple,
                          check_optional_number, check_positive, known_fields)
from plant.dynamics import plant_params
from plant.excitation import bandlimited_noise, multisine_reference
from plant.joint import simulate
from plant.sampling import sample

__all__ = ["Comparison", "CompareOptions", "ComparisonSetup", "DriveLimitError", "check_comparison",
           "check_drive_moves", "compare", "comparison_reference", "eta", "FIXED_METHODS", "PREFIT_MODES",
           "compensator_context", "mode_width", "number_text", "friction_scale", "measurement_noise", "prefit_stribeck",
           "prepare_comparison", "residual_cutoff", "run_notes",
           "WORSE_THAN_NONE", "worse_than_none_notes", "J_CONTRADICTED", "observer_inertia", "EXPERIMENT_LOOP",
           "DESIGNED",
           "EXPERIMENT_DEFAULTS"]

#: Offline identification behind the ``fixed`` mode: the sliding-regime
#: inverse-dynamics LS (:func:`adaptive_ff.compensation.sliding_estimator.fit_sliding`,
#: default) or the paper's eq. 4 LS at Ts (:func:`adaptive_ff.fit_ls`).
FIXED_METHODS = ("sliding", "eq4")

#: Modes that use the Stribeck factors Vs, delta (the pre-fit runs only for them); ``none``, ``canudas``,
#: ``dob``, ``oracle`` and ``frictionless`` never run it.
PREFIT_MODES = ("fixed", "adaptive", "adaptive-dob")


def friction_scale(p, peak_w: float) -> float:
    """Largest |steady-state friction| (N·m) of plant ``p`` for speeds up to ``peak_w`` (rad/s).

    Reads the true plant: for tests and benchmarks that size a scenario. :func:`compare` uses the torque
    scale measured in its quasi-static runs instead (:attr:`StribeckExperiment.torque_scale`).

    Evaluated on 400 speeds log-spaced from ``1e-4*peak_w`` to ``peak_w`` in both
    directions (covers the stiction peak and the viscous end).
    """
    wg = np.geomspace(1e-4 * peak_w, peak_w, 400)
    return float(np.max(np.abs(np.concatenate([p.friction(wg), p.friction(-wg)]))))


#: The experiment's own defaults of loop settings the bare loop (:class:`LoopConfig`, the C components) defaults
#: otherwise, the one place where they differ, each on purpose: ``noise_std`` 1e-3 rad/s (a real sensor's noise; the
#: bare loop is noiseless); ``u_max`` None (three times the measured friction level plus the design inertia times the
#: reference's peak acceleration; the bare loop is unbounded); ``warmup`` 50 sliding-regime RLS updates (the bare
#: component's 200 give the same second-half eta on every plant of ``benchmarks/variants.py``, the feedforward
#: acts about twice as early: docs/benchmarks/variants.md) and ``stick_samples`` 50 (50 ms at 1 ms: with the observer's
#: sign a slow reversal is not taken for sticking; the component's 10: docs/benchmarks/compensation.md).
EXPERIMENT_DEFAULTS = {"noise_std": 1e-3, "u_max": None, "warmup": 50, "stick_samples": 50}
#: Loop settings a comparison sets itself for each joint (its PI design and what it measures,
#: :func:`prepare_comparison`): no keyword of :meth:`CompareOptions.from_flat`.
DESIGNED = ("Kp", "Ki", "ff_max", "model", "estimate", "initial", "start", "omega_r", "J_n")
#: A comparison's loop by default (:attr:`CompareOptions.loop`): the loop's defaults with :data:`EXPERIMENT_DEFAULTS`.
EXPERIMENT_LOOP = LoopConfig.from_flat(**EXPERIMENT_DEFAULTS)


@known_fields(hint="; a loop setting goes in loop=LoopConfig(...) or CompareOptions.from_flat(...)")
@dataclass(frozen=True)
class CompareOptions:
    """Settings of :func:`compare` (all keyword, validated; units SI): the experiment's own settings and the loop's
    (:attr:`loop`, a :class:`controllers.simulation.loop_config.LoopConfig`).

    :meth:`from_flat` takes both as flat keywords (``CompareOptions.from_flat(duration=30.0, estimator="eq4")``: a
    loop setting by its name of :data:`controllers.simulation.loop_config.FLAT_PATHS`, the compare CLI's and the
    TOML files' names); :meth:`replace` changes either kind.

    Parameters
    ----------
    duration : float
        Length of each run (s), default 120.
    seed : int
        Seed of everything random (reference phases, noise, identification run), >= 0.
    modes : sequence of str
        Subset of :data:`controllers.simulation.compensators.MODES`; ``none`` and ``frictionless`` are always
        run (``eta`` needs them).
    compensators : dict of str -> callable, optional
        Your own compensators beside the built-in modes: ``{name: factory}``, each ``factory(context)`` given a
        :class:`controllers.simulation.user_compensator.CompensatorContext` (the design inertia, the PI, the
        limits, the pre-fit; never the true plant) and returning an object with ``compensate(w_meas, w_ref)``
        and ``observe(u, w_meas)``; it runs in the same loop, on the same reference and noise, and appears in
        the table, the figures and the JSON under ``name`` (not a built-in mode's name).
    crossover, phase_margin : float
        PI design targets (rad/s, deg) for :func:`controllers.design.pi.design_pi` on ``1/(J s)``.
    controller : controllers.design.pi.PIDesign or None
        The loop's PI as the user has it (``adaptive-ff design --json``, read by
        :func:`controllers.design.controller_file.read_controller`, or :func:`controllers.design.pi.design_pi` /
        :func:`controllers.design.pi.analyse_gains`), run as given: ``crossover`` and ``phase_margin`` are then not
        used. Its ``Tc`` must equal ``loop.controller.Tc``. Default None: designed from the design inertia and the
        targets.
    prefit : bool
        Estimate Vs, delta by the Stribeck pre-fit from quasi-static runs designed from the joint's response
        (:func:`controllers.experiments.quasi_static.stribeck_experiment`, paper Sec. V-C). Run only for the
        modes that use Vs, delta (``fixed``, ``adaptive``) and when ``loop.estimator.Vs``/``delta`` are not given;
        False needs them for those modes.
    estimator_rows : tuple of str
        Further estimators of :data:`controllers.simulation.compensators.ESTIMATORS` whose mode ``adaptive`` runs
        beside the others, each a row ``adaptive[E]`` of the table (right after ``adaptive``, or where it would
        stand in the registry's order), with the settings of ``adaptive`` but the estimator, on the same
        reference and noise: e.g. ``("eq4", "eq4-rls")`` puts the paper's eq. 4 by instrumental variables and by
        its RLS beside the default. Default ``()``. Each differs from ``loop.estimator.name`` and from the others.
    fixed_method : {"sliding", "eq4"}
        Offline identification of the ``fixed`` mode (:data:`FIXED_METHODS`).
    canudas_input : {"reference", "measured"}
        The velocity the ``canudas`` peer's feedforward is evaluated at; default reference (on the ``paper``
        preset the better of the two for that scheme, see the benchmark pages). The other modes':
        ``loop.feedforward.ff_input``.
    adaptive_initial : bool
        Start the adaptive estimator from the pre-fit's Fc, Fs, sigma and the design inertia (default)
        instead of zero friction.
    adaptive_start : bool
        Provisional start of the adaptive feedforward (``adaptive``, ``adaptive-dob``, estimators ``sliding`` and
        ``eq4``; :class:`adaptive_ff.compensation.adaptive_feedforward.FeedforwardStart`), default True: from the
        first period the pre-fit's static map through the lag identified in the identification run (the offline
        fit of the Sec. IV-A experiment, run for this even without ``fixed``), evaluated as ``ff_input`` says,
        until the estimator's first trusted estimate. When that fit is rejected (implausible levels) the lag is
        unknown: ``1/crossover`` (the loop's own time constant) with the map at the reference, where a wrong lag
        cannot form a stick-slip cycle with the joint. Under the PI alone the joint sticks and the estimator gets
        no sliding data for seconds; until the hand-over the start's lag decides how far the joint strays from
        the frictionless run at every reversal (docs/benchmarks/variants.md).
    faults : mapping int -> float or None
        Measurement faults injected in every mode (see :func:`controllers.simulation.closed_loop.run_closed_loop`).
    reference : Reference or None
        The velocity reference of every run (:class:`plant.excitation.Reference` sampled at ``Tc``: a
        point-to-point cycle of :func:`plant.motion.point_to_point_reference`, constant speed with reversals of
        :func:`plant.motion.reversing_reference`, a recorded trajectory of
        :func:`adaptive_ff.io.references.load_reference`); default None: the multisine of
        :func:`comparison_reference`. Given, ``duration`` becomes the reference's (``N*Tc``).
    loop : LoopConfig
        The loop's settings (default :data:`EXPERIMENT_LOOP`: the loop's defaults but for the experiment's own,
        :data:`EXPERIMENT_DEFAULTS`). What the comparison measures or designs for the joint replaces some of them
        in every mode's config (:func:`prepare_comparison`): the PI gains; the design inertia where
        ``controller.J_design`` is None (identified on the joint before anything else by
        :func:`controllers.experiments.first_inertia.inertia_experiment`, a breakaway ramp to 1.2 times the
        reference's peak speed, then 20 s of open-loop noise torque; the plant's own ``J`` is never read);
        ``estimator.Vs``/``delta`` where None (the pre-fit; give both or neither, ``Vs > 0``, ``delta != 0``);
        ``drive.u_max`` where None (``3*(F_peak + J_design*accel_peak)`` with ``F_peak`` the largest mean torque
        measured in the quasi-static runs); ``feedforward.stick_band`` where None (the loop's own rule,
        :meth:`controllers.simulation.loop_config.LoopConfig.sized_stick_band`: three times the configured
        sensor's noise, :func:`measurement_noise`, which an encoder's quantisation (``sensor.encoder_counts``)
        raises; that noise also sets the residual observer's cut-off and the noise of the quasi-static and
        identification experiments); ``feedforward.ff_max`` (half of ``u_max``); the observers' nominal inertia
        and the residual observer's cut-off (:mod:`controllers.experiments.observer_design`).

    Raises
    ------
    ParameterError
        Unknown mode or fixed method, duration not > 0, ``Vs``/``delta``/``J_design``/``u_max`` out of range or
        only one of ``Vs``, ``delta`` given, or a duration whose runs do not fit into the memory available
        (:meth:`check_memory`: the message gives the samples, the memory they need and the longest duration
        that fits).
    """

    duration: float = 120.0
    seed: int = 0
    modes: tuple = MODES
    crossover: float = 20.0
    phase_margin: float = 60.0
    controller: PIDesign | None = None
    prefit: bool = True
    fixed_method: str = "sliding"
    canudas_input: str = "reference"
    adaptive_initial: bool = True
    adaptive_start: bool = True
    estimator_rows: tuple = ()
    faults: dict | None = None
    compensators: dict | None = None
    reference: object = None
    loop: LoopConfig = field(default_factory=lambda: EXPERIMENT_LOOP)

    def __post_init__(self):
        if not isinstance(self.loop, LoopConfig):
            raise ParameterError(f"loop must be a LoopConfig (controllers.simulation.loop_config), got "
                                 f"{type(self.loop).__name__}")
        Tc, est = self.loop.controller.Tc, self.loop.estimator
        if self.controller is not None:
            if not isinstance(self.controller, PIDesign):
                raise ParameterError(f"controller must be a PIDesign (controllers.design.controller_file."
                                     f"read_controller), got {type(self.controller).__name__}")
            if not math.isclose(self.controller.Tc, Tc, rel_tol=1e-9):
                raise ParameterError(f"controller: its period Tc = {self.controller.Tc!r} s differs from the loop's "
                                     f"Tc = {Tc!r} s")
        if self.reference is not None:  # the reference sets the duration
            object.__setattr__(self, "duration", _reference_duration(self.reference, Tc))
        check_positive("duration", self.duration)
        if self.canudas_input not in FF_INPUTS:
            raise ParameterError(f"canudas_input must be one of {FF_INPUTS}, got {self.canudas_input!r}")
        self._check_estimator_rows()
        check_optional_number("u_max", self.loop.drive.u_max, low=0.0, strict=True)
        if (est.Vs is None) != (est.delta is None):
            raise ParameterError(f"give both Vs and delta, or neither; got Vs={est.Vs!r}, delta={est.delta!r}")
        if est.Vs is not None:
            check_positive("Vs", est.Vs)
            if check_finite_scalar("delta", est.delta) == 0.0:
                raise ParameterError("delta must be non-zero (|w/Vs|**0 is constant), got 0.0")
        check_optional_number("J_design", self.loop.controller.J_design, low=0.0, strict=True)
        unknown = [m for m in self.modes if m not in MODES]
        if unknown:
            raise ParameterError(f"unknown mode(s) {unknown}; known: {MODES}")
        if self.fixed_method not in FIXED_METHODS:
            raise ParameterError(f"fixed_method must be one of {FIXED_METHODS}, got {self.fixed_method!r}")
        for name, factory in (self.compensators or {}).items():
            if not isinstance(name, str) or not name.strip() or name in MODES or name in self.row_labels:
                raise ParameterError(f"compensators: a name must be a non-empty string other than a built-in mode "
                                     f"{MODES} or an estimator row's label {tuple(self.row_labels)}, got {name!r}")
            if not callable(factory):
                raise ParameterError(f"compensators[{name!r}] must be a callable factory(context) -> compensator, "
                                     f"got {type(factory).__name__}")
        self.check_memory()

    @classmethod
    def from_flat(cls, **knobs) -> "CompareOptions":
        """The options of flat keywords: this class's own fields by name, the loop's settings by their flat names
        (:data:`controllers.simulation.loop_config.FLAT_PATHS`) on :data:`EXPERIMENT_LOOP`.

        Raises
        ------
        ParameterError
            A keyword that is neither (named), or a value a check refuses.
        """
        own, flat = _split(knobs)
        return cls(**own, loop=EXPERIMENT_LOOP.replace(**flat) if flat else EXPERIMENT_LOOP)

    @staticmethod
    def flat_names() -> tuple:
        """The keywords :meth:`from_flat` takes: the own fields (but ``loop``), then the loop's flat names
        (:data:`controllers.simulation.loop_config.FLAT_PATHS`) but :data:`DESIGNED`."""
        own = tuple(f.name for f in dataclasses.fields(CompareOptions) if f.name != "loop")
        return own + tuple(k for k in FLAT_PATHS if k not in DESIGNED)

    def flat(self, name: str):
        """The value of the setting ``name`` as :meth:`from_flat` names it (own field or loop setting)."""
        return getattr(self, name) if name in {f.name for f in dataclasses.fields(self)} else self.loop.flat(name)

    def replace(self, **knobs) -> "CompareOptions":
        """A copy with some settings changed, as :meth:`from_flat` names them (``loop=`` a whole
        :class:`LoopConfig`), checked anew."""
        own, flat = _split(knobs)
        loop = own.pop("loop", self.loop)
        return dataclasses.replace(self, **own, loop=loop.replace(**flat) if flat else loop)

    def _check_estimator_rows(self) -> None:
        """``estimator_rows``: a tuple of distinct estimators other than ``estimator`` (ParameterError)."""
        rows = self.estimator_rows
        if isinstance(rows, str) or not isinstance(rows, (tuple, list)):
            raise ParameterError(f"estimator_rows must be a tuple of estimators {ESTIMATORS}, got {rows!r}")
        for e in rows:
            check_estimator("estimator_rows", e)
            if e == self.loop.estimator.name:
                raise ParameterError(f"estimator_rows: {e!r} is the estimator of the adaptive mode's own row")
        if len(set(rows)) != len(rows):
            raise ParameterError(f"estimator_rows: an estimator given twice, {tuple(rows)!r}")
        object.__setattr__(self, "estimator_rows", tuple(rows))

    @property
    def row_labels(self) -> dict:
        """``{label: estimator}`` of :attr:`estimator_rows`, the label ``adaptive[E]`` (the table's row)."""
        return {f"adaptive[{e}]": e for e in self.estimator_rows}

    def check_memory(self, *, processes: int = 1) -> int:
        """Refuse a :func:`compare` of these settings that does not fit into the memory available; its samples.

        Before anything is allocated (run on construction, so every entry that builds these options is
        guarded: :func:`compare`, the zoo, the sweep): ``round(duration/Tc)`` samples times the float64
        signals a comparison holds at its peak, the larger of ``SHARED_SIGNALS + MODE_SIGNALS*n_modes``
        (the reference and one recorded run per mode) and ``PREPARATION_SIGNALS`` when the identification
        run is made (``fixed``, or the adaptive start); :mod:`controllers.simulation.memory`.

        Parameters
        ----------
        processes : int, keyword-only
            Comparisons running at the same time (the workers of a sweep), >= 1.

        Returns
        -------
        int
            Samples per run.

        Raises
        ------
        ParameterError
            The runs do not fit (:func:`controllers.simulation.memory.check_run_memory`).
        """
        run = set(self.modes) | {"none", "frictionless"} | set(self.compensators or {}) | set(self.row_labels)
        adaptive = bool(run & {"adaptive", "adaptive-dob"} or self.estimator_rows)  # estimator rows run adaptive
        ident = "fixed" in run or (self.adaptive_start and adaptive)
        signals = max(SHARED_SIGNALS + MODE_SIGNALS * len(run), PREPARATION_SIGNALS if ident else 0)
        return check_run_memory(self.duration, self.loop.controller.Tc, signals=signals, detail=f"{len(run)} modes",
                                processes=processes)


def _split(knobs: dict) -> tuple:
    """``(own, flat)``: the keywords of :class:`CompareOptions`' own fields and the loop's flat ones
    (ParameterError naming one the comparison sets itself, :data:`DESIGNED`; TypeError one that is neither)."""
    names = {f.name for f in dataclasses.fields(CompareOptions)}
    for k in knobs:
        if k in DESIGNED:
            raise ParameterError(f"{k}: the comparison sets it for each joint (its design and measurements)")
        if k not in names and k not in FLAT_PATHS:  # a keyword no signature has: TypeError, as Python's own
            raise TypeError(f"unknown option {k!r}; known: {', '.join(CompareOptions.flat_names())}")
    return {k: v for k, v in knobs.items() if k in names}, {k: v for k, v in knobs.items() if k not in names}


def compare(p, options: CompareOptions | None = None, *, progress: bool | None = None, **changes) -> Comparison:
    """Run the closed loop in several friction-compensation modes on one scenario.

    Parameters
    ----------
    p : JointParams or another plant model
        True plant, any model of :mod:`plant.models`, possibly drifting
        (:class:`plant.drift.FrictionDrift`; the pre-fit and the identification
        experiment of ``fixed`` then see the plant at ``t = 0``).
    options : CompareOptions, optional
        Settings; default ``CompareOptions()``.
    progress : bool, keyword-only
        Show a progress bar; default: when stderr is a terminal.
    **changes
        Fields of :class:`CompareOptions` to change (e.g. ``duration=20.0, seed=3``).

    Returns
    -------
    Comparison

    Raises
    ------
    ParameterError
        Unknown mode, unknown option name or invalid settings.

    Notes
    -----
    ``fixed`` uses an offline fit of a separate identification run: the
    paper's Sec. IV-A experiment (open loop, 1 Hz low-pass band-limited
    white-noise torque of standard deviation ``1.2*F_peak``, ``F_peak`` the
    torque scale measured in the quasi-static runs, same length, same
    velocity noise), identified by ``fixed_method`` — the same sliding-regime
    regression as the adaptive estimator (on the 1 kHz record) or the paper's
    eq. 4 at ``Ts``. ``adaptive`` estimates online on the loop's own data.
    ``eta`` uses the RMS error over the second half of the run, ``eta_full`` over the whole run; ``rms_dev``
    is the RMS distance of each run's velocity from the frictionless run's (same reference and noise), and
    ``t_ff_on`` the first time the mode's compensation torque is non-zero.

    No field of the true plant reaches the design, the estimators, the
    compensators or the experiments: they see the plant only through its
    simulated response (the plant step); without ``J_design`` the design
    inertia is identified (:func:`controllers.experiments.first_inertia.inertia_experiment`).
    ``oracle`` and ``frictionless`` are the references, not compensators a user could build.
    """
    o = options_with_changes(options if options is not None else CompareOptions(), changes, where="compare")
    s = prepare_comparison(p, o, progress=progress)
    results = {}
    runs = [(mode, mode, s.mode_options[mode]) for mode in s.modes]
    after = MODES.index("adaptive")  # the rows where adaptive stands in the registry's order, right after it
    at = next((k for k, mode in enumerate(s.modes) if MODES.index(mode) > after), len(runs))
    runs[at:at] = [(label, "adaptive", mo) for label, mo in s.estimator_rows.items()]
    for label, mode, mo in runs:
        s.bar.set_postfix_str(label)
        results[label] = run_mode(p, s.reference, mode, mo, rng=np.random.default_rng(s.noise_seed), faults=o.faults)
        s.bar.update()
    if o.compensators:
        ctx = compensator_context(s, o)
        for name, factory in o.compensators.items():
            s.bar.set_postfix_str(name)
            results[name] = run_own(p, s.reference, own_compensator(name, factory, ctx), s.mode_options["none"],
                                    name=name, rng=np.random.default_rng(s.noise_seed), faults=o.faults)
    s.bar.close()
    rn = results["none"].metrics.rms_second_half
    rf = results["frictionless"].metrics.rms_second_half
    etas = {mode: eta_or_none(rn, r.metrics.rms_second_half, rf) for mode, r in results.items()}
    return Comparison(plant=p, design=s.design, results=results, eta=etas, prefit=s.prefit, offline=s.offline,
                      model=s.model, experiment=s.experiment, J_design=s.J_design, inertia=s.inertia,
                      notes=(tuple(s.notes) + diverged_notes(results) + run_notes(results)
                             + worse_than_none_notes(etas, results) + beyond_frictionless_notes(etas, results)),
                      **whole_run_metrics(results))


def own_compensator(name: str, factory, ctx: CompensatorContext):
    """``factory(ctx)``, the compensator of ``compensators[name]``, checked for the protocol before its run.

    Raises
    ------
    CompensatorError
        The factory raised (an ``Exception``; an interrupt propagates as it is), naming the compensator.
    ParameterError
        What it returned lacks ``compensate`` or ``observe`` (the missing ones named).
    """
    try:
        obj = factory(ctx)
    except Exception as exc:  # noqa: BLE001 -- the user's code may raise anything
        raise CompensatorError(f"compensator {name!r}: its factory failed: {type(exc).__name__}: {exc}") from exc
    missing = [m for m in ("compensate", "observe") if not callable(getattr(obj, m, None))]
    if missing and getattr(obj, "C_OPS", None) is None:
        raise ParameterError(f"compensators[{name!r}]: its factory returned a {type(obj).__name__} without "
                             f"{' and '.join(missing)} (a compensator needs compensate(w_meas, w_ref) and "
                             f"observe(u, w_meas))")
    return obj


def compensator_context(s: ComparisonSetup, o: CompareOptions) -> CompensatorContext:
    """What a user's compensator factory is given (:class:`CompensatorContext`) in a comparison prepared as
    ``s`` with options ``o``: the design inertia, the PI, the periods and limits, the design's noise level
    (:func:`measurement_noise`) and the Stribeck pre-fit; never the true plant."""
    mo = s.mode_options["none"]
    c = mo.controller
    return CompensatorContext(J=float(s.J_design), Tc=c.Tc, Ts=mo.estimator.Ts, Kp=c.Kp, Ki=c.Ki,
                              u_max=mo.drive.u_max, ff_max=mo.feedforward.ff_max, noise_std=measurement_noise(o),
                              prefit=s.prefit)


def comparison_reference(o: CompareOptions):
    """The velocity reference of :func:`compare` with options ``o`` (a multisine of ``o.duration`` s at
    ``o.loop.controller.Tc`` from the first child of ``SeedSequence(o.seed)``; :func:`plant.excitation.multisine_reference`)."""
    ref_ss = np.random.SeedSequence(o.seed).spawn(4)[0]
    return multisine_reference(o.duration, dt=o.loop.controller.Tc, rng=np.random.default_rng(ref_ss))


@dataclass(frozen=True)
class ComparisonSetup:
    """What :func:`compare` prepares before its runs: the reference, the PI design, the experiments and fits and
    every mode's :class:`LoopConfig` (all from what a user has: simulated experiments, never the true friction).

    Attributes
    ----------
    modes : tuple of str
        The modes to run (``none`` and ``frictionless`` included), in registry order.
    reference : Reference
        Velocity reference sampled at ``Tc``.
    design : PIDesign
    mode_options : dict
        ``{mode: LoopConfig}``.
    noise_seed : numpy.random.SeedSequence
        Seed of the measurement noise (the same noise in every mode).
    prefit, offline, model, experiment, J_design, notes, inertia
        As in :class:`Comparison`.
    bar : tqdm progress bar (the caller updates and closes it)
    estimator_rows : dict
        ``{label: LoopConfig}`` of ``CompareOptions.estimator_rows``: mode ``adaptive`` with another estimator,
        label ``adaptive[E]``; empty without.
    """

    modes: tuple
    reference: object
    design: PIDesign
    mode_options: dict
    noise_seed: object
    prefit: object
    offline: object
    model: object
    experiment: object
    J_design: float
    notes: tuple
    bar: object
    estimator_rows: dict = field(default_factory=dict)
    inertia: InertiaExperiment | None = None


def _drive_limit(p0, o: CompareOptions, exp, J: float, peak_a: float) -> tuple:
    """``(u_max, F_peak)``: the torque limit (``o.loop.drive.u_max``, or ``3*(F_peak + J*peak_a)`` checked against the
    joint's breakaway, :func:`check_drive_moves`) and the measured friction level ``F_peak`` (N·m; the largest mean torque
    of the quasi-static runs ``exp``, else ``u_max/3``), for the design inertia ``J`` (kg·m²) and the reference's
    peak acceleration ``peak_a`` (rad/s²)."""
    F_peak = exp.torque_scale if exp is not None else None
    u_max = o.loop.drive.u_max if o.loop.drive.u_max is not None else 3.0 * (F_peak + J * peak_a)
    if o.loop.drive.u_max is None:
        check_drive_moves(p0, u_max, derived=True)
    return u_max, (F_peak if F_peak is not None else u_max / 3.0)


def prepare_comparison(p, o: CompareOptions, *, progress: bool | None = False, reference=None) -> ComparisonSetup:
    """The preparation of :func:`compare`: reference, PI design, Stribeck experiment and pre-fit, offline fit of
    ``fixed``, the options of every mode.

    Parameters
    ----------
    p : plant model or FrictionDrift
        True plant (only simulated experiments on it are used).
    o : CompareOptions
    progress : bool, keyword-only
        Progress bar over the preparation and the runs (:attr:`ComparisonSetup.bar`).
    reference : Reference, keyword-only
        ``comparison_reference(o)`` when the caller already has it (the zoo prepares many joints on one
        reference); default: made here.

    Returns
    -------
    ComparisonSetup

    Raises
    ------
    ParameterError, ExcitationError
        Invalid settings, a ``reference`` not on the grid of ``o`` (``Tc``, ``duration``), or a fit that cannot
        be made.

    Notes
    -----
    A joint whose quasi-static runs measured no friction (``StribeckExperiment.no_friction``: every mean
    torque within the resolution of its mean) has nothing to identify: there is no pre-fit (``prefit`` None) and no
    identification run (``offline`` None), ``fixed`` feeds forward zero friction (``Fc = Fs = sigma = 0``, so
    it runs exactly as ``none``), and the adaptive modes start from zero friction without a provisional start,
    their ``Vs``, ``delta`` the given ones or placeholders (the lowest speed of the runs and 1, as the pre-fit's
    Coulomb + viscous fallback); a note says so. ``eta`` is then undefined (0/0).

    Without ``o.loop.controller.J_design`` the design inertia is identified first
    (:func:`controllers.experiments.first_inertia.inertia_experiment`, :attr:`ComparisonSetup.inertia`): every loop
    of the preparation needs it, and it needs no loop.

    ``fixed`` never fails on its own identification: when the offline fit of its identification run is
    rejected as implausible (:func:`adaptive_ff.compensation.feedforward.project_estimate`: a level above half
    the actuator range, a negative inertia, e.g. a Stribeck term the pre-fit's ``Vs``, ``delta`` cannot
    separate from the Coulomb level), ``fixed`` uses the pre-fit's static map instead, without a lag (the lag
    would come from the rejected fit), with a note in ``notes``. The identification run is also made for the
    adaptive modes' provisional start (its lag, see ``CompareOptions.adaptive_start``). The residual observer of
    ``adaptive-dob`` gets the cut-off :func:`residual_cutoff` of the design inertia, the noise estimate and the
    friction level of the quasi-static runs that held (1000 rad/s unless its noise torque would exceed half
    that level, a third where the runs found the joint sticking: :func:`residual_share`). Where the identification
    run's inertia contradicts the design inertia (:func:`observer_inertia`), every observer takes the identified one
    (``LoopConfig.observer.J_n``) and a note says so; the PI keeps its design.
    """
    run_modes = [m for m in MODES if m in set(o.modes) | {"none", "frictionless"}]
    p0 = p.at(0.0) if hasattr(p, "at") else p
    _, id_ss, noise_ss, qs_ss, J_ss = np.random.SeedSequence(o.seed).spawn(5)
    if reference is None:
        reference = o.reference
    ref = comparison_reference(o) if reference is None else _checked_reference(reference, o)
    noise = measurement_noise(o)
    peak_w, peak_a = float(np.max(np.abs(ref.w))), float(np.max(np.abs(ref.dw)))
    _preflight(p0, o, peak_w, noise)
    J_given, Tc = o.loop.controller.J_design, o.loop.controller.Tc
    first = None if J_given is not None else _first_inertia(p0, o, peak_w, noise, np.random.default_rng(J_ss))
    J = float(J_given) if first is None else first.J  # the design inertia: what the user has
    design = o.controller if o.controller is not None else design_pi(J, crossover=o.crossover,
                                                                      phase_margin=o.phase_margin, Tc=Tc)
    adaptive_rows = ["adaptive"] * bool(o.estimator_rows)  # the estimator rows run mode adaptive
    needs_prefit = ((any(m in PREFIT_MODES for m in run_modes + adaptive_rows) or bool(o.compensators))
                    and o.loop.estimator.Vs is None)
    if needs_prefit and not o.prefit:
        wanting = [m for m in run_modes + adaptive_rows if m in PREFIT_MODES]
        raise ParameterError(f"modes {wanting} need Vs and delta: give them "
                             f"(Vs=..., delta=...; --Vs/--delta) or allow the Stribeck pre-fit")
    bar = tqdm(total=len(run_modes) + len(o.estimator_rows) + ("fixed" in run_modes) + needs_prefit, desc="compare",
               disable=(None if progress is None else not progress), leave=False)
    exp = None
    if needs_prefit or o.loop.drive.u_max is None:
        bar.set_postfix_str("quasi-static runs")
        exp = _quasi_static(p0, o, J, peak_w, np.random.default_rng(qs_ss), fit=needs_prefit, noise=noise)
    fit = exp.fit if needs_prefit else None
    Vs, delta = (fit.Vs, fit.delta) if fit is not None else (o.loop.estimator.Vs, o.loop.estimator.delta)
    no_friction = exp is not None and exp.no_friction
    if no_friction and Vs is None:  # placeholders, as the pre-fit's without a Stribeck effect: the lowest speed, 1
        Vs, delta = placeholder_shape(exp.setpoints)
    if needs_prefit:
        bar.update()
    u_max, F_peak = _drive_limit(p0, o, exp, J, peak_a)
    model = RegressionModel(1.0 if Vs is None else Vs, 1.0 if delta is None else delta, lag=True)
    offline = estimate = accepted = None
    notes = list(exp.notes) if fit is not None else []
    if no_friction:
        notes.append(_no_friction_note(exp, run_modes, Vs, o.loop.estimator.Vs is None))
    wants_start = o.adaptive_start and fit is not None and any(m in run_modes + adaptive_rows
                                                               for m in ("adaptive", "adaptive-dob"))
    if no_friction and "fixed" in run_modes:  # nothing to identify: the fixed map is zero friction
        estimate = FrictionEstimate(J=J, tau=0.0, sigma=0.0, Fc=0.0, Fs=0.0, offset=0.0, Vs=Vs, delta=delta,
                                    J_alt=float("nan"))
        bar.update()
    elif "fixed" in run_modes or wants_start:
        bar.set_postfix_str("identification run")
        try:
            offline = _offline_fit(p0, o, model, F_peak, Vs, delta, np.random.default_rng(id_ss), noise)
        except ExcitationError as exc:  # e.g. a short run whose noise torque hardly moves the joint
            why = f"failed ({exc})"
            if wants_start:
                notes.append(f"the identification run could not be fitted ({exc}): the adaptive start takes the "
                             f"loop's own time constant 1/crossover as its lag, at the reference")
        else:
            estimate = accepted = project_estimate(offline.estimate, F_max=0.5 * u_max)
            e = offline.estimate
            why = (f"was rejected (J = {e.J:.4g} kg·m², Fc = {e.Fc:.4g} N·m, Fs = {e.Fs:.4g} N·m, tau = "
                   f"{e.tau:.4g} s; the levels must not exceed {0.5 * u_max:.4g} N·m, half the actuator range, "
                   f"and J > 0)")
        if estimate is None and fit is not None and "fixed" in run_modes:
            estimate, note = _fixed_fallback(why, fit, J, 0.5 * u_max)
            notes.append(note)
        bar.update()
    initial = None
    if o.adaptive_initial and fit is not None:
        initial = FrictionEstimate(J=J, tau=0.0, sigma=max(fit.sigma, 0.0), Fc=max(fit.Fc, 0.0),
                                   Fs=max(fit.Fs, 0.0), offset=0.0, Vs=Vs, delta=delta, J_alt=float("nan"))
    start = _adaptive_start(fit, J, design, accepted, o.loop.feedforward.ff_input) if wants_start else None
    J_n = observer_inertia(J, offline.estimate if offline is not None else None)
    if J_n is not None:
        notes.append(f"the design inertia {J:.4g} kg·m² is {J / J_n:.3g} times the {J_n:.4g} kg·m² of the "
                     f"identification run: the observers (dob, the residual observer and switch-in of adaptive and "
                     f"adaptive-dob, the supervisor) take the identified one; the PI keeps its design")
    stick_band = o.loop.sized_stick_band()  # the loop's one rule: 3 x the configured sensor's noise
    # the feedforward may use at most half the actuator range; friction levels above it are implausible
    sensor = o.loop.sensor
    omega_r = residual_cutoff(J, noise, Tc, friction_level(exp, F_peak), share=residual_share(exp, stick_band),
                              omega_max=observer_max(Tc=Tc, encoder_counts=sensor.encoder_counts,
                                                     velocity=sensor.velocity,
                                                     velocity_bandwidth=sensor.velocity_bandwidth))
    # the shared knobs as given, then what the experiment measured or chose for this joint
    mo = o.loop.replace(Kp=design.Kp, Ki=design.Ki, u_max=u_max, ff_max=0.5 * u_max, J_design=J, Vs=Vs, delta=delta,
                        stick_band=stick_band, model=model, estimate=estimate, initial=initial, start=start,
                        omega_r=omega_r, J_n=J_n)
    ff_input = o.loop.feedforward.ff_input
    opts = {mode: mo.replace(ff_input=o.canudas_input if mode == "canudas" else ff_input) for mode in run_modes}
    rows = {label: mo.replace(ff_input=ff_input, estimator=e) for label, e in o.row_labels.items()}
    return ComparisonSetup(modes=tuple(run_modes), reference=ref, design=design, mode_options=opts,
                           noise_seed=noise_ss, prefit=fit, offline=offline, model=model, experiment=exp,
                           J_design=J, notes=tuple(notes), bar=bar, estimator_rows=rows, inertia=first)


def check_comparison(p, o: CompareOptions) -> None:
    """The checks of :func:`compare` that need no simulation, made before any (a scenario file runs them when it
    is read): the PI design of the crossover and phase margin at ``Tc``, ``Ts`` a multiple of ``Tc``, a velocity
    measurement (its noise, an encoder's quantisation) that resolves the reference, and a given ``u_max`` above
    the plant's friction levels (:func:`check_drive_moves`).

    Parameters
    ----------
    p : plant model
        The true plant (its friction levels against ``o.loop.drive.u_max``, the drive's check of the simulated world).
    o : CompareOptions

    Raises
    ------
    ParameterError
        The message starts with the option's name (``crossover``, ``Ts``, ``encoder_counts``, ``noise_std``) and
        names its value; :class:`DriveLimitError` for ``u_max``.
    """
    p0 = p.at(0.0) if hasattr(p, "at") else p
    ref = comparison_reference(o) if o.reference is None else _checked_reference(o.reference, o)
    _preflight(p0, o, float(np.max(np.abs(ref.w))), measurement_noise(o))


def _preflight(p0, o: CompareOptions, peak_w: float, noise: float) -> None:
    """:func:`check_comparison` on the plant at ``t = 0``, the reference's peak velocity (rad/s) and the
    measurement's noise (rad/s). The PI targets are checked on a unit inertia: with ``sigma = 0`` the loop of
    ``1/(J s)`` scales with ``J`` (the gains do, the margins do not), so they are reachable for every ``J`` or
    none."""
    check_multiple("Ts", o.loop.estimator.Ts, "Tc", o.loop.controller.Tc)
    sensor = o.loop.sensor
    if noise / 2.0 >= 1.2 * peak_w:
        what = (f"encoder_counts = {sensor.encoder_counts!r}: its quantisation makes the measured velocity's noise"
                if sensor.encoder_counts is not None else f"noise_std = {sensor.noise_std!r} rad/s: the measured "
                                                          f"velocity's noise")
        raise ParameterError(f"{what} {noise:.4g} rad/s, more than twice 1.2 times the reference's peak velocity "
                             f"{peak_w:.4g} rad/s: no speed of the reference can be measured")
    if o.loop.drive.u_max is not None:
        check_drive_moves(p0, o.loop.drive.u_max)
    if o.controller is None:
        design_pi(1.0, crossover=o.crossover, phase_margin=o.phase_margin, Tc=o.loop.controller.Tc)


def _first_inertia(p0, o: CompareOptions, peak_w: float, noise: float, rng) -> InertiaExperiment:
    """The design inertia's experiment (:func:`controllers.experiments.first_inertia.inertia_experiment`): the
    ramp to ``1.2*peak_w`` (at least ten times the noise, rad/s), the drive's limit ``o.loop.drive.u_max``, the
    regression's ``Ts`` and ``T_filter`` of ``o``; refused where it gives no positive inertia."""
    u_max, est = o.loop.drive.u_max, o.loop.estimator
    first = inertia_experiment(p0, w_switch=max(1.2 * peak_w, 10.0 * noise), Tc=o.loop.controller.Tc, noise_std=noise,
                               rng=rng, options=InertiaDesign(u_max=math.inf if u_max is None else u_max, Ts=est.Ts,
                                                              T_filter=est.T_filter))
    if not (math.isfinite(first.J) and first.J > 0.0):
        raise ExcitationError(f"the design inertia's experiment gave J = {first.J!r} kg·m² ({first.summary()}); "
                              f"give the design inertia (J_design, --J-design)")
    return first


class DriveLimitError(ParameterError):
    """The plant's friction is above the drive's torque limit: the drive cannot move the joint
    (:func:`check_drive_moves`)."""


def check_drive_moves(p0, u_max: float, *, derived: bool = False) -> None:
    """Refuse a plant whose friction the drive cannot overcome: a level (``Fc``, ``Fs``, or an asymmetric model's
    ``Fc_pos`` ...) above the torque limit ``u_max`` (N·m). Such a joint never moves (or never breaks away), and
    every mode's run would be a run of NaN: refused before any run instead.

    A check of the simulated world, as the engine's own bounds: the levels are read from the plant step's packing
    (:func:`plant.dynamics.plant_params`, what the engine integrates), and the answer only refuses; nothing of it
    reaches a design, an estimator or a compensator.

    Parameters
    ----------
    p0 : plant model
        The plant at ``t = 0``.
    u_max : float
        The drive's torque limit (N·m).
    derived : bool, keyword-only
        ``u_max`` was derived from the quasi-static runs (the message says so), not given.

    Raises
    ------
    DriveLimitError
        Naming the level, its value and ``u_max``.
    """
    par = plant_params(p0)[0]
    pos, neg = par.pos, par.neg
    sides = ((("Fc", "Fs"), pos),) if (pos.Fc, pos.dF) == (neg.Fc, neg.dF) else \
        ((("Fc_pos", "Fs_pos"), pos), (("Fc_neg", "Fs_neg"), neg))
    for (fc, fs), side in sides:
        for name, v in ((fc, float(side.Fc)), (fs, float(side.Fc + side.dF))):
            if v > u_max:
                how = (" (derived from the quasi-static runs: three times the torque they measured plus the "
                       "reference's peak inertial torque)" if derived else "")
                raise DriveLimitError(f"{name} = {v:g} N·m is above u_max = {u_max:.4g} N·m{how}: the drive cannot "
                                      f"move the joint; check the plant's units")


def _no_friction_note(exp: StribeckExperiment, run_modes, Vs: float, placeholders: bool) -> str:
    """The note of a comparison on a joint whose quasi-static runs measured no friction (what each mode does)."""
    what = list(exp.notes)
    if "fixed" in run_modes:
        what.append("fixed feeds forward zero friction (Fc = Fs = sigma = 0)")
    adaptive = [m for m in run_modes if m in ("adaptive", "adaptive-dob")]
    if adaptive:
        shape = f"placeholders Vs = {Vs:.4g} rad/s, delta = 1" if placeholders else "the Vs, delta given"
        what.append(f"{' and '.join(adaptive)} start from zero friction ({shape})")
    return "; ".join(what) + "; eta is undefined where friction does not degrade the loop (0/0)"


def _reference_duration(ref, Tc: float) -> float:
    """Duration ``N*Tc`` (s) of a :class:`plant.excitation.Reference` given to :class:`CompareOptions`, checked:
    1-D finite ``t``, ``w``, ``dw`` of one length ``N >= 2`` and a time step ``Tc`` throughout."""
    arrays = {}
    for k in ("t", "w", "dw"):
        a = getattr(ref, k, None)
        try:
            a = np.asarray(a, dtype=float)
        except (TypeError, ValueError):
            a = None
        if a is None or a.ndim != 1:
            raise ParameterError(f"reference must be a plant.excitation.Reference (1-D arrays t, w, dw), got "
                                 f"{type(ref).__name__} without a 1-D {k!r}")
        bad = np.flatnonzero(~np.isfinite(a))
        if bad.size:
            raise ParameterError(f"reference.{k}[{bad[0]}] = {float(a[bad[0]])!r} is not a finite number")
        arrays[k] = a
    n = arrays["t"].shape[0]
    if n < 2 or arrays["w"].shape[0] != n or arrays["dw"].shape[0] != n:
        raise ParameterError(f"reference: t, w, dw must have one length >= 2, got {n}, {arrays['w'].shape[0]}, "
                             f"{arrays['dw'].shape[0]}")
    step = np.diff(arrays["t"])
    off = np.flatnonzero(~np.isclose(step, Tc, rtol=1e-6, atol=0.0))
    if off.size:
        i = int(off[0])
        raise ParameterError(f"reference: the time step t[{i + 1}] - t[{i}] = {float(step[i])!r} s differs from Tc = "
                             f"{Tc!r} s (resample it: adaptive_ff.io.references.load_reference(dt=Tc))")
    return n * Tc


def measurement_noise(o: CompareOptions) -> float:
    """Standard deviation (rad/s) of the loop's velocity measurement error that the design assumes: that of the
    loop's configured sensor, :meth:`controllers.simulation.loop_config.LoopConfig.velocity_noise`.

    """
    return o.loop.velocity_noise()


def _checked_reference(ref, o: CompareOptions):
    """``ref`` if it is on the grid of ``o`` (step ``Tc``, length ``duration``); raise otherwise."""
    t = np.asarray(getattr(ref, "t", None), dtype=float)
    if t.ndim != 1 or t.shape[0] < 2 or not np.isclose(t[1] - t[0], o.loop.controller.Tc, rtol=1e-9) \
            or not np.isclose(t[-1] - t[0], o.duration, rtol=1e-9, atol=o.loop.controller.Tc):
        raise ParameterError(f"reference must be comparison_reference(options): step Tc = {o.loop.controller.Tc!r} s "
                             f"over duration = {o.duration!r} s")
    return ref


def _fixed_fallback(why: str, fit, J: float, F_max: float) -> tuple:
    """The ``fixed`` mode's estimate when its offline fit is rejected or failed (``why``, the note's words): the
    pre-fit's static map (eq. 3) without a lag (``tau = 0``), or its Coulomb + viscous part (``Fs = Fc``, the
    lower level) if a level of the map exceeds ``F_max`` too; ``(estimate or None, note)``.

    No lag: the lag would come from the rejected fit, and a guessed one (the adaptive start's ``1/crossover``)
    did much worse than none on the zoo joints where this happens (docs/benchmarks/zoo.md).
    """
    levels = (max(fit.Fc, 0.0), max(fit.Fs, 0.0))
    what = "the pre-fit's levels exceed it too: fixed has no estimate"
    est = None
    for (Fc, Fs), name in ((levels, "the pre-fit's static map"), ((min(levels),) * 2, "the Coulomb + viscous "
                                                                   "part of the pre-fit's map (Fs = Fc)")):
        est = project_estimate(FrictionEstimate(J=J, tau=0.0, sigma=max(fit.sigma, 0.0), Fc=Fc, Fs=Fs, offset=0.0,
                                                Vs=fit.Vs, delta=fit.delta, J_alt=float("nan")), F_max=F_max)
        if est is not None:
            what = f"{name} is used instead"
            break
    note = (f"fixed: the offline fit of the identification run {why}; {what} (Fc = {levels[0]:.4g} N·m, "
            f"Fs = {levels[1]:.4g} N·m, Vs = {fit.Vs:.4g} rad/s, delta = {fit.delta:.4g}, sigma = "
            f"{max(fit.sigma, 0.0):.4g} N·m·s/rad, no lag)")
    return est, note


def _adaptive_start(fit, J: float, design: PIDesign, identified: FrictionEstimate | None,
                    ff_input: str) -> FeedforwardStart:
    """The provisional start of the adaptive feedforward: the pre-fit's static map (eq. 3) through a lag.

    The lag is the one identified in the identification run (``identified``, the projected offline fit of
    :func:`_offline_fit`, Sec. IV-A), and the map is then evaluated as the feedforward's ``ff_input`` says (the
    same structure as after the hand-over). Without an accepted fit the lag is unknown: ``1/crossover`` (the
    loop's own time constant) at the reference, where a wrong lag cannot form a stick-slip cycle with the joint
    (:class:`adaptive_ff.compensation.adaptive_feedforward.FeedforwardStart`).
    """
    if identified is not None:
        tau, where = identified.tau, ff_input
    else:
        tau, where = 1.0 / design.crossover, "reference"
    return FeedforwardStart(FrictionEstimate(J=J, tau=tau, sigma=max(fit.sigma, 0.0), Fc=max(fit.Fc, 0.0),
                                             Fs=max(fit.Fs, 0.0), offset=0.0, Vs=fit.Vs, delta=fit.delta,
                                             J_alt=float("nan")), ff_input=where)


def _quasi_static(p0, o: CompareOptions, J: float, peak_w: float, rng, *, fit: bool,
                  noise: float) -> StribeckExperiment:
    """The quasi-static runs of :func:`compare`: designed from the joint's response; coarse only without a fit.
    ``noise``: the velocity noise (rad/s) of the runs' measurement (:func:`measurement_noise`)."""
    return stribeck_experiment(p0, J_design=J, noise_std=noise, Tc=o.loop.controller.Tc, rng=rng,
                               options=StribeckDesign(w_max=1.2 * peak_w), fit=fit)


def _offline_fit(p0, o: CompareOptions, model, F_peak, Vs, delta, id_rng, noise: float):
    """The paper's Sec. IV-A identification experiment (open loop, band-limited noise torque), fitted.

    The torque's standard deviation is ``1.2*F_peak``, the measured friction level (no plant field is read);
    the velocity is measured with white noise of ``noise`` (rad/s, :func:`measurement_noise`: an encoder's
    quantisation taken as white noise of its level).
    """
    _, u_id = bandlimited_noise(o.duration, dt=o.loop.controller.Tc, cutoff=1.0, std=1.2 * F_peak, rng=id_rng)
    resp = simulate(p0, u_id, dt=o.loop.controller.Tc)
    if o.fixed_method == "sliding":
        n = u_id.shape[0]
        w_id = resp.w[:-1] + id_rng.normal(0.0, noise, size=n) if noise > 0 else resp.w[:-1]
        return fit_sliding(u_id, w_id, Tc=o.loop.controller.Tc, Vs=Vs, delta=delta,
                           config=SlidingFrictionEstimatorConfig(Ts=o.loop.estimator.Ts, lag=o.loop.feedforward.lag,
                                                                 T_filter=o.loop.estimator.T_filter))
    meas = sample(resp, Ts=o.loop.estimator.Ts, noise_std=noise, rng=id_rng)
    return fit_ls(model, meas.u, meas.w, Ts=o.loop.estimator.Ts)
