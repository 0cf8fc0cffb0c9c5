"""The C plant (plant.stribeck_map, plant.dynamics) against the oracle of tests/plant_oracle.py.

The oracle writes each model's right-hand side from its equations and integrates it with the classical Runge-Kutta
tableau on arrays: every step of a kernel trajectory is recomputed from the kernel's own state at its start and must
give the next recorded state. The two differ in the order of their floating-point operations (the tableau's
weights 1/6, 1/3, numpy's exp against the C library's), so the comparison is to 1e-13 of the trajectory's scale
(measured 2e-16; 1e-9 for the steps through ``w = 0``, see ``assert_steps``); a wrong sign, a wrong factor or a
step of another length is many orders above it. Eq. 3 itself (``stribeck_scalar``) is compared to 1e-15 of the
map's level. Parameters are drawn by hypothesis (derandomized) over the physical ranges of the package. The
Python-facing steps (``make_step``, ``simulate``) are the same C step, bit for bit.
"""

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import plant_oracle as oracle
from adaptive_ff.identification.simulator import InputGrid, simulate_on_grid
from plant.asymmetric import AsymmetricParams
from plant.drift import FrictionDrift
from plant._cplant import ffi
from plant.dynamics import (LUGRE_RK4_MAX, RK4_RATE_MAX, lagged_params, make_plant_step, plant_friction,
                            plant_params, plant_simulate, plant_state)
from plant.errors import ParameterError
from plant.friction import JointParams, preset, stribeck, stribeck_cutoff, stribeck_scalar
from plant.joint import simulate
from plant.karnopp import KarnoppParams
from plant.lugre import LuGreParams
from plant.variant_plants import variant

SETTINGS = settings(derandomize=True, max_examples=25, deadline=None, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
DT = 1e-3
N_STEPS = 3000

levels = st.floats(0.0, 100.0)
deltas = st.floats(-1.0, 2.5).filter(lambda d: abs(d) > 0.05)
inertias = st.floats(0.01, 50.0)
stribeck_vs = st.floats(1e-3, 0.1)
sigmas = st.floats(0.0, 50.0)
lags = st.floats(DT / 2, 0.1)
seeds = st.integers(0, 2**32 - 1)


def _static(tau: float, seed: int) -> float:
    """``tau = 0`` (the static map) for about a quarter of the draws."""
    return 0.0 if seed % 4 == 0 else tau


def _one_rk4_step(p) -> bool:
    """The oracle takes one RK4 step per DT; the kernel does too unless a stable mode is faster than
    RK4_RATE_MAX/DT (then it sub-steps: tests/plant_layer/test_stiff_lugre.py checks those against a fine-step solution)."""
    return plant_params(p).rate * DT <= RK4_RATE_MAX


def _bits(x: np.ndarray) -> np.ndarray:
    """float64 bit patterns, every NaN mapped to one pattern (NaN payloads are not results)."""
    x = np.where(np.isnan(x), np.nan, x)
    return np.ascontiguousarray(x).view(np.int64)


def assert_bit_equal(a, b):
    np.testing.assert_array_equal(_bits(np.asarray(a, dtype=float)), _bits(np.asarray(b, dtype=float)))


def _input(seed: int, level: float, n: int = N_STEPS) -> np.ndarray:
    """Torque (N·m) that reverses the joint and dwells near standstill: two sines and a bias, scaled by ``level``."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * DT
    a, b = rng.uniform(0.2, 3.0), rng.uniform(0.0, 0.5)
    f1, f2 = rng.uniform(0.3, 3.0), rng.uniform(5.0, 40.0)
    return level * (a * np.sin(2 * np.pi * f1 * t + rng.uniform(0, 6.3)) + b * np.sin(2 * np.pi * f2 * t)
                    + rng.uniform(-0.3, 0.3))


def _state(w, s, aux=math.nan):
    """A new ``plant_state`` struct."""
    return ffi.new("plant_state *", (w, s, aux))


def _run_kernel(p, u, w0, s0, *, cached_state=None):
    st_ = _state(w0, s0) if cached_state is None else ffi.new("plant_state *", cached_state[0])
    W = np.empty(u.shape[0] + 1)
    S = np.empty(u.shape[0] + 1)
    plant_simulate(plant_params(p), st_, np.ascontiguousarray(u, dtype=float), DT, W, S)
    return W, S


def assert_steps(p, W, S, u, dt=DT, rel=1e-13, rel_cross=1e-9):
    """Each recorded step ``(W[k], S[k]) -> (W[k+1], S[k+1])`` under ``u[k]`` against the oracle's step.

    ``rel`` of the trajectory's scale; ``rel_cross`` for the steps whose velocity changes sign: their RK stages
    evaluate eq. 3 next to its jump at ``w = 0``, where (``delta < 0``) its slope is unbounded, so the rounding of
    the stage velocities comes out amplified (measured up to 2e-13 of the scale on the draws)."""
    w1, s1 = oracle.step(p, W[:-1], S[:-1], u[: W.shape[0] - 1], dt)
    cross = ~(W[:-1] * W[1:] > 0.0)
    for got, want in ((W[1:], w1), (S[1:], s1)):
        scale = max(1.0, float(np.max(np.abs(want))))
        bad = np.flatnonzero(~(np.abs(got - want) <= np.where(cross, rel_cross, rel) * scale))
        assert bad.size == 0, (int(bad[0]), float(got[bad[0]]), float(want[bad[0]]))


def _compare(p, u, w0, s0, *, cached_state=None):
    Wk, Sk = _run_kernel(p, u, w0, s0, cached_state=cached_state)
    fin = np.isfinite(Wk) & np.isfinite(Sk)
    m = int(np.argmin(fin)) if not fin.all() else Wk.shape[0]  # up to a diverging draw's first overflow
    assert m > 50  # the draw ran long enough to mean something
    assert_steps(p, Wk[:m], Sk[:m], u)
    # the Python-facing step (make_step) is the same kernel
    step = p.make_step(DT)
    w, s = w0, s0
    for k, uk in enumerate(u[: min(m - 1, 300)].tolist()):
        w, s = step(w, s, uk)
        assert_bit_equal([w, s], [Wk[k + 1], Sk[k + 1]])
    return Wk[:m], Sk[:m]


# ----------------------------------------------------------------------------------------------------- eq. 3
def test_stribeck_scalar_analytic_values():
    e = math.exp(1.0)
    # delta = 1 at w = Vs: Fc + (Fs - Fc)/e + sigma*Vs
    assert stribeck_scalar(0.02, 25.0, 10.0, 0.02, 1.0, 40.0, math.inf) == pytest.approx(25.0 + 10.0 / e + 0.8,
                                                                                          rel=1e-15)
    # delta = 2 at w = -2 Vs: -(Fc + (Fs - Fc) e^-4) + sigma w
    assert stribeck_scalar(-0.04, 25.0, 10.0, 0.02, 2.0, 40.0, math.inf) == pytest.approx(
        -(25.0 + 10.0 * math.exp(-4.0)) - 1.6, rel=1e-15)
    # limits: F(0) = 0; delta < 0 at tiny speed -> Fc (the power overflows, the shape is 0); high speed -> Fc + sigma w
    assert stribeck_scalar(0.0, 25.0, 10.0, 0.02, 1.0, 40.0, math.inf) == 0.0
    assert stribeck_scalar(1e-310, 25.0, 10.0, 0.02, -1.0, 0.0, math.inf) == 25.0
    assert stribeck_scalar(-3.0, 25.0, 10.0, 0.02, 1.0, 40.0, math.inf) == -25.0 - 120.0
    assert math.isnan(stribeck_scalar(math.nan, 25.0, 10.0, 0.02, 1.0, 40.0, math.inf))


@SETTINGS
@given(Fc=levels, Fs=levels, Vs=stribeck_vs, delta=deltas, sigma=sigmas, seed=seeds)
def test_stribeck_scalar_equals_eq3(Fc, Fs, Vs, delta, sigma, seed):
    p = preset("paper").replace(Fc=Fc, Fs=Fs, Vs=Vs, delta=delta, sigma=sigma)
    wcut = stribeck_cutoff(Fc, Fs - Fc, Vs, delta)
    rng = np.random.default_rng(seed)
    w = Vs * 10.0 ** rng.uniform(-4, 4, 300)
    if math.isfinite(wcut):
        w = np.concatenate([w, wcut * rng.uniform(0.5, 3.0, 300), [wcut, np.nextafter(wcut, 0.0)]])
    w = np.concatenate([w, -w, [0.0, -0.0, 1e-310, -1e-310]])
    got = np.array([stribeck_scalar(x, Fc, Fs - Fc, Vs, delta, sigma, wcut) for x in w.tolist()])
    # to 1e-15 of the map's level (deep in the tail exp(-y) carries the relative rounding of y = |w/Vs|**delta,
    # y*eps, against the C library's pow; beyond wcut the kernel returns Fc + sigma*w)
    want = oracle.friction(p, w)
    assert np.all(np.abs(got - want) <= 1e-15 * (np.abs(want) + max(Fc, Fs)))
    # the vectorised map is the same kernel, any shape
    assert_bit_equal(stribeck(w.reshape(2, -1), Fc=Fc, Fs=Fs, Vs=Vs, delta=delta, sigma=sigma).ravel(), got)


def test_stribeck_vectorised_scalar_input_and_validation():
    assert isinstance(stribeck(0.01, Fc=25, Fs=35, Vs=0.02, delta=1, sigma=40), float)
    assert stribeck(np.zeros((0, 3)), Fc=25, Fs=35, Vs=0.02, delta=1, sigma=40).shape == (0, 3)
    with pytest.raises(ParameterError, match="Vs must be > 0"):
        stribeck(0.1, Fc=25, Fs=35, Vs=0.0, delta=1, sigma=40)
    with pytest.raises(ParameterError, match="delta must be non-zero"):
        stribeck(0.1, Fc=25, Fs=35, Vs=0.02, delta=0.0, sigma=40)
    assert stribeck_cutoff(25.0, 10.0, 0.02, -1.0) == math.inf  # the shortcut needs delta > 0
    assert stribeck_cutoff(25.0, 0.0, 0.02, 1.0) == 0.0


# ----------------------------------------------------------------------------------------------------- models
@SETTINGS
@given(J=inertias, Fc=levels, Fs=levels, Vs=stribeck_vs, delta=deltas, sigma=sigmas, tau=lags, seed=seeds)
def test_lagged_joint_step_equals_the_oracle(J, Fc, Fs, Vs, delta, sigma, tau, seed):
    p = JointParams(J=J, Fc=Fc, Fs=Fs, Vs=Vs, delta=delta, sigma=sigma, tau=_static(tau, seed))
    assume(_one_rk4_step(p))
    u = _input(seed, max(Fc, Fs) + 1.0)
    w0 = float(np.random.default_rng(seed).choice([0.0, 0.3 * Vs, -2.0 * Vs]))
    s0 = p.initial_state(w0)
    W, S = _compare(p, u, w0, s0)
    if p.tau == 0.0:  # from plant_state the step reuses F(w) of the previous step (the cache slot): same bits
        Wc, Sc = _run_kernel(p, u, w0, s0, cached_state=plant_state(p, w0))
        assert_bit_equal(Wc[: W.shape[0]], W)
        assert_bit_equal(Sc[: S.shape[0]], S)


def test_lagged_joint_crosses_zero_and_covers_both_tau_branches():
    """A fixed case with many reversals (the draws above cover the ranges; this one is sure to reverse)."""
    for p in (preset("paper"), preset("paper").replace(tau=0.0), preset("paper").replace(delta=-1.0, J=0.4)):
        u = 60.0 * np.sin(2 * np.pi * 1.5 * np.arange(N_STEPS) * DT)
        W, _ = _compare(p, u, 0.0, p.initial_state(0.0))
        assert np.sum(np.diff(np.sign(W)) != 0) >= 8


@SETTINGS
@given(J=inertias, Fc=levels, Fs=levels, Vs=stribeck_vs, delta=deltas, sigma=sigmas, tau=lags,
       dv=st.floats(1e-4, 0.05), seed=seeds)
def test_karnopp_step_equals_the_oracle(J, Fc, Fs, Vs, delta, sigma, tau, dv, seed):
    p = KarnoppParams(J=J, Fc=Fc, Fs=Fs, Vs=Vs, delta=delta, sigma=sigma, tau=_static(tau, seed), dv=dv)
    assume(_one_rk4_step(p))
    u = _input(seed, max(Fc, Fs) + 1.0)
    _compare(p, u, 0.0, 0.0)


def test_karnopp_sticks_and_breaks_away():
    for tau in (0.02, 0.0):
        p = variant("karnopp").replace(tau=tau)
        t = np.arange(N_STEPS) * DT
        u = 1.3 * p.Fs * np.sin(2 * np.pi * 0.8 * t)  # |u| rises through Fs: stick, breakaway, stick again
        W, S = _compare(p, u, 0.0, 0.0)
        stuck = W[1:] == 0.0
        assert stuck.sum() > 100 and (~stuck).sum() > 100
        np.testing.assert_array_equal(S[1:][stuck], u[stuck])  # friction balances the torque while stuck


@SETTINGS
@given(J=inertias, Fcp=levels, Fcn=levels, Fsp=levels, Fsn=levels, Vs=stribeck_vs, delta=deltas, sp=sigmas,
       sn=sigmas, tau=lags, seed=seeds)
def test_asymmetric_step_equals_the_oracle(J, Fcp, Fcn, Fsp, Fsn, Vs, delta, sp, sn, tau, seed):
    p = AsymmetricParams(J=J, Fc_pos=Fcp, Fc_neg=Fcn, Fs_pos=Fsp, Fs_neg=Fsn, Vs=Vs, delta=delta, sigma_pos=sp,
                         sigma_neg=sn, tau=_static(tau, seed))
    assume(_one_rk4_step(p))
    u = _input(seed, max(Fcp, Fcn, Fsp, Fsn) + 1.0)
    _compare(p, u, 0.0, 0.0)


def _lugre_substeps(p, W, u):
    """Sub-steps the LuGre oracle takes over the trajectory (its cost), and the most in one step."""
    aw = np.abs(W[:-1])
    rate = p.sigma0 * (aw + (np.abs(u) + max(p.Fc, p.Fs) + p.sigma2 * aw) * DT / p.J) / min(p.Fc, p.Fs)
    n = rate * DT + (p.sigma1 + p.sigma2) / p.J * DT + math.sqrt(p.sigma0 / p.J) * DT + 1.0
    return float(np.sum(n)), float(np.max(n))


@SETTINGS
@given(J=inertias, Fc=st.floats(0.5, 100.0), Fs=st.floats(0.5, 100.0), Vs=stribeck_vs, delta=deltas,
       lsigma0=st.floats(2.0, 6.0), zeta=st.floats(0.0, 2.0), sigma2=sigmas, seed=seeds)
def test_lugre_step_and_friction_equal_the_oracle(J, Fc, Fs, Vs, delta, lsigma0, zeta, sigma2, seed):
    sigma0 = 10.0**lsigma0
    p = LuGreParams(J=J, Fc=Fc, Fs=Fs, Vs=Vs, delta=delta, sigma0=sigma0, sigma1=zeta * math.sqrt(sigma0 * J),
                    sigma2=sigma2)
    n = 600
    u = _input(seed, 1.5 * max(Fc, Fs), n)
    Wk, _ = _run_kernel(p, u, 0.0, 0.0)
    total, most = _lugre_substeps(p, Wk, u)
    # the oracle's running time; its RK4 sub-steps are kept up to LUGRE_RK4_MAX per step (beyond, the stiff path
    # of tests/plant_layer/test_stiff_lugre.py)
    assume(np.all(np.isfinite(Wk)) and total < 3e5 and most < LUGRE_RK4_MAX)
    W, Z = _compare(p, u, 0.0, 0.0)
    par = plant_params(p)
    for w, z in list(zip(W.tolist(), Z.tolist()))[::7] + [(0.0, Z[-1]), (-0.0, Z[-1])]:
        got = plant_friction(par, _state(w, z))
        assert_bit_equal([got], [p.friction_torque(w, z)])
        scale = sigma0 * abs(z) + (p.sigma1 + sigma2) * abs(w) + max(Fc, Fs)  # the terms that may cancel
        assert abs(got - float(oracle.lugre_friction_torque(p, w, z))) <= 1e-13 * scale


def test_lugre_stiff_bristles_fixed_case():
    p = variant("lugre").replace(sigma0=1e6, sigma1=2000.0)
    u = 80.0 * np.sin(2 * np.pi * 2.0 * np.arange(400) * DT)
    _compare(p, u, 0.0, 0.0)


# ----------------------------------------------------------------------------------------------------- component
def test_parameter_struct_state_and_friction_of_each_model():
    for name in ("lugre", "karnopp", "asymmetric", "static"):
        p = variant(name)
        par = plant_params(p)
        assert ffi.typeof(par) is ffi.typeof("plant_params *") and 1.0 <= par.key < 2.0**52
        assert par.J == p.J and par.pos.Vs == par.neg.Vs == p.Vs and par.pos.delta == par.neg.delta == p.delta
        for w0 in (0.0, 0.05, -0.3):
            s = plant_state(p, w0)
            assert ffi.typeof(s) is ffi.typeof("plant_state *") and s.w == w0 and s.s == p.initial_state(w0)
            # the eq. 3 cache is set exactly for the static map (tau == 0, lagged)
            assert (s.aux == par.key) == (name == "static")
            if name != "lugre":
                assert plant_friction(par, s) == s.s
    with pytest.raises(TypeError, match="FrictionDrift use p.at"):
        plant_params(FrictionDrift(preset("paper")))
    with pytest.raises(TypeError, match="frozen"):
        plant_params({"J": 1.0})
    with pytest.raises(ParameterError, match="w0"):
        plant_state(preset("paper"), math.inf)
    with pytest.raises(ParameterError, match="dt"):
        make_plant_step(preset("paper"), 0.0)
    # the raw struct of the fits equals the validated one, byte for byte
    q = preset("paper")
    raw = lagged_params(q.J, q.Fc, q.Fs, q.Vs, q.delta, q.sigma, q.tau)
    assert bytes(ffi.buffer(raw)) == bytes(ffi.buffer(plant_params(q)))


def test_plant_simulate_checks_its_arrays_and_lugre_pickles_without_its_c_struct():
    import pickle

    p = variant("lugre")
    par, st = plant_params(p), plant_state(p, 0.0)
    u = np.full(10, 30.0)
    for W, S in ((np.empty(10), np.empty(11)), (np.empty(11, dtype=np.float32), np.empty(11)),
                 (np.empty(22)[::2], np.empty(11))):
        with pytest.raises(TypeError, match="float64 array of at least 11"):
            plant_simulate(par, st, u, DT, W, S)
    with pytest.raises(TypeError, match="u must be"):
        plant_simulate(par, st, [30.0] * 10, DT, np.empty(11), np.empty(11))
    assert st.w == 0.0 and st.s == 0.0  # nothing ran
    torque = p.friction_torque(0.01, 1e-4)  # caches the C struct on the (frozen) model
    q = pickle.loads(pickle.dumps(p))
    assert q == p and "_packed" not in q.__dict__ and q.friction_torque(0.01, 1e-4) == torque


def test_swapping_the_parameter_row_invalidates_the_eq3_cache():
    """tau = 0: a drifting plant swaps rows; the step after a swap must not reuse F(w) of the old row."""
    a = preset("paper").replace(tau=0.0)
    b = a.replace(Fc=30.0, Fs=45.0)
    u = 40.0 * np.sin(2 * np.pi * 1.0 * np.arange(600) * DT)
    st_ = plant_state(a, 0.0)
    W, S = np.empty((2, 301)), np.empty((2, 301))
    plant_simulate(plant_params(a), st_, u[:300], DT, W[0], S[0])
    plant_simulate(plant_params(b), st_, u[300:], DT, W[1], S[1])  # continues from the state (and cache) of a
    assert_steps(a, W[0], S[0], u[:300])
    assert_steps(b, W[1], S[1], u[300:])
    assert abs(W[1, 0]) > 0.01  # the swap happened in motion, where F(w) of the two rows differ


def test_open_loop_simulate_runs_the_kernel_for_every_model_and_drift():
    u = 50.0 * np.sin(np.linspace(0.0, 12.0, 2000))
    for name in ("lugre", "karnopp", "asymmetric", "negative-delta", "static"):
        p = variant(name)
        r = simulate(p, u, w0=0.01, f0=0.0)
        step = p.make_step(DT)
        w, s = 0.01, (p.initial_state(0.01) if name == "static" else 0.0)
        for k in (0, 1, 2):
            w, s = step(w, s, u[k])
            assert_bit_equal([r.w[k + 1], r.f[k + 1]], [w, s])
    d = FrictionDrift(preset("paper"), t_start=0.0, t_end=1.0)
    assert_bit_equal(simulate(d, u).w, simulate(preset("paper"), u).w)  # a drift runs as its plant at t = 0
    with pytest.raises(TypeError, match="frozen JointParams"):
        simulate(object(), u)


# ----------------------------------------------------------------------------------------------------- simulator
def _grid(u, n):
    """Regular grid with the step 2**-10 s (exact in binary: every sub-step is the same h)."""
    h = 2.0**-10
    tg = np.arange(n + 1) * h
    return InputGrid(tg=tg, ug=np.ascontiguousarray(u, dtype=float), idx=np.arange(n + 1, dtype=np.int64)), h


@pytest.mark.parametrize("tau", [0.02, 0.005])
def test_simulator_with_held_input_is_the_plant_step(tau):
    """u0 = um = u1 (constant input): the simulator's FOH step is the plant's ZOH step (bit for bit), and the
    oracle's steps from its states give the next ones."""
    p = preset("paper").replace(tau=tau)
    n = 3000
    grid, h = _grid(np.full(n + 1, 38.0), n)
    w = simulate_on_grid(lagged_params(p.J, p.Fc, p.Fs, p.Vs, p.delta, p.sigma, p.tau), grid, w0=-0.05, f0=3.0)
    st_ = _state(-0.05, 3.0)
    W, S = np.empty(n + 1), np.empty(n + 1)
    plant_simulate(plant_params(p), st_, np.full(n, 38.0), h, W, S)
    assert_bit_equal(w, W)
    assert_steps(p, W, S, np.full(n, 38.0), dt=h)
    assert W[0] < 0.0 < W[-1]  # it crossed zero


def test_simulator_matches_the_oracle_with_offset_and_injection():
    """FOH input, offset and output injection: the oracle's simulator on the RK tableau, to rounding."""
    p = preset("paper").replace(Fs=30.0)
    n = 800
    rng = np.random.default_rng(5)
    t = np.arange(n + 1) * 2.0**-10
    u = 70.0 + 15.0 * np.sin(2 * np.pi * 1.3 * t) + rng.normal(0.0, 1.0, n + 1)  # keeps w > 0: no chatter
    idx = np.arange(0, n + 1, 4, dtype=np.int64)
    grid = InputGrid(tg=t, ug=u, idx=idx)
    w_meas = 0.8 + 0.05 * np.sin(2 * np.pi * 0.9 * t[idx])
    for offset, gain in ((0.0, (0.0, 0.0)), (2.5, (0.0, 0.0)), (-1.5, (1.0, 0.5)), (0.5, (0.3, 0.0))):
        new = simulate_on_grid(lagged_params(p.J, p.Fc, p.Fs, p.Vs, p.delta, p.sigma, p.tau), grid, w0=0.8, f0=55.0,
                               offset=offset, gain=gain, w_meas=w_meas)
        ref = oracle.simulate_foh(t, u, idx, p, offset=offset, w0=0.8, f0=55.0, gain=gain, w_meas=w_meas)
        assert np.all(ref > 0)
        np.testing.assert_allclose(new, ref, rtol=1e-12, atol=0)
