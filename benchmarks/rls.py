"""Benchmark of adaptive_ff.identification.rls.RecursiveLeastSquares: median µs per update (p = 6).

Run: ``python benchmarks/rls.py [--blocks 60] [--block 1000]``. Each case runs ``blocks``
blocks of ``block`` updates on a random stream (``lam = 0.995``, as benchmarks/perf.py) and
prints the median over blocks of the time per update, so a busy machine (another process
taking the core for a moment) does not move the result. Cases: ``update`` (one call per
sample, from a Python loop over the rows), ``update_many`` (the whole block in one call) and
the numpy RLS in information form of the test oracle (tests/rls_oracle.py).
"""

import argparse
import pathlib
import statistics
import sys
import time

import numpy as np

from adaptive_ff.identification.rls import RecursiveLeastSquares

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "tests"))
from rls_oracle import NumpyRLS  # noqa: E402

P = 6


def _median_per_update(run, phis, ys, blocks, block):
    ts = []
    for b in range(blocks):
        sl = slice((b * block) % (len(ys) - block + 1), (b * block) % (len(ys) - block + 1) + block)
        t0 = time.perf_counter()
        run(phis[sl], ys[sl])
        ts.append((time.perf_counter() - t0) / block * 1e6)
    return statistics.median(ts)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--blocks", type=int, default=60)
    ap.add_argument("--block", type=int, default=1000)
    args = ap.parse_args(argv)
    rng = np.random.default_rng(1)
    n = 20_000
    phis = rng.normal(size=(n, P))
    ys = rng.normal(size=n)
    rows = []
    for label, kw in (("exponential", dict(lam=0.995)), ("directional", dict(lam=0.995, forgetting="directional")),
                      ("exponential + bounds", dict(lam=0.995, bounds=([-5.0] * P, [5.0] * P))),
                      ("vector lam", dict(lam=np.full(P, 0.995), P_max=1e5))):
        for impl, cls in (("update", RecursiveLeastSquares), ("numpy oracle", NumpyRLS)):
            rls = cls(P, **kw)
            upd = rls.update

            def run(ph, y, upd=upd):
                for phi, yk in zip(ph, y.tolist()):
                    upd(phi, yk)

            blocks = args.blocks if cls is RecursiveLeastSquares else max(args.blocks // 6, 5)
            rows.append((f"{impl}, {label}", _median_per_update(run, phis, ys, blocks, args.block)))
        rls = RecursiveLeastSquares(P, **kw)
        rows.append((f"update_many, {label}", _median_per_update(rls.update_many, phis, ys, args.blocks,
                                                                 args.block)))
    print(f"RecursiveLeastSquares, p = {P}: median over blocks of {args.block} updates")
    print(f"{'case':40s} {'µs/update':>10s}")
    for name, v in rows:
        print(f"{name:40s} {v:10.3f}")


if __name__ == "__main__":
    main()
