"""The components of the drive's code are configured from config structs (``aff_X_config``, ``aff_X_default_config``,
``aff_error aff_X_init``): the defaults, every refused field with its named code, the struct untouched then, the
derived fields as the Python constructors computed them before (bit for bit), the Python classes filling the same
structs, and a sentence for every code.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from adaptive_ff._caff import ffi, lib
from plant.errors import ParameterError
from adaptive_ff.compensation.sliding_estimator import SlidingFrictionEstimatorConfig

ROOT = Path(__file__).resolve().parents[2]
TC = 1e-3
NAN, INF = math.nan, math.inf


def _set(cfg, path: str, value) -> None:
    *head, last = path.split(".")
    obj = cfg
    for h in head:
        obj = getattr(obj, h)
    setattr(obj, last, value)


def _code(name: str) -> int:
    return getattr(lib, name)


#: component -> (struct, config, init(struct, cfg), the fields to set before the default validates (the joint's),
#: [(field, bad value, code), ...]); every code named by component and field.
_SUPERVISOR_SET = {"J_n": 0.5, "omega": 20.0}
_SLIDING_SET = {"Vs": 0.02, "delta": 1.0}
_RESIDUAL_SET = {"dob.J_n": 0.5, "switch_in.J_n": 0.5, "switch_in.Kp": 10.0, "switch_in.Ki": 60.0}
COMPONENTS = {
    "gate": ("aff_gate", "aff_gate_config", lib.aff_gate_init, {}, [
        ("max_step", -1.0, "AFF_ERR_GATE_MAX_STEP"), ("max_step", NAN, "AFF_ERR_GATE_MAX_STEP"),
        ("n_sigma", 0.0, "AFF_ERR_GATE_N_SIGMA"), ("n_sigma", INF, "AFF_ERR_GATE_N_SIGMA"),
        ("alpha", 0.0, "AFF_ERR_GATE_ALPHA"), ("alpha", 1.5, "AFF_ERR_GATE_ALPHA"),
        ("max_consecutive", 0, "AFF_ERR_GATE_MAX_CONSECUTIVE")]),
    "range_gate": ("aff_range_gate", "aff_range_gate_config", lib.aff_range_gate_init, {}, [
        ("x_max", 0.0, "AFF_ERR_RANGE_GATE_X_MAX"), ("x_max", NAN, "AFF_ERR_RANGE_GATE_X_MAX"),
        ("factor", 1.0, "AFF_ERR_RANGE_GATE_FACTOR"), ("factor", INF, "AFF_ERR_RANGE_GATE_FACTOR"),
        ("floor", -1.0, "AFF_ERR_RANGE_GATE_FLOOR"), ("floor", INF, "AFF_ERR_RANGE_GATE_FLOOR"),
        ("memory", 0.0, "AFF_ERR_RANGE_GATE_MEMORY"), ("memory", INF, "AFF_ERR_RANGE_GATE_MEMORY"),
        ("max_consecutive", 0, "AFF_ERR_RANGE_GATE_MAX_CONSECUTIVE")]),
    "rls": ("aff_rls", "aff_rls_config", lib.aff_rls_init, {}, [
        ("n_params", 0, "AFF_ERR_RLS_N_PARAMS"), ("n_params", 17, "AFF_ERR_RLS_N_PARAMS"),
        ("forgetting", 3, "AFF_ERR_RLS_FORGETTING"), ("lam", 0.0, "AFF_ERR_RLS_LAM"), ("lam", 1.5, "AFF_ERR_RLS_LAM"),
        ("P0", 0.0, "AFF_ERR_RLS_P0"), ("P0", INF, "AFF_ERR_RLS_P0"), ("P_max", -1.0, "AFF_ERR_RLS_P_MAX"),
        ("P_max", NAN, "AFF_ERR_RLS_P_MAX")]),
    "loop_model": ("aff_loop_model", "aff_loop_model_config", lambda m, c: lib.aff_loop_model_init(m, c, TC),
                   {"Kp": 10.0, "Ki": 60.0, "J": 0.5}, [
        ("Kp", -1.0, "AFF_ERR_LOOP_MODEL_KP"), ("Kp", NAN, "AFF_ERR_LOOP_MODEL_KP"),
        ("Ki", -1.0, "AFF_ERR_LOOP_MODEL_KI"), ("J", 0.0, "AFF_ERR_LOOP_MODEL_J"),
        ("track", NAN, "AFF_ERR_LOOP_MODEL_TRACK")]),
    "sign_observer": ("aff_sign_observer", "aff_sign_observer_config",
                      lambda o, c: lib.aff_sign_observer_init(o, c, TC), {"J": 0.5, "bandwidth": 100.0}, [
        ("J", 0.0, "AFF_ERR_SIGN_OBSERVER_J"), ("bandwidth", 0.0, "AFF_ERR_SIGN_OBSERVER_BANDWIDTH"),
        ("bandwidth", INF, "AFF_ERR_SIGN_OBSERVER_BANDWIDTH"),
        ("residual_bandwidth", NAN, "AFF_ERR_SIGN_OBSERVER_RESIDUAL_BANDWIDTH")]),
    "fixed_ff": ("aff_fixed_ff", "aff_fixed_ff_config", lib.aff_fixed_ff_init, {}, [
        ("dt", 0.0, "AFF_ERR_FIXED_FF_DT"), ("lag", 2, "AFF_ERR_FIXED_FF_LAG"),
        ("ff_max", -1.0, "AFF_ERR_FIXED_FF_FF_MAX"), ("ff_max", NAN, "AFF_ERR_FIXED_FF_FF_MAX"),
        ("sign_width", -1.0, "AFF_ERR_FIXED_FF_SIGN_WIDTH"), ("sign_width", INF, "AFF_ERR_FIXED_FF_SIGN_WIDTH"),
        ("stick_band", -1.0, "AFF_ERR_FIXED_FF_STICK_BAND"), ("stick_samples", 0, "AFF_ERR_FIXED_FF_STICK_SAMPLES"),
        ("at_ref", 2, "AFF_ERR_FIXED_FF_AT_REF"), ("w_max", 0.0, "AFF_ERR_FIXED_FF_W_MAX"),
        ("use_loop_model", 2, "AFF_ERR_FIXED_FF_USE_LOOP_MODEL"),
        ("use_sign_observer", -1, "AFF_ERR_FIXED_FF_USE_SIGN_OBSERVER"),
        ("use_loop_model", 1, "AFF_ERR_LOOP_MODEL_GAINS"),  # the loop model's defaults: set its gains
        ("use_sign_observer", 1, "AFF_ERR_SIGN_OBSERVER_J")]),
    "sliding": ("aff_sliding", "aff_sliding_config", lib.aff_sliding_init, _SLIDING_SET, [
        ("Vs", 0.0, "AFF_ERR_SLIDING_VS"), ("delta", 0.0, "AFF_ERR_SLIDING_DELTA"),
        ("delta", NAN, "AFF_ERR_SLIDING_DELTA"), ("Tc", 0.0, "AFF_ERR_SLIDING_TC"),
        ("Ts", 0.0105, "AFF_ERR_SLIDING_TS"), ("Ts", 0.0, "AFF_ERR_SLIDING_TS"), ("Ts", 1e7, "AFF_ERR_SLIDING_TS"),
        ("T_filter", 0.0015, "AFF_ERR_SLIDING_T_FILTER"), ("forgetting", 3, "AFF_ERR_SLIDING_FORGETTING"),
        ("lam", 0.0, "AFF_ERR_SLIDING_LAM"), ("forgetting", 2, "AFF_ERR_SLIDING_LAM_EACH"),
        ("P0", 0.0, "AFF_ERR_SLIDING_P0"), ("P_max", -1.0, "AFF_ERR_SLIDING_P_MAX"),
        ("lag", 2, "AFF_ERR_SLIDING_LAG"), ("offset", 2, "AFF_ERR_SLIDING_OFFSET"),
        ("w_band_min", -1.0, "AFF_ERR_SLIDING_W_BAND_MIN"), ("dwell_max", 1.5, "AFF_ERR_SLIDING_DWELL_MAX"),
        ("J_max", 0.0, "AFF_ERR_SLIDING_J_MAX"), ("tau_max", 0.0, "AFF_ERR_SLIDING_TAU_MAX"),
        ("initial_Fc", NAN, "AFF_ERR_SLIDING_INITIAL"), ("gate.alpha", 0.0, "AFF_ERR_GATE_ALPHA"),
        ("u_range.factor", 1.0, "AFF_ERR_RANGE_GATE_FACTOR"), ("w_range.memory", 0.0, "AFF_ERR_RANGE_GATE_MEMORY")]),
    "robust_ff": ("aff_robust_ff", "aff_robust_ff_config", lib.aff_robust_ff_init,
                  {f"est.{k}": v for k, v in _SLIDING_SET.items()}, [
        ("ff.dt", 0.0, "AFF_ERR_FIXED_FF_DT"), ("est.Vs", 0.0, "AFF_ERR_SLIDING_VS"),
        ("warmup", -1, "AFF_ERR_ROBUST_FF_WARMUP"), ("fade_in", -1.0, "AFF_ERR_ROBUST_FF_FADE_IN"),
        ("J_lo", INF, "AFF_ERR_ROBUST_FF_J_RANGE"), ("J_hi", 0.0, "AFF_ERR_ROBUST_FF_J_RANGE"),
        ("tau_max", 0.0, "AFF_ERR_ROBUST_FF_TAU_MAX"), ("consistency", 0.0, "AFF_ERR_ROBUST_FF_CONSISTENCY"),
        ("lag_margin", -1.0, "AFF_ERR_ROBUST_FF_LAG_MARGIN"), ("lag_margin_max", -1.0,
                                                                 "AFF_ERR_ROBUST_FF_LAG_MARGIN_MAX"),
        ("max_rel_stderr", 0.0, "AFF_ERR_ROBUST_FF_MAX_REL_STDERR"), ("lag_memory", INF,
                                                                       "AFF_ERR_ROBUST_FF_LAG_MEMORY"),
        ("lag_zero", NAN, "AFF_ERR_ROBUST_FF_LAG_ZERO"), ("project", 2, "AFF_ERR_ROBUST_FF_PROJECT"),
        ("start.on", 2, "AFF_ERR_START_ON")]),
    "supervisor": ("aff_supervisor", "aff_supervisor_config", lib.aff_supervisor_init, _SUPERVISOR_SET, [
        ("Tc", 0.0, "AFF_ERR_SUPERVISOR_TC"), ("J_n", 0.0, "AFF_ERR_SUPERVISOR_J_N"),
        ("omega", INF, "AFF_ERR_SUPERVISOR_OMEGA"), ("window", 0.0, "AFF_ERR_SUPERVISOR_WINDOW"),
        ("margin", 1.0, "AFF_ERR_SUPERVISOR_MARGIN"), ("settle", NAN, "AFF_ERR_SUPERVISOR_SETTLE"),
        ("rest_band", -2.0, "AFF_ERR_SUPERVISOR_REST_BAND"), ("delay", 33, "AFF_ERR_SUPERVISOR_DELAY"),
        ("delay", -1, "AFF_ERR_SUPERVISOR_DELAY"), ("Kp", -1.0, "AFF_ERR_SUPERVISOR_KP"),
        ("Kp", INF, "AFF_ERR_SUPERVISOR_KP"), ("Ki", NAN, "AFF_ERR_SUPERVISOR_KI"),
        ("track_margin", -0.5, "AFF_ERR_SUPERVISOR_TRACK_MARGIN")]),
    "dob": ("aff_dob", "aff_dob_config", lib.aff_dob_init, {"J_n": 0.5}, [
        ("Tc", 0.0, "AFF_ERR_DOB_TC"), ("J_n", 0.0, "AFF_ERR_DOB_J_N"), ("omega_q", 0.0, "AFF_ERR_DOB_OMEGA_Q"),
        ("order", 0, "AFF_ERR_DOB_ORDER"), ("order", 9, "AFF_ERR_DOB_ORDER"), ("d_max", -1.0, "AFF_ERR_DOB_D_MAX"),
        ("u_range.x_max", -1.0, "AFF_ERR_RANGE_GATE_X_MAX")]),
    "residual": ("aff_residual", "aff_residual_config", lib.aff_residual_init, _RESIDUAL_SET, [
        ("u_max", -1.0, "AFF_ERR_RESIDUAL_U_MAX"), ("use_switch_in", 2, "AFF_ERR_RESIDUAL_USE_SWITCH_IN"),
        ("dob.order", 0, "AFF_ERR_DOB_ORDER"), ("switch_in.Tc", 0.0, "AFF_ERR_SWITCH_IN_TC"),
        ("switch_in.J_n", 0.0, "AFF_ERR_SWITCH_IN_J_N"), ("switch_in.Kp", 0.0, "AFF_ERR_SWITCH_IN_KP"),
        ("switch_in.Ki", -1.0, "AFF_ERR_SWITCH_IN_KI"), ("switch_in.window", 0.0, "AFF_ERR_SWITCH_IN_WINDOW"),
        ("switch_in.ratio", 0.0, "AFF_ERR_SWITCH_IN_RATIO"), ("switch_in.share", NAN, "AFF_ERR_SWITCH_IN_SHARE"),
        ("switch_in.fade_in", -1.0, "AFF_ERR_SWITCH_IN_FADE_IN"),
        ("switch_in.trial_margin", -0.1, "AFF_ERR_SWITCH_IN_TRIAL_MARGIN"),
        ("crossover", -1.0, "AFF_ERR_RESIDUAL_CROSSOVER"), ("crossover", INF, "AFF_ERR_RESIDUAL_CROSSOVER"),
        ("slew_time", NAN, "AFF_ERR_RESIDUAL_SLEW_TIME"), ("slew_time", -0.4, "AFF_ERR_RESIDUAL_SLEW_TIME")]),
    "adaptive": ("aff_adaptive", "aff_adaptive_config", lib.aff_adaptive_init,
                 {**{f"ff.est.{k}": v for k, v in _SLIDING_SET.items()}, **{f"res.{k}": v for k, v in
                                                                             _RESIDUAL_SET.items()},
                  **{f"sup.{k}": v for k, v in _SUPERVISOR_SET.items()}}, [
        ("use_residual", 2, "AFF_ERR_ADAPTIVE_USE_RESIDUAL"), ("use_supervisor", 2, "AFF_ERR_ADAPTIVE_USE_SUPERVISOR"),
        ("ff.est.delta", 0.0, "AFF_ERR_SLIDING_DELTA"), ("res.switch_in.ratio", 0.0, "AFF_ERR_SWITCH_IN_RATIO"),
        ("sup.window", -1.0, "AFF_ERR_SUPERVISOR_WINDOW")]),
    "drive": ("aff", "aff_config", lib.aff_init,
              {**{f"mode.ff.est.{k}": v for k, v in _SLIDING_SET.items()},
               **{f"mode.res.{k}": v for k, v in _RESIDUAL_SET.items()},
               **{f"mode.sup.{k}": v for k, v in _SUPERVISOR_SET.items()}}, [
        ("guard.Tc", 0.0, "AFF_ERR_GUARD_TC"), ("guard.w_max", INF, "AFF_ERR_GUARD_W_MAX"),
        ("guard.u_max", -1.0, "AFF_ERR_GUARD_U_MAX"), ("guard.hold_time", 1e-4, "AFF_ERR_GUARD_HOLD_TIME"),
        ("mode.sup.Tc", 2e-3, "AFF_ERR_DRIVE_TC"), ("mode.ff.ff.dt", 2e-3, "AFF_ERR_DRIVE_TC"),
        ("mode.res.switch_in.Tc", 2e-3, "AFF_ERR_DRIVE_TC"), ("mode.ff.est.Ts", 0.0, "AFF_ERR_SLIDING_TS")]),
}
#: the first code of the default config, for the components with fields to set (the joint's)
FIRST_UNSET = {"loop_model": "AFF_ERR_LOOP_MODEL_GAINS", "sign_observer": "AFF_ERR_SIGN_OBSERVER_J",
               "sliding": "AFF_ERR_SLIDING_VS", "robust_ff": "AFF_ERR_SLIDING_VS",
               "supervisor": "AFF_ERR_SUPERVISOR_J_N", "dob": "AFF_ERR_DOB_J_N", "residual": "AFF_ERR_DOB_J_N",
               "adaptive": "AFF_ERR_SLIDING_VS", "drive": "AFF_ERR_SLIDING_VS"}


def _default(name: str):
    ctype = COMPONENTS[name][1]
    fn = "aff_default_config" if name == "drive" else f"aff_{name}_default_config"
    return ffi.new(f"{ctype} *", getattr(lib, fn)())


def _valid(name: str):
    cfg = _default(name)
    for k, v in COMPONENTS[name][3].items():
        _set(cfg, k, v)
    return cfg


@pytest.mark.parametrize("name", list(COMPONENTS))
def test_the_default_config_validates_once_the_joints_fields_are_set(name):
    sname, _, init, must, _ = COMPONENTS[name]
    x = ffi.new(f"{sname} *")
    if must:  # the joint's fields are 0 in the defaults: refused, by name, until set
        assert init(x, _default(name)) == _code(FIRST_UNSET[name])
    assert init(x, _valid(name)) == lib.AFF_OK
    assert init(x, ffi.NULL) == lib.AFF_ERR_NULL and init(ffi.NULL, _valid(name)) == lib.AFF_ERR_NULL


@pytest.mark.parametrize("name,field,value,code",
                         [(n, f, v, c) for n, spec in COMPONENTS.items() for f, v, c in spec[4]])
def test_an_invalid_field_returns_its_named_code_and_leaves_the_struct_untouched(name, field, value, code):
    sname, _, init, _, _ = COMPONENTS[name]
    cfg = _valid(name)
    _set(cfg, field, value)
    x = ffi.new(f"{sname} *")
    buf = ffi.buffer(x)
    buf[:] = b"\x5a" * len(buf)
    assert init(x, cfg) == _code(code)
    assert buf[:] == b"\x5a" * len(buf)
    msg = ffi.string(lib.aff_error_message(_code(code))).decode()
    leaf = field.split(".")[-1]
    assert code == "AFF_ERR_DRIVE_TC" or leaf.startswith("use_") or leaf in msg or (
        leaf in ("J_lo", "J_hi") and "J_lo" in msg) or (leaf == "forgetting" and "lam_each" in msg) or (
        leaf.startswith("initial_") and "initial_" in msg) or code == "AFF_ERR_LOOP_MODEL_GAINS", msg


def test_start_map_fields_are_checked_once_it_is_on():
    x = ffi.new("aff_robust_ff *")
    for field, value, code in (("Fc", -1.0, "AFF_ERR_START_FC"), ("Fs", NAN, "AFF_ERR_START_FS"),
                               ("sigma", -1.0, "AFF_ERR_START_SIGMA"), ("tau", INF, "AFF_ERR_START_TAU"),
                               ("Vs", -1.0, "AFF_ERR_START_VS"), ("delta", NAN, "AFF_ERR_START_DELTA"),
                               ("gain", 0.0, "AFF_ERR_START_GAIN"), ("gain", 1.5, "AFF_ERR_START_GAIN"),
                               ("at_ref", 2, "AFF_ERR_START_AT_REF")):
        cfg = _valid("robust_ff")
        _set(cfg, f"start.{field}", value)
        assert lib.aff_robust_ff_init(x, cfg) == lib.AFF_OK  # off: not read
        cfg.start.on = 1
        assert lib.aff_robust_ff_init(x, cfg) == _code(code), field
    cfg = _valid("robust_ff")
    cfg.start = {"on": 1, "Fc": 25.0, "Fs": 35.0, "sigma": 40.0, "tau": 0.02, "gain": 0.5}
    assert lib.aff_robust_ff_init(x, cfg) == lib.AFF_OK
    assert x.provisional == 1 and x.start_gain == 0.5 and x.start_at_ref == 1 and x.ff.has == 1
    assert x.ff.Vs == 0.02 and x.ff.delta == 1.0 and x.ff.dF == 10.0  # the estimator's Vs, delta where 0


def test_parts_that_do_not_act_are_not_read():
    cfg = _valid("adaptive")
    cfg.use_residual = cfg.use_supervisor = 0
    cfg.res.dob.J_n = cfg.sup.J_n = 0.0
    cfg.res.u_max = 75.0
    a = ffi.new("aff_adaptive *")
    assert lib.aff_adaptive_init(a, cfg) == lib.AFF_OK
    assert a.res.u_max == 75.0 and a.res.dob.J_n == 0.0 and a.sup.J_n == 0.0
    cfg.res.u_max = -1.0  # reported, so checked
    assert lib.aff_adaptive_init(a, cfg) == lib.AFF_ERR_RESIDUAL_U_MAX
    d = _valid("drive")
    d.mode.use_supervisor = 0
    d.mode.sup.Tc = 5e-3  # not acting: its period is not compared
    assert lib.aff_init(ffi.new("aff *"), d) == lib.AFF_OK


def test_every_code_has_a_sentence_naming_its_component():
    text = (ROOT / "adaptive_ff" / "csrc" / "aff_error.h").read_text()
    codes = re.findall(r"^\s+(AFF_(?:OK|ERR_\w+)) = (\d+)", text, re.M)
    assert len(codes) > 100 and len({v for _, v in codes}) == len(codes)
    for name, value in codes:
        assert getattr(lib, name) == int(value)
        msg = ffi.string(lib.aff_error_message(int(value))).decode()
        assert msg != "unknown error code" and len(msg) >= 10, name
        if name.startswith("AFF_ERR_") and name != "AFF_ERR_NULL":
            assert ":" in msg and ("must" in msg or "are both 0" in msg), msg
    assert ffi.string(lib.aff_error_message(999)) == b"unknown error code"


# ------------------------------------------------------------------------------------------ the derived fields
def _struct(sname, init, cfg):
    x = ffi.new(f"{sname} *")
    assert init(x, cfg) == lib.AFF_OK
    return x


def test_derived_fields_are_the_former_python_computations_bit_for_bit():
    """The numbers the Python constructors computed before the settings moved into C (their expressions here), for
    settings whose results are not round numbers."""
    rg = _struct("aff_range_gate", lib.aff_range_gate_init, ffi.new("aff_range_gate_config *", dict(
        x_max=INF, factor=100.0, floor=0.0, memory=1234.5, max_consecutive=20)))
    assert rg.decay == math.exp(-1.0 / 1234.5)
    dt, Kp, Ki, J = 7e-4, 69.28, 786.1, 4.103424729656735
    lm = ffi.new("aff_loop_model *")
    for track in (-1.0, 3.7):
        cfg = ffi.new("aff_loop_model_config *", dict(Kp=Kp, Ki=Ki, J=J, track=track))
        assert lib.aff_loop_model_init(lm, cfg, dt) == lib.AFF_OK
        bw = Kp / J if track < 0 else track
        assert (lm.Kp, lm.KiTc, lm.TcJ, lm.a) == (Kp, Ki * dt, dt / J, 1.0 - math.exp(-bw * dt))
    ob = ffi.new("aff_sign_observer *")
    for rb in (-1.0, 2.9):
        cfg = ffi.new("aff_sign_observer_config *", dict(J=J, bandwidth=5.0 * Kp / J, residual_bandwidth=rb))
        assert lib.aff_sign_observer_init(ob, cfg, dt) == lib.AFF_OK
        p1 = math.exp(-float(5.0 * Kp / J) * dt)
        p2 = math.exp(-(0.1 * (5.0 * Kp / J) if rb < 0 else rb) * dt)
        assert (ob.TcJ, ob.l1, ob.l2) == (dt / J, 1.0 - p1 * p2, (1.0 - p1) * (1.0 - p2))
    # the sliding estimator: a, settle, m, e2_rate, w_band_min, the RLS's P_max and start
    cfg = _valid("sliding")
    cfg.Tc, cfg.Ts, cfg.T_filter, cfg.lam, cfg.Vs = dt, 7 * dt, 0.0231, 0.9931, 0.0173
    cfg.initial_J, cfg.initial_tau, cfg.initial_Fc, cfg.initial_Fs = 4.1, 0.0207, -1.0, 37.2
    cfg.initial_sigma, cfg.initial_offset, cfg.J_max, cfg.tau_max = 40.1, 0.3, 3.0, 0.015
    e = _struct("aff_sliding", lib.aff_sliding_init, cfg)
    assert e.a == 1.0 - math.exp(-dt / 0.0231) and e.settle == int(math.ceil(8.0 * 0.0231 / dt)) and e.m == 7
    assert e.e2_rate == 1.0 - 0.9931 and e.w_band_min == 0.1 * 0.0173 and e.w_range.floor == 0.0173
    assert e.rls.P_max == 7 * 1e4 and e.rls.lam == 0.9931 and e.p == 7
    J0, tau0 = min(max(4.1, 1e-9), 3.0), min(max(0.0207, 0.0), 0.015)
    assert list(e.rls.theta)[:7] == [J0, J0 * tau0, tau0, 0.0, 37.2, 40.1, 0.3]
    # the robust feedforward: fade and the forgetting of the weighted lag
    cfg = _valid("robust_ff")
    cfg.ff.dt = cfg.est.Tc = dt
    cfg.est.Ts = 13 * dt
    cfg.fade_in, cfg.lag_memory = 0.77, 9.3
    r = _struct("aff_robust_ff", lib.aff_robust_ff_init, cfg)
    assert r.fade == dt / 0.77 and r.lag_forget == math.exp(-(13 * dt) / 9.3)
    cfg.fade_in, cfg.lag_memory = 0.0, 0.0
    r = _struct("aff_robust_ff", lib.aff_robust_ff_init, cfg)
    assert r.fade == 1.0 and r.lag_forget == 0.0 and math.isnan(r.theta_used[0]) and r.gain == 0.0
    # the RLS's vector factors: numpy's lam**-0.5 and outer product
    lam = np.array([0.99, 0.95, 0.9, 0.999])
    rls = _struct("aff_rls", lib.aff_rls_init, ffi.new("aff_rls_config *", dict(
        n_params=4, forgetting=lib.AFF_RLS_VECTOR, lam=0.5, P0=1e4, P_max=0.0)))
    assert rls.lam == 1.0 and rls.P_max == 4e4
    assert lib.aff_rls_set_lam_each(rls, ffi.new("double[]", list(lam))) == lib.AFF_OK
    d = lam ** -0.5
    np.testing.assert_array_equal(np.frombuffer(ffi.buffer(rls.D), dtype=float)[:16], np.outer(d, d).ravel())
    assert lib.aff_rls_set_lam_each(rls, ffi.new("double[]", [0.9, 1.5, 0.9, 0.9])) == lib.AFF_ERR_RLS_LAM_EACH
    # the supervisor (settle -1: window/2), the observer, the switch-in
    s = _struct("aff_supervisor", lib.aff_supervisor_init, ffi.new("aff_supervisor_config *", dict(
        Tc=dt, J_n=J, omega=17.3, window=2.3, margin=0.1, settle=-1.0, rest_band=0.0, delay=0)))
    assert s.settle == 0.5 * 2.3 and s.a == 1.0 - math.exp(-dt * 17.3) and s.b == 1.0 - math.exp(-dt / 2.3)
    assert s.n_start == math.ceil(5.0 / (17.3 * dt)) and s.n_decide == s.n_start + math.floor(1.15 / dt + 0.5)
    assert s.track == 0  # Kp 0: no tracking test
    s = _struct("aff_supervisor", lib.aff_supervisor_init, ffi.new("aff_supervisor_config *", dict(
        Tc=dt, J_n=J, omega=17.3, window=2.3, margin=0.1, settle=-1.0, rest_band=0.0, delay=0, Kp=69.3, Ki=786.0,
        track_margin=0.5)))
    assert s.track == 1 and s.Kp == 69.3 and s.KiTc == 786.0 * dt and s.TcJ == dt / J and s.track_margin == 0.5
    cfg = _valid("dob")
    cfg.Tc, cfg.omega_q = dt, 731.0
    assert _struct("aff_dob", lib.aff_dob_init, cfg).a == 1.0 - math.exp(-dt * 731.0)
    cfg = _valid("residual")
    cfg.switch_in.Tc, cfg.switch_in.window, cfg.switch_in.fade_in = dt, 1.9, 0.37
    sw = _struct("aff_residual", lib.aff_residual_init, cfg).sw
    assert sw.b == 1.0 - math.exp(-dt / 1.9) and sw.fade == dt / 0.37 and sw.n_evidence == round(1.9 / dt)


# --------------------------------------------------------------------- the Python classes fill the same structs
def test_python_classes_with_their_defaults_are_the_c_defaults():
    """A class built with its defaults (the joint's settings given alike) and the C defaults configure the same
    bytes."""
    from adaptive_ff.compensation.adaptive_feedforward import RobustAdaptiveFeedforward
    from adaptive_ff.compensation.gate import OutlierGate, RangeGate
    from adaptive_ff.compensation.sliding_estimator import SlidingFrictionEstimator
    from adaptive_ff.compensation.supervisor import FeedforwardSupervisor
    from controllers.peers.dob import DisturbanceObserver

    def c(name, **fields):
        cfg = _default(name)
        for k, v in fields.items():
            _set(cfg, k, v)
        return bytes(ffi.buffer(_struct(COMPONENTS[name][0], COMPONENTS[name][2], cfg)))

    assert OutlierGate().struct_bytes() == c("gate")
    assert RangeGate().struct_bytes() == c("range_gate")
    est = SlidingFrictionEstimator(0.02, 1.0, Tc=TC)
    assert est.struct_bytes() == c("sliding", **_SLIDING_SET)
    ff = RobustAdaptiveFeedforward(SlidingFrictionEstimator(0.02, 1.0, Tc=TC), dt=TC)
    assert ff.struct_bytes() == c("robust_ff", **{f"est.{k}": v for k, v in _SLIDING_SET.items()})
    assert FeedforwardSupervisor(Tc=TC, **_SUPERVISOR_SET).struct_bytes() == c("supervisor", **_SUPERVISOR_SET)
    assert DisturbanceObserver(J_n=0.5, Tc=TC).struct_bytes() == c("dob", J_n=0.5)


def test_python_classes_keep_their_settings_and_a_composite_holds_its_parts():
    from controllers.simulation.compensators import LoopConfig, build_mode
    from plant import preset

    P = preset("paper")
    o = LoopConfig.from_flat(Kp=69.28, Ki=786.1, u_max=150.0, ff_max=75.0, J_design=P.J, Vs=P.Vs, delta=P.delta,
                    stick_band=3e-3, stick_input="model")
    _, _, comp = build_mode(P, "adaptive", o)
    cfg = comp.config
    assert cfg.use_residual == cfg.use_supervisor == 1 and cfg.ff.ff.use_loop_model == 1
    assert (cfg.ff.ff.loop_model.Kp, cfg.ff.ff.loop_model.J, cfg.ff.ff.loop_model.track) == (69.28, P.J, -1.0)
    assert cfg.ff.est.Vs == P.Vs and cfg.res.switch_in.Kp == 69.28 and cfg.sup.J_n == P.J and cfg.sup.settle == -1
    assert bytes(ffi.buffer(comp.supervisor.config)) == bytes(ffi.buffer(ffi.addressof(cfg, "sup")))
    d = comp.drive_config()
    c = ffi.new("aff *")
    assert lib.aff_init(c, d) == lib.AFF_OK
    assert bytes(ffi.buffer(ffi.addressof(c, "mode"))) == comp.struct_bytes()
    # the settings survive a copy (pickle: the process pools of compare and the zoo)
    import pickle

    again = pickle.loads(pickle.dumps(comp))
    assert bytes(ffi.buffer(again.config)) == bytes(ffi.buffer(cfg))


@pytest.mark.parametrize("variant", ["vector-lam", "start", "feedforward-only", "sign-observer", "directional"])
def test_python_composites_are_what_their_settings_configure(variant):
    """For the settings the classes offer beyond the defaults, aff_init of the compensator's settings builds its
    struct byte for byte (what the export checks before it writes them)."""

    from adaptive_ff.compensation.adaptive_feedforward import FeedforwardStart
    from adaptive_ff.identification.regression import FrictionEstimate
    from controllers.peers.adaptive_dob import AdaptiveCompensator
    from controllers.simulation.compensators import LoopConfig, build_mode
    from plant import preset

    P = preset("paper")
    o = LoopConfig.from_flat(Kp=69.28, Ki=786.1, u_max=150.0, ff_max=75.0, J_design=P.J, Vs=P.Vs, delta=P.delta)
    if variant == "start":
        o = o.replace(start=FeedforwardStart(FrictionEstimate(J=P.J, tau=0.02, sigma=40.0, Fc=25.0, Fs=35.0,
                                                               offset=0.0, Vs=None, delta=None, J_alt=NAN),
                                              gain=0.7, ff_input="measured"))
    elif variant == "feedforward-only":
        o = o.replace(switch_in=False, supervise=False)
    elif variant == "sign-observer":
        o = o.replace(sign_input="observer", stick_band=3e-3)
    elif variant == "directional":
        o = o.replace(forgetting="directional", lam=0.99)
    _, _, comp = build_mode(P, "adaptive", o)
    if variant == "vector-lam":
        from adaptive_ff.compensation.sliding_estimator import SlidingFrictionEstimator
        from adaptive_ff.compensation.adaptive_feedforward import RobustAdaptiveFeedforward

        est = SlidingFrictionEstimator(P.Vs, P.delta, Tc=TC,
                                       config=SlidingFrictionEstimatorConfig(lam=np.linspace(0.99, 0.999, 7),
                                                                             initial_J=P.J))
        comp = AdaptiveCompensator(RobustAdaptiveFeedforward(est, dt=TC))
        assert comp.config.ff.est.forgetting == lib.AFF_RLS_VECTOR
    c = ffi.new("aff *")
    assert lib.aff_init(c, comp.drive_config()) == lib.AFF_OK
    assert bytes(ffi.buffer(ffi.addressof(c, "mode"))) == comp.struct_bytes()


def test_a_setting_only_c_refuses_raises_a_parameter_error_naming_the_argument():
    from adaptive_ff.compensation.sliding_estimator import SlidingFrictionEstimator
    from adaptive_ff.identification.regression import FrictionEstimate

    bad = FrictionEstimate(J=1.0, tau=0.0, sigma=NAN, Fc=1.0, Fs=1.0, offset=0.0, Vs=None, delta=None, J_alt=NAN)
    with pytest.raises(ParameterError, match=r"SlidingFrictionEstimator: estimator: the start initial_J .* must be "
                                             r"finite \(argument initial = "):
        SlidingFrictionEstimator(0.02, 1.0, Tc=TC, initial=bad)
    # an infinite J is clipped to J_max first: finite then, accepted as before
    inf_J = FrictionEstimate(J=INF, tau=0.0, sigma=0.0, Fc=1.0, Fs=1.0, offset=0.0, Vs=None, delta=None, J_alt=NAN)
    assert SlidingFrictionEstimator(0.02, 1.0, Tc=TC, initial=inf_J,
                                    config=SlidingFrictionEstimatorConfig(J_max=5.0)).theta[0] == 5.0
