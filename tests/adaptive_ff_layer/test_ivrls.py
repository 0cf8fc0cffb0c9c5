"""Recursive IV (adaptive_ff/csrc/aff_ivrls.c) and the eq4 estimator: the recursion against the batch weighted IV
estimate, consistency in a closed-loop ARX where least squares is biased, input rejection, the eq. 4 component's
instruments against rows built with numpy, and the closed-loop compensation on the paper preset."""

import math

import numpy as np
import pytest

from adaptive_ff.compensation.eq4_feedforward import AdaptiveFrictionFeedforward, AdaptiveFrictionFeedforwardConfig
from adaptive_ff.compensation.ivrls import IVRLS_NMAX, RecursiveIV
from adaptive_ff.identification.regression import RegressionModel
from adaptive_ff.identification.rls import RecursiveLeastSquares
from controllers.experiments.compare import compare
from plant import ParameterError, SignalError
from plant.friction import preset


def _batch_iv(Phi, Z, Y, lam, P0):
    """theta_N = (lam^N I/P0 + sum lam^(N-k) z phi')^-1 sum lam^(N-k) z y (theta_0 = 0), with numpy."""
    n, p = Phi.shape
    w = lam ** np.arange(n - 1, -1, -1.0)
    R = lam ** n * np.eye(p) / P0 + (Z * w[:, None]).T @ Phi
    return np.linalg.solve(R, (Z * w[:, None]).T @ Y), R


def test_recursion_equals_batch_weighted_iv():
    rng = np.random.default_rng(1)
    n, p, lam, P0 = 400, 4, 0.97, 10.0
    Phi = rng.standard_normal((n, p))
    Z = Phi + 0.5 * rng.standard_normal((n, p))  # correlated with phi, not equal
    Y = Phi @ np.array([1.0, -2.0, 0.5, 3.0]) + 0.1 * rng.standard_normal(n)
    iv = RecursiveIV(p, lam=lam, P0=P0, P_max=math.inf)
    hist = iv.update_many(Phi, Z, Y)
    assert iv.n_updates == n and iv.n_rejected == 0
    for k in (1, 5, 50, n):
        theta_k, _ = _batch_iv(Phi[:k], Z[:k], Y[:k], lam, P0)
        np.testing.assert_allclose(hist[k - 1], theta_k, rtol=1e-9, atol=1e-10)
    _, R = _batch_iv(Phi, Z, Y, lam, P0)
    np.testing.assert_allclose(iv.P @ R, np.eye(p), atol=1e-9)
    # the one-sample path gives the same numbers
    iv1 = RecursiveIV(p, lam=lam, P0=P0, P_max=math.inf)
    for a, b, y in zip(Phi, Z, Y):
        iv1.update(a, b, y)
    np.testing.assert_array_equal(iv1.theta, iv.theta)


def test_instruments_equal_regressors_is_the_rls():
    rng = np.random.default_rng(2)
    Phi = rng.standard_normal((300, 3))
    Y = Phi @ np.array([0.3, -1.0, 2.0]) + 0.2 * rng.standard_normal(300)
    iv = RecursiveIV(3, lam=0.99, P0=100.0, P_max=math.inf)
    rls = RecursiveLeastSquares(3, lam=0.99, P0=100.0, P_max=math.inf)
    iv.update_many(Phi, Phi, Y)
    rls.update_many(Phi, Y)
    np.testing.assert_allclose(iv.theta, rls.theta, rtol=1e-10)


def _closed_loop_arx(seed, N=20000, a=0.9, b=0.5, K=0.5, noise=0.5):
    """x(k) = a x(k-1) + b u(k-1), y = x + n measured, u = -K y + r (r a low-passed white noise): the equation error
    n(k) - a n(k-1) is correlated with y(k-1) and, through the feedback, with u(k-1); instruments y(k-2), u(k-2)."""
    rng = np.random.default_rng(seed)
    e0, n = rng.standard_normal(N), noise * rng.standard_normal(N)
    r, x, y, u = (np.zeros(N) for _ in range(4))
    for k in range(1, N):
        r[k] = 0.95 * r[k - 1] + e0[k]
        x[k] = a * x[k - 1] + b * u[k - 1]
        y[k] = x[k] + n[k]
        u[k] = -K * y[k] + r[k]
    k = np.arange(3, N)
    return np.column_stack([y[k - 1], u[k - 1]]), np.column_stack([y[k - 2], u[k - 2]]), y[k]


@pytest.mark.parametrize("seed", [0, 1])
def test_iv_consistent_where_least_squares_is_biased(seed):
    Phi, Z, y = _closed_loop_arx(seed)
    ls = np.linalg.lstsq(Phi, y, rcond=None)[0]
    iv = RecursiveIV(2, lam=1.0, P0=1e6)
    iv.update_many(Phi, Z, y)
    # least squares: b about 0.587 instead of 0.5, a about 0.874 instead of 0.9 (measured, seeds 0-2)
    assert ls[1] - 0.5 > 0.07 and 0.9 - ls[0] > 0.02
    np.testing.assert_allclose(iv.theta, [0.9, 0.5], atol=0.005)


def test_guard_gives_the_batch_iv_of_the_accepted_samples():
    """With guard, updates with phi'P z < 0 are refused; the estimate is the batch IV estimate of the others."""
    rng = np.random.default_rng(4)
    n, p, lam, P0 = 300, 3, 0.99, 1.0
    Phi = rng.standard_normal((n, p))
    Z = Phi + 1.5 * rng.standard_normal((n, p))  # weak instruments: some rows oppose their regressor
    Y = Phi @ np.array([1.0, 0.5, -1.0]) + 0.1 * rng.standard_normal(n)
    iv = RecursiveIV(p, lam=lam, P0=P0, P_max=math.inf, guard=True)
    ok = np.zeros(n, bool)
    for k in range(n):
        P, theta = iv.P.copy(), iv.theta.copy()
        try:
            iv.update(Phi[k], Z[k], Y[k])
            ok[k] = True
            assert Phi[k] @ P @ Z[k] >= 0
        except SignalError:
            assert Phi[k] @ P @ Z[k] < 0 and np.array_equal(iv.theta, theta)
    assert 5 < np.sum(~ok) < n // 2 and iv.n_rejected == np.sum(~ok)
    # forgetting counts accepted updates only: weights lam^(number of accepted rows after the row)
    Pa, Za, Ya = Phi[ok], Z[ok], Y[ok]
    theta, _ = _batch_iv(Pa, Za, Ya, lam, P0)
    np.testing.assert_allclose(iv.theta, theta, rtol=1e-9)


def test_bad_input_refused_state_unchanged():
    iv = RecursiveIV(2, lam=0.99, P0=10.0)
    iv.update([1.0, 0.5], [1.0, 0.4], 2.0)
    theta, P = iv.theta.copy(), iv.P.copy()
    for phi, z, y in (([np.nan, 1.0], [1.0, 1.0], 1.0), ([1.0, 1.0], [np.inf, 1.0], 1.0),
                      ([1.0, 1.0], [1.0, 1.0], np.nan), ([1.0, 0.0], [-1e3, 0.0], 1.0)):  # the last: s <= 0

        with pytest.raises(SignalError):
            iv.update(phi, z, y)
        np.testing.assert_array_equal(iv.theta, theta)
        np.testing.assert_array_equal(iv.P, P)
    assert iv.n_updates == 1 and iv.n_rejected == 4
    with pytest.raises(SignalError, match="row 1"):
        iv.update_many([[1.0, 0.0], [np.nan, 0.0]], [[1.0, 0.0], [1.0, 0.0]], [1.0, 1.0])
    np.testing.assert_array_equal(iv.theta, theta)
    with pytest.raises(ParameterError, match="phi"):
        iv.update([1.0], [1.0, 1.0], 1.0)
    for kw in ({"lam": 0.0}, {"lam": 1.5}, {"P0": -1.0}, {"P_max": 0.0}, {"guard": 1}):
        with pytest.raises(ParameterError, match=next(iter(kw))):
            RecursiveIV(2, **kw)
    for n in (0, IVRLS_NMAX + 1, 2.0, True):
        with pytest.raises(ParameterError, match="n_params"):
            RecursiveIV(n)


def _g(w, Vs, d):
    return np.sign(w) * (1.0 - np.exp(-np.abs(w / Vs) ** d))


def _h(w, Vs, d):
    return np.sign(w) * np.exp(-np.abs(w / Vs) ** d)


def test_eq4_component_rows_and_gate_match_numpy():
    """The C component's IV updates equal a RecursiveIV fed with phi(k) and z(k) (phi with w(k-3), w(k-4) for w(k-1),
    w(k-2)) built here with numpy on the samples the sliding gate passes."""
    Vs, d, band, lam, P0 = 0.02, 1.0, 0.05, 0.99, 1e4
    rng = np.random.default_rng(3)
    t = np.arange(600) * 0.01
    w = 0.3 * np.sin(2 * np.pi * 0.4 * t) + 1e-3 * rng.standard_normal(t.size)
    u = 30.0 * np.sign(w) + 40.0 * w + 2.0 * rng.standard_normal(t.size)
    ok = np.ones(t.size, bool)
    c = AdaptiveFrictionFeedforward(RegressionModel(Vs, d, lag=True), dt=0.001,
                                    config=AdaptiveFrictionFeedforwardConfig(Ts=0.01, lam=lam, P0=P0, warmup=0,
                                                                             iv=True, w_band=band))
    ref = RecursiveIV(6, lam=lam, P0=P0, guard=True)
    n_gated = 0
    n_refused = 0
    for k in range(t.size):
        ok[k] = c.observe(u[k], w[k])
        if k < 1:
            continue
        w1, w2 = w[k - 1], w[max(k - 2, 0)]
        if not (min(abs(w[k]), abs(w1), abs(w2)) > band and np.sign(w[k]) == np.sign(w1) == np.sign(w2)):
            n_gated += 1
            continue
        if k < 4:
            continue
        phi = [w1, -w2, u[k], -u[k - 1], -_g(w1, Vs, d), -_h(w1, Vs, d)]
        z = [w[k - 3], -w[k - 4], u[k], -u[k - 1], -_g(w[k - 3], Vs, d), -_h(w[k - 3], Vs, d)]
        try:
            ref.update(phi, z, w[k])
        except SignalError:  # phi'P z < 0: refused by both, the sample still enters the past
            n_refused += 1
            assert not ok[k]
    assert c.n_gated == n_gated > 50 and c.ivrls.n_updates == ref.n_updates > 300
    assert c.n_rejected == n_refused == np.sum(~ok)
    np.testing.assert_allclose(c.theta, ref.theta, rtol=1e-7)  # g, h: C exp/pow against numpy
    # a bad sample: refused, the state unchanged but the counter
    before = c.struct_bytes()
    assert not c.observe(np.nan, 0.1)
    theta = c.theta.copy()
    assert not c.observe(np.nan, 0.1)
    assert c.n_rejected == n_refused + 2 and c.theta.tolist() == theta.tolist()
    assert len(before) == len(c.struct_bytes())
    with pytest.raises(ParameterError, match="w_band"):
        AdaptiveFrictionFeedforward(RegressionModel(Vs, d), dt=0.001,
                                    config=AdaptiveFrictionFeedforwardConfig(Ts=0.01, w_band=-1.0))


def test_closed_loop_eta_paper_preset():
    """Mode adaptive with eq4 (IV) on the paper preset (seed 0, 120 s), the feedforward alone (no residual switch-in):
    eta 1.002 measured (docs/benchmarks/compensation.md); the paper's RLS alone on the same scenario 0.68 (its
    biased estimate is backed off by the supervisor for 11 s, 0.15 where it was switched back on at a stuck joint).
    With the switch-in (the default) the paper's RLS hands over to the residual observer and reaches 0.996."""
    res = {(e, sw): compare(preset("paper"), modes=("none", "adaptive"), estimator=e, seed=0, switch_in=sw,
                            progress=False)
           for e, sw in (("eq4-rls", False), ("eq4", False), ("eq4-rls", True))}
    assert res["eq4", False].eta["adaptive"] >= 0.98
    assert res["eq4-rls", False].eta["adaptive"] < 0.8
    assert res["eq4-rls", True].eta["adaptive"] >= 0.98
    assert res["eq4-rls", True].results["adaptive"].info["t_switch_in"] is not None
    assert res["eq4-rls", False].results["adaptive"].info.get("t_switch_in") is None
    info = res["eq4", False].results["adaptive"].info
    assert info["estimator"] == "eq4" and info["n_gated"] > 0 and info["lam"] == 1.0 - 0.002 / 5.0
