"""Stiff lagged plants: the zoo's formerly refused joints through ``compare``, and the
120 s run time of the stiffest corners of the zoo box.

Run:  python benchmarks/stiff.py [--ids 46,51,93,179,225,537,913,925,993] [--n 1000] [--seed 0]
                                 [--duration 120] [--modes none,fixed,adaptive,dob,...] [--no-corners]

Part 1 draws the zoo exactly as ``python benchmarks/zoo.py --n 1000 --seed 0`` does
(:func:`controllers.experiments.zoo.draw_plants` on the comparison reference of ``--duration`` s), takes the
joints listed by ``--ids`` (default: the nine that ``plant.dynamics.check_integrable`` refused as stiff on
main 8d8402c, docs/benchmarks/zoo.md) and runs :func:`controllers.experiments.compare.compare` on each (every
mode, the single-run engine, seed ``--seed``): eta per mode, diverged runs, wall time per joint.

Part 2 runs mode ``none`` for ``--duration`` s on the stiffest corners of the zoo box (J = 0.01 kg·m², Vs = 1e-3
rad/s, Fs/Fc = 4, delta = -0.05: a rising map whose steepest slope is ~1e17 times 1/dt, tau = 0 and 1e-3 s, each
lagged model) and prints the wall time of the run (after a short warm-up run).
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np


def _zoo_part(args) -> None:
    from controllers.experiments.compare import CompareOptions, compare, comparison_reference
    from controllers.experiments.zoo import draw_plants
    from plant.models import plant_from_dict

    co = CompareOptions.from_flat(duration=args.duration, seed=args.seed, modes=tuple(args.modes.split(",")))
    specs = draw_plants(args.n, comparison_reference(co), seed=args.seed)
    print(f"## zoo joints (n = {args.n}, seed {args.seed}), compare, {args.duration:g} s")
    for i in (int(s) for s in args.ids.split(",")):
        s = specs[i]
        p = plant_from_dict(s)
        t0 = time.perf_counter()
        try:
            c = compare(p, co, progress=False)
        except Exception as exc:  # noqa: BLE001 - a refusal is the result to report
            print(f"#{i} {s['model']}: REFUSED {type(exc).__name__}: {exc}")
            if "fixed" not in co.modes:
                continue
            print(f"#{i}: again without the mode fixed")
            try:
                c = compare(p, co, progress=False, modes=tuple(m for m in co.modes if m != "fixed"))
            except Exception as exc2:  # noqa: BLE001
                print(f"#{i} {s['model']}: REFUSED {type(exc2).__name__}: {exc2}")
                continue
        wall = time.perf_counter() - t0
        d = c.to_dict()["modes"]
        div = [m for m, v in d.items() if v.get("diverged")]
        etas = " ".join(f"{m} {v:.3f}" if v == v else f"{m} nan" for m, v in c.eta.items())
        rms = " ".join(f"{m} {v['rms']:.3g}" for m, v in d.items() if m in ("none", "frictionless"))
        print(f"#{i} {s['model']} tau={s.get('tau', 0.0):.3g} delta={s['delta']:.3f} Vs={s['Vs']:.3g} "
              f"J={s['J']:.3g} drift={'drift' in s}: eta {etas}; diverged {div or 'none'}; RMS error (rad/s) {rms}; {wall:.1f} s", flush=True)


def _corners(args) -> None:
    from controllers.design.pi import design_pi
    from controllers.simulation.closed_loop import LoopConfig, run_mode
    from plant.asymmetric import AsymmetricParams
    from plant.dynamics import PLANT_SLOTS, plant_params
    from plant.excitation import multisine_reference
    from plant.friction import JointParams
    from plant.karnopp import KarnoppParams

    ref = multisine_reference(args.duration, rng=np.random.default_rng(0))
    J, Fc, Vs, delta = 0.01, 0.05, 1e-3, -0.05
    plants = []
    for tau in (0.0, 1e-3):
        plants += [JointParams(J=J, Fc=Fc, Fs=4 * Fc, Vs=Vs, delta=delta, sigma=0.01, tau=tau),
                   AsymmetricParams(J=J, Fc_pos=Fc, Fc_neg=0.7 * Fc, Fs_pos=4 * Fc, Fs_neg=2.8 * Fc, Vs=Vs,
                                    delta=delta, sigma_pos=0.01, sigma_neg=0.007, tau=tau),
                   KarnoppParams(J=J, Fc=Fc, Fs=4 * Fc, Vs=Vs, delta=delta, sigma=0.01, tau=tau, dv=0.05 * Vs)]
    d = design_pi(J, crossover=20.0, phase_margin=60.0, Tc=1e-3)
    o = LoopConfig.from_flat(Kp=d.Kp, Ki=d.Ki, u_max=10.0, noise_std=1e-3)
    run_mode(plants[0], multisine_reference(1.0, rng=np.random.default_rng(0)), "none", o, rng=np.random.default_rng(0))  # warm-up
    print(f"\n## stiffest corners, mode none, {args.duration:g} s (wall, this machine)")
    for p in plants:
        rate = plant_params(p)[PLANT_SLOTS["rate"]] * 1e-3
        t0 = time.perf_counter()
        r = run_mode(p, ref, "none", o, rng=np.random.default_rng(0))
        wall = time.perf_counter() - t0
        ok = bool(np.all(np.isfinite(r.w))) and not r.info.get("diverged")
        print(f"{type(p).__name__:17s} tau={p.tau:<6g} rate*dt={rate:.2g}: {wall:.2f} s, rms {r.metrics.rms:.3g} "
              f"rad/s, finite and not diverged: {ok}", flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ids", default="46,51,93,179,225,537,913,925,993")
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--duration", type=float, default=120.0)
    ap.add_argument("--modes", default=None)
    ap.add_argument("--no-corners", action="store_true")
    ap.add_argument("--no-zoo", action="store_true")
    args = ap.parse_args(argv)
    if args.modes is None:
        from controllers.simulation.compensators import MODES

        args.modes = ",".join(MODES)
    print(f"# python benchmarks/stiff.py {' '.join(sys.argv[1:] if argv is None else argv)}".rstrip())
    print(f"# {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
    if not args.no_zoo:
        _zoo_part(args)
    if not args.no_corners:
        _corners(args)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
