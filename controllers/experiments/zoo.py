"""A plant zoo: random joints from a log-uniform box, every compensation mode on each, on the batch engine.

:func:`draw_plants` is the one drawing code (``benchmarks/zoo.py`` and the
``random_plants`` spec of ``adaptive-ff sweep`` use it). A joint is drawn as a
JSON-ready dict of :func:`plant.models.plant_from_dict` (model, parameters,
optional drift) from the box of :class:`ZooBox` (docs/benchmarks/zoo.md):

- ``J`` log-uniform in 0.01-50 kg·m²;
- the friction at the reference's peak speed is a share (uniform 5-60 %) of the
  peak torque the reference demands, ``J*max|dw_ref/dt| + F_peak``; of it a
  viscous share (uniform 0-30 %) is ``sigma*max|w_ref|``; ``Fc`` follows;
- ``Fs/Fc`` uniform in 1-4, ``Vs`` log-uniform in 1e-3-0.1 rad/s;
- ``delta`` uniform in -1...2.5 with ``|delta| >= 0.05``. **delta < 0** turns
  eq. 3 around: ``exp(-|w/Vs|**delta)`` is 0 at standstill and tends to 1 at
  high speed, so the friction *rises* from ``Fc`` at standstill towards ``Fs``
  (no stiction peak; ``Fs`` is a high-speed level). The paper allows both signs
  (Sec. II-B); the zoo draws them and reports them apart (``delta < 0`` rows);
- lag ``tau``: 0 with probability ``p_static``, else log-uniform in 1e-3-0.1 s
  (LuGre has no lag: its pre-sliding deflection ``Fc/sigma0`` is log-uniform
  in 1e-6-1e-3 rad, ``sigma1 = zeta*2*sqrt(sigma0*J)`` with the bristle damping
  ratio ``zeta`` uniform in 0.1-2 (lightly damped up to twice critical damping),
  ``sigma2 = sigma``; Karnopp's stick band ``dv`` is 5-50 % of ``Vs``; the
  asymmetric model scales the negative direction's levels by 0.6-1.4);
- models drawn evenly from the four of :mod:`plant.models`; with probability
  ``p_drift`` a :class:`plant.drift.FrictionDrift` ramps ``Fc`` and ``Fs`` by
  -30...+60 % over the first half of the run, in :data:`DRIFT_STEPS` steps (a
  slow thermal drift: at most 1 % of the level per step; the engine's plant
  table then has ``2*DRIFT_STEPS`` rows instead of one per 10 ms).

:func:`run_zoo` prepares every joint as :func:`controllers.experiments.compare.compare`
does (its :func:`~controllers.experiments.compare.prepare_comparison`: the PI from
the design inertia, the Stribeck pre-fit from simulated quasi-static runs and the
offline fit of ``fixed`` from a simulated identification run, or the pre-fit's
static map where that fit is rejected; never the true friction), then runs each
mode on the joint's group with :func:`controllers.simulation.batch.run_batch`
(groups of ``group`` joints on ``workers`` processes, or Dask), and reports ``eta``
(second half) per joint and mode. Every (joint, mode) has one outcome
(:data:`STATUSES`, :meth:`ZooResult.status`), counted apart in the table:

- ``refused``: the preparation or the engine refused the joint (no mode ran), or
  this mode could not be built for it, with the reason (``fixed`` is not refused
  when its offline fit is rejected: it falls back to the pre-fit's static map,
  :meth:`ZooResult.fixed_fallbacks`);
- ``diverged``: the run left the engine's velocity bound;
- ``undefined``: friction does not measurably degrade the uncompensated loop
  (its second-half RMS error is within ``min_degradation`` of the frictionless
  loop's), so eta, a ratio over that difference, is undefined (``None`` in
  JSON). On a short run whose second half has no reversal the PI integrator
  absorbs the friction and all modes track alike: a 6 s run gave "eta" 5.1
  from a 0.7 % difference;
- ``no reference``: the ``none`` or ``frictionless`` run of the joint is missing;
- ``invalid``: a non-finite number from a run that neither diverged nor was
  refused (a defect; none is expected);
- ``ok``: eta is defined; the quantiles and win rates use these only.
"""

from __future__ import annotations

import functools
import math
import os
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path

import numpy as np

from controllers.experiments.compare import (WORSE_THAN_NONE, CompareOptions, compensator_context,
                                             comparison_reference, eta, prepare_comparison)
from controllers.experiments.scenario import compensator_factories
from controllers.simulation.batch import run_batch
from controllers.simulation.memory import PREPARATION_SIGNALS, SHARED_SIGNALS, check_run_memory
from controllers.simulation.closed_loop import plant_table, run_own
from controllers.simulation.compensators import MODES, build_mode
from plant.errors import ParameterError, check_nonnegative, check_optional_number, known_fields
from plant.models import plant_from_dict
from plant.results import json_safe
from plant.stribeck_map import stribeck

__all__ = ["DRIFT_STEPS", "STATUSES", "WORSE_THAN_NONE", "PER_JOINT", "ZooBox", "ZooOptions", "ZooResult",
           "ZOO_MODELS", "draw_plants", "run_zoo", "zoo_box", "zoo_options_dict"]

#: Plant models the zoo draws from.
ZOO_MODELS = ("lagged-stribeck", "lugre", "karnopp", "asymmetric")
#: Steps of a drifting joint's ramp (its :attr:`plant.drift.FrictionDrift.period` is the ramp length over this).
DRIFT_STEPS = 60


def _pair(name: str, v, lo: float = -math.inf) -> tuple:
    try:
        a, b = (float(x) for x in v)
    except (TypeError, ValueError):
        raise ParameterError(f"box {name} must be a pair [low, high], got {v!r}") from None
    if not (math.isfinite(a) and math.isfinite(b) and lo <= a <= b):
        raise ParameterError(f"box {name} must be finite with {lo:g} <= low <= high, got {v!r}")
    return a, b


@dataclass(frozen=True)
class ZooBox:
    """The box joints are drawn from (keyword-only; SI units; pairs are ``(low, high)``; see the module docstring).

    Parameters
    ----------
    J, Vs, tau, presliding : pair of float
        Log-uniform ranges: inertia (kg·m²), Stribeck velocity (rad/s), lag (s), LuGre ``Fc/sigma0`` (rad).
    friction_share, viscous_share, Fs_ratio, delta, lugre_zeta, karnopp_dv, asymmetry, drift_change : pair of float
        Uniform ranges: friction at peak speed over the peak torque demand, viscous part of it, ``Fs/Fc``, shape
        factor, LuGre bristle damping ratio ``sigma1/(2*sqrt(sigma0*J))`` (1: critical), Karnopp ``dv/Vs``,
        negative-direction level factor, relative drift.
    p_static, p_drift : float
        Probabilities of ``tau = 0`` and of a drifting joint, in [0, 1].
    models : tuple of str
        Models drawn evenly (subset of :data:`ZOO_MODELS`).

    Raises
    ------
    ParameterError
        A range or probability out of bounds, an unknown model.
    """

    J: tuple = (0.01, 50.0)
    friction_share: tuple = (0.05, 0.6)
    viscous_share: tuple = (0.0, 0.3)
    Fs_ratio: tuple = (1.0, 4.0)
    Vs: tuple = (1e-3, 0.1)
    delta: tuple = (-1.0, 2.5)
    tau: tuple = (1e-3, 0.1)
    p_static: float = 0.1
    presliding: tuple = (1e-6, 1e-3)
    lugre_zeta: tuple = (0.1, 2.0)
    karnopp_dv: tuple = (0.05, 0.5)
    asymmetry: tuple = (0.6, 1.4)
    p_drift: float = 0.5
    drift_change: tuple = (-0.3, 0.6)
    models: tuple = ZOO_MODELS

    def __post_init__(self):
        for name in ("J", "Vs", "tau", "presliding"):
            object.__setattr__(self, name, _pair(name, getattr(self, name), lo=1e-300))
        for name in ("friction_share", "viscous_share", "Fs_ratio", "delta", "lugre_zeta", "karnopp_dv",
                     "asymmetry", "drift_change"):
            object.__setattr__(self, name, _pair(name, getattr(self, name)))
        if not (0.0 < self.friction_share[0] and self.friction_share[1] < 1.0):
            raise ParameterError(f"box friction_share must lie in (0, 1), got {self.friction_share!r}")
        if not (0.0 <= self.viscous_share[0] and self.viscous_share[1] < 1.0):
            raise ParameterError(f"box viscous_share must lie in [0, 1), got {self.viscous_share!r}")
        if not (self.Fs_ratio[0] > 0 and self.asymmetry[0] > 0 and self.karnopp_dv[0] > 0 and self.lugre_zeta[0] >= 0
                and self.drift_change[0] > -1.0):
            raise ParameterError("box Fs_ratio, asymmetry, karnopp_dv must be > 0, lugre_zeta >= 0, "
                                 "drift_change > -1")
        for name in ("p_static", "p_drift"):
            v = float(getattr(self, name))
            if not 0.0 <= v <= 1.0:
                raise ParameterError(f"box {name} must lie in [0, 1], got {v!r}")
            object.__setattr__(self, name, v)
        models = tuple(self.models)
        bad = [m for m in models if m not in ZOO_MODELS]
        if not models or bad:
            raise ParameterError(f"box models must be a non-empty subset of {list(ZOO_MODELS)}, got {list(models)}")
        object.__setattr__(self, "models", models)


def zoo_box(d: dict | None = None) -> ZooBox:
    """A :class:`ZooBox` from a mapping of its fields (a sweep spec's ``box``); unknown keys are refused.

    Raises
    ------
    ParameterError
        Unknown key or a value out of range.
    """
    d = dict(d or {})
    known = set(ZooBox.__dataclass_fields__)
    unknown = sorted(set(d) - known)
    if unknown:
        raise ParameterError(f"unknown zoo box key(s) {unknown}; allowed {sorted(known)}")
    return ZooBox(**d)


def _log_uniform(rng, pair) -> float:
    return float(math.exp(rng.uniform(math.log(pair[0]), math.log(pair[1]))))


def _draw_one(rng, box: ZooBox, peak_w: float, peak_a: float, duration: float) -> dict:
    model = box.models[int(rng.integers(len(box.models)))]
    J = _log_uniform(rng, box.J)
    share = rng.uniform(*box.friction_share)
    F_peak = share / (1.0 - share) * J * peak_a  # friction at peak speed = share of (J*accel + friction)
    visc = rng.uniform(*box.viscous_share)
    ratio = rng.uniform(*box.Fs_ratio)
    Vs = _log_uniform(rng, box.Vs)
    delta = 0.0
    while abs(delta) < 0.05:
        delta = float(rng.uniform(*box.delta))
    # eq. 3 at the peak speed per unit Fc (sigma = 0): Fc*(1 + (ratio - 1)*exp(-(peak_w/Vs)**delta))
    unit = float(stribeck(peak_w, Fc=1.0, Fs=ratio, Vs=Vs, delta=delta, sigma=0.0))
    Fc = (1.0 - visc) * F_peak / unit
    sigma = visc * F_peak / peak_w
    tau = 0.0 if rng.uniform() < box.p_static else _log_uniform(rng, box.tau)
    d = {"model": model, "J": J, "Fc": Fc, "Fs": ratio * Fc, "Vs": Vs, "delta": delta}
    if model == "lugre":
        sigma0 = Fc / _log_uniform(rng, box.presliding)
        d.update(sigma0=sigma0, sigma1=rng.uniform(*box.lugre_zeta) * 2.0 * math.sqrt(sigma0 * J), sigma2=sigma)
    elif model == "asymmetric":
        k = rng.uniform(*box.asymmetry)
        d = {"model": model, "J": J, "Fc_pos": Fc, "Fc_neg": k * Fc, "Fs_pos": ratio * Fc, "Fs_neg": k * ratio * Fc,
             "Vs": Vs, "delta": delta, "sigma_pos": sigma, "sigma_neg": k * sigma, "tau": tau}
    else:
        d.update(sigma=sigma, tau=tau)
        if model == "karnopp":
            d["dv"] = rng.uniform(*box.karnopp_dv) * Vs
    if rng.uniform() < box.p_drift:
        ch = rng.uniform(*box.drift_change)
        # the ramp in DRIFT_STEPS steps (1 s apart on a 120 s run): a table of 2*DRIFT_STEPS plant rows
        d["drift"] = {"Fc_change": ch, "Fs_change": ch, "t_start": 0.0, "t_end": 0.5 * duration,
                      "period": 0.5 * duration / DRIFT_STEPS}
    return {k: (float(v) if isinstance(v, (float, np.floating)) else v) for k, v in d.items()}


def draw_plants(n: int, reference, *, seed: int = 0, box: ZooBox | None = None) -> list:
    """Draw ``n`` joints from ``box`` scaled to the torque ``reference`` demands (module docstring).

    Parameters
    ----------
    n : int
        Number of joints, >= 1.
    reference : Reference
        The velocity reference of the runs (its peak speed and acceleration set the friction scale).
    seed : int, keyword-only
        Seed of the draw.
    box : ZooBox, keyword-only
        Default ``ZooBox()``.

    Returns
    -------
    list of dict
        Specs for :func:`plant.models.plant_from_dict` (JSON-ready; a drifting joint has a ``drift`` key).

    Raises
    ------
    ParameterError
        ``n`` < 1 or a reference without motion.
    """
    if isinstance(n, bool) or int(n) != n or n < 1:
        raise ParameterError(f"n must be an integer >= 1, got {n!r}")
    box = ZooBox() if box is None else box
    peak_w = float(np.max(np.abs(reference.w)))
    peak_a = float(np.max(np.abs(reference.dw)))
    if not (peak_w > 0 and peak_a > 0):
        raise ParameterError("reference must move (peak speed and acceleration > 0)")
    duration = float(reference.t[-1] - reference.t[0])
    rng = np.random.default_rng(seed)
    return [_draw_one(rng, box, peak_w, peak_a, duration) for _ in range(int(n))]


#: The settings of every joint's comparison the zoo never takes from :attr:`ZooOptions.compare`: they belong to one
#: plant (its torque limit, design inertia, PI and own compensators are each joint's,
#: :meth:`ZooOptions.compare_options`).
PER_JOINT = {"u_max": None, "J_design": None, "controller": None, "compensators": None}


@known_fields(hint="; a comparison's setting (duration, seed, ...) goes in compare=CompareOptions(...) or "
                   "ZooOptions.from_flat(...)")
@dataclass(frozen=True)
class ZooOptions:
    """Settings of :func:`run_zoo` (keyword-only, validated): the zoo's own and the comparison every joint is placed
    into (:attr:`compare`, a :class:`controllers.experiments.compare.CompareOptions`, which holds and checks the
    duration, seed, modes, reference, sensor, drive and estimator settings).

    :meth:`from_flat` takes both as flat keywords (``ZooOptions.from_flat(n=20, duration=30.0, estimator="eq4")``:
    a setting of the comparison by its name of :meth:`CompareOptions.from_flat`).

    Parameters
    ----------
    n : int
        Number of joints.
    compare : CompareOptions
        The comparison of every joint (default ``CompareOptions()``, ``compare``'s defaults), e.g. a scenario file's
        (:attr:`controllers.experiments.scenario.Scenario.options`): its duration, seed (of the draw and of every
        run: reference, noise, experiments as in ``compare``), modes (``none`` and ``frictionless`` always, in the
        registry's order), reference (which sets the duration and the draw's peak speed and acceleration), sensor
        (encoder, velocity, delay, noise), drive slew rate, step, controller design targets and estimator settings
        are every joint's. Its settings of one plant (:data:`PER_JOINT`) are not: the torque limit is each joint's
        ``compare`` default (three times its measured friction level plus its design inertia times the reference's
        peak acceleration), the design inertia is identified on each joint or comes from ``J_design_factor``, each
        joint's PI is designed on its own design inertia with the targets, own compensators come from
        ``compensators``.
    box : ZooBox
    group : int
        Joints per task: a task prepares its joints and runs every mode on them, one batch call per mode
        (memory ~ ``group * duration/Tc * 8`` bytes of noise). Default 8: small tasks keep the workers
        evenly loaded, and a batch of 8 still lets the engine interleave its scenarios.
    workers : int or None
        Processes the tasks run on (one engine thread each); default all cores.
    scheduler : str, distributed.Client or None
        Where the preparation and the batches run instead: ``"synchronous"``, ``"threads"`` or ``"processes"``
        (Dask's local schedulers), or the address of a Dask cluster (``tcp://host:8786``) or a
        ``distributed.Client``. Needs dask.
    min_degradation : float
        eta of a joint is *undefined* (``None`` in JSON) where friction raises the second-half RMS error of the
        uncompensated loop by less than this share of the frictionless loop's, ``rms_none < (1 +
        min_degradation) * rms_frictionless``: the denominator of eta is then within the loop's own tracking
        error and the ratio is meaningless (a 6 s run without a reversal in its second half gives "eta" 5.1).
        Default 0.01; >= 0 (0: undefined only where friction does not degrade the loop at all, as
        :func:`controllers.experiments.compare.eta`).
    compensators : dict or None
        Your own compensators beside the modes, by import path (picklable, resolved in every worker):
        ``{name: "module:factory"}`` or ``{name: {"factory": "path/file.py:factory", **keywords}}`` as the
        ``[compensators]`` of a scenario file (:func:`controllers.experiments.scenario.compensator_factories`;
        a relative file is relative to the working folder). Each runs on every joint with ``compare``'s context
        (:func:`controllers.experiments.compare.compensator_context`) and the joint's noise, one run per joint
        through the Python protocol (about ten times the engine's time per step), and appears among the modes.
    J_design_factor : float or None
        Default None: every joint's design inertia (``loop.controller.J_design``: the PI design, the estimators'
        start, the gates, the observers' nominal inertia) is identified on it, ``compare``'s default
        (:func:`controllers.experiments.first_inertia.inertia_experiment`). A factor (finite, > 0) makes it that
        factor times the joint's true ``J`` instead: a data sheet off by that factor (1: an exact one), a benchmark
        of what a wrong or a perfect design inertia does, never what a user has.
    export : str or None
        An ``adaptive-ff export-c`` folder: mode ``adaptive`` runs on every joint through its code, compiled in
        each worker (:class:`controllers.simulation.exported.ExportedLibrary`: the drive's library, input guard
        included, configured with each joint's settings by its own ``aff_init``) instead of the package's module;
        default None. Needs a C compiler where the workers run.

    Raises
    ------
    ParameterError
        Values out of range, an unknown mode or a setting the comparison refuses (:class:`CompareOptions`' check).
    """

    n: int = 100
    compare: CompareOptions = field(default_factory=CompareOptions)
    box: ZooBox = field(default_factory=ZooBox)
    group: int = 8
    workers: int | None = None
    scheduler: object = None
    min_degradation: float = 0.01
    compensators: dict | None = None
    J_design_factor: float | None = None
    export: str | None = None

    def __post_init__(self):
        if self.export is not None:
            missing = [f for f in ("aff.h", "aff.c", "aff_config.h", "aff_config.c")
                       if not (Path(self.export) / f).is_file()]
            if missing:
                raise ParameterError(f"export: {self.export} is not an export-c folder (missing {', '.join(missing)})")
            object.__setattr__(self, "export", str(self.export))
        if not isinstance(self.compare, CompareOptions):
            raise ParameterError(f"compare must be a CompareOptions (e.g. a scenario's options), got "
                                 f"{type(self.compare).__name__}")
        for name in ("n", "group"):
            v = getattr(self, name)
            if isinstance(v, bool) or int(v) != v or v < 1:
                raise ParameterError(f"{name} must be an integer >= 1, got {v!r}")
        modes = tuple(m for m in MODES if m in set(self.compare.modes) | {"none", "frictionless"})
        if modes != self.compare.modes:
            object.__setattr__(self, "compare", self.compare.replace(modes=modes))
        self.compare_options()  # every joint's comparison: checked once, by CompareOptions (memory included)
        if self.compensators:
            compensator_factories(self.compensators, source="ZooOptions.compensators")  # importable, named well
        if self.workers is not None and (int(self.workers) != self.workers or self.workers < 1):
            raise ParameterError(f"workers must be an integer >= 1, got {self.workers!r}")
        object.__setattr__(self, "min_degradation", check_nonnegative("min_degradation", self.min_degradation))
        object.__setattr__(self, "J_design_factor", check_optional_number("J_design_factor", self.J_design_factor,
                                                                          low=0.0, strict=True))

    @classmethod
    def from_flat(cls, *, compare: CompareOptions | None = None, **knobs) -> "ZooOptions":
        """The options of flat keywords: this class's own fields by name, the comparison's settings by their names
        of :meth:`CompareOptions.from_flat` changed on ``compare`` (default ``CompareOptions()``).

        Raises
        ------
        ParameterError
            A keyword that is neither (named), or a value a check refuses.
        """
        own_names = {f.name for f in fields(cls)}
        own = {k: v for k, v in knobs.items() if k in own_names}
        flat = {k: v for k, v in knobs.items() if k not in own_names}
        if compare is None:
            return cls(**own, compare=CompareOptions.from_flat(**flat))
        return cls(**own, compare=compare.replace(**flat) if flat else compare)

    @property
    def duration(self) -> float:
        """Run length (s) of every joint, :attr:`compare`'s."""
        return self.compare.duration

    @property
    def seed(self) -> int:
        """Seed of the draw and of every run, :attr:`compare`'s."""
        return self.compare.seed

    @property
    def modes(self) -> tuple:
        """Modes run on every joint (``none`` and ``frictionless`` among them, the registry's order)."""
        return self.compare.modes

    @property
    def reference(self):
        """Velocity reference of every run (:attr:`compare`'s; None: the comparison's multisine)."""
        return self.compare.reference

    def compare_options(self) -> CompareOptions:
        """The :class:`controllers.experiments.compare.CompareOptions` every joint is prepared and run with:
        :attr:`compare` without the settings of one plant (:data:`PER_JOINT`: no torque limit, design inertia, given
        PI or own compensators; the design inertia is identified on each joint or set from ``J_design_factor``)."""
        return self.compare.replace(**PER_JOINT)


#: Outcome of one (joint, mode), :meth:`ZooResult.status`.
STATUSES = ("ok", "refused", "diverged", "undefined", "no reference", "invalid")


@dataclass(frozen=True)
class ZooResult:
    """Outcome of :func:`run_zoo`.

    Attributes
    ----------
    plants : list of dict
        The drawn joints (:func:`draw_plants`).
    modes : tuple of str
    eta : dict
        ``{mode: ndarray (n,)}``: eta over the second half where it is defined (:meth:`status` ``"ok"``), NaN
        elsewhere.
    rms : dict
        ``{mode: ndarray (n,)}``: second-half RMS velocity error (rad/s); NaN where the run was refused or
        diverged.
    refused : dict
        ``{index: reason}`` of joints the preparation or the engine refused (no mode ran).
    mode_refused : dict
        ``{mode: {index: reason}}``: a mode that could not be built for a joint the others ran on (e.g. the
        offline fit of ``fixed`` rejected as implausible).
    diverged : dict
        ``{mode: ndarray of bool (n,)}``.
    min_degradation : float
        The threshold of an undefined eta (:class:`ZooOptions`).
    seconds : float
        Wall time (s).
    timing : dict
        CPU time (s) summed over the workers: the preparation (``"prepare_cpu"``) and the runs of every mode
        (``"runs_cpu"``).
    notes : dict
        ``{index: [note, ...]}``: what the preparation of a joint could not do as asked (e.g. the pre-fit's
        Coulomb + viscous fallback, or the ``fixed`` mode's fallback to the pre-fit's static map), as
        :attr:`controllers.experiments.compare.Comparison.notes`.
    max_error : dict
        ``{mode: ndarray (n,)}``: the largest |velocity error| over the second half (rad/s, as eta and ``compare``'s
        max column); NaN where the run was refused or diverged.
    """

    plants: list
    modes: tuple
    eta: dict
    rms: dict
    refused: dict
    mode_refused: dict
    diverged: dict
    min_degradation: float
    seconds: float
    timing: dict = field(default_factory=dict)
    notes: dict = field(default_factory=dict)
    max_error: dict = field(default_factory=dict)

    def degradation(self) -> np.ndarray:
        """``rms_none / rms_frictionless - 1`` per joint (second half), shape (n,): how much friction degrades the
        uncompensated loop; NaN where a reference run is missing."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return self.rms["none"] / self.rms["frictionless"] - 1.0

    def undefined(self) -> np.ndarray:
        """Joints whose eta is undefined (friction degrades the loop by less than ``min_degradation``), (n,)."""
        d = self.degradation()
        return np.isfinite(d) & (d < self.min_degradation)

    def status(self, mode: str) -> np.ndarray:
        """Outcome per joint of ``mode`` (:data:`STATUSES`), shape (n,) of str.

        ``refused``: the joint or this mode was refused; ``diverged``: this run diverged; ``no reference``: the
        ``none`` or ``frictionless`` run is missing (refused or diverged); ``undefined``: friction does not degrade
        the loop (:meth:`undefined`); ``invalid``: a non-finite number from a run that neither diverged nor was
        refused (a defect; expected never); ``ok``: eta is defined.
        """
        n = len(self.plants)
        out = np.full(n, "ok", dtype=object)
        ref_ok = np.isfinite(self.rms["none"]) & np.isfinite(self.rms["frictionless"])
        bad = ~np.isfinite(self.rms[mode])
        out[self.undefined()] = "undefined"
        out[~ref_ok] = "no reference"
        out[bad] = "invalid"
        out[self.diverged[mode]] = "diverged"
        out[[i for i in range(n) if i in self.refused or i in self.mode_refused.get(mode, {})]] = "refused"
        out[(out == "ok") & ~np.isfinite(self.eta[mode])] = "invalid"
        return out.astype(str)

    def counts(self) -> dict:
        """``{mode: {status: number of joints}}`` (:data:`STATUSES`)."""
        return {m: {s: int(np.count_nonzero(self.status(m) == s)) for s in STATUSES} for m in self.modes}

    def worse_than_none(self, threshold: float = WORSE_THAN_NONE) -> dict:
        """``{mode: number of joints}`` whose eta is defined and below ``threshold`` (default
        :data:`WORSE_THAN_NONE`, -0.02): the compensation made the loop worse than no compensation."""
        return {m: int(np.count_nonzero(np.isfinite(self.eta[m]) & (self.eta[m] < threshold))) for m in self.modes}

    def fixed_fallbacks(self) -> list:
        """Joints where the offline fit of ``fixed`` was rejected and the pre-fit's static map used instead (a
        ``"fixed:"`` note, :func:`controllers.experiments.compare.prepare_comparison`), ascending."""
        return sorted(i for i, nts in self.notes.items() if any(n.startswith("fixed:") for n in nts))

    def adaptive_modes(self) -> tuple:
        """The modes named ``adaptive*`` (the adaptive friction feedforward and its composites)."""
        return tuple(m for m in self.modes if m.startswith("adaptive"))

    def tracking_harm(self) -> dict:
        """``{adaptive mode: [index, ...]}``: joints where the mode's largest velocity error exceeds the larger of
        ``none``'s and twice ``frictionless``'s (second halves, :attr:`max_error`; joints where one is missing are
        not judged): the compensation made a tracking error the loop would not make without it."""
        if not self.max_error:
            return {}
        bound = np.fmax(self.max_error["none"], 2.0 * self.max_error["frictionless"])
        with np.errstate(invalid="ignore"):
            return {m: [int(i) for i in np.flatnonzero(self.max_error[m] > bound)] for m in self.adaptive_modes()}

    def quantiles(self, q=(0.05, 0.25, 0.5, 0.75, 0.95)) -> dict:
        """``{mode: [min, quantiles..., max]}`` of eta over the joints where it is defined (the others are
        counted by :meth:`counts`); NaN where none is."""
        out = {}
        for m in self.modes:
            e = self.eta[m][np.isfinite(self.eta[m])]
            out[m] = [float(np.min(e))] + [float(v) for v in np.quantile(e, q)] + [float(np.max(e))] if e.size \
                else [math.nan] * (len(q) + 2)
        return out

    def best_adaptive(self) -> np.ndarray:
        """eta of the best adaptive mode per joint (NaN where none is defined), shape (n,)."""
        a = [self.eta[m] for m in self.adaptive_modes()]
        if not a:
            return np.full(len(self.plants), math.nan)
        st = np.vstack(a)
        ok = np.isfinite(st).any(axis=0)
        out = np.full(st.shape[1], math.nan)
        out[ok] = np.nanmax(st[:, ok], axis=0)
        return out

    def win_rates(self) -> dict:
        """``{adaptive mode or "best adaptive": {rival: share of joints with eta >= rival's}}`` (joints where
        both are defined)."""
        rows = {m: self.eta[m] for m in self.adaptive_modes()}
        if rows:
            rows["best adaptive"] = self.best_adaptive()
        out = {}
        for name, e in rows.items():
            out[name] = {}
            for rival in ("fixed", "dob", "canudas"):
                if rival in self.eta:
                    both = np.isfinite(e) & np.isfinite(self.eta[rival])
                    out[name][rival] = float(np.mean(e[both] >= self.eta[rival][both])) if both.any() else math.nan
        return out

    def targets(self) -> dict:
        """The zoo's targets and the joints that miss them.

        The targets (docs/benchmarks/zoo.md): no (joint, mode) run refused or diverged; the best adaptive eta > 0 on
        every joint with a defined eta; the best adaptive eta >= the DOB's on at least 95 % of the joints where both
        are defined.

        Returns
        -------
        dict
            ``refused``/``diverged``: numbers of (joint, mode) runs; ``best_positive``: share of the joints with a
            defined best-adaptive eta where it is > 0, and ``best_not_positive`` their indices;
            ``best_ge_dob``: share where the best adaptive eta >= the DOB's (both defined), ``best_below_dob``
            the indices; ``undefined``: joints without a defined eta; ``tracking_harm``: :meth:`tracking_harm`
            (target: none).
        """
        best = self.best_adaptive()
        fin = np.isfinite(best)
        out = {"refused": len(self.refused) * len(self.modes) + sum(len(v) for v in self.mode_refused.values()),
               "diverged": int(sum(np.count_nonzero(v) for v in self.diverged.values())),
               "undefined": [int(i) for i in np.flatnonzero(self.undefined())],
               "best_positive": float(np.mean(best[fin] > 0)) if fin.any() else math.nan,
               "best_not_positive": [int(i) for i in np.flatnonzero(fin & ~(best > 0))],
               "tracking_harm": self.tracking_harm()}
        if "dob" in self.eta:
            both = fin & np.isfinite(self.eta["dob"])
            out["best_ge_dob"] = float(np.mean(best[both] >= self.eta["dob"][both])) if both.any() else math.nan
            out["best_below_dob"] = [int(i) for i in np.flatnonzero(both & (best < self.eta["dob"]))]
        return out

    def to_dict(self) -> dict:
        """Plants, eta and status per mode, failures, quantiles, win rates and targets (strict JSON: NaN -> None;
        an undefined eta is None, its status says why)."""
        return json_safe({"plants": self.plants, "modes": list(self.modes),
                          "eta": {m: v.tolist() for m, v in self.eta.items()},
                          "rms_second_half": {m: v.tolist() for m, v in self.rms.items()},
                          "max_error": {m: v.tolist() for m, v in self.max_error.items()},
                          "status": {m: self.status(m).tolist() for m in self.modes}, "counts": self.counts(),
                          "worse_than_none": self.worse_than_none(),
                          "refused": {str(k): v for k, v in self.refused.items()},
                          "mode_refused": {m: {str(k): v for k, v in d.items()} for m, d in self.mode_refused.items()},
                          "diverged": {m: [bool(x) for x in v] for m, v in self.diverged.items()},
                          "min_degradation": self.min_degradation, "quantiles": self.quantiles(),
                          "win_rates": self.win_rates(), "targets": self.targets(), "seconds": self.seconds,
                          "timing": self.timing, "notes": {str(k): v for k, v in self.notes.items()}})

    def summary(self) -> str:
        """The zoo table: eta quantiles per mode with the count of every outcome and of the joints where the mode is
        worse than none (``<none``: eta < :data:`WORSE_THAN_NONE`), win rates, targets, failures."""
        n = len(self.plants)
        lines = [f"zoo: {n} joints, {len(self.refused)} refused, {int(self.undefined().sum())} with eta undefined "
                 f"(friction degrades the loop by < {self.min_degradation:.0%}), wall {self.seconds:.1f} s",
                 f"{'mode':<14}{'eta':>5}{'ref':>5}{'div':>5}{'undef':>6}{'noref':>6}{'inval':>6}{'<none':>6}{'min':>8}"
                 f"{'q05':>8}{'q25':>8}{'median':>8}{'q75':>8}{'q95':>8}{'max':>8}"]
        counts = self.counts()
        worse = self.worse_than_none()
        for m, qs in self.quantiles().items():
            c = counts[m]
            lines.append(f"{m:<14}{c['ok']:>5}{c['refused']:>5}{c['diverged']:>5}{c['undefined']:>6}"
                         f"{c['no reference']:>6}{c['invalid']:>6}{worse[m]:>6}" + "".join(f"{v:>8.3f}" for v in qs))
        for name, rivals in self.win_rates().items():
            if rivals:
                lines.append(f"{name} >= " + ", ".join(f"{r}: {v:.1%}" for r, v in rivals.items()))
        lines += self._target_lines()
        return "\n".join(lines)

    def _target_lines(self) -> list:
        t = self.targets()
        best = self.best_adaptive()
        lines = [f"targets: runs refused {t['refused']}, diverged {t['diverged']} (target 0); best adaptive eta > 0 "
                 f"on {t['best_positive']:.1%} of {int(np.isfinite(best).sum())} joints (target 100 %)"
                 + (f"; >= dob on {t['best_ge_dob']:.1%} (target >= 95 %)" if "best_ge_dob" in t else "")]
        harm = t["tracking_harm"]
        if harm:
            lines.append("largest error above max(none, 2 x frictionless) (target: none): " + ", ".join(
                f"{m} {len(ix)}" + (f" (#{', #'.join(str(i) for i in ix[:10])})" if ix else "")
                for m, ix in harm.items()))
        if "adaptive" in self.eta and "adaptive-dob" in self.eta:  # plain adaptive where the composite succeeds
            a, d = self.eta["adaptive"], self.eta["adaptive-dob"]
            ok = np.isfinite(a) & np.isfinite(d) & (d >= 0.95)
            gap = np.flatnonzero(ok & (a < 0.8))
            lines.append(f"adaptive >= 0.8 where adaptive-dob >= 0.95: {int(ok.sum()) - gap.size} of {int(ok.sum())} "
                         f"joints" + "".join(f"; #{i} {a[i]:.3f} (adaptive-dob {d[i]:.3f})" for i in gap[:10]))
        neg = np.array([p.get("delta", 1.0) < 0 for p in self.plants])
        fin = np.isfinite(best)
        if neg.any() and fin.any():
            med = [float(np.nanmedian(best[s])) if np.isfinite(best[s]).any() else math.nan for s in (neg, ~neg)]
            lines.append(f"delta < 0 (friction rising with speed): {int(neg.sum())} joints, best adaptive median "
                         f"{med[0]:.3f}; delta > 0: median {med[1]:.3f}")
        fb = self.fixed_fallbacks()
        if fb:
            lines.append(f"fixed: offline fit rejected on {len(fb)} joint(s), the pre-fit's static map used instead "
                         f"(#{', #'.join(str(i) for i in fb[:10])}{', ...' if len(fb) > 10 else ''})")
        for i, why in sorted(self.refused.items())[:10]:
            lines.append(f"refused #{i} ({self.plants[i].get('model')}): {why}")
        for m, d in self.mode_refused.items():
            for i, why in sorted(d.items())[:10]:
                lines.append(f"{m} refused on #{i} ({self.plants[i].get('model')}): {why}")
        for m in self.modes:
            for i in np.flatnonzero(self.diverged[m])[:10]:
                lines.append(f"{m} diverged on #{i}: {self.plants[i]}")
        for i in t["best_not_positive"][:10]:
            lines.append(f"best adaptive eta {best[i]:.3f} <= 0 on #{i}: {self.plants[i]}")
        for i in t.get("best_below_dob", [])[:10]:
            lines.append(f"best adaptive eta {best[i]:.3f} < dob {self.eta['dob'][i]:.3f} on #{i}: {self.plants[i]}")
        return lines


def _prepare(spec, o: CompareOptions, ref, J_design_factor: float | None = None) -> tuple:
    """(mode options, noise seed, {mode: reason it cannot be built}, notes, the context of own compensators) of
    one joint on the comparison reference ``ref`` of ``o`` with the design inertia ``J_design_factor`` times its
    ``J`` (None: identified, ``o``'s default), or the reason it was refused (last item)."""
    try:
        p = plant_from_dict(spec)
        if J_design_factor is not None:
            o = o.replace(J_design=J_design_factor * p.J)
        plant_table(p, ref.t, o.loop.controller.Tc)  # refuses a plant the engine cannot integrate (every row)
        s = prepare_comparison(p, o, reference=ref)
        s.bar.close()
    except Exception as exc:  # noqa: BLE001 - any refusal is a result of the zoo, with its reason
        return None, None, None, (), None, f"{type(exc).__name__}: {exc}"
    bad = {}
    for m in s.modes:
        try:
            build_mode(p, m, s.mode_options[m])
        except Exception as exc:  # noqa: BLE001 - a mode that cannot be built is that mode's failure
            bad[m] = f"{type(exc).__name__}: {exc}"
    if "none" in bad or "frictionless" in bad:
        return None, None, None, (), None, "; ".join(f"{m}: {why}" for m, why in bad.items())
    return s.mode_options, s.noise_seed, bad, tuple(s.notes), compensator_context(s, o), None


def _group_task(args) -> dict:
    """Worker: prepare a group of joints and run every mode on those it can (one batch call per mode).

    The measurement noise of a joint is drawn once and shared by its modes (the numbers of
    ``run_batch(..., seeds=...)``, which would draw the same noise once per mode). Returns the preparation
    outcome per joint, ``{mode: (rms_second_half, max_error, diverged)}`` over the group (NaN/False where not run) and the
    CPU seconds of the two phases.
    """
    import time

    specs, co, modes, own, J_design_factor, export = args
    through = None if export is None else _exported_library(export)
    t0 = time.process_time()
    ref = _reference(co)  # once per group: the same reference for every joint
    prepared = [_prepare(s, co, ref, J_design_factor) for s in specs]
    t1 = time.process_time()
    n = len(specs)
    noise = {}
    for j, (opts, seed, *_rest, why) in enumerate(prepared):
        sd = opts["none"].sensor.noise_std if why is None else 0.0
        if why is None and sd > 0:
            noise[j] = np.random.default_rng(seed).normal(0.0, sd, size=ref.t.shape[0])
    runs = {}
    for m in modes:
        rms, mx, div = np.full(n, math.nan), np.full(n, math.nan), np.zeros(n, dtype=bool)
        ok = [j for j, p in enumerate(prepared) if p[-1] is None and m not in p[2]]
        if ok:
            plants = [plant_from_dict(specs[j]) for j in ok]
            opts = [prepared[j][0][m] for j in ok]
            if all(j in noise for j in ok):
                r = run_batch(plants, ref, m, opts, noise=np.stack([noise[j] for j in ok]), through=through)
            else:
                r = run_batch(plants, ref, m, opts, seeds=[prepared[j][1] for j in ok], through=through)
            rms[ok] = np.where(r.diverged, math.nan, r.rms_second_half)
            mx[ok] = np.where(r.diverged, math.nan, r.max_second_half)
            div[ok] = r.diverged
        runs[m] = (rms, mx, div)
    if own:
        runs.update(_own_runs(specs, prepared, ref, own))
    outcome = [(p[2] or {}, p[3], p[-1]) for p in prepared]
    return {"prepared": outcome, "runs": runs, "cpu": (t1 - t0, time.process_time() - t1)}


@functools.lru_cache(maxsize=4)
def _exported_library(folder: str):
    """The export folder compiled once per worker process (the same sources give the same library)."""
    from controllers.simulation.exported import ExportedLibrary

    return ExportedLibrary(folder)


def _reference(co: CompareOptions):
    """The reference of every run: ``co.reference``, else the comparison's multisine."""
    return co.reference if co.reference is not None else comparison_reference(co)


def _own_runs(specs, prepared, ref, own: dict) -> dict:
    """``{name: (rms_second_half, max_error, diverged)}`` of the user's compensators ``own`` (import paths, resolved here in
    the worker) on the prepared joints, one :func:`run_own` each with the joint's context, options and noise; an
    error of the compensator is recorded as that joint's refusal of ``name`` (in the joint's ``bad``)."""
    from controllers.simulation.user_compensator import CompensatorError

    factories = compensator_factories(own, source="ZooOptions.compensators")
    out = {}
    for name, factory in factories.items():
        rms, mx, div = np.full(len(specs), math.nan), np.full(len(specs), math.nan), np.zeros(len(specs), dtype=bool)
        for j, (opts, seed, bad, _notes, ctx, why) in enumerate(prepared):
            if why is not None:
                continue
            try:
                r = run_own(plant_from_dict(specs[j]), ref, factory(ctx), opts["none"], name=name,
                            rng=np.random.default_rng(seed))
            except (CompensatorError, ParameterError) as exc:
                bad[name] = f"{type(exc).__name__}: {exc}"
                continue
            div[j] = bool(r.info.get("diverged"))
            rms[j] = math.nan if div[j] else r.metrics.rms_second_half
            mx[j] = math.nan if div[j] else r.metrics.max_second_half
        out[name] = (rms, mx, div)
    return out


def _init_worker() -> None:
    """Process pool initialiser: one engine thread per worker process (the processes share the cores;
    :func:`controllers.simulation.engine.engine_threads` reads ``ADAPTIVE_FF_THREADS``)."""
    os.environ["ADAPTIVE_FF_THREADS"] = "1"


_DASK_LOCAL = ("synchronous", "threads", "processes")


def _map(fn, items, o: ZooOptions) -> list:
    """``[fn(item) for item in items]`` on Dask (``o.scheduler``), a process pool (``o.workers`` > 1) or here."""
    if o.scheduler in _DASK_LOCAL:
        import dask

        return list(dask.compute(*[dask.delayed(fn, pure=False)(it) for it in items], scheduler=o.scheduler))
    if o.scheduler is not None:
        from dask.distributed import Client

        client = o.scheduler if isinstance(o.scheduler, Client) else Client(o.scheduler)
        try:
            return client.gather(client.map(fn, items, pure=False))
        finally:
            if client is not o.scheduler:
                client.close()
    workers = min(o.workers or os.cpu_count() or 1, len(items))
    if workers > 1:
        from concurrent.futures import ProcessPoolExecutor

        # one item at a time: a worker takes the next group as soon as it is free (groups differ in cost)
        with ProcessPoolExecutor(max_workers=workers, initializer=_init_worker) as pool:
            return list(pool.map(fn, items, chunksize=1))
    return [fn(it) for it in items]


def _group_bounds(n: int, group: int, workers: int) -> list:
    """``[(a, b), ...]``: joints ``a:b`` of each task, at most ``group`` each, shrinking towards the end.

    Guided self-scheduling (Polychronopoulos & Kuck 1987): a task takes ``ceil(remaining/(2*workers))`` joints,
    at most ``group`` and at least one, so that the last tasks are single joints and no worker is left with a
    long group while the others idle (joints differ in cost by more than 10x: stiff ones take the implicit step).
    """
    out, a = [], 0
    while a < n:
        size = max(1, min(group, -(-(n - a) // (2 * max(1, workers)))))
        out.append((a, a + size))
        a += size
    return out


def run_zoo(options: ZooOptions | None = None) -> ZooResult:
    """Draw the zoo and run every mode on every joint (module docstring).

    Parameters
    ----------
    options : ZooOptions
        Default ``ZooOptions()``.

    Returns
    -------
    ZooResult

    Raises
    ------
    ImportError
        ``scheduler`` given without dask installed.
    ParameterError
        A duration whose runs do not fit into the memory available, in every worker process at once (before
        anything is drawn or run; :func:`controllers.simulation.memory.check_run_memory`).

    Notes
    -----
    eta (second half) is :func:`controllers.experiments.compare.eta` of the joint's ``none``, mode and
    ``frictionless`` runs, the number ``compare`` gives, where it is defined (:meth:`ZooResult.status`).
    The joints are split into groups of at most ``group`` (smaller towards the end, :func:`_group_bounds`); each
    group is one task (its preparation, then one batch call per mode on its joints), the tasks run on ``workers``
    processes with one engine thread each (or on Dask), a free worker taking the next group. Each joint's numbers
    do not depend on the grouping.
    """
    import time

    o = ZooOptions() if options is None else options
    t0 = time.perf_counter()
    co = o.compare_options()
    n = o.n
    bounds = _group_bounds(n, o.group, o.workers or os.cpu_count() or 1)
    processes = 1 if o.scheduler is not None else min(o.workers or os.cpu_count() or 1, len(bounds))
    check_run_memory(co.duration, co.loop.controller.Tc, signals=SHARED_SIGNALS + PREPARATION_SIGNALS + o.group, processes=processes,
                     detail=f"a joint's preparation and the noise of {o.group} joint{'s' * (o.group > 1)}")
    specs = draw_plants(o.n, _reference(co), seed=o.seed, box=o.box)
    starts = [a for a, _ in bounds]
    own = tuple(o.compensators or ())
    out = _map(_group_task, [(specs[a:b], co, o.modes, o.compensators, o.J_design_factor, o.export)
                             for a, b in bounds], o)
    refused, mode_refused, notes = {}, {}, {}
    modes = o.modes + own
    rms = {m: np.full(n, math.nan) for m in modes}
    max_error = {m: np.full(n, math.nan) for m in modes}
    div = {m: np.zeros(n, dtype=bool) for m in modes}
    cpu = [0.0, 0.0]
    for a, res in zip(starts, out):
        for j, (bad, nts, why) in enumerate(res["prepared"]):
            if why is not None:
                refused[a + j] = why
            for m, reason in bad.items():
                mode_refused.setdefault(m, {})[a + j] = reason
            if nts:
                notes[a + j] = list(nts)
        for m, (r, mx, d) in res["runs"].items():
            rms[m][a:a + len(r)] = r
            max_error[m][a:a + len(mx)] = mx
            div[m][a:a + len(d)] = d
        cpu = [cpu[0] + res["cpu"][0], cpu[1] + res["cpu"][1]]
    mode_refused = {m: mode_refused[m] for m in modes if m in mode_refused}
    timing = {"prepare_cpu": cpu[0], "runs_cpu": cpu[1]}
    res = ZooResult(plants=specs, modes=modes, eta={}, rms=rms, refused=refused, mode_refused=mode_refused,
                    diverged=div, min_degradation=o.min_degradation, seconds=time.perf_counter() - t0, timing=timing,
                    notes=notes, max_error=max_error)
    undefined = res.undefined()
    for m in modes:
        res.eta[m] = np.array([math.nan if undefined[i] else eta(rms["none"][i], rms[m][i], rms["frictionless"][i])
                               for i in range(n)])
    return res


def zoo_options_dict(o: ZooOptions) -> dict:
    """The settings of a zoo run as a JSON-ready dict (for the benchmark page): the zoo's own fields, ``box``, and
    ``compare``, every joint's comparison (:meth:`ZooOptions.compare_options`) by its flat names
    (:meth:`CompareOptions.flat_names`; its reference summarised as ``reference``, no own compensators or PI)."""
    co = o.compare_options()
    d = {f.name: getattr(o, f.name) for f in fields(o) if f.name not in ("compare", "box", "scheduler")}
    d["scheduler"] = o.scheduler if isinstance(o.scheduler, (str, type(None))) else str(o.scheduler)
    d["box"] = asdict(o.box)
    d["compare"] = {k: co.flat(k) for k in CompareOptions.flat_names()
                    if k not in ("reference", "compensators", "controller")}
    if co.reference is not None:
        ref = co.reference
        d["reference"] = {"samples": int(ref.t.shape[0]), "stops": int(len(ref.stops())),
                          "reversals": int(len(ref.reversals()))}
    return json_safe(d)
