"""Each default of a component's settings is stated once, by its C ``aff_X_default_config()``, and each range is
checked once, by its C ``aff_X_init``: the Python keywords and option fields that mirror a C field take their
defaults from :func:`adaptive_ff.compensation.defaults.c_defaults`, and a value out of range raises the
ParameterError whose sentence is the C code's, naming the field.
"""

from __future__ import annotations

import dataclasses
import inspect
import math

import pytest

from adaptive_ff._caff import ffi, lib
from adaptive_ff.compensation.adaptive_feedforward import (FeedforwardStart, RobustAdaptiveFeedforward,
                                                            RobustAdaptiveFeedforwardConfig)
from adaptive_ff.compensation.defaults import c_defaults
from adaptive_ff.compensation.eq4_feedforward import AdaptiveFrictionFeedforward, AdaptiveFrictionFeedforwardConfig
from adaptive_ff.compensation.feedforward import FF_INPUTS, FrictionFeedforward, FrictionFeedforwardConfig
from adaptive_ff.compensation.gate import OutlierGate, RangeGate
from adaptive_ff.compensation.sliding_estimator import (FORGETTINGS, SlidingFrictionEstimator,
                                                         SlidingFrictionEstimatorConfig)
from adaptive_ff.compensation.supervisor import FeedforwardSupervisor, FeedforwardSupervisorConfig
from adaptive_ff.identification.regression import FrictionEstimate, RegressionModel
from controllers._cctl import ffi as cffi_ctl, lib as lib_ctl
from controllers.peers.adaptive_dob import ResidualSwitchIn
from controllers.peers.canudas import CanudasCompensator, CanudasCompensatorConfig
from controllers.peers.dob import DisturbanceObserver
from controllers.simulation.compensators import LoopConfig
from plant.component import SettingTypeError, config_defaults
from plant.errors import ParameterError

TC = 1e-3
_flag = bool
_same = float


def _sized_from_the_sensor(v):
    """The loop's stick band: None, sized from its sensor's velocity noise, which makes it the C default ``v`` for
    the default (noiseless) sensor."""
    assert LoopConfig().sized_stick_band() == v
    return None


def _cdef(ctype: str) -> dict:
    """The C defaults of ``ctype`` from the library that owns it (controllers' ``ctl_*``, else adaptive_ff's)."""
    return config_defaults(cffi_ctl, lib_ctl, ctype) if ctype.startswith("ctl_") else c_defaults(ctype)


def _at(ctype: str, path: str):
    v = _cdef(ctype)
    for k in path.split("."):
        v = v[k]
    return v


def _defaults(obj) -> dict:
    """Keyword -> default of a class's constructor (a dataclass's fields; the loop's config: its flat keywords)."""
    if obj is LoopConfig:
        return LoopConfig().to_flat()
    if dataclasses.is_dataclass(obj):
        return {f.name: f.default for f in dataclasses.fields(obj) if f.default is not dataclasses.MISSING}
    return {k: p.default for k, p in inspect.signature(obj).parameters.items() if p.default is not p.empty}


#: (class, its keyword or field, the C settings, the C field it mirrors, the C value as the keyword's): every Python
#: default that states a C default. A C sentinel (the supervisor's ``settle`` -1 and ``Kp`` 0, the estimator's
#: ``P_max`` and ``w_band_min`` 0) is the config field's default itself.
MIRRORS = [
    *[(OutlierGate, k, "aff_gate_config", k, _same) for k in ("max_step", "n_sigma", "alpha")],
    (OutlierGate, "max_consecutive", "aff_gate_config", "max_consecutive", int),
    *[(RangeGate, k, "aff_range_gate_config", k, _same) for k in ("x_max", "factor", "floor", "memory")],
    (RangeGate, "max_consecutive", "aff_range_gate_config", "max_consecutive", int),
    *[(FrictionFeedforwardConfig, k, "aff_fixed_ff_config", k, _same)
      for k in ("ff_max", "sign_width", "stick_band", "w_max")],
    (FrictionFeedforwardConfig, "stick_samples", "aff_fixed_ff_config", "stick_samples", int),
    (FrictionFeedforwardConfig, "lag", "aff_fixed_ff_config", "lag", _flag),
    (FrictionFeedforwardConfig, "ff_input", "aff_fixed_ff_config", "at_ref", FF_INPUTS.__getitem__),
    *[(RobustAdaptiveFeedforwardConfig, k, "aff_robust_ff_config", k, _same)
      for k in ("fade_in", "J_lo", "J_hi", "tau_max", "consistency", "lag_margin", "lag_margin_max",
                "max_rel_stderr", "lag_memory", "lag_zero")],
    (RobustAdaptiveFeedforwardConfig, "warmup", "aff_robust_ff_config", "warmup", int),
    (RobustAdaptiveFeedforwardConfig, "project", "aff_robust_ff_config", "project", _flag),
    (FeedforwardStart, "gain", "aff_start_config", "gain", _same),
    (FeedforwardStart, "ff_input", "aff_start_config", "at_ref", FF_INPUTS.__getitem__),
    *[(SlidingFrictionEstimatorConfig, k, "aff_sliding_config", k, _same)
      for k in ("Ts", "T_filter", "lam", "P0", "P_max", "w_band_min", "J_max", "tau_max", "dwell_max", "initial_J")],
    (SlidingFrictionEstimatorConfig, "forgetting", "aff_sliding_config", "forgetting", FORGETTINGS.__getitem__),
    *[(SlidingFrictionEstimatorConfig, k, "aff_sliding_config", k, _flag) for k in ("lag", "offset")],
    *[(FeedforwardSupervisorConfig, k, "aff_supervisor_config", k, _same)
      for k in ("window", "margin", "settle", "rest_band", "Kp", "Ki", "track_margin")],
    (FeedforwardSupervisorConfig, "delay", "aff_supervisor_config", "delay", int),
    *[(AdaptiveFrictionFeedforwardConfig, k, "aff_eq4_ff_config", k, _same)
      for k in ("Ts", "lam", "P0", "tau_max", "w_band", "map_rel_stderr")],
    (AdaptiveFrictionFeedforwardConfig, "warmup", "aff_eq4_ff_config", "warmup", int),
    (AdaptiveFrictionFeedforwardConfig, "iv", "aff_eq4_ff_config", "iv", _flag),
    *[(CanudasCompensatorConfig, k, "ctl_canudas_config", k, _same)
      for k in ("Ts", "lam", "P0", "J_guess", "w_dead", "ff_max")],
    (CanudasCompensatorConfig, "warmup", "ctl_canudas_config", "warmup", int),
    (CanudasCompensatorConfig, "forgetting", "ctl_canudas_config", "forgetting",
     {lib.AFF_RLS_DIRECTIONAL: "directional", lib.AFF_RLS_EXPONENTIAL: "exponential"}.__getitem__),
    (CanudasCompensatorConfig, "ff_input", "ctl_canudas_config", "ff_measured", {1: "measured", 0: "reference"}.get),
    *[(DisturbanceObserver, k, "aff_dob_config", k, _same) for k in ("omega_q", "d_max")],
    (DisturbanceObserver, "order", "aff_dob_config", "order", int),
    *[(ResidualSwitchIn, k, "aff_switch_in_config", k, _same)
      for k in ("window", "ratio", "share", "fade_in", "trial_margin")],
    # the loop's options: the components' defaults (the experiment's own overrides are CompareOptions')
    *[(LoopConfig, k, "aff_sliding_config", k, _same) for k in ("Ts", "P0", "T_filter", "dwell_max")],
    (LoopConfig, "forgetting", "aff_sliding_config", "forgetting", FORGETTINGS.__getitem__),
    (LoopConfig, "offset", "aff_sliding_config", "offset", _flag),
    (LoopConfig, "warmup", "aff_robust_ff_config", "warmup", int),
    (LoopConfig, "project", "aff_robust_ff_config", "project", _flag),
    *[(LoopConfig, k, "aff_robust_ff_config", k, _same)
      for k in ("lag_margin", "lag_margin_max", "max_rel_stderr", "lag_memory", "lag_zero")],
    (LoopConfig, "lag", "aff_fixed_ff_config", "lag", _flag),
    (LoopConfig, "ff_input", "aff_fixed_ff_config", "at_ref", FF_INPUTS.__getitem__),
    (LoopConfig, "sign_width", "aff_fixed_ff_config", "sign_width", _same),
    (LoopConfig, "stick_band", "aff_fixed_ff_config", "stick_band", _sized_from_the_sensor),
    (LoopConfig, "stick_samples", "aff_fixed_ff_config", "stick_samples", int),
    (LoopConfig, "omega_q", "aff_dob_config", "omega_q", _same),
    (LoopConfig, "switch_in_ratio", "aff_switch_in_config", "ratio", _same),
    *[(LoopConfig, f"supervise_{k}", "aff_supervisor_config", k, _same)
      for k in ("window", "margin", "track_margin", "rest_band")],
]
#: The classes and their settings: a keyword named as a field of these settings must be listed above.
CLASSES = {OutlierGate: ("aff_gate_config",), RangeGate: ("aff_range_gate_config",),
           FrictionFeedforwardConfig: ("aff_fixed_ff_config",),
           RobustAdaptiveFeedforwardConfig: ("aff_robust_ff_config",),
           FeedforwardStart: ("aff_start_config",), SlidingFrictionEstimatorConfig: ("aff_sliding_config",),
           FeedforwardSupervisorConfig: ("aff_supervisor_config",),
           AdaptiveFrictionFeedforwardConfig: ("aff_eq4_ff_config",),
           CanudasCompensatorConfig: ("ctl_canudas_config",), ResidualSwitchIn: ("aff_switch_in_config",),
           DisturbanceObserver: ("aff_dob_config",)}
#: The components whose settings are one config object (the class's ``Config``), and the inputs they take besides.
CONFIGURED = {FrictionFeedforward: ("estimate", "dt", "config", "loop_model", "sign_observer"),
              RobustAdaptiveFeedforward: ("estimator", "dt", "config", "start", "loop_model", "sign_observer"),
              SlidingFrictionEstimator: ("Vs", "delta", "Tc", "config", "initial", "gate", "u_range", "w_range"),
              AdaptiveFrictionFeedforward: ("model", "dt", "config", "u_range", "w_range", "loop_model",
                                            "sign_observer", "start"),
              FeedforwardSupervisor: ("Tc", "J_n", "omega", "config"),
              CanudasCompensator: ("Tc", "config", "u_range", "w_range")}


@pytest.mark.parametrize("cls,key,ctype,path,conv", MIRRORS, ids=lambda x: getattr(x, "__name__", str(x)))
def test_a_python_default_is_its_c_default(cls, key, ctype, path, conv):
    got = _defaults(cls)[key]
    want = conv(_at(ctype, path))
    assert got == want and type(got) is type(want), (cls.__name__, key, got, want)


def test_every_keyword_named_as_a_c_field_is_a_listed_mirror():
    listed = {(c, k) for c, k, *_ in MIRRORS}
    for cls, ctypes in CLASSES.items():
        fields = {k for t in ctypes for k, v in _cdef(t).items() if not isinstance(v, dict)}  # not the parts
        for key in _defaults(cls):
            if key in fields:
                assert (cls, key) in listed, f"{cls.__name__}.{key} mirrors a C field but is not checked here"


@pytest.mark.parametrize("cls", list(CONFIGURED), ids=lambda c: c.__name__)
def test_a_component_takes_its_settings_as_one_config_of_its_c_struct(cls):
    """The constructor's parameters are its inputs and one ``config`` (the class's ``Config``, a dataclass of the C
    config struct): a C field offered as a constructor keyword as well would be a second place of its default."""
    params = tuple(k for k in inspect.signature(cls).parameters)
    assert params == CONFIGURED[cls]
    assert dataclasses.is_dataclass(cls.Config) and cls.Config.CTYPE.endswith("_config")
    assert inspect.signature(cls).parameters["config"].default is None
    fields = {f.name for f in dataclasses.fields(cls.Config)}
    assert not fields & set(params), fields & set(params)


def test_a_config_class_is_frozen_documents_its_units_and_refuses_an_unknown_choice():
    c = FrictionFeedforwardConfig(ff_max=3.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        c.ff_max = 4.0
    assert c.replace(lag=False).c_fields() == {**c.c_fields(), "lag": False}
    assert c.c_fields()["at_ref"] == 0 and c.replace(ff_input="reference").c_fields()["at_ref"] == 1
    assert "bound on |feedforward| (N*m)" in FrictionFeedforwardConfig.__doc__  # the C header's comment
    assert "largest plausible lag (s)" in RobustAdaptiveFeedforwardConfig.__doc__
    with pytest.raises(ParameterError, match="ff_input must be one of"):
        FrictionFeedforwardConfig(ff_input="predicted")
    with pytest.raises(ParameterError, match="ff must be a FrictionFeedforwardConfig"):
        RobustAdaptiveFeedforwardConfig(ff={"lag": False})
    import pickle

    assert pickle.loads(pickle.dumps(RobustAdaptiveFeedforwardConfig(warmup=3))).warmup == 3


def test_c_defaults_are_the_bytes_of_every_default_config():
    names = [n[:-len("_default_config")] for n in dir(lib) if n.endswith("_default_config")]
    assert len(names) >= 15
    for n in names:
        ctype = f"{n}_config"
        want = getattr(lib, f"{n}_default_config")()
        got = ffi.new(f"{ctype} *", c_defaults(ctype))[0]
        assert _leaves(got) == _leaves(want), ctype
    assert c_defaults("aff_residual_config")["switch_in"]["share"] == 0.1
    with pytest.raises(ParameterError, match="aff_nothing_config"):
        c_defaults("aff_nothing_config")


def _leaves(x, path=""):
    """Every number of a C struct by its path (the padding between fields left out)."""
    if not isinstance(x, ffi.CData):
        return {path: x}
    t = ffi.typeof(x)
    if t.kind == "struct":
        return {k: v for name, _ in t.fields for k, v in _leaves(getattr(x, name), f"{path}.{name}").items()}
    if t.kind == "array":
        return {f"{path}[{i}]": x[i] for i in range(len(x))}
    raise AssertionError(t)


def _msg(code: str) -> str:
    return ffi.string(lib.aff_error_message(getattr(lib, code))).decode()


EST = FrictionEstimate(J=0.5, tau=0.01, sigma=1.0, Fc=1.0, Fs=1.5, offset=0.0, Vs=0.02, delta=1.0, J_alt=math.nan)
SUP = dict(Tc=TC, J_n=0.5, omega=20.0)


def _sup(**k):
    """A supervisor of SUP with ``k`` (a constructor input or a config field)."""
    return FeedforwardSupervisor(**{**SUP, **{a: v for a, v in k.items() if a in SUP}},
                                 config=FeedforwardSupervisorConfig(**{a: v for a, v in k.items() if a not in SUP}))


def _ff(**k):
    return FrictionFeedforward(EST, dt=TC, config=FrictionFeedforwardConfig(**k))


def _robust(**k):
    return RobustAdaptiveFeedforward(SlidingFrictionEstimator(0.02, 1.0, Tc=TC), dt=TC,
                                     config=RobustAdaptiveFeedforwardConfig(**k))


def _eq4(**k):
    return AdaptiveFrictionFeedforward(RegressionModel(0.02, 1.0), dt=TC, config=AdaptiveFrictionFeedforwardConfig(**k))


def _canudas(**k):
    return CanudasCompensator(Tc=TC, config=CanudasCompensatorConfig(**k))


def _sliding(**k):
    """The sliding estimator with ``Vs``, ``delta``, ``Tc`` or a config field of ``k``."""
    args = {"Vs": 0.02, "delta": 1.0, "Tc": TC, **{a: k.pop(a) for a in ("Vs", "delta", "Tc") if a in k}}
    return SlidingFrictionEstimator(args.pop("Vs"), args.pop("delta"), config=SlidingFrictionEstimatorConfig(**k),
                                    **args)


#: (constructor, keyword, bad value, the C code whose sentence the error carries)
REFUSED = [
    (OutlierGate, "n_sigma", 0.0, "AFF_ERR_GATE_N_SIGMA"), (OutlierGate, "alpha", 1.5, "AFF_ERR_GATE_ALPHA"),
    (OutlierGate, "max_step", -1.0, "AFF_ERR_GATE_MAX_STEP"),
    (OutlierGate, "max_consecutive", 0, "AFF_ERR_GATE_MAX_CONSECUTIVE"),
    (RangeGate, "factor", 1.0, "AFF_ERR_RANGE_GATE_FACTOR"), (RangeGate, "memory", 0.0, "AFF_ERR_RANGE_GATE_MEMORY"),
    (RangeGate, "x_max", -2.0, "AFF_ERR_RANGE_GATE_X_MAX"), (RangeGate, "floor", -1.0, "AFF_ERR_RANGE_GATE_FLOOR"),
    (lambda **k: FrictionFeedforward(EST, **{"dt": TC, **k}), "dt", 0.0, "AFF_ERR_FIXED_FF_DT"),
    (_ff, "stick_samples", 0, "AFF_ERR_FIXED_FF_STICK_SAMPLES"), (_ff, "w_max", -1.0, "AFF_ERR_FIXED_FF_W_MAX"),
    (_ff, "ff_max", -1.0, "AFF_ERR_FIXED_FF_FF_MAX"),
    *[(_robust, key, bad, code)
      for key, bad, code in (("warmup", -1, "AFF_ERR_ROBUST_FF_WARMUP"), ("tau_max", 0.0, "AFF_ERR_ROBUST_FF_TAU_MAX"),
                             ("consistency", 0.0, "AFF_ERR_ROBUST_FF_CONSISTENCY"),
                             ("lag_margin", -1.0, "AFF_ERR_ROBUST_FF_LAG_MARGIN"),
                             ("lag_margin_max", -1.0, "AFF_ERR_ROBUST_FF_LAG_MARGIN_MAX"),
                             ("max_rel_stderr", 0.0, "AFF_ERR_ROBUST_FF_MAX_REL_STDERR"),
                             ("lag_memory", -1.0, "AFF_ERR_ROBUST_FF_LAG_MEMORY"),
                             ("lag_zero", -1.0, "AFF_ERR_ROBUST_FF_LAG_ZERO"),
                             ("fade_in", -1.0, "AFF_ERR_ROBUST_FF_FADE_IN"),
                             ("J_hi", 0.0, "AFF_ERR_ROBUST_FF_J_RANGE"))],
    *[(_sup, key, bad, code)
      for key, bad, code in (("Tc", 0.0, "AFF_ERR_SUPERVISOR_TC"), ("J_n", -1.0, "AFF_ERR_SUPERVISOR_J_N"),
                             ("omega", math.inf, "AFF_ERR_SUPERVISOR_OMEGA"),
                             ("window", 0.0, "AFF_ERR_SUPERVISOR_WINDOW"),
                             ("margin", 1.0, "AFF_ERR_SUPERVISOR_MARGIN"), ("delay", 99, "AFF_ERR_SUPERVISOR_DELAY"),
                             ("Kp", math.inf, "AFF_ERR_SUPERVISOR_KP"),
                             ("track_margin", -1.0, "AFF_ERR_SUPERVISOR_TRACK_MARGIN"))],
    *[(_eq4, key, bad, code)
      for key, bad, code in (("Ts", 0.0, "AFF_ERR_EQ4_FF_TS"), ("lam", 1.5, "AFF_ERR_EQ4_FF_LAM"),
                             ("P0", -1.0, "AFF_ERR_EQ4_FF_P0"), ("warmup", -1, "AFF_ERR_EQ4_FF_WARMUP"),
                             ("tau_max", 0.0, "AFF_ERR_EQ4_FF_TAU_MAX"), ("w_band", -1.0, "AFF_ERR_EQ4_FF_W_BAND"),
                             ("map_rel_stderr", 0.0, "AFF_ERR_EQ4_FF_MAP_REL_STDERR"))],
    *[(_sliding, key, bad, code)
      for key, bad, code in (("Vs", 0.0, "AFF_ERR_SLIDING_VS"), ("delta", 0.0, "AFF_ERR_SLIDING_DELTA"),
                             ("Tc", -1.0, "AFF_ERR_SLIDING_TC"), ("Ts", 1.5e-3, "AFF_ERR_SLIDING_TS"),
                             ("T_filter", 1e-3, "AFF_ERR_SLIDING_T_FILTER"), ("lam", 0.0, "AFF_ERR_SLIDING_LAM"),
                             ("P0", math.nan, "AFF_ERR_SLIDING_P0"), ("P_max", -1.0, "AFF_ERR_SLIDING_P_MAX"),
                             ("w_band_min", -1.0, "AFF_ERR_SLIDING_W_BAND_MIN"),
                             ("dwell_max", 1.5, "AFF_ERR_SLIDING_DWELL_MAX"), ("J_max", 0.0, "AFF_ERR_SLIDING_J_MAX"),
                             ("tau_max", math.inf, "AFF_ERR_SLIDING_TAU_MAX"))],
    *[(_canudas, key, bad, code)
      for key, bad, code in (("Ts", 0.0, "AFF_ERR_CANUDAS_TS"), ("lam", 0.0, "AFF_ERR_CANUDAS_LAM"),
                             ("P0", math.nan, "AFF_ERR_CANUDAS_P0"), ("J_guess", 0.0, "AFF_ERR_CANUDAS_J_GUESS"),
                             ("w_dead", -1.0, "AFF_ERR_CANUDAS_W_DEAD"), ("warmup", -1, "AFF_ERR_CANUDAS_WARMUP"),
                             ("ff_max", -1.0, "AFF_ERR_CANUDAS_FF_MAX"))],
]


@pytest.mark.parametrize("make,key,bad,code", REFUSED, ids=lambda x: str(x) if isinstance(x, str) else None)
def test_a_range_is_checked_once_by_c_and_the_error_names_the_field(make, key, bad, code):
    with pytest.raises(ParameterError) as e:
        make(**{key: bad})
    assert _msg(code) in str(e.value)
    assert key in _msg(code)


@pytest.mark.parametrize("make,key", [(OutlierGate, "max_consecutive"), (OutlierGate, "n_sigma"),
                                      (RangeGate, "memory"), (_sup, "delay"), (_ff, "stick_samples"),
                                      (_eq4, "warmup"), (_canudas, "warmup"), (_sliding, "Vs"), (_sliding, "Tc")])
@pytest.mark.parametrize("bad", [True, "1", None, 2.5])
def test_a_value_of_the_wrong_type_is_refused_naming_the_field(make, key, bad):
    if bad == 2.5 and key in ("n_sigma", "memory", "Vs", "Tc"):
        return  # a real number is of the right type there
    with pytest.raises(SettingTypeError, match=key):  # a ParameterError and a TypeError
        make(**{key: bad})


def test_the_wrappers_public_fields_read_their_structs():
    """The one accessor (``plant.component.struct_field``): each public field reads its C struct's value, under its
    old name."""
    from adaptive_ff.compensation import adaptive_feedforward, feedforward, gate, sliding_estimator, supervisor

    g = OutlierGate(max_step=0.25, n_sigma=6.5, alpha=0.125, max_consecutive=7)
    assert (g.max_step, g.n_sigma, g.alpha, g.max_consecutive, g.n_rejected) == (0.25, 6.5, 0.125, 7, 0)
    assert not g.check(float("nan")) and (g.n_rejected, g.n_nonfinite) == (1, 1)
    r = RangeGate(x_max=3.0, factor=4.0, floor=0.5, memory=99.0, max_consecutive=3)
    assert (r.x_max, r.factor, r.floor, r.max_consecutive, r.memory) == (3.0, 4.0, 0.5, 3, 99.0)
    assert r.check(2.0) and r.envelope == 2.0
    ff = _robust(warmup=33, lag_zero=2.5, project=False,
                 ff=FrictionFeedforwardConfig(stick_samples=12, ff_max=9.0, lag=False))
    assert (ff.dt, ff.stick_samples, ff.warmup, ff.lag_zero, ff.project, ff.ff_max, ff.lag) == (
        TC, 12, 33, 2.5, False, 9.0, False)
    assert type(ff.warmup) is int and type(ff.project) is bool and type(ff.dt) is float
    s = FeedforwardSupervisor(**SUP)
    assert (s.on, s.n_backoff, s.f_hat, s.ms_error_comp) == (True, 0, 0.0, 0.0) and type(s.on) is bool
    src = "".join(inspect.getsource(m) for m in (adaptive_feedforward, feedforward, gate, sliding_estimator,
                                                 supervisor))
    assert "= property(lambda self: float(self._c." not in src and "= property(lambda self: int(self._c." not in src
