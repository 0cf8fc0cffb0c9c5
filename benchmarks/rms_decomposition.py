"""Where does adaptive's rms_dev excess over the oracle come from on ``paper``? (A script, not a test.)

Runs the ``compare`` setup of the ``paper`` preset (same reference, PI, noise and options) and prints, per variant,
``rms_dev`` (RMS of ``w - w_frictionless`` over the whole run, rad/s), its ratio to the oracle's, and the share of
``rms_dev**2`` that falls within +-50 ms of the reference's reversals, in the first 5 s and elsewhere.

Variants: the package modes (adaptive, fixed, oracle; the defaults) and the fixed feedforward with the TRUE friction
parameters (built here only, never in the package) evaluated at (a) ``true@meas``: the noisy measured velocity as the
package does it (defaults: stick detection with the loop model, the sign observer's sign inside the stick band),
(b) the loop model's velocity (``stick_band`` infinite), (c) rows marked ``(py)`` and below: a Python loop of the
package's kernels without the sign observer (it reproduced the engine for (a) with ``sign_input="measured"`` and 5
stick samples, the defaults before): at the measurement, at the true velocity, with other holds of the lag
filter, and with the sign and the magnitude taken from the true and the measured velocity crosswise.

    python benchmarks/rms_decomposition.py --seeds 0 1 --duration 120 [--noise 1e-3]
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import replace

import numpy as np

from adaptive_ff.compensation.feedforward import (FrictionFeedforward, FrictionFeedforwardConfig, ff_compensate,
                                                  ff_static)
from adaptive_ff.compensation.velocity_input import LoopModel
from adaptive_ff.compensation.gate import gate_check
from adaptive_ff.identification.regression import FrictionEstimate
from controllers.design.pi import PIController, pi_step
from controllers.experiments.compare import CompareOptions, prepare_comparison
from controllers.simulation.closed_loop import _sensor_gate, MeasurementSettings, run_closed_loop, run_mode  # noqa: PLC2701 (script)
from plant import preset
from plant.dynamics import plant_step
from plant.rows import plant_params, plant_state


def true_estimate(p) -> FrictionEstimate:
    return FrictionEstimate(J=p.J, tau=p.tau, sigma=p.sigma, Fc=p.Fc, Fs=p.Fs, offset=0.0, Vs=p.Vs, delta=p.delta,
                            J_alt=float("nan"))


def python_loop(p, ref, mo, ff: FrictionFeedforward, noise, *, ff_at_true: bool = False, pick=None, hold="post"):
    """The engine's period (sense, gate, compensate, PI, plant step) in Python with the package kernels.

    ``pick(w, wc)``: the velocity the static map is evaluated at (with ``hold`` other than "post" the lag filter is
    run here: "avg" holds the step average of the lag state, "pre" the state before the update)."""
    alpha = 1.0 - math.exp(-mo.Tc / p.tau)
    beta = 1.0 - p.tau / mo.Tc * (1.0 - math.exp(-mo.Tc / p.tau))
    y = 0.0
    ctrl = PIController(Kp=mo.Kp, Ki=mo.Ki, Tc=mo.Tc, u_max=mo.u_max)
    gate = _sensor_gate(True, ctrl, mo.J_design)
    par = plant_params(p)
    ps = plant_state(p, float(ref.w[0]))
    n = ref.w.shape[0]
    W = np.empty(n)
    held = float(ref.w[0])
    for k in range(n):
        w = ps[0]
        wm = w + noise[k]
        if gate_check(gate.params, gate.state, wm):
            held = wm
        wc = held
        wr = float(ref.w[k])
        x = w if ff_at_true else wc
        if pick is None and hold == "post":
            uff = ff_compensate(ff.params, ff.state, x, x, wr)
        else:
            x = x if pick is None else pick(w, wc)
            fx = ff_static(ff.params, ff.state, x)
            if hold == "post":
                y += alpha * (fx - y)
                uff = y
            elif hold == "avg":
                uff = y + beta * (fx - y)
                y += alpha * (fx - y)
            else:
                uff = y
                y += alpha * (fx - y)
        u = pi_step(ctrl.params, ctrl.state, wr - wc, uff)
        if pick is not None and hasattr(pick, "post"):
            pick.post(u, uff, wc)
        W[k] = w
        plant_step(par, ps, u, mo.Tc)
    return W


def shares(t, dev, revs, tw=0.05, t0=5.0):
    """rms_dev and the shares of its square near reversals (+-tw), in the first t0 s, and elsewhere."""
    d2 = dev ** 2
    idx = np.searchsorted(revs, t)
    lo = np.abs(t - revs[np.clip(idx - 1, 0, len(revs) - 1)])
    hi = np.abs(revs[np.clip(idx, 0, len(revs) - 1)] - t)
    near = (np.minimum(lo, hi) <= tw) & (t >= t0)
    start = t < t0
    tot = d2.sum()
    return math.sqrt(d2.mean()), d2[near].sum() / tot, d2[start].sum() / tot, d2[~near & ~start].sum() / tot


def run_seed(seed, duration, noise_std):
    p = preset("paper")
    o = CompareOptions(duration=duration, seed=seed, modes=("adaptive", "fixed", "oracle"), noise_std=noise_std)
    s = prepare_comparison(p, o)
    s.bar.close()
    ref = s.reference
    rng = lambda: np.random.default_rng(s.noise_seed)  # noqa: E731
    runs = {m: run_mode(p, ref, m, s.mode_options[m], rng=rng()) for m in ("frictionless", "oracle", "fixed",
                                                                            "adaptive")}
    mo = s.mode_options["fixed"]
    true = true_estimate(p)
    runs["true@meas"] = run_mode(p, ref, "fixed", replace(mo, estimate=true), rng=rng())
    runs["true@model"] = run_mode(p, ref, "fixed", replace(mo, estimate=true, stick_band=1e9, stick_samples=1),
                                  rng=rng())
    lm0 = LoopModel(Kp=mo.Kp, Ki=mo.Ki, J=mo.J_design, track=0.0)
    ff = FrictionFeedforward(true, dt=mo.Tc, config=FrictionFeedforwardConfig(ff_max=mo.ff_max, stick_band=1e9,
                                                                              stick_samples=1), loop_model=lm0)
    gate = _sensor_gate(True, PIController(Kp=mo.Kp, Ki=mo.Ki, Tc=mo.Tc, u_max=mo.u_max), mo.J_design)
    runs["true@model0"] = run_closed_loop(
        p, PIController(Kp=mo.Kp, Ki=mo.Ki, Tc=mo.Tc, u_max=mo.u_max), ff, ref,
        measurement=MeasurementSettings(noise_std=noise_std, rng=rng(), sensor_gate=gate))
    noise = rng().normal(0.0, noise_std, size=ref.w.shape[0]) if noise_std > 0 else np.zeros(ref.w.shape[0])
    mk = lambda band: FrictionFeedforward(true, dt=mo.Tc, config=FrictionFeedforwardConfig(  # noqa: E731
        ff_max=mo.ff_max, stick_band=band, stick_samples=mo.stick_samples),
        loop_model=LoopModel(Kp=mo.Kp, Ki=mo.Ki, J=mo.J_design))
    w_py = python_loop(p, ref, mo, mk(mo.stick_band), noise, ff_at_true=False)
    w_true = python_loop(p, ref, mo, mk(0.0), noise, ff_at_true=True)
    extra = {
        "true@true avg": dict(ff_at_true=True, hold="avg"),
        "true@true pre": dict(ff_at_true=True, hold="pre"),
        "true@meas avg": dict(hold="avg"),
        "sign true,|meas|": dict(pick=lambda w, wc: math.copysign(abs(wc), w) if w != 0 else 0.0),
        "sign meas,|true|": dict(pick=lambda w, wc: math.copysign(abs(w), wc)),
    }
    xw = {k: python_loop(p, ref, mo, mk(0.0), noise, **kw) for k, kw in extra.items()}
    w_lim = runs["frictionless"].w
    revs = ref.reversals()
    t = ref.t
    out = {}
    for name, r in runs.items():
        if name != "frictionless":
            out[name] = shares(t, r.w - w_lim, revs)
    out["true@meas(py)"] = shares(t, w_py - w_lim, revs)
    out["true@true(py)"] = shares(t, w_true - w_lim, revs)
    for k, v in xw.items():
        out[k] = shares(t, v - w_lim, revs)
    est = runs["adaptive"].estimate
    return out, est


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0])
    ap.add_argument("--duration", type=float, default=120.0)
    ap.add_argument("--noise", type=float, default=1e-3)
    a = ap.parse_args(argv)
    for seed in a.seeds:
        t0 = time.process_time()
        out, est = run_seed(seed, a.duration, a.noise)
        ro = out["oracle"][0]
        print(f"\nseed {seed}, {a.duration:g} s, noise {a.noise:g} rad/s  (CPU {time.process_time() - t0:.0f} s)")
        print(f"{'variant':<15}{'rms_dev':>11}{'/oracle':>9}{'rev+-50ms':>11}{'t<5s':>8}{'rest':>8}")
        for name, (r, near, st, rest) in out.items():
            print(f"{name:<15}{r:>11.3e}{r / ro:>9.3f}{near:>11.2f}{st:>8.2f}{rest:>8.2f}")
        if est is not None:
            print("adaptive final estimate: " + ", ".join(f"{k} {getattr(est, k):.4g}"
                                                          for k in ("J", "tau", "sigma", "Fc", "Fs")))


if __name__ == "__main__":
    main()
