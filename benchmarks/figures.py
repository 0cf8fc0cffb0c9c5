"""The cost of the main job's figures: ``plot_comparison`` on the 120 s ``paper`` comparison, warm.

Run:  python benchmarks/figures.py [--repeat 3]

Prints the best and the median wall time of drawing and writing the five PNG files of ``adaptive-ff compare``
(docs/benchmarks/figures.md), after one warm-up call (matplotlib imports, font cache).
"""

from __future__ import annotations

import argparse
import tempfile
import time

from controllers import compare
from controllers.report.figures import plot_comparison
from plant import preset


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    comp = compare(preset("paper"), progress=False)  # the main job's runs
    with tempfile.TemporaryDirectory() as out:
        plot_comparison(comp, out)  # warm-up
        times = []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            plot_comparison(comp, out)
            times.append(time.perf_counter() - t0)
    times.sort()
    print(f"plot_comparison, 5 figures of the 120 s main job: best of {args.repeat} {times[0]:.2f} s, "
          f"median {times[len(times) // 2]:.2f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
