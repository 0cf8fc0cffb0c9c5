"""Tests of adaptive_ff.identification.simulator: RK4 of eqs. 1-3 on irregular sample times with first-order-hold input."""

import numpy as np
import pytest
from scipy.linalg import expm

from adaptive_ff.identification.simulator import (BATCH_MAX, input_grid, simulate_on_grid, simulate_on_grid_batch,
                                                  simulate_sampled)
from plant.dynamics import lagged_params
from plant.errors import ParameterError, SignalError
from plant.friction import JointParams

P = JointParams(J=4.0, Fc=25.0, Fs=25.0, Vs=0.02, delta=1.0, sigma=40.0, tau=0.02)


def _linear_reference(t, u, w0, f0, p):
    """Exact solution for w > 0 (F(w) = Fc + sigma*w, linear) with u linear between samples (matrix exponential)."""
    # state z = (w, f, u, 1); u' = slope per interval; A depends on the slope
    out = [w0]
    z = np.array([w0, f0])
    for i in range(1, t.shape[0]):
        h = t[i] - t[i - 1]
        s = (u[i] - u[i - 1]) / h
        A = np.array([[0.0, -1.0 / p.J, 1.0 / p.J, 0.0],
                      [p.sigma / p.tau, -1.0 / p.tau, 0.0, p.Fc / p.tau],
                      [0.0, 0.0, 0.0, s],
                      [0.0, 0.0, 0.0, 0.0]])
        zz = expm(A * h) @ np.array([z[0], z[1], u[i - 1], 1.0])
        z = zz[:2]
        out.append(z[0])
    return np.array(out)


def test_irregular_times_match_matrix_exponential_on_the_linear_branch():
    rng = np.random.default_rng(3)
    t = np.concatenate([[0.0], np.cumsum(rng.uniform(0.004, 0.04, size=60))])  # irregular, 4-40 ms
    u = 60.0 + 20.0 * np.sin(2.0 * np.pi * 0.7 * t)  # keeps w > 0 (u > Fc) throughout
    w0 = 0.5
    f0 = P.Fc + P.sigma * w0
    w = simulate_sampled(P, t, u, w0=w0, f0=f0, h_max=1e-3)
    ref = _linear_reference(t, u, w0, f0, P)
    assert np.all(ref > 0)
    np.testing.assert_allclose(w, ref, rtol=0, atol=1e-8)


def test_zero_injection_error_leaves_the_free_run_unchanged():
    t = np.arange(0.0, 2.0, 0.01)
    u = 40.0 * np.sin(2.0 * np.pi * 0.5 * t)
    g = input_grid(t, u, h_max=1e-3)
    p = JointParams(J=4.0, Fc=25.0, Fs=35.0, Vs=0.02, delta=1.0, sigma=40.0, tau=0.02)
    free = simulate_on_grid(lagged_params(p.J, p.Fc, p.Fs, p.Vs, p.delta, p.sigma, p.tau), g, w0=0.0, f0=0.0)
    inj = simulate_on_grid(lagged_params(p.J, p.Fc, p.Fs, p.Vs, p.delta, p.sigma, p.tau), g, w0=0.0, f0=0.0, gain=(1.0, 1.0),
                           w_meas=free)
    np.testing.assert_allclose(inj, free, rtol=0, atol=1e-12)
    # a measured offset of +0.01 rad/s injected with Kw = 1 moves the next prediction
    inj2 = simulate_on_grid(lagged_params(p.J, p.Fc, p.Fs, p.Vs, p.delta, p.sigma, p.tau), g, w0=0.0, f0=0.0, gain=(1.0, 0.0),
                            w_meas=free + 0.01)
    assert np.max(np.abs(inj2[1:] - free[1:])) > 1e-3


def test_input_grid_subdivides_each_interval():
    t = np.array([0.0, 0.01, 0.035, 0.036])
    g = input_grid(t, np.array([0.0, 1.0, 3.5, 3.6]), h_max=0.005)
    np.testing.assert_array_equal(g.idx, [0, 2, 7, 8])
    np.testing.assert_allclose(g.tg[g.idx], t)
    np.testing.assert_allclose(np.diff(g.tg).max(), 0.005, rtol=1e-12)
    np.testing.assert_allclose(g.ug, 100.0 * g.tg, atol=1e-12)  # the input is linear: FOH is exact


def test_cubic_input_reconstruction_is_exact_for_a_cubic():
    t = np.array([0.0, 0.013, 0.02, 0.041, 0.05, 0.072])
    u = 3.0 - 2.0 * t + 40.0 * t**2 - 500.0 * t**3
    g = input_grid(t, u, h_max=0.002, interp="cubic")
    np.testing.assert_allclose(g.ug, 3.0 - 2.0 * g.tg + 40.0 * g.tg**2 - 500.0 * g.tg**3, atol=1e-12)
    with pytest.raises(ParameterError, match="interp"):
        input_grid(t, u, interp="spline")


def test_invalid_arguments_raise_typed_errors():
    t = np.arange(0.0, 0.1, 0.01)
    u = np.zeros_like(t)
    with pytest.raises(ParameterError, match="tau"):
        simulate_sampled(JointParams(J=4.0, Fc=25.0, Fs=35.0, Vs=0.02, delta=1.0, sigma=40.0, tau=0.0), t, u)
    with pytest.raises(SignalError, match="t"):
        simulate_sampled(P, t[::-1], u)
    with pytest.raises(SignalError, match="u"):
        simulate_sampled(P, t, u[:-1])
    with pytest.raises(ParameterError, match="h_max"):
        simulate_sampled(P, t, u, h_max=0.0)
    with pytest.raises(TypeError, match="JointParams"):
        simulate_sampled({"J": 4.0}, t, u)


def test_diverging_parameters_give_nan_from_the_divergence_on():
    # tau far below the RK4 stability limit (h/tau = 100 > 2.78): the friction state grows by |1 - h/tau + ...| ~
    # 1e6 per sub-step, overflows within a few samples; the samples before it stay finite
    t = np.arange(0.0, 0.2, 0.01)
    g = input_grid(t, 30.0 + 0.0 * t, h_max=1e-3)
    w = simulate_on_grid(lagged_params(4.0, 25.0, 35.0, 0.02, 1.0, 40.0, 1e-5), g, w0=0.1, f0=10.0)
    assert w[0] == 0.1
    bad = np.flatnonzero(~np.isfinite(w))
    assert 1 <= bad[0] < w.size and np.all(np.isnan(w[bad[0]:]))
    assert np.all(np.isfinite(w[:bad[0]]))


def test_injection_needs_a_measured_velocity_of_the_sample_length():
    t = np.arange(0.0, 0.1, 0.01)
    g = input_grid(t, np.zeros_like(t))
    par = lagged_params(P.J, P.Fc, P.Fs, P.Vs, P.delta, P.sigma, P.tau)
    with pytest.raises(SignalError, match="w_meas"):
        simulate_on_grid(par, g, w0=0.0, f0=0.0, gain=(1.0, 0.0), w_meas=np.zeros(t.size - 1))
    with pytest.raises(SignalError, match="w_meas"):
        simulate_on_grid(par, g, w0=0.0, f0=0.0, gain=(1.0, 0.0))


def test_batch_is_each_simulation_bit_for_bit():
    # more parameter sets than one C call takes (chunked), irregular sub-steps, every injection, and one set that
    # diverges (tau far below the RK4 limit): each row must be exactly the one-at-a-time simulation
    rng = np.random.default_rng(8)
    t = np.concatenate([[0.0], np.cumsum(rng.uniform(0.5e-3, 2.5e-3, size=1500))])
    u = 45.0 * np.sin(2.0 * np.pi * 0.7 * t) + rng.normal(0.0, 2.0, t.size)
    g = input_grid(t, u, h_max=1e-3)
    n = BATCH_MAX + 5
    sets = [(4.0 * (1 + 0.05 * k), 25.0 + 0.3 * k, 35.0 - 0.2 * k, 0.02, 1.0 + 0.1 * (k % 3), 40.0, 0.02 + 1e-3 * k)
            for k in range(n - 1)] + [(4.0, 25.0, 35.0, 0.02, 1.0, 40.0, 1e-5)]
    pars = [lagged_params(*p) for p in sets]
    offsets = np.linspace(-0.5, 0.5, n)
    w_meas = simulate_on_grid(pars[0], g, w0=0.0, f0=0.0) + rng.normal(0.0, 0.01, t.size)
    for gain in ((0.0, 0.0), (1.0, 0.0), (1.0, 1.0)):
        out = simulate_on_grid_batch(pars, g, w0=0.05, f0=3.0, offsets=offsets, gain=gain, w_meas=w_meas)
        assert out.shape == (n, t.size)
        for k in range(n):
            one = simulate_on_grid(pars[k], g, w0=0.05, f0=3.0, offset=offsets[k], gain=gain, w_meas=w_meas)
            np.testing.assert_array_equal(out[k], one)
        assert np.all(np.isfinite(out[:-1])) and np.isnan(out[-1, -1]) and out[-1, 0] == 0.05
    with pytest.raises(SignalError, match="offsets"):
        simulate_on_grid_batch(pars, g, w0=0.0, f0=0.0, offsets=offsets[:-1])
