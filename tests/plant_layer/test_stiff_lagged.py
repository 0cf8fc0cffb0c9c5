"""Stiff lagged plants: the implicit step of :func:`plant.dynamics.lagged_stiff_step`.

Plants whose fastest stable mode needs more than ``LAGGED_RK4_MAX`` RK4 sub-steps per 1 ms step (a rising Stribeck
map, ``delta < 0``, as the zoo draws it; a viscous slope far above ``J/dt``; a lag far below the step) are checked
against an independent tight-tolerance solution (tests/stiff_oracle.py: scipy's Radau IIA per step with the
torque held, restarted at the jumps of eq. 3, Filippov sticking for ``tau = 0``) through stick, breakaway,
sliding and reversal. The joints are the zoo's that were refused before (``python benchmarks/zoo.py --n 1000``,
seed 0: #93, #537, #925, #179; drift left out, it only swaps rows) and hand-made corners of each model.

Tolerance: the step controls the local error to ``LAGGED_RTOL = 1e-5`` of ``|w| + Vs`` per sub-step; over these
0.07-0.25 s open-loop runs (no loop removes an error: it stays) the velocity stays within 5e-3 of the peak speed,
its median within 2e-3 (measured: at most 2.4e-3 and 1.1e-3, the Karnopp joint #179; the others below 1.3e-4;
with LAGGED_RTOL = 1e-6 the worst is 5e-4, with 1e-7 1e-4: the step converges to the oracle). A step that
crept through ``w = 0`` instead of sticking, or missed the jump of the map, is off by tens of per cent.
"""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from controllers.simulation.batch import run_batch
from controllers.simulation.closed_loop import LoopConfig, run_mode
from controllers.design.pi import design_pi
from plant.asymmetric import AsymmetricParams
from plant.dynamics import (LAGGED_RK4_MAX, check_integrable, lagged_implicit_step, plant_params,
                            plant_simulate, plant_state)
from plant.excitation import multisine_reference
from plant.friction import JointParams
from plant.karnopp import KarnoppParams
from plant.models import plant_from_dict
from stiff_oracle import lagged_reference

DT = 1e-3
ZOO = json.loads((Path(__file__).parents[1] / "stiff_zoo_joints.json").read_text())


def _zoo(i: int, drift: bool = False):
    return plant_from_dict({k: v for k, v in ZOO[str(i)].items() if drift or k != "drift"})


PLANTS = {
    "zoo93-lagged-tau0": (_zoo(93), 250),
    "zoo925-lagged-lag": (_zoo(925), 250),
    "zoo537-asymmetric-lag": (_zoo(537), 250),
    "zoo179-karnopp-tau0": (_zoo(179), 250),
    "asymmetric-tau0": (AsymmetricParams(J=0.005, Fc_pos=1.0, Fc_neg=0.6, Fs_pos=3.0, Fs_neg=2.0, Vs=0.003,
                                         delta=-1.0, sigma_pos=20.0, sigma_neg=15.0, tau=0.0), 70),
    "karnopp-rising-tau0": (KarnoppParams(J=0.01, Fc=1.0, Fs=3.0, Vs=0.002, delta=-0.5, sigma=0.5, tau=0.0,
                                          dv=5e-4), 120),
}


def _kernel(p, u):
    W = np.empty(u.size + 1)
    S = np.empty(u.size + 1)
    plant_simulate(plant_params(p), plant_state(p, 0.0), np.ascontiguousarray(u), DT, W, S)
    return W, S


def _torque(p, n, hz=4.0):
    Fs = p.Fs_pos if hasattr(p, "Fs_pos") else p.Fs
    return 1.6 * Fs * np.sin(2 * np.pi * hz * np.arange(n) * DT + 0.3)


@pytest.mark.parametrize("name", list(PLANTS))
def test_stiff_lagged_step_matches_radau_through_stick_breakaway_and_reversal(name):
    p, n = PLANTS[name]
    assert plant_params(p).rate * DT > LAGGED_RK4_MAX  # the stiff path
    u = _torque(p, n, hz=4.0 if n > 200 else (8.0 if n > 100 else 14.0))
    W, _ = _kernel(p, u)
    Wo, _ = lagged_reference(p, u, DT)
    peak = float(np.max(np.abs(Wo)))
    assert np.min(Wo) < -0.3 * peak and np.max(Wo) > 0.3 * peak  # it moved both ways
    assert np.all(np.isfinite(W))
    err = np.abs(W - Wo)
    assert np.max(err) <= 5e-3 * peak, (np.max(err) / peak, int(np.argmax(err)))
    assert np.median(err) <= 2e-3 * peak


def test_a_vanishing_lag_tends_to_the_static_joint():
    # tau = 1e-6 s (1000 times below the step): the lagged joint is the static one up to ~ tau (Tikhonov)
    p = JointParams(J=0.05, Fc=1.0, Fs=2.0, Vs=0.01, delta=1.0, sigma=1.0, tau=1e-6)
    assert plant_params(p).rate * DT >= 1000.0
    u = _torque(p, 150, hz=8.0)
    W, _ = _kernel(p, u)
    Wo, _ = lagged_reference(p.replace(tau=0.0), u, DT)
    peak = float(np.max(np.abs(Wo)))
    np.testing.assert_allclose(W, Wo, rtol=0.0, atol=5e-3 * peak)


def test_implicit_step_sticks_inside_the_static_band_and_is_exact_where_linear():
    p = JointParams(J=0.02, Fc=1.0, Fs=3.0, Vs=0.002, delta=-0.5, sigma=0.5, tau=0.0)
    par = plant_params(p)
    # at rest, |u| below F(0+) = Fc (delta < 0: the map starts at Fc): stays at rest, friction balances u
    assert lagged_implicit_step(par, 0.0, 0.0, 0.7, 1e-3, 0.0) == (0.0, 0.7, 0.7)
    # sliding at -0.01 rad/s with a forward torque inside the band: stops on the jump within the step, with the
    # friction that stops it: F* = u + J*w0/h (backward Euler: J*(0 - w0) = h*(u - F*))
    w, f, Fs = lagged_implicit_step(par, -0.01, 0.0, 0.5, 1e-3, 0.0)
    assert w == 0.0 and f == Fs == pytest.approx(0.5 - 0.02 * 0.01 / 1e-3, rel=1e-12)
    assert -p.Fc <= f <= p.Fc
    # no Stribeck term (Fs = Fc) and w > 0 throughout: F is affine, backward Euler has the closed form
    q = JointParams(J=0.02, Fc=1.0, Fs=1.0, Vs=0.002, delta=1.0, sigma=400.0, tau=0.0)
    w, f, _ = lagged_implicit_step(plant_params(q), 0.5, 0.0, 300.0, 1e-3, 0.0)
    w_exact = (q.J * 0.5 + 1e-3 * (300.0 - q.Fc)) / (q.J + 1e-3 * q.sigma)
    assert w == pytest.approx(w_exact, rel=1e-12) and f == pytest.approx(q.Fc + q.sigma * w_exact, rel=1e-9)
    # with a lag: f = (f0 + a*F(w))/(1 + a), a = h/tau
    r = q.replace(tau=1e-5)
    w, f, F = lagged_implicit_step(plant_params(r), 0.5, 100.0, 300.0, 1e-3, 0.0)
    a = 1e-3 / r.tau
    assert F == pytest.approx(r.Fc + r.sigma * w, rel=1e-9) and f == pytest.approx((100.0 + a * F) / (1 + a))
    assert r.J * (w - 0.5) == pytest.approx(1e-3 * (300.0 - f), rel=1e-9)


def test_stiff_zoo_joints_run_in_the_closed_loop_engine():
    p = _zoo(93, drift=True)  # drifting, tau = 0, a rising map 1e10 times faster than 1/dt
    check_integrable(plant_params(p.base), DT)
    ref = multisine_reference(2.0, rng=np.random.default_rng(0))
    d = design_pi(p.J, crossover=20.0, phase_margin=60.0, Tc=DT)
    o = LoopConfig.from_flat(Kp=d.Kp, Ki=d.Ki, u_max=1e3, noise_std=1e-3)
    r = run_mode(p, ref, "none", o, rng=np.random.default_rng(0))
    b = run_batch([p, p], ref, "none", o, seeds=[0, 1])
    assert np.all(np.isfinite(r.w)) and not np.any(b.diverged)
    free = run_mode(p, ref, "frictionless", o, rng=np.random.default_rng(0)).metrics.rms
    assert free < r.metrics.rms < 0.5 * math.sqrt(float(np.mean(ref.w ** 2)))


# A candidate of the closed-loop fit's start search (seed 2 of benchmarks/coverage.py --method closed_loop) that
# stalled the fit: J = 1e-6 (a regression's J <= 0 clipped), Fs < Fc, tau = 2 ms. Linearised, its lag and inertia
# oscillate at 8.4e5 rad/s with a decay of 250 1/s: lagged_stiff_step resolved that at ~20000 sub-steps per step.
STALL = JointParams(J=1e-6, Fc=27.49347928859416, Fs=0.0, Vs=0.02, delta=1.0, sigma=28.47542624616106, tau=0.002)


def test_the_root_search_of_the_stalled_candidate_solves_the_backward_euler_equations():
    par = plant_params(STALL)
    for w0, f0, u, h in ((0.3, 36.0, 40.0, 1e-3), (0.3, 36.0, 40.0, 5e-8), (1e-4, 0.5, -3.0, 2e-6),
                         (-2.0, -30.0, 10.0, 1e-5)):
        w, f, F = lagged_implicit_step(par, w0, f0, u, h, 0.0)
        # the backward-Euler equations hold (eqs. 1-2): J (w - w0) = h (u - f), tau (f - f0) = h (F(w) - f)
        assert STALL.J * (w - w0) == pytest.approx(h * (u - f), rel=1e-9, abs=1e-12 * h * (abs(u) + abs(f)))
        assert STALL.tau * (f - f0) == pytest.approx(h * (F - f), rel=1e-9, abs=1e-9 * h * abs(F))


def test_an_under_damped_lag_oscillation_too_fast_for_the_step_is_refused_with_its_frequency():
    from plant.errors import ParameterError
    from plant.stiff import check_oscillation, lagged_oscillation

    # no Stribeck rise (Fs > Fc, delta > 0: the map dips): s = sigma, the eigenvalues of [[0, -1/J], [s/tau, -1/tau]]
    for J, sigma, tau in ((1e-6, 28.0, 0.002), (0.01, 400.0, 0.05), (4.0, 40.0, 0.05)):
        p = JointParams(J=J, Fc=25.0, Fs=35.0, Vs=0.02, delta=1.0, sigma=sigma, tau=tau)
        ev = np.linalg.eigvals(np.array([[0.0, -1.0 / J], [sigma / tau, -1.0 / tau]]))
        assert lagged_oscillation(plant_params(p)) == pytest.approx(float(np.max(np.abs(ev.imag))), rel=1e-12)
    assert lagged_oscillation(plant_params(JointParams(J=4.0, Fc=25.0, Fs=35.0, Vs=0.02, delta=1.0, sigma=40.0,
                                                       tau=0.02))) == 0.0  # the paper's joint: over-damped
    # the rising map of Fs < Fc adds its slope at standstill, (Fc - Fs)/Vs for delta = 1
    s = STALL.sigma + STALL.Fc / STALL.Vs
    om = math.sqrt(s / (STALL.J * STALL.tau) - 0.25 / STALL.tau**2)
    assert lagged_oscillation(plant_params(STALL)) == pytest.approx(om, rel=1e-12)
    with pytest.raises(ParameterError, match=r"oscillation 8\.\d+e\+05 rad/s .*J = 1e-06"):
        check_oscillation(plant_params(STALL), DT)
    check_oscillation(plant_params(STALL.replace(J=1e-2)), DT)  # 2.6e3 rad/s: RK4 sub-steps resolve it
    check_oscillation(plant_params(STALL.replace(tau=1e-12)), DT)  # over-damped: the implicit step's case
