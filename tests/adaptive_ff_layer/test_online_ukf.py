"""Tests of adaptive_ff.identification.online_ukf: joint UKF estimation of (Fc, Fs, Vs, delta, sigma, tau)."""

import math
import warnings
from dataclasses import fields

import numpy as np
import pytest

from adaptive_ff.identification.online_ukf import (PARAM_NAMES, STATE_NAMES, FilterDivergedError, OnlineUKF, OnlineUKFResult,
                                                   UKFOptions, convergence_time, run_online_ukf)
from plant.errors import ParameterError, SignalError
from plant.excitation import multisine_reference
from plant.friction import JointParams, preset
from plant.joint import make_rk4_step

PAPER = preset("paper")
TS = 0.01
NOISE = 1e-3  # rad/s


def closed_loop_stream(p, duration, seed):
    """PI velocity loop at Ts = 10 ms on the 1 kHz RK4 plant, multi-sine reference; u held over each interval.

    Returns t, u, w (measured, noisy) with u[k] the torque over (t[k-1], t[k]] (plant.sampling convention).
    """
    rng = np.random.default_rng(seed)
    ref = multisine_reference(duration, dt=TS, rng=rng)
    n = ref.t.size
    Kp = 30.0 * p.J
    Ki = Kp * 6.0
    step = make_rk4_step(p, 1e-3)
    noise = rng.normal(0.0, NOISE, n)
    u, wm = np.zeros(n), np.zeros(n)
    wm[0] = noise[0]
    w = f = integ = 0.0
    for k in range(n - 1):
        e = ref.w[k] - wm[k]
        uk = Kp * e + integ
        integ += Ki * TS * e
        for _ in range(10):
            w, f = step(w, f, uk)
        u[k + 1], wm[k + 1] = uk, w + noise[k + 1]
    return ref.t, u, wm


def truth(p):
    return {k: float(getattr(p, k)) for k in PARAM_NAMES}


def perturbed(p):
    """Initial guess 10-30 % off the truth (a previous estimate or the quasi-static pre-fit of a drifted joint)."""
    return {"Fc": 0.9 * p.Fc, "Fs": 1.1 * p.Fs, "Vs": 1.2 * p.Vs, "delta": 1.15 * p.delta, "sigma": 0.9 * p.sigma,
            "tau": 0.7 * p.tau}


# --------------------------------------------------------------------------- recovery on a short noisy stream


@pytest.mark.parametrize("delta", [1.0, -1.0])
def test_ukf_recovers_all_six_parameters_on_a_20s_noisy_stream(delta):
    p = JointParams(**dict(PAPER.to_dict(), delta=delta))
    t, u, w = closed_loop_stream(p, 20.0, seed=0)
    th0 = perturbed(p)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        res = run_online_ukf(t, u, w, J=p.J, theta0=th0, noise_std=NOISE)
    assert isinstance(res, OnlineUKFResult)
    tr = truth(p)
    err = {k: abs(res.final[k] / tr[k] - 1.0) for k in PARAM_NAMES}
    err0 = {k: abs(th0[k] / tr[k] - 1.0) for k in PARAM_NAMES}
    # stated tolerances: Stribeck factors within 10 %, levels within 3 %, lag within 5 %
    tol = {"Fc": 0.03, "Fs": 0.03, "Vs": 0.10, "delta": 0.10, "sigma": 0.03, "tau": 0.05}
    for k in PARAM_NAMES:
        assert err[k] < tol[k], (k, res.final[k], tr[k])
        assert err[k] < 0.5 * err0[k], (k, err[k], err0[k])  # at least halves the initial error
    assert np.sign(res.final["delta"]) == np.sign(delta)  # the curve branch is kept
    # histories: shapes, start at the guess, all finite
    for k in PARAM_NAMES:
        assert res.theta[k].shape == t.shape and res.theta_std[k].shape == t.shape
        assert res.theta[k][0] == pytest.approx(th0[k], rel=1e-12)
        assert np.all(np.isfinite(res.theta[k])) and np.all(res.theta_std[k] > 0)
    # the filtered velocity follows the measurement to about the noise level (innovations white-ish, small)
    assert np.std(res.innovation[100:]) < 3 * NOISE
    assert res.x.shape == (8,) and res.P.shape == (8, 8)
    np.testing.assert_allclose(res.P, res.P.T, rtol=0, atol=0)


# --------------------------------------------------------------------------- process model, parametrisation


def test_prediction_equals_plant_rk4_over_the_interval():
    # with a huge measurement noise the update does (almost) nothing, so the state after one sample is the
    # process model: 10 RK4 steps of 1 ms of eqs. 1-2 with u held -- the plant's own integrator (independent)
    p = PAPER
    est = OnlineUKF(J=p.J, theta0=truth(p), noise_std=1e6, w0=0.05, f0=10.0,
                    options=UKFOptions(std0={k: 1e-9 for k in STATE_NAMES}, q={k: 0.0 for k in STATE_NAMES},
                                       crossing_gate=False))
    step = make_rk4_step(p, 1e-3)
    w, f = 0.05, 10.0
    for _ in range(10):
        w, f = step(w, f, 40.0)
    est.update(40.0, 0.0, TS)
    assert est.x[0] == pytest.approx(w, rel=1e-9, abs=1e-12)
    assert est.x[1] == pytest.approx(f, rel=1e-9, abs=1e-12)
    for k, v in truth(p).items():
        assert est.theta[k] == pytest.approx(v, rel=1e-9)


def test_theta_maps_the_log_parametrisation_and_keeps_the_sign_of_delta():
    th0 = {"Fc": 20.0, "Fs": 30.0, "Vs": 0.03, "delta": -1.5, "sigma": 35.0, "tau": 0.01}
    est = OnlineUKF(J=4.0, theta0=th0, noise_std=NOISE)
    x = est.x
    assert x[4] == pytest.approx(math.log(0.03)) and x[5] == pytest.approx(math.log(1.5))
    assert x[7] == pytest.approx(math.log(0.01))
    for k, v in th0.items():
        assert est.theta[k] == pytest.approx(v, rel=1e-12)
    sd = np.sqrt(np.diag(est.P))
    assert est.theta_std["Vs"] == pytest.approx(sd[4] * 0.03)
    assert est.theta_std["delta"] == pytest.approx(sd[5] * 1.5)
    assert est.theta_std["tau"] == pytest.approx(sd[7] * 0.01)


@pytest.mark.parametrize("delta", [1.0, -1.0, 0.3, -4.0])
def test_zero_velocity_gives_finite_state_and_no_warning(delta):
    # w = 0 measured, u = 0, standing start: F(0) = 0 (sgn 0 = 0), also for delta < 0 (|0/Vs|**delta = inf)
    th0 = dict(truth(PAPER), delta=delta)
    est = OnlineUKF(J=4.0, theta0=th0, noise_std=NOISE)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with np.errstate(all="raise"):
            for k in range(50):
                est.update(0.0 if k % 2 else 5.0, 0.0, TS)
    assert np.all(np.isfinite(est.x)) and np.all(np.isfinite(est.P))
    assert all(np.isfinite(v) for v in est.theta.values())


# --------------------------------------------------------------------------- rejected samples leave the state alone


@pytest.mark.parametrize(
    "u, w, dt, exc",
    [
        (np.nan, 0.1, TS, SignalError),
        (1.0, np.nan, TS, SignalError),
        (1.0, np.inf, TS, SignalError),
        (1.0, 0.1, 0.0, ParameterError),
        (1.0, 0.1, -TS, ParameterError),
        (1.0, 0.1, np.nan, ParameterError),
        ("1", 0.1, TS, SignalError),
    ],
)
def test_rejected_sample_changes_neither_x_nor_P(u, w, dt, exc):
    est = OnlineUKF(J=4.0, theta0=truth(PAPER), noise_std=NOISE)
    for k in range(5):
        est.update(30.0, 0.01 * k, TS)
    x, P, n = est.x, est.P, est.n_updates
    with pytest.raises(exc, match="rejected sample"):
        est.update(u, w, dt)
    np.testing.assert_array_equal(est.x, x)
    np.testing.assert_array_equal(est.P, P)
    assert est.n_updates == n and est.n_rejected == 1
    est.update(30.0, 0.05, TS)  # and it goes on normally
    assert est.n_updates == n + 1


def test_numerical_failure_rolls_back(monkeypatch):
    est = OnlineUKF(J=4.0, theta0=truth(PAPER), noise_std=NOISE)
    est.update(30.0, 0.01, TS)
    x, P = est.x, est.P

    def broken_update(*args, **kwargs):
        est._ukf.x = np.full(8, np.nan)  # a failure half-way through the filterpy update
        raise np.linalg.LinAlgError("not positive definite")

    monkeypatch.setattr(est._ukf, "update", broken_update)
    with pytest.raises(FilterDivergedError, match="rolled back"):
        est.update(30.0, 0.02, TS)
    np.testing.assert_array_equal(est.x, x)
    np.testing.assert_array_equal(est.P, P)


def test_x_and_P_are_copies():
    est = OnlineUKF(J=4.0, theta0=truth(PAPER), noise_std=NOISE)
    x = est.x
    x[:] = 0.0
    est.P[0, 0] = -1.0
    assert est.x[2] == pytest.approx(PAPER.Fc) and est.P[0, 0] > 0


# --------------------------------------------------------------------------- hyperparameter validation


def _with_options(args):
    """Constructor arguments with the tuning keys moved into ``options`` (a mapping, validated inside)."""
    opt_keys = {f.name for f in fields(UKFOptions)}
    out = {k: v for k, v in args.items() if k not in opt_keys}
    out["options"] = {k: v for k, v in args.items() if k in opt_keys}
    return out


@pytest.mark.parametrize(
    "kwargs, exc, match",
    [
        (dict(J=0.0), ParameterError, "J"),
        (dict(noise_std=-1.0), ParameterError, "noise_std"),
        (dict(theta0={"Fc": 1.0}), ParameterError, "theta0"),
        (dict(theta0=dict(truth(PAPER), Vs=0.0)), ParameterError, "Vs"),
        (dict(theta0=dict(truth(PAPER), delta=0.0)), ParameterError, "delta"),
        (dict(theta0=dict(truth(PAPER), tau=-0.01)), ParameterError, "tau"),
        (dict(theta0=dict(truth(PAPER), delta=10.0)), ParameterError, "abs_delta_box"),
        (dict(theta0=[1, 2, 3]), TypeError, "theta0"),
        (dict(n_substeps=0), ParameterError, "n_substeps"),
        (dict(alpha=0.0), ParameterError, "alpha"),
        (dict(beta=-1.0), ParameterError, "beta"),
        (dict(kappa=-9.0), ParameterError, "kappa"),
        (dict(std0={"Vs": 1.0}), ParameterError, "std0"),
        (dict(std0={"Fc": 0.0}), ParameterError, "std0"),
        (dict(q={"f": -1.0}), ParameterError, "q"),
        (dict(Vs_box=(1.0, 0.1)), ParameterError, "Vs_box"),
        (dict(r_anneal=(1.0, 0.0)), ParameterError, "r_anneal"),
    ],
)
def test_bad_hyperparameters_raise_naming_them(kwargs, exc, match):
    args = dict(J=4.0, theta0=truth(PAPER), noise_std=NOISE)
    args.update(kwargs)
    with pytest.raises(exc, match=match):
        OnlineUKF(**_with_options(args))


def test_run_online_ukf_validates_the_signals():
    t = np.arange(5) * TS
    with pytest.raises(SignalError, match="increasing"):
        run_online_ukf(t[::-1], np.zeros(5), np.zeros(5), J=4.0, theta0=truth(PAPER), noise_std=NOISE)
    with pytest.raises(SignalError, match="w"):
        run_online_ukf(t, np.zeros(5), np.zeros(4), J=4.0, theta0=truth(PAPER), noise_std=NOISE)
    with pytest.raises(SignalError, match="u"):
        run_online_ukf(t, np.r_[0, 0, np.nan, 0, 0], np.zeros(5), J=4.0, theta0=truth(PAPER), noise_std=NOISE)


def test_irregular_sample_intervals_are_used():
    # the same smooth motion (no reversal) sampled at two different interval patterns ends in the same state
    p = PAPER
    kw = dict(J=p.J, theta0=truth(p), noise_std=1e6, w0=0.1, f0=p.friction(0.1),
              options=UKFOptions(std0={k: 1e-9 for k in STATE_NAMES}, q={k: 0.0 for k in STATE_NAMES},
                                 crossing_gate=False))
    a, b = OnlineUKF(**kw), OnlineUKF(**kw)
    a.update(50.0, 0.0, 0.02)
    b.update(50.0, 0.0, 0.005)
    b.update(50.0, 0.0, 0.015)
    assert a.x[0] == pytest.approx(b.x[0], rel=1e-6)
    assert a.x[1] == pytest.approx(b.x[1], rel=1e-6)


# --------------------------------------------------------------------------- convergence_time


def test_convergence_time_is_the_last_entry_into_the_band():
    t = np.arange(6.0)
    assert convergence_time(t, [0, 2, 1.0, 2, 1.04, 0.98], 1.0, rel_tol=0.05) == 4.0
    assert convergence_time(t, np.ones(6), 1.0) == 0.0
    assert convergence_time(t, [1, 1, 1, 1, 1, 2], 1.0) == math.inf
    with pytest.raises(ParameterError, match="true_value"):
        convergence_time(t, np.ones(6), 0.0)
    with pytest.raises(ParameterError, match="rel_tol"):
        convergence_time(t, np.ones(6), 1.0, rel_tol=0.0)


def test_crossing_gate_leaves_parameters_and_their_covariance_alone_at_a_reversal():
    # a standing start (w0 = 0, measured 0) puts sigma points on both sides of w = 0: the gated update corrects
    # w and f only. The parameters' own prediction is the identity, for which the unscented transform is exact,
    # so their mean stays and their covariance grows by exactly Q = diag(q**2)*dt.
    q = {"Fc": 0.1, "Fs": 0.2, "log_Vs": 0.01, "log_abs_delta": 0.02, "sigma": 0.3, "log_tau": 0.04}
    est = OnlineUKF(J=4.0, theta0=truth(PAPER), noise_std=NOISE, options=UKFOptions(q=q))
    x0, P0 = est.x, est.P
    est.update(10.0, 0.0, TS)
    assert est.n_gated == 1 and est.n_updates == 1
    np.testing.assert_allclose(est.x[2:], x0[2:], rtol=1e-12, atol=1e-12)
    Qp = np.diag([q[k] ** 2 * TS for k in STATE_NAMES[2:]])
    np.testing.assert_allclose(est.P[2:, 2:], P0[2:, 2:] + Qp, rtol=1e-9, atol=1e-15)
    assert est.P[0, 0] < P0[0, 0]  # the velocity was corrected
    # far from a reversal the parameters do learn
    est2 = OnlineUKF(J=4.0, theta0=truth(PAPER), noise_std=NOISE, w0=0.2, f0=PAPER.friction(0.2))
    x0 = est2.x
    est2.update(PAPER.friction(0.2) + 5.0, 0.2, TS)
    assert est2.n_gated == 0
    assert np.any(np.abs(est2.x[2:] - x0[2:]) > 1e-9)
