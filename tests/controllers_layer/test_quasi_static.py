"""Tests of controllers.experiments.quasi_static: constant-velocity runs recover the Stribeck map (eq. 3)."""

import math

import control
import numpy as np
import pytest
import scipy.linalg

from controllers.design.pi import design_pi
from controllers.experiments.quasi_static import QS_CROSSOVER, bidirectional_velocities, quasi_static_runs
from plant.errors import ParameterError, SignalError
from plant.friction import preset, stribeck

P = preset("paper")


def _F_true(w):
    return stribeck(w, Fc=P.Fc, Fs=P.Fs, Vs=P.Vs, delta=P.delta, sigma=P.sigma)


def _slope(w0):
    """dF/dw of eq. 3 at w0 != 0 (N·m·s/rad)."""
    x = abs(w0) / P.Vs
    return P.sigma - (P.Fs - P.Fc) * math.exp(-(x**P.delta)) * P.delta * x ** (P.delta - 1) / P.Vs


def test_bidirectional_velocities_grid():
    v = bidirectional_velocities(0.002, 0.35, 6)
    assert v.shape == (12,)
    np.testing.assert_allclose(v[:6], -v[:5:-1], rtol=0, atol=0)  # odd-symmetric
    pos = v[6:]
    assert pos[0] == pytest.approx(0.002) and pos[-1] == pytest.approx(0.35)
    ratios = pos[1:] / pos[:-1]
    np.testing.assert_allclose(ratios, (0.35 / 0.002) ** (1 / 5), rtol=1e-12)
    assert np.all(np.diff(v) > 0)


def test_means_match_stribeck_above_Vs():
    v = bidirectional_velocities(P.Vs, 0.35, 4)
    r = quasi_static_runs(P, v, settle=0.5, hold=0.3)
    F = _F_true(v)
    assert r.u_mean.shape == r.u_std.shape == r.w_mean.shape == (8,)
    np.testing.assert_array_equal(r.setpoints, v)
    # stated tolerance: 0.5 % for |w| >= Vs (observed ~1e-12: noise-free steady state is u = F(w))
    np.testing.assert_allclose(r.u_mean, F, rtol=5e-3)
    np.testing.assert_allclose(r.w_mean, v, rtol=1e-6)
    assert np.all(r.u_std < 1e-6 * np.abs(F))
    # F is odd: the two directions mirror each other
    np.testing.assert_allclose(r.u_mean[:4], -r.u_mean[:3:-1], rtol=1e-9)


def test_low_speed_held_with_default_loop():
    # Vs/10: negative slope ~ -412 N·m·s/rad; default stiff loop with default settling time
    w = np.array([-0.002, 0.002])
    d = design_pi(P.J, crossover=QS_CROSSOVER, phase_margin=60.0, Tc=1e-3)
    k = -_slope(0.002)
    assert d.Kp + d.Ki * P.tau > k  # linearised stability (Notes of quasi_static_runs)
    r = quasi_static_runs(P, w, hold=0.3)
    np.testing.assert_allclose(r.u_mean, _F_true(w), rtol=5e-3)
    np.testing.assert_allclose(r.w_mean, w, rtol=5e-3)


def test_soft_loop_fails_where_linear_analysis_predicts():
    d20 = design_pi(P.J, crossover=20.0, phase_margin=60.0, Tc=1e-3)
    fast, slow = 0.08, 0.005
    # Routh: Kp + Ki*tau must exceed the negative slope k of the Stribeck curve
    assert d20.Kp + d20.Ki * P.tau > -_slope(fast)
    assert d20.Kp + d20.Ki * P.tau < -_slope(slow)
    r = quasi_static_runs(P, [fast, slow], settle=1.0, hold=0.5, design=d20)
    F = _F_true(np.array([fast, slow]))
    assert abs(r.u_mean[0] - F[0]) / F[0] < 5e-3
    assert abs(r.u_mean[1] - F[1]) / F[1] > 0.05  # off the curve
    assert r.u_std[1] > 0.01 * F[1]  # limit cycle: large spread


def _h2(sys):
    """RMS gain of a stable discrete system to unit white noise (discrete Lyapunov equation)."""
    X = scipy.linalg.solve_discrete_lyapunov(sys.A, sys.B @ sys.B.T)
    return float(np.sqrt((sys.C @ X @ sys.C.T + sys.D @ sys.D.T)[0, 0]))


def test_noise_spread_matches_linearised_loop():
    w0, Tc, sn = 0.35, 1e-3, 1e-4
    d = design_pi(P.J, crossover=QS_CROSSOVER, Tc=Tc)
    k = _slope(w0)
    # plant linearised at w0 (eqs. 1-3): J dw = u - f, tau df = k w - f
    A = [[0.0, -1.0 / P.J], [k / P.tau, -1.0 / P.tau]]
    plant = control.sample_system(control.ss(A, [[1.0 / P.J], [0.0]], [[1.0, 0.0]], 0.0), Tc, method="zoh")
    Cs = control.ss(d.C)
    u_std_lin = sn * _h2(control.ss(control.feedback(Cs, plant)))  # noise -> torque: C/(1+CP)
    w_std_lin = sn * _h2(control.ss(control.feedback(1, Cs * plant)))  # noise -> measured w: 1/(1+CP)
    r = quasi_static_runs(P, [-w0, w0], settle=0.5, hold=3.0, noise_std=sn, rng=np.random.default_rng(7))
    np.testing.assert_allclose(r.u_std, u_std_lin, rtol=0.05)
    np.testing.assert_allclose(r.w_std, w_std_lin, rtol=0.05)
    np.testing.assert_allclose(r.u_mean, _F_true(r.setpoints), rtol=5e-3)


def test_noise_reproducible_with_seed():
    kw = dict(settle=0.2, hold=0.2, noise_std=1e-3)
    a = quasi_static_runs(P, [0.1], rng=np.random.default_rng(1), **kw)
    b = quasi_static_runs(P, [0.1], rng=np.random.default_rng(1), **kw)
    np.testing.assert_array_equal(a.u_std, b.u_std)
    assert a.u_std[0] > 0


@pytest.mark.parametrize(
    "kwargs, exc, name",
    [
        (dict(velocities=[0.1, 0.0]), ParameterError, "velocities"),
        (dict(velocities=[0.1, float("nan")]), SignalError, "velocities"),
        (dict(velocities=[0.1], hold=0.0), ParameterError, "hold"),
        (dict(velocities=[0.1], hold=1e-5), ParameterError, "hold"),
        (dict(velocities=[0.1], settle=-1.0), ParameterError, "settle"),
        (dict(velocities=[0.1], noise_std=-1.0), ParameterError, "noise_std"),
        (dict(velocities=[0.1], u_max=-1.0), ParameterError, "u_max"),
        (dict(velocities=[0.1], design={"Kp": 1.0, "Ki": 1.0, "Tc": 1e-3}), TypeError, "design must be a PIDesign"),
        (dict(velocities=[0.1], hold=1e-3, design=design_pi(4.0, Tc=2e-3)), ParameterError, "hold must be >= Tc"),
    ],
)
def test_quasi_static_bad_inputs(kwargs, exc, name):
    v = kwargs.pop("velocities")
    with pytest.raises(exc, match=name):
        quasi_static_runs(P, v, **kwargs)


@pytest.mark.parametrize(
    "args, name",
    [((0.0, 1.0, 3), "w_min"), ((1.0, 1.0, 3), "w_max"), ((0.1, 1.0, 1), "n"), ((0.1, -1.0, 3), "w_max")],
)
def test_bidirectional_bad_inputs(args, name):
    with pytest.raises(ParameterError, match=name):
        bidirectional_velocities(*args)
