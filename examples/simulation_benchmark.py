"""Simulation benchmark: every friction-compensation mode on your joint, several seeds, mean ± std.
================================================================================================

For the researcher comparing compensation schemes. Runs :func:`controllers.experiments.compare` (the 1 kHz RK4
joint of eqs. 1-3 in the discrete PI velocity loop, multi-sine reference) for each seed and prints
the tracking metrics over the second half of each run.

    python examples/simulation_benchmark.py                       # paper preset, 3 seeds x 60 s
    python examples/simulation_benchmark.py --plant my_joint.json --seeds 5 --duration 120
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from controllers import compare
from plant import JointParams, preset


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plant", help="JSON file with J, Fc, Fs, Vs, delta, sigma, tau (SI units); default: paper preset")
    ap.add_argument("--seeds", type=int, default=3, help="number of seeds (default 3)")
    ap.add_argument("--duration", type=float, default=60.0, help="run length in s (default 60)")
    ap.add_argument("--Vs", type=float, default=None,
                    help="Stribeck velocity in rad/s if you know it (with --delta: skips the Stribeck pre-fit)")
    ap.add_argument("--delta", type=float, default=None, help="Stribeck shape factor if you know it (with --Vs)")
    args = ap.parse_args(argv)

    p = JointParams.from_json(args.plant) if args.plant else preset("paper")
    t0 = time.perf_counter()
    known = {"Vs": args.Vs, "delta": args.delta} if args.Vs is not None and args.delta is not None else {}
    runs = [compare(p, duration=args.duration, seed=seed, progress=False, **known)
            for seed in range(args.seeds)]
    wall = time.perf_counter() - t0
    modes = [row["mode"] for row in runs[0].rows()]
    print(f"{args.plant or 'preset paper'}: {args.seeds} seeds x {args.duration:g} s, second half, "
          f"mean ± std over seeds; wall time {wall:.1f} s")
    head = f"{'mode':<13}{'RMS [deg/s]':>18}{'max [deg/s]':>18}{'eta':>16}"
    print(head)
    print("-" * len(head))
    for mode in modes:
        rows = [next(r for r in c.rows() if r["mode"] == mode) for c in runs]
        rms = np.rad2deg([r["rms"] for r in rows])
        mx = np.rad2deg([r["max"] for r in rows])
        et = np.array([np.nan if r["eta"] is None else r["eta"] for r in rows])  # None: undefined eta
        print(f"{mode:<13}{rms.mean():>10.3f} ± {rms.std():<5.3f}{mx.mean():>10.3f} ± {mx.std():<5.3f}"
              f"{et.mean():>8.3f} ± {et.std():<5.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
