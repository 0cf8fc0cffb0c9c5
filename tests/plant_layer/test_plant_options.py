"""Plant options: the position-dependent friction ripple (plant.ripple) and the payload step (plant.payload).

The ripple is checked against solve_ivp of its ODE written here from the physics (not from the package's
code), the payload step against the base plant's run (bit for bit before the step) and an open-loop replay of
the recorded torque with the switched inertia (after it); both compose with FrictionDrift and round-trip
through the plant file.
"""

import json
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from controllers.design.pi import design_pi
from controllers.simulation.batch import run_batch
from controllers.simulation.closed_loop import MeasurementSettings, plant_table, run_closed_loop, run_mode
from controllers.simulation.compensators import LoopConfig, TrueFriction
from plant import (AsymmetricParams, FrictionDrift, FrictionRipple, JointParams, KarnoppParams, LuGreParams,
                   ParameterError, PayloadStep, load_plant, multisine_reference, plant_from_dict, plant_to_dict,
                   preset)
from plant._cplant import ffi
from plant.dynamics import plant_friction, plant_params, plant_simulate, plant_state, plant_step
from plant.excitation import Reference
from plant.rows import check_integrable

DT = 1e-3
P = preset("paper")  # J 4, Fc 25, Fs 35, Vs 0.02, delta 1, sigma 40, tau 0.02


def _stribeck(w, Fc, Fs, Vs, delta, sigma):
    """Eq. 3 of Ruderman for w > 0, written out: Fc + (Fs - Fc)*exp(-(w/Vs)**delta) + sigma*w."""
    return Fc + (Fs - Fc) * math.exp(-abs(w / Vs) ** delta) + sigma * w


def _R(q, a, n, phase):
    return 1.0 + a * math.sin(n * q + phase)


def _zoh_reference(rhs, y0, u, method):
    """solve_ivp of rhs(t, y, u_k) over each zero-order-hold step of DT, tight tolerances; states at the steps."""
    ys = [np.asarray(y0, dtype=float)]
    y = ys[0]
    for k, uk in enumerate(u):
        sol = solve_ivp(lambda t, yy: rhs(t, yy, uk), (k * DT, (k + 1) * DT), y, method=method, rtol=1e-11,
                        atol=1e-13)
        assert sol.success
        y = sol.y[:, -1]
        ys.append(y)
    return np.array(ys)


def _run_open_loop(p, u, w0):
    """The package's open loop: (W, S, Q) of plant_simulate from the steady state at w0, and the friction."""
    par = plant_params(p)
    st = plant_state(p, w0)
    n = len(u)
    W, S, Q = np.empty(n + 1), np.empty(n + 1), np.empty(n + 1)
    plant_simulate(par, st, np.ascontiguousarray(u, dtype=float), DT, W, S, Q)
    f = np.empty(n + 1)
    for k in range(n + 1):
        s = ffi.new("plant_state *", (W[k], S[k], math.nan))
        s.q = Q[k]
        f[k] = plant_friction(par, s)
    return W, S, Q, f


# (plant, amplitude, harmonic, phase, torque offset and swing (N·m), w0 (rad/s), tolerance relative to the peak)
LAGGED = JointParams(J=4.0, Fc=25.0, Fs=35.0, Vs=0.02, delta=1.0, sigma=40.0, tau=0.02)
STATIC = LAGGED.replace(tau=0.0)
ASYM = AsymmetricParams(J=2.0, Fc_pos=20.0, Fc_neg=15.0, Fs_pos=30.0, Fs_neg=22.0, Vs=0.05, delta=2.0,
                        sigma_pos=30.0, sigma_neg=25.0, tau=0.01)
KARN = KarnoppParams(J=4.0, Fc=25.0, Fs=35.0, Vs=0.02, delta=1.0, sigma=40.0, tau=0.02, dv=1e-3)
LUGRE = LuGreParams(J=1.0, Fc=1.0, Fs=1.5, Vs=0.05, delta=2.0, sigma0=1e3, sigma1=10.0, sigma2=0.5)
STIFF_LAG = LAGGED.replace(tau=1e-5)  # 1/tau*dt = 100: the implicit stiff step (plant_lagged_stiff_step)
# sigma0*|w|/g*dt = 300 RK4 sub-steps: the implicit stiff step (plant_lugre_stiff_step)
STIFF_LUGRE = LuGreParams(J=0.01, Fc=1.0, Fs=1.5, Vs=0.05, delta=2.0, sigma0=1e6, sigma1=100.0, sigma2=0.5)
CASES = {
    "lagged": (LAGGED, 0.2, 50.0, 0.3, 60.0, 15.0, 0.3, 1e-6),
    "static": (STATIC, 0.15, 30.0, -1.0, 60.0, 15.0, 0.3, 1e-6),
    "asymmetric": (ASYM, 0.3, 20.0, 0.0, 45.0, 10.0, 0.3, 1e-6),
    "karnopp": (KARN, 0.2, 50.0, 0.3, 60.0, 15.0, 0.3, 1e-6),
    "lugre": (LUGRE, 0.25, 40.0, 0.5, 2.5, 0.8, 0.3, 1e-6),
    # the stiff steps control their error to 1e-5 relative (plant.stiff.LAGGED_RTOL, LUGRE_RTOL): 1e-4 here
    "lagged-stiff-step": (STIFF_LAG, 0.2, 50.0, 0.3, 60.0, 15.0, 0.3, 1e-4),
    "lugre-stiff-step": (STIFF_LUGRE, 0.25, 40.0, 0.5, 2.4, 0.4, 0.3, 1e-4),
}


def _physics_rhs(p, a, n, ph):
    """The ripple ODE of plant p from the physics (Ruderman eqs. 1-3; LuGre: Canudas de Wit et al. 1995) for
    w > 0 (outside any stick band): state (w, s, q), s the friction (lagged) or the bristle deflection z."""
    if isinstance(p, LuGreParams):
        def rhs(t, y, u):
            w, z, q = y
            R = _R(q, a, n, ph)
            g = (p.Fc + (p.Fs - p.Fc) * math.exp(-abs(w / p.Vs) ** p.delta)) * R
            zdot = w - p.sigma0 * abs(w) / g * z
            return [(u - p.sigma0 * z - p.sigma1 * zdot - p.sigma2 * R * w) / p.J, zdot, w]

        def friction(y):
            w, z, q = y
            R = _R(q, a, n, ph)
            g = (p.Fc + (p.Fs - p.Fc) * math.exp(-abs(w / p.Vs) ** p.delta)) * R
            return p.sigma0 * z + p.sigma1 * (w - p.sigma0 * abs(w) / g * z) + p.sigma2 * R * w

        return rhs, friction
    if isinstance(p, AsymmetricParams):
        lv = (p.Fc_pos, p.Fs_pos, p.Vs, p.delta, p.sigma_pos)
    else:
        lv = (p.Fc, p.Fs, p.Vs, p.delta, p.sigma)

    def target(w, q):
        return _stribeck(w, *lv) * _R(q, a, n, ph)

    if p.tau == 0.0:
        def rhs(t, y, u):
            w, _, q = y
            return [(u - target(w, q)) / p.J, 0.0, w]

        return rhs, lambda y: target(y[0], y[2])

    def rhs(t, y, u):
        w, f, q = y
        return [(u - f) / p.J, (target(w, q) - f) / p.tau, w]

    return rhs, lambda y: y[1]


@pytest.mark.parametrize("name", list(CASES))
def test_ripple_open_loop_matches_an_independent_ode_solution(name):
    p, a, n, ph, u0, du, w0, tol = CASES[name]
    N = 1500
    t = np.arange(N) * DT
    u = u0 + du * np.sin(2 * np.pi * 1.5 * t)
    W, S, Q, f = _run_open_loop(FrictionRipple(p, amplitude=a, harmonic=n, phase=ph), u, w0)
    assert np.min(W) > 0.05  # stays in sliding (w > 0): the ODE below is smooth there
    rhs, friction = _physics_rhs(p, a, n, ph)
    if isinstance(p, LuGreParams):  # steady sliding at w0 at q = 0: z = g(w0)*R(0)/sigma0
        s0 = (p.Fc + (p.Fs - p.Fc) * math.exp(-abs(w0 / p.Vs) ** p.delta)) * _R(0.0, a, n, ph) / p.sigma0
    else:
        s0 = friction([w0, 0.0, 0.0]) if p.tau == 0.0 else _stribeck(w0, *(
            (p.Fc_pos, p.Fs_pos, p.Vs, p.delta, p.sigma_pos) if isinstance(p, AsymmetricParams)
            else (p.Fc, p.Fs, p.Vs, p.delta, p.sigma))) * _R(0.0, a, n, ph)
    y = _zoh_reference(rhs, [w0, s0, 0.0], u, "Radau" if name.endswith("stiff-step") else "RK45")
    f_ref = np.array([friction(yk) for yk in y])
    assert Q[-1] * n / (2 * np.pi) > 2.0  # several ripple periods travelled
    for got, want in ((W, y[:, 0]), (Q, y[:, 2]), (f, f_ref)):
        np.testing.assert_allclose(got, want, rtol=0, atol=tol * np.max(np.abs(want)))


ZOO = {"lagged": LAGGED, "static": STATIC, "asymmetric": ASYM, "karnopp": KARN, "lugre": LUGRE}


@pytest.fixture(scope="module")
def ref():
    return multisine_reference(3.0, rng=np.random.default_rng(3))


def _options(p, **kw):
    d = design_pi(p.J, crossover=20.0, phase_margin=60.0, Tc=DT)
    return LoopConfig.from_flat(Kp=d.Kp, Ki=d.Ki, **kw)


def _signals(r):
    return np.stack([r.w, r.w_meas, r.u, r.u_ff, r.f])


@pytest.mark.parametrize("name", list(ZOO))
def test_zero_amplitude_is_the_base_plant_bit_for_bit(name, ref):
    p = ZOO[name]
    flat = FrictionRipple(p, amplitude=0.0, harmonic=7.0, phase=1.0)
    u = 0.8 * np.max(np.abs(p.friction(np.array([0.5])))) * np.sin(np.arange(2000) * DT * 2 * np.pi)
    for x, y in zip(_run_open_loop(flat, u, 0.1), _run_open_loop(p, u, 0.1)):
        assert np.array_equal(x[:, None] if x.ndim == 1 else x, y[:, None] if y.ndim == 1 else y)
    o = _options(p, sensor_gate=False)
    a, b = run_mode(flat, ref, "oracle", o), run_mode(p, ref, "oracle", o)
    assert np.array_equal(_signals(a), _signals(b))
    assert run_batch([flat], ref, "none", o).rms[0] == run_batch([p], ref, "none", o).rms[0]


def test_ripple_at_constant_velocity_has_n_periods_per_revolution_and_amplitude_a_times_F():
    """A static-map joint (tau = 0) run at 2 rad/s with the true friction fed forward: the recorded friction,
    divided by F(w), against the position: 1 + a*sin(n*q + phase) to 1 %, and no component at n +- 1."""
    a, n, ph = 0.1, 12.0, 0.4
    p = STATIC
    plant = FrictionRipple(p, amplitude=a, harmonic=n, phase=ph)
    N = 7000
    t = np.arange(N) * DT
    w_ref = np.full(N, 2.0)
    reference = Reference(t=t, w=w_ref, dw=np.zeros(N))
    d = design_pi(p.J, crossover=40.0, phase_margin=60.0, Tc=DT)
    from controllers.design.pi import PIController

    r = run_closed_loop(plant, PIController(Kp=d.Kp, Ki=d.Ki, Tc=DT), TrueFriction(), reference,
                        measurement=MeasurementSettings(sensor_gate=False))
    q = np.concatenate([[0.0], np.cumsum(r.w[:-1]) * DT])  # the position the friction of sample k sits at
    keep = t > 0.5
    assert np.max(np.abs(r.w[keep] - 2.0)) < 0.01  # constant velocity
    Fw = np.array([_stribeck(w, p.Fc, p.Fs, p.Vs, p.delta, p.sigma) for w in r.w])
    y = r.f[keep] / Fw[keep]
    revs = q[keep][-1] - q[keep][0]
    assert revs > 2 * 2 * np.pi

    def fit(m):
        A = np.column_stack([np.ones(keep.sum()), np.sin(m * q[keep]), np.cos(m * q[keep])])
        return np.linalg.lstsq(A, y, rcond=None)[0]

    c0, cs, cc = fit(n)
    assert abs(c0 - 1.0) < 0.01 * a
    assert abs(math.hypot(cs, cc) - a) < 0.01 * a
    assert abs(math.atan2(cc, cs) - ph) < 0.01
    for m in (n - 1.0, n + 1.0):
        assert math.hypot(*fit(m)[1:]) < 0.05 * a


def test_payload_step_closed_loop_equals_base_before_and_the_switched_plant_after(ref):
    t_step, J_after = 1.2, 9.0
    plant = PayloadStep(P, t_step=t_step, J_after=J_after)
    o = _options(P, sensor_gate=False)
    r, base = run_mode(plant, ref, "none", o), run_mode(P, ref, "none", o)
    k = int(np.searchsorted(ref.t, t_step))
    assert ref.t[k] >= t_step > ref.t[k - 1]
    assert np.array_equal(_signals(r)[:, :k + 1], _signals(base)[:, :k + 1])  # w[k] is the state before the step
    assert not np.array_equal(r.w[k + 1:k + 50], base.w[k + 1:k + 50])
    # after the step: an independent open loop from the state at k with the recorded torque and J_after
    par = plant_params(P.replace(J=J_after))
    st = ffi.new("plant_state *", (r.w[k], r.f[k], math.nan))
    w = np.empty(len(ref.t) - k)
    w[0] = st.w
    for j in range(k, len(ref.t) - 1):
        plant_step(par, st, r.u[j], DT)
        w[j - k + 1] = st.w
    assert np.array_equal(w, r.w[k:])
    # and not the plant with its old inertia: the same replay with J departs from the record
    st = ffi.new("plant_state *", (r.w[k], r.f[k], math.nan))
    plant_step(plant_params(P), st, r.u[k], DT)
    assert st.w != r.w[k + 1]
    # the batch engine runs the same rows
    assert run_batch([plant], ref, "none", o).rms[0] == r.metrics.rms


def test_payload_on_a_drifting_rippled_plant_switches_every_row_at_its_sample(ref):
    drift = FrictionDrift(P, Fc_change=0.4, Fs_change=0.2, t_start=0.5, t_end=2.5, period=0.25)
    inner = FrictionRipple(drift, amplitude=0.1, harmonic=40.0)
    plant = PayloadStep(inner, t_step=1.1, J_after=6.0)
    table, row_k = plant_table(plant, ref.t, DT)
    k_step = int(np.searchsorted(ref.t, 1.1))
    assert list(row_k) == sorted(set(range(0, len(ref.t), 250)) | {k_step})
    for j, kj in enumerate(row_k):
        tj = ref.t[kj] if j else 0.0
        assert table[j].J == (6.0 if tj >= 1.1 else P.J)
        assert table[j].pos.Fc == drift.at(tj).Fc and table[j].ripple_a == 0.1 and table[j].ripple_n == 40.0
    # the engine against a replay with plant_step that switches the rows itself
    o = _options(P, sensor_gate=False)
    r = run_mode(plant, ref, "none", o)
    st = plant_state(plant.at(0.0), float(ref.w[0]))
    w = [st.w]
    for k in range(len(ref.t) - 1):
        j = int(np.searchsorted(row_k, k, side="right")) - 1
        plant_step(table + j, st, r.u[k], DT)
        w.append(st.w)
    assert np.array_equal(np.array(w), r.w)
    # the wrappers' order does not matter: the same rows, the same run
    other = PayloadStep(FrictionDrift(FrictionRipple(P, amplitude=0.1, harmonic=40.0), Fc_change=0.4,
                                      Fs_change=0.2, t_start=0.5, t_end=2.5, period=0.25), t_step=1.1, J_after=6.0)
    assert np.array_equal(_signals(run_mode(other, ref, "none", o)), _signals(r))
    # the design inertia is the plant's J at t = 0
    assert plant.J == P.J and plant.at(0.0).J == P.J


def test_drift_and_ripple_alone_are_unchanged_by_the_row_starts(ref):
    """A FrictionDrift's rows still start every period (samples j*seg), as before the row_k generalisation."""
    drift = FrictionDrift(P, t_start=0.0, t_end=2.0, period=0.01)
    table, row_k = plant_table(drift, ref.t, DT)
    assert np.array_equal(row_k, np.arange(0, len(ref.t), 10)) and len(table) == len(row_k)
    static, k0 = plant_table(FrictionRipple(P, amplitude=0.2, harmonic=3.0), ref.t, DT)
    assert len(static) == 1 and list(k0) == [0]


PLANTS_FILE = [
    FrictionRipple(LUGRE, amplitude=0.2, harmonic=100.0, phase=0.5),
    PayloadStep(ASYM, t_step=2.0, J_after=3.0),
    PayloadStep(FrictionRipple(FrictionDrift(KARN, Fc_change=0.3), amplitude=0.05, harmonic=2.5), t_step=0.0,
                J_after=1.5),
]


@pytest.mark.parametrize("p", PLANTS_FILE, ids=["ripple", "payload", "all"])
def test_plant_file_round_trip(p, tmp_path):
    d = plant_to_dict(p)
    assert json.loads(json.dumps(d)) == d
    assert plant_from_dict(d) == p
    path = tmp_path / "plant.json"
    path.write_text(json.dumps(d))
    assert load_plant(path) == p


@pytest.mark.parametrize("kw, key", [
    (dict(amplitude=1.0, harmonic=2.0), "amplitude"), (dict(amplitude=-0.1, harmonic=2.0), "amplitude"),
    (dict(amplitude=math.nan, harmonic=2.0), "amplitude"), (dict(amplitude=0.1, harmonic=0.0), "harmonic"),
    (dict(amplitude=0.1, harmonic=-3.0), "harmonic"), (dict(amplitude=0.1, harmonic=math.inf), "harmonic"),
    (dict(amplitude=0.1, harmonic=math.nan), "harmonic"), (dict(amplitude=0.1, harmonic=2.0, phase=math.nan), "phase"),
])
def test_ripple_bad_values_name_the_key_and_value(kw, key):
    with pytest.raises(ParameterError, match=key):
        FrictionRipple(P, **kw)
    d = {"model": "lagged-stribeck", **P.to_dict(), "ripple": kw}
    with pytest.raises(ParameterError, match=key):
        plant_from_dict(d)


@pytest.mark.parametrize("kw, key", [
    (dict(t_step=-1.0, J_after=1.0), "t_step"), (dict(t_step=math.nan, J_after=1.0), "t_step"),
    (dict(t_step=1.0, J_after=0.0), "J_after"), (dict(t_step=1.0, J_after=-2.0), "J_after"),
    (dict(t_step=1.0, J_after=math.nan), "J_after"), (dict(t_step=1.0, J_after=math.inf), "J_after"),
])
def test_payload_bad_values_name_the_key_and_value(kw, key):
    with pytest.raises(ParameterError, match=key):
        PayloadStep(P, **kw)
    with pytest.raises(ParameterError, match=key):
        plant_from_dict({"model": "lagged-stribeck", **P.to_dict(), "payload": kw})


def test_plant_file_tables_refuse_unknown_and_missing_keys():
    base = {"model": "lagged-stribeck", **P.to_dict()}
    with pytest.raises(ParameterError, match="amplitude"):  # a string in the file: a typed error naming it
        plant_from_dict({**base, "ripple": {"amplitude": "0.1", "harmonic": 2}})
    with pytest.raises(TypeError, match="J_after"):
        PayloadStep(P, t_step=1.0, J_after="2")
    with pytest.raises(ParameterError, match="unknown ripple key"):
        plant_from_dict({**base, "ripple": {"amplitude": 0.1, "harmonic": 2, "n": 3}})
    with pytest.raises(ParameterError, match="harmonic"):
        plant_from_dict({**base, "ripple": {"amplitude": 0.1}})
    with pytest.raises(ParameterError, match="J_after"):
        plant_from_dict({**base, "payload": {"t_step": 1.0}})
    with pytest.raises(ParameterError, match="payload"):
        plant_from_dict({**base, "payload": [1.0, 2.0]})
    with pytest.raises(ParameterError, match="FrictionRipple"):
        FrictionRipple(FrictionRipple(P, amplitude=0.1, harmonic=2.0), amplitude=0.1, harmonic=2.0)
    with pytest.raises(ParameterError, match="make_step"):
        FrictionRipple(P, amplitude=0.1, harmonic=2.0).make_step(DT)


def test_a_hand_made_struct_with_a_bad_ripple_is_refused_before_a_run():
    for model in (P, LUGRE):
        par = plant_params(FrictionRipple(model, amplitude=0.1, harmonic=3.0))
        check_integrable(par, DT)
        for a, n in ((1.5, 3.0), (0.1, 0.0), (0.1, math.nan), (-0.2, 3.0)):
            par.ripple_a, par.ripple_n = a, n
            with pytest.raises(ParameterError, match="ripple"):
                check_integrable(par, DT)


def test_wrappers_delegate_to_the_plant_at_t0():
    drift = FrictionDrift(P, Fc_change=0.3)
    p = PayloadStep(FrictionRipple(drift, amplitude=0.1, harmonic=5.0), t_step=0.0, J_after=7.0)
    assert p.J == 7.0 and p.Fc == P.Fc and p.Fc_change == 0.3 and p.MODEL == P.MODEL
    assert p.frictionless().at(1.0).J == 7.0 and p.frictionless().at(1.0).Fc == 0.0
    assert FrictionRipple(P, amplitude=0.1, harmonic=5.0).tau == P.tau
    assert not hasattr(FrictionRipple(P, amplitude=0.1, harmonic=5.0), "at")


def test_joint_params_from_dict_reads_its_own_model_and_names_what_is_wrong():
    assert JointParams.from_dict(P.to_dict()) == P
    assert JointParams.from_dict({"model": "lagged-stribeck", **P.to_dict()}) == P
    with pytest.raises(ParameterError, match=r"^model 'lugre' is not 'lagged-stribeck'; read such plants with "
                                             r"plant\.models\.plant_from_dict / load_plant$"):
        JointParams.from_dict({**P.to_dict(), "model": "lugre"})
    with pytest.raises(ParameterError, match=r"miss the key\(s\) \['tau'\]"):
        JointParams.from_dict({k: v for k, v in P.to_dict().items() if k != "tau"})
    with pytest.raises(ParameterError, match=r"unknown 'lagged-stribeck' plant parameter key\(s\) \['dv'\]"):
        JointParams.from_dict({**P.to_dict(), "dv": 1.0})
