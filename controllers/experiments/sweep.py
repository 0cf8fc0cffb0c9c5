"""Parameter sweeps and Monte-Carlo studies of the closed loop: resumable, local processes or a Dask cluster.

A sweep is described by a small JSON or TOML spec::

    {
      "preset": "paper",                      # base plant (or "plant": {J, Fc, ...})
      "grid": {"Fc": [20, 25, 30], "tau": [0.01, 0.02]},      # plant parameters, full grid
      "controller": {"crossover": [10, 20]},                  # design_pi targets, full grid
      "monte_carlo": {"n": 50, "seed": 1,                     # optional random plants
                      "Fc": {"uniform": [20, 30]}, "sigma": {"normal": [40, 4]}},
      "modes": ["none", "adaptive", "frictionless"],
      "seeds": [0, 1, 2],                     # closed-loop seeds per case
      "duration": 60,
      "options": {"Vs": 0.02, "delta": 1}     # further keyword arguments of compare() (known Vs, delta: no pre-fit)
    }

Every combination of grid point x controller point x Monte-Carlo draw x seed is
one *case*; its id is a hash of its content, so reruns recognise finished cases.
Results go to one CSV (one row per case and mode), appended and flushed as each
case finishes: an interrupted sweep loses no finished case, and rerunning the
same command skips them.
"""

from __future__ import annotations

import csv
import hashlib
import itertools
import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from plant.errors import ParameterError
from plant.friction import JointParams, preset

__all__ = ["SweepSpec", "load_spec", "expand_cases", "run_case", "run_sweep", "summarize", "RESULT_FIELDS"]

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
    modes : tuple of str
    seeds : tuple of int
    duration : float
        Run length (s).
    options : dict
        Extra keyword arguments for :func:`controllers.experiments.compare.compare`.
    """

    base: dict
    grid: dict
    controller: dict
    monte_carlo: dict
    modes: tuple
    seeds: tuple
    duration: float
    options: dict


_PLANT_KEYS = ("J", "Fc", "Fs", "Vs", "delta", "sigma", "tau")
_CONTROLLER_KEYS = ("crossover", "phase_margin")
_SPEC_KEYS = {"preset", "plant", "grid", "controller", "monte_carlo", "modes", "seeds", "duration", "options"}


def load_spec(source) -> SweepSpec:
    """Read and validate a sweep spec from a ``.json``/``.toml`` file or a mapping.

    Raises
    ------
    ParameterError
        Unknown keys, unknown parameter names, empty lists, bad distributions.
    FileNotFoundError
        The file does not exist.
    """
    if isinstance(source, dict):
        d, where = source, "spec"
    else:
        path = Path(source)
        text = path.read_text()
        where = str(path)
        if path.suffix.lower() == ".toml":
            import tomllib

            try:
                d = tomllib.loads(text)
            except tomllib.TOMLDecodeError as exc:
                raise ParameterError(f"{path}: not valid TOML ({exc})") from None
        else:
            try:
                d = json.loads(text)
            except json.JSONDecodeError as exc:
                raise ParameterError(f"{path}: not valid JSON ({exc})") from None
    unknown = set(d) - _SPEC_KEYS
    if unknown:
        raise ParameterError(f"{where}: unknown key(s) {sorted(unknown)}; allowed {sorted(_SPEC_KEYS)}")
    base = preset(d.get("preset", "paper")).to_dict()
    base.update(d.get("plant", {}))
    JointParams.from_dict(base)  # validates
    grid = {k: list(v) for k, v in d.get("grid", {}).items()}
    controller = {k: list(v) for k, v in d.get("controller", {}).items()}
    for name, keys, g in (("grid", _PLANT_KEYS, grid), ("controller", _CONTROLLER_KEYS, controller)):
        for k, v in g.items():
            if k not in keys:
                raise ParameterError(f"{where}: {name} key {k!r} unknown; allowed {list(keys)}")
            if not v:
                raise ParameterError(f"{where}: {name}[{k!r}] is empty")
    mc = dict(d.get("monte_carlo", {}))
    for k, dist in mc.items():
        if k in ("n", "seed"):
            continue
        if k not in _PLANT_KEYS:
            raise ParameterError(f"{where}: monte_carlo key {k!r} unknown; allowed {list(_PLANT_KEYS)}")
        if not (isinstance(dist, dict) and len(dist) == 1 and next(iter(dist)) in ("uniform", "normal")
                and len(next(iter(dist.values()))) == 2):
            raise ParameterError(f"{where}: monte_carlo[{k!r}] must be {{'uniform': [lo, hi]}} or "
                                 f"{{'normal': [mean, std]}}, got {dist!r}")
    seeds = tuple(int(s) for s in d.get("seeds", [0]))
    modes = tuple(d.get("modes", ("none", "fixed", "adaptive", "oracle", "frictionless")))
    if not seeds or not modes:
        raise ParameterError(f"{where}: seeds and modes must not be empty")
    duration = float(d.get("duration", 60.0))
    if not duration > 0:
        raise ParameterError(f"{where}: duration must be > 0, got {duration!r}")
    return SweepSpec(base=base, grid=grid, controller=controller, monte_carlo=mc, modes=modes, seeds=seeds,
                     duration=duration, options=dict(d.get("options", {})))


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

    p = JointParams.from_dict(case["plant"])
    comp = compare(p, duration=case["duration"], seed=case["seed"], modes=case["modes"], progress=False,
                   **case["controller"], **case["options"])
    rows = []
    for r in comp.rows():
        if r["mode"] not in case["modes"]:
            continue
        row = {"case_id": case["id"], "seed": case["seed"], **case["plant"],
               **{k: case["controller"].get(k, "") for k in _CONTROLLER_KEYS}, "mode": r["mode"]}
        row.update({k: float(r[k]) for k in RESULT_FIELDS})
        rows.append(row)
    return rows


def _fields() -> list[str]:
    return ["case_id", "seed", *_PLANT_KEYS, *_CONTROLLER_KEYS, "mode", *RESULT_FIELDS]


def _finished(path: Path) -> set[str]:
    """Ids of the finished cases in ``path``; a torn last line (crash mid-write) is cut off first."""
    if not path.exists():
        return set()
    data = path.read_bytes()
    if data and not data.endswith(b"\n"):
        with path.open("r+b") as fh:
            fh.truncate(data.rfind(b"\n") + 1)
    with path.open(newline="") as fh:
        return {row["case_id"] for row in csv.DictReader(fh) if row.get("eta", "") != ""}


def run_sweep(spec: SweepSpec, out_csv, *, workers: int | None = None, scheduler: str | None = None,
              progress: bool | None = None) -> dict:
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

    Returns
    -------
    dict
        :func:`summarize` of the whole CSV, plus ``n_cases``, ``n_skipped``, ``n_run``.

    Raises
    ------
    ParameterError
        Bad ``workers``.
    ImportError
        ``scheduler`` given without dask installed.
    """
    from tqdm.auto import tqdm

    path = Path(out_csv)
    path.parent.mkdir(parents=True, exist_ok=True)
    cases = expand_cases(spec)
    done = _finished(path)
    todo = [c for c in cases if c["id"] not in done]
    if workers is None:
        workers = os.cpu_count() or 1
    if int(workers) != workers or workers < 1:
        raise ParameterError(f"workers must be an integer >= 1, got {workers!r}")
    new_file = not path.exists() or path.stat().st_size == 0
    with path.open("a", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=_fields())
        if new_file:
            writer.writeheader()
            fh.flush()

        def write(rows):
            writer.writerows(rows)
            fh.flush()
            os.fsync(fh.fileno())

        bar = tqdm(total=len(todo), desc="sweep", unit="case", disable=(None if progress is None else not progress))
        if scheduler is not None:
            from dask.distributed import Client, as_completed

            client = scheduler if isinstance(scheduler, Client) else Client(scheduler)
            try:
                futures = client.map(run_case, todo, pure=False)
                for fut in as_completed(futures):
                    write(fut.result())
                    bar.update()
            finally:
                if not isinstance(scheduler, Client):
                    client.close()
        elif workers == 1 or len(todo) <= 1:
            for case in todo:
                write(run_case(case))
                bar.update()
        else:
            from concurrent.futures import ProcessPoolExecutor, as_completed as done_iter

            with ProcessPoolExecutor(max_workers=int(workers)) as pool:
                futures = [pool.submit(run_case, c) for c in todo]
                for fut in done_iter(futures):
                    write(fut.result())
                    bar.update()
        bar.close()
    summary = summarize(path)
    summary.update(n_cases=len(cases), n_skipped=len(cases) - len(todo), n_run=len(todo))
    return summary


def summarize(out_csv) -> dict:
    """Per-mode statistics (count, mean, std, min, max of each metric) of a results CSV.

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
            stats[k] = {"mean": float(np.nanmean(a)), "std": float(np.nanstd(a)), "min": float(np.nanmin(a)),
                        "max": float(np.nanmax(a))}
        out["modes"][mode] = stats
    return out
