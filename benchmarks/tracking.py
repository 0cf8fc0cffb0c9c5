"""Tracking benchmark: the `paper` preset in all compensation modes, averaged over seeds.

Run:  python benchmarks/tracking.py [--seeds 5] [--duration 120]

Prints mean ± std over the seeds of the second-half RMS and max velocity error,
the RMS in the reversal windows (deg/s), the RMS control effort (N·m) and the
compensation efficiency eta = (RMS_none - RMS_mode) / (RMS_none - RMS_frictionless).
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from tqdm.auto import tqdm

from controllers.simulation.closed_loop import MODES
from controllers.experiments.compare import compare
from plant.friction import preset


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--duration", type=float, default=120.0)
    ap.add_argument("--preset", default="paper")
    args = ap.parse_args(argv)
    p = preset(args.preset)
    rows = {m: [] for m in MODES}
    t0 = time.perf_counter()
    for seed in tqdm(range(args.seeds), desc="seeds", disable=None):
        comp = compare(p, duration=args.duration, seed=seed, progress=False)
        for r in comp.rows():
            rows[r["mode"]].append([np.rad2deg(r["rms"]), np.rad2deg(r["max"]), np.rad2deg(r["rms_reversal"]),
                                    r["u_rms"], r["eta"]])
    wall = time.perf_counter() - t0
    print(f"preset '{args.preset}', {args.seeds} seeds x {args.duration:g} s, metrics over the second half "
          f"(mean ± std); wall time {wall:.1f} s")
    head = f"{'mode':<13}{'RMS [deg/s]':>17}{'max [deg/s]':>17}{'reversal RMS':>17}{'u RMS [N·m]':>17}{'eta':>17}"
    print(head)
    print("-" * len(head))
    for mode, vals in rows.items():
        a = np.asarray(vals)
        mean, std = a.mean(axis=0), a.std(axis=0)
        cells = "".join(f"{m:>9.3f} ± {s:<5.3f}" for m, s in zip(mean, std))
        print(f"{mode:<13}{cells}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
