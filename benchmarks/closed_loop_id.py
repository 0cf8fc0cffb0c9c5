"""Closed-loop logs read out slower than the loop: method 'closed_loop' against the open-loop output error.

Run ``python benchmarks/closed_loop_id.py [--n 6] [--duration 60] [--start 0] [--oe]``. For ``n`` seeded
records of the paper's robot experiment as ``paper-figures --save-data`` makes it (the ``paper`` preset in a
PI velocity loop at 1 kHz, crossover 200 rad/s, tracking a 20 deg/s multi-sine; the PI sees velocity noise
1e-3 rad/s; read out at the irregular Fig. 10 stamps, 20-40 ms, with noise 1e-3 rad/s and a 0.6 N·m torque
quantum; the reference logged at the stamps) it fits
:func:`controllers.experiments.closed_loop_id.fit_closed_loop` (Vs, delta of the README's Stribeck pre-fit)
and, with ``--oe``, the open-loop ``fit_physical(method="output_error")`` on the same record. Prints one row
per record: relative error (%) of J, Fc, Fs, sigma, tau, whether the targets hold (J, tau within
10 %, Fc, Fs, sigma within 5 %), the error in reported standard errors of J and tau (the fit's default: the
bootstrap; ``--n-bootstrap 0``: HAC), and the fit time. Times depend on the machine's load; the errors do not.
"""

from __future__ import annotations

import argparse
import time

from adaptive_ff.identification.physical_id import fit_physical
from adaptive_ff.io.data import MeasuredData
from controllers.experiments.closed_loop_id import ClosedLoopIdOptions, ControllerSpec, fit_closed_loop
from controllers.experiments.synthetic_logs import closed_loop_readout
from plant import preset

P = preset("paper")
VS, DELTA = 0.0197756, 1.01582
NAMES = ("J", "Fc", "Fs", "sigma", "tau")


def record(seed: int, duration: float):
    """``(measurement, reference at the stamps, ControllerSpec)`` of one seeded robot experiment."""
    exp = closed_loop_readout(P, duration, seeds=seed)
    return exp.measurement, exp.w_ref, ControllerSpec(**exp.controller())


def _row(label: str, params: dict, stderr: dict | None, dt: float) -> str:
    err = {k: params[k] / getattr(P, k) - 1.0 for k in NAMES}
    ok = max(abs(err["J"]), abs(err["tau"])) < 0.1 and max(abs(err[k]) for k in ("Fc", "Fs", "sigma")) < 0.05
    z = "" if stderr is None else "  ".join(f"{(params[k] - getattr(P, k)) / stderr[k]:+7.1f}" for k in ("J", "tau"))
    return (f"{label:<16}" + "".join(f"{100 * err[k]:+8.2f}" for k in NAMES) + f"  {'yes' if ok else 'NO':<4}"
            + f"{z:<18}{dt:7.1f}")


def main() -> None:
    """Print the table (module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=6)
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--start", type=int, default=0)
    ap.add_argument("--oe", action="store_true", help="also the open-loop output-error fit")
    ap.add_argument("--n-bootstrap", type=int, default=None, help="bootstrap refits (default: the fit's, 10)")
    a = ap.parse_args()
    opts = ClosedLoopIdOptions() if a.n_bootstrap is None else ClosedLoopIdOptions(n_bootstrap=a.n_bootstrap)
    print(f"{'record':<16}" + "".join(f"{k + ' %':>8}" for k in NAMES) + "  targets  z(J)    z(tau)  time s")
    for seed in range(a.start, a.start + a.n):
        m, w_ref, spec = record(seed, a.duration)
        t0 = time.perf_counter()
        f = fit_closed_loop(MeasuredData(m.t, m.u, m.w), w_ref, controller=spec, Vs=VS, delta=DELTA, options=opts)
        print(_row(f"{seed} closed_loop", f.params, f.stderr, time.perf_counter() - t0), flush=True)
        if a.oe:
            t0 = time.perf_counter()
            g = fit_physical(m.t, m.u, m.w, Vs=VS, delta=DELTA, method="output_error", offset=False,
                             n_bootstrap=0 if a.n_bootstrap == 0 else 20)
            print(_row(f"{seed} output_error", g.params, g.stderr, time.perf_counter() - t0), flush=True)


if __name__ == "__main__":
    main()
