"""``adaptive-ff stribeck``: Stribeck-curve pre-fit (paper Sec. V-C) from quasi-static data, and Fig. 8."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

__all__ = ["register", "run"]

_EPILOG = """\
The file is either a drive log (roles t, u, w or q; see below), from which support points are
extracted by --method: 'segments' (one point per constant-velocity run: settle time cut, mean and spread
of w and u), 'bins' (quasi-steady samples of a long log binned by velocity; --J subtracts J*dw/dt), or
'auto' (segments if they give >= 6 points, else bins) -- or, with --points, a table of support points
already averaged (roles w, F and optionally F_std, e.g. --columns w=speed,F=torque,F_std=spread).

Output: the fitted Fc, Fs, Vs, delta, sigma with standard errors and 95 % intervals, the command for
the next step (adaptive-ff identify LOG --Vs .. --delta ..), OUT/fig08_stribeck.png (curve over the
measured means and spread) and OUT/support_points.csv.

example:
  adaptive-ff stribeck out/paper/quasi_static_log.csv --out out/stribeck --report out/stribeck

"""


def _read_points(args):
    """Support points from a table file (roles w, F, F_std)."""
    from adaptive_ff.io.logs import VELOCITY_UNITS, parse_column_map, read_columns
    from adaptive_ff.identification.steady_state import SupportPoints
    import numpy as np

    cmap = parse_column_map(args.columns, roles=("w", "F", "F_std")) if args.columns else {}
    names = {"w": cmap.get("w", "w"), "F": cmap.get("F", "F"), "F_std": cmap.get("F_std", "F_std")}
    from controllers.cli.data import io_options_from_args

    table = read_columns(args.file, names, optional=("F_std",), csv_format=io_options_from_args(args)["csv_format"])
    w = table.columns["w"] * VELOCITY_UNITS[args.velocity_unit]
    F = table.columns["F"]
    if args.current_to_torque is not None:
        F = F * args.current_to_torque
    F_std = table.columns.get("F_std")
    if F_std is not None and args.current_to_torque is not None:
        F_std = F_std * args.current_to_torque
    n = w.shape[0]
    nan = np.full(n, np.nan)
    return SupportPoints(w_mean=w, w_std=nan, u_mean=F, u_std=F_std if F_std is not None else np.zeros(n),
                         n_samples=np.ones(n, dtype=np.int64), t_start=nan, t_end=nan, method="table",
                         notes=(f"{n} support points read from {table.source}",)), None


def run(args) -> int:
    """Execute ``adaptive-ff stribeck`` with parsed ``args``; return the exit status.

    The figure and ``support_points.csv`` (``--out``) and the report (``--report``) are staged and appear together
    at the end (:class:`adaptive_ff.io.output.StagedOutputs`).
    """
    from adaptive_ff.io.output import StagedOutputs
    from controllers.cli.data import check_output_dir

    out_dir = args.out if args.out is not None else (args.report or "out/stribeck")
    if not args.no_figures:
        check_output_dir(out_dir, "--out")
    if args.report:
        check_output_dir(args.report, "--report")
    with StagedOutputs() as staged:
        fig_dir = None if args.no_figures else staged.folder(out_dir, "--out")
        report_dir = staged.folder(args.report, "--report") if args.report else None
        fit, pts, data, paths, report_path = _fit_and_write(args, fig_dir, report_dir)
    paths = [staged.final(x) for x in paths]
    report_path = None if report_path is None else staged.final(report_path)
    return _print_fit(args, fit, pts, data, paths, report_path)


#: The options of the support points' methods: (option, argument of support_points, methods it applies to).
_METHOD_OPTIONS = (("--min-duration", "min_duration", ("segments", "auto")),
                   ("--settle", "settle", ("segments", "auto")), ("--rel-tol", "rel_tol", ("segments", "auto")),
                   ("--bins", "n_bins", ("bins", "auto")), ("--J", "J", ("bins", "auto")),
                   ("--max-accel", "max_accel", ("bins", "auto")))


def _method_options(args) -> dict:
    """The options given for the support points, checked against ``--method`` (ParameterError naming an option
    that the method does not take, or with ``--points``)."""
    from plant.errors import ParameterError

    options = {}
    for option, key, methods in _METHOD_OPTIONS:
        value = getattr(args, key if key != "n_bins" else "bins")
        if value is None:
            continue
        if args.method not in methods:
            raise ParameterError(f"{option} applies to --method {' or '.join(methods)}, not {args.method}")
        options[key] = value
    return options


def _fit_and_write(args, fig_dir, report_dir) -> tuple:
    """The support points and the Stribeck fit of ``args``, the figure and the points written into ``fig_dir``
    and the report into ``report_dir`` (None: not asked for); ``(fit, points, data, paths, report path)``."""
    import numpy as np

    from adaptive_ff.identification.steady_state import support_points
    from adaptive_ff.identification.stribeck_fit import fit_stribeck
    from controllers.cli.data import command_line, load_data_from_args, named_by
    from controllers.experiments.paper_figures import plot_stribeck_figure
    from plant.errors import ParameterError

    if args.points:
        pts, data = _read_points(args)
    else:
        options = _method_options(args)
        data = load_data_from_args(args)
        with named_by(args.file):
            pts = support_points(data, method=args.method, **options)
    F_std = None
    if args.weighted:
        if not np.all(pts.u_std > 0):
            raise ParameterError("--weighted needs a positive torque spread at every support point; "
                                 f"got {pts.u_std.tolist()}")
        F_std = pts.u_std
    with named_by(args.file):
        fit = fit_stribeck(pts.w_mean, pts.u_mean, F_std=F_std)
    show_std = pts.u_std if np.any(pts.u_std > 0) else None

    paths = []
    figure = None
    if fig_dir is not None or report_dir is not None:
        figure = plot_stribeck_figure(fit, pts.w_mean, pts.u_mean, F_std=show_std,
                                      title=f"Stribeck curve over the measured support points: {Path(args.file).name}")
    if fig_dir is not None:
        out = Path(fig_dir)
        png = out / "fig08_stribeck.png"
        figure.savefig(png, dpi=110)
        csv_path = out / "support_points.csv"
        np.savetxt(csv_path, np.column_stack([pts.w_mean, pts.w_std, pts.u_mean, pts.u_std, pts.n_samples]),
                   delimiter=",", header="w_mean,w_std,u_mean,u_std,n_samples", comments="", fmt="%.10g")
        paths = [png, csv_path]
    report_path = None
    if report_dir is not None:
        from controllers.report.html import write_report

        report_path = write_report(
            report_dir, title=f"Stribeck pre-fit: {args.file}", data=data, stribeck=fit, support_points=pts,
            figures={"Stribeck curve over the measured means and spread (cf. paper Fig. 8)": figure},
            command=command_line(),
            notes=[f"next step: adaptive-ff identify LOG --Vs {fit.Vs:.6g} --delta {fit.delta:.6g}"])
    return fit, pts, data, paths, report_path


def _print_fit(args, fit, pts, data, paths, report_path) -> int:
    """The printed fit (or its JSON) and the files written; the exit status (0)."""
    import numpy as np

    from controllers.cli.data import table_unit

    ci = fit.confidence_intervals(0.95)
    if args.json:
        d = fit.to_dict()
        d["confidence_95"] = {k: list(v) for k, v in ci.items()}
        d["support_points"] = pts.to_dict()
        d["source"] = str(args.file)
        d["figures"] = [str(p) for p in paths]
        d["report"] = str(report_path) if report_path else None
        print(json.dumps(d, indent=2, default=lambda x: None))
        return 0
    if data is not None:
        dt = np.diff(data.t)
        print(f"data: {data.source}: {data.n_samples} samples over {data.t[-1] - data.t[0]:.4g} s, "
              f"sample time median {1e3 * np.median(dt):.4g} ms (min {1e3 * dt.min():.4g}, max {1e3 * dt.max():.4g})")
    print(f"support points: {pts.n_points} ({pts.method})")
    for note in pts.notes:
        print(f"  {note}")
    kv, vunit = table_unit(args)
    angle = vunit.split("/")[0]
    units = {"Fc": "N·m", "Fs": "N·m", "Vs": vunit, "delta": "1", "sigma": f"N·m·s/{angle}"}
    scale = {"Fc": 1.0, "Fs": 1.0, "Vs": kv, "delta": 1.0, "sigma": 1.0 / kv}
    print("\nStribeck fit, eq. 3 (Levenberg-Marquardt, Sec. V-C)")
    head = f"{'parameter':<10}{'value':>13}{'std error':>12}{'95 % interval':>28}  unit"
    print(head)
    print("-" * len(head))
    for k in ("Fc", "Fs", "Vs", "delta", "sigma"):
        c = scale[k]
        lo, hi = sorted((c * ci[k][0], c * ci[k][1]))
        print(f"{k:<10}{c * getattr(fit, k):>13.6g}{c * fit.stderr[k]:>12.3g}{f'[{lo:.5g}, {hi:.5g}]':>28}  "
              f"{units[k]}")
    print("-" * len(head))
    print(f"residual RMS {fit.residual_rms:.3g} N·m over {fit.n_points} points; converged: {fit.converged}")
    print(f"\nnext: adaptive-ff identify LOG --Vs {fit.Vs:.6g} --delta {fit.delta:.6g}"
          + ("" if vunit == "rad/s" else "   (--Vs in rad/s)"))
    if paths:
        print("figures: " + ", ".join(str(p) for p in paths))
    if report_path:
        print(f"report: {report_path}")
    return 0


def register(sub) -> None:
    """Add the ``stribeck`` subcommand to an argparse subparsers object."""
    from controllers.cli.data import DATA_EPILOG, add_data_arguments, add_units_argument

    s = sub.add_parser(
        "stribeck", help="fit the Stribeck curve (Vs, delta) from quasi-static data and draw Fig. 8",
        description="Pre-fit of the static Stribeck map F(w) = sgn(w)(Fc + (Fs-Fc) exp(-|w/Vs|^delta)) + sigma w "
                    "(eq. 3) by Levenberg-Marquardt to steady-state support points (paper Sec. V-C), giving the Vs "
                    "and delta that 'adaptive-ff identify' needs for the Stribeck structure.",
        epilog=_EPILOG + DATA_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    s.add_argument("file", help="drive log (CSV/.mat/.npz), or a table of support points with --points")
    s.add_argument("--points", action="store_true",
                   help="the file holds averaged support points (roles w, F, optional F_std), not a log")
    s.add_argument("--method", choices=["auto", "segments", "bins"], default="auto",
                   help="support points from constant-velocity runs, velocity bins, or auto (default)")
    s.add_argument("--min-duration", type=float, default=None, metavar="S",
                   help="segments: shortest run kept after settling, in s (default 0.5)")
    s.add_argument("--settle", type=float, default=None, metavar="S",
                   help="segments: time cut from the start of each run, in s (default 0.2)")
    s.add_argument("--rel-tol", type=float, default=None,
                   help="segments: a run ends when w leaves its mean by more than this fraction (default 0.05)")
    s.add_argument("--bins", type=int, default=None, help="bins: velocity bins per direction (default 12)")
    s.add_argument("--J", type=float, default=None, metavar="KGM2",
                   help="bins: inertia in kg·m²; friction taken as u - J*dw/dt")
    s.add_argument("--max-accel", type=float, default=None, metavar="RAD_S2",
                   help="bins: drop samples with |dw/dt| above this (rad/s²)")
    s.add_argument("--weighted", action="store_true", help="weight the fit by 1/(torque spread) of each point")
    add_data_arguments(s)
    s.add_argument("--out", default=None, help="directory for the figure and support_points.csv "
                                               "(default: the --report directory, else out/stribeck)")
    s.add_argument("--no-figures", action="store_true", help="write no files to --out")
    s.add_argument("--report", metavar="DIR", default=None, help="write a self-contained HTML report to DIR")
    s.add_argument("--json", action="store_true", help="print the fit, intervals and support points as JSON")
    s.add_argument("--quiet", action="store_true", help="no progress bar (Kalman pass on position logs)")
    add_units_argument(s)
    s.set_defaults(func=run)
