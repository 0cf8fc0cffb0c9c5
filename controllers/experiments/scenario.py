"""A comparison scenario in one TOML file: plant, reference, sensor, drive, controller design, modes, your compensators.

``adaptive-ff compare --scenario FILE`` runs it, :func:`load_scenario` reads it into a :class:`Scenario` whose
:meth:`Scenario.compare` runs the same comparison from Python, and
:func:`controllers.testing.assert_tracking_bound` takes it (a regression test in three lines). The file (read
with the standard library's :mod:`tomllib`; SI units throughout)::

    name = "robot base joint, pick and place"     # optional: name, description
    seed = 0                                      # everything random (reference, noise, experiments)
    modes = ["none", "fixed", "adaptive", "adaptive-dob", "dob"]   # default: all built-in modes

    [plant]            # one of: preset = "paper" | variant = "karnopp" | file = "joint.json" (relative to this
    model = "lagged-stribeck"    # file) | the keys of a plant file (plant.models.plant_from_dict), as here
    J = 4.0
    Fc = 25.0
    # ...

    [reference]        # kind = "multisine" (duration) | "point-to-point" | "reversing" | "file"
    kind = "point-to-point"
    targets = [0.5, -0.2, 0.4, 0.0]   # rad; the other keys are those of plant.motion.point_to_point_reference
    v_max = 0.5
    a_max = 4.0
    dwell = 0.5
    repeat = 3                        # the target list three times

    [sensor]           # encoder_counts (counts per revolution), delay (periods), noise_std (rad/s; default 1e-3
    encoder_counts = 131072           # without an encoder, 0 with one: its quantisation is the noise),
    delay = 1                         # velocity = "difference" | "kalman" (velocity_bandwidth Hz, velocity_model)

    [drive]            # u_max (torque limit, N·m; default from the quasi-static runs), slew_rate (N·m/s)
    u_max = 150.0

    [controller]       # crossover (rad/s), phase_margin (deg), Tc, Ts (s), J_design (kg·m²)
    crossover = 20.0

    [compensation]     # further settings of CompareOptions.from_flat (estimator, lam, ...)

    [compensators.lugre-model]        # your compensator: factory(context, **the other keys) -> object with
    factory = "lugre_model.py:LuGreModel"   # compensate(w_meas, w_ref) and observe(u, w_meas); "module:name"
    deflection = 1e-3                       # or "path/to/file.py:name" (relative to this file)

    [bounds]           # for assert_tracking_bound: mode, min_eta, max_rms (rad/s), max_error (rad/s)
    mode = "adaptive-dob"
    min_eta = 0.8

Every error names the file, the table and key, and the value (:class:`ScenarioError`).
"""

from __future__ import annotations

import functools
import importlib
import importlib.util
import inspect
import math
import os
import sys
import tomllib
from dataclasses import dataclass, fields
from pathlib import Path

from controllers.experiments.compare import CompareOptions, Comparison, check_comparison, compare
from controllers.simulation.compensators import MODES
from plant.errors import ParameterError, check_not_special

__all__ = ["Scenario", "ScenarioError", "TrackingBounds", "compensator_factories", "load_scenario", "MAX_MOVES",
           "scenario_from_dict", "REFERENCE_KINDS"]

#: Kinds of ``[reference]`` and their keys (besides ``kind``).
REFERENCE_KINDS = {
    "multisine": ("duration",),
    "point-to-point": ("targets", "v_max", "a_max", "j_max", "dwell", "start_dwell", "q0", "repeat"),
    "reversing": ("speed", "hold", "accel", "n_reversals", "start_dwell", "end_dwell"),
    "file": ("path", "time", "velocity", "position", "time_unit", "velocity_unit", "position_unit"),
}
_TOP = ("name", "description", "seed", "modes", "plant", "reference", "sensor", "drive", "controller",
        "compensation", "compensators", "bounds")
_SENSOR = ("encoder_counts", "delay", "noise_std", "velocity", "velocity_bandwidth", "velocity_model")
_DRIVE = ("u_max", "slew_rate")
_CONTROLLER = ("crossover", "phase_margin", "Tc", "Ts", "J_design")
_BOUNDS = ("mode", "min_eta", "max_rms", "max_error")
#: CompareOptions settings (:meth:`CompareOptions.flat_names`) a scenario sets elsewhere (or not at all): not
#: allowed under ``[compensation]``.
_NOT_COMPENSATION = ("duration", "seed", "modes", "compensators", "reference", "faults", "u_max", "controller",
                     "slew_rate") + _SENSOR + _CONTROLLER


class ScenarioError(ParameterError):
    """A scenario file or mapping is invalid; the message names the file, the table and key, and the value."""


@dataclass(frozen=True)
class TrackingBounds:
    """The ``[bounds]`` of a scenario: what :func:`controllers.testing.assert_tracking_bound` asserts.

    Attributes
    ----------
    mode : str
        The mode (or own compensator) checked; default ``"adaptive"``.
    min_eta : float or None
        Lower bound on eta over the second half.
    max_rms, max_error : float or None
        Bounds on the RMS and the largest |velocity error| over the second half (rad/s).
    """

    mode: str = "adaptive"
    min_eta: float | None = None
    max_rms: float | None = None
    max_error: float | None = None


@dataclass(frozen=True)
class Scenario:
    """One comparison scenario: the plant and the :class:`CompareOptions` of everything else.

    Attributes
    ----------
    name : str
        Its name (the file's ``name``, else the file's stem).
    plant : plant model
        The true plant (:mod:`plant.models`; a drift, payload step or ripple as the plant file says).
    options : CompareOptions
        Reference, sensor, drive, design, modes, seed and your compensators.
    bounds : TrackingBounds or None
        The file's ``[bounds]``.
    description : str
    source : str or None
        The file it was read from.
    """

    name: str
    plant: object
    options: CompareOptions
    bounds: TrackingBounds | None = None
    description: str = ""
    source: str | None = None

    def compare(self, *, progress: bool | None = None, **changes) -> Comparison:
        """Run the comparison (:func:`controllers.experiments.compare.compare` on :attr:`plant` with
        :attr:`options`, fields changed by ``changes``, e.g. ``modes=("adaptive",)``)."""
        return compare(self.plant, self.options, progress=progress, **changes)

    def to_dict(self) -> dict:
        """Strict-JSON summary: name, description, source, the reference's length and its stops and reversals,
        sensor, drive, seed, modes, own compensators' names, bounds."""
        o = self.options
        ref, sensor, drive = o.reference, o.loop.sensor, o.loop.drive
        d = {"name": self.name, "description": self.description, "source": self.source, "seed": o.seed,
             "modes": list(o.modes), "duration": o.duration, "Tc": o.loop.controller.Tc,
             "sensor": {"encoder_counts": sensor.encoder_counts, "delay": sensor.delay, "noise_std": sensor.noise_std,
                        "velocity": sensor.velocity if sensor.encoder_counts else None},
             "drive": {"u_max": drive.u_max, "slew_rate": None if math.isinf(drive.slew_rate) else drive.slew_rate},
             "compensators": sorted(o.compensators or {}),
             "bounds": None if self.bounds is None else {f.name: getattr(self.bounds, f.name)
                                                         for f in fields(self.bounds)}}
        if ref is not None:
            d["reference"] = {"stops": int(len(ref.stops())), "reversals": int(len(ref.reversals()))}
        return d

    def summary(self) -> str:
        """One paragraph: name, duration, reference events, sensor, drive, modes."""
        o = self.options
        ref = o.reference
        events = "multisine" if ref is None else f"{len(ref.stops())} stops, {len(ref.reversals())} reversals"
        s, dr = o.loop.sensor, o.loop.drive
        sensor = (f"{s.encoder_counts}-count encoder ({s.velocity})" if s.encoder_counts else "velocity sensor") + \
            (f", {s.delay} period(s) delay" if s.delay else "") + f", noise {s.noise_std:g} rad/s"
        drive = ("u_max from the quasi-static runs" if dr.u_max is None else f"u_max {dr.u_max:g} N·m") + \
            ("" if math.isinf(dr.slew_rate) else f", slew {dr.slew_rate:g} N·m/s")
        own = f"; own: {', '.join(o.compensators)}" if o.compensators else ""
        return (f"scenario {self.name!r}: {o.duration:g} s ({events}), seed {o.seed}; {sensor}; {drive}; "
                f"modes {', '.join(o.modes)}{own}")


def load_scenario(path) -> Scenario:
    """Read a scenario TOML file (the module docstring shows every table and key).

    Parameters
    ----------
    path : str or os.PathLike
        The file; relative paths inside it (``[plant] file``, ``[reference] path``, a compensator's
        ``file.py:name``) are relative to its folder.

    Returns
    -------
    Scenario

    Raises
    ------
    ScenarioError
        Missing, unreadable or not TOML (with the line and column), an unknown table or key, a value out of
        range or of the wrong type, an unknown mode, a compensator that cannot be imported: the message names
        the file, the table and key, and the value.
    """
    p = Path(os.fspath(path))
    check_not_special(p, "scenario file (TOML)", error=ScenarioError)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ScenarioError(f"{p}: no such scenario file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"{p}: cannot read the scenario file ({exc})") from None
    try:
        d = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{p}: not valid TOML: {exc}") from None
    return scenario_from_dict(d, base_dir=p.parent, source=str(p), default_name=p.stem)


def scenario_from_dict(d: dict, *, base_dir=".", source: str = "<scenario>", default_name: str = "scenario") -> Scenario:
    """Build a :class:`Scenario` from the mapping of a scenario file (:func:`load_scenario`).

    Parameters
    ----------
    d : dict
        The tables and keys of the module docstring.
    base_dir : str or os.PathLike, keyword-only
        Folder that relative paths are resolved against.
    source : str, keyword-only
        Name used in error messages (the file).
    default_name : str, keyword-only
        Name when ``d`` has none.

    Raises
    ------
    ScenarioError
        As :func:`load_scenario`.
    """
    ctx = _Ctx(source, Path(os.fspath(base_dir)))
    if not isinstance(d, dict):
        raise ScenarioError(f"{source}: a scenario must be a table of tables, got {type(d).__name__}")
    ctx.known("", d, _TOP)
    name = ctx.typed("", "name", d.get("name", default_name), str)
    description = ctx.typed("", "description", d.get("description", ""), str)
    seed = d.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ctx.error("", "seed", seed, "must be an integer >= 0")
    modes = _modes(ctx, d)
    plant = _plant(ctx, ctx.table(d, "plant", required=True))
    controller = ctx.table(d, "controller")
    ctx.known("controller", controller, _CONTROLLER)
    Tc = controller.get("Tc", 1e-3)
    sensor, drive = ctx.table(d, "sensor"), ctx.table(d, "drive")
    ctx.known("sensor", sensor, _SENSOR)
    ctx.known("drive", drive, _DRIVE)
    reference = _reference(ctx, ctx.table(d, "reference"), Tc, seed)
    compensation = ctx.table(d, "compensation")
    allowed = tuple(k for k in CompareOptions.flat_names() if k not in _NOT_COMPENSATION)
    ctx.known("compensation", compensation, allowed)
    compensators = _compensators(ctx, ctx.table(d, "compensators"))
    noise = sensor.get("noise_std", 0.0 if sensor.get("encoder_counts") is not None else 1e-3)
    kw = dict(seed=seed, modes=modes, reference=reference, compensators=compensators or None, noise_std=noise,
              **{k: v for k, v in sensor.items() if k != "noise_std"}, **drive, **controller,
              **compensation)
    if reference is None:
        kw.pop("reference")
        duration = ctx.table(d, "reference").get("duration", 60.0)
        kw["duration"] = duration
    try:
        options = CompareOptions.from_flat(**kw)
        check_comparison(plant, options)  # what needs no simulation: before any
    except (ParameterError, TypeError, ValueError) as exc:
        raise ScenarioError(f"{source}: {_where_option(str(exc), plant=True)}{exc}") from None
    bounds = _bounds(ctx, d, modes, compensators)
    return Scenario(name=name, plant=plant, options=options, bounds=bounds, description=description, source=source)


class _Ctx:
    """The file being read (for messages) and its folder (for relative paths)."""

    def __init__(self, source: str, base: Path):
        self.source, self.base = source, base

    def error(self, table: str, key: str, value, what: str) -> ScenarioError:
        where = f"[{table}] {key}" if table else key
        return ScenarioError(f"{self.source}: {where} = {value!r}: {what}")

    def table(self, d: dict, name: str, *, required: bool = False) -> dict:
        t = d.get(name)
        if t is None:
            if required:
                raise ScenarioError(f"{self.source}: missing table [{name}]")
            return {}
        if not isinstance(t, dict):
            raise self.error("", name, t, f"must be a table [{name}]")
        return t

    def known(self, table: str, d: dict, allowed) -> None:
        for k, v in d.items():
            if k not in allowed:
                raise self.error(table, k, v, f"unknown key; known: {', '.join(allowed)}")

    def typed(self, table: str, key: str, value, typ):
        if not isinstance(value, typ) or isinstance(value, bool) and typ is not bool:
            raise self.error(table, key, value, f"must be a {typ.__name__}")
        return value

    def path(self, table: str, key: str, value) -> Path:
        self.typed(table, key, value, str)
        p = Path(value)
        return p if p.is_absolute() else self.base / p


def _where_option(msg: str, *, plant: bool = False) -> str:
    """The table of the CompareOptions field a ParameterError message starts with ("u_max must ..."), for the
    error message; with ``plant``, ``[plant]`` for a friction level (:func:`check_drive_moves`)."""
    key = msg.split(" ", 1)[0].strip("'\":,")
    if plant and key in ("Fc", "Fs", "Fc_pos", "Fc_neg", "Fs_pos", "Fs_neg"):
        return "[plant] "
    for table, keys in (("sensor", _SENSOR), ("drive", _DRIVE), ("controller", _CONTROLLER)):
        if key in keys:
            return f"[{table}] "
    return "[compensation] " if key in CompareOptions.flat_names() else ""


def _modes(ctx: _Ctx, d: dict) -> tuple:
    modes = d.get("modes", list(MODES))
    if not isinstance(modes, list) or not all(isinstance(m, str) for m in modes):
        raise ctx.error("", "modes", modes, "must be a list of mode names")
    unknown = [m for m in modes if m not in MODES]
    if unknown:
        raise ctx.error("", "modes", unknown[0], f"unknown mode; known: {', '.join(MODES)} (your own compensators "
                                                 f"go under [compensators.NAME])")
    return tuple(modes)


def _plant(ctx: _Ctx, t: dict):
    from plant.friction import PRESETS, preset
    from plant.models import load_plant, plant_from_dict
    from plant.variant_plants import VARIANT_NAMES, variant

    picks = [k for k in ("preset", "variant", "file") if k in t]
    if len(picks) > 1 or (picks and len(t) > 1):
        raise ScenarioError(f"{ctx.source}: [plant]: give one of preset, variant, file, or the plant's own keys; "
                            f"got {', '.join(sorted(t))}")
    try:
        if "preset" in t:
            if t["preset"] not in PRESETS:
                raise ctx.error("plant", "preset", t["preset"], f"unknown preset; known: {', '.join(PRESETS)}")
            return preset(t["preset"])
        if "variant" in t:
            if t["variant"] not in VARIANT_NAMES:
                raise ctx.error("plant", "variant", t["variant"], f"unknown variant; known: "
                                                                  f"{', '.join(VARIANT_NAMES)}")
            return variant(t["variant"])
        if "file" in t:
            return load_plant(ctx.path("plant", "file", t["file"]))
        return plant_from_dict(t)
    except ScenarioError:
        raise
    except (ParameterError, OSError, TypeError, ValueError, OverflowError) as exc:
        raise ScenarioError(f"{ctx.source}: [plant]{_plant_key(t, str(exc))}: {exc}") from None


def _plant_key(t: dict, msg: str) -> str:
    """`` KEY = VALUE`` of the ``[plant]`` key a plant's error message starts with (``"J must be a real number,
    ..."``; a key of its ``drift``, ``ripple`` or ``payload`` table as ``drift.KEY``), else ``""``."""
    key = msg.split(" ", 1)[0].strip("'\":,")
    if key in t and not isinstance(t[key], dict):
        return f" {key} = {t[key]!r}"
    for sub, table in t.items():
        if isinstance(table, dict) and key in table:
            return f" {sub}.{key} = {table[key]!r}"
    return ""


def _reference(ctx: _Ctx, t: dict, Tc, seed: int):
    """The Reference of ``[reference]``, or None for the multisine (made by compare from the seed)."""
    from adaptive_ff.io.logs import LogUnits
    from adaptive_ff.io.references import load_reference
    from plant.motion import point_to_point_reference, reversing_reference

    kind = t.get("kind", "multisine")
    if kind not in REFERENCE_KINDS:
        raise ctx.error("reference", "kind", kind, f"unknown kind; known: {', '.join(REFERENCE_KINDS)}")
    kw = {k: v for k, v in t.items() if k != "kind"}
    ctx.known("reference", kw, REFERENCE_KINDS[kind])
    if kind == "multisine":
        return None
    try:
        if kind == "point-to-point":
            targets = kw.pop("targets", None)
            if not isinstance(targets, list) or not targets or not all(
                    isinstance(x, (int, float)) and not isinstance(x, bool) for x in targets):
                raise ctx.error("reference", "targets", targets, "must be a non-empty list of positions (rad)")
            repeat = kw.pop("repeat", 1)
            if isinstance(repeat, bool) or not isinstance(repeat, int) or repeat < 1:
                raise ctx.error("reference", "repeat", repeat, "must be an integer >= 1")
            if len(targets) * repeat > MAX_MOVES:
                raise ctx.error("reference", "repeat", repeat, f"{len(targets)} targets times it are more than "
                                f"{MAX_MOVES:,} moves")
            for k in ("v_max", "a_max"):
                if k not in kw:
                    raise ScenarioError(f"{ctx.source}: [reference] {k}: missing (kind = 'point-to-point')")
            moves = [float(x) for x in targets] * repeat
            _check_reference_length(ctx, _moves_length(moves, kw), Tc)
            return point_to_point_reference(moves, dt=Tc, **kw)
        if kind == "reversing":
            _check_reference_length(ctx, _reversing_length(kw), Tc)
            return reversing_reference(dt=Tc, **kw)
        path = ctx.path("reference", "path", kw.pop("path", None))
        units = LogUnits(**{k: kw.pop(k) for k in ("time_unit", "velocity_unit", "position_unit") if k in kw})
        return load_reference(path, dt=Tc, max_samples=_max_reference_samples(), units=units, **kw)
    except ScenarioError:
        raise
    except (ParameterError, TypeError, ValueError, OSError) as exc:
        raise ScenarioError(f"{ctx.source}: [reference] (kind = {kind!r}): {exc}") from None


#: Most moves of a point-to-point reference (its targets times ``repeat``).
MAX_MOVES = 10**6
#: Float64 signals of the reference's length that making it holds at once (time, velocity, acceleration, the
#: interpolation's temporaries): a reference that does not fit into the memory available is refused before it is
#: made (the comparison's own check follows, :meth:`controllers.experiments.compare.CompareOptions.check_memory`).
_REFERENCE_SIGNALS = 6


def _reversing_length(kw: dict) -> float | None:
    """An upper bound of the length (s) of a ``reversing`` reference from its keys; None where a key is not a
    number (the reference names it)."""
    try:
        if not all(float(kw[k]) > 0.0 for k in ("speed", "accel", "hold")):
            return None  # the reference names the key
        ramp = 2.0 * float(kw["speed"]) / float(kw["accel"])
        return (float(kw.get("start_dwell", 0.5)) + float(kw.get("end_dwell", 0.5))
                + (float(kw["n_reversals"]) + 1.0) * (float(kw["hold"]) + ramp))
    except (KeyError, TypeError, ValueError, ZeroDivisionError, OverflowError):
        return None


def _moves_length(moves: list, kw: dict) -> float | None:
    """An upper bound of the length (s) of a ``point-to-point`` reference through ``moves`` from its keys."""
    try:
        v, a = float(kw["v_max"]), float(kw["a_max"])
        j = kw.get("j_max")
        if not (v > 0.0 and a > 0.0 and (j is None or float(j) > 0.0)):
            return None  # the reference names the key
        ramp = 2.0 * v / a + (0.0 if j is None else 2.0 * a / float(j))
        path = abs(moves[0] - float(kw.get("q0", 0.0))) + sum(abs(y - x) for x, y in zip(moves, moves[1:]))
        return float(kw.get("start_dwell", 0.5)) + path / v + len(moves) * (ramp + float(kw.get("dwell", 0.5)))
    except (KeyError, TypeError, ValueError, ZeroDivisionError, OverflowError):
        return None


def _check_reference_length(ctx: _Ctx, length: float | None, Tc) -> None:
    """ScenarioError when a reference of ``length`` s at the step ``Tc`` does not fit into the memory available."""
    from controllers.simulation.memory import check_run_memory

    if length is None or not length > 0 or not isinstance(Tc, (int, float)) or isinstance(Tc, bool) or not Tc > 0:
        return
    if not math.isfinite(length):
        raise ScenarioError(f"{ctx.source}: [reference]: its length is not finite ({length!r} s)")
    try:
        check_run_memory(length, Tc, signals=_REFERENCE_SIGNALS, what="its length",
                         detail="making the reference")
    except ParameterError as exc:
        raise ScenarioError(f"{ctx.source}: [reference]: {exc}") from None


def _max_reference_samples() -> int | None:
    """The samples of a reference that fit into the memory available (None: unknown)."""
    from controllers.simulation.memory import available_memory, run_bytes

    found = available_memory()
    return None if found is None else max(int(found[0] // run_bytes(1, _REFERENCE_SIGNALS)), 2)


def compensator_factories(table: dict, *, base_dir=".", source: str = "compensators") -> dict:
    """``{name: factory}`` of a table of own compensators, as ``[compensators]`` of a scenario file.

    Parameters
    ----------
    table : dict
        ``{name: {"factory": "module:name" | "path/file.py:name", **keywords}}`` or ``{name: "module:name"}``;
        the factory is called as ``factory(context, **keywords)``
        (:class:`controllers.simulation.user_compensator.CompensatorContext`).
    base_dir : str or os.PathLike, keyword-only
        Folder a relative ``file.py`` is resolved against.
    source : str, keyword-only
        Name used in error messages (the file the table came from).

    Returns
    -------
    dict
        Callables, one per name (a ``functools.partial`` where keywords are given), in the table's order.

    Raises
    ------
    ScenarioError
        A built-in mode's name, a missing or malformed ``factory``, a module or file that cannot be imported
        (with the import's own error) or without that callable.
    """
    if not isinstance(table, dict):
        raise ScenarioError(f"{source}: compensators must be a table {{name: {{factory = ...}}}}, got {table!r}")
    spelled = {k: ({"factory": v} if isinstance(v, str) else v) for k, v in table.items()}
    return _compensators(_Ctx(source, Path(os.fspath(base_dir))), spelled)


def _compensators(ctx: _Ctx, t: dict) -> dict:
    out = {}
    for name, spec in t.items():
        table = f"compensators.{name}"
        if name in MODES:
            raise ctx.error("compensators", name, spec, "is a built-in mode's name; choose another")
        if not isinstance(spec, dict) or "factory" not in spec:
            raise ScenarioError(f"{ctx.source}: [{table}] must be a table with factory = \"module:name\" or "
                                f"\"file.py:name\", got {spec!r}")
        kwargs = {k: v for k, v in spec.items() if k != "factory"}
        factory = _import_factory(ctx, table, spec["factory"])
        _check_factory(ctx, table, spec["factory"], factory, kwargs)
        out[name] = functools.partial(factory, **kwargs) if kwargs else factory
    return out


def _check_factory(ctx: _Ctx, table: str, ref: str, factory, kwargs: dict) -> None:
    """Refuse, before any run, a factory that cannot be called as ``factory(context, **kwargs)`` (an unknown or a
    missing keyword) and a class without the methods ``compensate`` and ``observe``."""
    if inspect.isclass(factory):
        missing = [m for m in ("compensate", "observe") if not callable(getattr(factory, m, None))]
        if missing:
            raise ctx.error(table, "factory", ref, f"the class {factory.__name__} has no method "
                                                   f"{' and no method '.join(missing)} (a compensator needs "
                                                   f"compensate(w_meas, w_ref) and observe(u, w_meas))")
    try:
        sig = inspect.signature(factory)
    except (TypeError, ValueError):  # a builtin without a signature: called as it is
        return
    try:
        sig.bind(None, **kwargs)
    except TypeError as exc:
        keys = [k for k in kwargs if k not in sig.parameters]
        if keys and not any(q.kind is q.VAR_KEYWORD for q in sig.parameters.values()):
            raise ctx.error(table, keys[0], kwargs[keys[0]], f"{ref} takes no keyword {keys[0]!r} (it takes: "
                                                             f"{', '.join(list(sig.parameters)[1:]) or 'none'})")
        raise ctx.error(table, "factory", ref, f"cannot be called as factory(context, **the table's other keys): "
                                               f"{exc}") from None


def _import_factory(ctx: _Ctx, table: str, ref):
    """The callable ``module:name`` (importable) or ``path/file.py:name`` (relative to the scenario file)."""
    if not isinstance(ref, str) or ref.count(":") != 1:
        raise ctx.error(table, "factory", ref, "must be \"module:name\" or \"path/file.py:name\"")
    mod_name, attr = ref.split(":")
    try:
        if mod_name.endswith(".py"):
            path = ctx.path(table, "factory", mod_name)
            check_not_special(path, f"Python file ([{table}] factory in {ctx.source})", error=ScenarioError)
            if not path.is_file():
                raise ctx.error(table, "factory", ref, f"no such file {path}")
            key = f"_adaptive_ff_scenario_{abs(hash(str(path.resolve())))}"
            module = sys.modules.get(key)
            if module is None:
                spec = importlib.util.spec_from_file_location(key, path)
                module = importlib.util.module_from_spec(spec)
                sys.modules[key] = module
                try:
                    spec.loader.exec_module(module)
                except BaseException:
                    del sys.modules[key]
                    raise
        else:
            module = importlib.import_module(mod_name)
    except ScenarioError:
        raise
    except Exception as exc:  # the user's module may raise anything while it is imported
        raise ctx.error(table, "factory", ref, f"cannot import it ({type(exc).__name__}: {exc})") from None
    obj = getattr(module, attr, None)
    if not callable(obj):
        raise ctx.error(table, "factory", ref, f"{mod_name} has no callable {attr!r}")
    return obj


def _bounds(ctx: _Ctx, d: dict, modes: tuple, compensators: dict) -> TrackingBounds | None:
    t = ctx.table(d, "bounds")
    if not t:
        return None
    ctx.known("bounds", t, _BOUNDS)
    mode = t.get("mode", "adaptive")
    if mode not in set(modes) | set(compensators):
        raise ctx.error("bounds", "mode", mode, f"is neither a mode of the scenario ({', '.join(modes)}) nor one of "
                                                f"its compensators")
    vals = {}
    for k in ("min_eta", "max_rms", "max_error"):
        v = t.get(k)
        if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v)
                              or (k != "min_eta" and v <= 0)):
            raise ctx.error("bounds", k, v, "must be a finite number" + ("" if k == "min_eta" else " > 0"))
        vals[k] = None if v is None else float(v)
    if all(v is None for v in vals.values()):
        raise ScenarioError(f"{ctx.source}: [bounds]: give at least one of min_eta, max_rms, max_error")
    return TrackingBounds(mode=mode, **vals)

