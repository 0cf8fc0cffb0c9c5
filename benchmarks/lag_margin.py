"""What an error in the feedforward's lag costs, and how the adaptive mode uses its estimate.

Runs the ``compare`` setup of a preset (same reference, PI, noise and options per seed) and prints, per variant,
``rms_dev`` (RMS of ``w - w_frictionless`` over the whole run) as a multiple of the oracle's, over the seeds
(mean, median, max):

- ``true tau x k``: the fixed feedforward with the TRUE friction parameters (built here only, never in the
  package) and the lag scaled by ``k``: the cost of a lag that is too short against one that is too long;
- ``adaptive z=.. cap=.. rel=.. mem=..``: the ``adaptive`` mode with ``lag_margin`` z (the lag in use is the
  estimate plus z standard errors), ``lag_margin_max`` cap (at most that fraction of the estimate more),
  ``max_rel_stderr`` rel (``inf``: an estimate is used whether or not ``Fc`` is determined) and ``lag_memory`` mem
  (s; the lag estimates are weighted by their inverse variance over that memory; 0: the latest estimate).

    python benchmarks/lag_margin.py --seeds 20 --duration 120 --jobs 2 [--preset paper]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from adaptive_ff.identification.regression import FrictionEstimate
from controllers.experiments.compare import CompareOptions, prepare_comparison
from controllers.simulation.closed_loop import run_mode
from plant import preset

#: Lag factors of the true-parameter rows.
TAU_FACTORS = (0.97, 0.99, 1.0, 1.01, 1.03, 1.05, 1.1, 1.3)
#: (lag_margin, lag_margin_max, max_rel_stderr, lag_memory) of the adaptive rows; the first is the package's default,
#: the second the former default without ``lag_memory``, the fifth the former default without ``lag_margin``.
ADAPTIVE = ((1.0, 0.05, 0.05, 10.0), (1.0, 0.05, 0.05, 0.0), (1.0, 0.05, 0.05, 3.0), (1.0, 0.05, 0.05, 30.0),
            (0.0, 0.0, math.inf, 0.0), (0.0, 0.0, 0.05, 10.0))


def _rms(a, b) -> float:
    return float(np.sqrt(np.mean((a - b) ** 2)))


def _one(args) -> dict:
    name, seed, duration = args
    p = preset(name)
    s = prepare_comparison(p, CompareOptions.from_flat(duration=duration, seed=seed, modes=("adaptive", "fixed", "oracle"),
                                             noise_std=1e-3))
    s.bar.close()
    ref = s.reference

    def run(mode, mo):
        return run_mode(p, ref, mode, mo, rng=np.random.default_rng(s.noise_seed)).w

    wl = run("frictionless", s.mode_options["frictionless"])
    ro = _rms(run("oracle", s.mode_options["oracle"]), wl)
    out = {}
    for k in TAU_FACTORS:
        est = FrictionEstimate(J=p.J, tau=k * p.tau, sigma=p.sigma, Fc=p.Fc, Fs=p.Fs, offset=0.0, Vs=p.Vs,
                               delta=p.delta, J_alt=math.nan)
        out[f"true tau x {k:g}"] = _rms(run("fixed", s.mode_options["fixed"].replace(estimate=est)), wl) / ro
    for z, cap, rel, mem in ADAPTIVE:
        mo = s.mode_options["adaptive"].replace(lag_margin=z, lag_margin_max=cap, max_rel_stderr=rel, lag_memory=mem)
        out[f"adaptive z={z:g} cap={cap:g} rel={rel:g} mem={mem:g}"] = _rms(run("adaptive", mo), wl) / ro
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20, help="number of seeds (0..N-1), default 20")
    ap.add_argument("--duration", type=float, default=120.0, help="run length (s), default 120")
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="worker processes")
    ap.add_argument("--preset", default="paper", help="plant preset, default paper")
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    jobs = [(a.preset, seed, a.duration) for seed in range(a.seeds)]
    if a.jobs > 1:
        with ProcessPoolExecutor(a.jobs) as ex:
            rows = list(ex.map(_one, jobs))
    else:
        rows = [_one(j) for j in jobs]
    print(f"rms_dev / oracle's, {a.preset}, seeds 0-{a.seeds - 1}, {a.duration:g} s, noise 1e-3 rad/s")
    print()
    print("| variant | mean | median | max |")
    print("|---|---:|---:|---:|")
    for key in rows[0]:
        v = np.array([r[key] for r in rows])
        print(f"| {key} | {v.mean():.3f} | {np.median(v):.3f} | {v.max():.3f} |")
    print()
    print(f"wall {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
