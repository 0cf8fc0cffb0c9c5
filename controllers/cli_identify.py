"""``adaptive-ff identify``: friction parameters from a measured log (offline LS and RLS)."""

from __future__ import annotations

import json

__all__ = ["register"]


def run(args) -> int:
    """Execute ``adaptive-ff identify`` with parsed ``args``; return the exit status."""
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



def register(sub) -> None:
    """Add the ``identify`` subcommand to an argparse subparsers object."""
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
    i.set_defaults(func=run)
