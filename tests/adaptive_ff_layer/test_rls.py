"""RLS (eqs. 10-13): batch equivalence, an independent Kalman-filter formulation, the closed-form weighted least
squares and the information form (tests/rls_oracle.py), numerical health, input checks."""

import math
import copy
import pickle

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter

from adaptive_ff.identification.ls import fit_ls
from adaptive_ff.identification.regression import RegressionModel
from adaptive_ff.identification.rls import RLS_NMAX, RecursiveLeastSquares
from plant import JointParams, ParameterError, SignalError, bandlimited_noise, sample, simulate
from rls_oracle import InformationRLS, weighted_ls_path

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
    rls = RecursiveLeastSquares(n, lam=lam, P0=100.0, P_max=math.inf)  # the paper's plain eqs. 10-13
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


# ---- the C update (aff_rls_step) against the oracle's closed form and information form (tests/rls_oracle.py) ----

CONFIGS = [
    dict(lam=1.0),
    dict(lam=0.97),
    dict(lam=0.85, P_max=50.0),
    dict(lam=0.9, forgetting="directional"),
    dict(lam=[0.99, 0.95, 0.9, 0.999], P_max=300.0),
    dict(lam=0.95, bounds=([-0.5, 0.0, -np.inf, -1.0], [0.5, np.inf, 2.0, 1.0])),
]


def _stream(rng, n=400, p=4):
    phi = rng.normal(size=(n, p)) * np.array([1.0, 3.0, 0.3, 1.0])
    phi[n // 2:n // 2 + 60] = phi[n // 2]  # a constant regressor: no excitation, the P_max / directional paths
    y = phi @ np.array([0.4, 1.5, -2.0, 0.7]) + 0.05 * rng.normal(size=n)
    return phi, y


@pytest.mark.parametrize("lam", [1.0, 0.97, 0.85])
def test_exponential_forgetting_equals_the_weighted_least_squares_closed_form(lam):
    """Eqs. 10-13 without a covariance bound: after every sample the estimate minimises the exponentially
    weighted squares plus the forgotten prior (numpy.linalg.lstsq on the whole window), and P is the inverse of
    the weighted information matrix. Measured agreement 1e-14; a sign or a factor lam misplaced is O(1)."""
    rng = np.random.default_rng(5)
    phi = rng.normal(size=(300, 4)) * np.array([1.0, 3.0, 0.3, 1.0])
    y = phi @ np.array([0.4, 1.5, -2.0, 0.7]) + 0.05 * rng.normal(size=300)
    theta0 = [1.0, 0.0, 0.0, -1.0]
    rls = RecursiveLeastSquares(4, lam=lam, P0=10.0, theta0=theta0, P_max=math.inf)
    e = np.array([rls.update(phi[k], y[k]) for k in range(100)])
    hist = rls.update_many(phi[100:], y[100:])
    theta_ls, P_ls, e_ls = weighted_ls_path(phi, y, lam=lam, P0=10.0, theta0=theta0)
    scale = np.max(np.abs(theta_ls))
    np.testing.assert_allclose(hist, theta_ls[100:], rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(e, e_ls[:100], rtol=0, atol=1e-12 * np.max(np.abs(y)))
    np.testing.assert_allclose(rls.P, P_ls, rtol=0, atol=1e-12 * np.max(np.abs(P_ls)))


@pytest.mark.parametrize("cfg", CONFIGS, ids=lambda c: "-".join(f"{k}" for k in c) + f"-{c['lam']}")
def test_update_equals_update_many_bitwise_and_the_information_form(cfg):
    """Every scheme (covariance bound, directional and vector forgetting, projection) against the information
    form of tests/rls_oracle.py; measured agreement 4e-14 relative, asserted to 1e-12."""
    phi, y = _stream(np.random.default_rng(3))
    a = RecursiveLeastSquares(4, P0=10.0, **cfg)
    b = RecursiveLeastSquares(4, P0=10.0, **cfg)
    o = InformationRLS(4, P0=10.0, **cfg)
    hist = b.update_many(phi, y)
    for k in range(len(y)):
        e = a.update(phi[k], y[k])
        e_o = o.update(phi[k], y[k])
        assert np.array_equal(a.theta, hist[k])
        assert e == pytest.approx(e_o, rel=1e-12, abs=1e-12)
        np.testing.assert_allclose(a.theta, o.theta, rtol=0, atol=1e-12 * max(1.0, np.max(np.abs(o.theta))))
        P_o = o.P
        np.testing.assert_allclose(a.P, P_o, rtol=0, atol=1e-12 * np.max(np.abs(P_o)))
    assert np.array_equal(a.P, b.P) and np.array_equal(a.P, a.P.T)
    assert a.n_updates == b.n_updates == o.n_updates == len(y)
    assert a.n_projected == b.n_projected == o.n_projected


def test_the_streams_reach_the_covariance_bound_and_the_box():
    """The comparisons above run through the bound (without it, trace(P) grows far beyond P_max while the
    regressor is constant) and the projection."""
    phi, y = _stream(np.random.default_rng(3))
    top = {}
    for P_max in (50.0, math.inf):
        rls = RecursiveLeastSquares(4, P0=10.0, lam=0.85, P_max=P_max)
        rls.update_many(phi[:200], y[:200])
        traces = []
        for k in range(200, 260):
            rls.update(phi[k], y[k])
            traces.append(float(np.trace(rls.P)))
        top[P_max] = max(traces)
    assert top[50.0] <= 50.0 * (1.0 + 1e-12) < 10 * 50.0 < top[math.inf]
    box = RecursiveLeastSquares(4, P0=10.0, lam=0.95, bounds=CONFIGS[-1]["bounds"])
    box.update_many(phi, y)
    assert box.n_projected >= 1


def test_update_many_rejects_a_stream_with_a_bad_sample_and_keeps_the_state():
    rls = RecursiveLeastSquares(3, lam=0.99)
    rls.update_many(np.eye(3), [1.0, 2.0, 3.0])
    theta, P, n = rls.theta.copy(), rls.P.copy(), rls.n_updates
    phi = np.ones((5, 3))
    y = np.ones(5)
    y[3] = np.nan
    with pytest.raises(SignalError, match=r"sample 3.*Y\[3\] = nan"):
        rls.update_many(phi, y)
    phi[1, 2] = np.inf
    with pytest.raises(SignalError, match=r"sample 1"):
        rls.update_many(phi, np.ones(5))
    with pytest.raises(SignalError, match="Phi"):
        rls.update_many(np.ones((5, 2)), np.ones(5))
    with pytest.raises(SignalError, match="Y"):
        rls.update_many(np.ones((5, 3)), np.ones(4))
    assert np.array_equal(rls.theta, theta) and np.array_equal(rls.P, P) and rls.n_updates == n
    assert rls.update_many(np.empty((0, 3)), np.empty(0)).shape == (0, 3)


def test_update_accepts_lists_int_arrays_and_strided_rows_and_names_bad_values():
    X = np.arange(12.0).reshape(3, 4)
    ref = RecursiveLeastSquares(3, lam=0.98)
    rls = RecursiveLeastSquares(3, lam=0.98)
    for phi, y in (([1.0, 2.0, 3.0], 1), (np.array([1, 0, 2]), np.float32(0.5)), (X[:, 1], 2.0)):
        e = rls.update(phi, y)
        assert e == ref.update(np.array(phi, dtype=float), float(y))
    np.testing.assert_array_equal(rls.theta, ref.theta)
    ro = np.broadcast_to(np.array([0.5, 1.0, 0.0]), (2, 3))  # read-only views
    assert rls.update(ro[0], 1.0) == ref.update(np.array([0.5, 1.0, 0.0]), 1.0)
    np.testing.assert_array_equal(rls.update_many(ro, np.broadcast_to(2.0, (2,)))[-1],
                                  ref.update_many(np.array(ro), np.full(2, 2.0))[-1])
    with pytest.raises(SignalError, match="y must be finite, got nan"):
        rls.update([1.0, 2.0, 3.0], float("nan"))
    with pytest.raises(SignalError, match=r"phi has a non-finite entry.*inf"):
        rls.update(np.array([1.0, np.inf, 0.0]), 1.0)
    with pytest.raises(SignalError, match="shape"):
        rls.update(np.ones((3, 1)), 1.0)
    with pytest.raises(SignalError, match="y must be a number"):
        rls.update(np.ones(3), "a")
    np.testing.assert_array_equal(rls.theta, ref.theta)


def test_state_survives_copy_and_pickle_and_theta_assignment():
    rng = np.random.default_rng(0)
    rls = RecursiveLeastSquares(3, lam=0.9, bounds=([-1.0] * 3, [1.0] * 3))
    rls.update_many(rng.normal(size=(20, 3)), rng.normal(size=20))
    for twin in (copy.deepcopy(rls), pickle.loads(pickle.dumps(rls))):
        phi, y = rng.normal(size=3), 0.3
        assert twin.update(phi, y) == copy.deepcopy(rls).update(phi, y)
        assert twin.n_updates == 21 and twin.bounds is not None and twin.lam == 0.9
        assert not np.shares_memory(twin.theta, rls.theta)
    rls.theta = [0.5, 0.0, -0.5]
    rls.update(np.zeros(3), 0.0)  # phi = 0: theta unchanged, P / lam
    np.testing.assert_array_equal(rls.theta, [0.5, 0.0, -0.5])
    with pytest.raises(ParameterError, match="theta"):
        rls.theta = np.zeros(4)


def test_more_parameters_than_the_c_struct_holds_are_refused_with_the_limit():
    """The C struct has room for AFF_RLS_NMAX parameters; the wrapper refuses more by name, not by a crash."""
    full = RecursiveLeastSquares(RLS_NMAX, lam=0.99)
    full.update(np.ones(RLS_NMAX), 1.0)
    np.testing.assert_allclose(full.theta, np.full(RLS_NMAX, 1.0 / RLS_NMAX), rtol=1e-3)
    with pytest.raises(ParameterError, match=f"n_params .* must be in 1..AFF_RLS_NMAX \\({RLS_NMAX}\\)"):
        RecursiveLeastSquares(RLS_NMAX + 1)
