"""Parameter sweeps and Monte-Carlo studies of the closed loop: resumable, local processes or a Dask cluster.

A sweep is described by a small JSON or TOML spec (``examples/sweep_grid.json``,
``examples/sweep_monte_carlo.json``), e.g.::

    {
      "preset": "paper",
      "grid": {"Fc": [20, 25, 30], "tau": [0.01, 0.02]},
      "controller": {"crossover": [10, 20]},
      "monte_carlo": {"n": 50, "seed": 1, "Fc": {"uniform": [20, 30]}, "sigma": {"normal": [40, 4]}},
      "modes": ["none", "adaptive", "frictionless"],
      "seeds": [0, 1, 2],
      "duration": 60,
      "options": {"Vs": 0.02, "delta": 1}
    }

``preset`` (or ``plant``: ``{J, Fc, ...}`` overriding it) is the base plant;
``grid`` a full grid of plant parameters; ``controller`` a grid of
:func:`controllers.design_pi` targets; ``monte_carlo`` optional random plants
(``uniform: [lo, hi]`` or ``normal: [mean, std]`` per parameter); ``seeds``
closed-loop seeds (integers >= 0); ``duration`` the run length in s;
``options`` further keyword arguments of ``compare()`` (e.g. known ``Vs``,
``delta``: no Stribeck pre-fit); ``compensators`` your own compensators by
import path, run in every case beside the modes, as the ``[compensators]`` of a
scenario file (``{"mine": {"factory": "my_comp.py:Mine", "gain": 2.0}}``, a
file relative to the spec's folder). All values in SI units.

``random_plants`` draws joints of every plant model (lagged Stribeck, LuGre,
Karnopp, asymmetric; with or without drift) with
:func:`controllers.experiments.zoo.draw_plants`, the drawing code of the plant
zoo; ``box`` may change any field of :class:`controllers.experiments.zoo.ZooBox`.
It replaces the base plant (not combined with ``grid``/``monte_carlo``), e.g.
``"random_plants": {"n": 20, "seed": 1, "box": {"models": ["lugre", "karnopp"], "J": [0.1, 5]}}``.

Every combination of grid point x controller point x Monte-Carlo draw x seed is
one *case*; its id is a hash of its content, so reruns recognise finished cases.
Results go to one CSV (one row per case and mode, SI units), appended, flushed
and fsynced as each case finishes. SIGINT (Ctrl-C) terminates the workers at
once and keeps every finished case; rerunning the same command skips the
finished cases and reruns any case whose rows are incomplete (a crash or
``kill -9`` in the middle of writing), after removing those rows.
"""

from __future__ import annotations

import csv
import hashlib
import itertools
import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from plant.errors import ParameterError
from plant.friction import JointParams, preset

__all__ = ["SweepSpec", "SweepInterrupted", "load_spec", "expand_cases", "check_case", "run_case", "run_sweep",
           "summarize", "RESULT_FIELDS", "DEFAULT_MODES", "MAX_CASES"]

#: Metric columns of the results CSV (SI units: rad/s, N·m).
RESULT_FIELDS = ("rms", "max", "rms_reversal", "u_rms", "eta")


@dataclass(frozen=True)
class SweepSpec:
    """A validated sweep description (see the module docstring for the format).

    Attributes
    ----------
    base : dict
        Base plant parameters (SI units).
    grid : dict[str, list]
        Plant-parameter grid.
    controller : dict[str, list]
        Grid of :func:`controllers.design_pi` targets (``crossover``, ``phase_margin``).
    monte_carlo : dict
        Random plant draws (``n``, ``seed`` and per-parameter distributions).
    seeds : tuple of int
    compare : CompareOptions
        The comparison of every case (:class:`controllers.experiments.compare.CompareOptions`: the spec's
        ``duration``, ``modes`` and ``options``), which checks them; a case sets its seed and its controller targets.
    options : dict
        The spec's ``options`` as written (flat keywords of :meth:`CompareOptions.from_flat`): a case carries them
        to its worker and its id hashes them.
    random_plants : dict
        ``{"n", "seed", "box"}`` of random joints of every model (empty: none).
    compensators : dict
        Your own compensators by import path (``{name: "module:factory"}`` or ``{name: {"factory":
        "file.py:factory", **keywords}}``, files made absolute), run in every case beside the modes (empty: none).
    """

    base: dict
    grid: dict
    controller: dict
    monte_carlo: dict
    seeds: tuple
    compare: object
    options: dict
    random_plants: dict = field(default_factory=dict)
    compensators: dict = field(default_factory=dict)

    @property
    def modes(self) -> tuple:
        """The modes of every case, :attr:`compare`'s."""
        return tuple(self.compare.modes)

    @property
    def duration(self) -> float:
        """Run length (s) of every case, :attr:`compare`'s."""
        return self.compare.duration


_PLANT_KEYS = ("J", "Fc", "Fs", "Vs", "delta", "sigma", "tau")
_CONTROLLER_KEYS = ("crossover", "phase_margin")
_SPEC_KEYS = {"preset", "plant", "grid", "controller", "monte_carlo", "modes", "seeds", "duration", "options"}
#: Fields of CompareOptions that the spec sets by its own keys (not through "options").
_OWN_OPTIONS = ("duration", "seed", "modes", "crossover", "phase_margin", "controller", "compensators", "reference")


#: Most cases one spec may expand to (a typo like "n": 1e9 fails at once instead of exhausting memory).
MAX_CASES = 1_000_000


def _is_number(x) -> bool:
    try:
        return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)
    except OverflowError:  # an integer beyond the float range
        return False


def _read_spec_file(path: Path) -> dict:
    """The spec mapping of a .json or .toml file (typed errors for every unreadable file)."""
    from plant.models import read_json

    if path.suffix.lower() != ".toml":
        d = read_json(path, what="sweep spec")
    else:
        import tomllib

        if path.is_dir() or not path.exists():
            read_json(path, what="sweep spec")  # the same directory / not-found errors
        try:
            d = tomllib.loads(path.read_bytes().decode("utf-8-sig"))
        except UnicodeDecodeError as exc:
            raise ParameterError(f"{path}: not a UTF-8 text file ({exc.reason} at byte {exc.start})") from None
        except tomllib.TOMLDecodeError as exc:
            raise ParameterError(f"{path}: not valid TOML ({exc})") from None
    if not isinstance(d, dict):
        raise ParameterError(f"{path}: a sweep spec must be a JSON/TOML object with keys {sorted(_SPEC_KEYS)}, "
                             f"got a {type(d).__name__}")
    return d


def _number_lists(where: str, name: str, value, keys) -> dict:
    """``{key: [finite numbers]}`` from a spec section (``grid`` or ``controller``), validated."""
    if not isinstance(value, dict):
        raise ParameterError(f"{where}: {name} must be an object {{key: [values]}}, got {value!r}")
    out = {}
    for k, v in value.items():
        if k not in keys:
            raise ParameterError(f"{where}: {name} key {k!r} unknown; allowed {list(keys)}")
        if not isinstance(v, list):
            raise ParameterError(f"{where}: {name}[{k!r}] must be a list of numbers, got {v!r}")
        if not v:
            raise ParameterError(f"{where}: {name}[{k!r}] is empty")
        bad = [x for x in v if not _is_number(x)]
        if bad:
            raise ParameterError(f"{where}: {name}[{k!r}] holds {bad[0]!r}, not a finite number")
        out[k] = list(v)  # as written: the case ids hash the values
    return out


def _count(where: str, name: str, value, lo: int = 0) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < lo:
        raise ParameterError(f"{where}: {name} must be an integer >= {lo}, got {value!r}")
    return value


def _monte_carlo(where: str, value) -> dict:
    """The validated ``monte_carlo`` section: ``n``, ``seed`` and ``{param: {"uniform"|"normal": [a, b]}}``."""
    if not isinstance(value, dict):
        raise ParameterError(f"{where}: monte_carlo must be an object, got {value!r}")
    mc = dict(value)
    for k, dist in mc.items():
        if k in ("n", "seed"):
            _count(where, f"monte_carlo[{k!r}]", dist)
            continue
        if k not in _PLANT_KEYS:
            raise ParameterError(f"{where}: monte_carlo key {k!r} unknown; allowed {list(_PLANT_KEYS)}")
        ok = (isinstance(dist, dict) and len(dist) == 1 and next(iter(dist)) in ("uniform", "normal")
              and isinstance(next(iter(dist.values())), list) and len(next(iter(dist.values()))) == 2
              and all(_is_number(x) for x in next(iter(dist.values()))))
        if not ok:
            raise ParameterError(f"{where}: monte_carlo[{k!r}] must be {{'uniform': [lo, hi]}} or "
                                 f"{{'normal': [mean, std]}} with finite numbers, got {dist!r}")
        kind, (a, b) = next(iter(dist.items()))
        if (kind == "uniform" and not a <= b) or (kind == "normal" and b < 0):
            raise ParameterError(f"{where}: monte_carlo[{k!r}]: need lo <= hi (uniform) or std >= 0 (normal), "
                                 f"got {dist!r}")
    return mc


def _compare_options(where: str, value, modes: tuple, duration: float):
    """The comparison of every case: the ``options`` section (flat keywords of :meth:`CompareOptions.from_flat`
    but those the spec has keys of its own for) with the spec's ``modes`` and ``duration``, checked by
    :class:`CompareOptions` (the message names the file and the section)."""
    from controllers.experiments.compare import CompareOptions

    if not isinstance(value, dict):
        raise ParameterError(f"{where}: options must be an object of compare() settings, got {value!r}")
    allowed = [k for k in CompareOptions.flat_names() if k not in _OWN_OPTIONS]
    unknown = [k for k in value if k not in allowed]
    if unknown:
        raise ParameterError(f"{where}: options key(s) {unknown} unknown; allowed {allowed} (duration, seeds, "
                             "modes and the controller targets have keys of their own)")
    try:
        return CompareOptions.from_flat(duration=duration, modes=modes, **value)
    except (ParameterError, TypeError, ValueError) as exc:
        raise ParameterError(f"{where}: options: {exc}") from None


def _modes_seeds_duration(where: str, d: dict) -> tuple:
    from controllers.simulation.compensators import MODES

    modes, seeds, duration = d.get("modes", DEFAULT_MODES), d.get("seeds", [0]), d.get("duration", 60.0)
    if not isinstance(modes, (list, tuple)) or not modes or not all(isinstance(m, str) for m in modes):
        raise ParameterError(f"{where}: modes must be a non-empty list of mode names, got {modes!r}")
    unknown = [m for m in modes if m not in MODES]
    if unknown:
        raise ParameterError(f"{where}: unknown mode(s) {unknown}; known {list(MODES)}")
    if not isinstance(seeds, list) or not seeds:
        raise ParameterError(f"{where}: seeds must be a non-empty list of integers >= 0, got {seeds!r}")
    for s in seeds:
        _count(where, "every seed", s)
    if not _is_number(duration) or not duration > 0:
        raise ParameterError(f"{where}: duration must be a number > 0 (s), got {duration!r}")
    return tuple(modes), tuple(seeds), float(duration)


#: Modes of a spec without a "modes" key.
DEFAULT_MODES = ("none", "fixed", "adaptive", "oracle", "frictionless")

_SPEC_KEYS = {"preset", "plant", "grid", "controller", "monte_carlo", "modes", "seeds", "duration", "options",
              "random_plants", "compensators"}
_RANDOM_KEYS = {"n", "seed", "box"}


def load_spec(source) -> SweepSpec:
    """Read and validate a sweep spec from a ``.json``/``.toml`` file or a mapping.

    Parameters
    ----------
    source : str, os.PathLike or dict
        The spec file (UTF-8 JSON or TOML) or the spec itself (module docstring for the keys).

    Returns
    -------
    SweepSpec

    Raises
    ------
    ParameterError
        Not a readable UTF-8 JSON/TOML object (a directory, bad bytes, bad
        syntax); unknown keys or parameter names; a value of the wrong type
        (grid or controller entries not lists of finite numbers, seeds not
        integers >= 0, unknown modes, duration not > 0); bad distributions;
        unknown or invalid ``options``; a base plant out of range or
        implausible (:func:`plant.models.check_plausible`). The message names
        the file and the key.
    FileNotFoundError
        The file does not exist.
    """
    from plant.models import check_plausible

    if isinstance(source, dict):
        d, where = source, "spec"
    else:
        d, where = _read_spec_file(Path(source)), str(source)
    unknown = set(d) - _SPEC_KEYS
    if unknown:
        raise ParameterError(f"{where}: unknown key(s) {sorted(unknown)}; allowed {sorted(_SPEC_KEYS)}")
    name, plant = d.get("preset", "paper"), d.get("plant", {})
    if not isinstance(name, str):
        raise ParameterError(f"{where}: preset must be a name, got {name!r}")
    if not isinstance(plant, dict):
        raise ParameterError(f"{where}: plant must be an object of parameters {list(_PLANT_KEYS)}, got {plant!r}")
    base = preset(name).to_dict()
    base.update(plant)
    try:
        check_plausible(JointParams.from_dict(base), where=f"{where}: plant")
    except (TypeError, OverflowError) as exc:
        raise ParameterError(f"{where}: plant: {exc}") from None
    grid = _number_lists(where, "grid", d.get("grid", {}), _PLANT_KEYS)
    controller = _number_lists(where, "controller", d.get("controller", {}), _CONTROLLER_KEYS)
    mc = _monte_carlo(where, d.get("monte_carlo", {}))
    modes, seeds, duration = _modes_seeds_duration(where, d)
    n_cases = math.prod(len(v) for v in grid.values()) * math.prod(len(v) for v in controller.values())
    n_cases *= max(1, mc.get("n", 0) or 0) * len(seeds)
    if n_cases > MAX_CASES:
        raise ParameterError(f"{where}: the spec expands to {n_cases} cases, more than {MAX_CASES}; "
                             "split the study or reduce the grid / monte_carlo n")
    random_plants = _random_plants(d.get("random_plants"), grid or mc.get("n"), where)
    if random_plants and random_plants["n"] * len(seeds) * math.prod(len(v) for v in controller.values()) > MAX_CASES:
        raise ParameterError(f"{where}: random_plants.n x seeds x controller points is more than {MAX_CASES} cases")
    own = _own_compensators(d.get("compensators", {}), Path(where).parent if not isinstance(source, dict) else Path("."),
                            where)
    options = d.get("options", {})
    return SweepSpec(base=base, grid=grid, controller=controller, monte_carlo=mc, seeds=seeds,
                     compare=_compare_options(where, options, modes, duration), options=dict(options),
                     random_plants=random_plants, compensators=own)


def _own_compensators(table, base: Path, where: str) -> dict:
    """The spec's ``compensators``, checked (importable, not a mode's name: ``compensator_factories``), with
    every ``file.py`` made absolute against the spec's folder (the cases run in other processes and folders)."""
    from controllers.experiments.scenario import compensator_factories

    compensator_factories(table, base_dir=base, source=f"{where}: compensators")
    out = {}
    for name, spec in table.items():
        spec = {"factory": spec} if isinstance(spec, str) else dict(spec)
        mod, _, attr = spec["factory"].partition(":")
        if mod.endswith(".py") and not Path(mod).is_absolute():
            spec["factory"] = f"{(base / mod).resolve()}:{attr}"
        out[name] = spec
    return out


def _random_plants(rp, combined, where: str) -> dict:
    """Validate the ``random_plants`` entry (n >= 1, seed, a box of :class:`controllers.experiments.zoo.ZooBox`)."""
    if rp is None:
        return {}
    from controllers.experiments.zoo import zoo_box

    if not isinstance(rp, dict) or set(rp) - _RANDOM_KEYS:
        raise ParameterError(f"{where}: random_plants must be an object with keys {sorted(_RANDOM_KEYS)}, got {rp!r}")
    if combined:
        raise ParameterError(f"{where}: random_plants cannot be combined with grid or monte_carlo")
    n = rp.get("n")
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ParameterError(f"{where}: random_plants.n must be an integer >= 1, got {n!r}")
    try:
        zoo_box(rp.get("box"))
    except (ParameterError, TypeError) as exc:
        raise ParameterError(f"{where}: random_plants.box: {exc}") from None
    return {"n": n, "seed": int(rp.get("seed", 0)), "box": dict(rp.get("box") or {})}


def _case_id(case: dict) -> str:
    return hashlib.sha1(json.dumps(case, sort_keys=True).encode()).hexdigest()[:16]


def expand_cases(spec: SweepSpec) -> list[dict]:
    """All cases of a spec, in a deterministic order, each with a content-hash ``id``.

    Returns
    -------
    list of dict
        Keys ``id``, ``plant`` (dict), ``controller`` (dict), ``seed``, ``modes``,
        ``duration``, ``options``.
    """
    plants = []
    gk = list(spec.grid)
    for values in itertools.product(*(spec.grid[k] for k in gk)) if gk else [()]:
        p = dict(spec.base)
        p.update(dict(zip(gk, values)))
        plants.append(p)
    rp = spec.random_plants
    if rp:
        from controllers.experiments.compare import comparison_reference
        from controllers.experiments.zoo import draw_plants, zoo_box

        ref = comparison_reference(spec.compare.replace(seed=0))
        plants = draw_plants(rp["n"], ref, seed=rp["seed"], box=zoo_box(rp["box"]))
    mc = spec.monte_carlo
    if mc.get("n"):
        rng = np.random.default_rng(int(mc.get("seed", 0)))
        drawn = []
        for p in plants:
            for _ in range(int(mc["n"])):
                q = dict(p)
                for k, dist in mc.items():
                    if k in ("n", "seed"):
                        continue
                    kind, (a, b) = next(iter(dist.items()))
                    q[k] = float(rng.uniform(a, b) if kind == "uniform" else rng.normal(a, b))
                drawn.append(q)
        plants = drawn
    ck = list(spec.controller)
    ctrls = [dict(zip(ck, v)) for v in itertools.product(*(spec.controller[k] for k in ck))] if ck else [{}]
    cases = []
    for p in plants:
        for c in ctrls:
            for seed in spec.seeds:
                case = {"plant": p, "controller": c, "seed": seed, "modes": list(spec.modes),
                        "duration": spec.duration, "options": spec.options}
                if spec.compensators:  # only then: the ids of cases without them stay as they were
                    case["compensators"] = spec.compensators
                case["id"] = _case_id(case)
                cases.append(case)
    return cases


def run_case(case: dict) -> list[dict]:
    """Run one case (all its modes) and return one flat row per mode.

    Returns
    -------
    list of dict
        ``case_id``, ``seed``, the plant and controller parameters, ``mode`` and
        the metrics of :data:`RESULT_FIELDS` (second half of the run).

    Raises
    ------
    ParameterError
        Invalid plant or controller values in the case.
    """
    from controllers.experiments.compare import compare
    from plant.models import plant_from_dict

    p = plant_from_dict(case["plant"])
    own = case.get("compensators") or {}
    if own:
        from controllers.experiments.scenario import compensator_factories

        own = compensator_factories(own, source=f"case {case.get('id')}: compensators")
    comp = compare(p, duration=case["duration"], seed=case["seed"], modes=case["modes"], progress=False,
                   compensators=own or None, **case["controller"], **case["options"])
    rows = []
    for r in comp.rows():
        if r["mode"] not in case["modes"] and r["mode"] not in own:
            continue
        row = {"case_id": case["id"], "seed": case["seed"], **{k: case["plant"].get(k, "") for k in _PLANT_KEYS},
               **{k: case["controller"].get(k, "") for k in _CONTROLLER_KEYS}, "mode": r["mode"]}
        row.update({k: math.nan if r[k] is None else float(r[k]) for k in RESULT_FIELDS})  # None: an undefined eta
        rows.append(row)
    return rows


def _fields() -> list[str]:
    return ["case_id", "seed", *_PLANT_KEYS, *_CONTROLLER_KEYS, "mode", *RESULT_FIELDS]


class SweepInterrupted(KeyboardInterrupt):
    """A sweep stopped by SIGINT (Ctrl-C) after writing every finished case.

    Attributes
    ----------
    path : str
        The results CSV.
    n_written : int
        Cases finished and written during this run.
    n_todo : int
        Cases this run had to do.
    """

    def __init__(self, path: str, n_written: int, n_todo: int):
        super().__init__(f"sweep interrupted: {n_written} of {n_todo} cases finished and written to {path}; "
                         "rerun the same command to resume")
        self.path, self.n_written, self.n_todo = path, n_written, n_todo


def check_case(case: dict) -> None:
    """Raise unless a case's plant and controller targets are valid (run before any case starts).

    Raises
    ------
    ParameterError
        Plant parameters out of range or implausible
        (:func:`plant.models.check_plausible` of any plant model, e.g. a Monte-Carlo draw of a
        negative ``J``), a crossover not > 0 or a phase margin outside (0, 90)
        deg; the message names the case's values.
    """
    from plant.models import check_plausible, plant_from_dict

    desc = ", ".join(f"{k}={v:g}" if _is_number(v) else f"{k}={v}" for k, v in case["plant"].items())
    try:
        check_plausible(plant_from_dict(case["plant"]), where=f"case {case['id']} ({desc})")
    except (ParameterError, TypeError, OverflowError) as exc:
        msg = str(exc)
        raise ParameterError(msg if msg.startswith("case ") else f"case {case['id']} ({desc}): {msg}") from None
    c = case["controller"]
    if "crossover" in c and not c["crossover"] > 0:
        raise ParameterError(f"case {case['id']}: controller crossover must be > 0 rad/s, got {c['crossover']!r}")
    if "phase_margin" in c and not 0 < c["phase_margin"] < 90:
        raise ParameterError(f"case {case['id']}: controller phase_margin must be in (0, 90) deg, "
                             f"got {c['phase_margin']!r}")


def _complete_row(row: dict) -> bool:
    """Every field of a results row present and the metrics numbers (``nan`` allowed: an undefined eta)."""
    if any(row.get(k) in (None, "") for k in ("case_id", "mode", *RESULT_FIELDS)):
        return False
    try:
        [float(row[k]) for k in RESULT_FIELDS]
    except ValueError:
        return False
    return True


def _finished(path: Path, cases: list[dict]) -> set[str]:
    """Ids of the cases of ``cases`` whose rows in ``path`` are complete; the file is repaired first.

    A case counts as finished only when ``path`` holds one complete row for every
    one of its modes. A torn last line (a crash mid-write) is cut off, and the
    rows of unfinished cases are removed (atomically: a new file replaces the
    old), so that rerunning them leaves no duplicates. Rows of cases not in
    ``cases`` are kept as they are.

    Raises
    ------
    ParameterError
        ``path`` exists but is not a results table of a sweep (another header).
    """
    if not path.exists() or path.stat().st_size == 0:
        return set()
    data = path.read_bytes()
    if not data.endswith(b"\n"):
        data = data[:data.rfind(b"\n") + 1]
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise ParameterError(f"{path}: not a results table of a sweep (not UTF-8 text)") from None
    lines = text.splitlines(keepends=True)
    if not lines:
        return set()
    header = next(csv.reader([lines[0]]))
    if header != _fields():
        raise ParameterError(f"{path}: not a results table of this sweep (header {header[:4]}...); "
                             "choose another --out")
    rows = list(csv.DictReader(lines))
    expected = {c["id"]: set(c["modes"]) | set(c.get("compensators") or ()) for c in cases}
    got: dict[str, set] = {}
    for r in rows:
        if _complete_row(r):
            got.setdefault(r["case_id"], set()).add(r["mode"])
    done = {cid for cid, modes in got.items() if cid in expected and modes >= expected[cid]}
    keep = [ln for ln, r in zip(lines[1:], rows)
            if _complete_row(r) and (r["case_id"] in done or r["case_id"] not in expected)]
    if len(keep) != len(lines) - 1 or len(data) != path.stat().st_size:
        tmp = path.with_name(path.name + ".tmp")
        with tmp.open("w", newline="") as fh:
            fh.write(lines[0] + "".join(keep))
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    return done


class _Writer:
    """Appends the rows of one case to the results CSV in a single write, flushed and fsynced."""

    def __init__(self, fh):
        self.fh = fh
        self.busy = False

    def write(self, rows: list[dict]) -> None:
        import io

        buf = io.StringIO()
        csv.DictWriter(buf, fieldnames=_fields(), lineterminator="\n").writerows(rows)
        self.busy = True
        try:
            self.fh.write(buf.getvalue())
            self.fh.flush()
            os.fsync(self.fh.fileno())
        finally:
            self.busy = False


def _ignore_sigint() -> None:
    """Worker initializer: SIGINT goes to the parent, which stops the pool (and writes what finished)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _run_pool(todo: list[dict], workers: int, writer: _Writer, bar, stop) -> int:
    """Run ``todo`` on a local process pool; write each case as it finishes; return the cases written.

    ``stop()`` is polled every 0.1 s; when it turns true (SIGINT) the workers are
    terminated at once (``multiprocessing.Pool.terminate``) after the finished
    cases already received are written.
    """
    import multiprocessing
    import queue

    results: queue.Queue = queue.Queue()
    written = 0
    pool = multiprocessing.Pool(processes=workers, initializer=_ignore_sigint)
    try:
        for case in todo:
            pool.apply_async(run_case, (case,), callback=lambda rows: results.put(("ok", rows)),
                             error_callback=lambda exc, c=case: results.put(("error", (c, exc))))
        pool.close()
        while written < len(todo) and not stop():
            try:
                kind, value = results.get(timeout=0.1)
            except queue.Empty:
                continue
            if kind == "error":
                case, exc = value
                raise ParameterError(f"case {case['id']} failed: {type(exc).__name__}: {exc}") from None
            writer.write(value)
            written += 1
            bar.update()
        while not results.empty():  # finished while stopping: keep them
            kind, value = results.get_nowait()
            if kind == "ok":
                writer.write(value)
                written += 1
    finally:
        pool.terminate()
        pool.join()
    return written


def _run_dask(todo: list[dict], scheduler, writer: _Writer, bar) -> int:
    from dask.distributed import Client, as_completed

    client = scheduler if isinstance(scheduler, Client) else Client(scheduler)
    written = 0
    futures = client.map(run_case, todo, pure=False)
    try:
        for fut in as_completed(futures):
            writer.write(fut.result())
            written += 1
            bar.update()
    finally:
        client.cancel(futures)
        if not isinstance(scheduler, Client):
            client.close()
    return written


class _Sigint:
    """SIGINT handling of a sweep: a flag while writing (never tears a case), else KeyboardInterrupt."""

    def __init__(self, writer: _Writer, raise_now: bool):
        self.writer, self.raise_now, self.hit, self.previous = writer, raise_now, False, None

    def __enter__(self):
        import signal
        import threading

        if threading.current_thread() is threading.main_thread():
            self.previous = signal.signal(signal.SIGINT, self._handler)
        return self

    def __exit__(self, *exc):
        import signal

        if self.previous is not None:
            signal.signal(signal.SIGINT, self.previous)
        return False

    def _handler(self, signum, frame):
        self.hit = True
        if self.raise_now and not self.writer.busy:
            raise KeyboardInterrupt


def run_sweep(spec: SweepSpec, out_csv, *, workers: int | None = None, scheduler: str | None = None,
              progress: bool | None = None, check=None) -> dict:
    """Run every unfinished case of ``spec``, appending rows to ``out_csv``; return the summary.

    Parameters
    ----------
    spec : SweepSpec
    out_csv : str or Path
        Results table; created with a header, or appended to (finished cases skipped).
    workers : int, keyword-only
        Local processes; default all cores (``os.cpu_count()``); 1 runs in this process.
    scheduler : str, keyword-only
        Address of a running Dask scheduler (``tcp://host:8786``) or a
        ``dask.distributed.Client``; then the cases run on that cluster
        (needs the ``dask`` extra: ``pip install adaptive-ff[dask]``).
    progress : bool, keyword-only
        Progress bar; default when stderr is a terminal.
    check : callable, keyword-only, optional
        ``check(cases)``, called with the cases still to run before any of them runs (e.g. ``adaptive-ff sweep``'s
        work bound); an exception it raises stops the sweep there.

    Returns
    -------
    dict
        :func:`summarize` of the whole CSV, plus ``n_cases``, ``n_skipped``, ``n_run``.

    Raises
    ------
    ParameterError
        Bad ``workers``; ``out_csv`` not a results table of a sweep; a case
        with invalid values (:func:`check_case`, before any case runs); a
        duration whose comparisons do not fit into the memory available in
        every local worker at once (before any case runs,
        :meth:`controllers.experiments.compare.CompareOptions.check_memory`); a case
        that failed in a worker (the cases finished before it are written).
    SweepInterrupted
        SIGINT (Ctrl-C): the workers are terminated at once, every finished
        case is written, the rest is left for a rerun.
    ImportError
        ``scheduler`` given without dask installed.

    Notes
    -----
    The rows of a case are appended in one write, flushed and fsynced. On a
    rerun a case counts as finished only when all its mode rows are complete
    (:func:`_finished` also drops the rows of a partly written case), so even
    a ``kill -9`` mid-write loses at most the cases then running.
    """
    from tqdm.auto import tqdm

    if workers is None:
        workers = os.cpu_count() or 1
    if isinstance(workers, bool) or int(workers) != workers or workers < 1:
        raise ParameterError(f"workers must be an integer >= 1, got {workers!r}")
    path = Path(out_csv)
    cases = expand_cases(spec)
    for case in cases:
        check_case(case)
    path.parent.mkdir(parents=True, exist_ok=True)
    done = _finished(path, cases)
    todo = [c for c in cases if c["id"] not in done]
    if check is not None:
        check(todo)
    if todo:  # every worker holds one comparison at a time: refused before any case runs if they do not fit
        parallel = 1 if scheduler is not None or workers == 1 else min(int(workers), len(todo))
        spec.compare.check_memory(processes=parallel)
    new_file = not path.exists() or path.stat().st_size == 0
    written = 0
    with path.open("a", newline="") as fh:
        writer = _Writer(fh)
        if new_file:
            fh.write(",".join(_fields()) + "\n")
            fh.flush()
        bar = tqdm(total=len(todo), desc="sweep", unit="case", disable=(None if progress is None else not progress))
        serial = scheduler is None and (workers == 1 or len(todo) <= 1)
        with _Sigint(writer, raise_now=serial or scheduler is not None) as sigint:
            try:
                if scheduler is not None:
                    written = _run_dask(todo, scheduler, writer, bar)
                elif serial:
                    for case in todo:
                        rows = run_case(case)
                        writer.write(rows)
                        written += 1
                        bar.update()
                        if sigint.hit:
                            raise KeyboardInterrupt
                else:
                    written = _run_pool(todo, int(workers), writer, bar, lambda: sigint.hit)
            except KeyboardInterrupt:
                sigint.hit = True
            finally:
                bar.close()
        if sigint.hit:
            raise SweepInterrupted(str(path), written, len(todo))
    summary = summarize(path)
    summary.update(n_cases=len(cases), n_skipped=len(cases) - len(todo), n_run=len(todo))
    return summary


def summarize(out_csv) -> dict:
    """Per-mode statistics (count, mean, std, min, max of each metric over its finite values, NaN where there are
    none, e.g. the eta of a joint without friction) of a results CSV.

    Returns
    -------
    dict
        ``{"modes": {mode: {metric: {"mean", "std", "min", "max"}, "n": int}}}``.
    """
    with Path(out_csv).open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    out: dict = {"modes": {}}
    for mode in sorted({r["mode"] for r in rows}):
        sel = [r for r in rows if r["mode"] == mode]
        stats = {"n": len(sel)}
        for k in RESULT_FIELDS:
            a = np.array([float(r[k]) for r in sel])
            a = a[np.isfinite(a)]  # nan: an undefined eta (a joint without friction) or a diverged run
            stats[k] = ({"mean": float(np.mean(a)), "std": float(np.std(a)), "min": float(np.min(a)),
                         "max": float(np.max(a))} if a.size else dict.fromkeys(("mean", "std", "min", "max"), math.nan))
        out["modes"][mode] = stats
    return out
