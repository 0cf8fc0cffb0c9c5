"""Command-line interface ``adaptive-ff`` (the package's top layer: it may import everything).

Subcommands
-----------
compare   run the closed loop in all friction-compensation modes and compare tracking
identify  identify friction (offline LS and RLS) from a measured log (CSV t,u,w or the EMPS .mat)
"""

from __future__ import annotations

import argparse
import json
import sys

__all__ = ["main", "build_parser"]


def _cmd_compare(args) -> int:
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


def _cmd_identify(args) -> int:
    from adaptive_ff.data import load_measurements
    from adaptive_ff.identify import identify

    data = load_measurements(args.file)
    report = identify(data, Vs=args.Vs, delta=args.delta, lag=args.lag, offset=not args.no_offset,
                      lam=args.lam)
    if args.json:
        print(json.dumps(report.to_json_dict(), indent=2))
    else:
        print(report.summary())
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The ``adaptive-ff`` argument parser (subcommands ``compare`` and ``identify``)."""
    ap = argparse.ArgumentParser(prog="adaptive-ff", description=(
        "Identify sliding dynamic friction (Ruderman's discrete-time model: LS, RLS) and compare "
        "friction compensation modes in a PI velocity loop."))
    sub = ap.add_subparsers(dest="command", required=True)

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
    c.set_defaults(func=_cmd_compare)

    i = sub.add_parser("identify", help="identify friction parameters from measured data",
                       description="Offline LS (eq. 9) and RLS (eqs. 10-13) identification of the discrete-time "
                                   "friction model from a CSV file with columns t,u,w (s, N·m or N, rad/s or m/s) "
                                   "or the EMPS benchmark .mat file.")
    i.add_argument("file", help="CSV (t,u,w) or EMPS .mat file")
    i.add_argument("--Vs", type=float, default=None, help="Stribeck velocity (rad/s); with --delta selects the "
                                                          "Stribeck structure, else Coulomb + viscous")
    i.add_argument("--delta", type=float, default=None, help="Stribeck shape factor")
    i.add_argument("--lag", action="store_true", help="also estimate the friction lag tau (default: tau = 0; on "
                                                      "EMPS the fitted tau follows the velocity filter, not the plant)")
    i.add_argument("--no-offset", action="store_true", help="no constant torque offset regressor")
    i.add_argument("--lam", type=float, default=1.0, help="RLS forgetting factor (default 1)")
    i.add_argument("--json", action="store_true", help="print the parameters as JSON")
    i.set_defaults(func=_cmd_identify)
    return ap


def main(argv=None) -> int:
    """Entry point of the ``adaptive-ff`` console script; returns the exit status.

    Package errors (bad parameters, bad data) are printed as ``adaptive-ff: error: ...``
    with exit status 2, without a traceback.
    """
    from plant.errors import FrictionError

    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (FrictionError, FileNotFoundError) as exc:
        print(f"adaptive-ff: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
