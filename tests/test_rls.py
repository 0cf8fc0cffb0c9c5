"""RLS (eqs. 10-13): batch equivalence, an independent Kalman-filter formulation, numerical health, input checks."""

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter

from adaptive_ff.ls import fit_ls
from adaptive_ff.regression import RegressionModel
from adaptive_ff.rls import RecursiveLeastSquares
from plant import JointParams, ParameterError, SignalError, bandlimited_noise, sample, simulate

P_TRUE = JointParams(J=4.0, Fc=25.0, Fs=35.0, Vs=0.02, delta=1.0, sigma=40.0, tau=0.02)


def _identification_data(seed=0, duration=30.0, Ts=0.01):
    rng = np.random.default_rng(seed)
    _, u = bandlimited_noise(duration, cutoff=1.0, std=40.0, rng=rng)
    m = sample(simulate(P_TRUE, u), Ts=Ts, noise_std=2e-3, rng=rng)
    model = RegressionModel(P_TRUE.Vs, P_TRUE.delta)
    X, y = model.regressors(m.u, m.w)
    return model, m, X, y


def test_rls_lam1_equals_ridge_batch_ls():
    model, m, X, y = _identification_data()
    p0 = 1e3
    rls = RecursiveLeastSquares(X.shape[1], lam=1.0, P0=p0)
    for phi, yk in zip(X, y):
        rls.update(phi, yk)
    batch = fit_ls(model, m.u, m.w, Ts=m.Ts, ridge=1.0 / p0)
    np.testing.assert_allclose(rls.theta, batch.theta, rtol=1e-8, atol=1e-8 * np.max(np.abs(batch.theta)))
    # and P equals the inverse of the regularised information matrix
    info = X.T @ X + np.eye(X.shape[1]) / p0
    np.testing.assert_allclose(rls.P @ info, np.eye(X.shape[1]), atol=1e-6)


@pytest.mark.parametrize("lam", [1.0, 0.98, 0.85])
def test_rls_matches_filterpy_kalman_filter_with_fading_memory(lam):
    _, _, X, y = _identification_data(seed=1, duration=5.0)
    n = X.shape[1]
    rls = RecursiveLeastSquares(n, lam=lam, P0=100.0)
    kf = KalmanFilter(dim_x=n, dim_z=1)
    kf.x = np.zeros((n, 1))
    kf.P = 100.0 * np.eye(n)
    kf.F = np.eye(n)
    kf.Q = np.zeros((n, n))
    kf.R = np.eye(1)
    kf.alpha = lam ** -0.5  # P- = P / lam
    for phi, yk in zip(X, y):
        e = rls.update(phi, yk)
        kf.predict()
        e_kf = yk - float(phi @ kf.x[:, 0])
        kf.update(np.array([[yk]]), H=phi.reshape(1, n))
        assert e == pytest.approx(e_kf, rel=1e-6, abs=1e-9)
    scale = np.max(np.abs(rls.theta))
    np.testing.assert_allclose(rls.theta, kf.x[:, 0], rtol=1e-6, atol=1e-8 * scale)
    np.testing.assert_allclose(rls.P, kf.P, rtol=1e-5, atol=1e-9 * np.max(np.abs(kf.P)))


def test_P_stays_exactly_symmetric_and_positive_definite_over_1e6_updates():
    rng = np.random.default_rng(7)
    n = 6
    rls = RecursiveLeastSquares(n, lam=0.999, P0=1e4)
    theta_true = rng.normal(size=n)
    phis = rng.normal(size=(1_000_000, n))
    ys = phis @ theta_true + 1e-3 * rng.normal(size=phis.shape[0])
    upd = rls.update
    for phi, yk in zip(phis, ys.tolist()):
        upd(phi, yk)
    assert np.array_equal(rls.P, rls.P.T)
    assert np.linalg.eigvalsh(rls.P)[0] > 0
    np.testing.assert_allclose(rls.theta, theta_true, atol=1e-3)


def test_rejected_sample_leaves_state_unchanged():
    rls = RecursiveLeastSquares(3, lam=0.99)
    rls.update([1.0, 2.0, 3.0], 1.0)
    theta, P, n = rls.theta.copy(), rls.P.copy(), rls.n_updates
    for phi, y in (([np.nan, 0, 0], 1.0), ([1.0, 0, 0], np.inf), ([1.0, 2.0], 1.0)):
        with pytest.raises(SignalError):
            rls.update(phi, y)
    assert np.array_equal(rls.theta, theta) and np.array_equal(rls.P, P) and rls.n_updates == n


@pytest.mark.parametrize("lam", [0.0, -0.5, 1.0000001, float("nan")])
def test_lam_outside_unit_interval_is_rejected_with_value(lam):
    with pytest.raises(ParameterError, match="lam"):
        RecursiveLeastSquares(2, lam=lam)


def test_default_initial_theta_is_zero_and_P0_validated():
    assert np.array_equal(RecursiveLeastSquares(4).theta, np.zeros(4))
    with pytest.raises(ParameterError, match="positive definite"):
        RecursiveLeastSquares(2, P0=np.diag([1.0, -1.0]))
    with pytest.raises(ParameterError, match="shape"):
        RecursiveLeastSquares(2, P0=np.eye(3))
