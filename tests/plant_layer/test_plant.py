"""Plant: Stribeck map, RK4 joint against scipy's adaptive solver, sampler, excitation generators."""

import warnings

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from plant import (JointParams, ParameterError, SignalError, bandlimited_noise, irregular_sample_times,
                   multisine_reference, preset, sample, simulate, stribeck)

P = preset("paper")


def test_stribeck_limits_and_symmetry():
    assert stribeck(1e-12, Fc=25, Fs=35, Vs=0.02, delta=1, sigma=40) == pytest.approx(35.0, rel=1e-9)
    big = 5.0
    assert stribeck(big, Fc=25, Fs=35, Vs=0.02, delta=1, sigma=40) == pytest.approx(25 + 40 * big, rel=1e-12)
    w = np.linspace(-1, 1, 101)
    F = P.friction(w)
    np.testing.assert_allclose(F, -P.friction(-w), rtol=0, atol=0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert P.replace(delta=-1.0).friction(0.0) == 0.0
        # negative delta: friction rises from Fc towards Fs with speed
        assert P.replace(delta=-1.0, sigma=0.0).friction(1e-9) == pytest.approx(25.0, rel=1e-9)


def test_rk4_matches_scipy_solve_ivp_on_smooth_motion():
    # u keeps w > 0, so the map is smooth along the trajectory
    t_end, dt = 0.5, 1e-3
    n = int(t_end / dt)
    tk = np.arange(n) * dt
    u = 60.0 + 20.0 * np.sin(2 * np.pi * 0.7 * tk)
    resp = simulate(P, u, dt=dt, w0=0.3, f0=float(P.friction(0.3)))

    def rhs(t, x):
        k = min(int(t / dt + 1e-9), n - 1)
        return [(u[k] - x[1]) / P.J, (P.friction(x[0]) - x[1]) / P.tau]

    # integrate piecewise (u is held over each step) with tight tolerances
    x = [0.3, float(P.friction(0.3))]
    for k in range(0, n, 100):
        sol = solve_ivp(rhs, (k * dt, (k + 100) * dt), x, rtol=1e-11, atol=1e-12, method="DOP853",
                        max_step=dt, t_eval=[(k + 100) * dt])
        x = sol.y[:, -1]
    assert resp.w[-1] == pytest.approx(x[0], rel=1e-8)
    assert resp.f[-1] == pytest.approx(x[1], rel=1e-8)


def test_steady_state_velocity_solves_F_of_w_equals_u():
    u0 = 45.0
    resp = simulate(P, np.full(20000, u0))
    w_ss = brentq(lambda w: P.friction(w) - u0, 1e-6, 5.0)
    assert resp.w[-1] == pytest.approx(w_ss, rel=1e-9)
    assert resp.f[-1] == pytest.approx(u0, rel=1e-9)


def test_static_friction_plant_tau_zero():
    p0 = P.replace(tau=0.0)
    resp = simulate(p0, np.full(5000, 45.0), w0=0.1)
    np.testing.assert_allclose(resp.f, p0.friction(resp.w), rtol=1e-12)


def test_sampler_alignment_noise_quantization():
    rng = np.random.default_rng(0)
    u = np.arange(100, dtype=float)
    resp = simulate(P, u)
    m = sample(resp, Ts=0.01)
    assert m.uniform and m.t[1] == pytest.approx(0.01)
    # u(k) is the torque applied over the step that ended at t(k)
    assert m.u[1] == resp.u[9] == 9.0
    mq = sample(resp, Ts=0.01, quantization=4.0, noise_std=0.01, rng=rng)
    assert np.all(np.abs(mq.u - mq.u_true) <= 2.0) and np.all(np.mod(mq.u, 4.0) == 0)
    assert np.std(mq.w - mq.w_true) == pytest.approx(0.01, rel=0.5)
    with pytest.raises(ParameterError, match="multiple"):
        sample(resp, Ts=0.0105)
    with pytest.raises(ParameterError, match="rng"):
        sample(resp, noise_std=0.1)


def test_irregular_sample_times_like_fig10():
    rng = np.random.default_rng(4)
    t = irregular_sample_times(200.0, rng=rng)
    d = np.diff(t)
    assert np.all(d > 0)
    assert d.mean() == pytest.approx(0.022, rel=0.02)
    assert d.max() <= 2.0 * d.mean() + 1e-3 and d.max() >= 1.7 * d.mean()
    resp = simulate(P, np.zeros(int(201 / 1e-3)))
    m = sample(resp, times=t)
    assert not m.uniform and m.Ts == pytest.approx(d.mean())
    with pytest.raises(SignalError, match="strictly increasing"):
        sample(resp, times=[0.0, 0.02, 0.01])


def test_excitation_generators():
    rng = np.random.default_rng(2)
    t, u = bandlimited_noise(100.0, cutoff=2.0, std=30.0, rng=rng)
    assert np.std(u) == pytest.approx(30.0, rel=1e-12) and abs(np.mean(u)) < 1e-9
    spec = np.abs(np.fft.rfft(u)) ** 2
    f = np.fft.rfftfreq(u.size, d=1e-3)
    assert spec[f > 20].sum() / spec.sum() < 1e-3  # band-limited
    ref = multisine_reference(120.0, rng=rng)
    assert np.max(np.abs(ref.w)) == pytest.approx(np.deg2rad(20.0), rel=1e-12)
    assert ref.w[0] == 0.0
    assert len(ref.reversals()) >= 30  # frequent motion reversals
    np.testing.assert_allclose(np.gradient(ref.w, ref.t)[10:-10], ref.dw[10:-10], atol=2e-4)
    with pytest.raises(ParameterError, match="f_min"):
        multisine_reference(10.0, f_min=2.0, f_max=1.0, rng=rng)


def test_joint_params_validation_and_json(tmp_path):
    with pytest.raises(ParameterError, match="J must be > 0, got -1.0"):
        P.replace(J=-1.0)
    with pytest.raises(ParameterError, match="delta must be non-zero"):
        P.replace(delta=0)
    with pytest.raises(TypeError, match="Fc must be a real number"):
        P.replace(Fc="x")
    f = tmp_path / "p.json"
    f.write_text('{"J": 1, "Fc": 2, "Fs": 3, "Vs": 0.1, "delta": 2, "sigma": 0.5, "tau": 0.01}')
    assert JointParams.from_json(f) == JointParams(1, 2, 3, 0.1, 2, 0.5, 0.01)
    f.write_text('{"J": 1}')
    with pytest.raises(ParameterError, match="miss"):
        JointParams.from_json(f)


def test_rk4_step_negative_delta_tiny_velocity_is_finite_and_matches_eq3():
    """delta < 0: (|w|/Vs)**delta overflows for |w| ~ 1e-310; the step must use the limit s -> 0."""
    import dataclasses
    import math
    import warnings

    from plant.friction import preset, stribeck
    from plant.joint import make_rk4_step

    p = dataclasses.replace(preset("paper"), delta=-1.0, tau=0.0)
    step = make_rk4_step(p, 1e-3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for w0 in (1e-310, -1e-310, 1e-300, 0.0):
            w1, f1 = step(w0, 0.0, 0.0)
            assert math.isfinite(w1) and math.isfinite(f1)
            # tau = 0: f is the algebraic eq. 3 at the end state, computed independently by numpy
            F = float(stribeck(np.array([w1]), Fc=p.Fc, Fs=p.Fs, Vs=p.Vs, delta=p.delta, sigma=p.sigma)[0])
            assert f1 == pytest.approx(F, rel=1e-12, abs=1e-12)


@pytest.mark.parametrize("ramp", [0.0, 2.5])
def test_multisine_reference_equals_dense_sum_and_its_derivative(ramp):
    """Built in blocks, component by component (O(N) memory); equal to the dense (n, N) formula and dw = d/dt w."""
    from plant.excitation import _BLOCK, multisine_reference

    T, n, seed = 2.5 * _BLOCK * 1e-3, 5, 7  # several blocks, the last one partial
    ref = multisine_reference(T, n_components=n, ramp=ramp, peak=1.0, rng=np.random.default_rng(seed))
    rng = np.random.default_rng(seed)
    freqs = np.geomspace(0.01, 1.0, n)
    phases = rng.uniform(0.0, 2.0 * np.pi, size=n)
    arg = 2.0 * np.pi * freqs[:, None] * ref.t[None, :] + phases[:, None]
    x = np.sin(arg).sum(axis=0)
    s = 0.5 - 0.5 * np.cos(np.pi * np.clip(ref.t / ramp, 0.0, 1.0)) if ramp > 0 else np.ones_like(x)
    x = s * x
    np.testing.assert_allclose(ref.w, x / np.max(np.abs(x)), rtol=0, atol=1e-15)
    # central differences: error <= dt**2/6 * max|w'''| <= dt**2/6 * sum((2*pi*f)**3) / max|x|
    dt = ref.t[1] - ref.t[0]
    dw_num = (ref.w[2:] - ref.w[:-2]) / (2.0 * dt)
    bound = dt**2 / 6.0 * np.sum((2.0 * np.pi * freqs) ** 3) / np.max(np.abs(x))
    after = ref.t[1:-1] > ramp + 2.0 * dt  # the fade-in adds its own third derivative
    assert np.max(np.abs(ref.dw[1:-1] - dw_num)[after]) <= bound + 1e-12
