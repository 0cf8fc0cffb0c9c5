"""``adaptive-ff identify``: friction parameters from a measured log (offline LS and RLS)."""

from __future__ import annotations

import json

__all__ = ["register"]


def run(args) -> int:
    """Execute ``adaptive-ff identify`` with parsed ``args``; return the exit status."""
    from adaptive_ff.identify import identify
    from controllers.cli_data import command_line, load_data_from_args

    data = load_data_from_args(args)
    report = identify(data, Vs=args.Vs, delta=args.delta, lag=args.lag, offset=not args.no_offset,
                      lam=args.lam)
    extra = {}
    if args.plot or args.report:
        from controllers.paper_figures import identification_figures, save_figures

        figures = identification_figures(report, data)
        if args.plot:
            extra["figures"] = [str(x) for x in save_figures(figures, args.plot)]
    if args.report:
        from controllers.report import identify_report

        extra["report"] = str(identify_report(args.report, report, data, command=command_line()))
    if args.json:
        print(json.dumps({**report.to_json_dict(), **extra}, indent=2))
    else:
        print(report.summary())
        if "figures" in extra:
            print("figures: " + ", ".join(extra["figures"]))
        if "report" in extra:
            print(f"report: {extra['report']}")
    return 0


def register(sub) -> None:
    """Add the ``identify`` subcommand to an argparse subparsers object."""
    from controllers.cli_data import DATA_EPILOG, add_data_arguments

    i = sub.add_parser("identify", help="identify friction parameters from measured data", epilog=DATA_EPILOG,
                       description="Offline LS (eq. 9) and RLS (eqs. 10-13) identification of the discrete-time "
                                   "friction model from a measured log (CSV/TXT, .mat, .npz with columns t,u,w or mapped "
                                   "by --columns; SI units unless told otherwise) or the EMPS benchmark .mat file.")
    i.add_argument("file", help="data file (CSV/TXT, .mat, .npz) or the EMPS benchmark .mat")
    i.add_argument("--Vs", type=float, default=None, help="Stribeck velocity (rad/s); with --delta selects the "
                                                          "Stribeck structure, else Coulomb + viscous")
    i.add_argument("--delta", type=float, default=None, help="Stribeck shape factor")
    i.add_argument("--lag", action="store_true", help="also estimate the friction lag tau (default: tau = 0; on "
                                                      "EMPS the fitted tau follows the velocity filter, not the plant)")
    i.add_argument("--no-offset", action="store_true", help="no constant torque offset regressor")
    i.add_argument("--lam", type=float, default=1.0, help="RLS forgetting factor (default 1)")
    i.add_argument("--json", action="store_true", help="print the parameters as JSON")
    i.add_argument("--plot", metavar="DIR", default=None,
                   help="write the paper's kinds of figures for these data (measured vs LS/RLS velocity, "
                        "parameter convergence, sample-time histogram) as PNG into DIR")
    i.add_argument("--report", metavar="DIR", default=None, help="write a self-contained HTML report into DIR")
    i.add_argument("--quiet", action="store_true", help="no progress bar")
    add_data_arguments(i)
    i.set_defaults(func=run)
