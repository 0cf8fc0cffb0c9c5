"""``adaptive-ff paper-figures``: regenerate the paper's Figs. 4, 5, 7-12 from the simulated joint."""

from __future__ import annotations

import argparse
import contextlib
import json
import math

__all__ = ["register", "run", "report_tables", "estimates_table"]

_EPILOG = """\
Experiments (see controllers.experiments.paper_figures): Sec. IV open-loop band-limited-noise run sampled at 10 ms
(Fig. 4: LS model, Fig. 5: RLS prediction); Sec. V-C quasi-static runs and Levenberg-Marquardt Stribeck
fit (Fig. 8); Sec. V closed-loop multi-sine tracking by a stiff velocity loop (--crossover), read out at
irregular instants with noise and torque quantisation (Fig. 7: the quantised torque, Fig. 9: LS, Fig. 10:
sample times, Fig. 11: RLS with lambda = 0.85, Fig. 12: RLS parameters, windup included).
--axis-units deg draws velocities in deg/s, as the paper does. --save-data also writes the demonstration logs
quasi_static_log.csv and robot_log.csv (current, encoder counts, irregular time in ms) for trying 'adaptive-ff stribeck' and 'identify'.

example:
  adaptive-ff paper-figures --out out/paper --axis-units deg --save-data --report out/paper
"""


def report_tables(summary: dict) -> list:
    """Tables for the HTML report from the ``numbers`` of a :class:`controllers.experiments.paper_figures.PaperFigures`.

    Returns
    -------
    list
        ``[(title, header, rows), ...]``: physical parameters (true plant,
        Stribeck fit, LS and final RLS estimates of both experiments), fits
        and sample times.
    """
    st, sim, ex, p = summary["stribeck"], summary["simulation"], summary["experiment"], summary["plant"]
    keys = ("J", "tau", "sigma", "Fc", "Fs", "Vs", "delta")
    units = ("kg·m²", "s", "N·m·s/rad", "N·m", "N·m", "rad/s", "1")
    cols = [("true plant", p), ("Stribeck fit (Fig. 8)", st), ("LS, simulation (Fig. 4)", sim["ls_estimate"]),
            ("RLS final, simulation (Fig. 5)", sim["rls_estimate"]), ("LS, experiment (Fig. 9)", ex["ls_estimate"]),
            ("RLS final, experiment (Figs. 11-12)", ex["rls_estimate"])]
    rows = [[k, u] + [c.get(k, "–") for _, c in cols] for k, u in zip(keys, units)]
    params = ("physical parameters", ["parameter", "unit"] + [name for name, _ in cols], rows)
    fits = ("fits (NRMSE, %)", ["experiment", "samples", "LS one-step", "LS free run", "RLS a-priori", "RLS λ"],
            [["simulation, Ts = 10 ms", sim["n_samples"], sim["ls_fit_one_step"], sim["ls_fit_free_run"],
              sim["rls_fit"], sim["rls_lam"]],
             ["closed loop, irregular readout", ex["n_samples"], ex["ls_fit_one_step"], ex["ls_fit_free_run"],
              ex["rls_fit"], ex["rls_lam"]]])
    times = ("sample time of the experiment (Fig. 10)", ["mean (ms)", "min (ms)", "max (ms)", "noise (rad/s)",
                                                          "torque quantum (N·m)"],
             [[1e3 * ex["Ts_mean"], 1e3 * ex["Ts_min"], 1e3 * ex["Ts_max"], ex["noise_std"], ex["quantization"]]])
    return [params, fits, times]


def estimates_table(numbers: dict, args) -> str:
    """The printed table of true and estimated J, tau, sigma, Fc, Fs, each header with its unit.

    Parameters
    ----------
    numbers : dict
        ``PaperFigures.numbers`` (SI units).
    args : argparse.Namespace
        Parsed arguments; ``args.units`` (``deg`` or ``rad``) sets the unit of sigma:
        N·m·s/deg (the value times pi/180) or N·m·s/rad.

    Returns
    -------
    str
        Header, rule and rows ``true``, ``LS sim`` (Fig. 4), ``LS exp`` (Fig. 9),
        ``RLS exp`` (final value, Figs. 11-12).
    """
    from controllers.cli.data import per_angle

    c, angle = per_angle(args)
    sim, ex = numbers["simulation"], numbers["experiment"]
    cols = (("J", "kg·m²", 1.0), ("tau", "s", 1.0), ("sigma", f"N·m·s/{angle}", c), ("Fc", "N·m", 1.0),
            ("Fs", "N·m", 1.0))
    head = f"{'':8}" + "".join(f"{f'{k} [{u}]':>18}" for k, u, _ in cols)
    lines = [head, "-" * len(head)]
    for name, e in (("true", numbers["plant"]), ("LS sim", sim["ls_estimate"]), ("LS exp", ex["ls_estimate"]),
                    ("RLS exp", ex["rls_estimate"])):
        lines.append(f"{name:<8}" + "".join(f"{f * e[k]:>18.4g}" for k, _, f in cols))
    return "\n".join(lines)


#: The options of the settings of :class:`controllers.experiments.paper_figures.PaperFigureOptions`.
_OPTIONS = {"sim_duration": "--sim-duration", "exp_duration": "--exp-duration", "n_speeds": "--speeds",
            "noise_std": "--noise", "quantization": "--quantization", "lam_sim": "--lam-sim", "lam_exp": "--lam",
            "crossover": "--crossover", "seed": "--seed", "units": "--axis-units"}


@contextlib.contextmanager
def _options_named(args=None):
    """Name the options in an error of the paper's experiments: a setting's message (``n_speeds must be ...``)
    with its option (``--speeds must be ...``); with ``args``, an error of the simulated data (a fit the data do
    not excite) prefixed with the options that shaped them."""
    from plant.errors import FrictionError, ParameterError

    try:
        yield
    except FrictionError as exc:
        text = str(exc)
        for name, option in _OPTIONS.items():
            if text.startswith(name + " ") or text.startswith(name + " ="):
                raise ParameterError(option + text[len(name):]) from None
        if args is None or any(option in text for option in _OPTIONS.values()):
            raise
        shaped = ", ".join(f"{o} {getattr(args, a):g}" for a, o in (
            ("sim_duration", "--sim-duration"), ("exp_duration", "--exp-duration"), ("noise", "--noise"),
            ("quantization", "--quantization")))
        message = f"the simulated experiments ({shaped}) cannot be identified: {text}"
        try:
            new = type(exc)(message)
        except TypeError:
            new = ParameterError(message)
        raise new from None


def run(args) -> int:
    """Execute ``adaptive-ff paper-figures`` with parsed ``args``; return the exit status."""
    from controllers.cli.data import command_line, per_angle, progress_from_args, table_unit
    from controllers.experiments.paper_figures import PaperFigureOptions, paper_figures
    from adaptive_ff.io.units import parameter_text
    from adaptive_ff.io.output import StagedOutputs
    from controllers.cli.budget import check_work, paper_figures_estimate
    from controllers.cli.data import check_output_dir
    from plant.errors import ParameterError
    from plant.friction import JointParams, preset
    from plant.models import load_plant

    out_dir = args.out if args.out is not None else (args.report or "out/paper")
    check_output_dir(out_dir, "--out")
    if args.report:
        check_output_dir(args.report, "--report")
    p = load_plant(args.plant) if args.plant else preset(args.preset)
    if not isinstance(p, JointParams):
        raise ParameterError(f"{args.plant}: paper-figures needs the paper's lagged-stribeck model, "
                             f"got model {p.MODEL!r}")
    with _options_named():
        options = PaperFigureOptions(seed=args.seed, sim_duration=args.sim_duration, exp_duration=args.exp_duration,
                                     n_speeds=args.speeds, noise_std=args.noise, quantization=args.quantization,
                                     lam_sim=args.lam_sim, lam_exp=args.lam, crossover=args.crossover,
                                     units=args.axis_units)
    check_work(paper_figures_estimate(args.sim_duration, args.exp_duration, args.speeds), yes=args.yes)
    with StagedOutputs() as staged:  # the figures, the data and the report appear together at the end
        fig_dir = staged.folder(out_dir, "--out")
        report_dir = staged.folder(args.report, "--report") if args.report else None
        with _options_named(args):
            res = paper_figures(fig_dir, p=p, options=options, save_data=args.save_data,
                                progress=progress_from_args(args))
        report_path = None
        if report_dir is not None:
            from controllers.report.html import write_report

            report_path = write_report(
                report_dir,
                title="Figures of Ruderman's paper, regenerated from the simulation",
                tables=report_tables(res.numbers), figures={res.captions[k]: v for k, v in res.figures.items()},
                command=command_line(), notes=["All numbers in SI units; the full set is in --json."])
    report_path = None if report_path is None else staged.final(report_path)
    if args.json:
        d = staged.relocate(res.to_dict())
        d["report"] = str(report_path) if report_path else None
        print(json.dumps(d, indent=2))
        return 0
    s = res.numbers
    st, sim, ex = s["stribeck"], s["simulation"], s["experiment"]
    print(f"plant: {args.plant or 'preset ' + repr(args.preset)}: {parameter_text(s['plant'])}")
    k, vunit = table_unit(args)
    c, angle = per_angle(args)
    print(f"Fig. 8  Stribeck fit: Fc={st['Fc']:.4g} N·m, Fs={st['Fs']:.4g} N·m, Vs={k * st['Vs']:.4g} {vunit}, "
          f"delta={st['delta']:.4g}, sigma={c * st['sigma']:.4g} N·m·s/{angle} ({st['n_points']} runs)")
    print(f"Fig. 4  simulation, Ts = {sim['Ts'] * 1e3:g} ms, {sim['n_samples']} samples: LS fit one-step "
          f"{sim['ls_fit_one_step']:.2f} %, free run {sim['ls_fit_free_run']:.2f} %")
    print(f"Fig. 5  RLS (lambda = {sim['rls_lam']:g}) a-priori fit {sim['rls_fit']:.2f} %")
    print(f"Fig. 10 irregular readout: mean {ex['Ts_mean'] * 1e3:.2f} ms, min {ex['Ts_min'] * 1e3:.2f} ms, "
          f"max {ex['Ts_max'] * 1e3:.2f} ms, {ex['n_samples']} samples")
    mo = ex["motion"]
    print(f"Figs. 7, 9-12 joint motion: stuck (|w| < 0.2 deg/s) {mo['stuck_fraction']:.1%} of the time, speed "
          f"{math.degrees(mo['speed_p05']):.2g}-{math.degrees(mo['speed_p95']):.3g} deg/s (5-95 %), "
          f"{mo['reversals']} reversals")
    print(f"Fig. 9  experiment LS fit one-step {ex['ls_fit_one_step']:.2f} %, free run {ex['ls_fit_free_run']:.2f} %")
    print(f"Fig. 11 RLS (lambda = {ex['rls_lam']:g}) a-priori fit {ex['rls_fit']:.2f} %")
    print(estimates_table(s, args))
    print("figures: " + ", ".join(str(staged.final(v)) for v in res.figures.values()))
    if res.data_files:
        print("data: " + ", ".join(str(staged.final(v)) for v in res.data_files.values()))
    if report_path:
        print(f"report: {report_path}")
    return 0


def register(sub) -> None:
    """Add the ``paper-figures`` subcommand to an argparse subparsers object."""
    from controllers.cli.budget import add_yes_argument
    from controllers.cli.data import PRESET_NAMES, add_units_argument, seed_type

    f = sub.add_parser("paper-figures", help="regenerate the paper's Figs. 4, 5, 7, 8, 9, 10, 11, 12 from simulation",
                       description="Simulate the paper's experiments on the joint model (1 kHz RK4) and redraw its "
                                   "figures: LS and RLS velocity fits, Stribeck curve, irregular sample times, RLS "
                                   "parameter convergence, quantised input torque. Axes in SI units unless "
                                   "--axis-units deg.",
                       epilog=_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    f.add_argument("--out", default=None, help="output directory for the PNG files (default: the --report "
                                               "directory, else out/paper)")
    f.add_argument("--preset", default="paper", choices=PRESET_NAMES,
                   help="named plant parameter set: %(choices)s (default: paper)")
    f.add_argument("--plant", metavar="FILE", help="JSON file with J, Fc, Fs, Vs, delta, sigma, tau (SI units)")
    f.add_argument("--seed", type=seed_type, default=0, help="random seed, an integer >= 0 (default 0)")
    f.add_argument("--sim-duration", type=float, default=30.0, metavar="S",
                   help="open-loop simulation length for Figs. 4-5 in s (default 30)")
    f.add_argument("--exp-duration", type=float, default=60.0, metavar="S",
                   help="closed-loop experiment length for Figs. 9-12 in s (default 60)")
    f.add_argument("--speeds", type=int, default=10, help="quasi-static speeds per direction for Fig. 8 (default 10)")
    f.add_argument("--noise", type=float, default=1e-3, metavar="RAD_S",
                   help="velocity measurement noise std in rad/s (default 1e-3)")
    f.add_argument("--quantization", type=float, default=0.6, metavar="NM",
                   help="torque readout quantisation step in N·m (default 0.6 = 0.01 A at 60 N·m/A)")
    f.add_argument("--lam-sim", type=float, default=0.995, help="RLS forgetting factor of Fig. 5 (default 0.995)")
    f.add_argument("--lam", type=float, default=0.85, help="RLS forgetting factor of Figs. 11-12 (paper: 0.85)")
    f.add_argument("--crossover", type=float, default=200.0, metavar="RAD_S",
                   help="crossover of the experiment's PI velocity loop in rad/s (default 200: a stiff robot loop, "
                        "the joint rarely sticks)")
    f.add_argument("--axis-units", choices=("rad", "deg"), default="rad",
                   help="velocity unit on the figure axes: rad/s (default) or deg/s as in the paper")
    add_units_argument(f, extra="Converts Vs (deg/s) and sigma (N·m·s/deg) in the printed lines; the figures' "
                                "axes follow --axis-units")
    f.add_argument("--save-data", action="store_true",
                   help="also write demonstration logs (quasi_static_log.csv, robot_log.csv, controller_log.csv, "
                        "controller.json, plant.json)")
    f.add_argument("--report", metavar="DIR", default=None, help="write a self-contained HTML report to DIR")
    f.add_argument("--json", action="store_true", help="print the numbers behind the figures as JSON")
    f.add_argument("--quiet", action="store_true", help="no progress bar")
    add_yes_argument(f)
    f.set_defaults(func=run)
