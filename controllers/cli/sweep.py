"""``adaptive-ff sweep``: grid / Monte-Carlo studies over plants, gains, modes and seeds (resumable)."""

from __future__ import annotations

import json

__all__ = ["register", "run", "sweep_table"]


def sweep_table(summary: dict, args) -> str:
    """Per-mode table of a sweep summary in the ``--units`` of ``args`` (eta [-], RMS in deg/s or rad/s).

    Undefined statistics (no finite value) print as ``n/a``.
    """
    from controllers.cli.data import table_unit

    k, unit = table_unit(args)

    def f(x, width, fmt, scale=1.0):
        return f"{'n/a':>{width}}" if x is None or x != x else f"{scale * x:>{width}{fmt}}"

    head = f"{'mode':<13}{'n':>6}{'eta mean [-]':>14}{'eta std [-]':>13}{'eta min [-]':>13}{f'RMS mean [{unit}]':>19}"
    lines = [head]
    for mode, st in summary["modes"].items():
        lines.append(f"{mode:<13}{st['n']:>6}{f(st['eta']['mean'], 14, '.3f')}{f(st['eta']['std'], 13, '.3f')}"
                     f"{f(st['eta']['min'], 13, '.3f')}{f(st['rms']['mean'], 19, '.5f', k)}")
    return "\n".join(lines)


def run(args) -> int:
    """Execute ``adaptive-ff sweep`` with parsed ``args``; return the exit status (130 when interrupted)."""
    import sys
    import time

    from adaptive_ff.io.output import atomic_file, output_lock
    from controllers.cli.budget import check_work, sweep_estimate
    from controllers.cli.data import check_output_file
    from controllers.experiments.sweep import SweepInterrupted, expand_cases, load_spec, run_sweep
    from plant.results import json_safe

    summary_path = f"{args.out}.summary.json"
    check_output_file(args.out, "--out")
    check_output_file(summary_path, "--out (summary)")
    spec = load_spec(args.spec)

    def bound(todo) -> None:  # the cases still to run, before the first of them
        check_work(sweep_estimate(todo, None if args.scheduler else args.workers), yes=args.yes)

    t0 = time.perf_counter()
    with output_lock(args.out, "--out"):  # a second sweep into the same results refuses instead of interleaving
        try:
            summary = run_sweep(spec, args.out, workers=args.workers, scheduler=args.scheduler,
                                progress=False if args.quiet else None, check=bound)
        except SweepInterrupted as exc:
            print(f"adaptive-ff: {exc}", file=sys.stderr)
            return 130
        wall = time.perf_counter() - t0
        summary["wall_s"] = wall
        summary["cases_per_s"] = summary["n_run"] / wall if summary["n_run"] else None
        summary["results"] = str(args.out)
        summary = json_safe(summary)
        with atomic_file(summary_path, "--out (summary)") as tmp, open(tmp, "w", encoding="utf-8") as fh:
            json.dump(summary, fh, indent=2, allow_nan=False)
    if args.json:
        print(json.dumps(summary, indent=2, allow_nan=False))
        return 0
    rate = "" if summary["cases_per_s"] is None else f" = {summary['cases_per_s']:.3g} cases/s"
    print(f"{summary['n_cases']} cases ({summary['n_skipped']} already done, {summary['n_run']} run) in "
          f"{wall:.1f} s{rate}; {len(expand_cases(spec))} in the spec")
    print(sweep_table(summary, args))
    print(f"results (SI units, rad/s): {args.out}  summary: {summary_path}")
    return 0


def register(sub) -> None:
    """Add the ``sweep`` subcommand to an argparse subparsers object."""
    from controllers.cli.budget import add_yes_argument
    from controllers.cli.data import add_units_argument, positive_int

    s = sub.add_parser("sweep", help="grid or Monte-Carlo study of the closed loop (resumable, parallel)",
                       description="Run every case of a JSON/TOML sweep spec (plant-parameter grid, Monte-Carlo "
                                   "draws, controller targets, modes, seeds; format in controllers.experiments.sweep, "
                                   "examples in examples/*.json) on all local cores or a Dask cluster. Appends one "
                                   "CSV row per case and mode as each case finishes; rerunning skips finished cases "
                                   "and reruns partly written ones. Ctrl-C stops the workers, keeps every finished "
                                   "case and exits with status 130. Writes OUT.summary.json.")
    s.add_argument("spec", help="sweep spec (.json or .toml)")
    s.add_argument("--out", default="sweep.csv", help="results CSV, appended to (default sweep.csv)")
    s.add_argument("--workers", type=positive_int, default=None, help="local processes (default: all cores)")
    s.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="Dask scheduler address, e.g. tcp://10.0.0.5:8786 (needs the 'dask' extra)")
    s.add_argument("--json", action="store_true", help="print the summary as JSON (SI units)")
    s.add_argument("--quiet", action="store_true", help="no progress bar")
    add_units_argument(s)
    add_yes_argument(s)
    s.set_defaults(func=run)
