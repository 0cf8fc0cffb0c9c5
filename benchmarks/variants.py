"""Variants table: every compensation mode on the ``paper`` preset, its plant variants and the drift case.

Run:  python benchmarks/variants.py [--seeds 1] [--duration 120] [--jobs N] [--plants paper,karnopp,...]

For each plant (:mod:`plant.variant_plants`: the ``paper`` preset, each variant that changes one thing, and the
drift case with Fc, Fs +50 % over the first half) :func:`controllers.experiments.compare.compare` runs every
mode on one scenario per seed (same reference and noise in every mode). Printed per plant and mode, as the
mean over the seeds:

- ``eta``: compensation efficiency over the second half, ``(RMS_none - RMS_mode)/(RMS_none - RMS_frictionless)``;
- ``eta_full``: the same over the whole run (start-up included);
- ``dev``: RMS of ``w - w_frictionless`` over the whole run (deg/s);
- ``max2``: the largest tracking error of the second half (deg/s);
- ``t_on``: the first time the mode's compensation acts (s).

Then the margin target per plant: ``adaptive >= max(fixed, dob) - 0.02`` on the plants whose
friction is a sliding (lagged Stribeck) model, and ``max(adaptive, adaptive-dob) >= max(fixed, dob) - 0.02`` on
every plant (Karnopp sticking and LuGre pre-sliding included); and the targets on ``paper`` (``t_on``,
``eta_full``, ``dev`` and ``max2`` against the oracle's).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from controllers.experiments.compare import compare
from plant.friction import preset
from plant.variant_plants import VARIANT_NAMES, drift_case, variant

#: Plants of the table, in order.
PLANTS = ("paper",) + VARIANT_NAMES + ("drift",)
#: Plants whose friction does not follow a sliding model (true sticking, pre-sliding).
NON_SLIDING = ("karnopp", "lugre")
COLUMNS = ("eta", "eta_full", "rms_dev", "max", "t_ff_on")


def _plant(name: str, duration: float):
    if name == "paper":
        return preset("paper")
    if name == "drift":
        return drift_case(duration)
    return variant(name)


def _one(args) -> tuple:
    name, seed, duration = args
    c = compare(_plant(name, duration), duration=duration, seed=seed, progress=False)
    return name, seed, {r["mode"]: r for r in c.rows()}


def _mean(rows: list, mode: str, key: str) -> float:
    vals = [r[mode][key] for r in rows if r[mode][key] is not None]
    return float(np.mean(vals)) if vals else float("nan")


def _table(name: str, rows: list) -> list:
    modes = list(rows[0])
    d = np.rad2deg
    out = [f"### {name}", "", "| mode | eta | eta_full | dev [deg/s] | max2 [deg/s] | t_on [s] |",
           "|---|---:|---:|---:|---:|---:|"]
    for m in modes:
        ton = _mean(rows, m, "t_ff_on")
        out.append(f"| {m} | {_mean(rows, m, 'eta'):.3f} | {_mean(rows, m, 'eta_full'):.3f} | "
                   f"{d(_mean(rows, m, 'rms_dev')):.4f} | {d(_mean(rows, m, 'max')):.4f} | "
                   f"{'-' if ton != ton else f'{ton:.3f}'} |")
    return out + [""]


def _targets(results: dict) -> list:
    out = ["### Margin target: margin = mode - max(fixed, dob); pass when >= -0.02", "",
           "| plant | sliding model | adaptive | adaptive-dob | best adaptive | pass |", "|---|---|---:|---:|---:|---|"]
    for name, rows in results.items():
        ref = max(_mean(rows, "fixed", "eta"), _mean(rows, "dob", "eta"))
        a, ad = _mean(rows, "adaptive", "eta") - ref, _mean(rows, "adaptive-dob", "eta") - ref
        sliding = name not in NON_SLIDING
        ok = max(a, ad) >= -0.02 and (a >= -0.02 or not sliding)
        out.append(f"| {name} | {'yes' if sliding else 'no'} | {a:+.3f} | {ad:+.3f} | {max(a, ad):+.3f} | "
                   f"{'yes' if ok else 'NO'} |")
    if "paper" in results:
        rows = results["paper"]
        o_dev, o_max = _mean(rows, "oracle", "rms_dev"), _mean(rows, "oracle", "max")
        out += ["", "### Targets on `paper`", "",
                "| mode | t_on <= 2 s | eta_full >= 0.9 | dev / oracle's <= 1.5 | max2 / oracle's <= 1.5 |",
                "|---|---:|---:|---:|---:|"]
        for m in ("adaptive", "adaptive-dob"):
            ton = _mean(rows, m, "t_ff_on")
            out.append(f"| {m} | {ton:.3f} | {_mean(rows, m, 'eta_full'):.3f} | "
                       f"{_mean(rows, m, 'rms_dev') / o_dev:.2f} | {_mean(rows, m, 'max') / o_max:.2f} |")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=1, help="seeds per plant (default 1)")
    ap.add_argument("--duration", type=float, default=120.0, help="run length in s (default 120)")
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="worker processes (default: cores)")
    ap.add_argument("--plants", default=",".join(PLANTS), help="comma-separated subset of " + ",".join(PLANTS))
    a = ap.parse_args(argv)
    plants = [p.strip() for p in a.plants.split(",") if p.strip()]
    unknown = [p for p in plants if p not in PLANTS]
    if unknown:
        print(f"unknown plant(s) {unknown}; known: {list(PLANTS)}", file=sys.stderr)
        return 2
    t0 = time.perf_counter()
    jobs = [(p, s, a.duration) for p in plants for s in range(a.seeds)]
    if a.jobs > 1:
        with ProcessPoolExecutor(max_workers=a.jobs) as pool:
            done = list(pool.map(_one, jobs))
    else:
        done = [_one(j) for j in jobs]
    results = {p: [r for n, _, r in done if n == p] for p in plants}
    print(f"Variants table: {a.seeds} seed(s) x {a.duration:g} s per plant; means over the seeds; eta over the "
          "second half, eta_full, dev (RMS of w - w_frictionless) and t_on over the whole run.\n")
    for p in plants:
        print("\n".join(_table(p, results[p])))
    print("\n".join(_targets(results)))
    print(f"\nwall time {time.perf_counter() - t0:.0f} s ({a.jobs} process(es); a loaded machine: not a speed figure)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
