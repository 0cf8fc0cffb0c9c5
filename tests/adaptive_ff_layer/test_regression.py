"""The discrete model of eq. 4 is derived, not copied: exact recovery, steady state, the erratum."""

import numpy as np
import pytest

from adaptive_ff.identification.ls import fit_ls
from adaptive_ff.identification.regression import (RegressionModel, g_regressor, h_regressor, nrmse_fit, theta_from_physical,
                                    theta_from_physical_printed)
from plant import ExcitationError, JointParams, ParameterError, SignalError, bandlimited_noise, stribeck

TRUE = JointParams(J=4.0, Fc=25.0, Fs=35.0, Vs=0.02, delta=1.0, sigma=40.0, tau=0.02)
TS = 0.01


def _discrete_data(p, model, seed=1, n_seconds=60.0, offset=0.0):
    rng = np.random.default_rng(seed)
    _, u = bandlimited_noise(n_seconds, dt=TS, cutoff=1.0, std=40.0, rng=rng)
    theta = model.theta_from_physical(p, TS, offset=offset)
    w = model.simulate(theta, u, [0.0, 0.0])
    return u, w, theta


@pytest.mark.parametrize("p", [TRUE, TRUE.replace(delta=-0.7, Vs=0.05, tau=0.08, J=0.3),
                               TRUE.replace(tau=0.005, sigma=2.0, Fs=26.0)])
def test_ls_recovers_discrete_model_to_machine_precision(p):
    model = RegressionModel(p.Vs, p.delta)
    u, w, theta = _discrete_data(p, model)
    res = fit_ls(model, u, w, Ts=TS)
    assert np.max(np.abs(res.theta - theta) / np.abs(theta)) <= 1e-9
    est = res.estimate
    for name in ("J", "tau", "sigma", "Fc", "Fs"):
        assert getattr(est, name) == pytest.approx(getattr(p, name), rel=1e-6), name
    assert est.J_alt == pytest.approx(p.J, rel=1e-6)
    assert res.fit_one_step == pytest.approx(100.0, abs=1e-6)
    assert res.residual_rms < 1e-10


def test_offset_and_coulomb_structure_recovered():
    p = TRUE.replace(Fs=TRUE.Fc)  # Coulomb + viscous plant: Fs = Fc
    model = RegressionModel(stribeck=False, offset=True)
    u, w, theta = _discrete_data(p, model, offset=-3.0)
    est = fit_ls(model, u, w, Ts=TS).estimate
    assert est.offset == pytest.approx(-3.0, rel=1e-6)
    assert est.Fc == pytest.approx(p.Fc, rel=1e-6) and est.Fs == est.Fc
    assert est.J == pytest.approx(p.J, rel=1e-6)


def test_corrected_coefficients_satisfy_steady_state_and_printed_do_not():
    # At constant w > 0, u: w = a1 w - a2 w + b0 u - b1 u - c1 g - d1 h  must give u = F(w).
    w = 0.1
    u_true = stribeck(w, Fc=TRUE.Fc, Fs=TRUE.Fs, Vs=TRUE.Vs, delta=TRUE.delta, sigma=TRUE.sigma)
    g, h = g_regressor(w, TRUE.Vs, TRUE.delta), h_regressor(w, TRUE.Vs, TRUE.delta)
    for theta, ok in ((theta_from_physical(TRUE, TS)[:6], True), (theta_from_physical_printed(TRUE, TS), False)):
        a1, a2, b0, b1, c1, d1 = theta
        u_ss = (w * (1 - a1 + a2) + c1 * g + d1 * h) / (b0 - b1)
        if ok:
            assert u_ss == pytest.approx(u_true, rel=1e-12)
        else:
            assert abs(u_ss - u_true) / u_true > 1.0  # the printed formulas are grossly off


def test_corrected_coefficients_match_backward_difference_of_eq2_directly():
    # Independent computation: plug a random sequence into the difference form of eq. 2.
    rng = np.random.default_rng(3)
    w = rng.normal(size=3)
    u = rng.normal(size=2)
    J, tau, sig = TRUE.J, TRUE.tau, TRUE.sigma
    # J*tau*w'' + J*w' + sigma*w(k) + Fc*g + Fs*h = u + tau*u' ; solve for w(k)
    model = RegressionModel(TRUE.Vs, TRUE.delta)
    theta = theta_from_physical(TRUE, TS)[:6]
    wk = model.phi(u[1], u[0], w[1], w[0]) @ theta
    d1w = (wk - w[1]) / TS
    d2w = (wk - 2 * w[1] + w[0]) / TS**2
    fr = TRUE.Fc * g_regressor(w[1], TRUE.Vs, TRUE.delta) + TRUE.Fs * h_regressor(w[1], TRUE.Vs, TRUE.delta)
    lhs = J * tau * d2w + J * d1w + sig * wk + fr
    rhs = u[1] + tau * (u[1] - u[0]) / TS
    assert lhs == pytest.approx(rhs, rel=1e-9, abs=1e-9)


def test_regressors_are_not_nan_at_zero_velocity_for_negative_delta():
    with np.errstate(all="raise"):
        assert g_regressor(0.0, 0.02, -1.0) == 0.0
        assert h_regressor(np.zeros(3), 0.02, -1.0).tolist() == [0.0, 0.0, 0.0]


def test_no_excitation_is_a_typed_error():
    model = RegressionModel(0.02, 1.0)
    u = np.full(200, 10.0)
    w = np.full(200, 0.1)
    with pytest.raises(ExcitationError, match="excitation|zero"):
        fit_ls(model, u, w, Ts=TS)


def test_bad_input_errors_name_the_argument():
    model = RegressionModel(0.02, 1.0)
    u = np.ones(50)
    w = np.ones(50)
    w[7] = np.nan
    with pytest.raises(SignalError, match=r"w has a non-finite value nan at index 7"):
        fit_ls(model, u, w, Ts=TS)
    with pytest.raises(SignalError, match="length 50"):
        fit_ls(model, u, w[:40], Ts=TS)
    with pytest.raises(ParameterError, match="Ts must be > 0, got -0.01"):
        fit_ls(model, u, np.ones(50), Ts=-0.01)
    with pytest.raises(ParameterError, match="Vs and delta"):
        RegressionModel()


def test_nrmse_fit_matches_definition():
    y = np.array([1.0, 2.0, 3.0, 4.0])
    yh = y + np.array([0.1, -0.1, 0.1, -0.1])
    expected = 100 * (1 - 0.2 / np.sqrt(5.0))
    assert nrmse_fit(y, yh) == pytest.approx(expected, rel=1e-12)
