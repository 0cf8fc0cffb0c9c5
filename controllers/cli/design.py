"""``adaptive-ff design``: discrete PI velocity controller for a given or identified inertia (python-control)."""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
from pathlib import Path

__all__ = ["register", "run", "plant_from_file", "warnings_from_file", "entry_warnings", "target_options",
           "refused_warnings", "EXIT_REFUSED"]

#: Exit status of ``design --from`` refusing an identification with plausibility/identifiability warnings.
EXIT_REFUSED = 3

_EPILOG = """\
The plant is the joint's linear part P(s) = 1/(J s + sigma) (friction is what the feedforward removes),
held by a zero-order hold at Tc. The PI C(z) = Kp + Ki*Tc*z/(z-1) places the gain crossover of the
discrete loop at --crossover with --phase-margin (controllers.design.pi.design_pi); margins come from
control.stability_margins. J and sigma can be read from a JSON file with --from: the output of
'adaptive-ff identify --json', a plant file (J, Fc, ..., tau) or this command's own --json output.
An identification whose JSON carries a plausibility or identifiability warning (codes implausible,
identifiability, conditioning) is refused with exit status 3 and the warnings echoed, unless
--accept-warnings.

Output: gains, crossover, phase and gain margins, stability margin (1/Ms), closed-loop bandwidth, step
metrics; OUT/bode.png (open loop with margins, |S|, |T|) and OUT/step.png (velocity and torque of a
1 rad/s reference step, no friction, no saturation).

examples:
  adaptive-ff design --J 4 --crossover 20 --phase-margin 60 --Tc 0.001
  adaptive-ff identify log.csv --json > id.json && adaptive-ff design --from id.json --crossover 30
"""


def _read_json(path: Path):
    from plant.models import read_json

    return read_json(path, what="JSON file with J (and sigma)")


def warnings_from_file(path) -> list:
    """The warnings of an ``identify --json`` output (empty for a plant file or a design output).

    Parameters
    ----------
    path : str or os.PathLike
        JSON file.

    Returns
    -------
    list of adaptive_ff.identification.plausibility.IdentificationWarning
        From the top-level ``"warnings"`` list (``{"code", "parameter", "message"}`` objects; a bare
        string of an older file counts as an identifiability warning).

    Raises
    ------
    ParameterError
        Not JSON, or ``"warnings"`` not a list of warning objects.
    FileNotFoundError
        No such file.
    """
    from adaptive_ff.identification.plausibility import warning_from_dict
    from plant.errors import ParameterError

    path = Path(path)
    d = _read_json(path)
    raw = d.get("warnings", []) if isinstance(d, dict) else []
    if not isinstance(raw, list):
        raise ParameterError(f"{path}: 'warnings' must be a list, got {type(raw).__name__}")
    try:
        return [warning_from_dict(w) for w in raw]
    except ParameterError as exc:
        raise ParameterError(f"{path}: {exc}") from None


def plant_from_file(path) -> tuple[float, float]:
    """``(J, sigma)`` from a JSON object with a ``J`` key and optionally ``sigma`` (0 if absent).

    An ``identify --json`` output (a ``method``, ``physical`` or ``baselines`` key) is read by
    :func:`adaptive_ff.identification.result_file.read_identification`: the J and sigma of the method that gave
    the answer (the top level; in a file written before the ``baselines`` layout, ``physical.params`` when
    present). A plant file or this command's own ``--json`` output (``plant``) gives its ``J`` and ``sigma``.

    Raises
    ------
    ParameterError
        Not JSON, not an object, or no numeric ``J``.
    IdentificationFileError
        An identification of no known layout (the file and the missing key named; a ParameterError).
    FileNotFoundError
        No such file.
    """
    from adaptive_ff.identification.result_file import identification_from_dict, is_identification
    from plant.errors import ParameterError

    from plant.models import read_json

    path = Path(path)
    d = read_json(path, what="JSON file with J (and sigma)")
    if is_identification(d):
        joint = identification_from_dict(d, where=path)
        d = {"J": joint.J, "sigma": joint.sigma}
    if isinstance(d, dict) and "J" not in d and isinstance(d.get("plant"), dict):
        d = d["plant"]
    if not isinstance(d, dict) or not isinstance(d.get("J"), (int, float)) or isinstance(d.get("J"), bool):
        raise ParameterError(f"{path}: expected a JSON object with a numeric 'J' (kg·m²) and optionally 'sigma'")
    sigma = d.get("sigma", 0.0)
    if sigma is None:
        sigma = 0.0
    try:
        return float(d["J"]), float(sigma)
    except (TypeError, ValueError, OverflowError):
        raise ParameterError(f"{path}: J = {d['J']!r} and sigma = {sigma!r} must be finite numbers") from None


def _check_range(J: float, sigma: float, source: str) -> None:
    """ParameterError unless J (kg·m²) and sigma (N·m·s/rad) lie in :data:`plant.models.PLAUSIBLE_RANGE`."""
    import math

    from plant.errors import ParameterError
    from plant.models import PLAUSIBLE_RANGE

    lo, hi = PLAUSIBLE_RANGE
    if not (math.isfinite(J) and lo <= J <= hi):
        raise ParameterError(f"J = {J!r} kg·m² (from {source}) is outside the plausible range {lo:g}..{hi:g}; "
                             "check the units")
    if not (math.isfinite(sigma) and sigma <= hi):
        raise ParameterError(f"sigma = {sigma!r} N·m·s/rad (from {source}) is outside the plausible range "
                             f"0..{hi:g}; check the units")


def _method_of(path) -> str:
    d = _read_json(Path(path))
    m = d.get("method") if isinstance(d, dict) else None
    return f" (method {m!r})" if isinstance(m, str) else ""


def run(args) -> int:
    """Execute ``adaptive-ff design`` with parsed ``args``; return the exit status.

    The figures (``--out``) and the report (``--report``) are staged and appear together at the end
    (:class:`adaptive_ff.io.output.StagedOutputs`).
    """
    from adaptive_ff.io.output import StagedOutputs
    from controllers.cli.data import check_output_dir

    out_dir = args.out if args.out is not None else (args.report or "out/design")
    if not args.no_figures:
        check_output_dir(out_dir, "--out")
    if args.report:
        check_output_dir(args.report, "--report")
    with StagedOutputs() as staged:
        fig_dir = None if args.no_figures else staged.folder(out_dir, "--out")
        report_dir = staged.folder(args.report, "--report") if args.report else None
        done = _design_and_write(args, fig_dir, report_dir)
    if isinstance(done, int):
        return done
    analysis, source, paths, report_path = done
    paths = [staged.final(x) for x in paths]
    report_path = None if report_path is None else staged.final(report_path)
    return _print_design(args, analysis, source, paths, report_path)


def target_options(text: str) -> str:
    """A message of :func:`controllers.design.pi.design_pi` with its targets named as the options that set them:
    ``phase_margin=60.0 deg`` becomes ``--phase-margin 60.0 deg``, ``crossover must`` ``--crossover must``
    (``crossover``, ``phase_margin``, ``Tc``).

    Parameters
    ----------
    text : str
        The message.

    Returns
    -------
    str
    """
    return re.sub(r"\b(crossover|phase_margin|Tc)(=| must)",
                  lambda m: "--" + m.group(1).replace("_", "-") + (" " if m.group(2) == "=" else m.group(2)), text)


def _check_work(args, design) -> None:
    """Refuse a step response whose estimated time or memory is beyond the limits without ``--yes``."""
    from controllers.cli.budget import check_work, design_estimate
    from controllers.design.loop_analysis import default_step_duration
    from plant.errors import ParameterError

    if args.step_duration is None:
        t_end = default_step_duration(design)
        what = f"the step response of 15/--crossover = {t_end:g} s"
    else:
        t_end, what = args.step_duration, f"--step-duration {args.step_duration:g}"
        if not (math.isfinite(t_end) and t_end > 0.0):
            raise ParameterError(f"--step-duration must be a finite time > 0 s, got {t_end!r}")
    check_work(design_estimate(t_end, design.Tc, what=what), yes=args.yes)


def refused_warnings(warns, where: str, *, accept: bool, command: str) -> int:
    """An identification's refusing warnings (:attr:`IdentificationWarning.refusing`) echoed on stderr, one line each,
    and :data:`EXIT_REFUSED` unless ``accept`` (``--accept-warnings``); else 0.

    Parameters
    ----------
    warns : list of adaptive_ff.identification.plausibility.IdentificationWarning
        The identification's warnings.
    where : str
        The file (and joint) they come from, for the messages.
    accept : bool
        ``--accept-warnings`` given: echo them, go on.
    command : str
        What is refused (``"design"``, ``"compare"``), for the message.
    """
    refusing = [w for w in warns if w.refusing]
    for w in refusing:
        print(f"adaptive-ff: {where}: {w.code} warning on {w.parameter}: {w}", file=sys.stderr)
    if refusing and not accept:
        print(f"adaptive-ff: refused: {where} carries {len(refusing)} plausibility/identifiability "
              f"warning(s); fix the identification, or {command} anyway with --accept-warnings", file=sys.stderr)
        return EXIT_REFUSED
    return 0


def _identified(args) -> tuple:
    """``(warnings, (J, sigma), where, source)`` of ``--from FILE``, or of its joint ``--joint NAME`` (an
    ``identify-arm --json`` output, :func:`adaptive_ff.arm.result.read_arm_joint`)."""
    from adaptive_ff.arm.result import read_arm_joint
    from adaptive_ff.identification.result_file import identification_from_dict

    if getattr(args, "joint", None) is None:
        return (warnings_from_file(args.from_file), plant_from_file(args.from_file), str(args.from_file),
                str(args.from_file) + _method_of(args.from_file))
    entry = read_arm_joint(args.from_file, args.joint)
    where = f"{args.from_file} joint {args.joint!r}"
    joint = identification_from_dict(entry, where=where)
    return entry_warnings(entry, where), (joint.J, joint.sigma), where, f"{where} (method {joint.method!r})"


def entry_warnings(entry: dict, where: str) -> list:
    """The warnings of one joint's entry of an ``identify-arm --json`` output (or of an ``identify --json`` object).

    Parameters
    ----------
    entry : dict
        The parsed entry: its ``"warnings"`` list of ``{"code", "parameter", "message"}`` objects.
    where : str
        The file and the joint, for the messages.

    Returns
    -------
    list of adaptive_ff.identification.plausibility.IdentificationWarning

    Raises
    ------
    ParameterError
        A warning that is not a warning object (``where`` named).
    """
    from adaptive_ff.identification.plausibility import warning_from_dict
    from plant.errors import ParameterError

    raw = entry.get("warnings", [])
    try:
        return [warning_from_dict(w) for w in (raw if isinstance(raw, list) else [raw])]
    except ParameterError as exc:
        raise ParameterError(f"{where}: {exc}") from None


def _design_and_write(args, fig_dir, report_dir):
    """The design of ``args``, its figures written into ``fig_dir`` and its report into ``report_dir`` (None: not
    asked for); ``(analysis, source of J and sigma, figure paths, report path or None)``, or the exit status of a
    refusal."""
    from controllers.cli.data import command_line
    from controllers.design.loop_analysis import analyse_design, plot_bode, plot_step
    from controllers.design.pi import design_pi
    from plant.errors import ParameterError

    J, sigma = args.J, args.sigma
    source = "command line"
    if getattr(args, "joint", None) is not None and not args.from_file:
        raise ParameterError(f"--joint {args.joint} picks a joint of an identify-arm --json output: give it with "
                             "--from ARM.json")
    if args.from_file:
        warns, (Jf, sf), where, source = _identified(args)
        status = refused_warnings(warns, where, accept=args.accept_warnings, command="design")
        if status:
            return status
        J = Jf if J is None else J
        sigma = sf if sigma is None else sigma
    if J is None:
        raise ParameterError("give the inertia with --J (kg·m²) or a JSON file with --from")
    sigma = 0.0 if sigma is None else sigma
    if sigma < 0:
        if not args.from_file:
            raise ParameterError(f"sigma must be >= 0, got {sigma!r}")
        sigma = 0.0  # an identified negative viscous term: design for the inertia alone
    _check_range(J, sigma, source)
    try:
        design = design_pi(J, sigma=sigma, crossover=args.crossover, phase_margin=args.phase_margin, Tc=args.Tc)
    except ParameterError as exc:  # the targets' names as the options that set them, and where J, sigma come from
        raise ParameterError(f"{target_options(str(exc))} (J = {J:g} kg·m², sigma = {sigma:g} N·m·s/rad from "
                             f"{source})") from None
    _check_work(args, design)
    analysis = analyse_design(design, t_end=args.step_duration)
    paths = []
    figs = None
    if fig_dir is not None or report_dir is not None:
        figs = {"Bode plot of the open loop with gain and phase margins, |S| and |T|": plot_bode(design),
                "closed-loop response to a 1 rad/s velocity step": plot_step(analysis)}
    if fig_dir is not None:
        for name, fig in zip(("bode.png", "step.png"), figs.values()):
            fig.savefig(fig_dir / name, dpi=110)
            paths.append(fig_dir / name)
    report_path = None
    if report_dir is not None:
        from controllers.report.html import write_report

        report_path = write_report(
            report_dir, title="PI velocity-loop design", design=analysis, figures=figs, command=command_line(),
            summary={"source of J, sigma": source,
                     "targets": {"crossover (rad/s)": args.crossover, "phase margin (deg)": args.phase_margin}})
    return analysis, source, paths, report_path


def _print_design(args, analysis, source, paths, report_path) -> int:
    """The printed design (or its JSON) and the files written; the exit status (0)."""
    design = analysis.design
    if args.json:
        d = analysis.to_json_dict()
        d["targets"] = {"crossover": args.crossover, "phase_margin": args.phase_margin}
        d["source"] = source
        d["figures"] = [str(p) for p in paths]
        d["report"] = str(report_path) if report_path else None
        print(json.dumps(d, indent=2))
        return 0
    print(f"J, sigma from {source}")
    print(_summary(analysis, args))
    print(f"targets: crossover {args.crossover:g} rad/s, phase margin {args.phase_margin:g} deg")
    if math.isfinite(design.gain_margin) and design.gain_margin < 2.0:
        print(f"warning: gain margin {design.gain_margin:.3g} < 2: little room for an inertia error")
    if paths:
        print("figures: " + ", ".join(str(p) for p in paths))
    if report_path:
        print(f"report: {report_path}")
    return 0


def _summary(analysis, args) -> str:
    """``analysis.summary()`` with the gains, sigma and the step's peak torque per ``--units`` angle.

    For ``--units rad`` it is :meth:`controllers.design.loop_analysis.LoopAnalysis.summary` itself.
    Frequencies (crossover, bandwidth) are angular frequencies and stay in rad/s; J stays in kg·m².
    """
    from controllers.cli.data import per_angle

    text = analysis.summary()
    if getattr(args, "axis", "rotary") == "linear":
        return _linear_summary(analysis)
    c, angle = per_angle(args)
    if angle == "rad":
        return text
    d = analysis.design

    def swap(line: str, old: str, new: str) -> str:
        if old not in line:  # the summary's format changed: fail loudly rather than print rad/s as deg/s
            raise RuntimeError(f"design summary line without {old!r}: {line!r}")
        return line.replace(old, new)

    lines = text.splitlines()
    for i, line in enumerate(lines):
        if line.startswith("plant: "):
            lines[i] = swap(line, f"sigma = {d.sigma:g} N·m·s/rad", f"sigma = {c * d.sigma:.6g} N·m·s/{angle}")
        elif line.startswith("PI: "):
            lines[i] = swap(line, f"Kp = {d.Kp:.6g} N·m·s/rad, Ki = {d.Ki:.6g} N·m/rad",
                                    f"Kp = {c * d.Kp:.6g} N·m·s/{angle}, Ki = {c * d.Ki:.6g} N·m/{angle}")
        elif line.startswith("closed loop: "):
            lines[i] = swap(line, f"peak torque {analysis.peak_torque:.4g} N·m per rad/s",
                                    f"peak torque {c * analysis.peak_torque:.4g} N·m per {angle}/s")
    return "\n".join(lines)


def _linear_summary(analysis) -> str:
    """``analysis.summary()`` for a linear (prismatic) axis (``--axis linear``): the same SI numbers with the units
    of :data:`adaptive_ff.io.units.LINEAR_UNITS` (kg, N·s/m, N/m, N per m/s); frequencies stay in rad/s.

    Raises
    ------
    RuntimeError
        The summary's format changed (a rotary unit label not found where expected).
    """
    from adaptive_ff.io.units import LINEAR_UNITS, PARAMETER_UNITS

    d = analysis.design
    swaps = {"plant: ": [(f"J = {d.J:g} {PARAMETER_UNITS['J']}", f"J = {d.J:g} {LINEAR_UNITS['J']}"),
                         (f"sigma = {d.sigma:g} {PARAMETER_UNITS['sigma']}", f"sigma = {d.sigma:g} "
                                                                              f"{LINEAR_UNITS['sigma']}")],
             "PI: ": [(f"Kp = {d.Kp:.6g} {PARAMETER_UNITS['Kp']}, Ki = {d.Ki:.6g} {PARAMETER_UNITS['Ki']}",
                       f"Kp = {d.Kp:.6g} {LINEAR_UNITS['Kp']}, Ki = {d.Ki:.6g} {LINEAR_UNITS['Ki']}")],
             "closed loop: ": [(f"peak torque {analysis.peak_torque:.4g} {PARAMETER_UNITS['Fc']} per "
                                f"{PARAMETER_UNITS['Vs']}", f"peak force {analysis.peak_torque:.4g} "
                                                            f"{LINEAR_UNITS['Fc']} per {LINEAR_UNITS['Vs']}")]}
    lines = analysis.summary().splitlines()
    for i, line in enumerate(lines):
        for head, pairs in swaps.items():
            if line.startswith(head):
                for old, new in pairs:
                    if old not in line:  # the summary's format changed: fail loudly rather than mislabel
                        raise RuntimeError(f"design summary line without {old!r}: {line!r}")
                    line = line.replace(old, new)
        lines[i] = line
    return "\n".join(lines)


def register(sub) -> None:
    """Add the ``design`` subcommand to an argparse subparsers object."""
    from controllers.cli.budget import add_yes_argument
    from controllers.cli.data import add_units_argument

    d = sub.add_parser("design", help="design the discrete PI velocity controller (gains, margins, Bode, step)",
                       description="Loop-shaping design of the discrete PI velocity controller for the joint "
                                   "inertia J (and viscous sigma) at a target crossover and phase margin, with "
                                   "python-control; prints gains and margins and plots Bode and step responses.",
                       epilog=_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    d.add_argument("--J", type=float, default=None, metavar="KGM2", help="inertia in kg·m² (or kg)")
    d.add_argument("--sigma", type=float, default=None, metavar="NMS",
                   help="viscous coefficient in N·m·s/rad (default 0, or from --from)")
    d.add_argument("--from", dest="from_file", metavar="FILE", default=None,
                   help="JSON with J (and sigma): 'identify --json' output or a plant file; --J/--sigma override it")
    d.add_argument("--joint", metavar="NAME", default=None,
                   help="with --from ARM.json (identify-arm --json): design for that joint's entry")
    d.add_argument("--accept-warnings", action="store_true",
                   help="design even if the --from identification carries plausibility or identifiability warnings "
                        "(otherwise refused with exit status 3, the warnings echoed)")
    d.add_argument("--crossover", type=float, default=20.0, metavar="RAD_S",
                   help="target gain crossover in rad/s (default 20; at most 0.2*pi/Tc)")
    d.add_argument("--phase-margin", type=float, default=60.0, metavar="DEG",
                   help="target phase margin in degrees, in (0, 90) (default 60)")
    d.add_argument("--Tc", type=float, default=1e-3, metavar="S", help="controller period in s (default 0.001)")
    d.add_argument("--step-duration", type=float, default=None, metavar="S",
                   help="length of the step response in s (default 15/crossover)")
    d.add_argument("--out", default=None, help="directory for bode.png and step.png (default: the --report "
                                               "directory, else out/design)")
    d.add_argument("--no-figures", action="store_true", help="write no figures")
    d.add_argument("--report", metavar="DIR", default=None, help="write a self-contained HTML report to DIR")
    d.add_argument("--json", action="store_true", help="print gains, margins and step metrics as JSON")
    d.add_argument("--quiet", action="store_true", help="accepted for uniformity (the design is instantaneous)")
    d.add_argument("--axis", choices=("rotary", "linear"), default="rotary",
                   help="rotary (default): J in kg·m², sigma and Kp in N·m·s/rad, Ki in N·m/rad; linear: a "
                        "prismatic axis, the same SI numbers in kg, N·s/m, N/m, N (--units does not apply)")
    add_units_argument(d, extra="Converts sigma, Kp (N·m·s/deg), Ki (N·m/deg) and the step's peak torque; "
                                "crossover and bandwidth are angular frequencies and stay in rad/s, J in kg·m²")
    add_yes_argument(d)
    d.set_defaults(func=run)
