"""Pre-fit benchmark: the designed quasi-static experiment on hard joints, and the
adaptive mode with a wrong design inertia.

Run:  python benchmarks/prefit.py [--duration 120] [--seed 0]

Table 1: per joint, what the Stribeck experiment designed from the joint's response (runs, held runs, the
stiffer loop) and the pre-fit against the truth (Vs, delta, Fs; or the Coulomb + viscous fallback).
Table 2: ``compare`` on the ``paper`` preset, modes adaptive and dob, with ``J_design`` 0.5x, 1x and 2x the true
J (the PI design, the estimator start, the gates and the DOB all use it): eta over the second half
(target: adaptive >= 0.9 at 0.5x and 2x).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from controllers.experiments.compare import compare
from controllers.experiments.quasi_static import StribeckDesign, stribeck_experiment
from plant.friction import JointParams, preset
from plant.lugre import LuGreParams
from plant.variant_plants import variant

JOINTS = {
    "paper": preset("paper"),
    "deep narrow dip (Fs = 5 Fc, Vs = 3 mrad/s)": JointParams(J=4.0, Fc=5.0, Fs=25.0, Vs=0.003, delta=1.0,
                                                              sigma=40.0, tau=0.02),
    "Coulomb + viscous (Fs = Fc)": JointParams(J=4.0, Fc=25.0, Fs=25.0, Vs=0.02, delta=1.0, sigma=40.0, tau=0.02),
    "stiff LuGre (sigma0 1e6, J 0.05)": LuGreParams(J=0.05, Fc=25.0, Fs=35.0, Vs=0.02, delta=2.0, sigma0=1e6,
                                                    sigma1=224.0, sigma2=40.0),
    "karnopp variant": variant("karnopp"),
    "negative-delta variant": variant("negative-delta"),
    "static variant (tau = 0)": variant("static"),
}


def experiments(seed: int) -> None:
    print(f"{'joint':<44}{'runs':>5}{'held':>5}{'stiff':>6}{'Vs fit/true':>13}{'delta fit/true':>16}"
          f"{'Fs fit/true':>13}  fallback   time [s]")
    for name, p in JOINTS.items():
        t0 = time.perf_counter()
        ex = stribeck_experiment(p, J_design=p.J, noise_std=1e-3, rng=np.random.default_rng(seed),
                                 options=StribeckDesign(w_max=0.6))
        dt = time.perf_counter() - t0
        f = ex.fit
        stiff = int(np.sum(ex.crossover > 1.5 * StribeckDesign().crossover))
        print(f"{name:<44}{ex.setpoints.size:>5}{int(ex.held.sum()):>5}{stiff:>6}{f.Vs / p.Vs:>13.3f}"
              f"{f.delta / p.delta:>16.3f}{f.Fs / p.Fs:>13.3f}  {str(f.fallback):<10}{dt:>8.1f}")


def j_design(duration: float, seed: int) -> None:
    p = preset("paper")
    print(f"\n{'J_design / J':<14}{'eta adaptive':>14}{'eta dob':>10}")
    for k in (0.5, 1.0, 2.0):
        c = compare(p, duration=duration, seed=seed, modes=("adaptive", "dob"), J_design=k * p.J, progress=False)
        print(f"{k:<14g}{c.eta['adaptive']:>14.3f}{c.eta['dob']:>10.3f}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=120.0)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    experiments(args.seed)
    j_design(args.duration, args.seed)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
