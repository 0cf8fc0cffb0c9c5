"""``adaptive-ff compare``: all friction-compensation modes on one plant, table and figures."""

from __future__ import annotations

import contextlib
import json

__all__ = ["register", "run", "comparison_table", "pi_text", "loop_flags"]


def run(args) -> int:
    """Execute ``adaptive-ff compare`` with parsed ``args``; return the exit status.

    Loads the plant, runs :func:`controllers.experiments.compare.compare`,
    draws the figures (:func:`controllers.report.figures.plot_comparison`, one
    after the other in this process) and writes the report, then prints the
    table (or the JSON).
    """
    from adaptive_ff.io.output import StagedOutputs
    from controllers.cli.data import check_output_dir

    refused = _refused_identification(args)
    if refused:
        return refused
    out_dir = args.out if args.out is not None else (args.report or "out")
    if not args.no_figures:
        check_output_dir(out_dir, "--out")
    if args.report:
        check_output_dir(args.report, "--report")
    with StagedOutputs() as staged:  # the figures and the report appear together at the end, or not at all
        fig_dir = None if args.no_figures else staged.folder(out_dir, "--out")
        report_dir = staged.folder(args.report, "--report") if args.report else None
        if args.scenario:
            comp, header, scenario, run_line = _scenario_comparison(args)
        else:
            comp, header, scenario, run_line = _comparison(args, _load_plant(args), _modes(args))
        paths, report = _write_outputs(args, comp, fig_dir, report_dir)
    paths = [staged.final(x) for x in paths]
    report = None if report is None else staged.final(report)
    return _print_comparison(args, comp, header, scenario, run_line, paths, report)


#: Options the scenario file sets, with the table that holds each: refused beside ``--scenario``.
_SCENARIO_SETS = {"preset": "[plant] preset", "plant": "[plant] file", "variant": "[plant] variant",
                  "modes": "modes", "estimator": "[compensation] estimator", "ff_input": "[compensation] ff_input",
                  "omega_q": "[compensation] omega_q", "duration": "[reference] (its length)", "seed": "seed",
                  "Ts": "[controller] Ts", "noise_std": "[sensor] noise_std", "lam": "[compensation] lam",
                  "crossover": "[controller] crossover", "phase_margin": "[controller] phase_margin",
                  "no_prefit": "[compensation] prefit", "no_fast_start": "[compensation] adaptive_start",
                  "switch_in": "[compensation] switch_in", "estimator_rows": "[compensation] estimator_rows",
                  "Vs": "[compensation] Vs", "delta": "[compensation] delta", "J_design": "[controller] J_design",
                  "controller": "[controller]", "from_file": "[plant] and [controller]",
                  "joint": "[plant] and [controller]"}


def _scenario_comparison(args) -> tuple:
    """``compare --scenario FILE``: the file's comparison, the header lines, the scenario's ``to_dict`` and the run
    line (empty)."""
    from controllers.experiments.scenario import load_scenario
    from plant.errors import ParameterError

    given = [k for k in _SCENARIO_SETS if getattr(args, k) != args.scenario_defaults[k]]
    if given:
        k = given[0]
        flag = {name: f for f, (name, _) in loop_flags().items()}.get(k, "--" + k.replace("_", "-"))
        raise ParameterError(f"{flag} cannot be combined with --scenario: the scenario file "
                             f"sets it ({_SCENARIO_SETS[k]})")
    sc = load_scenario(args.scenario)
    o = sc.options
    _check_work(args, o.duration, o.modes, o.estimator_rows, o.compensators, o.adaptive_start, o.loop.controller.Tc,
                f"{args.scenario}: the reference of {o.duration:g} s")
    with _plant_named(f"{args.scenario}: [plant]"):
        comp = sc.compare(progress=None if not args.quiet else False)
    header = [sc.summary()] + ([sc.description] if sc.description else [])
    return comp, header, sc.to_dict(), ""


def _load_plant(args):
    """The plant of ``adaptive-ff compare`` (``--plant``, ``--variant`` or ``--preset``; with ``--from`` alone, the
    identified joint)."""
    from plant.friction import preset
    from plant.variant_plants import drift_case, variant

    if args.plant:
        p = _plant_or_identification(args.plant)
    elif args.variant == "drift":
        p = drift_case(args.duration)
    elif args.variant:
        p = variant(args.variant)
    elif args.preset is None and args.from_file:
        p = _plant_or_identification(args.from_file) if args.joint is None else _joint_plant(args)
    else:
        p = preset(args.preset or "paper")
    return p


def _refused_identification(args) -> int:
    """``--from FILE`` (its joint ``--joint NAME``) as ``design --from`` takes it: its refusing warnings echoed on
    stderr and the exit status 3 unless ``--accept-warnings``; else 0."""
    from adaptive_ff.arm.result import read_arm_joint
    from controllers.cli.design import entry_warnings, refused_warnings, warnings_from_file
    from plant.errors import ParameterError

    if args.joint is not None and not args.from_file:
        raise ParameterError(f"--joint {args.joint} picks a joint of an identify-arm --json output: give it with "
                             "--from ARM.json")
    if not args.from_file:
        return 0
    if args.joint is None:
        warns = warnings_from_file(args.from_file)
    else:
        warns = entry_warnings(read_arm_joint(args.from_file, args.joint), _where(args))
    return refused_warnings(warns, _where(args), accept=args.accept_warnings, command="compare")


def _where(args) -> str:
    """The ``--from`` file, with its joint ``--joint NAME`` if given: what the messages name."""
    return str(args.from_file) + ("" if args.joint is None else f" joint {args.joint!r}")


def _inertia_source(args) -> str:
    """Where a design inertia that no experiment measured came from, for the ``design inertia`` line: ``--J-design``,
    the ``--from`` file (and joint) or the scenario file."""
    if getattr(args, "J_design", None) is not None:
        return "given: --J-design"
    if getattr(args, "from_file", None):
        return f"from {_where(args)}"
    if getattr(args, "scenario", None):
        return f"given: {args.scenario} [controller] J_design"
    return "given"


def _joint_identified(args):
    """The :class:`adaptive_ff.identification.result_file.IdentifiedJoint` of the joint ``--joint`` of the
    ``identify-arm --json`` output ``--from``."""
    from adaptive_ff.arm.result import read_arm_joint
    from adaptive_ff.identification.result_file import identification_from_dict

    return identification_from_dict(read_arm_joint(args.from_file, args.joint), where=_where(args))


def _joint_plant(args):
    """The plant of ``--from ARM.json --joint NAME`` alone: the identified joint (its lag ``tau`` needed)."""
    from plant.errors import ParameterError
    from plant.models import check_plausible, plant_from_dict

    joint = _joint_identified(args)
    try:
        p = plant_from_dict(joint.plant_dict())
    except (ParameterError, TypeError, OverflowError) as exc:
        raise ParameterError(f"{exc} (the simulated plant is the identified joint without --plant, --variant or "
                             "--preset)") from None
    check_plausible(p, where=_where(args))
    return p


def _user_loop(args) -> tuple:
    """``(J_design or None, PIDesign or None, source line or None)`` of ``--J-design``, ``--from`` and
    ``--controller``: the design inertia a user has and the PI they run.

    ``--controller FILE`` (a ``design --json`` output) is run as given. ``--from FILE`` (an ``identify --json``
    output) gives the design inertia (``--J-design`` overrides it) and, without ``--controller``, the PI that
    ``design --from FILE`` designs: on the identified ``J`` and ``sigma`` (a negative sigma taken as 0) at
    ``--crossover`` and ``--phase-margin``.
    """
    from controllers.cli.design import plant_from_file, target_options
    from controllers.design.controller_file import read_controller
    from controllers.design.pi import design_pi
    from plant.errors import ParameterError

    J, controller, source = args.J_design, None, None
    given = [o for o, k in (("--crossover", "crossover"), ("--phase-margin", "phase_margin"))
             if getattr(args, k) != args.loop_defaults[k]]
    if args.controller:
        if given:
            raise ParameterError(f"{given[0]} cannot be combined with --controller: the controller file's gains "
                                 f"are run as they are")
        controller = read_controller(args.controller)
        source = f"PI from {args.controller} (run as given)"
    if args.from_file:
        if args.joint is None:
            Jf, sf = plant_from_file(args.from_file)
        else:
            joint = _joint_identified(args)
            Jf, sf = joint.J, joint.sigma
        J = Jf if J is None else J
        if controller is None:
            sigma = max(sf, 0.0)
            try:
                controller = design_pi(J, sigma=sigma, crossover=args.crossover, phase_margin=args.phase_margin)
            except ParameterError as exc:
                raise ParameterError(f"{target_options(str(exc))} (J = {J:g} kg·m², sigma = {sigma:g} N·m·s/rad "
                                     f"from {_where(args)})") from None
            design_from = args.from_file if args.joint is None else f"{args.from_file} --joint {args.joint}"
            source = f"PI designed as 'design --from {design_from}' designs it (J = {J:g} kg·m², sigma = " \
                     f"{sigma:g} N·m·s/rad)"
    return J, controller, source


def _plant_or_identification(path):
    """The plant of ``--plant FILE``: a plant file, or an ``identify --json`` output read by
    :func:`adaptive_ff.identification.result_file.identification_from_dict` (the chosen form's parameters;
    a Coulomb + viscous form gives ``Fs = Fc``)."""
    from adaptive_ff.identification.result_file import identification_from_dict, is_identification
    from plant.errors import ParameterError
    from plant.models import check_plausible, load_plant, plant_from_dict, read_json

    d = read_json(path, what="plant file")
    if not is_identification(d):
        return load_plant(path)
    try:
        p = plant_from_dict(identification_from_dict(d, where=path).plant_dict())
    except (ParameterError, TypeError, OverflowError) as exc:
        raise ParameterError(f"{path}: {exc}") from None
    check_plausible(p, where=str(path))
    return p


def _modes(args) -> tuple:
    """The modes of ``--modes`` (default: all), checked."""
    from controllers.simulation.compensators import MODES
    from plant.errors import ParameterError

    if not args.modes:
        return MODES
    modes = tuple(m.strip() for m in args.modes.split(",") if m.strip())
    unknown = [m for m in modes if m not in MODES]
    if unknown:
        raise ParameterError(f"--modes: unknown mode(s) {unknown}; known: {list(MODES)}")
    return modes


def _estimator_rows(args) -> tuple:
    """The estimators of ``--estimator-rows`` (comma-separated; CompareOptions checks them)."""
    return tuple(e.strip() for e in (args.estimator_rows or "").split(",") if e.strip())


def _comparison(args, p, modes) -> tuple:
    """The comparison of the plant ``p`` in ``modes`` with the options of ``args``, the header lines, None (no
    scenario) and the run line."""
    from controllers.experiments.compare import compare
    from adaptive_ff.io.units import parameter_text
    from plant.models import plant_to_dict

    _check_work(args, args.duration, modes, _estimator_rows(args), (), not args.no_fast_start, 1e-3,
                f"--duration {args.duration:g}")
    progress = None if not args.quiet else False
    J_design, controller, loop_source = _user_loop(args)
    if args.plant:
        src = args.plant
    elif args.variant:
        src = f"variant '{args.variant}'"
    elif args.preset is None and args.from_file:
        src = f"the joint identified in {_where(args)}"
    else:
        src = f"preset '{args.preset or 'paper'}'"
    with _plant_named(f"--plant {src}" if args.plant else src):
        loop = {name: getattr(args, name) for name, _ in loop_flags().values() if getattr(args, name) is not None}
        comp = compare(p, duration=args.duration, seed=args.seed, modes=modes, crossover=args.crossover,
                       phase_margin=args.phase_margin, progress=progress, prefit=not args.no_prefit,
                       J_design=J_design, controller=controller, adaptive_start=not args.no_fast_start,
                       estimator_rows=_estimator_rows(args), **loop)
    header = [f"plant: {src}: {parameter_text(plant_to_dict(p))}"] + _time_varying_lines(p)
    if loop_source:
        header.append(loop_source)
    return comp, header, None, f"run: {args.duration:g} s, seed {args.seed}"


def _check_work(args, duration, modes, rows, compensators, adaptive_start, Tc, what) -> None:
    """Refuse a comparison whose estimated time or memory is beyond the limits without ``--yes``
    (:func:`controllers.cli.budget.check_work`)."""
    from controllers.cli.budget import check_work, compare_estimate, compare_runs

    n_runs, ident = compare_runs(modes, estimator_rows=rows, compensators=compensators or (),
                                 adaptive_start=adaptive_start)
    check_work(compare_estimate(duration, n_runs, identification=ident, Tc=Tc, what=what), yes=args.yes)


@contextlib.contextmanager
def _plant_named(where: str):
    """Prefix a :class:`controllers.experiments.compare.DriveLimitError` (a friction level above the drive's limit)
    with where the plant comes from (the file, the scenario's ``[plant]``)."""
    from controllers.experiments.compare import DriveLimitError

    try:
        yield
    except DriveLimitError as exc:
        raise DriveLimitError(f"{where}: {exc}") from None


def _time_varying_lines(p) -> list:
    """What of the plant changes during the run or along the position: drift, payload step, friction ripple."""
    lines = []
    if hasattr(p, "Fc_change"):
        lines.append(f"drift: Fc {p.Fc_change:+.0%}, Fs {p.Fs_change:+.0%} from t = {p.t_start:g} s to "
                     f"{p.t_end:g} s")
    if hasattr(p, "J_after"):
        lines.append(f"payload step: J {p.at(0.0).J:g} -> {p.J_after:g} kg·m² at t = {p.t_step:g} s")
    if hasattr(p, "harmonic"):
        lines.append(f"friction ripple: 1 + {p.amplitude:g}*sin({p.harmonic:g}*q + {p.phase:g})")
    return lines


def _write_outputs(args, comp, fig_dir, report_dir) -> tuple:
    """The figures (into ``fig_dir``, None: none) and the report (into ``report_dir``, None: none) of a comparison;
    ``(figure paths, report path or None)``."""
    paths = []
    if fig_dir is not None:
        from controllers.report.figures import plot_comparison

        paths = plot_comparison(comp, fig_dir)
    report = None
    if report_dir is not None:
        from controllers.cli.data import command_line
        from controllers.report.html import compare_report

        report = compare_report(report_dir, comp, figures=paths, command=command_line())
    return paths, report


def _print_comparison(args, comp, header, scenario, run, paths, report) -> int:
    """The printed table (or JSON) of a comparison; ``header``: lines printed before the design; ``scenario``: the
    scenario's ``to_dict`` for the JSON (None without one); ``run``: the run line (may be empty); ``paths``,
    ``report``: the figures and the report written."""
    from adaptive_ff.io.units import parameter_text
    from plant.models import plant_to_dict

    if args.json:
        d = comp.to_dict()
        d["figures"] = [str(x) for x in paths]
        if report is not None:
            d["report"] = str(report)
        if scenario is not None:
            d["scenario"] = scenario
        print(json.dumps(d, indent=2))
        return _diverged_status(comp)
    d = comp.design
    for line in header:
        print(line)
    if scenario is not None:
        print(f"plant: {parameter_text(plant_to_dict(comp.plant))}")
        for line in _time_varying_lines(comp.plant):
            print(line)
    print(pi_text(d, args))
    i = comp.inertia
    how = _inertia_source(args) if i is None else (
        f"identified: a torque ramp to {i.u_ramp:.4g} N·m reached {i.w_switch:.4g} rad/s, "
        f"then {i.duration:g} s of open-loop noise torque of {i.u_std:.4g} N·m")
    print(f"design inertia J_design={comp.J_design:g} kg·m² ({how})")
    if comp.prefit is not None:
        fb = comp.prefit.fallback
        kind = "Coulomb + viscous (no Stribeck effect)" if fb == "coulomb-viscous" else f"Vs={comp.prefit.Vs:.4g} " \
            f"rad/s, delta={comp.prefit.delta:.4g}" + (f" ({fb})" if fb else "")
        print(f"Stribeck pre-fit (Sec. V-C): {kind}")
    elif args.Vs is not None:
        print(f"Stribeck factors given: Vs={args.Vs:g} rad/s, delta={args.delta:g} (no pre-fit)")
    for note in comp.notes:
        print(f"note: {note}")
    print((f"{run}; " if run else "") + "metrics over the second half\n")
    print(comparison_table(comp, args))
    if paths:
        print("\nfigures: " + ", ".join(str(x) for x in paths))
    if report is not None:
        print(f"report: {report}")
    return _diverged_status(comp)


def pi_text(d, args) -> str:
    """The PI line of ``compare``: the gains per the ``--units`` angle, as ``design`` prints them (``Kp = ...
    N·m·s/deg, Ki = ... N·m/deg`` by default; ``--units rad``: per rad), the period and the margins."""
    from controllers.cli.data import per_angle

    c, angle = per_angle(args)
    return (f"PI: Kp = {c * d.Kp:.6g} N·m·s/{angle}, Ki = {c * d.Ki:.6g} N·m/{angle}, Tc = {d.Tc:g} s; crossover "
            f"{d.crossover:.4g} rad/s, phase margin {d.phase_margin:.1f} deg, gain margin {d.gain_margin:.3g}")


def _diverged_status(comp) -> int:
    """0, or 3 (a refusal to call the comparison a success, one line on stderr) where a run diverged."""
    import sys

    from controllers.cli.design import EXIT_REFUSED

    diverged = [mode for mode in comp.results if _diverged(comp, mode)]
    if not diverged:
        return 0
    print(f"adaptive-ff: {', '.join(diverged)} diverged (see the notes): exit status {EXIT_REFUSED}", file=sys.stderr)
    return EXIT_REFUSED


def comparison_table(comp, args) -> str:
    """The metrics table of a :class:`controllers.experiments.compare.Comparison` in the ``--units`` of ``args``.

    Velocities (RMS, max and reversal RMS of the tracking error over the second
    half) in deg/s or rad/s, the torque RMS in N·m, eta dimensionless; each
    header names its unit. Undefined values (eta without friction degradation)
    print as ``n/a``, a run that diverged as ``diverged`` and ``-``; every
    column keeps its width for any value (e.g. eta <= -100). When the reference has stops (point-to-point moves,
    ``Comparison.has_stops``) three more columns, over the second half: the
    RMS error while the reference moves, the longest settling time after a stop
    (s; ``no (k)`` when k stops did not settle into their band) and the largest
    error at a reversal (``MotionMetrics``).
    """
    from controllers.cli.data import table_unit
    from controllers.experiments.comparison import mode_width, number_text, settling_text

    k, unit = table_unit(args)
    stops = getattr(comp, "has_stops", False)
    rows = comp.rows()
    wm = mode_width(row["mode"] for row in rows)
    head = (f"{'mode':<{wm}}{f'RMS [{unit}]':>14}{f'max [{unit}]':>14}{f'reversal RMS [{unit}]':>23}"
            f"{'u RMS [N·m]':>13}{'eta [-]':>9}")
    widths = [14, 14, 23, 13, 9]
    if stops:
        head += f"{f'motion RMS [{unit}]':>22}{'settle max [s]':>16}{f'reversal max [{unit}]':>23}"
        widths += [22, 16, 23]
    lines = [head, "-" * len(head)]
    for row in rows:
        if _diverged(comp, row["mode"]):
            lines.append(f"{row['mode']:<{wm}}" + "".join(f"{'diverged' if i == 0 else '-':>{w}}"
                                                          for i, w in enumerate(widths)))
            continue
        line = (f"{row['mode']:<{wm}}{number_text(k * row['rms'], 14)}{number_text(k * row['max'], 14)}"
                f"{number_text(k * row['rms_reversal'], 23)}{number_text(row['u_rms'], 13, 2)}"
                f"{number_text(row['eta'], 9, 3)}")
        if stops:
            line += (f"{number_text(k * row['rms_motion'], 22)}"
                     f"{settling_text(row['settling_max'], row['n_unsettled']):>16}"
                     f"{number_text(k * row['max_reversal'], 23)}")
        lines.append(line)
    return "\n".join(lines)


def _diverged(comp, mode: str) -> bool:
    """Whether ``mode``'s run of the comparison ``comp`` diverged (its ``info``)."""
    r = getattr(comp, "results", {}).get(mode)
    return bool(r is not None and (r.info or {}).get("diverged"))


def loop_flags() -> dict:
    """The flags of loop settings: flag -> (the setting's flat name, argparse keywords). The name is a keyword of
    :meth:`controllers.experiments.compare.CompareOptions.from_flat` (its path in the loop's config:
    :data:`controllers.simulation.loop_config.FLAT_PATHS`); a flag has no default of its own (None: not given, the
    comparison's default, :data:`controllers.experiments.compare.EXPERIMENT_LOOP`) and its choices are the
    registries'. No C import: ``--help`` stays light."""
    from controllers.simulation.estimators import ESTIMATORS

    return {
        "--estimator": ("estimator", dict(choices=ESTIMATORS, help="adaptive estimator: sliding-regime "
                                      "inverse-dynamics RLS (default); eq4: the paper's eq. 4 by recursive IV on the "
                                      "sliding samples (the model estimated consistently in closed loop, "
                                      "docs/theory.md); eq4-rls: eq. 4 by the paper's RLS, eqs. 10-13 as printed "
                                      "(biased on the loop's own data); export-c exports mode adaptive with the "
                                      "sliding estimator only")),
        "--iv-map-stderr": ("iv_map_stderr", dict(type=float, help="eq4 in mode adaptive: put an estimate into use "
                                                  "only once the standard error of its static map is at most this "
                                                  "times its max(Fc, Fs) (default inf: no test; docs/benchmarks/"
                                                  "compensation.md, \"The eq. 4 estimate's determinacy test\")")),
        "--ff-input": ("ff_input", dict(choices=("measured", "reference"),
                                        help="velocity the friction feedforward is evaluated at (default: measured)")),
        "--omega-q": ("omega_q", dict(type=float, help="Q-filter cut-off of the disturbance observer in rad/s "
                                                       "(default 500, the C default)")),
        "--Ts": ("Ts", dict(type=float, help="estimator update period in s (default 0.01)")),
        "--noise": ("noise_std", dict(type=float, help="velocity noise std in rad/s (default 1e-3)")),
        "--lam": ("lam", dict(type=float, help="RLS forgetting factor per update (default 0.995; 0.999 for canudas)")),
        "--no-switch-in": ("switch_in", dict(action="store_const", const=False,
                                             help="adaptive: the feedforward alone, never the residual observer "
                                                  "(with --estimator eq4-rls the paper's bare prototype; "
                                                  "CompareOptions.loop.observer.switch_in = False)")),
        "--Vs": ("Vs", dict(type=float, help="Stribeck velocity in rad/s, if known (with --delta; no pre-fit then)")),
        "--delta": ("delta", dict(type=float, help="Stribeck shape factor, if known (with --Vs)")),
    }


def register(sub) -> None:
    """Add the ``compare`` subcommand to an argparse subparsers object."""
    from controllers.cli.budget import add_yes_argument
    from controllers.cli.data import PRESET_NAMES, add_units_argument, seed_type

    c = sub.add_parser("compare", help="run all compensation modes on a plant and compare tracking error",
                       description="Simulate the 1 kHz plant in closed loop with the PI velocity controller in the "
                                   "modes none, fixed, adaptive, adaptive-dob (adaptive feedforward plus a "
                                   "disturbance observer on its residual), canudas (Canudas de Wit et al. 1987), dob "
                                   "(disturbance observer), oracle and frictionless; print the metrics table and "
                                   "write PNG figures.")
    c.add_argument("--preset", default=None, choices=PRESET_NAMES,
                   help="named plant parameter set: %(choices)s (default: paper; with --from alone, the identified "
                        "joint)")
    c.add_argument("--plant", metavar="FILE",
                   help='JSON plant file (SI units): "model" = "lagged-stribeck" (default; J, Fc, Fs, Vs, delta, '
                        'sigma, tau), "lugre" (J, Fc, Fs, Vs, delta, sigma0, sigma1, sigma2), "karnopp" (... tau, dv) '
                        'or "asymmetric" (J, Fc_pos, Fc_neg, Fs_pos, Fs_neg, Vs, delta, sigma_pos, sigma_neg, tau); '
                        'optional "drift": {"Fc_change", "Fs_change", "t_start", "t_end"}, "ripple": {"amplitude", '
                        '"harmonic", "phase"} (friction times 1 + a*sin(n*q + phase)), "payload": {"t_step", '
                        '"J_after"}')
    c.add_argument("--variant", choices=("lugre", "karnopp", "asymmetric", "small-inertia", "long-lag",
                                         "negative-delta", "static", "drift"),
                   help="a plant variant of the paper preset (drift: Fc, Fs +50%% over the first half)")
    c.add_argument("--modes", help="comma-separated subset of none,fixed,adaptive,adaptive-dob,canudas,dob,oracle,"
                                   "frictionless "
                                   "(default: all; none and frictionless always run)")
    for flag, (name, kw) in loop_flags().items():  # default None: not given, the comparison's default
        metavar = {"metavar": flag.lstrip("-").upper().replace("-", "_")} if "type" in kw else {}
        c.add_argument(flag, dest=name, default=None, **metavar, **kw)
    c.add_argument("--duration", type=float, default=120.0, help="run length in s (default 120)")
    c.add_argument("--seed", type=seed_type, default=0, help="random seed, an integer >= 0 (default 0)")
    c.add_argument("--out", default=None, help="directory for the PNG figures (default: the --report "
                                               "directory, else ./out)")
    c.add_argument("--crossover", type=float, default=20.0, help="PI crossover in rad/s (default 20)")
    c.add_argument("--phase-margin", type=float, default=60.0, help="PI phase margin in deg (default 60)")
    c.add_argument("--no-prefit", action="store_true",
                   help="do not run the Stribeck pre-fit (then fixed/adaptive need --Vs and --delta)")
    c.add_argument("--no-fast-start", action="store_true",
                   help="adaptive, adaptive-dob (estimators sliding and eq4): no provisional feedforward from the "
                        "pre-fit before the estimator's first trusted estimate (CompareOptions.adaptive_start = "
                        "False)")
    c.add_argument("--estimator-rows", dest="estimator_rows", default=None, metavar="LIST",
                   help="further estimators whose adaptive mode runs beside the others, each a row adaptive[E], "
                        "e.g. eq4,eq4-rls: the paper's eq. 4 by instrumental variables and by its RLS beside the "
                        "default (CompareOptions.estimator_rows)")
    c.add_argument("--J-design", dest="J_design", type=float, default=None,
                   help="design inertia in kg·m² (a data sheet's) for the PI, the experiments, the estimator start, "
                        "the gates and the observers (default: the J of --from, else identified on the joint by a "
                        "torque ramp and 20 s of open-loop noise torque, before any loop)")
    c.add_argument("--from", dest="from_file", metavar="FILE", default=None,
                   help="an 'identify --json' output: the design inertia is its J and the PI the one 'design --from "
                        "FILE' designs (on J and sigma, at --crossover and --phase-margin); without --plant, "
                        "--variant or --preset the simulated plant is the identified joint")
    c.add_argument("--joint", metavar="NAME", default=None,
                   help="with --from ARM.json (identify-arm --json): that joint's entry is the identification")
    c.add_argument("--controller", metavar="FILE", default=None,
                   help="run this PI as given: a 'design --json' output (Kp, Ki, Tc, J, sigma, SI units); "
                        "--crossover and --phase-margin do not apply")
    c.add_argument("--accept-warnings", action="store_true",
                   help="use a --from identification even if it carries plausibility or identifiability warnings "
                        "(otherwise refused with exit status 3, as 'design --from')")
    c.add_argument("--json", action="store_true", help="print the metrics as JSON instead of the table")
    c.add_argument("--no-figures", action="store_true", help="do not write figures")
    c.add_argument("--quiet", action="store_true", help="no progress bar")
    c.add_argument("--report", metavar="DIR", default=None, help="write a self-contained HTML report into DIR")
    c.add_argument("--scenario", metavar="FILE", default=None,
                   help="a scenario TOML file: plant, reference (multisine, point-to-point, reversing, a CSV "
                        "trajectory), sensor (encoder, delay), drive (torque and slew limits), controller design, "
                        "modes and your own compensators (controllers.experiments.scenario); the output options "
                        "(--out, --report, --json, --no-figures, --quiet, --units) still apply")
    add_units_argument(c)
    add_yes_argument(c)
    c.set_defaults(func=run, scenario_defaults={k: c.get_default(k) for k in _SCENARIO_SETS},
                   loop_defaults={k: c.get_default(k) for k in ("crossover", "phase_margin")})

