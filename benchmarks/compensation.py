"""Compensation benchmark: targets, robustness matrix, feedforward design alternatives, closed-loop bias.

Run:  python benchmarks/compensation.py [--seeds 10] [--duration 120] [--jobs N] [--feedforward-alone]

Prints, as mean ± std over the seeds (metrics over the second half of each run;
velocities in deg/s, torques in N·m; eta = (RMS_none - RMS_mode) / (RMS_none - RMS_frictionless)):

1. the ``paper`` preset and the drift case (Fc, Fs +50 % over the first half) in every mode,
   including the two peers (Canudas de Wit et al. 1987, disturbance observer);
2. the matrix of plant variants (:mod:`plant.variant_plants`): eta per mode and diverged runs;
3. feedforward and estimator design alternatives side by side, the peers' tuning;
4. the closed-loop identification bias: the sliding-regime regression on the loop's own
   data with and without its gate, against the true parameters.

``--feedforward-alone`` prints part 3 only, for the alternatives of mode ``adaptive``, each run without the
residual switch-in (``switch_in=False``): the feedforward the alternative designs, with the supervisor, and no
observer carrying what it leaves.

"u noise" is ``std(diff(u))/sqrt(2)`` over the second half: the white part of the torque command.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed

import numpy as np
from tqdm.auto import tqdm

from adaptive_ff.compensation.sliding_estimator import SlidingFrictionEstimatorConfig, fit_sliding
from controllers.simulation.closed_loop import MODES
from controllers.experiments.compare import compare
from plant.friction import preset
from plant.variant_plants import VARIANT_NAMES, drift_case, variant

COLUMNS = ("rms", "max", "rms_reversal", "u_rms", "u_noise", "eta")
EST_KEYS = ("J", "tau", "Fc", "Fs", "sigma")

#: design alternatives: (scenario, label, compare options, mode)
ALTERNATIVES = [
    ("paper", "eq. 4 RLS at Ts = 10 ms, FF at w_ref (vertical slice)",
     dict(estimator="eq4-rls", ff_input="reference", stick_band=0.0), "adaptive"),
    ("paper", "eq. 4 RLS, FF at w_meas", dict(estimator="eq4-rls", stick_band=0.0), "adaptive"),
    ("paper", "sliding RLS, FF at w_ref", dict(ff_input="reference"), "adaptive"),
    ("paper", "sliding RLS, FF at w_meas, no lag filter", dict(lag=False), "adaptive"),
    ("paper", "sliding RLS, FF at w_meas, lag, sgn", dict(stick_band=0.0), "adaptive"),
    ("paper", "sliding RLS, FF at w_meas, lag, ramp sign 3 mrad/s", dict(stick_band=0.0, sign_width=3e-3),
     "adaptive"),
    ("paper", "sliding RLS, FF at w_meas, lag, stick detection (default)", dict(), "adaptive"),
    ("paper", "sliding RLS without the sliding-regime gate", dict(dwell_max=1.0), "adaptive"),
    ("paper", "sliding RLS, updates every 2 ms (lam 0.999)", dict(Ts=0.002, lam=0.999), "adaptive"),
    ("paper", "sliding RLS, updates every 5 ms (lam 0.9975)", dict(Ts=0.005, lam=0.9975), "adaptive"),
    ("paper", "sliding RLS, lam 0.999 (10 s memory)", dict(lam=0.999), "adaptive"),
    ("paper", "sliding RLS, directional forgetting", dict(forgetting="directional"), "adaptive"),
    ("paper", "fixed: eq. 4 LS offline, FF at w_ref (vertical slice)",
     dict(fixed_method="eq4", ff_input="reference", stick_band=0.0), "fixed"),
    ("paper", "fixed: sliding LS offline, FF at w_meas (default)", dict(), "fixed"),
    ("paper", "canudas, compensation at w_meas", dict(canudas_input="measured"), "canudas"),
    ("paper", "canudas, compensation at w_ref (default)", dict(), "canudas"),
    ("paper", "dob, omega_q = 300 rad/s", dict(omega_q=300.0), "dob"),
    ("paper", "dob, omega_q = 500 rad/s (default)", dict(), "dob"),
    ("paper", "dob, omega_q = 1000 rad/s", dict(omega_q=1000.0), "dob"),
    ("paper", "dob, omega_q = 2000 rad/s", dict(omega_q=2000.0), "dob"),
    ("drift", "sliding RLS, lam 0.995 (default)", dict(), "adaptive"),
    ("drift", "sliding RLS, lam 0.999 (10 s memory)", dict(lam=0.999), "adaptive"),
    ("drift", "sliding RLS, directional forgetting", dict(forgetting="directional"), "adaptive"),
    ("drift", "eq. 4 RLS, FF at w_ref (vertical slice)", dict(estimator="eq4-rls", ff_input="reference",
                                                             stick_band=0.0), "adaptive"),
]


def _plant(scenario: str, duration: float):
    if scenario == "paper":
        return preset("paper")
    if scenario == "drift":
        return drift_case(duration)
    return variant(scenario)


def _row(comp, mode: str) -> dict:
    r = comp.results[mode]
    m = r.metrics
    half = r.t >= 0.5 * r.t[-1]
    du = np.diff(r.u[half])
    return {"rms": np.rad2deg(m.rms_second_half), "max": np.rad2deg(m.max_second_half),
            "rms_reversal": np.rad2deg(m.rms_reversal), "u_rms": m.u_rms,
            "u_noise": float(np.std(du) / np.sqrt(2.0)), "eta": comp.eta[mode],
            "diverged": bool(r.info.get("diverged"))}


def main_task(scenario: str, seed: int, duration: float) -> dict:
    """All modes on one scenario and seed; for the preset also the closed-loop bias fits (part 4)."""
    comp = compare(_plant(scenario, duration), duration=duration, seed=seed, progress=False)
    out = {"rows": {mode: _row(comp, mode) for mode in comp.results}}
    est = comp.results["adaptive"].estimate
    out["adaptive_estimate"] = {k: getattr(est, k) for k in EST_KEYS} if est is not None else None
    if scenario == "paper":
        r = comp.results["none"]
        kw = dict(Tc=r.info["Tc"], Vs=comp.model.Vs, delta=comp.model.delta)
        gate = SlidingFrictionEstimatorConfig(Ts=0.01)
        no_gate = SlidingFrictionEstimatorConfig(Ts=0.01, dwell_max=1.0)
        fits = {"none run, all rows (no gate)": fit_sliding(r.u, r.w_meas, config=no_gate, **kw),
                "none run, sliding-regime gate": fit_sliding(r.u, r.w_meas, config=gate, **kw),
                "none run, noise-free w, no gate": fit_sliding(r.u, r.w, config=no_gate, **kw)}
        out["bias"] = {k: {p: getattr(f.estimate, p) for p in EST_KEYS} for k, f in fits.items()}
        out["bias"]["adaptive run, online, final"] = out["adaptive_estimate"]
    return out


def alt_task(index: int, seed: int, duration: float, alone: bool = False) -> dict:
    """One design alternative (index into ALTERNATIVES) on one seed; ``alone``: without the residual switch-in."""
    scenario, _, options, mode = ALTERNATIVES[index]
    if alone:
        options = {**options, "switch_in": False}
    comp = compare(_plant(scenario, duration), duration=duration, seed=seed, modes=(mode,), progress=False, **options)
    out = {"row": _row(comp, mode)}
    if index == ALTERNATIVES.index(next(a for a in ALTERNATIVES if a[1].startswith("sliding RLS without"))):
        est = comp.results["adaptive"].estimate
        out["estimate"] = {k: getattr(est, k) for k in EST_KEYS} if est is not None else None
    return out


def _fmt(vals, width=15, prec=3) -> str:
    a = np.asarray(vals, dtype=float)
    return f"{np.nanmean(a):>{width - 8}.{prec}f} ± {np.nanstd(a):<5.{prec}f}"


def _print_alternatives(results: dict, seeds, indices, title: str) -> None:
    print(title)
    head3 = f"{'scenario':<8} {'alternative':<58}{'eta':>15}{'u noise [N·m]':>15}{'RMS [deg/s]':>15}"
    print(head3)
    print("-" * len(head3))
    for i in indices:
        sc, label = ALTERNATIVES[i][:2]
        rows = [results[("alt", i, s)]["row"] for s in seeds]
        dv = sum(r["diverged"] for r in rows)
        print(f"{sc:<8} {label:<58}{_fmt([r['eta'] for r in rows])}{_fmt([r['u_noise'] for r in rows])}"
              f"{_fmt([r['rms'] for r in rows])}" + (f"  ({dv} diverged)" if dv else ""))
    print()


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--duration", type=float, default=120.0)
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--feedforward-alone", action="store_true",
                    help="part 3 only: the alternatives of mode adaptive without the residual switch-in")
    args = ap.parse_args(argv)
    seeds = range(args.seeds)
    alone = args.feedforward_alone
    alternatives = [i for i, a in enumerate(ALTERNATIVES) if not alone or a[3] == "adaptive"]
    scenarios = [] if alone else ["paper", "drift", *VARIANT_NAMES]
    tasks = [("main", sc, s) for sc in scenarios for s in seeds] + \
            [("alt", i, s) for i in alternatives for s in seeds]
    results = {}
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=args.jobs) as ex:
        futs = {}
        for kind, key, s in tasks:
            fut = (ex.submit(main_task, key, s, args.duration) if kind == "main"
                   else ex.submit(alt_task, key, s, args.duration, alone))
            futs[fut] = (kind, key, s)
        for f in tqdm(as_completed(futs), total=len(futs), desc="runs", disable=None):
            results[futs[f]] = f.result()
    wall = time.perf_counter() - t0
    print(f"{args.seeds} seeds x {args.duration:g} s, metrics over the second half, mean ± std; "
          f"{len(tasks)} comparisons in {wall:.0f} s on {args.jobs} processes\n")
    if alone:
        _print_alternatives(results, seeds, alternatives, "3. design alternatives of mode adaptive, the feedforward "
                            "alone (no residual switch-in; eta and u noise, mean ± std)")
        return 0

    head = f"{'mode':<13}" + "".join(f"{c:>15}" for c in ("RMS [deg/s]", "max [deg/s]", "reversal RMS",
                                                           "u RMS [N·m]", "u noise [N·m]", "eta"))
    for sc, title in (("paper", "1a. paper preset"), ("drift", "1b. drift: Fc, Fs +50 % over the first half")):
        print(title)
        print(head + "  diverged")
        print("-" * (len(head) + 10))
        for mode in MODES:
            rows = [results[("main", sc, s)]["rows"][mode] for s in seeds]
            cells = "".join(_fmt([r[c] for r in rows]) for c in COLUMNS)
            print(f"{mode:<13}{cells}  {sum(r['diverged'] for r in rows):>5}")
        ests = [results[("main", sc, s)]["adaptive_estimate"] for s in seeds]
        ests = [e for e in ests if e is not None]
        print("adaptive final estimate: " + ", ".join(f"{k} {_fmt([e[k] for e in ests], 12, 4).strip()}"
                                                     for k in EST_KEYS) + "\n")

    print("2. plant variants: eta per mode (mean ± std), runs diverged over all modes")
    vm = ("fixed", "adaptive", "canudas", "dob", "oracle")
    head2 = f"{'variant':<16}" + "".join(f"{m:>15}" for m in vm) + "  diverged"
    print(head2)
    print("-" * len(head2))
    for sc in ["paper", "drift", *VARIANT_NAMES]:
        rows = [results[("main", sc, s)]["rows"] for s in seeds]
        cells = "".join(_fmt([r[m]["eta"] for r in rows]) for m in vm)
        dv = sum(r[m]["diverged"] for r in rows for m in r)
        print(f"{sc:<16}{cells}  {dv:>5}")
    print()

    _print_alternatives(results, seeds, range(len(ALTERNATIVES)), "3. design alternatives (eta and u noise, mean ± std)")

    p = preset("paper")
    print("4. closed-loop identification bias on the paper preset (noise 1e-3 rad/s), estimates mean ± std")
    head4 = f"{'data, rows':<42}" + "".join(f"{k:>17}" for k in EST_KEYS)
    print(head4)
    print("-" * len(head4))
    print(f"{'true':<42}" + "".join(f"{getattr(p, k):>17.4g}" for k in EST_KEYS))
    labels = list(results[("main", "paper", 0)]["bias"])
    for lab in labels:
        ests = [results[("main", "paper", s)]["bias"][lab] for s in seeds]
        ests = [e for e in ests if e is not None]
        print(f"{lab:<42}" + "".join(_fmt([e[k] for e in ests], 17, 4) for k in EST_KEYS))
    i_ng = next(i for i, a in enumerate(ALTERNATIVES) if a[1].startswith("sliding RLS without"))
    ests = [results[("alt", i_ng, s)].get("estimate") for s in seeds]
    ests = [e for e in ests if e is not None]
    if ests:
        print(f"{'adaptive run without gate, online, final':<42}"
              + "".join(_fmt([e[k] for e in ests], 17, 4) for k in EST_KEYS))
    return 0


if __name__ == "__main__":
    sys.exit(main())
