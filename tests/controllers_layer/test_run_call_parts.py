"""The cheap paths of a run_mode call give what the general ones give: parts made in place, settings checked once,
one plant packing, scalar metrics, no reference cycles (docs/benchmarks/perf.md, the whole call side by side)."""

from __future__ import annotations

import gc
import math
import weakref

import numpy as np
import pytest

from adaptive_ff.compensation.adaptive_feedforward import RobustAdaptiveFeedforward
from adaptive_ff.compensation.feedforward import FrictionFeedforward, FrictionFeedforwardConfig
from adaptive_ff.compensation.gate import RangeGate, range_gate_in
from adaptive_ff.compensation.sliding_estimator import SlidingFrictionEstimator
from controllers.design.pi import design_pi
from controllers.peers.dob import DisturbanceObserver
from controllers.simulation import memory
from controllers.simulation.closed_loop import LoopConfig, run_mode
from controllers.simulation.compensators import build_mode
from controllers.simulation.metrics import METRICS_DTYPE, metrics_columns, metrics_result
from plant.errors import ParameterError
from plant.excitation import multisine_reference
from plant.friction import preset
from plant.results import json_safe
from plant.rows import params_state, plant_params, plant_state


def _options(p):
    d = design_pi(p.J, crossover=20.0, phase_margin=60.0, Tc=1e-3)
    return LoopConfig.from_flat(Kp=d.Kp, Ki=d.Ki, u_max=150.0, Vs=p.Vs, delta=p.delta, noise_std=1e-3)


def test_a_built_compensator_leaves_no_reference_cycle():
    # parts hold their composite weakly: dropping the compensator frees it and its parts at once (reference counts),
    # not at a later pass of the cyclic collector
    p = preset("paper")
    o = _options(p)
    gc.disable()
    try:
        for mode in ("adaptive", "adaptive-dob", "dob", "canudas"):
            comp = build_mode(p, mode, o)[2]
            parts = [comp] + [v for v in vars(comp).values() if hasattr(v, "struct_bytes")]
            ff = getattr(comp, "feedforward", None)
            if ff is not None:
                parts += [ff.estimator, ff.estimator.rls, ff.estimator.u_range, ff.estimator.w_range]
            refs = [weakref.ref(x) for x in parts]
            assert len(refs) >= 3 and comp.struct_bytes()
            del comp, parts, ff
            assert [r() for r in refs] == [None] * len(refs), mode
    finally:
        gc.enable()


def test_a_part_keeps_its_memory_after_its_composite_is_dropped():
    p = preset("paper")
    comp = build_mode(p, "adaptive", _options(p))[2]
    est = comp.feedforward.estimator
    raw, theta = est.struct_bytes(), est.rls.theta.copy()
    del comp
    gc.collect()
    assert est.struct_bytes() == raw and np.array_equal(est.rls.theta, theta)
    assert est.observe(1.0, 0.5) in (True, False)  # the struct still works in place


def test_default_range_gates_made_in_place_equal_a_gate_of_their_own():
    est = SlidingFrictionEstimator(0.05, 1.5, Tc=1e-3)
    own_u, own_w = RangeGate(), RangeGate(floor=0.05)
    assert est.u_range.struct_bytes() == own_u.struct_bytes()
    assert est.w_range.struct_bytes() == own_w.struct_bytes() and est.w_range.floor == 0.05
    assert (est.w_range.config.floor, est.w_range.config.memory) == (0.05, own_w.config.memory)
    dob = DisturbanceObserver(J_n=2.0, Tc=1e-3)
    assert dob.u_range.struct_bytes() == own_u.struct_bytes() == dob.w_range.struct_bytes()
    g = range_gate_in(dob, "w_range")
    assert g.struct_bytes() == own_u.struct_bytes() and g.memory == own_u.memory
    with pytest.raises(ParameterError, match="w_range must be a RangeGate, got str"):
        SlidingFrictionEstimator(0.05, 1.5, Tc=1e-3, w_range="gate")
    with pytest.raises(ParameterError, match="u_range must be a RangeGate, got int"):
        DisturbanceObserver(J_n=2.0, Tc=1e-3, u_range=3)


def test_checked_settings_are_the_constructors_settings_and_errors():
    cfg = FrictionFeedforwardConfig(lag=True, ff_max=40.0)
    own = FrictionFeedforward(None, dt=1e-3, config=cfg).config
    checked = FrictionFeedforward.checked_settings(dt=1e-3, config=cfg)
    names = [n for n, _ in FrictionFeedforward._ffi.typeof("aff_fixed_ff_config").fields]
    assert [getattr(checked, n) for n in names if n not in ("loop_model", "sign_observer")] == [
        getattr(own, n) for n in names if n not in ("loop_model", "sign_observer")]
    for kw, dt in ((dict(ff_max=-2.0), 1e-3), (dict(stick_samples=0), 1e-3), ({}, 0.0), ({}, "x")):
        bad = FrictionFeedforwardConfig(**kw)
        with pytest.raises(ParameterError) as a:
            FrictionFeedforward(None, dt=dt, config=bad)
        with pytest.raises(ParameterError) as b:
            FrictionFeedforward.checked_settings(dt=dt, config=bad)
        assert (type(a.value), str(a.value)) == (type(b.value), str(b.value))
        assert str(a.value).startswith("FrictionFeedforward: ")


def test_raw_estimate_of_info_is_the_estimates_to_dict():
    p = preset("paper")
    res = run_mode(p, multisine_reference(2.0, rng=np.random.default_rng(4)), "adaptive", _options(p),
                   rng=np.random.default_rng(5))
    comp = build_mode(p, "adaptive", _options(p))[2]
    ff = comp.feedforward
    assert isinstance(ff, RobustAdaptiveFeedforward)
    assert ff.info()["raw_estimate"] == ff.estimator.estimate.to_dict()
    assert res.mode == "adaptive" and res.info["raw_estimate"]["J"] > 0 and res.info["Ts"] == 0.01


def test_params_state_is_plant_state_of_the_packed_plant():
    p = preset("paper")
    par = plant_params(p)
    for w0 in (0.0, 0.3, -1.2):
        a, b = params_state(par, w0), plant_state(p, w0)
        assert (a.w, a.s) == (b.w, b.s) and (math.isnan(a.aux) and math.isnan(b.aux) or a.aux == b.aux)
    with pytest.raises(ParameterError, match="w0 must be finite"):
        params_state(par, math.inf)


def test_metrics_result_equals_the_vectorised_columns_bit_for_bit():
    rng = np.random.default_rng(11)
    st = np.zeros(6, METRICS_DTYPE)
    for k in METRICS_DTYPE.names:
        st[k] = rng.integers(0, 4, 6) if st[k].dtype.kind == "i" else rng.uniform(0.0, 3.0, 6)
    st["n"][1] = st["n_half"][2] = st["n_rev"][3] = 0
    st["e2_rev_c"][4] = -10.0  # a sum below 0: NaN as numpy's square root gives
    cols = metrics_columns(st)
    for b in range(6):
        r = metrics_result(st[b:b + 1])
        for k, v in cols.items():
            x, y = getattr(r, k), float(v[b])
            assert x == y or (math.isnan(x) and math.isnan(y)), (b, k, x, y)
    assert math.isnan(metrics_result(st[1:2]).rms) and math.isnan(metrics_result(st[4:5]).rms_reversal)


def test_available_memory_reuses_a_reading_for_its_lifetime(monkeypatch):
    reads, now = [], [100.0]
    monkeypatch.setattr(memory, "_read_available", lambda: reads.append(1) or (4096 * len(reads), "are available"))
    monkeypatch.setattr(memory.time, "monotonic", lambda: now[0])
    monkeypatch.setattr(memory, "_reading", [-math.inf, None])
    assert memory.available_memory() == (4096, "are available")
    now[0] += 0.5 * memory.READING_LIFETIME
    assert memory.available_memory() == (4096, "are available") and len(reads) == 1
    now[0] += memory.READING_LIFETIME
    assert memory.available_memory() == (8192, "are available") and len(reads) == 2


def test_json_safe_fast_paths_keep_the_general_answers():
    assert json_safe({"a": 1.5, "b": math.nan, 3: [math.inf, 2], "c": {"d": True}}) == {
        "a": 1.5, "b": None, "3": [None, 2], "c": {"d": True}}
    assert json_safe(np.float64(2.5)) == 2.5 and type(json_safe(np.float64(2.5))) is float
    assert json_safe(True) is True and json_safe(7) == 7


def _cfg_values(x):
    """The settings ``x`` was configured from, field by field (their padding bytes aside), NaN as the string "nan";
    None: none."""
    def value(v):
        if not isinstance(v, x._ffi.CData):
            return "nan" if v != v else v
        t = x._ffi.typeof(v)
        if t.kind == "struct":
            return {n: value(getattr(v, n)) for n, _ in t.fields}
        return [value(e) for e in v]

    c = x.config
    return None if c is None else value(c[0])


def _built_parts_composite(p, o):
    """Mode ``adaptive``'s compensator made the general way: every part by its own constructor, then copied into the
    composite's struct (the settings from ``o`` as :func:`build_mode` makes them)."""
    from adaptive_ff.compensation.gate import OutlierGate
    from controllers.peers.adaptive_dob import AdaptiveCompensator, ResidualSwitchIn
    from adaptive_ff.compensation.supervisor import FeedforwardSupervisor
    comp = build_mode(p, "adaptive", o)[2]  # its settings objects (the parts' config dataclasses)
    ff, est = comp.feedforward, comp.feedforward.estimator
    gate = OutlierGate(max_step=est.gate.max_step)
    own_est = SlidingFrictionEstimator(est.Vs, est.delta, Tc=est.Tc, config=est.settings, initial=o.estimator.initial,
                                       gate=gate)
    own_ff = RobustAdaptiveFeedforward(own_est, dt=ff.dt, config=ff.settings, start=ff.start, loop_model=ff.loop_model,
                                       sign_observer=ff.sign_observer)
    dob = sw = sup = None
    if comp.observer is not None:
        d = comp.observer
        dob = DisturbanceObserver(J_n=d.J_n, omega_q=d.omega_q, Tc=d.Tc, d_max=d.d_max)
        sw = ResidualSwitchIn(**{k: getattr(comp.switch_in, k) for k in ("Tc", "J_n", "Kp", "Ki", "ratio")})
    if comp.supervisor is not None:
        s = comp.supervisor
        sup = FeedforwardSupervisor(Tc=s.cdata.Tc, J_n=s.cdata.J_n, omega=s.cdata.omega, config=s.settings)
    return comp, AdaptiveCompensator(own_ff, dob, u_max=comp.u_max, switch_in=sw, supervisor=sup,
                                     crossover=comp.config.res.crossover if dob is not None else 0.0)


@pytest.mark.parametrize("extra", [{}, dict(supervise=False), dict(switch_in=False), dict(forgetting="directional"),
                                   dict(lam=(0.999, 0.998, 0.997, 0.999, 0.999, 0.998, 0.999), offset=True),
                                   dict(sign_input="measured", stick_input="reference")])
def test_a_composite_made_of_unbuilt_parts_is_the_composite_of_built_parts(extra):
    # build_mode's adaptive compensator (its parts made in its struct by its C init) against the one of parts made
    # by their constructors and copied in: the same bytes, settings and attributes of every part
    p = preset("paper")
    comp, own = _built_parts_composite(p, _options(p).replace(**extra))
    assert comp.struct_bytes() == own.struct_bytes() and _cfg_values(comp) == _cfg_values(own)
    pairs = [(comp.feedforward, own.feedforward), (comp.estimator, own.estimator),
             (comp.estimator.rls, own.estimator.rls), (comp.estimator.gate, own.estimator.gate),
             (comp.observer, own.observer), (comp.supervisor, own.supervisor)]
    for a, b in pairs:
        assert (a is None) == (b is None)
        if a is None:
            continue
        assert a.struct_bytes() == b.struct_bytes() and _cfg_values(a) == _cfg_values(b), type(a).__name__
        assert a._holder() is not None and a.struct_bytes() in comp.struct_bytes()
    e, f = comp.estimator, own.estimator
    assert (e.names, e.m, e.Ts, e.Vs, e.delta, e.lag, e.offset) == (f.names, f.m, f.Ts, f.Vs, f.delta, f.lag, f.offset)
    assert np.array_equal(e.box[0], f.box[0]) and np.array_equal(e.box[1], f.box[1])
    assert (e.rls.n_params, e.rls.forgetting) == (f.rls.n_params, f.rls.forgetting)
    assert np.array_equal(np.ravel(e.rls.lam), np.ravel(f.rls.lam)) and np.array_equal(e.rls.theta, f.rls.theta)


def test_the_rls_made_in_place_is_the_rls_of_its_constructor():
    # the estimator's RLS over the field its C init configured, against RecursiveLeastSquares with the same
    # settings and start (independently made: the standalone constructor, its P set from P0)
    from adaptive_ff.compensation.sliding_estimator import SlidingFrictionEstimatorConfig
    from adaptive_ff.identification.rls import RecursiveLeastSquares
    for cfg in (SlidingFrictionEstimatorConfig(), SlidingFrictionEstimatorConfig(lam=0.99, forgetting="directional"),
                SlidingFrictionEstimatorConfig(lam=(0.99, 0.98, 0.97, 0.995, 0.99, 0.99, 0.999), P0=30.0),
                SlidingFrictionEstimatorConfig(lag=False, offset=False, P_max=77.0, initial_J=3.0)):
        est = SlidingFrictionEstimator(0.05, 1.5, Tc=1e-3, config=cfg)
        own = RecursiveLeastSquares(est.rls.n_params, lam=cfg.lam, P0=cfg.P0, forgetting=cfg.forgetting,
                                    P_max=cfg.P_max if cfg.P_max else est.rls.n_params * cfg.P0)
        own.theta = est.rls.theta
        assert est.rls.struct_bytes() == own.struct_bytes()
        names = [n for n, _ in own._ffi.typeof("aff_rls_config").fields]
        assert [getattr(est.rls.config, n) for n in names] == [getattr(own.config, n) for n in names]
        assert est.rls.forgetting == own.forgetting and np.array_equal(np.ravel(est.rls.lam), np.ravel(own.lam))


def test_unbuilt_raises_the_constructors_errors():
    from adaptive_ff.compensation.gate import OutlierGate
    from adaptive_ff.compensation.supervisor import FeedforwardSupervisor
    est = SlidingFrictionEstimator.unbuilt(0.05, 1.5, Tc=1e-3)
    bad = [(SlidingFrictionEstimator, (0.05, 0.0), dict(Tc=1e-3)), (SlidingFrictionEstimator, (0.05, 1.5), dict(Tc=0.0)),
           (SlidingFrictionEstimator, (0.05, 1.5), dict(Tc=1e-3, gate="g")),
           (RobustAdaptiveFeedforward, (est,), dict(dt=-1.0)), (RobustAdaptiveFeedforward, (est,), dict(dt="x")),
           (RobustAdaptiveFeedforward, ("est",), dict(dt=1e-3)),
           (DisturbanceObserver, (), dict(J_n=-2.0, Tc=1e-3)), (DisturbanceObserver, (), dict(J_n=2.0, Tc=1e-3, order=1.5)),
           (FeedforwardSupervisor, (), dict(Tc=1e-3, J_n=2.0, omega=math.nan)), (OutlierGate, (), dict(max_step=-1.0)),
           (OutlierGate, (), dict(max_consecutive=True))]
    for cls, args, kw in bad:
        with pytest.raises(Exception) as a:
            cls(*args, **kw)
        with pytest.raises(Exception) as b:
            cls.unbuilt(*args, **kw)
        assert isinstance(a.value, (ParameterError, TypeError)), (cls, kw)
        assert (type(a.value), str(a.value)) == (type(b.value), str(b.value)), (cls, kw)
    with pytest.raises(TypeError, match="RangeGate is made by its constructor only"):
        RangeGate.unbuilt()
    with pytest.raises(ParameterError, match=r"SlidingFrictionEstimator.unbuilt\(...\) has no struct of its own"):
        est.cdata


def test_build_modes_shares_the_settings_of_one_options_object_in_its_call_only():
    from controllers.simulation.compensators import build_modes
    p = preset("paper")
    o = _options(p)
    comps = build_modes([p, p], "adaptive", [o, o])[2]
    assert comps[0].feedforward.settings is comps[1].feedforward.settings
    assert comps[0].cdata != comps[1].cdata and comps[0].struct_bytes() == comps[1].struct_bytes()
    again = build_modes([p], "adaptive", [o])[2][0]
    one, two = build_mode(p, "adaptive", o)[2], build_mode(p, "adaptive", o)[2]
    for c in (again, two):  # made again by the next call: equal, not the same objects
        assert c.feedforward.settings is not comps[0].feedforward.settings
        assert c.feedforward.settings == comps[0].feedforward.settings and c.struct_bytes() == comps[0].struct_bytes()
    assert one.estimator.settings is not two.estimator.settings
