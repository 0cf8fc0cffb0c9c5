"""The user-facing tracking-bound helper and the fault generator."""

import math

import numpy as np
import pytest

from controllers.testing import TrackingBoundError, assert_tracking_bound, velocity_faults
from plant import JointParams, ParameterError


JOINT = JointParams(J=1.2, Fc=8.0, Fs=11.0, Vs=0.03, delta=1.5, sigma=6.0, tau=0.01)


def test_assert_tracking_bound_passes_and_returns_the_runs():
    comp = assert_tracking_bound(JOINT, mode="adaptive", min_eta=0.8, max_rms=0.02, duration=30.0, seed=1)
    assert comp.eta["adaptive"] >= 0.8 and comp.results["adaptive"].metrics.rms_second_half <= 0.02


def test_assert_tracking_bound_fails_with_the_numbers():
    with pytest.raises(TrackingBoundError, match=r"RMS error .* > max_rms 1e-06 rad/s.*eta") as exc:
        assert_tracking_bound(JOINT, mode="none", max_rms=1e-6, duration=10.0, seed=1)
    assert isinstance(exc.value, AssertionError)
    with pytest.raises(ParameterError, match="at least one bound"):
        assert_tracking_bound(JOINT)
    with pytest.raises(ParameterError, match="mode"):
        assert_tracking_bound(JOINT, mode="magic", min_eta=0.5)


def test_velocity_faults_counts_and_values():
    f = velocity_faults(1000, rng=np.random.default_rng(0), n_nan=3, n_inf=2, n_spikes=5, spike=0.7, start=100)
    vals = list(f.values())
    assert len(f) == 10 and min(f) >= 100
    assert sum(math.isnan(v) for v in vals) == 3 and sum(math.isinf(v) for v in vals) == 2
    assert sorted(abs(v) for v in vals if math.isfinite(v)) == [0.7] * 5
    with pytest.raises(ParameterError, match="do not fit"):
        velocity_faults(10, rng=np.random.default_rng(0), n_nan=11)
