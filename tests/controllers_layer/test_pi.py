"""Tests of controllers.design.pi: discrete PI design (margins checked independently) and the runtime PI."""

import math

import numpy as np
import pytest
from scipy import optimize, signal

from controllers.design.pi import MAX_CROSSOVER_FRACTION, PIController, PIDesign, closed_loop_step, design_pi
from plant.errors import ParameterError
from plant.friction import preset
from plant.joint import make_rk4_step

# (J, sigma, crossover, phase_margin, Tc)
CASES = [
    (4.0, 0.0, 20.0, 60.0, 1e-3),
    (4.0, 40.0, 100.0, 45.0, 1e-3),
    (0.01, 0.0, 600.0, 30.0, 1e-3),
    (0.5, 2.0, 50.0, 70.0, 2e-3),
]


def _loop_numpy(d: PIDesign, w):
    """Independent L(exp(j w Tc)): hand-derived ZOH plant times the backward-Euler PI."""
    z = np.exp(1j * np.asarray(w) * d.Tc)
    if d.sigma == 0.0:
        P = d.Tc / (d.J * (z - 1.0))
    else:
        a = math.exp(-d.sigma * d.Tc / d.J)
        P = (1.0 - a) / (d.sigma * (z - a))
    C = d.Kp + d.Ki * d.Tc * z / (z - 1.0)
    return C * P


@pytest.mark.parametrize("J, sigma, wc, pm, Tc", CASES)
def test_margins_match_targets_and_independent_frequency_response(J, sigma, wc, pm, Tc):
    d = design_pi(J, sigma=sigma, crossover=wc, phase_margin=pm, Tc=Tc)
    w_nyq = math.pi / Tc
    # gain crossover of the numpy loop, by bracketing |L| = 1
    wgc = optimize.brentq(lambda w: abs(_loop_numpy(d, w)) - 1.0, wc / 20.0, 0.999 * w_nyq, xtol=1e-12)
    pm_ind = 180.0 + math.degrees(np.angle(_loop_numpy(d, wgc)))
    # targets (the brief's tolerances)
    assert abs(wgc - wc) / wc < 0.01
    assert abs(pm_ind - pm) < 0.5
    # python-control's margins agree with the independent evaluation
    assert d.crossover == pytest.approx(wgc, rel=1e-6)
    assert d.phase_margin == pytest.approx(pm_ind, abs=1e-6)
    # |L| decreasing and phase above -180 deg on (0, Nyquist): single crossover, GM at z = -1
    w = np.linspace(1e-3 * wc, (1 - 1e-6) * w_nyq, 20001)
    L = _loop_numpy(d, w)
    assert np.all(np.diff(np.abs(L)) < 0)
    assert np.all(np.angle(L) > -math.pi)
    assert d.phase_crossover == pytest.approx(w_nyq, rel=1e-12)
    assert d.gain_margin == pytest.approx(1.0 / abs(_loop_numpy(d, w_nyq)), rel=1e-9)
    assert d.gain_margin > 1.0


@pytest.mark.parametrize("J, sigma, wc, pm, Tc", CASES)
def test_closed_loop_poles_inside_unit_circle(J, sigma, wc, pm, Tc):
    d = design_pi(J, sigma=sigma, crossover=wc, phase_margin=pm, Tc=Tc)
    a = math.exp(-sigma * Tc / J)
    b = (1 - a) / sigma if sigma > 0 else Tc / J
    # (z - 1)(z - a) + b((Kp + Ki Tc) z - Kp) = 0
    char = np.polyadd(np.polymul([1, -1], [1, -a]), b * np.array([d.Kp + d.Ki * Tc, -d.Kp]))
    assert np.all(np.abs(np.roots(char)) < 1.0)


def test_gains_tend_to_continuous_time_formula_for_fast_sampling():
    J, sigma, wc, pm = 4.0, 40.0, 30.0, 60.0
    d = design_pi(J, sigma=sigma, crossover=wc, phase_margin=pm, Tc=1e-6)
    phi_c = math.pi - math.radians(pm) - math.atan2(J * wc, sigma)
    mag = math.hypot(J * wc, sigma)
    assert d.Kp == pytest.approx(mag * math.cos(phi_c), rel=1e-3)
    assert d.Ki == pytest.approx(wc * mag * math.sin(phi_c), rel=1e-3)


def test_discrete_gains_differ_from_continuous_at_coarse_sampling():
    # at Tc = 5 ms and 100 rad/s the hold costs ~14 deg: the continuous gains would miss the target
    J, wc, pm, Tc = 1.0, 100.0, 60.0, 5e-3
    d = design_pi(J, crossover=wc, phase_margin=pm, Tc=Tc)
    phi_c = math.pi / 2 - math.radians(pm)
    cont = PIDesign(Kp=J * wc * math.cos(phi_c), Ki=J * wc * wc * math.sin(phi_c), Tc=Tc, crossover=wc,
                    phase_margin=pm, gain_margin=math.inf, phase_crossover=math.nan,
                    stability_margin=math.nan, J=J, sigma=0.0, C=d.C, plant=d.plant, loop=d.loop)
    pm_cont = 180.0 + math.degrees(np.angle(_loop_numpy(cont, wc)))
    assert pm - pm_cont > 5.0  # naive design loses > 5 deg
    assert 180.0 + math.degrees(np.angle(_loop_numpy(d, wc))) == pytest.approx(pm, abs=1e-6)


def test_closed_loop_step_final_values():
    d = design_pi(4.0, sigma=40.0, crossover=100.0, phase_margin=60.0, Tc=1e-3)
    s = closed_loop_step(d, t_end=0.5)
    assert s.t.shape == s.w.shape == s.u.shape == (501,)
    assert s.t[-1] == pytest.approx(0.5)
    assert s.w[0] == 0.0  # strictly proper loop: no direct feedthrough to w
    assert s.u[0] == pytest.approx(d.Kp + d.Ki * d.Tc, rel=1e-9)  # first command
    assert s.w[-1] == pytest.approx(1.0, abs=1e-6)  # integral action
    assert s.u[-1] == pytest.approx(40.0, rel=1e-6)  # u = sigma * w in steady state


def test_controller_equals_linear_filter_without_saturation():
    d = design_pi(4.0, sigma=40.0, crossover=100.0, Tc=1e-3)
    c = PIController.from_design(d)
    e = np.random.default_rng(3).standard_normal(500)
    u = np.array([c.step(ek) for ek in e.tolist()])
    u_ref = signal.lfilter([d.Kp + d.Ki * d.Tc, -d.Kp], [1.0, -1.0], e)
    np.testing.assert_allclose(u, u_ref, rtol=1e-11, atol=1e-11)
    assert c.integral == pytest.approx(d.Ki * d.Tc * e.sum(), rel=1e-11)
    assert not c.saturated


def test_feedforward_is_added_before_saturation():
    c = PIController(Kp=2.0, Ki=0.0, Tc=1e-3, u_max=10.0)
    assert c.step(1.0, u_ff=3.0) == pytest.approx(5.0)
    assert not c.saturated
    assert c.step(1.0, u_ff=9.0) == 10.0
    assert c.saturated
    assert c.step(-1.0, u_ff=-9.5) == -10.0


def test_integral_does_not_wind_up_under_saturation():
    Kp, Ki, Tc, u_max, u_ff, e = 2.0, 70.0, 1e-2, 10.0, 3.0, 1.0
    c = PIController(Kp=Kp, Ki=Ki, Tc=Tc, u_max=u_max)
    n = 1000
    for _ in range(n):
        u = c.step(e, u_ff)
    # clamped exactly where the command touches the limit; a plain integrator would hold n*Ki*Tc*e = 700
    assert c.integral == pytest.approx(u_max - Kp * e - u_ff, abs=1e-12)
    assert u == u_max and c.saturated
    # error reverses: the command leaves the limit on the very first step
    I0 = c.integral
    u = c.step(-0.5, u_ff)
    assert u == pytest.approx(Kp * -0.5 + I0 + Ki * Tc * -0.5 + u_ff, rel=1e-12)
    assert u < u_max and not c.saturated


def test_integral_held_when_proportional_part_alone_saturates():
    c = PIController(Kp=2.0, Ki=70.0, Tc=1e-2, u_max=10.0)
    c.reset(1.5)
    for _ in range(100):
        assert c.step(10.0) == 10.0  # Kp*e = 20 > u_max
    assert c.integral == 1.5
    for _ in range(100):
        assert c.step(-10.0) == -10.0
    # Kp*e = -20 alone saturates the other way: the headroom -u_max - Kp*e = 10 > 1.5, held again
    assert c.integral == 1.5


def test_negative_saturation_symmetric():
    Kp, Ki, Tc, u_max = 2.0, 70.0, 1e-2, 10.0
    c = PIController(Kp=Kp, Ki=Ki, Tc=Tc, u_max=u_max)
    for _ in range(500):
        u = c.step(-1.0, -3.0)
    assert u == -u_max
    assert c.integral == pytest.approx(-u_max + Kp + 3.0, abs=1e-12)


def test_zero_steady_state_error_under_constant_disturbance_on_inertia():
    p = preset("paper").frictionless()
    d = design_pi(p.J, crossover=100.0, phase_margin=60.0, Tc=1e-3)
    c = PIController.from_design(d)
    step = make_rk4_step(p, d.Tc)
    w_ref, dist = 0.5, 20.0  # rad/s, N·m load torque from t = 0.5 s
    w = f = 0.0
    err = []
    for k in range(2000):
        u = c.step(w_ref - w)
        w, f = step(w, f, u - (dist if k >= 500 else 0.0))
        err.append(w_ref - w)
    assert max(err[500:600]) > 1e-3  # the disturbance did push the velocity
    assert abs(err[-1]) < 1e-9
    assert c.integral == pytest.approx(dist, rel=1e-8)  # the integrator carries the load


@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(J=0.0), "J"),
        (dict(J=-1.0), "J"),
        (dict(J=1.0, sigma=-0.1), "sigma"),
        (dict(J=1.0, crossover=0.0), "crossover"),
        (dict(J=1.0, crossover=float("nan")), "crossover"),
        (dict(J=1.0, Tc=1e-2, crossover=MAX_CROSSOVER_FRACTION * math.pi / 1e-2 * 1.01), "crossover"),
        (dict(J=1.0, phase_margin=0.0), "phase_margin"),
        (dict(J=1.0, phase_margin=90.0), "phase_margin"),
        (dict(J=1.0, phase_margin=-10.0), "phase_margin"),
        (dict(J=1.0, Tc=0.0), "Tc"),
        (dict(J=1.0, sigma=1000.0, crossover=10.0, phase_margin=60.0), "phase_margin"),
    ],
)
def test_design_bad_inputs(kwargs, name):
    J = kwargs.pop("J")
    with pytest.raises(ParameterError, match=name):
        design_pi(J, **kwargs)


@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(Kp=-1.0, Ki=1.0, Tc=1e-3), "Kp"),
        (dict(Kp=1.0, Ki=-1.0, Tc=1e-3), "Ki"),
        (dict(Kp=1.0, Ki=1.0, Tc=0.0), "Tc"),
        (dict(Kp=1.0, Ki=1.0, Tc=1e-3, u_max=0.0), "u_max"),
        (dict(Kp=1.0, Ki=1.0, Tc=1e-3, u_max=float("nan")), "u_max"),
        (dict(Kp=float("inf"), Ki=1.0, Tc=1e-3), "Kp"),
    ],
)
def test_controller_bad_inputs(kwargs, name):
    with pytest.raises(ParameterError, match=name):
        PIController(**kwargs)


def test_controller_keyword_only_and_type_errors():
    with pytest.raises(TypeError):
        PIController(1.0, 1.0, 1e-3)  # noqa: keyword-only
    with pytest.raises(TypeError, match="u_max"):
        PIController(Kp=1.0, Ki=1.0, Tc=1e-3, u_max="10")


# ---------------------------------------------------------------------------------------------------- pi_step
def _random_pi_case(rng):
    """Random gains, limit and a run of errors/feedforwards that saturate part of the time (both signs)."""
    Kp = float(rng.choice([0.0, 10.0 ** rng.uniform(-2, 3)]))
    Ki = float(rng.choice([0.0, 10.0 ** rng.uniform(-1, 4)]))
    Tc = float(10.0 ** rng.uniform(-4, -2))
    u_max = float(rng.choice([math.inf, 10.0 ** rng.uniform(-1, 2)]))
    n = 400
    scale = 10.0 ** rng.uniform(-3, 1)
    e = scale * np.cumsum(rng.standard_normal(n)) / 4.0  # slowly varying: long stretches in saturation
    e[rng.random(n) < 0.05] = 0.0  # d == 0 branch
    u_ff = rng.choice([0.0, 1.0]) * 10.0 ** rng.uniform(-1, 2) * rng.standard_normal(n)
    integral0 = float(rng.normal(0.0, 5.0))
    return dict(Kp=Kp, Ki=Ki, Tc=Tc, u_max=u_max, integral0=integral0), e.tolist(), u_ff.tolist()


def test_pi_step_without_limit_is_the_backward_difference_filter():
    """u_max = inf: the command and the integrator over whole runs equal C(z) = Kp + Ki*Tc*z/(z-1) from
    scipy (cont2discrete, backward differences; lfilter from the initial integrator), to 1e-12 of the run's scale."""
    from controllers.design.pi import pi_step
    from pi_oracle import pi_linear

    rng = np.random.default_rng(20240611)
    for _ in range(40):
        kw, e, u_ff = _random_pi_case(rng)
        kw["u_max"] = math.inf
        st = PIController(**kw).cdata  # the C struct, stepped as the engine steps it
        u, integral = np.empty(len(e)), np.empty(len(e))
        for k, (ek, fk) in enumerate(zip(e, u_ff)):
            u[k] = pi_step(st, ek, fk)
            integral[k] = st.I
        u_o, integral_o = pi_linear(e, u_ff, Kp=kw["Kp"], Ki=kw["Ki"], Tc=kw["Tc"], integral0=kw["integral0"])
        scale = max(1.0, float(np.max(np.abs(u_o))), float(np.max(np.abs(integral_o))))
        assert np.max(np.abs(u - u_o)) <= 1e-12 * scale
        assert np.max(np.abs(integral - integral_o)) <= 1e-12 * scale
        assert not st.saturated


def test_pi_step_with_limit_follows_the_conditional_integration_rule():
    """Saturating runs against OraclePI (tests/pi_oracle.py: the clamping rule of the class Notes, written as
    the room left to the limit): command and integrator to 1e-12 of the run's scale, the saturation flag wherever
    the command is not within that rounding of the limit."""
    from controllers.design.pi import pi_step
    from pi_oracle import OraclePI

    rng = np.random.default_rng(20240610)
    n_sat = n_clamped = 0
    for _ in range(60):
        kw, e, u_ff = _random_pi_case(rng)
        ref = OraclePI(**kw)
        ctl = PIController(**kw)
        st = PIController(**kw).cdata
        scale = max(1.0, abs(kw["integral0"]), float(np.max(np.abs(u_ff))),
                    kw["Kp"] * float(np.max(np.abs(e))), kw["u_max"] if math.isfinite(kw["u_max"]) else 0.0)
        for ek, fk in zip(e, u_ff):
            I_before = ref.integral
            u_ref = ref.step(ek, fk)
            u_cls = ctl.step(ek, fk)
            u_raw = pi_step(st, ek, fk)
            assert u_cls == u_raw and st.I == ctl.integral  # the class is the C step on its struct
            tol = 1e-12 * max(scale, abs(ref.integral))
            assert abs(u_raw - u_ref) <= tol and abs(st.I - ref.integral) <= tol
            if abs(abs(ek * kw["Kp"] + st.I + fk) - kw["u_max"]) > tol:
                assert bool(st.saturated) == ref.saturated == ctl.saturated
            n_sat += ref.saturated
            n_clamped += ref.saturated and abs(ref.integral - (I_before + kw["Ki"] * kw["Tc"] * ek)) > tol
    assert n_sat > 1000 and n_clamped > 100  # the cases exercise saturation and the clamp


def test_pi_struct_fields_and_properties():
    c = PIController(Kp=2.0, Ki=70.0, Tc=1e-2, u_max=10.0, integral0=1.5)
    st = c.cdata
    assert (st.Kp, st.KiTc, st.u_max, st.I, st.saturated) == (2.0, 70.0 * 1e-2, 10.0, 1.5, 0)
    assert (c.Kp, c.Ki, c.Tc, c.u_max, c.integral, c.saturated) == (2.0, 70.0, 1e-2, 10.0, 1.5, False)
    c.step(10.0)
    assert c.saturated and st.saturated == 1
    c.integral = -2.0
    assert st.I == -2.0
    with pytest.raises(ParameterError, match="integral"):
        c.integral = float("nan")
    c.reset()
    assert (st.I, st.saturated) == (0.0, 0)


def test_pi_pickles_and_copies_its_state():
    """A pickled or deep-copied controller (a process pool) carries gains and integrator, owns its own struct
    and continues exactly as the original."""
    import copy
    import pickle

    c = PIController(Kp=2.0, Ki=70.0, Tc=1e-2, u_max=10.0, integral0=1.5)
    e = np.random.default_rng(5).standard_normal(300).tolist()
    for x in e[:100]:
        c.step(x, 2.0)
    copies = [pickle.loads(pickle.dumps(c)), copy.deepcopy(c)]
    for d in copies:
        assert d.cdata != c.cdata
        assert (d.Kp, d.Ki, d.Tc, d.u_max, d.integral, d.saturated) == (c.Kp, c.Ki, c.Tc, c.u_max, c.integral,
                                                                         c.saturated)
    u = [c.step(x, 2.0) for x in e[100:]]
    for d in copies:
        assert [d.step(x, 2.0) for x in e[100:]] == u and d.integral == c.integral


def test_pi_tuning_gives_its_gains_or_the_design_at_its_targets():
    from controllers.design.pi import PITuning

    assert PITuning(Kp=3.0, Ki=7.0).gains(4.0, sigma=1.0, Tc=1e-3) == (3.0, 7.0)
    d = design_pi(4.0, sigma=1.0, crossover=35.0, phase_margin=55.0, Tc=2e-3)
    assert PITuning(crossover=35.0, phase_margin=55.0).gains(4.0, sigma=1.0, Tc=2e-3) == (d.Kp, d.Ki)
    with pytest.raises(ParameterError, match="give both --Kp and --Ki, or neither"):
        PITuning(Kp=3.0)
