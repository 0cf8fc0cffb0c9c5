"""Encoder velocity table: eta and tracking RMS of the adaptive modes with a 17-bit encoder, by the velocity's
estimator (backward difference or the Kalman velocity of :class:`controllers.simulation.sensor_drive.Sensor`).

Run:  python -m benchmarks.encoder_velocity [--counts 131072] [--duration 20] [--bandwidths 100] [--models cv,ca]
      [--seeds 1,2,3,4,5,6,7,8]

The ``paper`` preset, the multi-sine reference of :func:`plant.excitation.multisine_reference` (``--duration`` s,
reference seed 0), PI from :func:`controllers.design.pi.design_pi` (20 rad/s, 60 deg), torque limit 150 N·m,
noise 1e-3 rad/s, the plant's own Stribeck factors, run seeds ``--seeds`` (the same noise in every mode and
sensor; the first seed's numbers, then the mean and range over all: the adaptive mode's eta moves by a few
hundredths from seed to seed and with changes of the velocity in its last digits). Rows:
the ideal velocity sensor (``w + noise``), the encoder's backward difference, the encoder's Kalman velocity per
model and bandwidth (Hz; the default ``0.1/Tc`` = 100 Hz). Printed per row and mode: eta over the second half,
``(RMS_none - RMS_mode)/(RMS_none - RMS_frictionless)`` with none and frictionless measured through the same
sensor, and the tracking RMS over the second half (rad/s). Also the RMS of the measured minus the true velocity
of the first seed's ``none`` run (the sensor's error in the loop: noise and lag). Results: docs/getting_started.md (the encoder rows).
"""

from __future__ import annotations

import argparse

import numpy as np

from controllers.design.pi import design_pi
from controllers.simulation.closed_loop import LoopConfig, run_mode
from plant.excitation import multisine_reference
from plant.friction import preset

MODES = ("adaptive", "adaptive-dob")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--counts", type=int, default=2**17, help="encoder counts per revolution (default 2**17)")
    ap.add_argument("--duration", type=float, default=20.0, help="multi-sine length in s (default 20)")
    ap.add_argument("--bandwidths", default="100", help="comma-separated Kalman bandwidths in Hz (default 100)")
    ap.add_argument("--models", default="cv,ca", help="comma-separated Kalman models (default cv,ca)")
    ap.add_argument("--seeds", default="1,2,3,4,5,6,7,8", help="comma-separated run seeds (default 1-8)")
    a = ap.parse_args(argv)
    p = preset("paper")
    d = design_pi(p.J, crossover=20.0, phase_margin=60.0, Tc=1e-3)
    ref = multisine_reference(a.duration, rng=np.random.default_rng(0))
    rows = [("ideal sensor", {}), ("encoder, difference", dict(encoder_counts=a.counts))]
    for model in a.models.split(","):
        for fb in a.bandwidths.split(","):
            rows.append((f"encoder, Kalman {model} {float(fb):g} Hz",
                         dict(encoder_counts=a.counts, velocity="kalman", velocity_model=model,
                              velocity_bandwidth=float(fb))))
    seeds = [int(x) for x in a.seeds.split(",")]
    print("| velocity | sensor noise RMS (rad/s) | "
          + " | ".join(f"eta {m} seed {seeds[0]} | RMS {m} (rad/s) | eta {m} mean (range) over {len(seeds)} seeds"
                       for m in MODES) + " |")
    print("|---|---:|" + "---:|---:|---:|" * len(MODES))
    for label, kw in rows:
        o = LoopConfig.from_flat(Kp=d.Kp, Ki=d.Ki, u_max=150.0, Vs=p.Vs, delta=p.delta, noise_std=1e-3, **kw)
        eta = {m: [] for m in MODES}
        for i, seed in enumerate(seeds):
            runs = {m: run_mode(p, ref, m, o, rng=np.random.default_rng(seed)) for m in ("none", "frictionless") + MODES}
            rn, rf = runs["none"].metrics.rms_second_half, runs["frictionless"].metrics.rms_second_half
            for m in MODES:
                eta[m].append((rn - runs[m].metrics.rms_second_half) / (rn - rf))
            if i == 0:
                first = runs
                sn = float(np.sqrt(np.mean((runs["none"].w_meas - runs["none"].w) ** 2)))
        cells = []
        for m in MODES:
            e = np.array(eta[m])
            cells += [f"{e[0]:.2f}", f"{first[m].metrics.rms_second_half:.4f}",
                      f"{e.mean():.2f} ({e.min():.2f}..{e.max():.2f})"]
        print(f"| {label} | {sn:.4f} | " + " | ".join(cells) + " |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
