"""The peers as C compensator components (struct and ops table) against the oracles of tests/peers_oracle.py.

The oracles are written from the peers' equations and run over whole signals: Canudas de Wit's compensator as
the sample intervals of the accepted samples, the rows of the sampled motor model, the RLS (the package's,
checked on its own by tests/adaptive_ff_layer/test_rls.py) and the direction-dependent map; the disturbance observer as the raw
disturbance samples through its binomial Q-filter (scipy's ``lfilter`` with coefficients from
``cont2discrete``). The components run on long seeded random streams with direction changes, sticking (dead
zone), non-finite samples, warm-up and saturation of the compensation, through their methods and through their
C ops tables on their structs (as the closed-loop engine calls them); every output, the update instants,
the parameter history and the counters are compared with the oracle fed the same signals.
"""

import json
import math
import pickle

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as hst

import peers_oracle as oracle
from controllers.peers.canudas import CanudasCompensator, CanudasCompensatorConfig
from controllers._cctl import ffi
from controllers.peers.dob import DOB_ORDER_MAX, DisturbanceObserver
from plant.errors import ParameterError
from adaptive_ff.compensation.eq4_feedforward import AdaptiveFrictionFeedforwardConfig
from adaptive_ff.compensation.adaptive_feedforward import RobustAdaptiveFeedforwardConfig
from adaptive_ff.compensation.sliding_estimator import SlidingFrictionEstimatorConfig

SETTINGS = dict(deadline=None, derandomize=True, database=None, max_examples=12,
                suppress_health_check=[HealthCheck.too_slow])


def _stream(seed: int, n: int, *, bad: float = 0.003, stick: bool = True):
    """Velocity (controller and raw), reference and torque streams with reversals, standstill and bad samples."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 1e-3
    w = 0.3 * np.sin(2 * np.pi * 0.7 * t) + 0.1 * np.sin(2 * np.pi * 3.1 * t + 1.0) + rng.normal(0, 0.004, n)
    if stick:
        for s in rng.integers(0, n - 200, 6):  # standstill phases (inside any dead zone)
            w[s:s + int(rng.integers(20, 200))] = 0.0
    w_ref = 0.3 * np.sin(2 * np.pi * 0.7 * t)
    u = 20.0 * np.sign(w) + 8.0 * w + rng.normal(0, 2.0, n)
    wc = w.copy()
    wm = w + rng.normal(0, 1e-4, n)
    for arr in (wc, wm, u):
        idx = rng.random(n) < bad
        arr[idx] = rng.choice([math.nan, math.inf, -math.inf], idx.sum())
    return wc, wm, w_ref, u


def _same(a, b) -> bool:
    """Equal bit for bit (NaN equal to NaN)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    return a.shape == b.shape and bool(np.all((a == b) | (np.isnan(a) & np.isnan(b))))


def _run_canudas(c, wc, wm, wr, u_in):
    """The component's methods in the engine's order (compensate, apply, observe): compensation, applied torque,
    update flags and theta after each update (NaN elsewhere)."""
    wc, wm, wr, u_in = wc.tolist(), wm.tolist(), wr.tolist(), u_in.tolist()  # Python floats, as the engine had
    n = len(wc)
    out, u, upd, th = np.empty(n), np.empty(n), np.zeros(n, dtype=bool), np.full((n, 5), np.nan)
    for k in range(n):
        out[k] = c.compensate(wc[k], wr[k])
        u[k] = u_in[k] + out[k]
        n0 = c.rls.n_updates
        c.observe(u[k], wm[k])
        upd[k] = c.rls.n_updates > n0
        if upd[k]:
            th[k] = c.rls.theta
    return out, u, upd, th


def _check_canudas(c, kw, wc, wm, wr, out, u, upd, th):
    """Outputs, update instants, theta history and counters against the oracle fed the same signals.

    The oracle averages each interval's torques with numpy and solves nothing else differently: measured
    agreement 1e-15 (compensation) to 1e-13 (theta, relative to each column's range)."""
    o = oracle.canudas_path(u, wm, wc, wr, **kw)
    assert np.max(np.abs(out - o["c"])) <= 1e-11 * max(1.0, float(np.max(np.abs(o["c"]))))
    np.testing.assert_array_equal(np.flatnonzero(upd), o["update_at"])
    scale = np.maximum(np.max(np.abs(o["theta"]), axis=0), 1e-300) if o["theta"].size else 1.0
    assert np.all(np.abs(th[upd] - o["theta"]) <= 1e-10 * scale)
    assert c.n_rejected == o["n_rejected"] and c.rls.n_updates == o["rls"].n_updates
    assert c.rls.n_projected == o["rls"].n_projected
    np.testing.assert_allclose(c.rls.P, o["rls"].P, rtol=0, atol=1e-10 * float(np.max(np.abs(o["rls"].P))))
    if o["coef"] is None:
        assert c.coef is None and c.estimate is None
    else:
        np.testing.assert_allclose(c.coef, o["coef"], rtol=1e-10, atol=1e-12)
        assert c.estimate["J"] == pytest.approx(c.Ts / float(o["rls"].theta[0]), rel=1e-10)
    return o



def _canudas(Tc, **settings):
    """A Canudas compensator with the flat ``settings`` (fields of :class:`CanudasCompensatorConfig`)."""
    return CanudasCompensator(Tc=Tc, config=CanudasCompensatorConfig(**settings))

CANUDAS_CASES = [
    dict(Tc=1e-3, Ts=1e-3, warmup=0, w_dead=0.0),
    dict(Tc=1e-3, Ts=5e-3, warmup=40, w_dead=0.02, ff_max=21.0),
    dict(Tc=1e-3, Ts=1e-2, warmup=10, forgetting="exponential", lam=0.99, ff_input="reference"),
    dict(Tc=2e-4, Ts=6e-4, warmup=300, P0=1e3, J_guess=0.5, ff_max=0.0),
]


@pytest.mark.parametrize("kw", CANUDAS_CASES)
def test_canudas_methods_equal_the_oracle(kw):
    c = _canudas(**kw)
    wc, wm, wr, u_in = _stream(1, 12000)
    out, u, upd, th = _run_canudas(c, wc, wm, wr, u_in)
    o = _check_canudas(c, kw, wc, wm, wr, out, u, upd, th)
    n_on = int(np.count_nonzero(out))
    assert o["n_rejected"] > 20 and o["rls"].n_updates > 100  # the stream exercised rejection and updates
    if kw["warmup"] < 300 and kw.get("ff_max", 1.0) > 0.0:
        assert n_on > 1000 and o["coef"] is not None
        if "ff_max" in kw:  # saturation was reached
            assert max(abs(c.compensate(x, x)) for x in (-5.0, 5.0)) == kw["ff_max"]


@given(seed=hst.integers(0, 10_000), m=hst.integers(1, 12), w_dead=hst.sampled_from([0.0, 1e-3, 0.05]),
       warmup=hst.integers(0, 80), ff_max=hst.sampled_from([math.inf, 15.0, 3.0]),
       meas=hst.booleans(), directional=hst.booleans())
@settings(**SETTINGS)
def test_canudas_property_equal_to_oracle(seed, m, w_dead, warmup, ff_max, meas, directional):
    kw = dict(Tc=1e-3, Ts=m * 1e-3, w_dead=w_dead, warmup=warmup, ff_max=ff_max,
              ff_input="measured" if meas else "reference",
              forgetting="directional" if directional else "exponential", lam=0.999 if directional else 0.995)
    c = _canudas(**kw)
    wc, wm, wr, u_in = _stream(seed, 3000, bad=0.01)
    _check_canudas(c, kw, wc, wm, wr, *_run_canudas(c, wc, wm, wr, u_in))


def _drive(c, wc, wm, wr, u_in):
    """The engine's calling sequence through the component's C ops table on its struct (compensate, apply,
    observe): compensation, update flags, and theta after each update (NaN elsewhere)."""
    from controllers._cctl import ffi

    ops, p = c.ops, c.cdata
    n, m = wc.shape[0], c.n_theta
    buf = ffi.new("double[]", max(m, 1))
    out, upd, th = np.empty(n), np.zeros(n, dtype=bool), np.full((n, m), np.nan)
    for k, (a, b, r, x) in enumerate(zip(wc.tolist(), wm.tolist(), wr.tolist(), u_in.tolist())):
        out[k] = ops.compensate(p, a, b, r)
        upd[k] = ops.observe(p, x + out[k], b, buf)
        if upd[k]:
            th[k] = list(buf)[:m]
    return out, upd, th


def test_canudas_ops_table_equals_the_oracle_and_reports_theta():
    kw = dict(Tc=1e-3, Ts=4e-3, warmup=25, w_dead=0.01, ff_max=30.0)
    c = _canudas(**kw)
    wc, wm, wr, u_in = _stream(7, 20000)
    out, upd, th = _drive(c, wc, wm, wr, u_in)
    assert np.isnan(th[~upd]).all()  # theta is reported exactly when the RLS was updated
    o = _check_canudas(c, kw, wc, wm, wr, out, u_in + out, upd, th)
    assert upd.sum() == o["rls"].n_updates > 500


def test_canudas_struct_pickle_and_coef_setter():
    c = CanudasCompensator(Tc=1e-3, config=CanudasCompensatorConfig(Ts=2e-3, warmup=3, w_dead=0.0))
    assert c.C_OPS == "ctl_canudas_ops" and c.n_theta == 5 and ffi.string(c.ops.name) == b"canudas"
    for part in ("rls", "u_range", "w_range"):  # the parts' structs are fields of the compensator's struct
        assert getattr(c, part).cdata == ffi.addressof(c.cdata, part)
    wc, wm, wr, u = _stream(3, 2000, bad=0.0, stick=False)
    for k in range(1000):
        c.observe(u[k] + c.compensate(wc[k], wr[k]), wm[k])
    d = pickle.loads(pickle.dumps(c))
    assert d.rls.cdata == ffi.addressof(d.cdata, "rls") and d.struct_bytes() == c.struct_bytes()
    for k in range(1000, 2000):  # the copy continues exactly like the original
        a, b = c.compensate(wc[k], wr[k]), d.compensate(wc[k], wr[k])
        assert a == b
        c.observe(u[k] + a, wm[k])
        d.observe(u[k] + b, wm[k])
    assert d.struct_bytes() == c.struct_bytes()
    # moved into an element of a composite's array of structs, it continues exactly like the copy
    big = ffi.new("ctl_canudas[3]")
    c._use(ffi.addressof(big, 1), big)
    assert c.cdata == ffi.addressof(big, 1) and c.rls.cdata == ffi.addressof(big[1], "rls")
    assert c.w_range.cdata == ffi.addressof(big[1], "w_range") and c.struct_bytes() == d.struct_bytes()
    e = pickle.loads(pickle.dumps(d))
    for k in range(1000, 1500):
        c.observe(u[k] + c.compensate(wc[k], wr[k]), wm[k])
        e.observe(u[k] + e.compensate(wc[k], wr[k]), wm[k])
    assert c.struct_bytes() == e.struct_bytes() and c.coef == e.coef and c.rls.n_updates == e.rls.n_updates
    c.coef = (10.0, 6.0, 8.0, 5.0)
    assert c.coef == (10.0, 6.0, 8.0, 5.0) and c.compensate(-0.5, 0.0) == -6.0 - 2.5
    c.coef = None
    assert c.coef is None and c.estimate is None and c.compensate(1.0, 1.0) == 0.0
    with pytest.raises(ParameterError, match="coef"):
        c.coef = (1.0, 2.0)
    c.coef = (10.0, 6.0, 8.0, 5.0)
    info = c.info()
    # no non-finite samples here; the rejections are torques u + compensation far above the torque envelope
    # (the compensation of a 3-update warm-up is absurd): the torque range gate
    assert c.n_rejected == c.u_range.n_rejected + c.w_range.n_rejected
    assert info == {"n_rejected": c.n_rejected, "n_updates": c.rls.n_updates, "lam": 0.999,
                    "canudas_estimate": c.estimate}
    assert info["canudas_estimate"]["J"] == c.Ts / c.rls.theta[0] and json.dumps(info, allow_nan=False)


def test_canudas_refuses_an_overflowing_row_without_touching_the_rls():
    """Finite samples whose torque sum overflows: the row is refused and counted, the RLS untouched."""
    c = CanudasCompensator(Tc=1e-3, config=CanudasCompensatorConfig(Ts=3e-3, warmup=0, w_dead=0.0))
    for u_, w_ in [(0.0, 1.0), (1.7e308, 1.0), (1.7e308, 1.0)]:  # u_sum = inf over the interval
        c.observe(u_, w_)
    rls_before = bytearray(c.rls.struct_bytes())
    c.observe(0.0, 1.0)  # closes the interval: u_bar = inf
    assert c.rls.n_updates == 0 and c.n_rejected == 1 and c.rls.n_rejected == 1
    c.rls.cdata.n_rejected = 0  # the RLS counted the refused row, nothing else changed
    assert c.rls.struct_bytes() == bytes(rls_before)
    c.rls.cdata.n_rejected = 1
    for u_, w_ in [(1.0, 1.0), (1.0, 1.0), (0.0, 1.0)]:  # the next interval is an ordinary row
        c.observe(u_, w_)
    assert c.rls.n_updates == 1 and c.coef is not None and np.all(np.isfinite(c.rls.theta))


def _check_dob(kw, wc, u, d_hat, n_rejected):
    """Estimates against the oracle fed the same velocities and torques; measured agreement 1e-13 relative
    (the oracle's lfilter runs the binomial filter in direct form, the component as a cascade)."""
    o = oracle.dob_path(wc, u, **kw)
    assert np.max(np.abs(d_hat - o["d_hat"])) <= 1e-11 * max(1.0, float(np.max(np.abs(o["d_hat"]))))
    assert n_rejected == o["n_rejected"]
    return o


@pytest.mark.parametrize("order,omega_q,d_max", [(1, 300.0, math.inf), (2, 500.0, 25.0), (4, 2000.0, 5.0)])
def test_dob_equals_the_oracle(order, omega_q, d_max):
    kw = dict(J_n=1.7, omega_q=omega_q, Tc=1e-3, order=order, d_max=d_max)
    c = DisturbanceObserver(**kw)
    wc, wm, wr, u_in = _stream(11, 12000, bad=0.005)
    d_hat, u = np.empty(12000), np.empty(12000)
    for k, (a, b, r, x) in enumerate(zip(wc.tolist(), wm.tolist(), wr.tolist(), u_in.tolist())):
        d_hat[k] = c.compensate(a, r)
        u[k] = x - d_hat[k]
        c.observe(u[k], b)
    assert c.d_hat == d_hat[-1]
    o = _check_dob(kw, wc, u, d_hat, c.n_rejected)
    assert o["n_rejected"] > 20 and np.count_nonzero(d_hat) > 10000
    if math.isfinite(d_max):
        assert np.max(np.abs(d_hat)) == d_max  # the bound acted
    c2 = DisturbanceObserver(**kw)
    out, upd, th = _drive(c2, wc, wm, wr, u_in)
    _check_dob(kw, wc, u_in + out, out, c2.n_rejected)
    assert not upd.any() and th.shape == (12000, 0)


def test_dob_layout_and_properties():
    c = DisturbanceObserver(J_n=2.0, omega_q=400.0, Tc=1e-3, order=3, d_max=9.0)
    assert c.C_OPS == "aff_dob_ops" and c.n_theta == 0 and ffi.string(c.ops.name) == b"dob"
    # the two range gates (torque, velocity) live in the observer's struct
    assert c.u_range.cdata == ffi.addressof(c.cdata, "u_range") and c.w_range.cdata == ffi.addressof(c.cdata, "w_range")
    assert (c.J_n, c.omega_q, c.Tc, c.order, c.d_max) == (2.0, 400.0, 1e-3, 3, 9.0)
    assert c.a == 1.0 - math.exp(-0.4) and c.w_last is None
    c.d_hat = 1.5
    c.n_rejected = 4
    assert c.compensate(0.1, 0.0) == 1.5 and c.w_last == 0.1 and c.n_rejected == 4
    assert c.compensate(math.nan, 0.0) == 1.5 and c.n_rejected == 5
    assert c.info() == {"n_rejected": 5, "J_n": 2.0, "omega_q": 400.0}


def test_dob_pickle_continues_exactly_and_its_gates_stay_live():
    kw = dict(J_n=1.2, omega_q=800.0, Tc=1e-3, order=2, d_max=30.0)
    c = DisturbanceObserver(**kw)
    wc, wm, wr, u_in = _stream(5, 4000, bad=0.01)
    for k in range(2000):
        c.observe(u_in[k] - c.compensate(wc[k], wr[k]), wm[k])
    d = pickle.loads(pickle.dumps(c))
    assert d.cdata != c.cdata and d.struct_bytes() == c.struct_bytes()
    assert d.u_range.cdata == ffi.addressof(d.cdata, "u_range") and d.w_range.cdata == ffi.addressof(d.cdata, "w_range")
    for k in range(2000, 4000):
        a, b = c.compensate(wc[k], wr[k]), d.compensate(wc[k], wr[k])
        assert a == b or (math.isnan(a) and math.isnan(b))
        c.observe(u_in[k] - a, wm[k])
        d.observe(u_in[k] - b, wm[k])
    assert d.struct_bytes() == c.struct_bytes()
    # every refusal is a gate's: the gate objects show the counts of the struct's gates
    assert c.n_rejected == c.u_range.n_rejected + c.w_range.n_rejected > 40
    assert c.u_range.n_rejected == c.cdata.u_range.n_rejected and c.w_range.envelope == c.cdata.w_range.env


def test_dob_order_capacity():
    assert DisturbanceObserver(J_n=1.0, Tc=1e-3, order=DOB_ORDER_MAX).order == DOB_ORDER_MAX
    with pytest.raises(ParameterError, match="order"):
        DisturbanceObserver(J_n=1.0, Tc=1e-3, order=DOB_ORDER_MAX + 1)


def _adob_parts(u_max=math.inf, start=False):
    """A robust adaptive feedforward and an observer for the ``paper`` joint, built twice from the same settings."""
    from adaptive_ff.compensation.adaptive_feedforward import FeedforwardStart, RobustAdaptiveFeedforward
    from adaptive_ff.compensation.sliding_estimator import SlidingFrictionEstimator
    from adaptive_ff.identification.regression import FrictionEstimate
    from plant.friction import preset

    p = preset("paper")
    init = FrictionEstimate(J=p.J, tau=0.0, sigma=0.8 * p.sigma, Fc=0.8 * p.Fc, Fs=0.8 * p.Fs, offset=0.0,
                            Vs=p.Vs, delta=p.delta, J_alt=math.nan)
    est = SlidingFrictionEstimator(p.Vs, p.delta, Tc=1e-3, initial=init,
                                   config=SlidingFrictionEstimatorConfig(initial_J=p.J))
    ff = RobustAdaptiveFeedforward(est, dt=1e-3, start=FeedforwardStart(init) if start else None,
                                   config=RobustAdaptiveFeedforwardConfig(warmup=20, fade_in=0.05,
                                                                          max_rel_stderr=math.inf))
    return p, ff, DisturbanceObserver(J_n=0.9 * p.J, Tc=1e-3, omega_q=400.0, d_max=60.0)


def _adob_stream(p, n, seed):
    """Velocities of a sliding joint with reversals and bad samples, and torques consistent with them (eq. 3 plus
    inertia), so that the estimator updates and the feedforward switches on."""
    from plant.friction import stribeck

    rng = np.random.default_rng(seed)
    t = np.arange(n) * 1e-3
    w = 0.2 * np.sin(2 * np.pi * 0.5 * t) + 0.05 * np.sin(2 * np.pi * 2.3 * t)
    u = p.J * np.gradient(w, 1e-3) + stribeck(w, Fc=p.Fc, Fs=p.Fs, Vs=p.Vs, delta=p.delta, sigma=p.sigma)
    wm = w + rng.normal(0.0, 1e-4, n)
    u = u + rng.normal(0.0, 0.2, n)
    for a in (wm, u):
        idx = rng.random(n) < 0.002
        a[idx] = rng.choice([math.nan, math.inf, 1e3], idx.sum())
    return wm, 0.2 * np.sin(2 * np.pi * 0.5 * t), u


@pytest.mark.parametrize("u_max,start", [(math.inf, False), (25.0, True)])
def test_adaptive_dob_is_its_parts_composed_and_moves_as_one_struct(u_max, start):
    """The composite (its ops table on its struct) equals the two parts driven by hand in the stated order:
    u_ff, then d_hat, the sum clipped to u_max; the observer records u - u_ff, the feedforward (u, w)."""
    from controllers.peers.adaptive_dob import AdaptiveDOBCompensator

    p, ff, dob = _adob_parts(u_max, start)
    c = AdaptiveDOBCompensator(ff, dob, u_max=u_max)
    assert ff.cdata == ffi.addressof(c.cdata, "ff") and dob.cdata == ffi.addressof(c.cdata.res, "dob")
    assert ff.estimator.cdata == ffi.addressof(c.cdata.ff, "est") and ffi.string(c.ops.name) == b"adaptive-dob"
    assert c.n_theta == ff.n_theta and c.u_max == u_max
    _, ff2, dob2 = _adob_parts(u_max, start)  # the reference: the parts on their own
    wm, wr, u_in = _adob_stream(p, 6000, 4)
    ops, cp = c.ops, c.cdata
    th = ffi.new("double[]", c.n_theta)
    n_upd = 0
    for k, (w, r, x) in enumerate(zip(wm.tolist(), wr.tolist(), u_in.tolist())):
        out = ops.compensate(cp, w, w, r)
        uff = ff2.compensate(w, r)
        ref = min(max(uff + dob2.compensate(w, r), -u_max), u_max)
        assert out == ref or (math.isnan(out) and math.isnan(ref)), k
        assert c.u_ff == uff or (math.isnan(uff) and math.isnan(c.u_ff))
        uk = x + 0.3 * out
        upd = ops.observe(cp, uk, w, th)
        dob2.observe(uk - uff, w)
        n0 = ff2.estimator.n_updates
        ff2.observe(uk, w)
        assert bool(upd) == (ff2.estimator.n_updates > n0)
        if upd:
            n_upd += 1
            assert list(th) == ff2.estimator.theta.tolist()
        if k == 3000:  # moved into an element of a struct array mid-run (as the engine holds it), it carries on
            arr = ffi.new("ctl_adob[2]")
            c._use(ffi.addressof(arr, 1), arr)
            cp = c.cdata
            assert ff.estimator.cdata == ffi.addressof(arr[1].ff, "est") and dob.cdata == ffi.addressof(arr[1].res, "dob")
    assert n_upd > 50 and c.active and ff2.active
    assert dob.struct_bytes() == dob2.struct_bytes() and ff.estimator.theta.tolist() == ff2.estimator.theta.tolist()
    d = pickle.loads(pickle.dumps(c))
    assert d.struct_bytes() == c.struct_bytes() and d.feedforward.estimator.cdata == ffi.addressof(d.cdata.ff, "est")
    for w, r, x in zip(wm[:500].tolist(), wr[:500].tolist(), u_in[:500].tolist()):
        a, b = c.compensate(w, r), d.compensate(w, r)
        assert a == b or (math.isnan(a) and math.isnan(b))
        c.observe(x, w)
        d.observe(x, w)
    assert d.struct_bytes() == c.struct_bytes()


def _eq4_parts(iv):
    """The eq. 4 feedforward (RLS or IV) and an observer for the ``paper`` joint, built twice from the same settings."""
    from adaptive_ff.compensation.eq4_feedforward import AdaptiveFrictionFeedforward
    from adaptive_ff.identification.regression import RegressionModel
    from plant.friction import preset

    p = preset("paper")
    ff = AdaptiveFrictionFeedforward(RegressionModel(p.Vs, p.delta), dt=1e-3,
                                     config=AdaptiveFrictionFeedforwardConfig(Ts=2e-3, warmup=50, iv=iv,
                                                                              w_band=p.Vs if iv else 0.0))
    return p, ff, DisturbanceObserver(J_n=0.9 * p.J, Tc=1e-3, omega_q=400.0, d_max=60.0)


@pytest.mark.parametrize("iv", [False, True])
def test_the_eq4_composite_is_its_parts_composed_with_the_switch_in(iv):
    """Over the eq. 4 feedforward the composite (``ctl_eq4_dob``) is the same arrangement: before the residual
    switch-in exactly the feedforward's torque, after it ``u_ff + g*d_hat`` (both clipped to u_max) with g rising by Tc/fade_in per period
    from the switch-in on; the observer records u - u_ff, the feedforward (u, w); it survives a pickle."""
    from controllers._cctl import lib
    from controllers.peers.adaptive_dob import AdaptiveDOBCompensator, ResidualSwitchIn

    p, ff, dob = _eq4_parts(iv)
    # no trial (trial_margin inf): the stream's error is made up, and the trial's verdict on it is not what this
    # composition test is about (tests/controllers_layer/test_switch_in.py tests the trial, also in the closed loop)
    sw = ResidualSwitchIn(Tc=1e-3, J_n=p.J, Kp=20.0, Ki=200.0, window=0.05, fade_in=0.02, trial_margin=math.inf)
    c = AdaptiveDOBCompensator(ff, dob, u_max=80.0, switch_in=sw)
    assert c.C_OPS == "ctl_eq4_dob_ops" and ff.cdata == ffi.addressof(c.cdata, "ff")
    assert dob.cdata == ffi.addressof(c.cdata.res, "dob") and c.estimator is ff and c.MODE == "adaptive"
    _, ff2, dob2 = _eq4_parts(iv)
    wm, wr, u_in = _adob_stream(p, 4000, 5)
    ops, cp = c.ops, c.cdata
    k_in, n_samples, n_samples2 = None, 0, 0
    for k, (w, r, x) in enumerate(zip(wm.tolist(), wr.tolist(), u_in.tolist())):
        out = ops.compensate(cp, w, w, r)
        uff = lib.aff_eq4_ff_compensate(ff2.cdata, w, w, r)
        d = dob2.compensate(w, r)
        if k_in is None and c.t_switch_in is not None:
            k_in = round(c.t_switch_in / 1e-3)
            assert k_in == k
        g = 0.0 if k_in is None else min(1.0, (k - k_in + 1) * 0.05)
        ref = min(max(uff if g == 0.0 else uff + g * d, -80.0), 80.0)  # the bound holds throughout
        assert out == pytest.approx(ref, rel=1e-12, abs=1e-12) or (math.isnan(out) and math.isnan(ref)), k
        uk = x + 0.3 * out
        n_samples += ops.observe(cp, uk, w, ffi.NULL)
        dob2.observe(uk - uff, w)
        n_samples2 += lib.aff_eq4_ff_observe(ff2.cdata, uk, w, ffi.NULL)
    assert k_in is not None and n_samples == n_samples2 > 1900 and ff.active == ff2.active
    assert dob.struct_bytes() == dob2.struct_bytes() and ff.struct_bytes() == ff2.struct_bytes()
    d = pickle.loads(pickle.dumps(c))
    assert d.struct_bytes() == c.struct_bytes() and d.feedforward.cdata == ffi.addressof(d.cdata, "ff")
    assert d.C_OPS == "ctl_eq4_dob_ops" and d.info()["t_switch_in"] == c.t_switch_in
