"""Coverage of identify-arm's 95 % intervals over seeded simulated arms, per parameter.

Run:  python -m benchmarks.arm_coverage [--n 50] [--start 0] [--bootstrap 200] [--duration 20] [--rows moving|sliding]
      [--lag] [--coarse-arms] [--refine-stops | --coarse-stops]

Each arm is ``examples/planar3.urdf`` (three links in the vertical plane) with the armatures 0.2, 0.1, 0.05 kg·m²
and a friction per joint drawn from its seed (:func:`draw_friction`: ``Fc`` 0.5-2.5 N·m, ``Fs = Fc`` times
1.15-1.5, ``Vs`` 0.06-0.14 rad/s, ``delta = 1``, ``sigma`` 0.15-1 N·m·s/rad, an offset of -0.1-0.1 N·m, no lag),
simulated for ``--duration`` s (:func:`adaptive_ff.arm.simulate.simulate_arm`: its PI per joint on a multisine,
sensor noise, the seed's reference phases and noise) and identified as ``adaptive-ff identify-arm`` identifies it
(:func:`adaptive_ff.arm.fit.identify_arm`, default cutoff, ``--bootstrap`` refits, bootstrap seed = the arm's,
its ``rows`` from ``--rows``, default identify_arm's (``"moving"``); without the lag fit: the arms have none).
With ``--lag`` each joint's friction lags (eq. 1) as ``benchmarks/arm_lag.py`` draws it (:func:`draw_lags`: none
with probability 0.4, else 2-10 ms), and the arms are identified with their lag fits (10 refits each; the whole-arm
fit then runs again with each reported lag in its joint's friction columns), whose reported lags' intervals make
the row ``tau`` (over the lagged joints whose lag is reported; a lag reported on a lag-free joint counts as outside).
Each arm is integrated as a continuous arm is: one Runge-Kutta step per 1 ms period, and ten
(:data:`adaptive_ff.arm.simulate.STOP_REFINE`, ``ArmSimulation.stop_refine``) in each period in which a joint stops
or reverses, where a lagged joint rings through zero velocity faster than a 1 ms step resolves. ``--coarse-arms``
steps those periods once too (the step's own ringing then sits in the log at every stop). The lag fits refine the
stops of the joints that stick, ``identify-arm``'s default; ``--refine-stops`` every joint's
(``LagOptions(refine_stops=True)``, ``identify-arm --refine-stops``), ``--coarse-stops`` none (``identify-arm
--coarse-stops``).
``--workers N`` runs the arms in N processes.

Printed per parameter: the share of the true values inside their 95 % interval, over every joint of every arm
(``J`` against Pinocchio's ``M_jj`` at the log's mean position with the armatures; ``Vs`` only where the Stribeck
term was kept) and over every base parameter of every arm (the URDF's inertias with the armatures, reduced to the
base parameters), with the 95 % binomial (Wilson) interval of that share, and how many true values lie outside
their interval on a joint without a warning whose text names the parameter (a base parameter has no warnings). The target of a 95 % interval is a
share near 0.95; between 0.90 and 0.98 is what ``docs/your_arm.md`` reports as calibrated.
"""

from __future__ import annotations

import argparse
import math
import resource
from concurrent.futures import ProcessPoolExecutor
from functools import partial
from pathlib import Path

import numpy as np

from adaptive_ff.arm.simulate import STOP_REFINE

ROOT = Path(__file__).resolve().parents[1]
URDF = ROOT / "examples" / "planar3.urdf"
ARMATURE = np.array([0.2, 0.1, 0.05])
PARAMETERS = ("J", "Fc", "Fs", "sigma", "offset", "Vs", "tau")
#: Probability that a joint is drawn without a lag (:func:`draw_lags`, ``benchmarks/arm_lag.py``).
P_LAG_FREE = 0.4
#: Range (s) of a drawn lag.
LAG_RANGE = (2e-3, 10e-3)


def draw_friction(n: int, seed: int) -> list:
    """The friction of the ``n`` joints of arm ``seed`` (module docstring), from ``default_rng([seed, 7])``."""
    from adaptive_ff.arm.simulate import JointFriction

    rng = np.random.default_rng([seed, 7])
    out = []
    for _ in range(n):
        Fc = rng.uniform(0.5, 2.5)
        out.append(JointFriction(Fc=Fc, Fs=Fc * rng.uniform(1.15, 1.5), Vs=rng.uniform(0.06, 0.14), delta=1.0,
                                 sigma=rng.uniform(0.15, 1.0), offset=rng.uniform(-0.1, 0.1)))
    return out


def lag_draws(rng, n: int) -> list:
    """``n`` friction lags (s) drawn from the generator ``rng``: 0 with probability :data:`P_LAG_FREE`, else uniform
    in :data:`LAG_RANGE` (one draw for the choice, one for the lag)."""
    return [0.0 if rng.uniform() < P_LAG_FREE else float(rng.uniform(*LAG_RANGE)) for _ in range(n)]


def draw_lags(n: int, seed: int) -> list:
    """Each of the ``n`` joints' friction lag (s) of arm ``seed``: :func:`lag_draws` (as
    :func:`benchmarks.arm_lag.draw_friction` draws them) from ``default_rng([seed, 52])``."""
    return lag_draws(np.random.default_rng([seed, 52]), n)


def arm_friction(n: int, seed: int, lag: bool = False) -> list:
    """The friction of arm ``seed``: :func:`draw_friction`, with :func:`draw_lags`' lags where ``lag``."""
    from dataclasses import replace

    friction = draw_friction(n, seed)
    return [replace(f, tau=t) for f, t in zip(friction, draw_lags(n, seed))] if lag else friction


def arm_log(arm, seed: int, *, duration: float = 20.0, lag: bool = False, substeps: int = 1,
            stop_refine: int = STOP_REFINE):
    """The simulated log (:class:`adaptive_ff.arm.arm_log.ArmLog`) of the arm of seed ``seed``: its friction
    :func:`arm_friction`, ``duration`` seconds (s) of the planar arm with the armatures :data:`ARMATURE`, integrated
    with ``substeps`` Runge-Kutta steps per 1 ms period (the coverage takes 1) and ``stop_refine`` times as many in
    the periods in which a joint stops or reverses (``ArmSimulation.stop_refine``; default :data:`adaptive_ff.arm.
    simulate.STOP_REFINE`, a continuous arm's stops; 1: none)."""
    from adaptive_ff.arm.simulate import ArmSimulation, simulate_arm

    run = ArmSimulation(duration=duration, substeps=substeps, stop_refine=stop_refine)
    return simulate_arm(arm, arm_friction(arm.n, seed, lag), run=run, seed=seed, armature=ARMATURE)


def true_theta(arm) -> np.ndarray:
    """The arm's true dynamic parameters (the regressor's columns): the URDF's inertias with the armatures
    :data:`ARMATURE`."""
    theta = arm.theta_urdf.copy()
    theta[-arm.n:] = ARMATURE
    return theta


def true_inertia(arm, q) -> np.ndarray:
    """Each joint's true ``M_jj`` (kg·m², shape (N,)) at the position ``q`` (rad): Pinocchio's CRBA of the URDF with
    the armatures :data:`ARMATURE`, the truth of identify-arm's ``J``."""
    import pinocchio as pin

    model = arm.model.copy()
    model.armature = ARMATURE.copy()
    return np.diag(pin.crba(model, model.createData(), np.asarray(q, dtype=float))).copy()


def arm_hits(arm, seed: int, *, duration: float = 20.0, n_bootstrap: int = 200, rows: str = "moving",
             log=None, lag: bool = False, stop_refine: int = STOP_REFINE, refine_stops: bool | str = "auto",
             misses: list | None = None) -> dict:
    """``{parameter: [hits, count, unwarned]}`` of one arm (seed ``seed``), the base parameters under ``"base"``
    (``unwarned``: the misses whose joint has no warning naming the parameter); ``misses``: None, or a list to which
    a line per joint parameter whose interval misses its truth is appended (and per lagged joint whose lag is null);
    ``log``: its :func:`arm_log` if already simulated (default None: simulated here, its stops stepped ``stop_refine``
    times as finely); ``lag``: the joints' friction lagged (:func:`draw_lags`); ``refine_stops``: the lag fits' stops
    refined (``LagOptions(refine_stops=True)``)."""
    import re

    from adaptive_ff.arm.fit import identify_arm
    from adaptive_ff.arm.lag import LagOptions

    friction = arm_friction(arm.n, seed, lag)
    if log is None:
        log = arm_log(arm, seed, duration=duration, lag=lag, stop_refine=stop_refine)
    res = identify_arm(log, arm, seed=seed, n_bootstrap=n_bootstrap, rows=rows,
                       lag=LagOptions(workers=1, refine_stops=refine_stops) if lag else False)
    J = true_inertia(arm, log.q.mean(axis=0))
    out = {k: [0, 0, 0] for k in PARAMETERS + ("base",)}
    for j, (joint, f) in enumerate(zip(res.joints, friction)):
        truth = {"J": J[j], "Fc": f.Fc, "Fs": f.Fs, "sigma": f.sigma, "offset": f.offset, "Vs": f.Vs,
                 "tau": f.tau}
        for k in PARAMETERS:
            lo, hi = joint.interval95[k]
            if k == "tau" and f.tau == 0.0 and not (lo is not None and math.isfinite(lo)):
                continue  # a lag-free joint's lag null: right, and no interval
            if lo is None or hi is None or not (math.isfinite(lo) and math.isfinite(hi)):
                if k == "tau" and misses is not None:
                    misses.append(f"seed {seed} {joint.name}: tau {1e3 * f.tau:.2f} ms, null")
                continue  # Vs where no Stribeck term was kept
            inside = bool(lo <= truth[k] <= hi) and not (k == "tau" and f.tau == 0.0)  # a false lag: outside
            if not inside and misses is not None:
                s, unit = (1e3, " ms") if k == "tau" else (1.0, "")  # the lag in ms, as the null lags' lines
                misses.append(f"seed {seed} {joint.name}: {k} {s * truth[k]:.5g}{unit} outside [{s * lo:.5g}, "
                              f"{s * hi:.5g}] (estimate {s * joint.params[k]:.5g})")
            out[k][0] += inside
            out[k][1] += 1
            out[k][2] += not inside and not any(re.search(rf"\b{k}\b", str(w)) for w in joint.warnings)
    base = arm.base_parameters().of(true_theta(arm))
    lo, hi = res.base_interval.T
    inside = int(np.sum((lo <= base) & (base <= hi)))
    out["base"][0] += inside
    out["base"][1] += base.shape[0]
    out["base"][2] += base.shape[0] - inside
    return out


def _arm_hits(seed: int, **kwargs) -> tuple:
    """:func:`arm_hits` of arm ``seed`` on the URDF loaded in the calling process (a worker's), and its misses."""
    from adaptive_ff.arm.robot import load_urdf

    misses = []
    return arm_hits(load_urdf(URDF), seed, misses=misses, **kwargs), misses


def cpu_seconds() -> float:
    """CPU seconds (user and system) of this process and of its finished worker processes."""
    return sum(resource.getrusage(who).ru_utime + resource.getrusage(who).ru_stime
               for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))


def add_stops_arguments(ap) -> None:
    """Add ``--refine-stops`` and ``--coarse-stops`` (``args.refine_stops``: True, False or ``"auto"``, identify-arm's
    default) to the argparse parser ``ap``."""
    stops = ap.add_mutually_exclusive_group()
    stops.add_argument("--refine-stops", dest="refine_stops", action="store_const", const=True, default="auto",
                       help="every joint's lag fit with its stops refined (LagOptions(refine_stops=True), "
                            "identify-arm --refine-stops; default: identify-arm's, the joints that stick)")
    stops.add_argument("--coarse-stops", dest="refine_stops", action="store_const", const=False,
                       help="no joint's lag fit with its stops refined (identify-arm --coarse-stops)")


def stops_text(refine_stops) -> str:
    """The run's title words for its lag fits' ``refine_stops`` (True, False or ``"auto"``: identify-arm's default,
    none)."""
    return {True: ", lag fits with refined stops", False: ", lag fits with coarse stops"}.get(refine_stops, "")


def wilson(hits: int, n: int, z: float = 1.959963984540054) -> tuple:
    """The Wilson score interval of a binomial share ``hits/n`` (95 % by default)."""
    if n == 0:
        return math.nan, math.nan
    p = hits / n
    d = 1 + z * z / n
    c = (p + z * z / (2 * n)) / d
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return c - h, c + h


def main(argv=None) -> int:
    """Run the benchmark (module docstring) and print the coverage table."""
    from adaptive_ff.arm.fit import DEFAULT_ROWS, ROWS

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=50, help="number of arms (default 50)")
    ap.add_argument("--start", type=int, default=0, help="first seed (default 0)")
    ap.add_argument("--bootstrap", type=int, default=200, help="bootstrap refits per arm (default 200)")
    ap.add_argument("--duration", type=float, default=20.0, help="log length in s (default 20)")
    ap.add_argument("--rows", choices=ROWS, default=DEFAULT_ROWS,
                    help=f"identify_arm's rows (default {DEFAULT_ROWS}, its default)")
    ap.add_argument("--lag", action="store_true", help="each joint's friction lagged (none or 2-10 ms), the lags fitted")
    ap.add_argument("--workers", type=int, default=1, help="processes the arms run in (default 1)")
    ap.add_argument("--coarse-arms", dest="coarse_arms", action="store_true",
                    help="the arms' stops stepped once per period as the rest (default: ten times, "
                         "ArmSimulation.stop_refine, as a continuous arm's)")
    add_stops_arguments(ap)
    ap.add_argument("--misses", action="store_true",
                    help="list each joint parameter whose interval misses its truth, and each lagged joint whose "
                         "lag is null")
    args = ap.parse_args(argv)
    total = {k: [0, 0, 0] for k in PARAMETERS + ("base",)}
    c0 = cpu_seconds()
    job = partial(_arm_hits, duration=args.duration, n_bootstrap=args.bootstrap, rows=args.rows, lag=args.lag,
                  stop_refine=1 if args.coarse_arms else STOP_REFINE, refine_stops=args.refine_stops)
    seeds = range(args.start, args.start + args.n)
    if args.workers > 1:
        with ProcessPoolExecutor(max_workers=args.workers) as pool:
            results = list(pool.map(job, seeds))
    else:
        results = [job(seed) for seed in seeds]
    for hits, _ in results:
        for k, counts in hits.items():
            total[k] = [a + b for a, b in zip(total[k], counts)]
    cpu = cpu_seconds() - c0
    print(f"identify-arm 95 % intervals over {args.n} simulated arms (planar3, seeds {args.start}-"
          f"{args.start + args.n - 1}, {args.duration:g} s logs, {args.bootstrap} bootstrap refits, rows {args.rows}"
          f"{', lagged friction' if args.lag else ''}{', coarse arms' if args.coarse_arms else ''}"
          f"{stops_text(args.refine_stops) if args.lag else ''})")
    print(f"{'parameter':<10} {'inside':>8} {'of':>6} {'coverage':>9}   95 % (Wilson)    outside, no warning")
    for k, (h, c, u) in total.items():
        if c == 0:
            continue  # tau without --lag
        lo, hi = wilson(h, c)
        print(f"{k:<10} {h:>8} {c:>6} {h / c:>9.3f}   [{lo:.3f}, {hi:.3f}]   {u:>8}")
    print(f"CPU {cpu:.0f} s")
    if args.misses:
        for _, lines in results:
            for line in lines:
                print(f"  {line}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
