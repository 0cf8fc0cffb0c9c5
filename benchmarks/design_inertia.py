"""The design inertia ``compare`` identifies when none is given, against the joint's true inertia.

Run:  python benchmarks/design_inertia.py [--zoo 100] [--seed 0]

Without ``J_design`` (``--J-design``, ``--from``) ``compare`` identifies the design inertia before any loop
(:func:`controllers.experiments.first_inertia.inertia_experiment`, through
:func:`controllers.experiments.compare.prepare_comparison`). This prints, for the plant variants
(the ``paper`` preset and :mod:`plant.variant_plants`) and ``--zoo`` joints of the zoo (:func:`controllers.experiments.zoo.draw_plants`,
drawn with ``--seed``), the identified inertia's relative error ``J_design / J - 1`` at the comparison's default
velocity noise (1e-3 rad/s) and seed ``--seed``.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from controllers.experiments.compare import CompareOptions, comparison_reference, prepare_comparison
from controllers.experiments.zoo import draw_plants
from plant.friction import preset
from plant.models import plant_from_dict
from plant.variant_plants import VARIANT_NAMES, variant


def inertia_error(p, o: CompareOptions, ref) -> float:
    """``J_design / J - 1`` of the design inertia ``compare`` identifies on plant ``p`` (options ``o``)."""
    s = prepare_comparison(p, o, reference=ref)
    s.bar.close()
    return float(s.J_design) / float(p.at(0.0).J if hasattr(p, "at") else p.J) - 1.0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--zoo", type=int, default=100, help="zoo joints (default 100)")
    ap.add_argument("--seed", type=int, default=0, help="the comparison's seed and the zoo's draw (default 0)")
    args = ap.parse_args(argv)
    o = CompareOptions(seed=args.seed, modes=("none",))
    ref = comparison_reference(o)
    t0 = time.process_time()
    print(f"design inertia identified / true - 1, seed {args.seed}, velocity noise 1e-3 rad/s")
    print(f"{'joint':<16}{'J true [kg·m²]':>16}{'J_design / J - 1':>18}")
    print("-" * 50)
    for name in ("paper", *VARIANT_NAMES):
        p = preset("paper") if name == "paper" else variant(name)
        p0 = p.at(0.0) if hasattr(p, "at") else p
        print(f"{name:<16}{p0.J:>16.4g}{100 * inertia_error(p, o, ref):>17.2f}%")
    errs = np.array([inertia_error(plant_from_dict(spec), o, ref)
                     for spec in draw_plants(args.zoo, ref, seed=args.seed)])
    print(f"{args.zoo} zoo joints (seed {args.seed}): median {100 * np.median(errs):.2f} %, "
          f"largest |error| {100 * np.max(np.abs(errs)):.2f} %, 5-95 % [{100 * np.quantile(errs, 0.05):.2f}, "
          f"{100 * np.quantile(errs, 0.95):.2f}] %")
    print(f"CPU {time.process_time() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
