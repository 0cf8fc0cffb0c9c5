"""The example scenarios: eta of every mode and the wall time of each comparison (warm).

Run:  python benchmarks/scenarios.py [FILE.toml ...] [--repeat 2]

Default: every ``examples/scenarios/*.toml``. Each scenario's comparison (:meth:`Scenario.compare`: quasi-static
runs and pre-fit, identification run, every mode and own compensator) runs ``--repeat`` times in this process;
the wall time printed is the fastest (warm: imports, the first figure-free run's caches of the interpreter). Prints
a Markdown table per scenario (mode, eta, RMS over the second half in rad/s) and one of wall times. Results:
docs/benchmarks/scenarios.md.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from controllers.experiments.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", nargs="*", help="scenario files (default: examples/scenarios/*.toml)")
    ap.add_argument("--repeat", type=int, default=2, help="runs per scenario; the fastest is printed (default 2)")
    a = ap.parse_args(argv)
    files = [Path(f) for f in a.files] or sorted((ROOT / "examples" / "scenarios").glob("*.toml"))
    times = []
    for f in files:
        s = load_scenario(f)
        best, comp = float("inf"), None
        for _ in range(max(a.repeat, 1)):
            t0 = time.perf_counter()
            comp = s.compare(progress=False)
            best = min(best, time.perf_counter() - t0)
        times.append((f.name, s.options.duration, best))
        print(f"\n{s.summary()}\n")
        print("| mode | eta | RMS (rad/s) |")
        print("|---|---:|---:|")
        for mode, r in comp.results.items():
            e = comp.eta[mode]
            print(f"| {mode} | {'-' if e is None else f'{e:.3f}'} | {r.metrics.rms_second_half:.4g} |")
    print("\n| scenario | simulated (s) | wall time, warm (s) |")
    print("|---|---:|---:|")
    for name, dur, t in times:
        print(f"| {name} | {dur:.1f} | {t:.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
