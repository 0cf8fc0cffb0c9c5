"""Benchmark of controllers.batch.run_batch: time per scenario-step (B = 1000 x 10 s) and single-run time per step.

Run: ``python benchmarks/batch.py``. Prints a table (median of 3 repeats, after a warm-up call).
"""

import statistics
import time

import numpy as np

from controllers.batch import run_batch
from controllers.closed_loop import run_closed_loop
from plant.excitation import multisine_reference
from plant.friction import preset


def _median_time(fn, repeats=3):
    ts = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return statistics.median(ts)


def main():
    rng = np.random.default_rng(0)
    ref = multisine_reference(10.0, rng=rng)
    n = ref.t.size
    base = preset("paper")
    B = 1000
    plants = [base.replace(J=base.J * rng.uniform(0.8, 1.2), Fc=base.Fc * rng.uniform(0.8, 1.2),
                           tau=base.tau * rng.uniform(0.5, 2.0)) for _ in range(B)]
    Kp, Ki = 2.0, 40.0
    run_batch(plants[:2], ref, mode="oracle", Kp=Kp, Ki=Ki)  # compile / load cache
    rows = []
    for mode in ("none", "oracle"):
        tb = _median_time(lambda: run_batch(plants, ref, mode=mode, Kp=Kp, Ki=Ki))
        t1 = _median_time(lambda: run_batch(plants[:1], ref, mode=mode, Kp=Kp, Ki=Ki), repeats=5)
        rows.append((f"batch {mode}, B={B} x {n} steps", tb / (B * n) * 1e6))
        rows.append((f"kernel single run {mode}, {n} steps", t1 / n * 1e6))
    tp = _median_time(lambda: run_closed_loop(plants[0], ref, mode="oracle", Kp=Kp, Ki=Ki), repeats=1)
    rows.append(("run_closed_loop (Python) oracle, per step", tp / n * 1e6))
    print(f"{'case':50s} {'us/step':>10s}")
    for name, v in rows:
        print(f"{name:50s} {v:10.4f}")


if __name__ == "__main__":
    main()
