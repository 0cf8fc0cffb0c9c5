"""The plant zoo: N random joints, every compensation mode, eta quantiles, win rates, failures.

Run:  python benchmarks/zoo.py [--n 100] [--duration 120] [--seed 0] [--modes none,fixed,adaptive,dob,...]
                               [--group 8] [--workers 2] [--scheduler tcp://host:8786]
                               [--min-degradation 0.01] [--estimator sliding|eq4|eq4-rls] [--J-design-factor F]
                               [--iv-map-stderr inf] [--no-switch-in] [--scenario FILE] [--export DIR]
                               [--json out.json] [--yes]

Draws the joints with :func:`controllers.experiments.zoo.draw_plants` (the box of
:class:`controllers.experiments.zoo.ZooBox`), prepares each as ``compare`` does
(PI from the design inertia, pre-fit and offline fit from simulated experiments),
runs every mode on the batch engine (all cores; Dask with ``--scheduler``) and
prints eta (second half) per mode as quantiles with the count of every outcome
(ok, refused, diverged, undefined, no reference, invalid) and of the joints where the mode is worse than none
(``<none``: eta < -0.02), the win rates of the
adaptive modes against fixed, DOB and Canudas, the targets (no run refused or
diverged; best adaptive eta > 0 on every joint with a defined eta; best adaptive
at or above the DOB on at least 95 %) with the joints that miss them, and the
wall time split into preparation and runs, and the joints where an adaptive mode's largest velocity error
exceeds the larger of ``none``'s and twice ``frictionless``'s (target: none).

``--scenario FILE`` places every joint into a scenario file's comparison (``ZooOptions.compare``): its
reference (the joints are drawn for its peak speed and acceleration; ``--duration`` is refused), sensor,
slew limit and controller design; each joint keeps its own torque limit and design inertia.

``--export DIR`` runs mode ``adaptive`` on every joint through an ``adaptive-ff export-c`` folder's C code,
compiled in each worker (``ZooOptions.export``, :class:`controllers.simulation.exported.ExportedLibrary`), each joint
configured by the library's own ``aff_init`` with the settings the package gives it: the zoo of what a drive
runs. A new mode
of the registry is picked up by default (``--modes`` lists the registry).

A zoo estimated beyond 10 minutes or 4 GiB (``--n`` joints of ``--duration`` s in every mode,
:func:`controllers.cli.budget.zoo_estimate`) is refused with what it would cost unless ``--yes``.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import subprocess
import sys
import time

from controllers.cli.budget import add_yes_argument, check_work, zoo_estimate
from controllers.experiments.scenario import load_scenario
from controllers.experiments.zoo import ZooOptions, run_zoo, zoo_options_dict
from controllers.simulation.compensators import ESTIMATORS, MODES
from plant.errors import ParameterError


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=100, help="number of joints")
    ap.add_argument("--duration", type=float, default=120.0, help="run length (s)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--modes", default=",".join(MODES), help=f"comma-separated subset of {','.join(MODES)}")
    ap.add_argument("--group", type=int, default=8, help="joints per task (preparation + one batch call per mode)")
    ap.add_argument("--workers", type=int, default=None, help="worker processes (default: cores)")
    ap.add_argument("--scheduler", default=None,
                    help="Dask: 'synchronous', 'threads', 'processes' (local schedulers) or a scheduler address")
    ap.add_argument("--min-degradation", type=float, default=0.01,
                    help="eta is undefined where friction raises the uncompensated RMS error by less than this share")
    ap.add_argument("--estimator", default="sliding", choices=ESTIMATORS,
                    help="estimator of the adaptive modes (default sliding)")
    ap.add_argument("--J-design-factor", dest="J_design_factor", type=float, default=None,
                    help="every joint's design inertia as this factor times its true J (a data sheet off by it; 1: "
                         "an exact one); default: identified on each joint, as compare does")
    ap.add_argument("--iv-map-stderr", dest="iv_map_stderr", type=float, default=math.inf,
                    help="the eq4 estimator's determinacy test in mode adaptive, relative to max(Fc, Fs) (default inf: "
                         "none; LoopConfig.estimator.iv_map_stderr)")
    ap.add_argument("--no-switch-in", dest="switch_in", action="store_false",
                    help="mode adaptive as the feedforward alone, without the residual switch-in (as export-c writes "
                         "it; ZooOptions.switch_in)")
    ap.add_argument("--scenario", default=None,
                    help="place every joint into this scenario file's reference, sensor and controller")
    ap.add_argument("--export", default=None, metavar="DIR",
                    help="run mode adaptive through this export-c folder's compiled C (ZooOptions.export)")
    ap.add_argument("--json", default=None, help="write the full result (strict JSON) to this file")
    add_yes_argument(ap)
    args = ap.parse_args(argv)
    base, flat = None, {"duration": args.duration}
    if args.scenario is not None:
        if any(a == "--duration" or a.startswith("--duration=") for a in (argv if argv is not None else sys.argv[1:])):
            ap.error("--duration: the scenario's reference sets the duration")
        try:
            base, flat = load_scenario(args.scenario).options, {}
        except ParameterError as exc:
            ap.error(str(exc))
    try:
        o = ZooOptions.from_flat(compare=base, **flat, n=args.n, seed=args.seed, modes=tuple(args.modes.split(",")),
                                 group=args.group, workers=args.workers, scheduler=args.scheduler,
                                 min_degradation=args.min_degradation, estimator=args.estimator,
                                 J_design_factor=args.J_design_factor, iv_map_stderr=args.iv_map_stderr,
                                 switch_in=args.switch_in, export=args.export)
    except ParameterError as exc:  # a setting out of range: argparse's message and exit code 2, no traceback
        ap.error(str(exc))
    try:  # --n and --duration bounded up front: beyond 10 min or 4 GiB only with --yes
        check_work(zoo_estimate(o.n, o.duration, len(o.modes), o.workers), yes=args.yes)
    except ParameterError as exc:
        ap.error(str(exc))
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], capture_output=True,
                               text=True).stdout.strip()
        commit += "+dirty" * bool(dirty)  # uncommitted changes: the numbers are not those of the commit alone
    except OSError:
        commit = "?"
    print(f"# {' '.join(['python benchmarks/zoo.py', *(argv if argv is not None else sys.argv[1:])])}")
    print(f"# {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, commit {commit}, {platform.machine()}, "
          f"cores {__import__('os').cpu_count()}")
    if o.export is not None:
        print(f"# mode adaptive runs through the compiled C of the export folder {o.export}")
    r = run_zoo(o)
    print(r.summary())
    tm = r.timing
    print(f"wall {r.seconds:.1f} s, {60.0 * len(r.plants) / r.seconds:.1f} joints/min ({len(r.modes)} modes, "
          f"{o.duration:g} s each); CPU in the workers: preparation {tm['prepare_cpu']:.1f} s, runs of every "
          f"mode {tm['runs_cpu']:.1f} s")
    if args.json:
        d = r.to_dict()
        d["options"] = zoo_options_dict(o)
        with open(args.json, "w") as fh:
            json.dump(d, fh, allow_nan=False)
    return 0


if __name__ == "__main__":
    sys.exit(main())
