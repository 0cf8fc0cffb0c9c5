"""``adaptive-ff export-c``: mode adaptive's compensator, configured from an identification, as a C library for a
drive."""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

__all__ = ["register", "run", "check_options", "FLOAT_MAX", "PLAUSIBLE"]

#: The largest finite float32 (N·m, rad/s): a setting of the export must fit the float build.
FLOAT_MAX = 3.4028234663852886e38

_EPILOG = """\
The compensator is mode 'adaptive' as the package runs it (one C struct, aff_adaptive): the adaptive
feedforward (adaptive_ff.RobustAdaptiveFeedforward on a SlidingFrictionEstimator), the residual observer it
switches in where the feedforward misses (with the switch-in's trial) and the supervisor that backs the
compensation off where it hurts, with its rest rule. --feedforward-only writes the feedforward alone (no
observer, no supervisor). It is configured as 'compare' configures it: the identification's Stribeck factors
Vs and delta ('identify --Vs --delta ... --json'), its inertia as the design inertia (of the estimator, the
observer, the switch-in's loop model and the supervisor), its friction levels as the estimator's start, a
feedforward bound of half your drive's torque limit, a stick band of three times the identified velocity
noise and the residual observer's cut-off from that noise and the identified friction level. The PI gains of
the example loop (and of the switch-in's loop model and the stick fallback) are --Kp/--Ki, or designed as
'design --from' does (--crossover, --phase-margin). Every input of the drive's calls passes an input guard
(--w-max, twice --u-max, --hold-time): a bad sample drops its period and holds the output.

Writes into DIR: aff.h (the API, one header), aff.c (the package's C code of the compensator, one file),
aff_config.h (the settings as macros: AFF_TC, AFF_TS, AFF_VS, AFF_DELTA, AFF_J_DESIGN, AFF_U_MAX,
AFF_FF_MAX, AFF_KP, AFF_KI, AFF_W_MAX, AFF_HOLD_TIME, ...), aff_config.c (AFF_CONFIG, the settings of the
compensator and the input guard, every field commented: edit one and rebuild, aff_init checks them and computes
the rest), example_loop.c (a 1 kHz loop: read velocity, aff_step,
aff_transfer into the PI, write torque, aff_observe) and a Makefile ('make': libaff.a and
the example in double; 'make FLOAT=1': single precision, -DAFF_FLOAT). C99 and <math.h> only: no malloc,
no I/O, bounded work per call. An identification with plausibility or identifiability warnings is
refused with exit status 3 (as 'design --from') unless --accept-warnings.

From an arm's identification ('identify-arm --json'): one library with a compensator per joint, each
configured from its joint's entry as above; aff_config.h names the joints (AFF_N_JOINTS, the enum
AFF_JOINT_<NAME>, AFF_JOINT_NAMES_INIT) and aff_config.c holds AFF_CONFIGS[AFF_N_JOINTS], one configuration
per joint (aff_init(&c[j], &AFF_CONFIGS[j])); the example loop runs an array of compensators. --joint NAME
exports that joint alone, in the one-joint layout. --J-design, --Vs, --delta, --Kp, --Ki set one joint's
value: with an arm, only with --joint.

examples:
  adaptive-ff export-c --from id.json --u-max 150 --out drive_ff && make -C drive_ff run
  adaptive-ff export-c --from id.json --u-max 150 --Kp 80 --Ki 1600 --float --out drive_ff
  adaptive-ff export-c --from arm.json --u-max 50 --out arm_ff && make -C arm_ff run
"""


#: The plausible range of a physical setting (SI units), as plant files have it (docs/cli.md).
PLAUSIBLE = (1e-9, 1e9)
#: The options of the export that are physical settings: (option, attribute, unit, zero allowed), each checked
#: against :data:`PLAUSIBLE` (None: not given, the default applies).
_SETTINGS = (("--u-max", "u_max", "N·m", False), ("--Tc", "Tc", "s", False), ("--Ts", "Ts", "s", False),
             ("--J-design", "J_design", "kg·m²", False), ("--ff-max", "ff_max", "N·m", False),
             ("--stick-band", "stick_band", "rad/s", True), ("--Vs", "Vs", "rad/s", False),
             ("--Kp", "Kp", "N·m·s/rad", True), ("--Ki", "Ki", "N·m/rad", True),
             ("--crossover", "crossover", "rad/s", False), ("--w-max", "w_max", "rad/s", False),
             ("--hold-time", "hold_time", "s", False))


def check_options(args) -> None:
    """Refuse, naming the option, a setting of ``export-c`` that the float build cannot represent or that is
    physically absurd: ``--u-max`` (twice it, the input guard's bound, must be a float), every physical setting
    finite and within :data:`PLAUSIBLE` (zero allowed for ``--stick-band``, ``--Kp``, ``--Ki``), ``--delta``
    finite, non-zero and of magnitude within 1e-3..1e3 (``|w/Vs|**delta`` must stay a number in float), ``--Tc``
    at most 1 s and ``--Ts`` at most 1000 periods of it.

    Raises
    ------
    ParameterError
        ``--NAME VALUE UNIT: ...`` with what the value must be.
    """
    from plant.errors import ParameterError

    u = args.u_max
    if not (math.isfinite(u) and u > 0.0):
        raise ParameterError(f"--u-max must be a finite torque > 0 (N·m), got {u!r}")
    if not 2.0 * u <= FLOAT_MAX:
        raise ParameterError(f"--u-max {u!r} N·m: twice it, the input guard's bound, is beyond what the "
                             f"float build represents ({FLOAT_MAX:.4g}); give the drive's torque limit")
    lo, hi = PLAUSIBLE
    for option, attr, unit, zero in _SETTINGS:
        v = getattr(args, attr, None)
        if v is None or (zero and v == 0.0):
            continue
        if not (math.isfinite(v) and lo <= v <= hi):
            raise ParameterError(f"{option} {v!r} {unit}: must be a finite number in the plausible range "
                                 f"{lo:g}..{hi:g}{' (or 0)' if zero else ''} in SI units; a unit slip?")
    d = args.delta
    if d is not None and not (math.isfinite(d) and 1e-3 <= abs(d) <= 1e3):
        raise ParameterError(f"--delta {d!r}: the Stribeck shape factor must be finite with 1e-3 <= |delta| <= 1e3 "
                             f"(|w/Vs|**delta must stay a number in the float build)")
    if args.Tc > 1.0:
        raise ParameterError(f"--Tc {args.Tc!r} s: a drive's controller period is at most 1 s")
    if args.Ts > 1000.0 * args.Tc:
        raise ParameterError(f"--Ts {args.Ts!r} s: at most 1000 periods --Tc ({1000.0 * args.Tc:g} s)")
    if not 0.0 < args.phase_margin < 90.0:
        raise ParameterError(f"--phase-margin {args.phase_margin!r} deg: must lie in (0, 90) degrees")


def run(args) -> int:
    """Execute ``adaptive-ff export-c`` with parsed ``args``; return the exit status.

    The files appear together at the end, or the folder keeps its previous content; a second export into the same
    folder while one runs is refused (:mod:`adaptive_ff.io.output`).
    """
    from adaptive_ff.io.output import output_lock
    from controllers.cli.data import check_output_dir
    from plant.errors import ParameterError

    check_output_dir(args.out, "--out")
    out = Path(args.out)
    if out.is_dir() and any(out.iterdir()) and not args.force:
        raise ParameterError(f"--out {out}: the folder exists and is not empty; give a new folder, or --force to "
                             "overwrite the exported files in it")
    check_options(args)
    with output_lock(out, "--out"):  # held from the start; export_c writes the files together at its end
        return _export(args, out)


def _export(args, out: Path) -> int:
    """The export of :func:`run` once its options are checked and ``out`` is locked; the exit status."""
    from adaptive_ff.arm.result import read_arm_joint
    from adaptive_ff.compensation.export_c import JointExport, export_c
    from controllers.cli.design import entry_warnings, refused_warnings, warnings_from_file

    if args.joint is None and _is_arm_file(args.from_file):
        return _export_arm(args, out)
    from controllers.experiments.compensator_file import read_identified

    read_identified(args.from_file, args.joint)  # read errors name the file as what it should be: an identification
    if args.joint is None:
        where, warns = str(args.from_file), warnings_from_file(args.from_file)
    else:
        where = f"{args.from_file} joint {args.joint!r}"
        warns = entry_warnings(read_arm_joint(args.from_file, args.joint), where)
    status = refused_warnings(warns, where, accept=args.accept_warnings, command="export")
    if status:
        return status
    comp, s = _compensator(args, args.joint)
    origin = f" for {Path(args.from_file).name}" + ("" if args.joint is None else f" joint {args.joint!r}")
    joint = JointExport(compensator=comp, J_design=s["J_design"], u_max=s["u_max"], Kp=s["Kp"], Ki=s["Ki"],
                        friction=s["joint"], notes=s["notes"])
    res = export_c(joint, out, w_max=args.w_max, hold_time=args.hold_time, float_default=args.float,
                   force=args.force, origin=origin)
    return _print_export(args, res)


def _is_arm_file(path) -> bool:
    """Whether ``path`` is an ``identify-arm --json`` output (False where it does not parse: the identification's
    reader names what is wrong)."""
    from adaptive_ff.arm.result import is_arm_identification
    from plant.errors import ParameterError
    from plant.models import read_json

    try:
        return is_arm_identification(read_json(path, what="JSON identification"))
    except (ParameterError, OSError):
        return False


def _compensator(args, arm_joint=None) -> tuple:
    """:func:`controllers.experiments.compensator_file.compensator_from_file` of ``args`` (of the joint ``arm_joint``
    of an ``identify-arm`` output)."""
    from controllers.cli.design import target_options
    from controllers.design.pi import PITuning
    from controllers.experiments.compensator_file import compensator_from_file
    from plant.errors import ParameterError

    extra = {k: getattr(args, k) for k in ("ff_max", "stick_band") if getattr(args, k) is not None}
    try:
        pi = PITuning(Kp=args.Kp, Ki=args.Ki, crossover=args.crossover, phase_margin=args.phase_margin)
        return compensator_from_file(args.from_file, u_max=args.u_max, pi=pi, start=args.start,
                                     Tc=args.Tc, Ts=args.Ts, J_design=args.J_design, Vs=args.Vs, delta=args.delta,
                                     feedforward_only=args.feedforward_only, arm_joint=arm_joint, **extra)
    except ParameterError as exc:
        text = target_options(str(exc))
        if text == str(exc):
            raise
        where = args.from_file if arm_joint is None else f"{args.from_file} joint {arm_joint!r}"
        raise ParameterError(f"{text} (the example loop's PI designed for the J and sigma of {where}; "
                             "--Kp and --Ki give it instead)") from None


#: The options that set one joint's value, refused for a whole arm's export (each joint has its own).
_ONE_JOINT = (("--J-design", "J_design"), ("--Vs", "Vs"), ("--delta", "delta"), ("--Kp", "Kp"), ("--Ki", "Ki"))


def _export_arm(args, out: Path) -> int:
    """``export-c --from ARM.json`` without ``--joint``: a compensator per joint in one library
    (:func:`adaptive_ff.compensation.export_c_arm.export_c_arm`); the exit status."""
    from adaptive_ff.arm.result import read_arm_entries
    from adaptive_ff.compensation.export_c_arm import JointExport, export_c_arm
    from controllers.cli.design import EXIT_REFUSED, entry_warnings, refused_warnings
    from plant.errors import ParameterError

    given = [o for o, k in _ONE_JOINT if getattr(args, k) is not None]
    if given:
        raise ParameterError(f"{given[0]} sets one joint's value; {args.from_file} is an arm's identification, each "
                             "of whose joints has its own: export one joint with --joint NAME to set it")
    entries = read_arm_entries(args.from_file)
    refused = [refused_warnings(entry_warnings(e, f"{args.from_file} joint {e['name']!r}"),
                                f"{args.from_file} joint {e['name']!r}", accept=args.accept_warnings, command="export")
               for e in entries]
    if any(refused):
        return EXIT_REFUSED
    joints = []
    for e in entries:
        comp, s = _compensator(args, e["name"])
        joints.append(JointExport(name=e["name"], compensator=comp, J_design=s["J_design"], u_max=s["u_max"],
                                  Kp=s["Kp"], Ki=s["Ki"], friction=s["joint"], notes=s["notes"]))
    res = export_c_arm(joints, out, w_max=args.w_max, hold_time=args.hold_time, float_default=args.float,
                       force=args.force, origin=f" for {Path(args.from_file).name}")
    return _print_export(args, res)


def _print_export(args, res) -> int:
    """Print what an export wrote (``--json``: its ``to_dict``; ``--quiet``: nothing); 0."""
    if args.json:
        print(json.dumps(res.to_dict(), indent=2))
    elif not args.quiet:
        print(res.summary())
    return 0


def register(sub) -> None:
    """Add the ``export-c`` subcommand to an argparse subparsers object."""
    e = sub.add_parser("export-c", help="write mode adaptive's compensator as a C library for your drive (C99, "
                                        "<math.h> only)",
                       description="Write mode adaptive's friction compensator (the adaptive feedforward, the "
                                   "residual observer it switches in, the supervisor), configured from an "
                                   "identification, as C sources with one header, its configuration, an example "
                                   "1 kHz loop and a Makefile: the package's own C code of the compensator.",
                       epilog=_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    e.add_argument("--from", dest="from_file", metavar="FILE", required=True,
                   help="'adaptive-ff identify --Vs ... --delta ... --json' output (Vs, delta, J, sigma), or an "
                        "'identify-arm --json' output (a compensator per joint; --joint picks one)")
    e.add_argument("--joint", metavar="NAME", default=None,
                   help="with --from ARM.json (identify-arm --json): export only that joint's compensator (the "
                        "layout of a one-joint export); without it, one library with a compensator per joint")
    e.add_argument("--out", metavar="DIR", required=True, help="folder to write (new or empty; see --force)")
    e.add_argument("--u-max", type=float, required=True, metavar="NM",
                   help="the drive's torque limit in N·m: the velocity gate's bound, twice the feedforward's (unless "
                        "--ff-max) and the example's saturation")
    e.add_argument("--Tc", type=float, default=1e-3, metavar="S", help="controller period in s (default 0.001)")
    e.add_argument("--Ts", type=float, default=0.01, metavar="S",
                   help="estimator update period in s, a multiple of --Tc (default 0.01)")
    e.add_argument("--J-design", type=float, default=None, metavar="KGM2",
                   help="design inertia in kg·m² (default: the identified J)")
    e.add_argument("--ff-max", type=float, default=None, metavar="NM",
                   help="bound on |feedforward| in N·m (default: half of --u-max, as compare)")
    e.add_argument("--stick-band", type=float, default=None, metavar="RAD_S",
                   help="stick-detection band in rad/s (default: three times the identification's velocity noise "
                        "estimate, excitation.noise_std; 0 without one)")
    e.add_argument("--Vs", type=float, default=None, metavar="RAD_S", help="Stribeck velocity (default: the file's)")
    e.add_argument("--delta", type=float, default=None, help="Stribeck shape factor (default: the file's)")
    e.add_argument("--Kp", type=float, default=None, metavar="NMS", help="PI gain in N·m·s/rad (with --Ki)")
    e.add_argument("--Ki", type=float, default=None, metavar="NM", help="PI gain in N·m/rad (with --Kp)")
    e.add_argument("--crossover", type=float, default=20.0, metavar="RAD_S",
                   help="without --Kp/--Ki: the PI's gain crossover in rad/s (default 20)")
    e.add_argument("--phase-margin", type=float, default=60.0, metavar="DEG",
                   help="without --Kp/--Ki: the PI's phase margin in degrees (default 60)")
    e.add_argument("--start", action="store_true",
                   help="feed the identified friction map forward from the first period until the first "
                        "trusted estimate (a provisional start; default: 0 until the estimator switches on)")
    e.add_argument("--feedforward-only", action="store_true",
                   help="export the adaptive feedforward alone, without the residual observer and the supervisor of "
                        "mode adaptive")
    e.add_argument("--w-max", type=float, default=1e4, metavar="RAD_S",
                   help="the input guard's largest plausible velocity in rad/s: a sample beyond it is refused "
                        "(default 1e4)")
    e.add_argument("--hold-time", type=float, default=0.1, metavar="S",
                   help="while inputs are refused the output is held; after this time it fades to 0 (s, default 0.1)")
    e.add_argument("--float", action="store_true",
                   help="make builds single precision by default (AFF_FLOAT; make FLOAT=0 for double)")
    e.add_argument("--accept-warnings", action="store_true",
                   help="export even if the identification carries plausibility or identifiability warnings")
    e.add_argument("--force", action="store_true", help="write into a non-empty --out (the exported files are "
                                                         "overwritten)")
    e.add_argument("--json", action="store_true", help="print the files and the configuration as JSON")
    e.add_argument("--quiet", action="store_true", help="print nothing on success")
    e.set_defaults(func=run)
