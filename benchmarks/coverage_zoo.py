"""Do the 95 % intervals of ``identify`` cover the truth on many different joints?

Run ``python benchmarks/coverage_zoo.py [--n 40] [--start 0] [--duration 15] [--n-bootstrap 20]
[--no-lag-profile] [--input-quantum auto] [--kinds oe eq4 default] [--jobs 1] [--out rows.jsonl]`` (or ``--table-from
rows.jsonl [more.jsonl ...]``: the table of the records earlier, possibly unfinished, runs saved; the rows of one
seed in several files are merged, each kind from the file that has it).

Joints: ``n`` joints of eqs. 1-3 drawn per seed (``numpy.random.default_rng(seed)``) around the ``paper``
preset, the way the plant zoo (:mod:`controllers.experiments.zoo`) randomises a preset: ``J``
log-uniform in 1-10 kg·m², ``Fc`` uniform in 10-40 N·m, ``Fs/Fc`` uniform in 1.2-1.6, ``Vs`` log-uniform in
0.01-0.05 rad/s, ``delta`` uniform in 0.7-1.5, ``sigma`` uniform in 20-60 N·m·s/rad, ``tau`` log-uniform in
5-50 ms (:func:`draw_joint`). Each is driven open loop by the band-limited torque of Sec. IV-A (scaled to its
own friction) and read out as in ``benchmarks/coverage.py``: white velocity noise 1 % of the peak velocity,
input quantisation 0.6 N·m, the Fig. 10 sampling scaled to a 10 ms base (``record`` of
``benchmarks/identification.py``, same seed).

Each output-error row also keeps its interval's parts per parameter (``stderr_refits``, ``stderr_delay``,
``bias`` of ``info["bootstrap"]``).

Fits, all through :func:`adaptive_ff.identification.identify.identify` with ``Vs`` and ``delta`` given (the
pre-fit's values are the true ones: the intervals are conditional on them) and ``lag=True``:

* ``oe``: ``method="output_error"`` (``fit_physical``: free-run fit on the record's own stamps, its
  bootstrap of the fit's residuals, ``--n-bootstrap`` refits), interval ``interval95`` of the report;
* ``eq4``: ``method="paper"`` (eq. 4 LS on the record resampled to a uniform grid), interval from the
  residual block bootstrap of :mod:`adaptive_ff.identification.uncertainty` (200 refits), and ``eq4 delta``:
  ``value ± 1.96 std_delta`` (the white-noise delta method);
* ``default``: ``identify`` as the CLI calls it by default (``method="auto"``, no options but ``bootstrap_workers=1``, which
  does not change the result), interval ``interval95``; the method it chose and the parameters its
  ``model_form`` warnings name are kept in the row (``default_method``, ``default_named``).

``--input-quantum`` passes ``bootstrap_input_quantum`` to the ``oe`` and ``default`` fits: ``auto`` or a
resolution in N·m, the quantum their bootstrap worlds read the torque with
(:class:`adaptive_ff.identification.oe_options.OutputErrorOptions`; ``0``: the logged torque taken as exact);
without it, the package's default (``"auto"``).

``--kinds`` runs a subset (``eq4`` also gives ``eq4 delta``); a kind not run is left out of the table.

Prints per parameter the coverage (%) of each kind of interval, the median of ``|error| / stderr`` (0.67 for
exact normal intervals) and the median relative error, then the coverage's Wilson 95 % score interval (the
binomial sampling error of a count on this many joints, Wilson 1927) and the seeds missed. Target: ``oe`` coverage in 90-98 % for every
parameter (exit status 1 if not; the ``eq4`` rows are reported, not judged: eq. 4's discretisation and
errors-in-variables bias, docs/benchmarks/identification.md, is common to every bootstrap refit).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from identification import INPUT_DELAY, KEYS, QUANT, record  # noqa: E402

from adaptive_ff.identification.covariance import bias_corrected_interval  # noqa: E402
from adaptive_ff.identification.identify import identify  # noqa: E402
from adaptive_ff.io.data import MeasuredData  # noqa: E402
from plant import preset  # noqa: E402

Z95 = 1.959963984540054
KINDS = ("oe", "eq4", "eq4 delta", "default")
TARGET = (90.0, 98.0)


def draw_joint(seed: int):
    """The joint of ``seed``: the ``paper`` preset with every parameter drawn from the box of the module docstring."""
    rng = np.random.default_rng(seed)
    lu = lambda lo, hi: float(math.exp(rng.uniform(math.log(lo), math.log(hi))))  # noqa: E731
    J, Fc = lu(1.0, 10.0), float(rng.uniform(10.0, 40.0))
    Fs, Vs, delta = Fc * float(rng.uniform(1.2, 1.6)), lu(0.01, 0.05), float(rng.uniform(0.7, 1.5))
    sigma, tau = float(rng.uniform(20.0, 60.0)), lu(0.005, 0.05)
    return dataclasses.replace(preset("paper"), J=J, Fc=Fc, Fs=Fs, Vs=Vs, delta=delta, sigma=sigma, tau=tau)


def _kind_row(rep, p, kind: str) -> dict:
    """Per parameter: error, standard error and interval half-widths (low, high distances) of one report."""
    if kind == "eq4 delta":
        std = rep.std
        return {k: {"err": getattr(rep.estimate, k) - getattr(p, k), "se": std[k],
                    "lo": Z95 * std[k], "hi": Z95 * std[k]} for k in KEYS}
    iv, se = rep.interval95, rep.stderr
    out = {k: {"err": rep.params[k] - getattr(p, k), "se": se[k], "lo": rep.params[k] - iv[k][0],
               "hi": iv[k][1] - rep.params[k]} for k in KEYS}
    boot = (rep.physical.info.get("bootstrap") or {}) if getattr(rep, "physical", None) is not None else {}
    for part in ("stderr_refits", "stderr_delay", "bias"):  # the output-error interval's parts, where it has them
        for k in KEYS:
            if isinstance(boot.get(part), dict) and k in boot[part]:
                out[k][part] = float(boot[part][k])
                out[k]["n_valid"] = int(boot["n_valid"])
    return out


def rescored(rows: list, n_bootstrap: int) -> list:
    """``rows`` with every interval that keeps its parts (``stderr_refits``, ``bias``, ``stderr_delay`` if any and
    ``n_valid``, else ``n_bootstrap``) recomputed by the package's current rule
    (:func:`adaptive_ff.identification.covariance.bias_corrected_interval`): the table of fits that the current
    code reproduces, kept under an earlier interval rule, without refitting them."""
    out = []
    for r in rows:
        r = json.loads(json.dumps(r))
        for kd, cells in r["kinds"].items():
            for k, c in cells.items() if isinstance(cells, dict) and "failed" not in cells else ():
                if "stderr_refits" not in c or "bias" not in c:
                    continue
                value = r["params"][k] + c["err"]
                centre, se, t = bias_corrected_interval(value, c["bias"], c["stderr_refits"],
                                                        c.get("stderr_delay", 0.0), c.get("n_valid", n_bootstrap))
                c.update(se=se, lo=value - (centre - t * se), hi=centre + t * se - value)
        out.append(r)
    return out


def one(seed: int, duration: float, n_bootstrap: int, lag_profile: bool = True, refit: str = "full",
        kinds: tuple = ("oe", "eq4"), quantum=None) -> dict:
    """Simulate, read out and identify joint ``seed`` by the methods of ``kinds`` (of :data:`KINDS`; ``"eq4"``
    gives ``"eq4 delta"`` too); the per-kind rows and CPU times (``lag_profile``: the output-error fit's profile
    search over tau, ``OutputErrorOptions.lag_profile``; ``refit``: ``OutputErrorOptions.bootstrap_refit``). The
    bootstrap refits run in this thread (``--jobs`` spreads the joints over processes; the result does not
    depend on it); ``quantum``: ``OutputErrorOptions.bootstrap_input_quantum`` of the ``oe`` and ``default`` fits
    (None: the package's default)."""
    extra = {} if quantum is None else {"bootstrap_input_quantum": quantum}
    p = draw_joint(seed)
    m = record(p, seed=seed, noise=0.01, quant=QUANT, irregular="scaled", duration=duration)
    d = MeasuredData(m.t, m.u, m.w, source=f"zoo joint {seed}")
    row = {"seed": seed, "params": dataclasses.asdict(p), "kinds": {}, "time": {}}
    if "oe" in kinds:
        t0 = time.process_time()
        try:
            rep = identify(d, Vs=p.Vs, delta=p.delta, lag=True, method="output_error",
                           method_options={"input_delay": INPUT_DELAY, "n_bootstrap": n_bootstrap,
                                           "lag_profile": lag_profile, "bootstrap_refit": refit,
                                           "bootstrap_workers": 1, **extra})
            row["kinds"]["oe"] = _kind_row(rep, p, "oe")
        except Exception as exc:  # noqa: BLE001 - a failed fit is a row of the table, with its reason
            row["kinds"]["oe"] = {"failed": f"{type(exc).__name__}: {exc}"}
        row["time"]["oe"] = time.process_time() - t0
    if "eq4" in kinds:
        t0 = time.process_time()
        rep = identify(d, Vs=p.Vs, delta=p.delta, lag=True, method="paper")
        row["kinds"]["eq4"] = _kind_row(rep, p, "eq4")
        row["kinds"]["eq4 delta"] = _kind_row(rep, p, "eq4 delta")
        row["block"] = rep.uncertainty.block
        row["time"]["eq4"] = time.process_time() - t0
    if "default" in kinds:
        t0 = time.process_time()
        try:
            rep = identify(d, Vs=p.Vs, delta=p.delta, lag=True, method="auto",
                           method_options={"bootstrap_workers": 1, **extra})
            row["kinds"]["default"] = _kind_row(rep, p, "default")
            row["default_method"] = rep.method
            row["default_named"] = sorted({w.parameter for w in rep.warnings if w.code == "model_form"})
        except Exception as exc:  # noqa: BLE001 - as for oe
            row["kinds"]["default"] = {"failed": f"{type(exc).__name__}: {exc}"}
        row["time"]["default"] = time.process_time() - t0
    return row


def wilson95(k: int, n: int) -> tuple:
    """The Wilson 95 % score interval (%, %) of a proportion ``k`` of ``n`` (Wilson 1927; Agresti & Coull 1998):
    the range of true coverages that a count of ``k`` covered joints out of ``n`` does not reject at 5 %.
    Raises ``ValueError`` unless ``0 <= k <= n`` and ``n >= 1``."""
    if not (isinstance(n, int) and isinstance(k, int) and n >= 1 and 0 <= k <= n):
        raise ValueError(f"wilson95 needs integers 0 <= k <= n, n >= 1, got k={k!r}, n={n!r}")
    ph, z2 = k / n, Z95 * Z95
    centre = (ph + z2 / (2 * n)) / (1 + z2 / n)
    half = Z95 * math.sqrt(ph * (1 - ph) / n + z2 / (4 * n * n)) / (1 + z2 / n)
    return 100 * max(0.0, centre - half), 100 * min(1.0, centre + half)


def covered(c: dict) -> bool:
    """Whether the interval ``[value - lo, value + hi]`` of one parameter holds the truth (``value - err``)."""
    return -c["lo"] <= -c["err"] <= c["hi"]


def _present(rows: list) -> tuple:
    """The kinds of :data:`KINDS` that every row of ``rows`` has."""
    return tuple(kd for kd in KINDS if all(kd in r["kinds"] for r in rows))


def table(rows: list) -> str:
    """The coverage table of ``rows`` (of :func:`one`): per parameter the coverage of every kind the rows have (a
    failed fit counts as not covered), the median ``|error| / stderr`` and the median relative error."""
    kinds = _present(rows)
    head = (f"{'parameter':<10}" + "".join(f"{kd + ' cover %':>19}" for kd in kinds)
            + "".join(f"{'|e|/se ' + kd:>19}" for kd in kinds)
            + "".join(f"{'med |e| % ' + kd:>19}" for kd in kinds if kd != "eq4 delta"))
    lines = [head, "-" * len(head)]
    for k in KEYS:
        cells = []
        for kd in kinds:
            cov = [covered(r["kinds"][kd][k]) if "failed" not in r["kinds"][kd] else False for r in rows]
            cells.append(f"{100 * np.mean(cov):>19.1f}")
        for kd in kinds:
            ok = [r["kinds"][kd][k] for r in rows if "failed" not in r["kinds"][kd]]
            cells.append(f"{np.median([abs(c['err']) / c['se'] for c in ok]) if ok else math.nan:>19.2f}")
        for kd in kinds:
            if kd == "eq4 delta":
                continue
            ok = [(r["kinds"][kd][k], r["params"][k]) for r in rows if "failed" not in r["kinds"][kd]]
            cells.append(f"{np.median([100 * abs(c['err']) / v for c, v in ok]) if ok else math.nan:>19.2f}")
        lines.append(f"{k:<10}" + "".join(cells))
    lines.append("-" * len(head))
    for kd in kinds:
        cells = []
        for k in KEYS:
            miss = [r["seed"] for r in rows if "failed" in r["kinds"][kd] or not covered(r["kinds"][kd][k])]
            lo, hi = wilson95(len(rows) - len(miss), len(rows))
            seeds = "no misses" if not miss else (f"misses: seeds {', '.join(map(str, miss))}" if len(miss) <= 10
                                                  else f"{len(miss)} misses")
            cells.append(f"{k} {lo:.1f}-{hi:.1f} ({seeds})")
        lines.append(f"{kd}: Wilson 95 % interval of the coverage, %: " + "; ".join(cells))
    for kd in ("oe", "default"):
        if kd in kinds:
            failed = [r["seed"] for r in rows if "failed" in r["kinds"][kd]]
            lines.append(f"{kd}: {len(failed)} fits failed{': seeds ' + str(failed) if failed else ''} (counted as "
                         f"not covered); CPU time per joint median {np.median([r['time'][kd] for r in rows]):.0f} s")
    if "default" in kinds:
        methods = [r.get("default_method") for r in rows]
        lines.append("default: methods chosen " + ", ".join(f"{m} {methods.count(m)}" for m in sorted(
            set(methods), key=str)) + "; parameters named by a model_form warning on "
            f"{sum(bool(r.get('default_named')) for r in rows)} joints")
    if "eq4" in kinds:
        blocks = [r["block"] for r in rows]
        lines.append(f"eq4: bootstrap block median {int(np.median(blocks))}, range {min(blocks)}..{max(blocks)} "
                     f"samples; CPU time per joint median {np.median([r['time']['eq4'] for r in rows]):.1f} s")
    lines += ["|e|/se: median over joints; coverage target of the oe and default intervals: 90-98 % per parameter"]
    return "\n".join(lines)


def _coverage_ok(rows: list) -> bool:
    """Whether the coverage of every parameter is within :data:`TARGET` for ``oe`` and ``default``, those of the
    two the rows have (failed fits count as misses)."""
    kinds = [kd for kd in ("oe", "default") if kd in _present(rows)]
    cov = [100 * np.mean([covered(r["kinds"][kd][k]) if "failed" not in r["kinds"][kd] else False for r in rows])
           for kd in kinds for k in KEYS]
    return all(TARGET[0] <= c <= TARGET[1] for c in cov)


def merge_rows(rows) -> list:
    """Rows of :func:`one` sorted by seed, the rows of one seed merged into one: the union of their kinds and CPU
    times (a later row's kind replaces an earlier one's), their other fields from the first. Raises ``ValueError``
    where two rows of a seed disagree on the joint's parameters."""
    by_seed: dict = {}
    for r in rows:
        m = by_seed.setdefault(r["seed"], {**r, "kinds": {}, "time": {}})
        if m["params"] != r["params"]:
            raise ValueError(f"rows of seed {r['seed']} disagree on the joint: {m['params']} and {r['params']}")
        m["kinds"].update(r["kinds"])
        m["time"].update(r["time"])
        m.update({k: v for k, v in r.items() if k not in m})
    return [by_seed[s] for s in sorted(by_seed)]


def _save(path: Path | None, row: dict) -> dict:
    if path is not None:
        with path.open("a") as fh:
            fh.write(json.dumps(row) + "\n")
    for kd in ("oe", "default"):
        if kd not in row["kinds"]:
            continue
        c = row["kinds"][kd]
        print(f"seed {row['seed']} {kd}{' (' + row['default_method'] + ')' if 'default_method' in row else ''}: "
              + (", ".join(f"{k} {100 * c[k]['err'] / row['params'][k]:+.2f}% (se "
                           f"{100 * c[k]['se'] / row['params'][k]:.2f}%{'' if covered(c[k]) else ' MISS'})"
                           for k in KEYS) if "failed" not in c else c["failed"])
              + f"  [{row['time'][kd]:.0f} s CPU]", file=sys.stderr, flush=True)
    return row


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=40, help="number of joints (default 40)")
    ap.add_argument("--start", type=int, default=0, help="first seed (default 0)")
    ap.add_argument("--duration", type=float, default=15.0, help="record length in s (default 15)")
    ap.add_argument("--n-bootstrap", type=int, default=20, help="output-error bootstrap refits (default 20)")
    ap.add_argument("--no-lag-profile", action="store_true",
                    help="output-error fit without its profile search over tau (the former fit)")
    ap.add_argument("--bootstrap-refit", choices=("full", "partial"), default="full",
                    help="how the output-error bootstrap refits each replicate (OutputErrorOptions.bootstrap_refit; "
                         "default full, the package's)")
    ap.add_argument("--input-quantum", default=None,
                    help="bootstrap_input_quantum of the oe and default fits: 'auto' or a resolution in N·m, 0 for "
                         "the logged torque taken as exact (default: the package's default, 'auto')")
    ap.add_argument("--kinds", nargs="+", choices=("oe", "eq4", "default"), default=["oe", "eq4"],
                    help="the fits to run (default: oe eq4; eq4 gives eq4 delta too)")
    ap.add_argument("--jobs", type=int, default=1, help="worker processes (default 1)")
    ap.add_argument("--out", type=Path, default=None, help="append each joint's row to this JSON-lines file")
    ap.add_argument("--table-from", type=Path, nargs="+", default=None,
                    help="print the table of the rows of these files (one seed's rows merged), fit nothing")
    ap.add_argument("--rescore", action="store_true",
                    help="with --table-from: each output-error interval recomputed from the parts its row keeps "
                         "(the refits' RMS deviation and mean shift, the delay's share; --n-bootstrap refits where "
                         "the row does not say) by the current interval rule")
    a = ap.parse_args(argv)
    if a.rescore and a.table_from is None:
        ap.error("--rescore needs --table-from")
    if a.table_from is not None:
        rows = merge_rows(json.loads(x) for f in a.table_from for x in f.read_text().splitlines() if x.strip())
        rows = rescored(rows, a.n_bootstrap) if a.rescore else rows
    else:
        quantum = a.input_quantum
        if quantum not in (None, "auto"):
            try:
                quantum = float(quantum)
            except ValueError:
                quantum = math.nan
            if not (math.isfinite(quantum) and quantum >= 0):
                ap.error(f"--input-quantum must be 'auto' or a resolution >= 0 N·m, got {a.input_quantum!r}")
        seeds = range(a.start, a.start + a.n)
        if a.jobs > 1:
            from concurrent.futures import ProcessPoolExecutor

            with ProcessPoolExecutor(a.jobs) as pool:
                rows = [_save(a.out, r) for r in pool.map(one, seeds, [a.duration] * a.n, [a.n_bootstrap] * a.n,
                                                           [not a.no_lag_profile] * a.n, [a.bootstrap_refit] * a.n,
                                                           [tuple(a.kinds)] * a.n, [quantum] * a.n)]
        else:
            rows = [_save(a.out, one(s, a.duration, a.n_bootstrap, not a.no_lag_profile, a.bootstrap_refit,
                                     tuple(a.kinds), quantum)) for s in seeds]
    seeds = [r["seed"] for r in rows]
    print(f"coverage of nominal 95 % intervals of identify on {len(rows)} zoo joints (seeds {min(seeds)}..{max(seeds)}), "
          f"noise 1 %, quantisation {QUANT} N·m, Fig. 10 sampling scaled to 10 ms, Vs and delta given, lag fitted")
    print(table(rows))
    return 0 if _coverage_ok(rows) else 1


if __name__ == "__main__":
    sys.exit(main())
