"""Do nominal 95 % intervals of the output-error fit cover the truth? (issue 12, item 3)

Run ``python benchmarks/coverage.py [--n 40] [--duration 20] [--start 0]``. For ``n`` simulated records
(seeds ``start .. start+n-1``) of the Sec. IV-A experiment (the ``paper`` preset driven open loop by
band-limited torque, 1 kHz RK4) read out as a real drive delivers them -- white velocity noise 1 % of the
peak velocity, input quantisation 0.6 N·m, the non-uniform sampling of Fig. 10 scaled to a 10 ms base
(jitter ±1 ms, every 10th interval 20 ms) -- ``fit_physical(method="output_error")`` (Vs, delta known) is
fitted and the interval ``value ± 1.96 stderr`` checked against the true value, per parameter, for

* ``HAC``: the Newey-West standard errors the fit reports (``stderr``,
  :mod:`adaptive_ff.identification.covariance`), and
* ``white``: the Gauss-Newton ones that assume white residuals (``info["stderr_white"]``).

Prints one table: coverage (%) of each kind, the median of |error| / stderr, the median relative error, and
the Bartlett bandwidth. Target: HAC coverage >= 85 % for every parameter. Timing depends on the machine's
load (about 2-20 s per fit); the numbers do not.

Records are the ``record`` function of ``benchmarks/identification.py`` (same seeds, same sampling).
"""

from __future__ import annotations

import argparse
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

from adaptive_ff.identification.physical_id import fit_physical  # noqa: E402
from plant import preset  # noqa: E402

Z95 = 1.959963984540054


def one(p, seed: int, duration: float) -> dict:
    """Fit one record; per parameter the error and both standard errors."""
    m = record(p, seed=seed, noise=0.01, quant=QUANT, irregular="scaled", duration=duration)
    f = fit_physical(m.t, m.u, m.w, Vs=p.Vs, delta=p.delta, method="output_error", input_delay=INPUT_DELAY)
    return {"err": {k: f.params[k] - getattr(p, k) for k in KEYS}, "hac": {k: f.stderr[k] for k in KEYS},
            "white": {k: f.info["stderr_white"][k] for k in KEYS}, "lags": f.info["hac_lags"],
            "predictor": f.info["predictor"]}


def table(p, rows: list) -> str:
    n = len(rows)
    head = f"{'parameter':<10}{'true':>8}{'HAC cover %':>13}{'white cover %':>15}{'med |e|/HAC':>13}" \
           f"{'med |e|/white':>15}{'med |e| %':>11}"
    lines = [head, "-" * len(head)]
    for k in KEYS:
        e = np.array([abs(r["err"][k]) for r in rows])
        h = np.array([r["hac"][k] for r in rows])
        w = np.array([r["white"][k] for r in rows])
        lines.append(f"{k:<10}{getattr(p, k):>8g}{100 * np.mean(e <= Z95 * h):>13.1f}{100 * np.mean(e <= Z95 * w):>15.1f}"
                     f"{np.median(e / h):>13.2f}{np.median(e / w):>15.2f}{100 * np.median(e) / getattr(p, k):>11.2f}")
    lags = [r["lags"] for r in rows]
    lines += ["-" * len(head), f"{n} records; HAC bandwidth (lags) median {int(np.median(lags))}, "
                               f"range {min(lags)}..{max(lags)}; predictors: "
                               + ", ".join(sorted({r['predictor'] for r in rows}))]
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=40, help="number of records (default 40)")
    ap.add_argument("--duration", type=float, default=20.0, help="record length in s (default 20)")
    ap.add_argument("--start", type=int, default=0, help="first seed (default 0)")
    a = ap.parse_args(argv)
    p = preset("paper")
    rows = []
    t0 = time.time()
    for s in range(a.start, a.start + a.n):
        rows.append(one(p, s, a.duration))
        print(f"seed {s}: " + ", ".join(f"{k} {100 * rows[-1]['err'][k] / getattr(p, k):+.2f}% "
                                        f"(HAC {100 * rows[-1]['hac'][k] / getattr(p, k):.2f}%)" for k in KEYS),
              file=sys.stderr, flush=True)
    print(f"coverage of nominal 95 % intervals, output-error fit, noise 1 %, quantisation {QUANT} N·m, "
          f"Fig. 10 sampling scaled to 10 ms, {a.duration:g} s records, seeds {a.start}..{a.start + a.n - 1}")
    print(table(p, rows))
    print(f"({time.time() - t0:.0f} s on this machine)", file=sys.stderr)
    return 0 if all(np.mean([abs(r["err"][k]) <= Z95 * r["hac"][k] for r in rows]) >= 0.85 for k in KEYS) else 1


if __name__ == "__main__":
    sys.exit(main())
