"""RLS windup protection (covariance bound, directional forgetting) and projection onto parameter bounds."""

import math

import numpy as np
import pytest
from scipy.optimize import minimize

from adaptive_ff.identification.rls import RecursiveLeastSquares
from plant import ParameterError

# the sliding estimator's structure: theta = (J, J*tau, tau, Fc, Fs, sigma, offset)
THETA_TRUE = np.array([4.0, 0.08, 0.02, 25.0, 35.0, 40.0, 0.5])
N_PARAMS = THETA_TRUE.size


def _excited(rls, rng, n=300):
    """Rich excitation first, so that P is small and theta has converged."""
    for _ in range(n):
        phi = rng.normal(size=N_PARAMS) * np.array([1.0, 5.0, 300.0, 1.0, 0.5, 0.3, 1.0])
        rls.update(phi, phi @ THETA_TRUE + 1e-3 * rng.normal())


def _no_excitation(rls, rng, n):
    """n/2 updates at constant velocity (constant regressor), then n/2 at standstill (only the offset column)."""
    const = np.array([0.0, 0.0, 0.0, 0.99, 0.01, 0.2, 1.0])  # filtered regressors at w = 0.2 rad/s, settled
    still = np.zeros(N_PARAMS)
    still[-1] = 1.0
    noise = 1e-3 * rng.normal(size=n)
    upd = rls.update
    max_eig = 0.0
    for k, (phi, y0) in enumerate(((const, const @ THETA_TRUE), (still, still @ THETA_TRUE))):
        for e in noise[k * (n // 2):(k + 1) * (n // 2)].tolist():
            upd(phi, y0 + e)
        max_eig = max(max_eig, float(np.linalg.eigvalsh(rls.P)[-1]) if np.all(np.isfinite(rls.P)) else np.inf)
    return max_eig


def test_plain_exponential_forgetting_winds_up_at_lam_085():
    """The problem: eqs. 10-13 (``P_max=inf``, by name) with lam = 0.85 divide the unexcited part of P by 0.85
    per update."""
    rng = np.random.default_rng(0)
    rls = RecursiveLeastSquares(N_PARAMS, lam=0.85, P0=1e4, P_max=math.inf)
    _excited(rls, rng)
    with np.errstate(over="ignore", invalid="ignore"):
        _no_excitation(rls, rng, 2000)
        top = np.max(np.abs(rls.P))
    assert not np.isfinite(top) or top > 1e60  # 0.85**-1000 = 1e70: it grows without bound


def test_covariance_bound_keeps_P_bounded_and_theta_still_over_a_million_updates_at_lam_085():
    rng = np.random.default_rng(1)
    P0 = 1e4
    rls = RecursiveLeastSquares(N_PARAMS, lam=0.85, P0=P0, P_max=N_PARAMS * P0)
    _excited(rls, rng)
    theta0 = rls.theta.copy()
    np.testing.assert_allclose(theta0, THETA_TRUE, rtol=1e-3, atol=1e-3)
    max_eig = _no_excitation(rls, rng, 1_000_000)
    assert rls.n_updates == 300 + 1_000_000
    # bounded: trace(P) <= P_max holds after every update, so every eigenvalue is below it
    assert np.all(np.isfinite(rls.P)) and max_eig <= N_PARAMS * P0
    assert float(np.trace(rls.P)) <= N_PARAMS * P0 * (1 + 1e-9)
    assert np.linalg.eigvalsh(rls.P)[0] > 0 and np.array_equal(rls.P, rls.P.T)
    # theta does not drift: the data (consistent with THETA_TRUE up to 1e-3 noise) move it only along the
    # excited directions, by about the noise level
    np.testing.assert_allclose(rls.theta, theta0, atol=0.05)
    assert abs(rls.theta[-1] - THETA_TRUE[-1]) < 0.01  # the offset, excited at standstill, stays right


def test_directional_forgetting_keeps_P_bounded_without_excitation_at_lam_085():
    rng = np.random.default_rng(2)
    rls = RecursiveLeastSquares(N_PARAMS, lam=0.85, P0=1e4, forgetting="directional")
    _excited(rls, rng)
    theta0, P_exc = rls.theta.copy(), rls.P.copy()
    max_eig = _no_excitation(rls, rng, 100_000)
    # only the excited directions are forgotten: phi @ P @ phi -> (1 - lam)/lam; the rest of P is untouched
    const = np.array([0.0, 0.0, 0.0, 0.99, 0.01, 0.2, 1.0])
    still = np.eye(N_PARAMS)[-1]
    assert still @ rls.P @ still == pytest.approx((1 - 0.85) / 0.85, rel=1e-6)
    assert max_eig < 1e4 * (1 + 1e-9) and np.all(np.isfinite(rls.P))
    assert np.linalg.eigvalsh(rls.P)[0] > 0
    assert const @ rls.P @ const < 10 * const @ P_exc @ const + 1.0
    np.testing.assert_allclose(rls.theta, theta0, atol=0.05)


def test_directional_forgetting_with_lam_1_is_ordinary_rls():
    rng = np.random.default_rng(3)
    a = RecursiveLeastSquares(3, lam=1.0, P0=10.0)
    b = RecursiveLeastSquares(3, lam=1.0, P0=10.0, forgetting="directional")
    for _ in range(200):
        phi = rng.normal(size=3)
        y = phi @ [1.0, 2.0, 3.0] + 0.1 * rng.normal()
        assert a.update(phi, y) == pytest.approx(b.update(phi, y), rel=1e-10, abs=1e-12)
    np.testing.assert_allclose(a.theta, b.theta, rtol=1e-10)
    np.testing.assert_allclose(a.P, b.P, rtol=1e-8, atol=1e-14)


def test_projection_is_the_P_metric_projection_for_one_active_bound():
    """After an update that leaves the box, theta equals argmin (x - t)^T P^-1 (x - t) over the box."""
    rng = np.random.default_rng(4)
    n = 4
    lower = np.array([0.0, -np.inf, 0.0, -np.inf])
    upper = np.full(n, np.inf)
    A = rng.normal(size=(n, n))
    P0 = A @ A.T + 0.5 * np.eye(n)  # a full (coupled) covariance
    theta0 = np.array([1.0, 1.0, 20.0, 1.0])
    rls = RecursiveLeastSquares(n, lam=0.99, P0=P0, theta0=theta0, bounds=(lower, upper))
    free = RecursiveLeastSquares(n, lam=0.99, P0=P0, theta0=theta0)
    phi = np.array([1.0, 0.3, 0.0, -0.2])
    y = phi @ theta0 - 8.0
    rls.update(phi, y)  # drives theta_0 below its bound 0
    free.update(phi, y)
    t_free, P = free.theta, free.P
    assert t_free[0] < 0 and t_free[2] >= 0  # exactly one bound is violated
    Pi = np.linalg.inv(P)
    res = minimize(lambda x: (x - t_free) @ Pi @ (x - t_free), np.maximum(t_free, 0.0),
                   jac=lambda x: 2 * Pi @ (x - t_free), bounds=list(zip(lower, upper)), method="L-BFGS-B",
                   options={"ftol": 1e-15, "gtol": 1e-12})
    np.testing.assert_allclose(rls.theta, res.x, atol=1e-6)
    assert rls.theta[0] == 0.0 and rls.n_projected >= 1
    np.testing.assert_array_equal(rls.P, P)  # projection does not touch P


def test_bounds_and_P_max_are_validated():
    with pytest.raises(ParameterError, match="forgetting"):
        RecursiveLeastSquares(2, forgetting="sliding-window")
    with pytest.raises(ParameterError, match="P_max"):
        RecursiveLeastSquares(2, P_max=-1.0)
    with pytest.raises(ParameterError, match="lower <= upper"):
        RecursiveLeastSquares(2, bounds=([1.0, 0.0], [0.0, 1.0]))
    with pytest.raises(ParameterError, match="outside the bounds"):
        RecursiveLeastSquares(2, theta0=[-1.0, 0.0], bounds=([0.0, 0.0], [1.0, 1.0]))


def test_default_rls_is_windup_safe_at_lam_085():
    """Regression: with default settings lam = 0.85 overflowed after about 4,400 updates without excitation
    and stayed NaN; the default covariance bound trace(P) <= trace(P0) keeps P finite and theta where it was."""
    rng = np.random.default_rng(5)
    rls = RecursiveLeastSquares(3, lam=0.85)
    assert rls.P_max == pytest.approx(3e4)
    for _ in range(300):
        phi = rng.normal(size=3)
        rls.update(phi, phi @ [1.0, 2.0, 3.0])
    theta0 = rls.theta.copy()
    plain = RecursiveLeastSquares(3, lam=0.85, P_max=math.inf)
    plain.theta, plain.P = rls.theta, rls.P
    phi = np.array([1.0, 0.0, 0.0])
    with np.errstate(over="ignore", invalid="ignore"):
        for _ in range(20_000):
            rls.update(phi, 1.0)
            try:
                plain.update(phi, 1.0)
            except Exception:  # noqa: BLE001 - the plain update overflows: refused now (it used to go NaN)
                pass
    assert np.all(np.isfinite(rls.P)) and np.trace(rls.P) <= 3e4 * (1 + 1e-12)
    assert rls.theta[0] == pytest.approx(1.0, abs=1e-9) and np.allclose(rls.theta[1:], theta0[1:], atol=1e-6)
    assert rls.n_updates == 20_300 and rls.n_rejected == 0
    # the paper's plain update winds up until its update would overflow; from then on it refuses the samples
    # (counted, state finite) instead of going NaN
    assert plain.n_rejected > 0 and np.all(np.isfinite(plain.theta)) and np.max(plain.P) > 1e100
