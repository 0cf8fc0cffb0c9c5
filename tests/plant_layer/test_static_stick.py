"""The static joint (``tau = 0``) at standstill: the map jumps at ``w = 0`` and the joint sticks there.

With ``tau = 0`` eq. 1 makes the friction the static map itself, ``f = F(w)``, which jumps from ``-F(0-)`` to
``F(0+)`` at ``w = 0``; the solution there is Filippov's (the joint stays at rest while ``F(0-) <= u <= F(0+)``,
with ``f = u``). Ordinary RK4 steps of 1 ms on such a map creep and chatter through zero (before this fix a held
34 N·m, below ``Fs`` = 35 N·m, broke the ``paper`` joint away to 0.23 rad/s; 10 N·m made it chatter at ~3e-3
rad/s). :func:`plant.dynamics.plant_step` now hands every step that can reach the jump
(:func:`plant.stiff.static_jump_in_reach`) to the set-valued implicit step and keeps RK4 elsewhere.

Checked against the independent solution of tests/stiff_oracle.py (scipy's Radau IIA per smooth piece, restarted
at the jump, Filippov sticking) on non-stiff static joints (one RK4 step per 1 ms away from zero), and against
the analytic stick and breakaway conditions of each direction.
"""

import numpy as np
import pytest

from plant.asymmetric import AsymmetricParams
from plant.dynamics import (RK4_RATE_MAX, plant_friction, plant_params, plant_simulate, plant_state,
                            plant_step)
from plant.friction import JointParams, preset
from plant.stiff import static_jump_in_reach
import plant_oracle
from stiff_oracle import lagged_reference

DT = 1e-3

PLANTS = {
    "paper-tau0": preset("paper").replace(tau=0.0),
    "light-delta2": JointParams(J=0.3, Fc=2.0, Fs=3.5, Vs=0.05, delta=2.0, sigma=1.5, tau=0.0),
    "rising-delta-neg": JointParams(J=1.0, Fc=4.0, Fs=6.0, Vs=0.05, delta=-1.0, sigma=2.0, tau=0.0),
    "asymmetric-tau0": AsymmetricParams(J=2.0, Fc_pos=10.0, Fc_neg=6.0, Fs_pos=14.0, Fs_neg=8.0, Vs=0.03,
                                        delta=1.0, sigma_pos=8.0, sigma_neg=5.0, tau=0.0),
}


def _levels(p):
    """``(F(0-), F(0+))`` magnitudes: the breakaway levels of each direction (Fs; Fc where delta < 0)."""
    if hasattr(p, "Fc_pos"):
        pos, neg = (p.Fc_pos, p.Fs_pos), (p.Fc_neg, p.Fs_neg)
    else:
        pos = neg = (p.Fc, p.Fs)
    pick = 0 if p.delta < 0 else 1
    return neg[pick], pos[pick]


def _simulate(p, u, w0=0.0):
    W = np.empty(u.size + 1)
    S = np.empty(u.size + 1)
    plant_simulate(plant_params(p), plant_state(p, w0), np.ascontiguousarray(u, dtype=float), DT, W, S)
    return W, S


@pytest.mark.parametrize("name", list(PLANTS))
def test_static_joint_matches_the_filippov_solution_through_stick_breakaway_and_reversal(name):
    p = PLANTS[name]
    assert plant_params(p).rate * DT <= RK4_RATE_MAX  # one RK4 step per period away from zero
    lo, hi = _levels(p)
    n = 1500
    t = np.arange(n) * DT
    # a slow torque sine of 1.3x the larger breakaway level, with a held stretch below the levels: the joint
    # breaks away, slides, decelerates, sticks, reverses, and sticks again while the torque is held
    u = 1.3 * max(lo, hi) * np.sin(2 * np.pi * 1.5 * t + 0.2)
    u[700:900] = 0.5 * min(lo, hi)
    W, S = _simulate(p, u)
    Wo, So = lagged_reference(p, u, DT)
    peak = float(np.max(np.abs(Wo)))
    assert np.min(Wo) < -0.2 * peak and np.max(Wo) > 0.2 * peak  # it moved both ways
    stuck = Wo[1:] == 0.0
    assert stuck.sum() >= 150  # the oracle sticks for a while (the held stretch, the reversals)
    # where the oracle sticks the joint sticks: exactly at rest, the friction balancing the torque
    # (a step that reaches zero within the period ends at rest; allow the first period of each stick interval)
    settled = stuck & np.concatenate(([False], stuck[:-1]))
    assert np.all(W[1:][settled] == 0.0), int(np.count_nonzero(W[1:][settled]))
    np.testing.assert_allclose(S[1:][settled], u[settled], rtol=0, atol=1e-9 * max(lo, hi))
    # measured: max 0.7e-6 .. 3e-6 of the peak speed, median below 1e-6 (before the fix the joint crept and
    # chattered through the stick intervals: off by 0.5-10 % of the peak)
    err = np.abs(W - Wo)
    assert np.max(err) <= 3e-5 * peak, (np.max(err) / peak, int(np.argmax(err)))
    assert np.median(err) <= 1e-5 * peak


@pytest.mark.parametrize("name", list(PLANTS))
def test_held_torque_sticks_inside_the_static_band_and_breaks_away_outside(name):
    p = PLANTS[name]
    par = plant_params(p)
    lo, hi = _levels(p)
    for u, moves in ((0.98 * hi, 0), (-0.98 * lo, 0), (1.02 * hi, 1), (-1.02 * lo, -1)):
        st = plant_state(p, 0.0)
        for _ in range(200):
            plant_step(par, st, u, DT)
            if moves == 0:
                assert st.w == 0.0 and plant_friction(par, st) == u  # at rest, the friction balances the torque
        if moves:
            assert np.sign(st.w) == moves and abs(st.w) > 1e-3, (u, st.w)


def test_a_joint_coasting_to_rest_stops_where_the_friction_impulse_says_and_stays():
    # no viscous term, Fs = Fc (constant Coulomb friction): from w0 > 0 with u = 0 the joint decelerates at Fc/J
    # and stops at t* = J*w0/Fc exactly; then stays at rest (|u| = 0 < Fc)
    p = JointParams(J=2.0, Fc=5.0, Fs=5.0, Vs=0.05, delta=1.0, sigma=0.0, tau=0.0)
    w0 = 0.0123
    W, S = _simulate(p, np.zeros(40), w0=w0)
    t_stop = p.J * w0 / p.Fc  # 4.92 ms
    k = np.arange(W.size) * DT
    moving = k < t_stop
    np.testing.assert_allclose(W[moving], w0 - p.Fc / p.J * k[moving], rtol=0, atol=1e-12)
    assert np.all(W[~moving] == 0.0) and np.all(S[~moving][1:] == 0.0)


def test_only_steps_near_the_jump_leave_rk4():
    p = PLANTS["paper-tau0"]
    par = plant_params(p)
    # a_max = (|u| + max level + 2*sigma*|w|)/J: the step reaches 0 only if |w| <= dt*a_max
    u = 30.0
    bound = DT * (u + p.Fs) / p.J  # 16.25e-3 rad/s, sigma term below 1 %
    assert static_jump_in_reach(par, 0.0, u, DT)
    assert static_jump_in_reach(par, 0.99 * bound, u, DT) and static_jump_in_reach(par, -0.99 * bound, u, DT)
    assert not static_jump_in_reach(par, 1.05 * bound, u, DT) and not static_jump_in_reach(par, -1.05 * bound, u, DT)
    assert static_jump_in_reach(par, 0.5, float("nan"), DT)
    # far from zero the step is an ordinary RK4 step (tests/plant_oracle.py's tableau, without the jump step)
    st = plant_state(p, 0.2)
    plant_step(par, st, u, DT)
    w1, f1 = plant_oracle.rk4(p, 0.2, p.initial_state(0.2), u, DT)
    assert st.w == pytest.approx(float(w1), rel=1e-14) and st.s == pytest.approx(float(f1), rel=1e-14)
