"""Karnopp band: a joint inside it with ``|u| <= Fs`` is held by a friction of at most ``Fs`` (Karnopp 1985).

Analytic answers of the constant deceleration ``(Fs*sgn(w) - u)/J``: a joint entering the band at ``w0`` with
``u = 0`` slides ``ceil(J*w0/(Fs*dt)) - 1`` steps at the rate ``Fs/J`` and is at rest after the next one; its
position advances by the distance to the stop, ``J*w0^2/(2*Fs)``; a light joint (``J*|w0|/dt <= Fs - |u|``) is at
rest after one step. The step-by-step comparison with the independent oracles is in test_plant_kernels.py
(tests/plant_oracle.py) and test_stiff_lagged.py (tests/stiff_oracle.py).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from plant import FrictionRipple
from plant.dynamics import plant_friction, plant_params, plant_step
from plant.joint import simulate
from plant.karnopp import KarnoppParams
from plant.rows import plant_state

DT = 1e-3
# a heavy joint: J*dv/dt is ~490 times Fs, so one step cannot stop it from the band's edge
HEAVY = KarnoppParams(J=28.0, Fc=2.0, Fs=2.35, Vs=0.16, delta=1.0, sigma=0.1, tau=0.0, dv=0.041)
LIGHT = KarnoppParams(J=1e-3, Fc=2.0, Fs=2.35, Vs=0.16, delta=1.0, sigma=0.1, tau=0.0, dv=0.041)


def _run(p, w0, u, n):
    """n steps of the C plant_step from (w0, F(w0)) at q = 0: arrays w, f, q of n + 1 entries."""
    par = plant_params(p)
    st = plant_state(p, w0)
    out = np.empty((n + 1, 3))
    out[0] = st.w, plant_friction(par, st), st.q
    for k in range(n):
        plant_step(par, st, u, DT)
        out[k + 1] = st.w, plant_friction(par, st), st.q
    return out.T


@pytest.mark.parametrize("w0, u", [(0.04, 0.0), (-0.0371, 0.0), (0.03, 1.2), (-0.025, 0.8), (0.035, -2.0)])
@pytest.mark.parametrize("tau", [0.0, 0.02])
def test_heavy_joint_decelerates_at_the_static_limit_then_sticks(w0, u, tau):
    p = HEAVY.replace(tau=tau)
    d = math.copysign(1.0, w0)
    a = (p.Fs - u * d) / p.J  # the deceleration of |w| (rad/s^2)
    n_slide = math.ceil(abs(w0) / (a * DT)) - 1
    assert n_slide > 100  # many steps: far from the one-step stick
    W, F, Q = _run(p, w0, u, n_slide + 5)
    k = np.arange(1, n_slide + 1)
    np.testing.assert_allclose(W[1: n_slide + 1], w0 - d * a * DT * k, rtol=0, atol=1e-13)
    assert np.all(F[1: n_slide + 1] == d * p.Fs)  # the friction is at its static limit while it slides
    assert np.all(W[n_slide + 1:] == 0.0) and np.all(F[n_slide + 1:] == u)  # at rest, balancing u
    assert Q[-1] == pytest.approx(w0 * abs(w0) / (2.0 * a), rel=1e-12)  # the distance to the stop
    assert np.all(np.diff(Q[: n_slide + 2]) * d > 0.0)


def test_the_count_of_sliding_steps_is_the_ceiling():
    """From w0 = m*Fs*dt/J (m whole) the last sliding step leaves exactly Fs*dt/J, which one step stops."""
    p = HEAVY
    a = p.Fs * DT / p.J
    for w0, steps in ((0.5 * a, 1), (1.5 * a, 2), (100.5 * a, 101), (0.0405, math.ceil(0.0405 / a))):
        W, _, _ = _run(p, w0, 0.0, steps + 2)
        assert W[steps - 1] > 0.0 and np.all(W[steps:] == 0.0), (w0, steps)


def test_light_joint_sticks_in_one_step():
    for w0, u in ((0.04, 0.0), (-0.04, 2.0), (0.02, -2.3)):
        assert LIGHT.J * abs(w0) / DT <= LIGHT.Fs - abs(u)
        W, F, Q = _run(LIGHT, w0, u, 3)
        assert np.all(W[1:] == 0.0) and np.all(F[1:] == u)
        # stopped within the step at the deceleration (Fs*sgn(w0) - u)/J
        assert Q[1] == pytest.approx(LIGHT.J * w0 * abs(w0) / (2.0 * (LIGHT.Fs - u * math.copysign(1.0, w0))),
                                     rel=1e-12)
        assert Q[1] == Q[-1]


def test_breakaway_above_Fs_is_unchanged_by_the_band_rule():
    """|u| > Fs in the band: RK4 with the band target Fs*sgn(u) (the lagged joint's step with that map)."""
    p = HEAVY
    u = 1.5 * p.Fs
    W, F, _ = _run(p, 0.02, u, 1)
    assert W[1] == pytest.approx(0.02 + DT * (u - p.Fs) / p.J, rel=1e-14)  # constant target inside the band
    assert F[1] == p.Fs


def test_open_loop_simulate_and_make_step_take_the_same_rule():
    p = HEAVY
    w0, n = 0.04, 600
    W, F, _ = _run(p, w0, 0.0, n)
    r = simulate(p, np.zeros(n), dt=DT, w0=w0, f0=p.initial_state(w0))
    np.testing.assert_array_equal(r.w, W)
    np.testing.assert_array_equal(r.f, F)
    step = p.make_step(DT)
    w, s = w0, p.initial_state(w0)
    for k in range(n):
        w, s = step(w, s, 0.0)
        assert (w, s) == (W[k + 1], F[k + 1])


def test_ripple_scales_the_limit_at_the_step_start():
    """With a friction ripple the limit is Fs*R(q) at the step's start position."""
    r = FrictionRipple(HEAVY, amplitude=0.3, harmonic=50.0, phase=0.7)
    W, F, Q = _run(r, 0.04, 0.0, 200)
    R = 1.0 + 0.3 * np.sin(50.0 * Q[:-1] + 0.7)
    np.testing.assert_allclose(F[1:], HEAVY.Fs * R, rtol=1e-14)
    np.testing.assert_allclose(np.diff(W), -DT * HEAVY.Fs * R / HEAVY.J, rtol=1e-9, atol=1e-17)
    np.testing.assert_allclose(np.diff(Q), 0.5 * DT * (W[:-1] + W[1:]), rtol=1e-13)
