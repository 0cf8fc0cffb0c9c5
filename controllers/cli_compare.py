"""``adaptive-ff compare``: all friction-compensation modes on one plant, table and figures."""

from __future__ import annotations

import json

__all__ = ["register"]


def run(args) -> int:
    """Execute ``adaptive-ff compare`` with parsed ``args``; return the exit status."""
    from controllers.compare import compare
    from controllers.figures import plot_comparison
    from plant.friction import JointParams, preset

    p = JointParams.from_json(args.plant) if args.plant else preset(args.preset)
    progress = None if not args.quiet else False
    comp = compare(p, duration=args.duration, seed=args.seed, Ts=args.Ts, noise_std=args.noise, lam=args.lam,
                   crossover=args.crossover, phase_margin=args.phase_margin, progress=progress)
    paths = [] if args.no_figures else plot_comparison(comp, args.out)
    if args.json:
        d = comp.to_json_dict()
        d["figures"] = [str(x) for x in paths]
        print(json.dumps(d, indent=2))
        return 0
    src = args.plant if args.plant else f"preset '{args.preset}'"
    d = comp.design
    print(f"plant: {src}: " + ", ".join(f"{k}={v:g}" for k, v in p.to_dict().items()))
    print(f"PI: Kp={d.Kp:.4g} N·m·s/rad, Ki={d.Ki:.4g} N·m/rad, Tc={d.Tc:g} s; "
          f"phase margin {d.phase_margin:.1f} deg, gain margin {d.gain_margin:.3g}")
    if comp.prefit is not None:
        print(f"Stribeck pre-fit (Sec. V-C): Vs={comp.prefit.Vs:.4g} rad/s, delta={comp.prefit.delta:.4g}")
    print(f"run: {args.duration:g} s, seed {args.seed}; metrics over the second half\n")
    print(comp.table())
    if paths:
        print("\nfigures: " + ", ".join(str(x) for x in paths))
    return 0



def register(sub) -> None:
    """Add the ``compare`` subcommand to an argparse subparsers object."""
    c = sub.add_parser("compare", help="run all compensation modes on a plant and compare tracking error",
                       description="Simulate the 1 kHz plant in closed loop with the PI velocity controller in the "
                                   "modes none, fixed, adaptive, oracle and frictionless; print the metrics table "
                                   "and write PNG figures.")
    c.add_argument("--preset", default="paper", help="named plant parameter set (default: paper)")
    c.add_argument("--plant", metavar="FILE", help="JSON file with J, Fc, Fs, Vs, delta, sigma, tau (SI units)")
    c.add_argument("--duration", type=float, default=120.0, help="run length in s (default 120)")
    c.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    c.add_argument("--out", default="out", help="directory for the PNG figures (default ./out)")
    c.add_argument("--Ts", type=float, default=0.01, help="identification sample time in s (default 0.01)")
    c.add_argument("--noise", type=float, default=1e-3, help="velocity noise std in rad/s (default 1e-3)")
    c.add_argument("--lam", type=float, default=0.995, help="RLS forgetting factor (default 0.995)")
    c.add_argument("--crossover", type=float, default=20.0, help="PI crossover in rad/s (default 20)")
    c.add_argument("--phase-margin", type=float, default=60.0, help="PI phase margin in deg (default 60)")
    c.add_argument("--json", action="store_true", help="print the metrics as JSON instead of the table")
    c.add_argument("--no-figures", action="store_true", help="do not write figures")
    c.add_argument("--quiet", action="store_true", help="no progress bar")
    c.set_defaults(func=run)

