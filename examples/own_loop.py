"""Deploy the adaptive friction feedforward in your own 1 kHz velocity loop (docs/your_loop.md).

Your loop, not the package's: every period you measure the velocity ``w``, ask the feedforward object for its
torque with ``step(w, w_ref)``, add it to your own controller's output, apply the torque ``u`` and then hand the
pair ``(u, w)`` to ``observe(u, w)``. Nothing else of the package runs in the loop. The object learns ``Fc``,
``Fs``, ``sigma`` and the lag ``tau`` from the sliding motion (sliding-regime inverse-dynamics RLS), switches
itself on once its estimate is plausible, fades in, and refuses bad samples (NaN, inf, spikes: counted, state
unchanged).

Without hardware at hand this script stands in for your drive with the package's plant model (the ``paper``
preset: J 4 kg·m², Fc 25, Fs 35 N·m, sigma 40 N·m·s/rad, tau 20 ms), a velocity sensor with 1e-3 rad/s noise and
a hand-written PI, so that the tracking with and without the feedforward can be compared. ``--log FILE.csv``
(columns t, u, w at the loop rate) replays a measured log through ``observe`` instead and prints what the
object learned from it.

    python examples/own_loop.py                       # 60 s simulated drive, PI alone vs PI + feedforward
    python examples/own_loop.py --duration 20 --faults
    python examples/own_loop.py --log my_drive.csv --Vs 0.02 --delta 1
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from adaptive_ff.compensation.adaptive_feedforward import RobustAdaptiveFeedforward, RobustAdaptiveFeedforwardConfig
from adaptive_ff.compensation.feedforward import FrictionFeedforwardConfig
from adaptive_ff.compensation.gate import OutlierGate
from adaptive_ff.compensation.sliding_estimator import SlidingFrictionEstimator, SlidingFrictionEstimatorConfig

TC = 1e-3  # your loop's period (s): 1 kHz


def make_feedforward(*, Vs: float, delta: float, J_guess: float, u_max: float) -> RobustAdaptiveFeedforward:
    """The object you keep in your loop. What you know about your drive goes in; nothing about the friction.

    ``Vs``, ``delta``: the Stribeck velocity and shape from a quasi-static test (``adaptive-ff stribeck``).
    ``J_guess``: the data-sheet inertia (only the start of the estimate and the velocity gate).
    ``u_max``: your drive's torque limit, which bounds the feedforward and the torque samples.
    """
    from adaptive_ff.compensation.gate import RangeGate

    gate = OutlierGate(max_step=2.0 * u_max * TC / J_guess)  # a velocity cannot jump faster than u_max allows
    est = SlidingFrictionEstimator(Vs, delta, Tc=TC, config=SlidingFrictionEstimatorConfig(initial_J=J_guess),
                                   gate=gate, u_range=RangeGate(x_max=u_max))
    return RobustAdaptiveFeedforward(est, dt=TC, config=RobustAdaptiveFeedforwardConfig(
        ff=FrictionFeedforwardConfig(ff_max=0.5 * u_max, stick_band=3e-3, stick_samples=5)))


class PI:
    """Your own velocity controller (here a plain discrete PI with anti-windup clamping)."""

    def __init__(self, Kp: float, Ki: float, u_max: float):
        self.Kp, self.KiTc, self.u_max, self.i = Kp, Ki * TC, u_max, 0.0

    def __call__(self, e: float, u_ff: float) -> float:
        u = self.Kp * e + self.i + u_ff
        if -self.u_max < u < self.u_max:
            self.i += self.KiTc * e
            return u
        return math.copysign(self.u_max, u)


def run_drive(duration: float, *, with_ff: bool, faults: bool, seed: int = 1) -> dict:
    """Your 1 kHz loop on a simulated drive; returns the tracking record and the feedforward object."""
    from plant import multisine_reference, preset
    from plant.dynamics import make_plant_step

    p = preset("paper")
    drive = make_plant_step(p, TC)  # stands in for your amplifier + joint
    ref = multisine_reference(duration, rng=np.random.default_rng(seed))
    rng = np.random.default_rng(seed + 1)
    u_max = 150.0
    from controllers.design.pi import design_pi

    d = design_pi(4.0, crossover=20.0, phase_margin=60.0, Tc=TC)  # your gains (here: 20 rad/s crossover)
    pi = PI(Kp=d.Kp, Ki=d.Ki, u_max=u_max)
    ff = make_feedforward(Vs=p.Vs, delta=p.delta, J_guess=4.0, u_max=u_max) if with_ff else None
    w_true, s = float(ref.w[0]), p.initial_state(float(ref.w[0]))
    n = ref.t.size
    err = np.empty(n)
    t_ff = 0.0
    for k in range(n):
        w = w_true + rng.normal(0.0, 1e-3)  # what your sensor reads
        if faults and k % 2500 == 1234:
            w = (math.nan, math.inf, 1e308, 5.0)[(k // 2500) % 4]  # a dropped frame, a glitch, a spike
        w_ref = float(ref.w[k])
        t0 = time.perf_counter()
        u_ff = ff.step(w, w_ref) if ff is not None else 0.0  # 1. the feedforward for this period
        t_ff += time.perf_counter() - t0 if k > 0 else 0.0  # (the first call, cold caches: not timed)
        w_ctrl = w if math.isfinite(w) and abs(w) < 10.0 else w_ref  # your own sensor check, for your controller
        u = pi(w_ref - w_ctrl, u_ff)  # 2. your controller, plus the feedforward
        w_true, s = drive(w_true, s, u)  # 3. apply u for one period
        t0 = time.perf_counter()
        if ff is not None:
            ff.observe(u, w)  # 4. tell the object what was applied and measured
        t_ff += time.perf_counter() - t0 if k > 0 else 0.0
        err[k] = w_ref - w_true
    half = n // 2
    return {"rms": float(np.sqrt(np.mean(err[half:] ** 2))), "ff": ff, "us_per_period": t_ff / (n - 1) * 1e6}


def replay_log(path: str, *, Vs: float, delta: float, J_guess: float, u_max: float) -> RobustAdaptiveFeedforward:
    """Feed a measured log (CSV with columns t, u, w at the loop rate) through ``observe``."""
    from adaptive_ff.io.data import load_csv

    m = load_csv(path)
    ff = make_feedforward(Vs=Vs, delta=delta, J_guess=J_guess, u_max=u_max)
    for u, w in zip(np.asarray(m.u).tolist(), np.asarray(m.w).tolist()):
        ff.observe(u, w)
    return ff


def report(ff: RobustAdaptiveFeedforward) -> str:
    e = ff.estimate if ff.active else ff.estimator.estimate
    state = "in use" if ff.active else "not yet in use (still warming up or implausible)"
    return (f"estimate {state}: J {e.J:.3g} kg·m², tau {e.tau * 1e3:.3g} ms, Fc {e.Fc:.4g} N·m, Fs {e.Fs:.4g} N·m, "
            f"sigma {e.sigma:.4g} N·m·s/rad\n"
            f"samples rejected {ff.n_rejected}, RLS updates {ff.estimator.n_updates}, "
            f"step() inputs rejected {ff.n_step_rejected}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=60.0, help="simulated seconds (default 60)")
    ap.add_argument("--faults", action="store_true", help="inject NaN, inf, 1e308 and spikes into the sensor")
    ap.add_argument("--log", default=None, help="replay a measured CSV (t, u, w) instead of simulating")
    ap.add_argument("--Vs", type=float, default=0.02, help="Stribeck velocity in rad/s (with --log)")
    ap.add_argument("--delta", type=float, default=1.0, help="Stribeck shape factor (with --log)")
    ap.add_argument("--J", type=float, default=4.0, help="data-sheet inertia in kg·m² (with --log)")
    ap.add_argument("--u-max", type=float, default=150.0, help="torque limit in N·m (with --log)")
    a = ap.parse_args(argv)
    if a.log:
        print(report(replay_log(a.log, Vs=a.Vs, delta=a.delta, J_guess=a.J, u_max=a.u_max)))
        return 0
    base = run_drive(a.duration, with_ff=False, faults=a.faults)
    comp = run_drive(a.duration, with_ff=True, faults=a.faults)
    print(f"RMS tracking error, second half: PI alone {base['rms']:.4g} rad/s, "
          f"PI + adaptive feedforward {comp['rms']:.4g} rad/s ({comp['rms'] / base['rms']:.2f}x)")
    print(report(comp["ff"]))
    print(f"cost of step() + observe() in this Python loop: {comp['us_per_period']:.2f} µs per period "
          "(of the 1000 µs budget)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
