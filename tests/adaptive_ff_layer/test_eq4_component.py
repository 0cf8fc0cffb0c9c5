"""The eq. 4 adaptive feedforward as a C compensator component against the oracle of tests/peers_oracle.py.

The oracle builds eq. 4's regressor and its inverse map from the derivation in
:mod:`adaptive_ff.identification.regression` (not from ``RegressionModel``), projects by the rule of
``project_estimate`` and feeds the fixed feedforward oracle; its RLS is the package's (checked on its own by
tests/adaptive_ff_layer/test_rls.py). It evaluates the Stribeck shape with numpy's ``exp``, which differs from the C library's
(the C code) in the last bit on some arguments, and eq. 4's covariance (condition near 1e8) amplifies those
differences over thousands of updates: the comparisons are to ``RTOL`` relative to each column's range
(measured up to 8e-11 with the offset column). In the closed loop the component runs the loop and the oracle is
fed the loop's recorded signals.
"""

import dataclasses
import json
import math
import pickle

import numpy as np
import pytest

import peers_oracle as oracle
from adaptive_ff._caff import ffi, lib
from adaptive_ff.compensation.eq4_feedforward import AdaptiveFrictionFeedforward, AdaptiveFrictionFeedforwardConfig
from adaptive_ff.compensation.feedforward import FrictionFeedforwardConfig, project_levels
from adaptive_ff.identification.regression import RegressionModel, eq4_phi, eq4_to_physical
from plant.errors import ParameterError
from plant.friction import JointParams

PLANT = JointParams(J=0.8, Fc=6.0, Fs=9.0, Vs=0.03, delta=1.2, sigma=4.0, tau=0.004)
TC = 1e-3
RTOL = 1e-9



#: The fields of the feedforward's settings (the rest of a flat ``kw`` are the eq. 4 feedforward's own).
_FF_FIELDS = {f.name for f in dataclasses.fields(FrictionFeedforwardConfig)}


def _eq4(model, *, dt, start=None, **settings):
    """The eq. 4 feedforward with the flat ``settings`` (the oracle's keywords) put into its config."""
    ff = {k: settings.pop(k) for k in list(settings) if k in _FF_FIELDS}
    return AdaptiveFrictionFeedforward(model, dt=dt, start=start, config=AdaptiveFrictionFeedforwardConfig(
        ff=FrictionFeedforwardConfig(**ff), **settings))

def _close(a, b, rtol) -> bool:
    """Equal (NaN = NaN), or within ``rtol`` times each column's largest magnitude (rows: time)."""
    a = np.atleast_1d(np.asarray(a, dtype=float))
    b = np.atleast_1d(np.asarray(b, dtype=float))
    if a.shape != b.shape:
        return False
    same = (a == b) | (np.isnan(a) & np.isnan(b))
    if rtol == 0.0 or same.all():
        return bool(same.all())
    fin = np.where(np.isfinite(b), np.abs(b), 0.0)
    scale = fin.max(axis=0) if b.ndim > 1 else fin.max()
    return bool(np.all(same | (np.abs(a - b) <= rtol * scale)))


def _same_estimate(a, b) -> bool:
    return (a is None and b is None) or (a is not None and b is not None and _close(_est_tuple(a), _est_tuple(b), 0.0))


def _est_tuple(e):
    return None if e is None else (e.J, e.tau, e.sigma, e.Fc, e.Fs, e.offset, e.J_alt)


def _record(c):
    e = _est_tuple(c.estimate)
    return np.concatenate([c.theta, np.diag(c.rls.P), [math.nan] * 7 if e is None else e,
                           [c.u_ff, c.n_rejected, c.n_implausible, c.rls.n_updates]])


def _oracle_record(est, ff):
    e = _est_tuple(est.estimate)
    return np.concatenate([est.rls.theta, np.diag(est.rls.P), [math.nan] * 7 if e is None else e,
                           [ff.u_ff, est.n_rejected, est.n_implausible, est.rls.n_updates]])


def _open_stream(seed, n):
    """Samples (u, w) of a plant moving back and forth, with noise and non-finite entries."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.01
    w = 0.4 * np.sin(2 * np.pi * 0.3 * t) + 0.15 * np.sin(2 * np.pi * 1.3 * t) + rng.normal(0, 0.002, n)
    u = 20.0 * np.tanh(w / 0.02) + 4.0 * w + 3.0 * np.gradient(w, t) + rng.normal(0, 0.5, n)
    for arr in (u, w):
        idx = rng.random(n) < 0.004
        arr[idx] = rng.choice([math.nan, math.inf, -math.inf], idx.sum())
    return u.tolist(), w.tolist()


@pytest.mark.parametrize("struct", [dict(), dict(lag=False), dict(stribeck=False), dict(offset=True),
                                    dict(lag=False, stribeck=False, offset=True)])
def test_standalone_observe_and_step_equal_the_oracle(struct):
    Vs, delta = (PLANT.Vs, PLANT.delta) if struct.get("stribeck", True) else (None, None)
    kw = dict(Ts=0.01, lam=0.99, warmup=50, ff_max=60.0, tau_max=0.5)
    model = RegressionModel(Vs, delta, **struct)
    c = _eq4(model, dt=TC, **kw)
    est = oracle.Eq4Estimator(model, **kw)
    ff = oracle.Feedforward(dt=TC, ff_max=60.0)
    u, w = _open_stream(3, 3000)
    rc, ro, sc, so = [], [], [], []
    for k in range(len(u)):
        assert c.observe(u[k], w[k]) == est.sample(u[k], w[k])
        if est.estimate is not ff.estimate:
            ff.use(est.estimate)
        for j in range(3):
            x = w[k] if math.isfinite(w[k]) else 0.1
            sc.append(c.step(x, 0.3 if j else None))
            so.append(ff.step(x, 0.3 if j else None))
        rc.append(_record(c))
        ro.append(_oracle_record(est, ff))
    rc, ro = np.array(rc), np.array(ro)
    assert np.array_equal(rc[:, -3:], ro[:, -3:])  # counters exactly
    assert _close(rc, ro, RTOL) and _close(sc, so, RTOL) and _close(c.rls.P, est.rls.P, RTOL)
    assert est.n_rejected > 5 and est.rls.n_updates > 2900 and est.estimate is not None
    assert (c.estimate.Vs, c.estimate.delta) == (est.estimate.Vs, est.estimate.delta)


def _reference(n):
    t = np.arange(n) * TC
    return (0.5 * np.sin(2 * np.pi * 0.4 * t) + 0.2 * np.sin(2 * np.pi * 1.7 * t + 0.5)).tolist()


def _closed_loop(n, seed, step_comp, observe_comp):
    """A velocity loop on PLANT: sensor noise and faults, held last good measurement for the controller, PI with
    output limit, friction with lag (Euler, 10 substeps). Columns: w, u, u_ff, w_meas, w_ctrl."""
    rng = np.random.default_rng(seed)
    noise = rng.normal(0.0, 2e-4, n).tolist()
    faults = set(rng.integers(100, n, 15).tolist()) | {1000, 2000, 2500, 3100}  # some on sample instants
    wr = _reference(n)
    J, Fc, Fs, Vs, dl, sg, tau = PLANT.J, PLANT.Fc, PLANT.Fs, PLANT.Vs, PLANT.delta, PLANT.sigma, PLANT.tau
    Kp, KiTc, umax = 16.0, 16.0 * 5.0 * TC, 80.0
    w = f = integ = 0.0
    held = w
    out = np.empty((n, 5))
    for k in range(n):
        wm = math.nan if k in faults else w + noise[k]
        if math.isfinite(wm):
            held = wm
        wc = held
        uff = step_comp(k, wc, wm, wr[k])
        e = wr[k] - wc
        integ += KiTc * e
        u = min(max(Kp * e + integ + uff, -umax), umax)
        observe_comp(k, u, wm)
        out[k] = (w, u, uff, wm, wc)
        h = TC / 10
        for _ in range(10):
            F = math.copysign(Fc + (Fs - Fc) * math.exp(-((abs(w) / Vs) ** dl)), w) + sg * w if w != 0.0 else 0.0
            w, f = w + h * (u - f) / J, f + h * (F - f) / tau
    return out


def _component_loop(c, n, seed):
    hist = []
    th = np.empty(c.n_theta)

    th_c = ffi.from_buffer("double[]", th, require_writable=True)

    def comp(k, wc, wm, wr):
        return lib.aff_eq4_ff_compensate(c.cdata, wc, wm, wr)

    def obs(k, u, wm):
        if lib.aff_eq4_ff_observe(c.cdata, u, wm, th_c):
            hist.append((k, th.copy()))

    return _closed_loop(n, seed, comp, obs), hist


@pytest.mark.parametrize("measured,Ts,n", [(True, 0.01, 12000), (False, 0.005, 12000)])
def test_closed_loop_protocol_equals_the_oracle_on_the_loop_record(measured, Ts, n):
    """The component in the engine's calling sequence (a sample of the stream every m periods with the previous
    period's torque, before the feedforward's step): its outputs and parameter history against the oracle fed
    the loop's recorded torques and velocities."""
    model = RegressionModel(Vs=PLANT.Vs, delta=PLANT.delta)
    kw = dict(Ts=Ts, warmup=300, lag=True, ff_max=40.0)
    c = _eq4(model, dt=TC, **kw, ff_input="measured" if measured else "reference")
    m = int(round(Ts / TC))
    got, h_got = _component_loop(c, n, 5)
    u_prev = np.concatenate([[0.0], got[:-1, 1]])
    o = oracle.eq4_path(u_prev, got[:, 3], got[:, 4], np.array(_reference(n)), model, dt=TC, measured=measured, **kw)
    assert _close(got[:, 2], o["u_ff"], RTOL)
    assert [k for k, _ in h_got] == np.flatnonzero(o["sampled"]).tolist() == list(range(m, n, m))
    assert _close(np.array([x for _, x in h_got]), o["theta"], RTOL)
    assert _close(_record(c), _oracle_record(o["est"], o["ff"]), RTOL)
    # the run exercised rejection, the estimate and the feedforward
    assert o["est"].n_rejected > 0 and o["est"].estimate is not None and np.abs(got[:, 2]).max() > 1.0


def test_a_struct_copy_through_the_ops_table_continues_exactly_like_the_component():
    """What the closed-loop engine does: copy the component's struct by value into its own storage and call the
    ops table. The copy is a complete compensator (no pointer into the original): driven through
    ``aff_eq4_ff_ops`` it gives the same outputs, parameter history and final struct as the component driven
    through the functions, and the original is left untouched by the copy's run."""
    n = 5000
    rng = np.random.default_rng(2)
    wm = 0.3 * np.sin(np.arange(n) * 2e-3) + rng.normal(0, 1e-3, n)
    wm[rng.integers(0, n, 10)] = np.nan
    wc = np.where(np.isfinite(wm), wm, 0.0)
    wr = 0.3 * np.sin(np.arange(n) * 2e-3)
    u = 10.0 * np.tanh(wm / 0.01) + rng.normal(0, 0.3, n)
    model = RegressionModel(PLANT.Vs, PLANT.delta)
    a = AdaptiveFrictionFeedforward(model, dt=TC, config=AdaptiveFrictionFeedforwardConfig(Ts=0.004, warmup=20))
    for k in range(n // 2):  # the copy is taken mid-run
        c = lib.aff_eq4_ff_compensate(a.cdata, wc[k], wm[k], wr[k])
        lib.aff_eq4_ff_observe(a.cdata, u[k] + c, wm[k], ffi.NULL)
    store = ffi.new("aff_eq4_ff[2]")  # the engine's per-scenario array
    store[1] = a.cdata[0]
    frozen = a.struct_bytes()
    ops = lib.aff_eq4_ff_ops
    assert ffi.string(ops.name) == b"adaptive"
    self_ = ffi.addressof(store, 1)
    t_ops, t_fn = np.empty(a.n_theta), np.empty(a.n_theta)
    b = AdaptiveFrictionFeedforward(model, dt=TC, config=AdaptiveFrictionFeedforwardConfig(Ts=0.004, warmup=20))
    b.cdata[0] = a.cdata[0]
    upd = 0
    for k in range(n // 2, n):
        c1 = ops.compensate(self_, wc[k], wm[k], wr[k])
        c2 = lib.aff_eq4_ff_compensate(b.cdata, wc[k], wm[k], wr[k])
        assert c1 == c2
        o1 = ops.observe(self_, u[k] + c1, wm[k], ffi.from_buffer("double[]", t_ops, require_writable=True))
        o2 = lib.aff_eq4_ff_observe(b.cdata, u[k] + c2, wm[k], ffi.from_buffer("double[]", t_fn, require_writable=True))
        assert o1 == o2
        if o1:
            upd += 1
            assert np.array_equal(t_ops, t_fn) and np.array_equal(t_fn, b.theta)
    assert bytes(ffi.buffer(self_)) == b.struct_bytes() and a.struct_bytes() == frozen
    assert upd == (n - 1) // 4 - (n // 2 - 1) // 4 and b.n_rejected > 0 and b.estimate is not None


def test_c_phi_and_inverse_map_against_the_model_the_oracle_and_the_analytic_theta():
    for struct in [dict(), dict(lag=False), dict(stribeck=False), dict(offset=True), dict(lag=False, offset=True)]:
        strib = struct.get("stribeck", True)
        model = RegressionModel(PLANT.Vs if strib else None, PLANT.delta if strib else None, **struct)
        p = model.n_params
        phi = np.empty(p)
        for args in [(3.0, -1.0, 0.02, 0.01), (-2.0, 1.5, -0.5, 0.3), (0.0, 0.0, 0.0, -0.1)]:
            n = eq4_phi(phi, model, *args)
            assert n == p and _close(phi, model.phi(*args), 1e-15)
            assert _close(phi, oracle.eq4_columns(*args, model), 1e-15)
        # the inverse map is RegressionModel.to_physical bit for bit and recovers the physical parameters
        plant = PLANT.replace(tau=0.0) if not model.lag else PLANT
        plant = plant.replace(Fs=plant.Fc) if not model.stribeck else plant
        off = 0.3 if model.offset else 0.0
        theta = model.theta_from_physical(plant, 0.01, offset=off)
        got = eq4_to_physical(theta, 0.01, model.lag, model.stribeck, model.offset)
        assert _close(got, _est_tuple(model.to_physical(theta, 0.01)), 0.0)
        assert _close(got, oracle.eq4_physical(theta, model, 0.01), 1e-15)
        np.testing.assert_allclose(got[:6], [plant.J, plant.tau, plant.sigma, plant.Fc, plant.Fs, off], rtol=1e-12,
                                   atol=1e-15)
    # b0 == b1: no input gain -> non-finite, like numpy (1/0 = inf)
    J, tau, *_ = eq4_to_physical(np.array([1.0, 0.5, 0.2, 0.2, 0.1, 0.1]), 0.01, True, True, False)
    assert math.isinf(tau) or math.isnan(tau)
    ref = RegressionModel(0.03, 1.0).to_physical([1.0, 0.5, 0.2, 0.2, 0.1, 0.1], 0.01)
    assert _close((J, tau), (ref.J, ref.tau), 0.0)


def test_projection_equals_project_estimate():
    raw = dict(J=2.0, tau=-0.01, sigma=-3.0, Fc=-1.0, Fs=5.0, offset=0.0)
    cases = [raw, {**raw, "tau": 3.0}, {**raw, "Fs": math.nan}, {**raw, "J": -1.0}, {**raw, "J": 0.0},
             {**raw, "Fc": 9.0}, {**raw, "offset": math.inf}, {**raw, "tau": -0.0, "sigma": -0.0}]
    for d in cases:
        ref = oracle.admissible(tuple(d.values()) + (1.0,), tau_max=0.5, F_max=8.0)
        ok, tau, sigma, Fc, Fs = project_levels(d["J"], d["tau"], d["sigma"], d["Fc"], d["Fs"], d["offset"], 0.5, 8.0)
        assert ok == (ref is not None)
        if ok:
            assert (tau, sigma, Fc, Fs) == (ref.tau, ref.sigma, ref.Fc, ref.Fs)
            assert [math.copysign(1.0, x) for x in (tau, sigma)] == [math.copysign(1.0, x) for x in (ref.tau,
                                                                                                     ref.sigma)]


def test_layout_properties_pickle_and_validation():
    model = RegressionModel(PLANT.Vs, PLANT.delta, offset=True)
    c = AdaptiveFrictionFeedforward(model, dt=TC,
                                    config=AdaptiveFrictionFeedforwardConfig(Ts=0.01, warmup=5,
                                                                             ff=FrictionFeedforwardConfig(ff_max=30.0)))
    assert c.C_OPS == "aff_eq4_ff_ops" and c.n_theta == 7 and c.m == 10 and c.Ts == 0.01 and c.dt == TC and c.tau_max == 1.0
    # the parts live inside the component's struct
    assert c.rls.cdata == ffi.addressof(c.cdata, "rls") and c.u_range.cdata == ffi.addressof(c.cdata, "u_range")
    assert c.ff_max == 30.0 and c.ff_input == "measured" and c.lag
    assert c.estimate is None and c.static(0.3) == 0.0 and c.step(0.3) == 0.0
    u, w = _open_stream(8, 400)
    for k in range(200):
        c.observe(u[k], w[k])
    d = pickle.loads(pickle.dumps(c))
    assert d.rls.cdata == ffi.addressof(d.cdata, "rls") and d.struct_bytes() == c.struct_bytes()
    assert np.shares_memory(d.theta, np.frombuffer(ffi.buffer(d.cdata), dtype=np.uint8))
    for k in range(200, 400):
        assert c.observe(u[k], w[k]) == d.observe(u[k], w[k])
        assert c.step(0.2) == d.step(0.2)
    assert d.struct_bytes() == c.struct_bytes() and _same_estimate(d.estimate, c.estimate)
    info = c.info()
    assert info == {"estimator": "eq4-rls", "n_rejected": c.n_rejected, "n_implausible": c.n_implausible,
                    "n_updates": c.rls.n_updates, "lam": 0.995, "names": list(model.names)}
    assert info["n_updates"] == 399 - c.n_rejected and json.dumps(info, allow_nan=False)
    with pytest.raises(ParameterError, match="multiple"):
        AdaptiveFrictionFeedforward(model, dt=TC, config=AdaptiveFrictionFeedforwardConfig(Ts=0.0105))
    with pytest.raises(ParameterError, match="warmup"):
        AdaptiveFrictionFeedforward(model, dt=TC, config=AdaptiveFrictionFeedforwardConfig(Ts=0.01, warmup=-1))
    with pytest.raises(ParameterError, match="tau_max"):
        AdaptiveFrictionFeedforward(model, dt=TC, config=AdaptiveFrictionFeedforwardConfig(Ts=0.01, tau_max=0.0))
    with pytest.raises(ParameterError, match="ff_input"):
        AdaptiveFrictionFeedforward(model, dt=TC,
                                    config=AdaptiveFrictionFeedforwardConfig(Ts=0.01,
                                                                             ff=FrictionFeedforwardConfig(ff_input="predicted")))
    with pytest.raises(ParameterError, match="lam"):
        AdaptiveFrictionFeedforward(model, dt=TC, config=AdaptiveFrictionFeedforwardConfig(Ts=0.01, lam=1.5))
    with pytest.raises(ParameterError, match="model"):
        AdaptiveFrictionFeedforward("eq4", dt=TC, config=AdaptiveFrictionFeedforwardConfig(Ts=0.01))


def test_rejected_samples_leave_the_state_unchanged():
    ff = AdaptiveFrictionFeedforward(RegressionModel(PLANT.Vs, PLANT.delta), dt=TC,
                                     config=AdaptiveFrictionFeedforwardConfig(Ts=0.01, warmup=0))
    rng = np.random.default_rng(0)
    for _ in range(50):
        ff.observe(rng.normal(30.0, 5.0), rng.normal(0.2, 0.05))
    c = ff.cdata
    counters = lambda: (c.n_rejected, c.u_range.n_held, c.u_range.n_rejected, c.w_range.n_held,  # noqa: E731
                        c.w_range.n_rejected)
    n0 = counters()
    before = ff.struct_bytes()
    assert ff.observe(math.nan, 0.1) is False and ff.observe(1.0, math.inf) is False
    assert ff.n_rejected == n0[0] + 2 == 2
    assert ff.u_range.n_rejected == n0[2] + 1 and ff.w_range.n_rejected == n0[4] + 1
    # only counters changed: n_rejected, and the held/rejected counts of the torque and velocity range gates
    c.n_rejected, c.u_range.n_held, c.u_range.n_rejected, c.w_range.n_held, c.w_range.n_rejected = n0
    assert ff.struct_bytes() == before


def test_the_provisional_start_acts_until_the_first_estimate_then_the_estimate_alone():
    """With a start (at the reference, gain 0.5) the feedforward is half of eq. 3 at the reference (its closed form,
    numpy) until the first admissible estimate; from that period on it is, bit for bit, what the same feedforward
    without a start gives on the same record (the estimator sees the same samples)."""
    from adaptive_ff.compensation.adaptive_feedforward import FeedforwardStart
    from adaptive_ff.identification.regression import FrictionEstimate

    kw = dict(Ts=0.01, lam=0.99, warmup=50, ff_max=60.0, tau_max=0.5, lag=False)
    model = RegressionModel(PLANT.Vs, PLANT.delta)
    Fc, Fs, Vs, dl, sg = 5.0, 7.5, 0.025, 1.1, 2.0
    start = FeedforwardStart(FrictionEstimate(J=0.8, tau=0.0, sigma=sg, Fc=Fc, Fs=Fs, offset=0.0, Vs=Vs, delta=dl,
                                              J_alt=math.nan), gain=0.5, ff_input="reference")
    c = _eq4(model, dt=TC, start=start, **kw)
    bare = _eq4(model, dt=TC, **kw)
    assert c.active and c.provisional and c.estimate is None and not bare.active and not bare.provisional
    provisional = []

    def comp(k, wc, wm, wr):
        y = lib.aff_eq4_ff_compensate(c.cdata, wc, wm, wr)
        provisional.append(c.provisional)
        return y

    rec = _closed_loop(6000, 4, comp, lambda k, u, wm: lib.aff_eq4_ff_observe(c.cdata, u, wm, ffi.NULL))
    provisional = np.array(provisional)
    k0 = int(np.argmin(provisional))  # the period of the hand-over
    assert 100 < k0 < 5000 and not provisional[k0:].any() and c.estimate is not None
    wr = np.array(_reference(6000))
    closed_form = np.sign(wr) * (Fc + (Fs - Fc) * np.exp(-np.abs(wr / Vs) ** dl)) + sg * wr
    np.testing.assert_allclose(rec[:k0, 2], 0.5 * closed_form[:k0], rtol=1e-12, atol=1e-12)
    twin = np.empty(len(wr))
    for k, ((_, u, _, wm, wc), r) in enumerate(zip(rec, wr)):  # the loop's calling sequence on its record
        twin[k] = lib.aff_eq4_ff_compensate(bare.cdata, wc, wm, r)
        lib.aff_eq4_ff_observe(bare.cdata, u, wm, ffi.NULL)
    assert not np.any(twin[:k0]) and np.array_equal(twin[k0:], rec[k0:, 2])
    assert _same_estimate(bare.estimate, c.estimate)
    # the Python step of the start: the map at the reference, times the gain
    d = _eq4(model, dt=TC, start=start, **kw)
    assert d.step(0.3, 0.02) == pytest.approx(0.5 * (Fc + (Fs - Fc) * math.exp(-((0.02 / Vs) ** dl)) + sg * 0.02),
                                              rel=1e-12)
    with pytest.raises(ParameterError, match="start"):
        _eq4(model, dt=TC, start=start.estimate, **kw)
    no_shape = FeedforwardStart(dataclasses.replace(start.estimate, Vs=None, delta=None))
    with pytest.raises(ParameterError, match="start: a start map needs Vs and delta"):
        _eq4(RegressionModel(None, None, stribeck=False), dt=TC, start=no_shape, **kw)
    with pytest.raises(ParameterError, match="start: refused"):
        _eq4(model, dt=TC, start=dataclasses.replace(start, estimate=dataclasses.replace(
            start.estimate, Vs=-0.01)), **kw)
