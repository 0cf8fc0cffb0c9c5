"""How a heavy joint's lag reading depends on how its stops are integrated: the simulated arm's Runge-Kutta steps per
period and the output-error simulation's step.

Run:  python -m benchmarks.arm_stops [--cases 0:3,26:3] [--arms 1:1,1:10,10:1] [--h-max 1e-3,2.5e-4,1e-4]

Part 1, the fit. Each case ``SEED:JOINT`` is joint ``JOINT`` (1-based, the log's ``q1..qN``) of the arm of
``benchmarks.arm_coverage --lag`` with seed ``SEED`` (:func:`benchmarks.arm_coverage.arm_friction`), simulated for
20 s (:func:`adaptive_ff.arm.simulate.simulate_arm`) each way of ``--arms``: ``SUBSTEPS:REFINE``, that many
Runge-Kutta steps per 1 ms period and ``REFINE`` times as many in the periods in which a joint stops or reverses
(``ArmSimulation.stop_refine``; the coverage benchmarks take 1:10, ``--coarse-arms`` 1:1). Its output-error record
is built as ``identify-arm`` builds it (:func:`adaptive_ff.arm.lag.lag_records`) but with the *true* rigid body removed (the URDF's inertias with the
armatures; each joint's ``M_jj`` at the log's mean position), so no identification error enters, and the lag fit's
output-error fit (:func:`adaptive_ff.identification.physical_id.fit_physical`: its one-step predictor and injection
gain, no input delay, the true Stribeck shape held, no bootstrap, no low-pass correction) runs with each of
``--h-max`` as its largest simulation step, and at 1 ms with its stop band as ``identify-arm``'s lag fit takes it
(:data:`adaptive_ff.arm.lag.LAG_STOP_BAND` times ``Fs Ts / J``, the true ``Fs`` and ``M_jj``: 0.1 ms steps in the
intervals where the record's velocity is inside it or reverses). Printed per case: the lag it reads (ms) for every
pair.

Part 2, the stop. The case's joint alone (its friction, its ``M_jj`` as ``J``), from 0.05 rad/s at its steady
friction, under a constant 1 N·m, simulated by the output-error fit's simulator
(:func:`adaptive_ff.identification.simulator.simulate_sampled`) with steps of 1 µs and of 1 ms: the largest
``|w|`` (rad/s) in each 5 ms window after the first reversal. Eqs. 1-3 with a lag, integrated finely, ring through
zero velocity at the stop and settle; one step per millisecond keeps them ringing.

The numbers are quoted in ``docs/your_arm.md`` (Not yet).
"""

from __future__ import annotations

import argparse

import numpy as np


def _cases(text: str) -> list:
    """``[(seed, joint_index_0_based), ...]`` of ``"SEED:JOINT,..."`` (JOINT 1-based)."""
    out = []
    for item in text.split(","):
        seed, joint = item.split(":")
        out.append((int(seed), int(joint) - 1))
    return out


def true_record(seed: int, substeps: int, stop_refine: int) -> tuple:
    """``(friction, J, t, u, w)`` of arm ``seed``: its lagged friction, each joint's ``M_jj`` (kg·m²) and the
    output-error record (s, N·m, rad/s; shapes (n,), (n, N), (n, N)) with the true rigid body removed."""
    from adaptive_ff.arm.arm_log import DEFAULT_CUTOFF
    from adaptive_ff.arm.lag import lag_records
    from adaptive_ff.arm.robot import load_urdf
    from benchmarks.arm_coverage import URDF, arm_friction, arm_log, true_inertia, true_theta

    arm = load_urdf(URDF)
    friction = arm_friction(arm.n, seed, lag=True)
    log = arm_log(arm, seed, lag=True, substeps=substeps, stop_refine=stop_refine)
    theta = true_theta(arm)
    J = true_inertia(arm, log.q.mean(axis=0))
    t, u, w = lag_records(log, arm, lambda Y: Y @ theta, J, DEFAULT_CUTOFF)
    return friction, J, t, u, w


def lag_read(t, u, w, f, h_max: float, stop_band: float | None = None) -> float:
    """The lag (s) the lag fit's output-error fit reads on one joint's record at the largest step ``h_max`` (s)
    and the stop band ``stop_band`` (rad/s, None: none; inside it the fit's default 0.1 ms, the tenth of the 1 kHz
    record's sample time that identify-arm's lag fit takes), the true Stribeck shape of ``f``
    (:class:`adaptive_ff.arm.simulate.JointFriction`) held."""
    from adaptive_ff.arm.lag import LAG_INJECTION_GAIN
    from adaptive_ff.identification.physical_id import fit_physical

    fit = fit_physical(t, u, w, Vs=f.Vs, delta=f.delta, n_bootstrap=0, input_delay=0.0,
                       injection_gain=LAG_INJECTION_GAIN, h_max=h_max, stop_band=stop_band)
    return float(fit.params["tau"])


def stop_peaks(f, J: float, h_max: float, *, windows: int = 6, window: float = 5e-3) -> list:
    """Largest ``|w|`` (rad/s) in each ``window`` s after the first reversal of the joint of friction ``f`` and
    inertia ``J`` (kg·m²), from 0.05 rad/s under 1 N·m, simulated with steps of at most ``h_max`` s (Part 2)."""
    from adaptive_ff.identification.simulator import simulate_sampled
    from plant.friction import JointParams

    p = JointParams(J=J, Fc=f.Fc, Fs=f.Fs, Vs=f.Vs, delta=f.delta, sigma=f.sigma, tau=f.tau)
    ts = max(h_max, 1e-4)  # samples every 0.1 ms, or every step where the step is longer
    t = np.arange(0.0, 0.2, ts)
    w = simulate_sampled(p, t, np.full(t.shape, 1.0), w0=0.05, h_max=h_max)
    k0 = int(np.argmax(w <= 0.0))
    per = int(round(window / ts))
    return [float(np.max(np.abs(w[k0 + i * per: k0 + (i + 1) * per]))) for i in range(windows)]


def main(argv=None) -> int:
    from adaptive_ff.arm.lag import stop_bands
    from plant.stribeck_map import static_friction

    ap = argparse.ArgumentParser(prog="python -m benchmarks.arm_stops", description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default="0:3,26:3", help="SEED:JOINT pairs, JOINT 1-based (default 0:3,26:3)")
    ap.add_argument("--arms", default="1:1,1:10,10:1",
                    help="the simulated arm's SUBSTEPS:REFINE, steps per period and the factor in its stops "
                         "(default 1:1,1:10,10:1)")
    ap.add_argument("--h-max", dest="h_max", default="1e-3,2.5e-4,1e-4",
                    help="the output-error simulation's largest steps, s (default 1e-3,2.5e-4,1e-4)")
    a = ap.parse_args(argv)
    cases = _cases(a.cases)
    arms = [tuple(int(v) for v in item.split(":")) for item in a.arms.split(",")]
    hs = [float(h) for h in a.h_max.split(",")]
    print("Part 1: the lag read (ms), true rigid body removed; rows: the arm's steps per 1 ms period and their factor "
          "in its stops, columns: the output-error simulation's largest step, then 1 ms with the lag fit's stop band")
    records = {}
    for seed, j in cases:
        for arm_way in arms:
            if (seed, arm_way) not in records:
                records[seed, arm_way] = true_record(seed, *arm_way)
            fr, J, t, u, w = records[seed, arm_way]
            band = float(stop_bands([static_friction(fr[j].Fc, fr[j].Fs)], [J[j]], float(np.median(np.diff(t))))[0])
            reads = "  ".join(f"h_max {1e3 * h:g} ms: {1e3 * lag_read(t, u[:, j], w[:, j], fr[j], h):6.2f}"
                              for h in hs)
            banded = 1e3 * lag_read(t, u[:, j], w[:, j], fr[j], 1e-3, band)
            print(f"  seed {seed} joint {j + 1} (true {1e3 * fr[j].tau:.2f} ms, Fc {fr[j].Fc:.2f} N·m, "
                  f"M_jj {J[j]:.4f} kg·m²)  arm {arm_way[0]:2d}:{arm_way[1]:<2d}  {reads}  "
                  f"1 ms + band {band:.3f} rad/s: {banded:6.2f}", flush=True)
    print("Part 2: largest |w| (rad/s) per 5 ms after the first reversal, 0.05 rad/s under 1 N·m")
    for seed, j in cases:
        fr, J, *_ = records[seed, arms[0]]
        if not fr[j].tau > 0.0:
            continue
        for h in (1e-6, 1e-3):
            peaks = " ".join(f"{p:.4f}" for p in stop_peaks(fr[j], J[j], h))
            print(f"  seed {seed} joint {j + 1} (tau {1e3 * fr[j].tau:.2f} ms)  step {1e3 * h:g} ms:  {peaks}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
