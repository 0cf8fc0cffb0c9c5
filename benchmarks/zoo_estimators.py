"""The zoo joint by joint: each estimator's adaptive modes against the default estimator's.

Run:  python benchmarks/zoo.py --n 1000 --duration 60 --workers 2 --modes none,adaptive,adaptive-dob \
          --estimator E --json E.json                      # once for each of sliding, eq4, eq4-rls
      python benchmarks/zoo_estimators.py sliding.json eq4.json eq4-rls.json [--gap 0.1] [--list 12]

Reads the strict-JSON results that ``benchmarks/zoo.py --json`` writes (the same joints, reference and seed in
each file, one estimator each; the first file is the reference, normally the default ``sliding``) and prints, per
file and adaptive mode, over the joints where eta is defined in both:

- ``below``: the joints where the mode is more than ``gap`` below ``min(eta of the reference, 1)``, the target of
  the eq. 4 estimator ("within 0.1 of the default on the zoo"; beyond the frictionless loop, eta > 1, the default's
  excess is not asked of the others), with the worst of them listed;
- ``below raw``: the same against the reference's eta itself;
- ``<none``: eta below ``controllers.experiments.zoo.WORSE_THAN_NONE`` (worse than no compensation, the zoo's own
  count);
- ``>= 0.8 where adaptive-dob >= 0.95``: plain ``adaptive`` where its composite succeeds.

``--quantiles`` prints instead one Markdown row per file and adaptive mode: the zoo's seed, the joints where eta is
defined, the estimator, eta's minimum, 5 %, 25 % and 50 % quantiles, the joints worse than none and (after the
reference) those more than ``gap`` below ``min(eta of the reference, 1)``.
"""

from __future__ import annotations

import argparse
import json
import math
import sys

import numpy as np

from controllers.experiments.zoo import WORSE_THAN_NONE


def _etas(path: str) -> tuple:
    """(estimator, {mode: list of eta or None}, number of joints) of one ``zoo.py --json`` file."""
    try:
        with open(path) as fh:
            d = json.load(fh)
    except (OSError, ValueError) as exc:
        raise SystemExit(f"zoo_estimators: {path}: cannot read a zoo result ({exc})") from None
    if "eta" not in d or "plants" not in d:
        raise SystemExit(f"zoo_estimators: {path}: not a benchmarks/zoo.py --json result (no 'eta' or 'plants')")
    return _estimator(d), d["eta"], len(d["plants"])


def _estimator(d: dict) -> str:
    """The estimator a ``zoo.py --json`` result ran: its comparison options' ``estimator``."""
    return ((d.get("options") or {}).get("compare") or {}).get("estimator", "?")


def _defined(*xs) -> bool:
    return all(x is not None and math.isfinite(x) for x in xs)


def compare_files(paths: list, *, gap: float = 0.1, n_list: int = 12) -> list:
    """The table's lines for the zoo results ``paths`` (the first the reference), module docstring."""
    ref_est, ref, n = _etas(paths[0])
    lines = [f"reference: {paths[0]} (estimator {ref_est}), {n} joints; gap {gap:g}",
             f"{'estimator':10s} {'mode':13s} {'joints':>6s} {'below':>6s} {'below raw':>9s} {'<none':>6s} "
             f"{'>=0.8 where adob>=0.95':>24s}  worst below (joint: eta / reference)"]
    for path in paths:
        est, eta, m = _etas(path)
        if m != n:
            raise SystemExit(f"zoo_estimators: {path}: {m} joints, the reference has {n}")
        for mode in ("adaptive", "adaptive-dob"):
            if mode not in eta or mode not in ref:
                continue
            idx = [i for i in range(n) if _defined(eta[mode][i], ref[mode][i])]
            below = sorted((eta[mode][i] - min(ref[mode][i], 1.0), i) for i in idx
                           if eta[mode][i] < min(ref[mode][i], 1.0) - gap)
            raw = sum(1 for i in idx if eta[mode][i] < ref[mode][i] - gap)
            worse = sum(1 for i in idx if eta[mode][i] < WORSE_THAN_NONE)
            hand = ""
            if mode == "adaptive" and "adaptive-dob" in eta:
                ok = [i for i in range(n) if _defined(eta["adaptive"][i], eta["adaptive-dob"][i])
                      and eta["adaptive-dob"][i] >= 0.95]
                hand = f"{sum(1 for i in ok if eta['adaptive'][i] >= 0.8)} of {len(ok)}"
            worst = ", ".join(f"#{i}: {eta[mode][i]:.3f} / {ref[mode][i]:.3f}" for _, i in below[:n_list])
            lines.append(f"{est:10s} {mode:13s} {len(idx):6d} {len(below):6d} {raw:9d} {worse:6d} {hand:>24s}  "
                         f"{worst or '-'}")
    return lines


def quantile_rows(paths: list, *, gap: float = 0.1) -> list:
    """Markdown rows (``--quantiles``, module docstring) for the zoo results ``paths``, the first the reference."""
    _, ref, n = _etas(paths[0])
    lines = ["| zoo | estimator | mode | min | q05 | q25 | median | worse than none | more than "
             f"{gap:g} below the reference |", "|---|---|---|---|---|---|---|---|---|"]
    for k, path in enumerate(paths):
        with open(path) as fh:
            seed = json.load(fh)["options"]["compare"]["seed"]
        est, eta, m = _etas(path)
        if m != n:
            raise SystemExit(f"zoo_estimators: {path}: {m} joints, the reference has {n}")
        for mode in ("adaptive", "adaptive-dob"):
            if mode not in eta:
                continue
            vals = np.array([x for x in eta[mode] if _defined(x)])
            q = np.quantile(vals, [0.05, 0.25, 0.5])
            worse = int(np.sum(vals < WORSE_THAN_NONE))
            below = "" if k == 0 else str(sum(1 for i in range(n) if _defined(eta[mode][i], ref[mode][i])
                                              and eta[mode][i] < min(ref[mode][i], 1.0) - gap))
            lines.append(f"| seed {seed}, {vals.size} joints | {est} | {mode} | {vals.min():.3f} | {q[0]:.3f} | "
                         f"{q[1]:.3f} | {q[2]:.3f} | {worse} | {below} |")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", nargs="+", help="benchmarks/zoo.py --json results, the reference (default estimator) first")
    ap.add_argument("--gap", type=float, default=0.1, help="how far below min(reference, 1) counts (default 0.1)")
    ap.add_argument("--list", type=int, default=12, help="how many of the joints below to name (default 12)")
    ap.add_argument("--quantiles", action="store_true", help="Markdown rows of eta's quantiles per file and mode")
    args = ap.parse_args(argv)
    if args.quantiles:
        print("\n".join(quantile_rows(args.files, gap=args.gap)))
        return 0
    print(f"# {' '.join(['python benchmarks/zoo_estimators.py', *(argv if argv is not None else sys.argv[1:])])}")
    print("\n".join(compare_files(args.files, gap=args.gap, n_list=args.list)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
