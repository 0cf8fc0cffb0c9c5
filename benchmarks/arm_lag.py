"""identify-arm's friction lag over seeded simulated arms: coverage of the true lags, false lags, missed lags.

Run:  python -m benchmarks.arm_lag [--n 20] [--start 0] [--lag-bootstrap 10] [--duration 20] [--cache FILE]
      [--workers 1] [--coarse-arms] [--refine-stops | --coarse-stops] [--friction example|coverage]

Each arm is ``examples/planar3.urdf`` with the armatures 0.2, 0.1, 0.05 kg·m², the friction of ``docs/your_arm.md``
(:data:`FRICTION`) with ``Fc, Fs, sigma`` scaled by a factor 0.8-1.25 per joint, or with ``--friction coverage``
the wider draws of :func:`benchmarks.arm_coverage.draw_friction` (a wrist with up to 2.5 N·m of Coulomb friction,
which sticks at most reversals), and a lag per joint drawn from its seed (:func:`draw_friction`: none with
probability :data:`benchmarks.arm_coverage.P_LAG_FREE`, else uniform in 2-10 ms), simulated for
``--duration`` s (:func:`adaptive_ff.arm.simulate.simulate_arm`, the default sensor noise, one Runge-Kutta step per
period and ten, :data:`adaptive_ff.arm.simulate.STOP_REFINE`, in each period in which a joint stops or reverses, as
a continuous arm's stops are; ``--coarse-arms``: one there too) and identified as ``adaptive-ff identify-arm``
identifies it (:func:`adaptive_ff.arm.fit.identify_arm`, bootstrap seed = the arm's, ``--lag-bootstrap`` refits of
each lag fit, 30 refits of the whole-arm bootstrap: the lag fits do not use its intervals).

Printed: over the lag-free joints the share reported with a lag (false lags); over the lagged joints the share
reported null and, of the reported ones, the share whose 95 % interval holds the true lag (coverage), each with its
95 % binomial (Wilson) interval; the reported intervals' median width over the true lag; and the coverage by joint.
``--cache FILE`` keeps each arm's joints (JSON lines, each with the run's settings) and reads back the arms it
already holds at the same settings (an arm at other settings runs again): it keeps the fits, and each joint is
decided again by :func:`adaptive_ff.arm.lag.lag_decision` (a cache made before a change of the lag fit itself is
stale). The lag fits refine the stops of the joints that stick (``identify-arm``'s
default); ``--refine-stops`` every joint's (``LagOptions(refine_stops=True)``, ``identify-arm --refine-stops``;
``docs/your_arm.md``, Not yet), ``--coarse-stops`` none. ``--workers N`` runs the arms in N processes. 50 arms
take 25-45 minutes of CPU; the numbers of seeds 0-49 (0-19 set the rule, 20-49 check it) are in
``docs/your_arm.md`` (How, Lag; Not yet).
"""

from __future__ import annotations

import argparse
import json
import math
from concurrent.futures import ProcessPoolExecutor
from functools import partial
from pathlib import Path

import numpy as np

from adaptive_ff.arm.simulate import STOP_REFINE
from benchmarks.arm_coverage import add_stops_arguments, cpu_seconds, lag_draws, stops_text, wilson

ROOT = Path(__file__).resolve().parents[1]
URDF = ROOT / "examples" / "planar3.urdf"


#: The planar arm's friction of ``docs/your_arm.md`` (shoulder, elbow, wrist): ``(Fc, Fs, Vs, delta, sigma, offset)``.
FRICTION = ((2.0, 2.6, 0.1, 1.0, 0.8, 0.1), (1.2, 1.5, 0.08, 1.0, 0.5, -0.05), (0.5, 0.7, 0.1, 1.0, 0.2, 0.0))


def draw_friction(n: int, seed: int, kind: str = "example") -> list:
    """The friction (:class:`adaptive_ff.arm.simulate.JointFriction`, with its lag) of the ``n`` joints of arm
    ``seed`` (module docstring), from ``default_rng([seed, 51])``; ``kind`` ``"example"`` or ``"coverage"``."""
    from dataclasses import replace

    from adaptive_ff.arm.simulate import JointFriction
    from benchmarks.arm_coverage import draw_friction as coverage_friction

    rng = np.random.default_rng([seed, 51])
    lags = lag_draws(rng, n)
    if kind == "coverage":
        return [replace(f, tau=lag) for f, lag in zip(coverage_friction(n, seed), lags)]
    out = []
    for (Fc, Fs, Vs, delta, sigma, offset), lag in zip(FRICTION, lags):
        k = float(np.exp(rng.uniform(np.log(0.8), np.log(1.25))))
        out.append(JointFriction(Fc=k * Fc, Fs=k * Fs, Vs=Vs, delta=delta, sigma=k * sigma, offset=offset, tau=lag))
    return out


def arm_joints(arm, seed: int, *, duration: float = 20.0, n_lag: int = 10, kind: str = "example",
               stop_refine: int = STOP_REFINE, refine_stops: bool | str = "auto") -> list:
    """One arm's joints: ``{"seed", "joint", "true", "tau", "lo", "hi", "reason", "info"}`` per joint (s);
    ``stop_refine``: the arm's steps per step in its stops (``ArmSimulation.stop_refine``; default a continuous
    arm's, 1: coarse), ``refine_stops``: the lag fits' stops refined (module docstring)."""
    from adaptive_ff.arm.fit import identify_arm
    from adaptive_ff.arm.lag import LagOptions
    from adaptive_ff.arm.simulate import ArmSimulation, simulate_arm
    from benchmarks.arm_coverage import ARMATURE

    friction = draw_friction(arm.n, seed, kind)
    lags = [f.tau for f in friction]
    run = ArmSimulation(duration=duration, substeps=1, stop_refine=stop_refine)
    log = simulate_arm(arm, friction, run=run, seed=seed, armature=ARMATURE)
    res = identify_arm(log, arm, n_bootstrap=30, seed=seed,
                       lag=LagOptions(n_bootstrap=n_lag, workers=1, refine_stops=refine_stops))
    out = []
    for j, joint in enumerate(res.joints):
        lo, hi = joint.interval95["tau"]
        reason = next((w.message for w in joint.warnings if w.parameter == "tau"), None)
        out.append({"seed": seed, "joint": joint.name, "true": lags[j], "tau": joint.params["tau"], "lo": lo,
                    "hi": hi, "reason": reason, "info": joint.lag_info})
    return out


def decided(row: dict) -> tuple:
    """``(tau, lo, hi)`` (s) that identify-arm reports for the joint, NaN where its lag is null: decided again from its
    fit (so that a cache holds fits, not decisions) by :func:`adaptive_ff.arm.lag.lag_decision`, as
    :func:`adaptive_ff.arm.lag.joint_lag` decides it."""
    from adaptive_ff.arm.lag import lag_decision

    tau, (lo, hi), _ = lag_decision(row["info"])
    return tau, lo, hi


def reported(row: dict) -> bool:
    """Whether identify-arm reports the joint's lag (:func:`decided`)."""
    return math.isfinite(decided(row)[0])


def summary(rows: list) -> dict:
    """``{"false", "missed", "covered"}``: each ``(k, n)`` over ``rows`` (module docstring); ``"width"``: the
    reported intervals' median width over the true lag (the lags and intervals :func:`decided`)."""
    free = [r for r in rows if r["true"] == 0.0]
    lagged = [(r, decided(r)) for r in rows if r["true"] > 0.0]
    reported_ = [(r, d) for r, d in lagged if math.isfinite(d[0])]
    width = [(hi - lo) / r["true"] for r, (_, lo, hi) in reported_]
    return {"false": (sum(map(reported, free)), len(free)),
            "missed": (len(lagged) - len(reported_), len(lagged)),
            "covered": (sum(lo <= r["true"] <= hi for r, (_, lo, hi) in reported_), len(reported_)),
            "width": float(np.median(width)) if width else math.nan}


def read_cache(path, settings: dict) -> dict:
    """``{seed: rows}`` of the cache file ``path`` (None or absent: empty), its arms run at ``settings`` only."""
    rows = {}
    if path is not None and Path(path).exists():
        for line in Path(path).read_text().splitlines():
            r = json.loads(line)
            if r.get("settings") == settings:
                rows.setdefault(r["seed"], []).append(r)
    return rows


def main(argv=None) -> int:
    """Run the arms and print the table (module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=20, help="arms (default 20)")
    ap.add_argument("--start", type=int, default=0, help="first seed (default 0)")
    ap.add_argument("--lag-bootstrap", type=int, default=10, help="refits of each lag fit's bootstrap (default 10)")
    ap.add_argument("--duration", type=float, default=20.0, help="log length in s (default 20)")
    ap.add_argument("--friction", choices=("example", "coverage"), default="example",
                    help="the joints' friction: the page's scaled (default) or arm_coverage's draws")
    ap.add_argument("--cache", default=None, help="JSON-lines file of the arms' joints, read and appended")
    ap.add_argument("--verbose", action="store_true", help="print every joint")
    ap.add_argument("--coarse-arms", dest="coarse_arms", action="store_true",
                    help="the arms' stops stepped once per period as the rest (default: ten times, "
                         "ArmSimulation.stop_refine, as a continuous arm's)")
    add_stops_arguments(ap)
    ap.add_argument("--workers", type=int, default=1, help="processes the arms run in (default 1; the result does "
                    "not depend on it)")
    a = ap.parse_args(argv)
    settings = {"duration": a.duration, "n_lag": a.lag_bootstrap, "kind": a.friction,
                "stop_refine": 1 if a.coarse_arms else STOP_REFINE, "refine_stops": a.refine_stops}
    cache = read_cache(a.cache, settings)
    seeds = range(a.start, a.start + a.n)
    todo = [seed for seed in seeds if seed not in cache]
    c0 = cpu_seconds()
    job = partial(_arm_rows, settings=settings)
    if a.workers > 1 and len(todo) > 1:
        with ProcessPoolExecutor(max_workers=a.workers) as pool:
            done = zip(todo, pool.map(job, todo))
            collect(done, cache, a.cache, settings)
    else:
        collect(((seed, job(seed)) for seed in todo), cache, a.cache, settings)
    rows = []
    for seed in seeds:
        rows += cache[seed]
        if a.verbose:
            for r in cache[seed]:
                tau, lo, hi = decided(r)
                print(f"seed {seed:3d} {r['joint']:9s} true {1e3 * r['true']:5.2f} ms  tau {1e3 * tau:6.2f} "
                      f"[{1e3 * lo:6.2f}, {1e3 * hi:6.2f}] ms  estimate "
                      f"{1e3 * r['info'].get('estimate', math.nan):6.2f} ms")
    s = summary(rows)
    print(f"{a.n} arms (seeds {a.start}-{a.start + a.n - 1}, friction {a.friction}), {a.duration:g} s logs, "
          f"{a.lag_bootstrap} refits per lag fit" + (", coarse arms" if a.coarse_arms else "")
          + stops_text(a.refine_stops)
          + f"; CPU {cpu_seconds() - c0:.0f} s")
    for key, text in (("false", "lag-free joints reported with a lag"), ("missed", "lagged joints reported null"),
                      ("covered", "reported lags whose interval holds the true lag")):
        k, n = s[key]
        lo, hi = wilson(k, n)
        print(f"  {text:50s} {k:3d} / {n:3d} = {k / n if n else math.nan:5.3f}  "
              f"[{max(lo, 0.0):.3f}, {min(hi, 1.0):.3f}]")
    print(f"  {'median width of the reported intervals / true lag':50s} {s['width']:.3f}")
    by_joint = []
    for name in dict.fromkeys(r["joint"] for r in rows):
        k, n = summary([r for r in rows if r["joint"] == name])["covered"]
        by_joint.append(f"{name} {k} / {n}")
    print(f"  {'reported lags inside, by joint':50s} {', '.join(by_joint)}")
    return 0


def _arm_rows(seed: int, *, settings: dict) -> list:
    """:func:`arm_joints` of arm ``seed`` at ``settings`` (:func:`main`'s; the URDF loaded in the calling process: a
    worker's)."""
    from adaptive_ff.arm.robot import load_urdf

    return arm_joints(load_urdf(URDF), seed, **settings)


def collect(done, cache: dict, path, settings: dict) -> None:
    """Put each ``(seed, rows)`` of ``done`` into ``cache`` and append it, each row with ``settings``, to the cache
    file ``path`` (None: none)."""
    for seed, rows in done:
        cache[seed] = rows
        if path is not None:
            with open(path, "a", encoding="utf-8") as fh:
                for r in rows:
                    fh.write(json.dumps({**r, "settings": settings}, default=float) + "\n")


if __name__ == "__main__":
    raise SystemExit(main())
