"""The slope of eq. 3's Stribeck term (plant.stribeck_map.stribeck_slope_scalar) against central differences of the map;
the map's static friction (static_friction) against its largest value off rest."""

import math

import numpy as np
import pytest

from plant.stribeck_map import static_friction, stribeck, stribeck_slope_scalar


@pytest.mark.parametrize("delta", [-0.7, 0.5, 1.0, 2.0, 2.5])
@pytest.mark.parametrize("dF", [10.0, -4.0])
def test_slope_matches_central_difference_of_eq3(delta, dF):
    Fc, Vs, sigma = 25.0, 0.02, 3.0
    for w in (1e-3, 0.007, 0.02, 0.05, 0.09):
        h = 1e-7 * w
        fd = (stribeck(w + h, Fc=Fc, Fs=Fc + dF, Vs=Vs, delta=delta, sigma=sigma)
              - stribeck(w - h, Fc=Fc, Fs=Fc + dF, Vs=Vs, delta=delta, sigma=sigma)) / (2 * h) - sigma
        got = stribeck_slope_scalar(w / Vs, dF, Vs, delta)
        assert got == pytest.approx(fd, rel=1e-6, abs=1e-6 * abs(dF) / Vs)
        # the map is odd, its slope even: the same at -w
        fdn = (stribeck(-w + h, Fc=Fc, Fs=Fc + dF, Vs=Vs, delta=delta, sigma=sigma)
               - stribeck(-w - h, Fc=Fc, Fs=Fc + dF, Vs=Vs, delta=delta, sigma=sigma)) / (2 * h) - sigma
        assert fdn == pytest.approx(fd, rel=1e-5, abs=1e-5 * abs(dF) / Vs)


def test_slope_limits():
    # the term underflows: exactly 0, never inf*0 = NaN
    assert stribeck_slope_scalar(1e3, 10.0, 0.02, 2.0) == 0.0
    assert stribeck_slope_scalar(0.0, 10.0, 0.02, -0.5) == 0.0
    assert stribeck_slope_scalar(1e-300, 10.0, 0.02, -0.5) == 0.0
    # delta = 1 at standstill: -dF/Vs; 0 < delta < 1: unbounded; delta > 1: flat
    assert stribeck_slope_scalar(0.0, 10.0, 0.02, 1.0) == pytest.approx(-500.0, rel=1e-15)
    assert stribeck_slope_scalar(0.0, 10.0, 0.02, 0.5) == -math.inf
    assert stribeck_slope_scalar(0.0, 10.0, 0.02, 2.0) == 0.0
    assert np.isfinite(stribeck_slope_scalar(1e-12, 10.0, 0.02, 0.5))


def test_static_friction_is_the_largest_friction_at_breakaway():
    """static_friction(Fc, Fs): the map's largest value just off rest, max over w -> 0+ of |F(w)| with sigma = 0
    (sampled here from the map itself), for a hump (Fs > Fc), a dip (Fs < Fc), negative values; NaN passes."""
    w = np.geomspace(1e-9, 10.0, 4001)
    for Fc, Fs in ((1.2, 1.5), (2.0, 0.7), (-0.5, -0.9), (0.8, 0.8)):
        peak = float(np.max(np.abs(stribeck(w, Fc=Fc, Fs=Fs, Vs=0.1, delta=1.0, sigma=0.0))))
        assert static_friction(Fc, Fs) == pytest.approx(peak, rel=1e-6), (Fc, Fs)
    both = static_friction([1.2, 2.0], [1.5, 0.7])
    assert isinstance(both, np.ndarray) and both.tolist() == [1.5, 2.0]
    assert isinstance(static_friction(1.0, 2.0), float) and np.isnan(static_friction(np.nan, 1.0))
