"""Instructions per 1 kHz step of the C engine (``run_mode none``, ``fixed`` and ``adaptive``) under callgrind.

Run:  python benchmarks/engine_instructions.py [--tree TREE ...] [--seconds 2] [--keep DIR] [--batch B [--plants M]]

Each mode runs in one process under ``valgrind --tool=callgrind`` with collection on inside the engine call only
(``--toggle-collect`` of its cffi wrapper ``_cffi_f_ctl_run_chunk``) and one profile dump after every call
(``--dump-after``): a warm-up, then runs of ``seconds`` and ``3*seconds`` on the loop of ``benchmarks/perf.py``
(paper preset, PI at 20 rad/s; ``fixed`` with the true friction as its estimate and ``adaptive`` with its Vs,
delta, both with the noise 1e-3 rad/s). Instructions per step
are the difference of the two runs' counts over the difference of their steps: the work per period, without the
fixed cost of a call. Counts do not depend on the machine's load (timings on a shared machine do), only on the
code and the compiler: the measure to compare two trees side by side (``--tree`` names one or more source trees
with their extensions built in place; default this one; a tree whose loop settings are the older flat
``ModeOptions`` runs the same loop). ``--keep DIR`` keeps the profiles (``DIR/<tree>-<mode>.<i>``, the last one
the long run) for ``callgrind_annotate``. ``--batch B`` counts ``run_batch`` instead, per scenario-step: B ``paper``
plants (2 to 64: one chunk, one engine call per run, time-major as every chunk of a larger batch) with J, Fc and tau
jittered as ``benchmarks/tree_ab.py``'s, the loop's PI and the ``adaptive`` estimator's Vs, delta without noise or
sensor gate (``run_batch``'s rows of ``benchmarks/perf.py``); ``fixed`` is left out. ``--plants NAME`` with
``--batch``: one plant of that model of :func:`plant.variant_plants.variant` B times (``lugre``, ...).
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile

#: The script each measured process runs: mode, seconds; prints the steps of its three engine calls.
_SCRIPT = r"""
import math, sys
import numpy as np
from controllers.simulation.closed_loop import run_mode
from controllers.design.pi import design_pi
from adaptive_ff.identification.regression import FrictionEstimate
from plant.excitation import multisine_reference
from plant.friction import preset
mode, secs = sys.argv[1], float(sys.argv[2])
p = preset("paper")
d = design_pi(p.J, crossover=20.0, phase_margin=60.0, Tc=1e-3)
extra = {}
if mode == "adaptive":
    extra = dict(Vs=p.Vs, delta=p.delta, noise_std=1e-3)
elif mode == "fixed":
    extra = dict(estimate=FrictionEstimate(J=p.J, tau=p.tau, sigma=p.sigma, Fc=p.Fc, Fs=p.Fs, offset=0.0, Vs=p.Vs,
                                           delta=p.delta, J_alt=math.nan), noise_std=1e-3)
try:
    from controllers.simulation.closed_loop import LoopConfig
    o = LoopConfig.from_flat(Kp=d.Kp, Ki=d.Ki, u_max=150.0, **extra)
except ImportError:  # a tree with the flat ModeOptions
    from controllers.simulation.compensators import ModeOptions
    o = ModeOptions(Kp=d.Kp, Ki=d.Ki, u_max=150.0, **extra)
refs = [multisine_reference(s, rng=np.random.default_rng(0)) for s in (0.2, secs, 3 * secs)]
for ref in refs:
    run_mode(p, ref, mode, o, rng=np.random.default_rng(1))
print(" ".join(str(r.t.size) for r in refs))
"""

#: The script of ``--batch``: mode, seconds, B; prints the scenario-steps of its three engine calls.
_BATCH_SCRIPT = r"""
import sys
import numpy as np
from controllers.simulation.batch import run_batch
from plant.excitation import multisine_reference
from plant.friction import preset
mode, secs, B, model = sys.argv[1], float(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
p = preset("paper")
rng = np.random.default_rng(2)
plants = [p.replace(J=p.J * rng.uniform(0.7, 1.3), Fc=p.Fc * rng.uniform(0.7, 1.3), tau=p.tau * rng.uniform(0.5, 2.0))
          for _ in range(B)]
if model != "paper":  # one plant of a variant model, B times (tree_ab.py --plants)
    from plant.variant_plants import variant
    plants = [variant(model)] * B
flat = dict(Kp=69.28434179621937, Ki=786.1169272191827, u_max=150.0, Vs=p.Vs, delta=p.delta, sensor_gate=False)
try:
    from controllers.simulation.closed_loop import LoopConfig
    o = LoopConfig.from_flat(**flat)
except ImportError:  # a tree with the flat ModeOptions
    from controllers.simulation.compensators import ModeOptions
    o = ModeOptions(**flat)
refs = [multisine_reference(s, rng=np.random.default_rng(0)) for s in (0.1, secs, 3 * secs)]
for ref in refs:
    run_batch(plants, ref, mode, o)
print(" ".join(str(r.t.size * B) for r in refs))
"""

MODES = ("none", "fixed", "adaptive")


def per_step(tree: str, mode: str, seconds: float = 2.0, keep: str | None = None, batch: int = 0,
             plants: str = "paper") -> float | None:
    """Instructions per step of ``mode`` in the source tree ``tree`` (None without valgrind); ``keep``: a folder
    that receives the profiles (``<tree's name>-<mode>.<i>``); ``batch`` > 0: per scenario-step of ``run_batch``
    over that many scenarios of ``plants`` (``--batch``, ``--plants``)."""
    vg = shutil.which("valgrind")
    if vg is None:
        return None
    script = (_BATCH_SCRIPT, mode, str(seconds), str(batch), plants) if batch > 0 else (_SCRIPT, mode, str(seconds))
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "cg.out")
        env = dict(os.environ, PYTHONPATH=os.path.abspath(tree), ADAPTIVE_FF_THREADS="1")
        res = subprocess.run([vg, "--tool=callgrind", f"--callgrind-out-file={out}", "--collect-atstart=no",
                              "--toggle-collect=_cffi_f_ctl_run_chunk", "--dump-after=_cffi_f_ctl_run_chunk",
                              sys.executable, "-c", *script],
                             capture_output=True, text=True, check=True, cwd=tree, env=env, timeout=3600)
        steps = [int(x) for x in res.stdout.split()]
        counts = []
        names = sorted(os.listdir(tmp), key=lambda f: int(f.rsplit(".", 1)[-1]) if f[-1].isdigit() else 0)
        for name in names:
            m = re.search(r"^(?:summary|totals):\s+(\d+)", open(os.path.join(tmp, name)).read(), re.M)
            if name.startswith("cg.out.") and m:
                counts.append(int(m.group(1)))
                if keep is not None:
                    os.makedirs(keep, exist_ok=True)
                    label = os.path.basename(os.path.abspath(tree))
                    shutil.copy(os.path.join(tmp, name), os.path.join(keep, f"{label}-{mode}.{len(counts)}"))
    counts = counts[-3:]
    return (counts[2] - counts[1]) / (steps[2] - steps[1])


def perf_rows(tree: str, seconds: float = 2.0) -> list:
    """Rows for ``benchmarks/perf.py``: instructions per step of each mode in ``tree``."""
    rows = []
    for mode in MODES:
        n = per_step(tree, mode, seconds)
        if n is None:
            return [("instructions per step: valgrind not installed", None, "")]
        rows.append((f"  run_mode {mode}, instructions per step (callgrind, in the engine call)", n, "instr"))
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tree", action="append", default=None,
                    help="source tree with its extensions built (repeatable; default this one)")
    ap.add_argument("--seconds", type=float, default=2.0, help="length of the shorter measured run (s)")
    ap.add_argument("--keep", default=None, help="folder that keeps the callgrind profiles (for callgrind_annotate)")
    ap.add_argument("--batch", type=int, default=0,
                    help="count run_batch over B scenarios (none, adaptive), per scenario-step")
    ap.add_argument("--plants", default="paper",
                    help="with --batch: paper (jittered paper plants, default) or a variant model's name, B times")
    args = ap.parse_args(argv)
    if args.batch and not 2 <= args.batch <= 64:
        ap.error(f"--batch must be 2 to 64 scenarios (one engine call per run), got {args.batch}")
    trees = args.tree or [os.path.dirname(os.path.dirname(os.path.abspath(__file__)))]
    modes = ("none", "adaptive") if args.batch > 0 else MODES
    unit = f"instructions per scenario-step of run_batch, B = {args.batch}" if args.batch > 0 else \
        "instructions per step"
    print(f"{'tree':<40}" + "".join(f"{m:>12}" for m in modes) + f"   {unit}")
    for tree in trees:
        vals = [per_step(tree, m, args.seconds, args.keep, args.batch, args.plants) for m in modes]
        print(f"{tree:<40}" + "".join(f"{v:>12.1f}" if v is not None else f"{'n/a':>12}" for v in vals))
    return 0


if __name__ == "__main__":
    sys.exit(main())
