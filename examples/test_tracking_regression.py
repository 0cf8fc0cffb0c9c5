"""Tracking-error regression test for friction compensation: copy it into your own test suite.

For the engineer who integrates the adaptive friction feedforward into a product and wants CI to
fail when a change (new gains, new estimator settings, a new package version) makes velocity
tracking worse. Put your joint's parameters in PLANT and your requirements in the bounds, run it
once, and keep the bounds a margin above the measured values.

Uses the public API only: :func:`controllers.experiments.compare` (all modes on one scenario) and
:func:`controllers.run_mode` (one mode). Run: ``python -m pytest test_tracking_regression.py``.
The values noted below were measured for the ``paper`` preset, seed 0, 30 s.
"""

import math

import numpy as np
import pytest

from controllers import LoopConfig, compare, design_pi, run_mode
from plant import multisine_reference, preset

# --- your joint and your requirements ------------------------------------------------------------
PLANT = preset("paper")  # or JointParams(J=..., Fc=..., Fs=..., Vs=..., delta=..., sigma=..., tau=...)
VS, DELTA = 0.02, 1.0  # your joint's Stribeck velocity (rad/s) and shape factor, if known (else a pre-fit runs)
DURATION = 30.0  # s of multi-sine tracking (0.01-1 Hz, up to 20 deg/s); metrics over the second half
SEED = 0
MAX_RMS_ADAPTIVE = math.radians(1.5)  # rad/s; measured 0.67 deg/s
MAX_ERROR_ADAPTIVE = math.radians(6.0)  # rad/s, largest error; measured 2.4 deg/s
MAX_RATIO_TO_NONE = 0.5  # adaptive RMS / uncompensated RMS; measured 0.20
MIN_ETA = 0.6  # share of the friction-induced error removed; measured 0.99
MAX_RMS_UNCOMPENSATED = math.radians(5.0)  # rad/s; guards the PI loop itself; measured 3.4 deg/s


@pytest.fixture(scope="module")
def comparison():
    return compare(PLANT, duration=DURATION, seed=SEED, modes=("none", "adaptive", "frictionless"),
                   Vs=VS, delta=DELTA, progress=False)


def test_adaptive_feedforward_meets_the_tracking_bound(comparison):
    m = comparison.results["adaptive"].metrics
    assert m.rms_second_half < MAX_RMS_ADAPTIVE, f"RMS {math.degrees(m.rms_second_half):.3f} deg/s"
    assert m.max_second_half < MAX_ERROR_ADAPTIVE, f"max {math.degrees(m.max_second_half):.3f} deg/s"


def test_adaptive_feedforward_removes_most_of_the_friction_error(comparison):
    none = comparison.results["none"].metrics.rms_second_half
    adaptive = comparison.results["adaptive"].metrics.rms_second_half
    assert adaptive < MAX_RATIO_TO_NONE * none
    assert comparison.eta["adaptive"] > MIN_ETA


def test_uncompensated_loop_is_sane():
    """The PI loop alone (run_mode, mode 'none') must track within its own bound."""
    ref = multisine_reference(DURATION, rng=np.random.default_rng(SEED))
    d = design_pi(PLANT.J, crossover=20.0, phase_margin=60.0)
    assert d.phase_margin == pytest.approx(60.0, abs=0.1)
    r = run_mode(PLANT, ref, "none", LoopConfig.from_flat(Kp=d.Kp, Ki=d.Ki, noise_std=1e-3), rng=np.random.default_rng(SEED))
    assert np.all(np.isfinite(r.w))
    assert r.metrics.rms_second_half < MAX_RMS_UNCOMPENSATED
