"""Quasi-static support points from logs (adaptive_ff.identification.steady_state) and the synthetic logs behind them."""

import math

import numpy as np
import pytest

from adaptive_ff.io.data import MeasuredData
from adaptive_ff.identification.steady_state import (binned_steady_state, constant_velocity_segments, noise_std_estimate,
                                      support_points)
from adaptive_ff.identification.stribeck_fit import fit_stribeck
from controllers.experiments.quasi_static import bidirectional_velocities
from controllers.experiments.synthetic_logs import quasi_static_log
from plant import preset
from plant.errors import ExcitationError, ParameterError

P = preset("paper")
VEL = bidirectional_velocities(0.2 * P.Vs, 0.4, 8)


@pytest.fixture(scope="module")
def clean_log():
    return quasi_static_log(P, VEL, hold=1.0, settle=1.0)


def test_segments_of_a_noise_free_log_are_points_of_eq3(clean_log):
    pts = constant_velocity_segments(clean_log.t, clean_log.u, clean_log.w)
    assert pts.n_points == VEL.size
    np.testing.assert_allclose(pts.w_mean, np.sort(VEL), rtol=1e-6)  # the loop holds each setpoint
    np.testing.assert_allclose(pts.u_mean, P.friction(pts.w_mean), rtol=1e-6)  # u = F(w) in steady state
    assert np.all(pts.t_end - pts.t_start >= 0.5)


def test_piecewise_constant_signal_segments_exactly():
    """Analytic case: 4 plateaus of 1 s at 100 Hz with steps between them (moving average over 5 samples)."""
    levels = [-0.3, -0.05, 0.02, 0.2]
    w = np.repeat(levels, 100)
    t = 0.01 * np.arange(w.size)
    u = 10.0 * np.sign(w) + w
    pts = constant_velocity_segments(t, u, w, settle=0.1, min_duration=0.5)
    np.testing.assert_allclose(pts.w_mean, levels, rtol=1e-12)
    np.testing.assert_allclose(pts.u_mean, 10.0 * np.sign(levels) + levels, rtol=1e-12)
    # 100 samples minus the 0.1 s settle, minus at most 2 samples the moving average smears at each step
    assert all(86 <= n <= 90 for n in pts.n_samples), pts.n_samples


@pytest.mark.parametrize("noise_std, method, tol", [(1e-3, "segments", 0.05), (0.0, "bins", 0.01)])
def test_log_fit_recovers_the_stribeck_curve(clean_log, noise_std, method, tol):
    """Segments: 5 % with 1e-3 rad/s noise. Bins: 1 % noise-free (with noise, binning by the noisy
    velocity biases the lowest-speed points: errors in variables, see binned_steady_state)."""
    log = clean_log if noise_std == 0 else quasi_static_log(P, VEL, hold=1.0, settle=1.0, noise_std=noise_std,
                                                              rng=np.random.default_rng(0))
    if noise_std:
        assert noise_std_estimate(log.w) == pytest.approx(noise_std, rel=0.15)
    pts = support_points(log, method=method)
    fit = fit_stribeck(pts.w_mean, pts.u_mean)
    for name in ("Fc", "Fs", "Vs", "delta", "sigma"):
        assert getattr(fit, name) == pytest.approx(getattr(P, name), rel=tol), name


def test_bins_with_inertia_correction_use_accelerating_samples():
    """A slow triangle sweep: u = F(w) + J dw/dt exactly; with J the bins give F(w) although |dw/dt| is large."""
    t = np.arange(0, 40, 0.005)
    w = 0.4 * (2 * np.abs((t / 10) % 1 - 0.5) * 2 - 1)  # triangle, +-0.4 rad/s, slope 0.16 rad/s^2
    a = np.gradient(w, t)
    u = P.friction(w) + P.J * a
    pts = binned_steady_state(MeasuredData(t, u, w), J=P.J, n_bins=8, w_min=0.01)
    np.testing.assert_allclose(pts.u_mean, P.friction(pts.w_mean), rtol=0.02, atol=0.3)
    plain = binned_steady_state(MeasuredData(t, u, w), n_bins=8, w_min=0.01, max_accel=0.1)
    assert np.all(np.abs(plain.w_mean) > 0.39)  # only the turning points of the sweep are slow enough


def test_auto_falls_back_to_bins_and_errors():
    t = np.arange(0, 20, 0.01)
    w = 0.3 * np.sin(2 * np.pi * 0.05 * t)
    d = MeasuredData(t, P.friction(w), w, source="sweep")
    pts = support_points(d, method="auto", J=P.J)
    assert pts.method == "bins" and any("binned instead" in n for n in pts.notes)
    with pytest.raises(ExcitationError, match=r"sweep: only \d support point\(s\) found by 'segments'"):
        support_points(d, method="segments", min_duration=5.0)
    with pytest.raises(ParameterError, match="method must be one of"):
        support_points(d, method="magic")
    with pytest.raises(ParameterError, match="min_duration must be > 0"):
        constant_velocity_segments(t, w, w, min_duration=0)
    assert math.isfinite(pts.u_std.sum())
