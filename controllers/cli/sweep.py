"""``adaptive-ff sweep``: grid / Monte-Carlo studies over plants, gains, modes and seeds (resumable)."""

from __future__ import annotations

import json

__all__ = ["register", "run"]


def run(args) -> int:
    """Execute ``adaptive-ff sweep`` with parsed ``args``; return the exit status."""
    import time

    from controllers.experiments.sweep import expand_cases, load_spec, run_sweep

    spec = load_spec(args.spec)
    t0 = time.perf_counter()
    summary = run_sweep(spec, args.out, workers=args.workers, scheduler=args.scheduler,
                        progress=False if args.quiet else None)
    wall = time.perf_counter() - t0
    summary["wall_s"] = wall
    summary["cases_per_s"] = summary["n_run"] / wall if summary["n_run"] else float("nan")
    summary["results"] = str(args.out)
    summary_path = f"{args.out}.summary.json"
    with open(summary_path, "w") as fh:
        json.dump(summary, fh, indent=2)
    if args.json:
        print(json.dumps(summary, indent=2))
        return 0
    print(f"{summary['n_cases']} cases ({summary['n_skipped']} already done, {summary['n_run']} run) in "
          f"{wall:.1f} s = {summary['cases_per_s']:.3g} cases/s; {len(expand_cases(spec))} in the spec")
    print(f"{'mode':<13}{'n':>6}{'eta mean':>10}{'eta std':>9}{'eta min':>9}{'RMS mean [rad/s]':>18}")
    for mode, st in summary["modes"].items():
        print(f"{mode:<13}{st['n']:>6}{st['eta']['mean']:>10.3f}{st['eta']['std']:>9.3f}{st['eta']['min']:>9.3f}"
              f"{st['rms']['mean']:>18.5f}")
    print(f"results: {args.out}  summary: {summary_path}")
    return 0


def register(sub) -> None:
    """Add the ``sweep`` subcommand to an argparse subparsers object."""
    s = sub.add_parser("sweep", help="grid or Monte-Carlo study of the closed loop (resumable, parallel)",
                       description="Run every case of a JSON/TOML sweep spec (plant-parameter grid, Monte-Carlo "
                                   "draws, controller targets, modes, seeds; format in controllers.experiments.sweep) on all "
                                   "local cores or a Dask cluster. Appends one CSV row per case and mode as each "
                                   "case finishes; rerunning skips finished cases. Writes OUT.summary.json.")
    s.add_argument("spec", help="sweep spec (.json or .toml)")
    s.add_argument("--out", default="sweep.csv", help="results CSV (default sweep.csv)")
    s.add_argument("--workers", type=int, default=None, help="local processes (default: all cores)")
    s.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="Dask scheduler address, e.g. tcp://10.0.0.5:8786 (needs the 'dask' extra)")
    s.add_argument("--json", action="store_true", help="print the summary as JSON")
    s.add_argument("--quiet", action="store_true", help="no progress bar")
    s.set_defaults(func=run)
