"""A/B of the batch engine between two source trees (e.g. before/after a change of the plant step).

Run:  git worktree add /tmp/old REV   (or: mkdir /tmp/old && git archive REV | tar -x -C /tmp/old)
      (cd /tmp/old && python setup.py build_ext --inplace)   # its C core, built in place
      python benchmarks/tree_ab.py /tmp/old [--B 1000] [--seconds 2] [--repeat 5] [--rounds 3] [--mode none]

Each tree imports its own C core: the extension modules built in place beside its packages (``setup.py
build_ext --inplace``; an editable install of this tree has done that for this one). Each round runs one
fresh process per tree (this tree and OTHER, alternating), which times ``run_batch`` with one engine thread
(``ADAPTIVE_FF_THREADS=1``) by the CPU time of the calling thread (``time.thread_time``: not inflated by other
processes on a loaded machine) and prints µs per scenario-step of the engine (median and fastest of
``--repeat``), the serial Python part of the call (CPU of the calling thread outside the engine's
``EngineRun.run``: packing the scenarios, the results) and the first metrics, so a change of the numbers shows.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

_CHILD = r"""
import statistics, sys, time
import numpy as np
import controllers.simulation.batch as bm
from controllers.simulation.engine import EngineRun
from controllers.simulation.closed_loop import ModeOptions
from plant.excitation import multisine_reference
from plant.friction import preset
B, seconds, repeat, mode = int(sys.argv[1]), float(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
p = preset("paper")
ref = multisine_reference(seconds, rng=np.random.default_rng(0))
rng = np.random.default_rng(2)
plants = [p.replace(J=p.J * rng.uniform(0.7, 1.3), Fc=p.Fc * rng.uniform(0.7, 1.3), tau=p.tau * rng.uniform(0.5, 2.0))
          for _ in range(B)]
o = ModeOptions(Kp=69.28434179621937, Ki=786.1169272191827, u_max=150.0, Vs=p.Vs, delta=p.delta, sensor_gate=False)
run, spent = EngineRun.run, []
def timed(self):
    t0 = time.thread_time(); run(self); spent.append(time.thread_time() - t0)
bm.run_batch(plants[:2], ref, mode, o)
EngineRun.run = timed
whole = []
for _ in range(repeat):
    t0 = time.thread_time()
    r = bm.run_batch(plants, ref, mode, o)
    whole.append(time.thread_time() - t0)
n = B * ref.t.size
serial = [a - b for a, b in zip(whole, spent)]
print(f"median {statistics.median(spent) / n * 1e6:.4f} µs, fastest {min(spent) / n * 1e6:.4f} µs; "
      f"serial Python part {statistics.median(serial) * 1e3:.2f} ms (least {min(serial) * 1e3:.2f}); "
      f"rms[:2] {r.rms[:2].tolist()}")
"""


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("other", help="root of the other source tree (holds plant/, adaptive_ff/, controllers/)")
    ap.add_argument("--B", type=int, default=1000)
    ap.add_argument("--seconds", type=float, default=2.0)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--mode", default="none")
    args = ap.parse_args(argv)
    trees = {"this tree": str(Path(__file__).resolve().parent.parent), "other": str(Path(args.other).resolve())}
    print(f"run_batch {args.mode}, B={args.B}, {args.seconds:g} s, 1 thread, engine CPU time per scenario-step")
    for _ in range(args.rounds):
        for name, root in trees.items():
            env = dict(os.environ, PYTHONPATH=root, ADAPTIVE_FF_THREADS="1")
            out = subprocess.run([sys.executable, "-c", _CHILD, str(args.B), str(args.seconds), str(args.repeat),
                                  args.mode], env=env, cwd=root, capture_output=True, text=True, check=True)
            print(f"{name:<10} {out.stdout.strip()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
