"""Same-process A/B of the batch engine: this tree's engine against another version of engine.py.

Run:  git show REV:controllers/simulation/engine.py > /tmp/old_engine.py
      python benchmarks/engine_ab.py /tmp/old_engine.py [--B 1000] [--seconds 2] [--repeat 7] [--mode none]

Loads the other engine module (its kernels compiled in memory, not cached),
runs ``run_batch`` with each engine in turn (alternating, ``--repeat`` times) on
the plants of ``benchmarks/perf.py``'s batch rows, and prints the CPU time of
the engine call per scenario-step (``time.thread_time`` with one numba thread:
not inflated by other processes on a loaded machine) and whether every metric
of every scenario is bit-identical. The other module must accept this tree's
``EngineInputs`` (same fields).
"""

from __future__ import annotations

import argparse
import importlib.util
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np

import controllers.simulation.batch as batch_module
from controllers.design.pi import design_pi
from controllers.simulation.closed_loop import ModeOptions
from plant.excitation import multisine_reference
from plant.friction import preset

_NOCACHE = ("import numba as _nb\n\n\ndef kernel(*a, **k):\n    if a and callable(a[0]):\n        return _nb.njit(a[0])\n"
            "    return _nb.njit(**k)\n")


def _load(path: str):
    src = Path(path).read_text().replace("from plant.jit import kernel\n", _NOCACHE)
    tmp = Path(tempfile.mkdtemp()) / "engine_other.py"
    tmp.write_text(src)
    spec = importlib.util.spec_from_file_location("engine_other", tmp)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("other", help="path of the other engine.py")
    ap.add_argument("--B", type=int, default=1000)
    ap.add_argument("--seconds", type=float, default=2.0)
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--mode", default="none")
    args = ap.parse_args(argv)
    numba.set_num_threads(1)
    p = preset("paper")
    design = design_pi(p.J, crossover=20.0, phase_margin=60.0, Tc=1e-3)
    ref = multisine_reference(args.seconds, rng=np.random.default_rng(0))
    rng = np.random.default_rng(2)
    plants = [p.replace(J=p.J * rng.uniform(0.7, 1.3), Fc=p.Fc * rng.uniform(0.7, 1.3),
                        tau=p.tau * rng.uniform(0.5, 2.0)) for _ in range(args.B)]
    o = ModeOptions(Kp=design.Kp, Ki=design.Ki, u_max=150.0, Vs=p.Vs, delta=p.delta, sensor_gate=False)
    engines = {"this tree": batch_module.run_engine, "other": _load(args.other).run_engine}
    times = {k: [] for k in engines}
    metrics = {}
    for name, fn in engines.items():  # compile / load
        batch_module.run_engine = fn
        batch_module.run_batch(plants[:2], ref, args.mode, o)
    for _ in range(args.repeat):
        for name, fn in engines.items():
            spent = []

            def timed(x, fn=fn, spent=spent):
                t0 = time.thread_time()
                fn(x)
                spent.append(time.thread_time() - t0)

            batch_module.run_engine = timed
            r = batch_module.run_batch(plants, ref, args.mode, o)
            times[name].append(spent[0])
            metrics[name] = [r.rms, r.max, r.rms_second_half, r.max_second_half, r.rms_reversal, r.u_rms]
    n = args.B * ref.t.size
    base = min(times["other"])
    print(f"run_batch {args.mode}, B={args.B}, {args.seconds:g} s, 1 thread, engine CPU time per scenario-step")
    for name in engines:
        same = all(np.array_equal(a, b, equal_nan=True) for a, b in zip(metrics[name], metrics["this tree"]))
        print(f"{name:<10} median {statistics.median(times[name]) / n * 1e6:.4f} µs, fastest "
              f"{min(times[name]) / n * 1e6:.4f} µs, fastest / other's {min(times[name]) / base:.3f}, "
              f"metrics bit-identical to this tree: {same}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
