"""A/B of the engine between two source trees (e.g. before/after a change of the plant step).

Run:  git worktree add /tmp/old REV   (or: mkdir /tmp/old && git archive REV | tar -x -C /tmp/old)
      (cd /tmp/old && python setup.py build_ext --inplace)   # its C core, built in place
      python benchmarks/tree_ab.py /tmp/old [--B 1000] [--seconds 2] [--repeat 5] [--rounds 3] [--mode none]
                                   [--plants lugre]
      python benchmarks/tree_ab.py /tmp/old --ratio [--other-python /venv-of-old/bin/python]
      python benchmarks/tree_ab.py /tmp/old --engine [--seconds 60] [--repeat 5] [--rounds 4]
      python benchmarks/tree_ab.py /tmp/old --build [--rounds 4]

``--ratio`` times, in the same alternating fresh processes, python-control's ``input_output_response`` on
the PI + plant loop of ``benchmarks/perf.py`` and the single-run engine (``run_mode`` ``none`` and
``adaptive`` with noise 1e-3; the whole call, and its Python part: CPU time outside the C engine call
``EngineRun.run``), each timed call from a new options object made before the timing (a user's single call
builds its settings: a cache keyed by the options object would save only on repeats), and prints the ratios of both trees to one python-control baseline (the
median over all their processes): the speed target "warm engine ratio to python-control not worse than
before" compared on one machine in one run, where python-control's own time per step varies several-fold
between runs (docs/benchmarks/perf.md). ``--other-python`` runs the
other tree under another interpreter (a tree from before the C core needs an environment with numba).

Each tree imports its own C core: the extension modules built in place beside its packages (``setup.py
build_ext --inplace``; an editable install of this tree has done that for this one). Each round runs one
fresh process per tree (this tree and OTHER, alternating), which times ``run_batch`` with one engine thread
(``ADAPTIVE_FF_THREADS=1``) by the CPU time of the calling thread (``time.thread_time``: not inflated by other
processes on a loaded machine) and prints µs per scenario-step of the engine (median and fastest of
``--repeat``), the serial Python part of the call (CPU of the calling thread outside the engine's
``EngineRun.run``: packing the scenarios, the results; each timed call from a new options object) and the first
metrics, so a change of the numbers shows. The scenarios are B ``paper`` plants with jittered J, Fc and tau (default),
or with ``--plants NAME`` one plant of a model of :func:`plant.variant_plants.variant` B times (``lugre``,
``karnopp``, ``asymmetric``: the plant-model rows of ``benchmarks/perf.py``).

``--build`` times ``build_mode none`` and ``adaptive`` (the ``--ratio`` settings), each call from a new options
object made before the timing, in alternating fresh processes, and prints each process's fastest of nine timings of
200 calls and, per tree, the median and the range over its processes (µs per call).

``--engine`` times the C engine call alone (``EngineRun.run``, CPU time of the calling thread) of the single runs
``run_mode none`` and ``adaptive`` (noise 1e-3) of ``benchmarks/engine_instructions.py``'s loop on a reference of
``--seconds`` (long, so the call's fixed cost does not count), in alternating fresh processes, and prints each
process's median of ``--repeat`` calls and, per tree, the median and the range over its processes (ns per step).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

_CHILD = r"""
import statistics, sys, time
import numpy as np
import controllers.simulation.batch as bm
from controllers.simulation.engine import EngineRun
from plant.excitation import multisine_reference
from plant.friction import preset
B, seconds, repeat, mode, model = int(sys.argv[1]), float(sys.argv[2]), int(sys.argv[3]), sys.argv[4], sys.argv[5]
p = preset("paper")
ref = multisine_reference(seconds, rng=np.random.default_rng(0))
rng = np.random.default_rng(2)
if model == "paper":
    plants = [p.replace(J=p.J * rng.uniform(0.7, 1.3), Fc=p.Fc * rng.uniform(0.7, 1.3),
                        tau=p.tau * rng.uniform(0.5, 2.0)) for _ in range(B)]
else:  # one plant of the model, B times (perf.py's rows of the plant models)
    from plant.variant_plants import variant
    plants = [variant(model)] * B
def options():
    flat = dict(Kp=69.28434179621937, Ki=786.1169272191827, u_max=150.0, Vs=p.Vs, delta=p.delta, sensor_gate=False)
    try:
        from controllers.simulation.closed_loop import LoopConfig
        return LoopConfig.from_flat(**flat)
    except ImportError:  # a tree with the flat ModeOptions
        from controllers.simulation.compensators import ModeOptions
        return ModeOptions(**flat)
fresh = [options() for _ in range(repeat)]  # a new options object per timed call, made before the timing
run, spent = EngineRun.run, []
def timed(self):
    t0 = time.thread_time(); run(self); spent.append(time.thread_time() - t0)
bm.run_batch(plants[:2], ref, mode, options())
EngineRun.run = timed
whole = []
for o in fresh:
    t0 = time.thread_time()
    r = bm.run_batch(plants, ref, mode, o)
    whole.append(time.thread_time() - t0)
n = B * ref.t.size
serial = [a - b for a, b in zip(whole, spent)]
print(f"median {statistics.median(spent) / n * 1e6:.4f} µs, fastest {min(spent) / n * 1e6:.4f} µs; "
      f"serial Python part {statistics.median(serial) * 1e3:.2f} ms (least {min(serial) * 1e3:.2f}); "
      f"rms[:2] {r.rms[:2].tolist()}")
"""

#: The children's loop: the ``paper`` preset, its PI, ``options(**extra)`` (a new options object, in either tree's
#: form) and each mode's ``extra`` settings.
_LOOP = r"""
from controllers.design.pi import design_pi
from plant.friction import preset
p = preset("paper")
d = design_pi(p.J, crossover=20.0, phase_margin=60.0, Tc=1e-3)
u_max = 150.0
def options(**extra):
    try:
        from controllers.simulation.closed_loop import LoopConfig
        return LoopConfig.from_flat(Kp=d.Kp, Ki=d.Ki, u_max=u_max, **extra)
    except ImportError:  # a tree with the flat ModeOptions
        from controllers.simulation.compensators import ModeOptions
        return ModeOptions(Kp=d.Kp, Ki=d.Ki, u_max=u_max, **extra)
extra = {"none": {}, "adaptive": dict(Vs=p.Vs, delta=p.delta, noise_std=1e-3)}
"""

_RATIO_CHILD = _LOOP + r"""
import json, statistics, sys, time
import numpy as np
import control
from controllers.simulation.closed_loop import run_mode
from plant.excitation import multisine_reference
from plant.joint import make_rk4_step
seconds, repeat = float(sys.argv[1]), int(sys.argv[2])
Tc = d.Tc
step = make_rk4_step(p, Tc)
Kp, KiTc = d.Kp, d.Ki * Tc
def ctrl_out(t, x, u, params):
    e = u[0] - u[1]
    return np.array([min(max(Kp * e + x[0] + KiTc * e, -u_max), u_max)])
P = control.nlsys(lambda t, x, u, params: np.array(step(x[0], x[1], u[0])), lambda t, x, u, params: x[:1],
                  inputs=["u"], outputs=["w"], states=2, dt=Tc, name="plant")
C = control.nlsys(lambda t, x, u, params: np.array([x[0] + KiTc * (u[0] - u[1])]), ctrl_out,
                  inputs=["r", "w"], outputs=["u"], states=1, dt=Tc, name="pi")
loop = control.interconnect([P, C], inplist=["pi.r"], outlist=["plant.w", "pi.u"],
                            connections=[["plant.u", "pi.u"], ["pi.w", "plant.w"]], dt=Tc)
def cpu(fn, reps):
    out = []
    for _ in range(reps):
        t0 = time.thread_time(); fn(); out.append(time.thread_time() - t0)
    return statistics.median(out)
pc_ref = multisine_reference(min(seconds, 2.0), rng=np.random.default_rng(0))
us = {"python-control": cpu(lambda: control.input_output_response(loop, pc_ref.t, pc_ref.w),
                            max(1, repeat // 2)) / pc_ref.t.size * 1e6}
ref = multisine_reference(seconds, rng=np.random.default_rng(0))
from controllers.simulation.engine import EngineRun
engine_run, spent = EngineRun.run, []
def timed(self):
    t0 = time.thread_time(); engine_run(self); spent.append(time.thread_time() - t0)
EngineRun.run = timed
for mode in ("none", "adaptive"):
    run_mode(p, ref, mode, options(**extra[mode]), rng=np.random.default_rng(1))  # warm-up (a JIT compiles)
    # each timed call gets a new options object, made before the timing: a user's single call pays what a
    # settings cache keyed by the options object would save on repeats
    fresh = [options(**extra[mode]) for _ in range(repeat)]
    whole = []
    spent.clear()
    for o in fresh:
        t0 = time.thread_time(); run_mode(p, ref, mode, o, rng=np.random.default_rng(1))
        whole.append(time.thread_time() - t0)
    us[mode] = statistics.median(whole) / ref.t.size * 1e6
    us[mode + " python ms"] = statistics.median(w - e for w, e in zip(whole, spent)) * 1e3
print(json.dumps(us))
"""

_ENGINE_CHILD = _LOOP + r"""
import json, statistics, sys, time
import numpy as np
from controllers.simulation.closed_loop import run_mode
from controllers.simulation.engine import EngineRun
from plant.excitation import multisine_reference
seconds, repeat = float(sys.argv[1]), int(sys.argv[2])
run, spent = EngineRun.run, []
def timed(self):
    t0 = time.thread_time(); run(self); spent.append(time.thread_time() - t0)
EngineRun.run = timed
ref = multisine_reference(seconds, rng=np.random.default_rng(0))
ns = {}
for mode in ("none", "adaptive"):
    o = options(**extra[mode])
    run_mode(p, ref, mode, o, rng=np.random.default_rng(1))  # warm-up
    spent.clear()
    for _ in range(repeat):
        run_mode(p, ref, mode, o, rng=np.random.default_rng(1))
    ns[mode] = statistics.median(spent) / ref.t.size * 1e9
print(json.dumps(ns))
"""

_BUILD_CHILD = _LOOP + r"""
import json, sys, time
from controllers.simulation.compensators import build_mode
calls, timings = int(sys.argv[1]), int(sys.argv[2])
us = {}
for mode in ("none", "adaptive"):
    build_mode(p, mode, options(**extra[mode]))  # warm-up
    best = []
    for _ in range(timings):
        fresh = [options(**extra[mode]) for _ in range(calls)]  # new options objects, made before the timing
        t0 = time.thread_time()
        for o in fresh:
            build_mode(p, mode, o)
        best.append((time.thread_time() - t0) / calls * 1e6)
    us[mode] = min(best)
print(json.dumps(us))
"""


def build_rounds(trees: dict, *, calls: int = 200, timings: int = 9, rounds: int = 4, out=print) -> dict:
    """Alternate fresh processes of the trees; print µs per ``build_mode`` call of ``none`` and ``adaptive``, each
    call from a new options object (made before the timing), the fastest of ``timings`` timings of ``calls`` calls.

    Parameters
    ----------
    trees : dict of str -> str
        Name -> root of a source tree (holds plant/, adaptive_ff/, controllers/, extensions built in place).
    calls, timings, rounds : int
        Calls per timing, timings per process (the fastest counts), processes per tree.
    out : callable
        Receives each printed line.

    Returns
    -------
    dict of str -> dict of str -> list of float
        Name -> mode -> the processes' fastest timings (µs per call), in the order run.
    """
    out(f"build_mode from a new options object per call, CPU time of the calling thread, fastest of {timings} "
        f"timings of {calls} calls per process, µs per call")
    return _alternate(trees, (_BUILD_CHILD, str(calls), str(timings)), rounds, "µs per call", out)


def _alternate(trees: dict, child: tuple, rounds: int, unit: str, out) -> dict:
    """Run ``python -c child[0] child[1:]`` in each tree in turn, ``rounds`` times (fresh processes, one BLAS and
    engine thread); each prints a JSON ``{"none": x, "adaptive": y}`` as its last line. Prints each process's pair
    and each tree's medians and ranges (``unit``); returns name -> mode -> the values in the order run."""
    out(f"{'tree':<10} {'none':>9} {'adaptive':>9}")
    runs = {name: {"none": [], "adaptive": []} for name in trees}
    for _ in range(rounds):
        for name, root in trees.items():
            env = dict(os.environ, PYTHONPATH=root, ADAPTIVE_FF_THREADS="1")
            proc = subprocess.run([sys.executable, "-c", *child], env=env, cwd=root, capture_output=True, text=True,
                                  check=True)
            v = json.loads(proc.stdout.strip().splitlines()[-1])
            for mode in ("none", "adaptive"):
                runs[name][mode].append(v[mode])
            out(f"{name:<10} {v['none']:>9.1f} {v['adaptive']:>9.1f}")
    for name, by_mode in runs.items():
        out(f"{name:<10} " + ", ".join(f"{m} median {statistics.median(v):.1f} (range {min(v):.1f}-{max(v):.1f})"
                                       for m, v in by_mode.items()) + f" {unit}")
    return runs


def engine_rounds(trees: dict, *, seconds: float = 60.0, repeat: int = 5, rounds: int = 4, out=print) -> dict:
    """Alternate fresh processes of the trees; print the C engine call's ns per step of ``none`` and ``adaptive``.

    Parameters
    ----------
    trees : dict of str -> str
        Name -> root of a source tree (holds plant/, adaptive_ff/, controllers/, extensions built in place).
    seconds, repeat, rounds : float, int, int
        Simulated time of each run (s), timed calls per process (median), processes per tree.
    out : callable
        Receives each printed line.

    Returns
    -------
    dict of str -> dict of str -> list of float
        Name -> mode -> the processes' medians (ns per step), in the order run.
    """
    out(f"C engine call (EngineRun.run) of run_mode, {seconds:g} s reference, CPU time of the calling thread, "
        f"median of {repeat} calls per process, ns per step")
    return _alternate(trees, (_ENGINE_CHILD, str(seconds), str(repeat)), rounds, "ns/step", out)


def ratio_rounds(trees: dict, pythons: dict, *, seconds: float = 20.0, repeat: int = 5, rounds: int = 3,
                 out=print) -> dict:
    """Alternate fresh processes of the trees; print µs per step of python-control and the engine, and ratios.

    Every process times python-control's loop too, but the ratios judged are taken against one baseline: the
    median python-control time over all processes of both trees (its per-process time varies by 10-20 % on a
    shared machine, more than the engines differ), divided by each tree's median engine time.

    Parameters
    ----------
    trees : dict of str -> str
        Name -> root of a source tree (holds plant/, adaptive_ff/, controllers/).
    pythons : dict of str -> str
        Name -> interpreter that runs that tree.
    seconds, repeat, rounds : float, int, int
        Simulated time of each ``run_mode`` (s; python-control runs ``min(seconds, 2)``), timed calls per
        process (median), processes per tree.
    out : callable
        Receives each printed line.

    Returns
    -------
    dict of str -> (float, float)
        Name -> ratio of ``none`` and of ``adaptive`` to the common python-control baseline.
    """
    out(f"python-control input_output_response ({min(seconds, 2.0):g} s) and run_mode ({seconds:g} s), "
        "CPU time of the calling thread, median of --repeat, µs per step")
    out(f"{'tree':<10} {'python-control':>15} {'none':>9} {'adaptive':>9}   Python part of a call (ms): none, adaptive")
    runs = {name: [] for name in trees}
    for _ in range(rounds):
        for name, root in trees.items():
            env = dict(os.environ, PYTHONPATH=root, ADAPTIVE_FF_THREADS="1")
            proc = subprocess.run([pythons[name], "-c", _RATIO_CHILD, str(seconds), str(repeat)],
                                  env=env, cwd=root, capture_output=True, text=True, check=True)
            us = json.loads(proc.stdout.strip().splitlines()[-1])
            runs[name].append(us)
            out(f"{name:<10} {us['python-control']:>15.1f} {us['none']:>9.4f} {us['adaptive']:>9.4f}   "
                f"{us['none python ms']:.3f} {us['adaptive python ms']:.3f}")
    pc = statistics.median(us["python-control"] for rs in runs.values() for us in rs)
    ratios = {}
    for name, rs in runs.items():
        none, adaptive, py_none, py_adaptive = (statistics.median(us[m] for us in rs) for m in (
            "none", "adaptive", "none python ms", "adaptive python ms"))
        ratios[name] = (pc / none, pc / adaptive)
        out(f"{name:<10} median engine none {none:.4f}, adaptive {adaptive:.4f} µs/step (Python part {py_none:.3f}, "
            f"{py_adaptive:.3f} ms per call); against python-control's median of all runs ({pc:.1f} µs/step): none "
            f"{pc / none:.0f}x, adaptive {pc / adaptive:.0f}x")
    return ratios


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("other", help="root of the other source tree (holds plant/, adaptive_ff/, controllers/)")
    ap.add_argument("--B", type=int, default=1000)
    ap.add_argument("--seconds", type=float, default=2.0)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--mode", default="none")
    ap.add_argument("--plants", default="paper",
                    help="run_batch's plants: paper (B jittered paper plants, default) or a variant model's name, B times")
    ap.add_argument("--ratio", action="store_true",
                    help="time run_mode none/adaptive against python-control in both trees (ratios), not run_batch")
    ap.add_argument("--engine", action="store_true",
                    help="time the C engine call of run_mode none/adaptive in both trees (ns per step)")
    ap.add_argument("--build", action="store_true",
                    help="time build_mode none/adaptive from new options objects in both trees (µs per call)")
    ap.add_argument("--other-python", default=sys.executable,
                    help="interpreter for the other tree (default: this one)")
    args = ap.parse_args(argv)
    trees = {"this tree": str(Path(__file__).resolve().parent.parent), "other": str(Path(args.other).resolve())}
    pythons = {"this tree": sys.executable, "other": args.other_python}
    if args.build:
        build_rounds(trees, rounds=args.rounds)
        return 0
    if args.engine:
        engine_rounds(trees, seconds=args.seconds, repeat=args.repeat, rounds=args.rounds)
        return 0
    if args.ratio:
        ratio_rounds(trees, pythons, seconds=args.seconds, repeat=args.repeat, rounds=args.rounds)
        return 0
    print(f"run_batch {args.mode}, B={args.B} {args.plants} plants, {args.seconds:g} s, 1 thread, engine CPU time per "
          "scenario-step")
    for _ in range(args.rounds):
        for name, root in trees.items():
            env = dict(os.environ, PYTHONPATH=root, ADAPTIVE_FF_THREADS="1")
            out = subprocess.run([pythons[name], "-c", _CHILD, str(args.B), str(args.seconds), str(args.repeat),
                                  args.mode, args.plants], env=env, cwd=root, capture_output=True, text=True,
                             check=True)
            print(f"{name:<10} {out.stdout.strip()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
