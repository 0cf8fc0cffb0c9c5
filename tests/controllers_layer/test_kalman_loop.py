"""The encoder's Kalman velocity in the loop (controllers/csrc/ctl_sensor.c, ``Sensor(velocity="kalman")``,
``LoopConfig.from_flat(velocity="kalman")``).

Oracles: the gain against scipy's discrete algebraic Riccati solution built here from the textbook matrices
(Bar-Shalom, Li, Kirubarajan 2001, Sec. 6.2-6.3) and against filterpy's covariance recursion run to
convergence; the filtered velocity against a filterpy ``KalmanFilter`` on the same quantised position sequence
(computed here); on a constant-velocity ramp the error statistics against the exact variance of a linear filter
driven by the quantisation error of an equidistributed (Weyl) sequence; the offline
:func:`adaptive_ff.io.kalman_velocity.velocity_from_position` (causal) as the same filter once converged.
"""

import copy
import math

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter
from scipy.linalg import solve_discrete_are

from adaptive_ff.io.kalman_velocity import velocity_from_position
from controllers import LoopConfig, design_pi, run_batch, run_mode
from controllers.simulation.sensor_drive import Sensor
from plant import ParameterError
from plant.excitation import multisine_reference
from plant.friction import preset

TC = 1e-3
COUNTS = 2**17
RES = 2 * math.pi / COUNTS


def _matrices(model, h, S):
    """F, Q of the kinematic model (white acceleration / jerk noise of density S), written out independently."""
    if model == "cv":
        F = np.array([[1.0, h], [0.0, 1.0]])
        Q = S * np.array([[h**3 / 3, h**2 / 2], [h**2 / 2, h]])
    else:
        F = np.array([[1.0, h, h * h / 2], [0.0, 1.0, h], [0.0, 0.0, 1.0]])
        Q = S * np.array([[h**5 / 20, h**4 / 8, h**3 / 6], [h**4 / 8, h**3 / 3, h**2 / 2], [h**3 / 6, h**2 / 2, h]])
    return F, Q


def _dare(model, fb, res=RES, T=TC):
    """Steady-state prior covariance, gain and posterior covariance: S = (2 pi fb)^(2n) r T, r = res^2/12."""
    n = 2 if model == "cv" else 3
    r = res**2 / 12
    S = (2 * math.pi * fb) ** (2 * n) * r * T
    F, Q = _matrices(model, T, S)
    H = np.zeros((1, n))
    H[0, 0] = 1.0
    P = solve_discrete_are(F.T, H.T, Q, np.array([[r]]))
    K = (P @ H.T / (H @ P @ H.T + r)).ravel()
    return F, Q, H, r, P, K, (np.eye(n) - np.outer(K, H)) @ P


def _positions(w, res=RES, T=TC):
    """The counts read, as positions (rad): the sensor's trapezoid sum in the same order, then whole counts."""
    qm = np.empty_like(w)
    q, wp = 0.0, 0.0
    for k, x in enumerate(w.tolist()):
        if k:
            q += 0.5 * T * (wp + x)
        qm[k] = res * math.floor(q / res)
        wp = x
    return qm


def _measure(sensor, w, noise=None):
    n = np.zeros_like(w) if noise is None else noise
    return np.array([sensor.measure(x, e) for x, e in zip(w.tolist(), n.tolist())])


def _random_motion(n, seed):
    t = np.arange(n) * TC
    rng = np.random.default_rng(seed)
    amp, f, ph = rng.uniform(0.05, 0.4, 6), rng.uniform(0.1, 8.0, 6), rng.uniform(0, 2 * np.pi, 6)
    return (amp[:, None] * np.sin(2 * np.pi * f[:, None] * t + ph[:, None])).sum(axis=0) + 0.02


def _converged_filterpy(F, Q, H, r):
    """A filterpy KalmanFilter whose covariance recursion ran from a wide start until its gain changed by at most
    2 rounding units per step (a contraction: at 2 Hz, 1e-14 from the fixed point)."""
    n = F.shape[0]
    kf = KalmanFilter(dim_x=n, dim_z=1)
    kf.F, kf.Q, kf.H, kf.R = F, Q, H, np.array([[r]])
    kf.P = np.diag([r, 1.0, 1e4][:n])
    K = None
    for _ in range(20000):
        kf.predict()
        kf.update(0.0)  # the covariance does not depend on the measurements
        if K is not None and np.max(np.abs(kf.K - K) / np.abs(kf.K)) <= 2 * np.finfo(float).eps:
            break
        K = kf.K.copy()
    return kf


@pytest.mark.parametrize("model", ["cv", "ca"])
@pytest.mark.parametrize("fb", [100.0, 30.0, 250.0, 2.0])
def test_gain_is_the_riccati_solution(model, fb):
    """The gain against scipy's DARE solution (to its accuracy on these badly scaled matrices: up to 3e-9
    relative measured for ca at 10 Hz), against filterpy's converged covariance recursion to 1e-12, and the
    Riccati equation's residual at the sensor's covariance to rounding."""
    s = Sensor(Tc=TC, counts_per_rev=COUNTS, velocity="kalman", bandwidth=fb, model=model)
    F, Q, H, r, P, K, _ = _dare(model, fb)
    np.testing.assert_allclose(s.gain, K, rtol=1e-8, atol=0)
    np.testing.assert_allclose(s.filter.P_prior, P, rtol=1e-8, atol=0)
    kf = _converged_filterpy(F, Q, H, r)
    np.testing.assert_allclose(s.gain, kf.K.ravel(), rtol=1e-12, atol=0)
    Pk = s.filter.P_prior
    residual = F @ (Pk - np.outer(s.gain, Pk[0])) @ F.T + Q - Pk
    assert np.all(np.abs(residual) <= 1e-13 * np.abs(Pk) + 1e-15 * np.max(np.abs(Pk)))


@pytest.mark.parametrize("model", ["cv", "ca"])
@pytest.mark.parametrize("fb", [100.0, 30.0])
def test_the_c_filter_equals_filterpy_on_the_same_counts(model, fb):
    """filterpy's KalmanFilter (covariance recursion converged beforehand and continued) on the counts computed
    here; the same start [qm0, w0, 0]. Measured agreement about 1e-13 of the velocity's range."""
    w = _random_motion(20000, seed=3)
    qm = _positions(w)
    s = Sensor(Tc=TC, counts_per_rev=COUNTS, velocity="kalman", bandwidth=fb, model=model)
    v = _measure(s, w)
    F, Q, H, r, _, _, _ = _dare(model, fb)
    kf = _converged_filterpy(F, Q, H, r)
    n = F.shape[0]
    kf.x = np.zeros((n, 1))
    kf.x[0, 0], kf.x[1, 0] = qm[0], w[0]
    ref = np.empty_like(w)
    ref[0] = w[0]
    for k in range(1, w.shape[0]):
        kf.predict()
        kf.update(qm[k])
        ref[k] = kf.x[1, 0]
    scale = np.max(np.abs(ref))
    np.testing.assert_allclose(v, ref, rtol=1e-12, atol=1e-12 * scale)
    assert np.std(v - w) < 0.25 * np.std(w)  # and it is the velocity (lag and quantisation: measured 0.02-0.2)


def test_the_offline_causal_filter_converges_to_the_loop_filter():
    """velocity_from_position(smooth=False) with the encoder's noise: after its covariance converged, the same
    velocity as the loop's constant-gain filter (one tuning rule, two uses)."""
    w = _random_motion(6000, seed=5)
    qm = _positions(w)
    s = Sensor(Tc=TC, counts_per_rev=COUNTS, velocity="kalman", bandwidth=80.0)
    v = _measure(s, w)
    est = velocity_from_position(np.arange(w.shape[0]) * TC, qm, bandwidth=80.0, position_noise=RES / math.sqrt(12),
                                 smooth=False)
    np.testing.assert_allclose(est.w[3000:], v[3000:], rtol=0, atol=1e-9 * np.max(np.abs(v)))


def _weyl_cov(alpha, m):
    """Autocovariance at lag m of frac(k*alpha) for an irrational alpha: 1/12 - f(1-f)/2, f = frac(m*alpha)."""
    f = np.mod(np.asarray(m) * alpha, 1.0)
    return 1.0 / 12.0 - f * (1.0 - f) / 2.0


def _impulse_response(F, H, K, n_taps=400):
    """Velocity response of the steady-state filter to a unit position measurement: x_k = (I-KH)F x_{k-1} + K z_k."""
    A = (np.eye(F.shape[0]) - np.outer(K, H)) @ F
    h, x = np.empty(n_taps), K.copy()
    for j in range(n_taps):
        h[j] = x[1]
        x = A @ x
    return h


@pytest.mark.parametrize("model", ["cv", "ca"])
def test_ramp_zero_steady_error_and_noise_against_theory(model):
    """Constant velocity v0 = alpha*res/Tc with alpha = 3 + (sqrt(5)-1)/2 counts per period: the quantisation
    error -res*frac(k*alpha) is an equidistributed sequence with autocovariance res^2*(1/12 - f(1-f)/2),
    f = frac(m*alpha) (not white: c(1) = -0.035 res^2 against c(0) = 0.083 res^2). The variance of a filter
    sum_j h_j z_{k-j} on it is res^2 * sum_{j,l} h_j h_l c(j-l): the difference (h = [1, -1]/Tc) and the
    Kalman velocity (h its impulse response) are checked against it, their mean error is 0 (both follow a ramp
    without steady error). At the default 100 Hz the theory gives an RMS ratio Kalman/difference of 0.152 (cv)
    and 0.277 (ca); for white noise of variance res^2/12 (the steady-state filter's design assumption:
    r*sum(h^2) against 2r/Tc^2) it would be 0.206 (cv) and 0.377 (ca)."""
    alpha = 3.0 + (math.sqrt(5.0) - 1.0) / 2.0
    v0 = alpha * RES / TC
    N, k0 = 100000, 1000
    w = np.full(N, v0)
    diff = _measure(Sensor(Tc=TC, counts_per_rev=COUNTS), w)[k0:] - v0
    s = Sensor(Tc=TC, counts_per_rev=COUNTS, velocity="kalman", model=model)
    kal = _measure(s, w)[k0:] - v0
    F, _, H, _, _, K, _ = _dare(model, 100.0)
    h = _impulse_response(F, H[0], K)
    lags = np.abs(np.subtract.outer(np.arange(h.size), np.arange(h.size)))
    var_kal = RES**2 * float(h @ _weyl_cov(alpha, lags) @ h)
    var_diff = RES**2 * 2.0 * (_weyl_cov(alpha, 0) - _weyl_cov(alpha, 1)) / TC**2
    np.testing.assert_allclose(np.var(diff), var_diff, rtol=1e-3)
    np.testing.assert_allclose(np.var(kal), var_kal, rtol=1e-2)
    ratio = math.sqrt(var_kal / var_diff)
    ratio_white = math.sqrt(float(h @ h) / (2.0 / TC**2))
    assert ratio == pytest.approx({"cv": 0.152, "ca": 0.277}[model], abs=1e-3)
    assert ratio_white == pytest.approx({"cv": 0.206, "ca": 0.377}[model], abs=1e-3)
    assert np.std(kal) / np.std(diff) == pytest.approx(ratio, rel=1e-2)
    # steady error 0: the mean telescopes to edge terms of at most sum|h|*res over the window
    bound = 2.0 * float(np.sum(np.abs(h))) * RES / (N - k0)
    assert abs(np.mean(kal)) < bound < 1e-3 * np.std(kal)
    assert abs(np.mean(diff)) <= RES / TC / (N - k0) * (1 + 1e-9)


def test_noise_is_added_to_the_kalman_velocity_and_copies_continue_alike():
    w = _random_motion(3000, seed=7)
    e = np.random.default_rng(8).normal(0.0, 1e-3, w.shape[0])
    a = Sensor(Tc=TC, counts_per_rev=COUNTS, velocity="kalman", model="ca", delay=2)
    b = Sensor(Tc=TC, counts_per_rev=COUNTS, velocity="kalman", model="ca", delay=2)
    va, vb = _measure(a, w, e), _measure(b, w)
    np.testing.assert_allclose(va[2:] - vb[2:], e[:-2], rtol=0, atol=1e-15)  # the noise after the filter, delayed
    c = copy.deepcopy(a)
    tail = _random_motion(500, seed=9)
    np.testing.assert_array_equal(_measure(a, tail), _measure(c, tail))


P = preset("paper")
D = design_pi(P.J, crossover=20.0, phase_margin=60.0, Tc=TC)
REF = multisine_reference(20.0, rng=np.random.default_rng(0))


def _opts(**kw):
    return LoopConfig.from_flat(Kp=D.Kp, Ki=D.Ki, u_max=150.0, Vs=P.Vs, delta=P.delta, noise_std=1e-3, **kw)


def test_closed_loop_with_the_kalman_velocity():
    """The Kalman velocity lowers the encoder loop's error (benchmarks/encoder_velocity.py, the same runs, seed 1):
    second-half RMS (rad/s) with the 17-bit encoder, difference -> Kalman cv 100 Hz: adaptive 0.0445 -> 0.0131 (the estimate is refused with
    the difference, used with the Kalman velocity; ratio 0.29), adaptive-dob 0.0134 -> 0.0113 (0.84);
    frictionless 0.0103 / 0.0101 (Kalman: adaptive 1.30x, adaptive-dob 1.12x of it). The adaptive mode's RMS
    moves by up to 0.003 between seeds (eta 0.80..0.96 over seeds 1-8): the margins cover that."""
    rms = {}
    for vel in ("difference", "kalman"):
        o = _opts(encoder_counts=COUNTS, velocity=vel)
        for m in ("adaptive", "adaptive-dob", "frictionless"):
            r = run_mode(P, REF, m, o, rng=np.random.default_rng(1))
            assert np.all(np.isfinite(r.w))
            rms[vel, m] = r.metrics.rms_second_half
    assert rms["kalman", "adaptive"] < 0.45 * rms["difference", "adaptive"]
    assert rms["kalman", "adaptive-dob"] < 0.93 * rms["difference", "adaptive-dob"]
    assert rms["kalman", "adaptive"] < 1.5 * rms["kalman", "frictionless"]
    assert rms["kalman", "adaptive-dob"] < 1.25 * rms["kalman", "frictionless"]


def test_the_loop_measures_the_kalman_velocity_and_batches_equal_single_runs():
    o = _opts(encoder_counts=COUNTS, velocity="kalman", velocity_bandwidth=120.0, velocity_model="ca", delay=1)
    r = run_mode(P, REF, "none", o, rng=np.random.default_rng(2))
    s = Sensor(Tc=TC, counts_per_rev=COUNTS, velocity="kalman", bandwidth=120.0, model="ca", delay=1)
    noise = r.w_meas - _measure(s, r.w)  # the run's noise, the only difference
    assert 0.8e-3 < np.std(noise) < 1.2e-3
    single = run_mode(P, REF, "adaptive", o, rng=np.random.default_rng(4))
    b = run_batch([P, P.replace(J=3.0)], REF, "adaptive", o, seeds=[4, 5])
    assert b.rms_second_half[0] == single.metrics.rms_second_half


def test_defaults_are_the_difference():
    s = Sensor(Tc=TC, counts_per_rev=COUNTS)
    assert s.velocity == "difference" and s.filter is None and s.gain is None and s.bandwidth is None
    k = Sensor(Tc=2e-3, counts_per_rev=COUNTS, velocity="kalman")
    assert k.velocity == "kalman" and k.bandwidth == 50.0 and k.filter.model == "cv"  # 0.1/Tc


@pytest.mark.parametrize("kw,match", [
    (dict(velocity="kalman", bandwidth=0.0), "bandwidth"), (dict(velocity="kalman", bandwidth=-3.0), "bandwidth"),
    (dict(velocity="kalman", bandwidth=math.nan), "bandwidth"), (dict(velocity="kalman", bandwidth=500.0), "bandwidth"),
    (dict(bandwidth=100.0), "bandwidth"), (dict(velocity="kalmann"), "velocity"),
    (dict(velocity="kalman", model="cj"), "model")])
def test_bad_kalman_settings_are_refused(kw, match):
    with pytest.raises(ParameterError, match=match):
        Sensor(Tc=TC, counts_per_rev=COUNTS, **kw)


def test_kalman_needs_an_encoder():
    with pytest.raises(ParameterError, match="counts_per_rev"):
        Sensor(Tc=TC, velocity="kalman")
    with pytest.raises(ParameterError, match="encoder_counts"):
        _opts(velocity="kalman")


@pytest.mark.parametrize("kw,match", [
    (dict(velocity_bandwidth=0.0), "velocity_bandwidth"), (dict(velocity_bandwidth=math.nan), "velocity_bandwidth"),
    (dict(velocity_bandwidth=-1.0), "velocity_bandwidth"), (dict(velocity_bandwidth=500.0), "velocity_bandwidth"),
    (dict(velocity="fir"), "velocity"),
    (dict(velocity_model="cj"), "velocity_model")])
def test_bad_mode_options_are_refused(kw, match):
    with pytest.raises(ParameterError, match=match):
        _opts(encoder_counts=COUNTS, **{"velocity": "kalman", **kw})
