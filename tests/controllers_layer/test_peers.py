"""The two peers: Canudas de Wit-Åström-Braun (1987) adaptive Coulomb + viscous compensation, disturbance observer."""

import math

import numpy as np
import pytest

from controllers.peers.canudas import CanudasCompensator, CanudasCompensatorConfig
from loop_helpers import run_named
from controllers.peers.dob import DisturbanceObserver
from controllers.design.pi import design_pi
from plant import ParameterError, multisine_reference
from plant.asymmetric import AsymmetricParams

# a plant with exactly the 1987 model: static, direction-dependent Coulomb + viscous, no Stribeck effect, no lag
MATCHING = AsymmetricParams(J=2.0, Fc_pos=10.0, Fc_neg=6.0, Fs_pos=10.0, Fs_neg=6.0, Vs=0.02, delta=1.0,
                            sigma_pos=8.0, sigma_neg=5.0, tau=0.0)


def test_canudas_recovers_its_own_model_in_closed_loop():
    d = design_pi(MATCHING.J, crossover=20.0, phase_margin=60.0, Tc=1e-3)
    ref = multisine_reference(40.0, rng=np.random.default_rng(0))
    r = run_named(MATCHING, ref, mode="canudas", Kp=d.Kp, Ki=d.Ki, Ts=0.005, ff_input="reference")
    est = r.info["canudas_estimate"]
    assert est["Fc_pos"] == pytest.approx(10.0, rel=1e-3) and est["Fc_neg"] == pytest.approx(6.0, rel=1e-3)
    assert est["sigma_pos"] == pytest.approx(8.0, rel=1e-3) and est["sigma_neg"] == pytest.approx(5.0, rel=1e-3)
    # Euler discretisation of the motor model over Ts = 5 ms with the PI acting: J within 1 %
    assert est["J"] == pytest.approx(2.0, rel=0.01)
    none = run_named(MATCHING, ref, mode="none", Kp=d.Kp, Ki=d.Ki).metrics.rms_second_half
    assert r.metrics.rms_second_half < 0.3 * none


def test_canudas_compensation_is_the_direction_dependent_map():
    c = CanudasCompensator(Tc=1e-3, config=CanudasCompensatorConfig(Ts=1e-3, warmup=0, J_guess=1.0, w_dead=0.0))
    assert c.compensate(0.5, 0.5) == 0.0  # nothing before the first estimate
    c.coef = (10.0, 6.0, 8.0, 5.0)
    assert c.compensate(0.5, -1.0) == pytest.approx(10.0 + 8.0 * 0.5)
    assert c.compensate(-0.5, 1.0) == pytest.approx(-6.0 - 5.0 * 0.5)
    assert c.compensate(0.0, 1.0) == 0.0
    c2 = CanudasCompensator(Tc=1e-3, config=CanudasCompensatorConfig(ff_input="reference", ff_max=12.0))
    c2.coef = (10.0, 6.0, 8.0, 5.0)
    assert c2.compensate(-0.5, 1.0) == 12.0  # at the reference velocity, bounded


def test_dob_estimate_converges_to_a_constant_disturbance():
    """Open loop: J w' = u - d with d constant; d_hat = Q[u] - J s Q[w] -> d (Q(0) = 1)."""
    J, d, Tc = 2.0, 7.5, 1e-3
    dob = DisturbanceObserver(J_n=J, omega_q=300.0, Tc=Tc)
    w = 0.0
    u_prev = 0.0
    for k in range(3000):
        dob.compensate(w, 0.0)
        u = 20.0 * math.sin(2 * math.pi * 1.5 * k * Tc)
        dob.observe(u, w)
        w += Tc * (u - d) / J  # exact for the held u: w is linear in time over the step
        u_prev = u
    assert dob.d_hat == pytest.approx(d, rel=2e-3)
    assert u_prev != 0.0


def test_dob_cancels_coulomb_friction_in_closed_loop():
    """Coulomb-only plant at constant speed: the observer's output equals the friction torque."""
    p = MATCHING.replace(sigma_pos=0.0, sigma_neg=0.0)
    d = design_pi(p.J, crossover=20.0, phase_margin=60.0, Tc=1e-3)
    t = np.arange(5000) * 1e-3
    from plant.excitation import Reference

    ref = Reference(t=t, w=np.minimum(t, 1.0) * 0.2, dw=np.where(t < 1.0, 0.2, 0.0))
    r = run_named(p, ref, mode="dob", Kp=d.Kp, Ki=d.Ki, omega_q=200.0)
    assert r.u_ff[-1] == pytest.approx(p.Fc_pos, rel=1e-4)
    assert abs(r.w_ref[-1] - r.w[-1]) < 1e-6


def test_peer_settings_are_validated():
    with pytest.raises(ParameterError, match="omega_q"):
        DisturbanceObserver(J_n=1.0, omega_q=0.0, Tc=1e-3)
    with pytest.raises(ParameterError, match="order"):
        DisturbanceObserver(J_n=1.0, Tc=1e-3, order=0)
    with pytest.raises(ParameterError, match="multiple"):
        CanudasCompensator(Tc=1e-3, config=CanudasCompensatorConfig(Ts=0.0015))
    with pytest.raises(ParameterError, match="ff_input"):
        CanudasCompensator(Tc=1e-3, config=CanudasCompensatorConfig(ff_input="predicted"))
