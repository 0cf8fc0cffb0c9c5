"""``adaptive-ff compare-arm``: every joint of a simulated arm in its velocity loop, per mode, eta per joint.

The experiment: :func:`controllers.experiments.compare_arm.compare_arm`. Needs the ``[arm]`` extra (Pinocchio).
"""

from __future__ import annotations

import json

__all__ = ["register", "run"]

_EPILOG = """\
Each joint of the arm gets what identify-arm --json gives you for it: the PI that 'design --from ARM.json
--joint NAME' designs (on the joint's identified J and sigma at --crossover, --phase-margin) and, per mode,
the package's compensator: fixed the identified static map (no lag), adaptive the compensator 'export-c --from
ARM.json' writes for the joint (the adaptive feedforward, the residual observer it switches in, the
supervisor), adaptive-ff that feedforward alone (export-c --feedforward-only), dob and canudas compare's peers
(the disturbance observer, the Canudas de Wit compensator) on the joint's identified J. --encoder-counts and
--delay give every joint's sensor an encoder and a measurement delay (compare's [sensor] models). The simulated arm (--plant):
the URDF's rigid body (Pinocchio's articulated-body algorithm) with the file's armatures and a lagged Stribeck
friction per joint; nothing of it reaches a design or a compensator. Each joint follows its own multisine
velocity reference; the other joints' rigid-body torques (inertia coupling, Coriolis, gravity) are
disturbances to its loop, as on a drive without a model-based feedforward. eta per joint: (RMS_none -
RMS_mode) / (RMS_none - RMS_frictionless) over the second half.

The plant file (JSON): {"armature": [Ia1, ..., IaN], "joints": [{"name": "shoulder", "Fc": 2.0, "Fs": 2.6,
"Vs": 0.1, "delta": 1.0, "sigma": 0.8, "tau": 0.002}, ...]} (SI units; armature and tau optional, 0).

example:
  adaptive-ff compare-arm --urdf examples/planar3.urdf --from arm.json --plant planar3_plant.json
"""


def run(args) -> int:
    """Execute ``adaptive-ff compare-arm`` with parsed ``args``; return the exit status."""
    from adaptive_ff.arm.robot import load_urdf
    from adaptive_ff.arm.simulate import load_arm_plant
    from controllers.cli.data import check_output_dir, write_plot
    from controllers.experiments.compare_arm import CompareArmOptions, compare_arm

    if args.plot:
        check_output_dir(args.plot, "--plot")
    options = CompareArmOptions(duration=args.duration, seed=args.seed, modes=_modes(args.modes),
                                crossover=args.crossover, phase_margin=args.phase_margin, Ts=args.Ts,
                                u_max=_limits(args.u_max), noise_std=args.noise, amplitude=args.amplitude,
                                start=args.start, encoder_counts=args.encoder_counts, delay=args.delay)
    arm = load_urdf(args.urdf)
    plant = load_arm_plant(args.plant, arm)
    result = compare_arm(plant, args.from_file, options, progress=None if not args.quiet else False)
    out = write_plot(result.to_dict(), args.plot, "arm_eta.png", lambda: result.plot().figure)
    if args.json:
        print(json.dumps(out, indent=2, allow_nan=False))
        return 0
    print(f"arm: {args.urdf} ({', '.join(arm.names)}); plant: {args.plant}; identification: {args.from_file}")
    for d in result.designs:
        print(f"  {d.name}: J_design {d.J_design:.6g} kg·m², PI Kp {d.Kp:.6g} N·m·s/rad, Ki {d.Ki:.6g} N·m/rad, "
              f"u_max {d.u_max:g} N·m, stick band {d.settings['stick_band']:.3g} rad/s "
              f"({'3 x its noise estimate' if d.noise_source == 'identification' else '3 x --noise'})"
              + ("" if not args.start else ", start map" if d.settings["start"] else ", no start map (tau null)"))
    print(result.summary())
    if "figures" in out:
        print("figures: " + ", ".join(out["figures"]))
    return 0


def _modes(text):
    """The modes of ``--modes`` (comma-separated; CompareArmOptions checks them), default all of ARM_MODES but
    adaptive-ff."""
    from controllers.experiments.compare_arm import DEFAULT_MODES

    if not text:
        return DEFAULT_MODES
    return tuple(m.strip() for m in text.split(",") if m.strip())


def _limits(text):
    """``--u-max``: None, one number or one per joint (comma-separated)."""
    from plant.errors import ParameterError

    if text is None:
        return None
    try:
        vals = [float(x) for x in text.split(",")]
    except ValueError:
        raise ParameterError(f"--u-max must be a number or comma-separated numbers (N·m), got {text!r}") from None
    return vals[0] if len(vals) == 1 else vals


def register(sub) -> None:
    """Add the ``compare-arm`` subcommand to an argparse subparsers object."""
    import argparse

    from controllers.cli.data import nonnegative_int, positive_int, seed_type

    c = sub.add_parser("compare-arm", help="every joint of a simulated arm in its velocity loop: eta per joint",
                       epilog=_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter,
                       description="The whole arm in closed loop: a velocity PI and the package's compensator per "
                                   "joint (configured from identify-arm --json) on the coupled rigid body, in the "
                                   "modes none, fixed, adaptive (and adaptive-ff) against the frictionless arm; "
                                   "the second-half RMS error and eta per joint. Needs pip install "
                                   "'adaptive-ff[arm]'.")
    c.add_argument("--urdf", required=True, metavar="ROBOT.urdf", help="the robot's URDF")
    c.add_argument("--from", dest="from_file", required=True, metavar="ARM.json",
                   help="the arm's identification (identify-arm --json): each joint's J, friction and Stribeck "
                        "factors")
    c.add_argument("--plant", required=True, metavar="FILE.json",
                   help="the simulated arm's armatures and friction per joint (the truth; format below)")
    c.add_argument("--u-max", dest="u_max", default=None, metavar="NM",
                   help="the drives' torque limits (N·m): one for all joints or one per joint, comma-separated "
                        "(default: the URDF's effort limits)")
    c.add_argument("--duration", type=float, default=20.0, metavar="S", help="length of each run (default 20 s)")
    c.add_argument("--seed", type=seed_type, default=0, help="seed of the references and the noise (default 0)")
    c.add_argument("--modes", default=None, metavar="LIST",
                   help="comma-separated subset of none, fixed, adaptive, adaptive-ff, dob, canudas, frictionless "
                        "(default: none, fixed, adaptive, frictionless; none and frictionless always run); dob and "
                        "canudas are compare's peers of those names, per joint on its identified J")
    c.add_argument("--crossover", type=float, default=20.0, metavar="RAD_S",
                   help="each joint's PI crossover (default 20 rad/s)")
    c.add_argument("--phase-margin", dest="phase_margin", type=float, default=60.0, metavar="DEG",
                   help="each joint's PI phase margin (default 60 deg)")
    c.add_argument("--Ts", type=float, default=0.01, metavar="S",
                   help="the adaptive estimator's sample time (default 0.01 s; a multiple of the 1 ms period)")
    c.add_argument("--noise", type=float, default=1e-3, metavar="RAD_S",
                   help="velocity measurement noise per joint (default 0.001 rad/s); the stick band where an "
                        "entry has no noise estimate is three times it")
    c.add_argument("--encoder-counts", dest="encoder_counts", type=positive_int, default=None, metavar="N",
                   help="each joint measures with an encoder of N counts per joint revolution (quantised position, "
                        "backward-difference velocity, plus --noise), as compare's [sensor] encoder_counts "
                        "(default: a velocity sensor)")
    c.add_argument("--delay", type=nonnegative_int, default=0, metavar="PERIODS",
                   help="measurement delay of every joint's sensor in controller periods (default 0), as compare's "
                        "[sensor] delay")
    c.add_argument("--amplitude", type=float, default=0.5, metavar="RAD",
                   help="position amplitude of each joint's multisine reference (default 0.5 rad)")
    c.add_argument("--start", action="store_true",
                   help="start the adaptive modes' feedforward from each joint's identified map with its lag "
                        "(export-c --start) where the joint's entry has a tau")
    c.add_argument("--json", action="store_true", help="print the result as JSON")
    c.add_argument("--plot", metavar="DIR", default=None, help="write the eta-per-joint figure into DIR")
    c.add_argument("--quiet", action="store_true", help="no progress bar")
    c.set_defaults(func=run)
