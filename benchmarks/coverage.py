"""Do nominal 95 % intervals of the output-error fit cover the truth? (issue 12, item 3)

Run ``python benchmarks/coverage.py [--n 40] [--duration 20] [--start 0]``. For ``n`` simulated records
(seeds ``start .. start+n-1``) of the Sec. IV-A experiment (the ``paper`` preset driven open loop by
band-limited torque, 1 kHz RK4) read out as a real drive delivers them -- white velocity noise 1 % of the
peak velocity, input quantisation 0.6 N·m, the non-uniform sampling of Fig. 10 scaled to a 10 ms base
(jitter ±1 ms, every 10th interval 20 ms) -- ``fit_physical(method="output_error")`` (Vs, delta known) is
fitted and the interval ``value ± 1.96 stderr`` checked against the true value, per parameter, for

* ``boot``: the standard errors the fit reports (``stderr``: the parametric moving-block bootstrap of
  :func:`adaptive_ff.identification.physical_id.fit_physical`, ``--n-bootstrap`` refits, default 20),
* ``HAC``: the Newey-West ones (``info["stderr_hac"]``, :mod:`adaptive_ff.identification.covariance`), and
* ``white``: the Gauss-Newton ones that assume white residuals (``info["stderr_white"]``).

Prints one table: coverage (%) of each kind, the median of |error| / stderr (0.67 for exact normal
intervals), the median relative error, and the bootstrap block length. Target: ``boot`` coverage >= 85 % for
every parameter (exit status 1 if not). Timing depends on the machine's load (about 5-40 s per fit with the
bootstrap); the numbers do not.

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


KINDS = ("boot", "hac", "white")


def one(p, seed: int, duration: float, n_bootstrap: int) -> dict:
    """Fit one record; per parameter the error and the three standard errors."""
    m = record(p, seed=seed, noise=0.01, quant=QUANT, irregular="scaled", duration=duration)
    t0 = time.perf_counter()
    f = fit_physical(m.t, m.u, m.w, Vs=p.Vs, delta=p.delta, method="output_error", input_delay=INPUT_DELAY,
                     n_bootstrap=n_bootstrap)
    return {"err": {k: f.params[k] - getattr(p, k) for k in KEYS}, "boot": {k: f.stderr[k] for k in KEYS},
            "hac": {k: f.info["stderr_hac"][k] for k in KEYS}, "white": {k: f.info["stderr_white"][k] for k in KEYS},
            "block": (f.info["bootstrap"] or {}).get("block", 0), "predictor": f.info["predictor"],
            "time": time.perf_counter() - t0}


def table(p, rows: list) -> str:
    n = len(rows)
    head = (f"{'parameter':<10}{'true':>8}" + "".join(f"{kd + ' cover %':>14}" for kd in KINDS)
            + "".join(f"{'|e|/' + kd:>12}" for kd in KINDS) + f"{'med |e| %':>11}")
    lines = [head, "-" * len(head)]
    for k in KEYS:
        e = np.array([abs(r["err"][k]) for r in rows])
        s = {kd: np.array([r[kd][k] for r in rows]) for kd in KINDS}
        lines.append(f"{k:<10}{getattr(p, k):>8g}" + "".join(f"{100 * np.mean(e <= Z95 * s[kd]):>14.1f}" for kd in KINDS)
                     + "".join(f"{np.median(e / s[kd]):>12.2f}" for kd in KINDS)
                     + f"{100 * np.median(e) / getattr(p, k):>11.2f}")
    blocks = [r["block"] for r in rows]
    lines += ["-" * len(head), f"{n} records; |e|/kind: median over records; bootstrap block length median "
                               f"{int(np.median(blocks))}, range {min(blocks)}..{max(blocks)} samples; predictors: "
                               + ", ".join(sorted({r['predictor'] for r in rows}))
              + f"; time per fit median {np.median([r['time'] for r in rows]):.0f} s (loaded machine)"]
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=40, help="number of records (default 40)")
    ap.add_argument("--duration", type=float, default=20.0, help="record length in s (default 20)")
    ap.add_argument("--start", type=int, default=0, help="first seed (default 0)")
    ap.add_argument("--n-bootstrap", type=int, default=20, help="bootstrap refits per fit (default 20)")
    a = ap.parse_args(argv)
    p = preset("paper")
    rows = []
    t0 = time.time()
    for s in range(a.start, a.start + a.n):
        rows.append(one(p, s, a.duration, a.n_bootstrap))
        print(f"seed {s}: " + ", ".join(f"{k} {100 * rows[-1]['err'][k] / getattr(p, k):+.2f}% "
                                        f"(boot {100 * rows[-1]['boot'][k] / getattr(p, k):.2f}%)" for k in KEYS),
              file=sys.stderr, flush=True)
    print(f"coverage of nominal 95 % intervals, output-error fit, noise 1 %, quantisation {QUANT} N·m, "
          f"Fig. 10 sampling scaled to 10 ms, {a.duration:g} s records, seeds {a.start}..{a.start + a.n - 1}")
    print(table(p, rows))
    print(f"({time.time() - t0:.0f} s on this machine)", file=sys.stderr)
    return 0 if all(np.mean([abs(r["err"][k]) <= Z95 * r["boot"][k] for r in rows]) >= 0.85 for k in KEYS) else 1


if __name__ == "__main__":
    sys.exit(main())
