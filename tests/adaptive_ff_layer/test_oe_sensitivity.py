"""The exact Jacobian of the output-error simulation (aff_simulate_on_grid_sens) against central differences of
the plain simulation (aff_simulate_on_grid), computed here independently, and the fit's use of it."""

import math

import numpy as np
import pytest

from adaptive_ff.identification.ls import fit_ls
from adaptive_ff.identification.physical_id import fit_physical
from adaptive_ff.identification.regression import RegressionModel
from adaptive_ff.identification.simulator import SENS_NAMES, input_grid, simulate_on_grid, simulate_on_grid_sens
from plant import bandlimited_noise, preset, sample, simulate
from plant.dynamics import lagged_params

P = preset("paper")
DT = 1e-3
# (J, Fc, Fs, sigma, tau, offset, Vs, delta): the paper preset with a non-trivial offset and shape factor
THETA = np.array([4.0, 25.0, 35.0, 40.0, 0.02, 0.3, 0.02, 1.3])


def _sim(theta, grid, w0, f0, gain, w_meas, sens=False):
    J, Fc, Fs, sigma, tau, off, Vs, delta = theta
    par = lagged_params(J, Fc, Fs, Vs, delta, sigma, tau)
    f = simulate_on_grid_sens if sens else simulate_on_grid
    return f(par, grid, w0=w0, f0=f0, offset=off, gain=gain, w_meas=w_meas)


def _central(theta, j, grid, w0, f0, gain, w_meas, rel=1e-6):
    h = rel * abs(theta[j])
    tp, tm = theta.copy(), theta.copy()
    tp[j] += h
    tm[j] -= h
    return (_sim(tp, grid, w0, f0, gain, w_meas) - _sim(tm, grid, w0, f0, gain, w_meas)) / (2.0 * h)


@pytest.fixture(scope="module")
def record():
    """3 s of the Sec. IV-A experiment at 1 kHz with 1 % velocity noise (seed 3), sub-steps of 0.5 ms."""
    rng = np.random.default_rng(3)
    _, u = bandlimited_noise(3.0, dt=DT, cutoff=1.0, std=1.2 * (P.Fs + P.sigma * math.radians(20.0)), rng=rng)
    m = sample(simulate(P, u, dt=DT), Ts=DT, noise_std=0.01 * 0.6, rng=rng)
    return m, input_grid(m.t, m.u, h_max=0.5e-3, input_delay=0.5 * DT)


def test_names_order():
    assert SENS_NAMES == ("J", "Fc", "Fs", "sigma", "tau", "offset", "Vs", "delta")


@pytest.mark.parametrize("gain", [(1.0, 0.0), (0.5, 0.7)])
def test_jacobian_equals_central_differences_with_output_injection(record, gain):
    # with the velocity reset after each sample the prediction is a smooth function of the parameters over a
    # step: the exact Jacobian is the limit of the differences
    m, grid = record
    w0, f0 = float(m.w[0]), float(m.u[0])
    w, dw = _sim(THETA, grid, w0, f0, gain, m.w, sens=True)
    assert np.array_equal(w, _sim(THETA, grid, w0, f0, gain, m.w))  # the same simulation, bit for bit
    assert np.all(dw[0] == 0.0)
    for j in range(len(SENS_NAMES)):
        fd = _central(THETA, j, grid, w0, f0, gain, m.w)
        scale = np.max(np.abs(fd))
        assert scale > 0.0, SENS_NAMES[j]
        assert np.max(np.abs(dw[:, j] - fd)) < 1e-4 * scale, (SENS_NAMES[j], np.max(np.abs(dw[:, j] - fd)), scale)


def test_jacobian_equals_central_differences_free_run_in_one_direction():
    # a free run that stays in forward motion through the Stribeck range (0.03 .. 0.2 rad/s): eq. 3 is smooth
    # there, so the free-run simulation is too and the differences converge to the exact Jacobian
    t = np.arange(0.0, 2.0 + DT / 2, DT)
    w_ss = 0.12
    F = P.Fc + (P.Fs - P.Fc) * math.exp(-((w_ss / 0.02) ** 1.3)) + P.sigma * w_ss + 0.3
    u = F + 2.0 * np.sin(2.0 * math.pi * 1.5 * t)
    grid = input_grid(t, u, h_max=DT)
    w, dw = _sim(THETA, grid, w_ss, F, (0.0, 0.0), None, sens=True)
    assert np.array_equal(w, _sim(THETA, grid, w_ss, F, (0.0, 0.0), None))
    assert 0.03 < np.min(w) and np.max(w) < 0.25
    for j in range(len(SENS_NAMES)):
        fd = _central(THETA, j, grid, w_ss, F, (0.0, 0.0), None)
        scale = np.max(np.abs(fd))
        assert scale > 0.0, SENS_NAMES[j]
        assert np.max(np.abs(dw[:, j] - fd)) < 1e-5 * scale, (SENS_NAMES[j], np.max(np.abs(dw[:, j] - fd)), scale)


def test_sensitivity_jacobian_option_fits_a_noise_free_record():
    # the one-step predictor (noise-free record, 10 s at 10 ms) with the exact Jacobian: measured J -0.12 %,
    # Fc +0.01 %, Fs -1.47 %, sigma -0.03 %, tau +0.2 % (the difference Jacobian: -0.02, +0.13, -1.36, -0.10,
    # -0.59 %, at a higher cost)
    rng = np.random.default_rng(0)
    _, u = bandlimited_noise(10.0, dt=DT, cutoff=1.0, std=1.2 * (P.Fs + P.sigma * math.radians(20.0)), rng=rng)
    m = sample(simulate(P, u, dt=DT), Ts=0.01, rng=rng)
    fit = fit_physical(m.t, m.u, m.w, Vs=P.Vs, delta=P.delta, input_delay=0.5 * DT, n_bootstrap=0,
                       jacobian="sensitivity")
    assert fit.info["predictor"] == "one-step"
    for k, tol in (("J", 0.01), ("Fc", 0.01), ("Fs", 0.03), ("sigma", 0.01), ("tau", 0.01)):
        assert fit.params[k] == pytest.approx(getattr(P, k), rel=tol), k


def test_fit_ls_without_free_run_has_the_same_estimate(record):
    m, _ = record
    model = RegressionModel(P.Vs, P.delta, lag=True, stribeck=True, offset=True)
    a = fit_ls(model, m.u, m.w, Ts=DT)
    b = fit_ls(model, m.u, m.w, Ts=DT, free_run=False)
    assert np.array_equal(a.theta, b.theta)
    assert math.isnan(b.fit_free_run) and np.all(np.isnan(b.w_free_run))
    assert math.isfinite(a.fit_free_run)


@pytest.mark.parametrize("bad", [np.inf, np.nan, 1e60])
def test_overflowing_sensitivities_fall_back_to_differences(monkeypatch, bad):
    """Sensitivities that are not finite or exceed SENS_MAX (a tangent grown through a stop's ringing) are not a
    Jacobian: each trust-region fit is then taken with forward differences from its start, so that the fit is the
    difference-Jacobian fit to the bit (the same record as above), the fallbacks counted, and no scipy error."""
    from adaptive_ff.identification import physical_id

    rng = np.random.default_rng(0)
    _, u = bandlimited_noise(10.0, dt=DT, cutoff=1.0, std=1.2 * (P.Fs + P.sigma * math.radians(20.0)), rng=rng)
    m = sample(simulate(P, u, dt=DT), Ts=0.01, rng=rng)
    kw = dict(Vs=P.Vs, delta=P.delta, input_delay=0.5 * DT, n_bootstrap=0)
    want = fit_physical(m.t, m.u, m.w, **kw)
    exact = physical_id._OutputErrorProblem.jac

    def overflowing(self, x):
        G = exact(self, x)
        G[len(G) // 2, 0] = bad
        return G

    monkeypatch.setattr(physical_id._OutputErrorProblem, "jac", overflowing)
    got = fit_physical(m.t, m.u, m.w, jacobian="sensitivity", **kw)
    assert got.params == want.params and got.info["cost"] == want.info["cost"]
    assert got.info["sensitivity_fallbacks"] >= 1 and want.info["sensitivity_fallbacks"] == 0
    assert physical_id.SENS_MAX < 1e60
