"""The whole arm in closed loop: eta per joint of compare-arm on a simulated 6-axis arm (the Staubli TX40's URDF).

Run:  python -m benchmarks.arm_closed_loop [--duration 40] [--seed 0] [--id-seed 1] [--rows moving|sliding] [--stops]

The arm: ``data/tx40/tx40.urdf`` (the six links' inertias of the Staubli TX40) with the armatures of
:data:`ARMATURE` and a lagged Stribeck friction per joint (:data:`FRICTION`: ``Fc`` and ``sigma`` near the
reference values of ``docs/benchmarks/arm_tx40.md``, ``Fs = 1.3 Fc``, ``Vs`` 0.1-0.15 rad/s, ``delta = 1``, a lag
``tau = 2 ms``). What the loops get is what a user has: a 20 s log of the arm (:func:`adaptive_ff.arm.simulate.
simulate_arm`, seed ``--id-seed``) identified by :func:`adaptive_ff.arm.fit.identify_arm` (as ``identify-arm
--json``, its rows ``--rows``, default identify_arm's; 20 bootstrap refits: the intervals do not enter the loops), then
:func:`controllers.experiments.compare_arm.compare_arm` on the same arm in the modes none, fixed, adaptive,
adaptive-ff, the peers dob and canudas, and frictionless (``--duration`` s, seed ``--seed``, the drives' limits the URDF's effort limits).
``--stops``: the arm stepped finely in the periods in which a joint stops or reverses, in the identification log and
in the loops (``ArmSimulation.stop_refine``, ``CompareArmOptions.stop_refine``: :data:`adaptive_ff.arm.simulate.
STOP_REFINE`), and every lag fit's stops refined (``LagOptions(refine_stops=True)``; without it identify-arm's
default, the joints that stick; ``docs/your_arm.md``, How, Lag).
Printed: each joint's identified inertia and PI, the second-half RMS error per joint and mode, eta per joint, the
adaptive compensator's switch-in time of its residual observer per joint, the CPU time.
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

from benchmarks.arm_coverage import cpu_seconds

ROOT = Path(__file__).resolve().parents[1]
URDF = ROOT / "data" / "tx40" / "tx40.urdf"
#: Rotor inertias reflected to the joints (kg·m²): motors of 1e-4 to 3e-4 kg·m² behind ratios 32-48.
ARMATURE = (0.3, 0.3, 0.2, 0.07, 0.06, 0.03)
#: ``(Fc, sigma, Vs)`` per joint (N·m, N·m·s/rad, rad/s); ``Fs = 1.3 Fc``, ``delta = 1``, ``tau = 2 ms``.
LEVELS = ((7.14, 8.05, 0.1), (8.26, 5.53, 0.1), (6.34, 1.97, 0.1), (2.48, 1.11, 0.15), (3.03, 1.24, 0.15),
          (0.4, 0.05, 0.15))


def friction():
    """The simulated arm's :class:`adaptive_ff.arm.simulate.JointFriction` per joint."""
    from adaptive_ff.arm.simulate import JointFriction

    return [JointFriction(Fc=c, Fs=1.3 * c, Vs=v, delta=1.0, sigma=s, tau=0.002) for c, s, v in LEVELS]


def identify(path, *, seed: int = 1, duration: float = 20.0, n_bootstrap: int = 20, rows: str | None = None,
             stops: bool = False):
    """Simulate the arm's identification log, identify it (``rows``: identify_arm's, None its default; ``stops``:
    the log's stops and the lag fits' refined, module docstring) and write the ``identify-arm --json`` to ``path``;
    returns the :class:`adaptive_ff.arm.robot.ArmModel`."""
    from adaptive_ff.arm.fit import identify_arm
    from adaptive_ff.arm.lag import LagOptions
    from adaptive_ff.arm.robot import load_urdf
    from adaptive_ff.arm.simulate import STOP_REFINE, ArmSimulation, simulate_arm

    arm = load_urdf(URDF)
    run = ArmSimulation(duration=duration, substeps=1, stop_refine=STOP_REFINE if stops else 1)
    log = simulate_arm(arm, friction(), run=run, seed=seed, armature=ARMATURE)
    res = identify_arm(log, arm, n_bootstrap=n_bootstrap, lag=LagOptions(refine_stops=True) if stops else LagOptions(),
                       **({} if rows is None else {"rows": rows}))
    Path(path).write_text(json.dumps(res.to_dict()))
    return arm


def main(argv=None) -> int:
    """Run the benchmark (module docstring) and print its table."""
    from adaptive_ff.arm.simulate import STOP_REFINE, ArmPlant
    from adaptive_ff.arm.rows import DEFAULT_ROWS, ROWS
    from controllers.experiments.compare_arm import ARM_MODES, compare_arm

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--duration", type=float, default=40.0, help="length of each closed-loop run (s, default 40)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the references and the noise (default 0)")
    ap.add_argument("--id-seed", dest="id_seed", type=int, default=1, help="seed of the identification log")
    ap.add_argument("--start", action="store_true",
                    help="start the adaptive modes from each joint's identified map and lag (compare-arm --start)")
    ap.add_argument("--rows", choices=ROWS, default=DEFAULT_ROWS,
                    help=f"identify_arm's rows (default {DEFAULT_ROWS}, its default)")
    ap.add_argument("--stops", action="store_true", help="the arm's stops stepped finely (log and loops) and the lag "
                    "fits' refined")
    args = ap.parse_args(argv)
    t0 = cpu_seconds()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "arm.json"
        arm = identify(path, seed=args.id_seed, rows=args.rows, stops=args.stops)
        t1 = cpu_seconds()
        res = compare_arm(ArmPlant(arm, friction(), armature=ARMATURE), path, duration=args.duration,
                          seed=args.seed, modes=ARM_MODES, start=args.start,
                          stop_refine=STOP_REFINE if args.stops else 1)
    t2 = cpu_seconds()
    print(f"compare-arm on the simulated TX40 (6 joints): identification log seed {args.id_seed}, closed loop "
          f"{args.duration:g} s seed {args.seed}, rows {args.rows}" + (", stops refined" if args.stops else ""))
    for d in res.designs:
        sw = res.runs["adaptive"].info[d.name].get("t_switch_in")
        print(f"  {d.name}: J_design {d.J_design:.4g} kg·m², Kp {d.Kp:.4g}, Ki {d.Ki:.4g}, u_max {d.u_max:g} N·m; "
              f"adaptive's residual observer switched in at {'-' if sw is None else f'{sw:.2f} s'}")
    print(res.summary())
    print(f"CPU: identification {t1 - t0:.0f} s, closed loop {t2 - t1:.0f} s ({len(res.runs)} modes)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
