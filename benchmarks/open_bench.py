"""The open bench's hard case: point-to-point moves, a 17-bit encoder, one period of delay, a torque limit.

Run:  python benchmarks/open_bench.py [--zoo 100] [--seed 0] [--workers 2] [--velocity difference|kalman]

Every plant of the project's variants (the ``paper`` preset, :data:`plant.variant_plants.VARIANT_NAMES`, the
drift case) and ``--zoo`` joints of the plant zoo (:func:`controllers.experiments.zoo.run_zoo`, drawn for this
reference) run ``compare`` on: the pick-and-place reference of ``benchmarks/point_to_point.py`` (targets
``[0.5, -0.2, 0.4, 0.0, 0.6, -0.3]`` rad three times, v 0.5 rad/s, a 4 rad/s², 0.5 s dwell; 35 s), a
2^17 counts/rev encoder (velocity by backward difference, or ``--velocity kalman``: the package's steady-state
Kalman filter on the counts at its default 100 Hz; no further noise), one period of measurement delay, and
the torque limit ``u_max`` of ``compare`` (three times the measured friction level plus the design inertia times
the peak acceleration; 150 N·m for the variants). Printed: eta of fixed, DOB, adaptive, adaptive-dob, the best
adaptive mode and its margin over the better of fixed and DOB; the zoo as quantiles, the joints where a mode is
worse than no compensation (eta < -0.02) and the joints where the best adaptive mode loses by more than 0.02.
Results: docs/benchmarks/scenarios.md ("The open bench").
"""

from __future__ import annotations

import argparse
import math
import subprocess
import time

import numpy as np

from controllers.experiments.compare import compare
from controllers.experiments.zoo import WORSE_THAN_NONE, ZooOptions, run_zoo
from plant.friction import preset
from plant.motion import point_to_point_reference
from plant.variant_plants import VARIANT_NAMES, drift_case, variant

TARGETS = [0.5, -0.2, 0.4, 0.0, 0.6, -0.3] * 3
MODES = ("none", "fixed", "adaptive", "adaptive-dob", "dob")
LOSS = 0.02
#: Degradation (rms_none/rms_frictionless - 1) from which friction matters to the loop.
MATERIAL = 0.2


def bench_reference():
    """The pick-and-place reference of the bench (35 s)."""
    return point_to_point_reference(TARGETS, v_max=0.5, a_max=4.0, dwell=0.5)


def _row(name: str, eta: dict) -> str:
    best = max(eta["adaptive"], eta["adaptive-dob"])
    rival = max(eta["fixed"], eta["dob"])
    flag = " **loses**" if best < rival - LOSS else ""
    cells = " | ".join(f"{eta[m]:.3f}" for m in ("fixed", "dob", "adaptive", "adaptive-dob"))
    return f"| {name} | {cells} | {best:.3f} | {best - rival:+.3f}{flag} |"


def variants_table(seed: int, velocity: str) -> None:
    ref = bench_reference()
    print("| plant | fixed | dob | adaptive | adaptive-dob | best adaptive | margin |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    plants = {"paper": preset("paper"), **{n: variant(n) for n in VARIANT_NAMES},
              "drift": drift_case(float(ref.t.shape[0]) * 1e-3)}
    for name, p in plants.items():
        c = compare(p, reference=ref, encoder_counts=2 ** 17, delay=1, noise_std=0.0, u_max=150.0, seed=seed,
                    modes=MODES, velocity=velocity, progress=False)
        eta = {m: (math.nan if c.eta[m] is None else c.eta[m]) for m in MODES}
        print(_row(name, eta), flush=True)


def zoo_table(n: int, seed: int, workers, velocity: str) -> None:
    o = ZooOptions.from_flat(n=n, seed=seed, modes=MODES, reference=bench_reference(), encoder_counts=2 ** 17, delay=1,
                             workers=workers, velocity=velocity)
    r = run_zoo(o)
    q = (0.05, 0.25, 0.5)
    best = np.fmax(r.eta["adaptive"], r.eta["adaptive-dob"])
    rival = np.fmax(r.eta["fixed"], r.eta["dob"])
    print(f"\nzoo: {n} joints, seed {seed}, {r.seconds:.0f} s; eta defined on {int(np.sum(np.isfinite(best)))}")
    print("| mode | q05 | q25 | median |")
    print("|---|---:|---:|---:|")
    for m, v in (*((m, r.eta[m]) for m in MODES[1:]), ("best adaptive", best)):
        qs = np.nanquantile(v, q) if np.any(np.isfinite(v)) else [math.nan] * 3
        print(f"| {m} | " + " | ".join(f"{x:.3f}" for x in qs) + " |")
    worse = r.worse_than_none()
    joints = {m: np.flatnonzero(np.isfinite(r.eta[m]) & (r.eta[m] < WORSE_THAN_NONE)).tolist() for m in MODES[1:]}
    print(f"\nworse than none (eta < {WORSE_THAN_NONE}): " + ", ".join(f"{m} {worse[m]}" for m in MODES[1:])
          + "; joints: " + "; ".join(f"{m} {joints[m]}" for m in MODES[1:] if worse[m]))
    deg = r.degradation()
    lose = np.flatnonzero(best < rival - LOSS)
    material = [i for i in lose if deg[i] >= MATERIAL]
    capped = np.flatnonzero(best < np.minimum(rival, 1.0) - LOSS)
    print(f"\nbest adaptive below min(max(fixed, dob), 1) - {LOSS} (short of the frictionless loop where a rival "
          f"reaches it): {capped.size} of {n} joints: {capped.tolist()}")
    print(f"best adaptive below max(fixed, dob) - {LOSS}: {lose.size} of {n} joints; {len(material)} of them "
          f"where friction raises the uncompensated RMS error by at least {MATERIAL:.0%} (of "
          f"{int(np.sum(deg >= MATERIAL))} such joints; elsewhere eta's denominator is within a few per cent "
          f"of the frictionless loop's own error and a difference of 0.02 is a fraction of a per cent of RMS)")
    for i in lose:
        spec = r.plants[i]
        kind = spec.get("model", "lagged-stribeck")
        print(f"  joint {i} ({kind}, J {spec.get('J', float('nan')):.3g}, friction +{deg[i]:.0%}): best adaptive "
              f"{best[i]:.3f}, fixed {r.eta['fixed'][i]:.3f}, dob {r.eta['dob'][i]:.3f}")
    refused = {k: v for k, v in r.refused.items()}
    if refused:
        print(f"refused: {len(refused)} joints, e.g. {next(iter(refused.items()))}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--zoo", type=int, default=100, help="zoo joints (0: the variants only)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--workers", type=int, default=None, help="zoo worker processes (default: cores)")
    ap.add_argument("--velocity", choices=("difference", "kalman"), default="difference",
                    help="the encoder's velocity (default: backward difference)")
    a = ap.parse_args(argv)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    print(f"# {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, commit {commit}, velocity {a.velocity}")
    t0 = time.perf_counter()
    variants_table(a.seed, a.velocity)
    if a.zoo > 0:
        zoo_table(a.zoo, a.seed, a.workers, a.velocity)
    print(f"\nwall time {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
