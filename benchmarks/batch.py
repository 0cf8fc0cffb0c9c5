"""Benchmark of controllers.simulation.batch.run_batch: time per scenario-step (B = 1000 x 10 s) and single-run time per step.

Run: ``python benchmarks/batch.py [--B 1000] [--repeats 3]``. Prints a table: for each case the
median wall time of ``repeats`` calls (after warm-up calls that load the compiled kernel and start the
numba threads) per
scenario-step, with 1 and with all numba threads, and the process CPU time per scenario-step of
the 1-thread run (a busy machine inflates wall time, not CPU time). Plants: the paper preset
(``delta = 1``) with J, Fc, tau varied, and the same with ``delta = 1.5`` (the general ``pow`` path).
"""

import argparse
import statistics
import time

import numba
import numpy as np

from controllers.simulation.batch import run_batch
from controllers.simulation.closed_loop import run_closed_loop
from plant.excitation import multisine_reference
from plant.friction import preset


def _median_time(fn, repeats=3):
    ws, cs = [], []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        ws.append(time.perf_counter() - t0)
        cs.append(time.process_time() - c0)
    return statistics.median(ws), statistics.median(cs)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--B", type=int, default=1000)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)
    rng = np.random.default_rng(0)
    ref = multisine_reference(10.0, rng=rng)
    n = ref.t.size
    base = preset("paper")
    B = args.B
    plants = [base.replace(J=base.J * rng.uniform(0.8, 1.2), Fc=base.Fc * rng.uniform(0.8, 1.2),
                           tau=base.tau * rng.uniform(0.5, 2.0)) for _ in range(B)]
    Kp, Ki = 2.0, 40.0
    threads = numba.get_num_threads()
    run_batch(plants[:2], ref, mode="oracle", Kp=Kp, Ki=Ki)  # compile / load cache
    run_batch(plants, ref, mode="oracle", Kp=Kp, Ki=Ki)  # start the numba worker threads
    rows = []
    for delta in (1.0, 1.5):
        ps = plants if delta == 1.0 else [p.replace(delta=delta) for p in plants]
        for mode in ("none", "oracle"):
            numba.set_num_threads(1)
            w1, c1 = _median_time(lambda: run_batch(ps, ref, mode=mode, Kp=Kp, Ki=Ki), args.repeats)
            numba.set_num_threads(threads)
            wt, _ = _median_time(lambda: run_batch(ps, ref, mode=mode, Kp=Kp, Ki=Ki), args.repeats)
            rows.append((f"batch {mode}, delta={delta:g}, B={B} x {n} steps", w1 / (B * n) * 1e6,
                         wt / (B * n) * 1e6, c1 / (B * n) * 1e6))
    numba.set_num_threads(threads)
    t1, c1 = _median_time(lambda: run_batch(plants[:1], ref, mode="oracle", Kp=Kp, Ki=Ki), 5)
    rows.append((f"kernel single run oracle, {n} steps (per step)", t1 / n * 1e6, float("nan"), c1 / n * 1e6))
    tp, cp = _median_time(lambda: run_closed_loop(plants[0], ref, mode="oracle", Kp=Kp, Ki=Ki, sensor_gate=False,
                                                  engine="python"), 1)
    rows.append(("run_closed_loop (Python engine) oracle, per step", tp / n * 1e6, float("nan"), cp / n * 1e6))
    print(f"µs per scenario-step; wall = median of {args.repeats}; cpu = process time of the 1-thread run")
    print(f"{'case':52s} {'wall 1 thr':>11s} {f'wall {threads} thr':>11s} {'cpu 1 thr':>10s}")
    for name, a, b, c in rows:
        print(f"{name:52s} {a:11.4f} {b:11.4f} {c:10.4f}")


if __name__ == "__main__":
    main()
