"""Point-to-point table: eta of the adaptive modes on rest-to-rest moves (a pick-and-place cycle).

Run:  python benchmarks/point_to_point.py [--plants paper,karnopp,...] [--seed 0]

For each plant (the ``paper`` preset and the variants of :mod:`plant.variant_plants`) and each motion profile
(speed limit v rad/s, acceleration limit a rad/s², optionally a jerk limit j rad/s³ on ``paper``), the reference is
:func:`plant.motion.point_to_point_reference` through the targets ``[0.5, -0.2, 0.4, 0.0, 0.6, -0.3]`` rad three
times with 0.5 s dwells (35 s with v 0.5, a 4); PI from :func:`controllers.design.pi.design_pi` for the plant's J
(20 rad/s, 60 deg), torque limit 150 N·m, noise 1e-3 rad/s, the plant's own Stribeck factors, seed 0 (the same
noise in every mode). Printed per plant, profile and mode: eta over the second half,
``(RMS_none - RMS_mode)/(RMS_none - RMS_frictionless)``, and the updates the robust feedforward refused as
implausible out of the estimator's updates. Results: docs/benchmarks/compensation.md.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from controllers.design.pi import design_pi
from controllers.simulation.closed_loop import LoopConfig, run_mode
from plant.friction import preset
from plant.motion import point_to_point_reference
from plant.variant_plants import variant

PLANTS = ("paper", "karnopp", "small-inertia", "lugre", "asymmetric")
#: (v_max, a_max, j_max) of the profiles; the jerk-limited one on ``paper`` only.
PROFILES = ((0.5, 4.0, None), (0.5, 1.0, None), (0.25, 2.0, None), (0.5, 4.0, 100.0))
MODES = ("adaptive", "adaptive-dob")
TARGETS = [0.5, -0.2, 0.4, 0.0, 0.6, -0.3] * 3


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plants", default=",".join(PLANTS), help="comma-separated: paper or variant names")
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    print("| plant | v, a, j | " + " | ".join(f"eta {m} | refused/updates {m}" for m in MODES) + " |")
    print("|---|---|" + "---:|---:|" * len(MODES))
    for name in a.plants.split(","):
        p = preset("paper") if name == "paper" else variant(name)
        d = design_pi(p.J, crossover=20.0, phase_margin=60.0, Tc=1e-3)
        o = LoopConfig.from_flat(Kp=d.Kp, Ki=d.Ki, u_max=150.0, Vs=p.Vs, delta=p.delta, noise_std=1e-3)
        for v, acc, j in PROFILES:
            if j is not None and name != "paper":
                continue
            ref = point_to_point_reference(TARGETS, v_max=v, a_max=acc, j_max=j, dwell=0.5)
            runs = {m: run_mode(p, ref, m, o, rng=np.random.default_rng(a.seed))
                    for m in ("none", "frictionless") + MODES}
            rn, rf = runs["none"].metrics.rms_second_half, runs["frictionless"].metrics.rms_second_half
            cells = []
            for m in MODES:
                r = runs[m]
                cells += [f"{(rn - r.metrics.rms_second_half) / (rn - rf):.2f}",
                          f"{r.info['n_implausible']}/{r.info['n_updates']}"]
            prof = f"{v:g}, {acc:g}" + (f", {j:g}" if j is not None else "")
            print(f"| {name} | {prof} | " + " | ".join(cells) + " |", flush=True)
    print(f"\nwall time {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
