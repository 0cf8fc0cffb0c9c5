"""The numbers docs/getting_started.md quotes for the sensor, the drive, the plant and the moves of its examples.

Run:  python -m benchmarks.getting_started

The page's setting: the ``paper`` preset, PI from :func:`controllers.design.pi.design_pi` (20 rad/s, 60 deg, 1 kHz),
``LoopConfig.from_flat(Kp, Ki, u_max=150, Vs, delta, noise_std=1e-3)``, the page's own run seeds. Printed, with eta over the
second half, ``(RMS_none - RMS_mode)/(RMS_none - RMS_frictionless)`` (none and frictionless through the same
sensor, drive and plant):

* **sensor and drive** (multi-sine 20 s, reference seed 0, run seed 1): the ideal sensor, a 17-bit encoder's
  backward difference, the same with one period of measurement delay and a 2000 N·m/s slew limit (the stick band
  the loop sizes for the sensor, three times its velocity noise, :meth:`LoopConfig.sized_stick_band`), and the two
  encoder rows again with a stick band of 0; eta of ``adaptive`` and ``adaptive-dob`` and the updates
  ``adaptive``'s estimator refused as implausible;
* **plant** (the same runs): a payload step (J 4 -> 6 kg·m² at 10 s) and a +-10 % friction ripple of 240 and 24
  periods per revolution;
* **moves** (the page's pick-and-place reference, run seed 0): RMS of the velocity error in motion (deg/s) and
  each stop's settling time (s; ``inf``: not settled within the dwell) of ``none``, ``adaptive`` and
  ``frictionless``.

The runs are deterministic for their seeds; docs/getting_started.md quotes this output and
``tests/docs_cli/test_getting_started.py`` checks that it does.
"""

from __future__ import annotations

import argparse

import numpy as np

from controllers.design.pi import design_pi
from controllers.simulation.closed_loop import LoopConfig, run_mode
from plant import FrictionRipple, PayloadStep, preset
from plant.excitation import multisine_reference
from plant.motion import point_to_point_reference

MODES = ("adaptive", "adaptive-dob")


def _eta(plant, ref, options, seed: int) -> tuple[dict, object]:
    """eta of each of :data:`MODES` on ``plant`` and ``adaptive``'s run."""
    runs = {m: run_mode(plant, ref, m, options, rng=np.random.default_rng(seed))
            for m in ("none", "frictionless") + MODES}
    rn, rf = runs["none"].metrics.rms_second_half, runs["frictionless"].metrics.rms_second_half
    return {m: (rn - runs[m].metrics.rms_second_half) / (rn - rf) for m in MODES}, runs["adaptive"]


def _row(label: str, eta: dict, run) -> str:
    return (f"{label:<38} " + " ".join(f"{eta[m]:>13.2f}" for m in MODES)
            + f" {run.info['n_implausible']:>6d} of {run.info['n_updates']:d}")


def main(argv=None) -> int:
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args(argv)
    p = preset("paper")
    d = design_pi(p.J, crossover=20.0, phase_margin=60.0, Tc=1e-3)
    o = dict(Kp=d.Kp, Ki=d.Ki, u_max=150.0, Vs=p.Vs, delta=p.delta, noise_std=1e-3)
    ref = multisine_reference(20.0, rng=np.random.default_rng(0))
    head = f"{'':<38} " + " ".join(f"{'eta ' + m:>13}" for m in MODES) + "  adaptive's refused updates"
    print("sensor and drive (multi-sine 20 s, seed 1)\n" + head)
    encoder, drive = dict(encoder_counts=2 ** 17), dict(encoder_counts=2 ** 17, delay=1, slew_rate=2000.0)
    for label, kw in (("ideal sensor", {}), ("17-bit encoder", encoder),
                      ("17-bit encoder, 1 period delay, slew", drive),
                      ("17-bit encoder, stick band 0", dict(encoder, stick_band=0.0)),
                      ("the same, 1 period delay, slew", dict(drive, stick_band=0.0))):
        print(_row(label, *_eta(p, ref, LoopConfig.from_flat(**o, **kw), 1)))
    print("\nplant (multi-sine 20 s, seed 1)\n" + head)
    for label, plant in (("payload step J 4 -> 6 at 10 s", PayloadStep(p, t_step=10.0, J_after=6.0)),
                         ("ripple 10 %, 240 per revolution", FrictionRipple(p, amplitude=0.1, harmonic=240.0)),
                         ("ripple 10 %, 24 per revolution", FrictionRipple(p, amplitude=0.1, harmonic=24.0))):
        print(_row(label, *_eta(plant, ref, LoopConfig.from_flat(**o), 1)))
    moves = point_to_point_reference([0.5, -0.2, 0.4], v_max=0.5, a_max=4.0, j_max=100.0, dwell=0.5)
    print("\nmoves (pick-and-place, seed 0)\n"
          f"{'':<13} {'RMS in motion (deg/s)':>22}  settling time per stop (s)")
    for m in ("none", "adaptive", "frictionless"):
        r = run_mode(p, moves, m, LoopConfig.from_flat(**o), rng=np.random.default_rng(0))
        settle = " ".join(f"{s:.3f}" if np.isfinite(s) else "inf" for s in r.motion.settling_time)
        print(f"{m:<13} {np.degrees(r.motion.rms_motion):>22.2f}  {settle}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
