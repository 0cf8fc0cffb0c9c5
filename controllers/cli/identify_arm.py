"""``adaptive-ff identify-arm``: every joint's friction and the rigid body of an arm from one log and its URDF.

The method: :func:`adaptive_ff.arm.fit.identify_arm` (Pinocchio's joint-torque regressor reduced to base
parameters, per-joint Coulomb, viscous, offset and profiled Stribeck columns, weighted least squares, block
bootstrap intervals). Needs the ``[arm]`` extra (Pinocchio).
"""

from __future__ import annotations

import json

__all__ = ["register", "run"]

_EPILOG = """\
The log: columns t, q1..qN (rad or m), optional dq1..dqN (rad/s), tau1..tauN (N·m), joints in the URDF's
order (SI units; --columns maps roles to your column names, e.g. --columns t=time,q1=j1_pos,tau1=j1_torque).
Velocities and accelerations come from the positions (or the given velocities) by a zero-phase Butterworth
low-pass (--cutoff) and central differences; the torques pass the same filter. A motor-side log (motor
angles and torques) with --transmission FILE.toml: ratio = [...] (one per joint), optional coupling (N x N),
offset (rad) and torque_constant (N·m per log unit) turn it into the joint side first.

Output: per joint J (its own diagonal inertia at the log's mean configuration), Fc, Fs, Vs, delta, sigma,
offset, and tau (the friction lag of eq. 1, by output error on the joint's torque minus the identified rigid
body; null with a warning where the log does not determine it) with 95 % intervals and warnings, and the
joint's velocity noise (excitation.noise_std: export-c's stick band is three times it). --json prints
{"joints": [...], "rigid_body": {...}}; each joint's entry has the layout of identify --json's top level.

example:
  adaptive-ff identify-arm arm_log.csv --urdf examples/planar3.urdf --json
"""


def run(args) -> int:
    """Execute ``adaptive-ff identify-arm`` with parsed ``args``; return the exit status."""
    from adaptive_ff.arm.arm_log import read_arm_log
    from adaptive_ff.arm.fit import identify_arm
    from adaptive_ff.arm.lag import LagOptions
    from adaptive_ff.arm.robot import load_urdf
    from controllers.cli.data import check_output_dir, named_by, progress_from_args, write_plot

    if args.plot:
        check_output_dir(args.plot, "--plot")
    arm = load_urdf(args.urdf)
    gear = None
    if args.transmission:
        from adaptive_ff.arm.transmission import read_transmission

        gear = read_transmission(args.transmission, arm.n)
    log = read_arm_log(args.file, arm.n, columns=args.columns, joint_names=arm.names, urdf=args.urdf)
    if gear is not None:
        log = gear.to_joint(log)
    with named_by(args.file):
        result = identify_arm(log, arm, cutoff=args.cutoff, n_bootstrap=args.bootstrap, seed=args.seed,
                              rigid_body=args.rigid_body, progress=progress_from_args(args),
                              lag=False if args.no_lag else LagOptions(n_bootstrap=args.lag_bootstrap,
                                                                       workers=args.workers,
                                                                       refine_stops=args.refine_stops),
                              rows=args.rows)
    if gear is not None:
        result = gear.with_coupling_warnings(result)
    out = write_plot(result.to_dict(), args.plot, "arm_friction.png", lambda: result.plot()[0].figure)
    if args.json:
        print(json.dumps(out, indent=2, allow_nan=False))
    else:
        print(result.summary())
        if "figures" in out:
            print("figures: " + ", ".join(out["figures"]))
    return 0


def register(sub) -> None:
    """Add the ``identify-arm`` subcommand to an argparse subparsers object."""
    import argparse

    from adaptive_ff.arm.arm_log import DEFAULT_CUTOFF
    from adaptive_ff.arm.lag import LAG_BOOTSTRAP, LAG_REFINE_STICK, LAG_STICK_MAX, LAG_WORKERS
    from adaptive_ff.arm.rows import DEFAULT_ROWS, REST_WINDOW, ROWS
    from controllers.cli.data import nonnegative_int, positive_int, seed_type

    def at_least_2(text):
        n = nonnegative_int(text)
        if n < 2:
            raise argparse.ArgumentTypeError(f"must be an integer >= 2, got {text!r}")
        return n

    i = sub.add_parser("identify-arm", help="identify every joint's friction and the rigid body of an arm (URDF)",
                       epilog=_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter,
                       description="Whole-arm identification from one multi-joint log and the robot's URDF: the "
                                   "rigid body (Pinocchio's joint-torque regressor, base parameters) jointly with "
                                   "each joint's Coulomb, viscous, offset and Stribeck friction, 95 % intervals by "
                                   "a block bootstrap, warnings per joint. Needs pip install 'adaptive-ff[arm]'.")
    i.add_argument("file", help="the log (CSV/TXT with a header, .mat, .npz): t, q1..qN, [dq1..dqN], tau1..tauN")
    i.add_argument("--urdf", required=True, metavar="ROBOT.urdf", help="the robot's URDF (fixed base; revolute "
                                                                        "or prismatic joints)")
    i.add_argument("--columns", metavar="MAP", default=None,
                   help="column map role=name,... with roles t, qJ, dqJ, tauJ (J = 1..N in the URDF's order)")
    i.add_argument("--transmission", metavar="FILE.toml", default=None,
                   help="the log is motor-side: convert it to the joint side with the gear ratios, coupling matrix, "
                        "offsets and torque constants of FILE.toml (q = G^-1 q_m + offset, tau = G^T tau_m, "
                        "G = diag(ratio) coupling; the keys below)")
    i.add_argument("--cutoff", type=float, default=DEFAULT_CUTOFF, metavar="HZ",
                   help=f"cutoff of the zero-phase low-pass before differentiation (default {DEFAULT_CUTOFF:g} Hz)")
    i.add_argument("--bootstrap", type=at_least_2, default=200, metavar="N",
                   help="refits of the block bootstrap behind the intervals (default 200, >= 2)")
    i.add_argument("--seed", type=seed_type, default=0, help="seed of the bootstrap (default 0)")
    i.add_argument("--rigid-body", dest="rigid_body", choices=("fit", "urdf"), default="fit",
                   help="fit (default): identify the base parameters with the friction; urdf: use the URDF's "
                        "inertias as given and fit only the friction")
    i.add_argument("--rows", choices=ROWS, default=DEFAULT_ROWS,
                   help=f"each joint's rows (default {DEFAULT_ROWS}): moving keeps every row faster than 2 %% of "
                        "the joint's 99th-percentile speed and one cutoff period from a reversal, friction columns "
                        f"of the filtered velocity; sliding also leaves out the rows within {REST_WINDOW:g} cutoff "
                        "periods of where the joint sticks and puts the friction columns through the torque's "
                        "filter (the calibrated intervals on simulated arms, but more joints without a Stribeck "
                        "term: docs/your_arm.md)")
    i.add_argument("--no-lag", dest="no_lag", action="store_true",
                   help="skip the friction lag (tau null): its output-error fits are most of the run's CPU time")
    i.add_argument("--lag-bootstrap", dest="lag_bootstrap", type=at_least_2, default=LAG_BOOTSTRAP, metavar="N",
                   help=f"refits of each joint's lag bootstrap (default {LAG_BOOTSTRAP}, >= 2)")
    stops = i.add_mutually_exclusive_group()
    stops.add_argument("--refine-stops", dest="refine_stops", action="store_const", const=True, default="auto",
                       help="simulate every joint's stops finely in its lag fit (sub-steps of a tenth of the record's "
                            "sample time where the joint is near rest or reverses), also on joints that stick hard "
                            f"(their Coulomb friction takes off {LAG_STICK_MAX:g} rad/s or more in one sample), whose "
                            "lags are null otherwise; by default only the joints that stick less, from "
                            f"{LAG_REFINE_STICK:g} rad/s (docs/your_arm.md, How, Lag)")
    stops.add_argument("--coarse-stops", dest="refine_stops", action="store_const", const=False,
                       help="simulate no joint's stops finely in its lag fit (each at the record's step)")
    i.add_argument("--workers", type=positive_int, default=LAG_WORKERS, metavar="N",
                   help=f"processes the joints' lag fits run in (default {LAG_WORKERS}; the result does not depend "
                        "on it)")
    i.add_argument("--json", action="store_true", help="print the result as JSON")
    i.add_argument("--plot", metavar="DIR", default=None, help="write the per-joint friction figure into DIR")
    i.add_argument("--quiet", action="store_true", help="no progress bar")
    i.set_defaults(func=run)
