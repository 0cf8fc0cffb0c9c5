"""Stiff LuGre joints and the refusal of plants the engine cannot integrate.

The stiff path of :func:`plant.dynamics.plant_step` (error-controlled extrapolated backward Euler,
:func:`plant.dynamics.lugre_stiff_step`) is checked against an independent tight-tolerance solution of the same
LuGre equations by scipy's Radau IIA (``solve_ivp``, rtol 1e-10, restarted at every 1 ms step with the torque
held), through stick, breakaway, sliding and reversal. Non-stiff LuGre joints keep their RK4 sub-steps (and their
bit-exact results, tests/plant_layer/test_plant_kernels.py).
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from controllers.design.pi import design_pi
from controllers.simulation.batch import run_batch
from controllers.simulation.closed_loop import LoopConfig, run_mode
from plant.dynamics import (LUGRE_RK4_MAX, LUGRE_STIFF_MAX, RK4_RATE_MAX,
                            check_integrable, plant_params, plant_simulate, plant_state)
from plant.errors import ParameterError
from plant.excitation import multisine_reference
from plant.asymmetric import AsymmetricParams
from plant.friction import JointParams
from plant.karnopp import KarnoppParams
from plant.lugre import LuGreParams

DT = 1e-3


def _radau(p: LuGreParams, u: np.ndarray) -> np.ndarray:
    """Velocity after every step: Radau IIA on the LuGre equations (Canudas de Wit et al. 1995), u held per step."""
    def f(t, y, uk):
        w, z = y
        zd = w - p.sigma0 * abs(w) / p.g(w) * z
        return [(uk - p.sigma0 * z - p.sigma1 * zd - p.sigma2 * w) / p.J, zd]

    y = np.zeros(2)
    W = [0.0]
    for uk in u.tolist():
        r = solve_ivp(f, (0.0, DT), y, method="Radau", rtol=1e-10, atol=[1e-12, 1e-18], args=(uk,))
        y = r.y[:, -1]
        W.append(y[0])
    return np.array(W)


def _kernel(p, u: np.ndarray) -> np.ndarray:
    st = plant_state(p, 0.0)
    W = np.empty(u.size + 1)
    S = np.empty(u.size + 1)
    plant_simulate(plant_params(p), st, np.ascontiguousarray(u), DT, W, S)
    return W


@pytest.mark.parametrize("J", [0.01, 0.05])
def test_stiff_lugre_matches_radau_through_stick_breakaway_and_reversal(J):
    p = LuGreParams(J=J, Fc=2.0, Fs=5.0, Vs=0.01, delta=2.0, sigma0=1e8, sigma1=math.sqrt(1e8 * J), sigma2=0.5)
    t = np.arange(120) * DT
    u = 7.0 * np.sin(2 * np.pi * 6.0 * t + 0.3)  # sticks (|u| < Fs), breaks away, slides, reverses, sticks again
    W = _kernel(p, u)
    Wo = _radau(p, u)
    peak = float(np.max(np.abs(Wo)))
    assert peak > 1.0 and np.min(Wo) < -0.1  # the joint did break away in both directions
    # stiff: far beyond the RK4 sub-step budget (rate*dt ~ sigma0*|w|/g*dt)
    assert p.sigma0 * peak / p.Fc * DT > 100 * LUGRE_RK4_MAX
    np.testing.assert_allclose(W, Wo, rtol=0.0, atol=1e-4 * peak)


def test_stiff_lugre_closed_loop_runs_and_tracks():
    p = LuGreParams(J=0.01, Fc=0.05, Fs=0.1, Vs=0.01, delta=2.0, sigma0=1e8, sigma1=1e3, sigma2=0.01)
    d = design_pi(p.J, crossover=20.0, phase_margin=60.0, Tc=DT)
    ref = multisine_reference(1.0, rng=np.random.default_rng(0))
    o = LoopConfig.from_flat(Kp=d.Kp, Ki=d.Ki, u_max=5.0)
    r = run_mode(p, ref, "none", o)
    b = run_batch([p, p], ref, "none", o)
    assert np.all(np.isfinite(r.w)) and not np.any(b.diverged)
    assert b.rms[0] == r.metrics.rms  # the batch engine runs the same stiff step
    free = run_mode(p, ref, "frictionless", o).metrics.rms
    # the loop tracks (error well below the reference) and the stiff friction costs tracking (not NaN, not free)
    assert free < r.metrics.rms < 0.7 * float(np.sqrt(np.mean(ref.w ** 2)))


def test_stiff_lagged_plants_take_rk4_sub_steps_and_match_a_fine_step_solution():
    # a rising friction (delta < 0) without lag and a lag far below the step: stable modes faster than 2.5/dt
    for p in (JointParams(J=0.01, Fc=0.5, Fs=2.0, Vs=0.002, delta=-1.0, sigma=0.2, tau=0.0),
              AsymmetricParams(J=0.05, Fc_pos=0.5, Fc_neg=0.4, Fs_pos=1.0, Fs_neg=0.8, Vs=0.01, delta=2.0,
                               sigma_pos=0.5, sigma_neg=0.4, tau=2e-5)):
        rate = plant_params(p).rate
        assert rate * DT > 10 * RK4_RATE_MAX
        if isinstance(p, JointParams):  # the steepest rise of eq. 3 for delta = -1: 0.541*(Fs - Fc)/Vs
            rise = 4.0 * math.exp(-2.0) * (p.Fs - p.Fc) / p.Vs  # max of d/dw e^(-Vs/w) = 4 e^-2 / Vs
            assert rate == pytest.approx((p.sigma + rise) / p.J, rel=1e-12)
        t = np.arange(400) * DT
        u = 1.5 * p.Fs * np.sin(2 * np.pi * 4.0 * t) if isinstance(p, JointParams) else \
            1.5 * p.Fs_pos * np.sin(2 * np.pi * 4.0 * t)
        W = _kernel(p, u)
        # reference: the same RK4 at a step 64 times finer than the sub-steps, u held over each DT
        st = plant_state(p, 0.0)
        par = plant_params(p)
        m = 64 * (int(rate * DT) + 1)
        Wf = np.empty(u.size * m + 1)
        Sf = np.empty(u.size * m + 1)
        plant_simulate(par, st, np.repeat(u, m), DT / m, Wf, Sf)
        assert np.all(np.isfinite(W)) and np.max(np.abs(W)) > 10 * p.Vs
        # near standstill the sign jump of the static map makes every fixed-step solution chatter with an
        # amplitude ~ Fc*h/J (h the sub-step); away from it the sub-stepped step matches the fine solution up to the
        # velocity offset such a chatter leaves in an open loop (nothing restores it): 5e-3 of the peak speed.
        # (One RK4 step per dt, as before this change, is unstable here: rate*dt > 25.)
        Fc = getattr(p, "Fc", None) or max(p.Fc_pos, p.Fc_neg)
        chatter = Fc * DT / (int(rate * DT) + 1) / p.J
        sliding = np.abs(Wf[::m]) > 20 * chatter
        assert sliding.mean() > 0.5
        np.testing.assert_allclose(W[sliding], Wf[::m][sliding], rtol=0.0, atol=5e-3 * np.max(np.abs(Wf)))
        assert np.all(np.abs(W[~sliding]) < 40 * chatter)


def test_refusal_of_unintegrable_plants_names_the_reason():
    # lagged models are never refused for stiffness (their stiff step is implicit, tests/plant_layer/test_stiff_lagged.py):
    # a lag far below the step, a viscous slope far beyond RK4's interval, a Karnopp joint with a tiny lag
    for p in (JointParams(J=1.0, Fc=1.0, Fs=2.0, Vs=0.01, delta=1.0, sigma=1.0, tau=1e-8),
              JointParams(J=1e-4, Fc=1.0, Fs=2.0, Vs=0.01, delta=1.0, sigma=1e5, tau=0.0),
              KarnoppParams(J=1.0, Fc=1.0, Fs=2.0, Vs=0.01, delta=1.0, sigma=1.0, tau=1e-7, dv=1e-3)):
        row = plant_params(p)
        assert row.rate * DT > 1000 * RK4_RATE_MAX
        check_integrable(row, DT)
    # a row not made by plant_params with a non-finite inertia: refused with the reason
    bad = plant_params(JointParams(J=1.0, Fc=1.0, Fs=2.0, Vs=0.01, delta=1.0, sigma=1.0, tau=0.0))
    bad.J = math.nan
    with pytest.raises(ParameterError, match="J = nan"):
        check_integrable(bad, DT)
    # LuGre beyond the stiff integrator's range
    absurd = LuGreParams(J=1e-4, Fc=1.0, Fs=2.0, Vs=0.01, delta=2.0, sigma0=1e14, sigma1=0.0, sigma2=0.0)
    with pytest.raises(ParameterError, match="pre-sliding frequency"):
        check_integrable(plant_params(absurd), DT)
    ref = multisine_reference(0.2, rng=np.random.default_rng(0))
    o = LoopConfig.from_flat(Kp=1.0, Ki=1.0, u_max=5.0)
    with pytest.raises(ParameterError, match="pre-sliding"):
        run_mode(absurd, ref, "none", o)
    with pytest.raises(ParameterError, match="pre-sliding"):
        run_batch([absurd], ref, "none", o)
    # at the limit: accepted
    J = 1e-2
    check_integrable(plant_params(absurd.replace(J=J, sigma0=(LUGRE_STIFF_MAX / DT) ** 2 * J)), DT)
