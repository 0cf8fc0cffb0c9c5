"""Fuzz the command line for longer than CI does: the strategies of tests/cli_strategies.py, the slow paths included.

Run: ``python benchmarks/fuzz_cli.py [--minutes 10] [--examples N] [--commands compare,identify,...] [--light]
[--seed 0] [--quiet]``.

Draws command lines of every subcommand with their input files (CSV logs, plant JSON, scenario TOML,
identification JSON, sweep specs; valid, at the boundaries, broken) and runs each in a fresh folder
(tests/docs_cli/test_fuzz_cli.py runs the same checks, bounded, in CI): exit status 0, 2, 3 or 130, no traceback, an error
naming the file or option, no partial output, strict JSON. Prints every case tried (exit status, seconds, the
command line and the first line of its error) and, for each failure, the case, its input files and what broke;
then a count by command and exit status. Stops after ``--minutes`` or ``--examples`` cases, whichever comes
first; exit status 1 if a case failed. ``--light`` leaves out the slow paths (figures, reports, output-error fits,
paper-figures runs), as CI does.
"""

from __future__ import annotations

import argparse
import collections
import pathlib
import sys
import tempfile
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "tests"))
from cli_strategies import CASES, check_outcome, cli_cases, run_case  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=10.0, help="stop after this long (default 10)")
    ap.add_argument("--examples", type=int, default=None, help="stop after this many cases (default: no limit)")
    ap.add_argument("--commands", default=",".join(CASES), help=f"comma-separated subset of {','.join(CASES)}")
    ap.add_argument("--light", action="store_true", help="leave out the slow paths, as CI does")
    ap.add_argument("--seed", type=int, default=0, help="random seed of the draws (default 0)")
    ap.add_argument("--quiet", action="store_true", help="print failures and the counts only")
    args = ap.parse_args(argv)
    commands = [c.strip() for c in args.commands.split(",") if c.strip()]
    unknown = [c for c in commands if c not in CASES]
    if unknown or not commands:
        ap.error(f"--commands: unknown {unknown}; known: {','.join(CASES)}")
    if not args.minutes > 0 or (args.examples is not None and args.examples < 1):
        ap.error("--minutes must be > 0 and --examples >= 1")

    import hypothesis
    from hypothesis import HealthCheck, Phase, given, settings

    t_start = time.monotonic()
    t_end = t_start + 60.0 * args.minutes
    counts: collections.Counter = collections.Counter()
    failures: list = []
    tried = 0

    def done() -> bool:
        return time.monotonic() > t_end or (args.examples is not None and tried >= args.examples)

    def one(case) -> None:
        nonlocal tried
        if done():
            return
        tried += 1
        with tempfile.TemporaryDirectory(prefix="fuzz_cli_") as folder:
            outcome = run_case(case, folder)
            try:
                check_outcome(case, outcome, folder)
                verdict = ""
            except AssertionError as exc:
                verdict = str(exc).splitlines()[0] if str(exc) else "assertion"
                failures.append((case, outcome, str(exc)))
        name = case.argv[0] if case.argv and case.argv[0] in CASES else "garbage"
        counts[(name, outcome.status)] += 1
        if not args.quiet or verdict:
            last = (outcome.stderr.strip().splitlines() or [""])[-1][:160]
            print(f"{tried:5d} exit {outcome.status:3d} {outcome.seconds:7.2f} s  {case.describe().splitlines()[0]}"
                  + (f"\n                      {last}" if last else "")
                  + (f"\n      FAILED: {verdict}" if verdict else ""), flush=True)

    strategy = cli_cases(commands, heavy=not args.light)
    chunk = 0
    while not done():  # batches of 20 draws, each batch from its own seed: reproducible with --seed
        run = settings(max_examples=20, deadline=None, database=None, phases=[Phase.generate],
                       suppress_health_check=list(HealthCheck))(given(case=strategy)(one))
        hypothesis.seed(args.seed * 1_000_003 + chunk)(run)()
        chunk += 1

    print(f"\n{tried} cases in {time.monotonic() - t_start:.0f} s; by command and exit status:")
    for (name, status), n in sorted(counts.items()):
        print(f"  {name:<14} {status:4d}  {n:5d}")
    for case, outcome, what in failures:
        print(f"\nFAILED: {what}\n{case.describe()}\nexit {outcome.status}; stderr:\n{outcome.stderr[-3000:]}")
    print(f"\n{len(failures)} failure(s)")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
