"""One default and one check per knob across the option bundles: the loop's options (``LoopConfig``), the
comparison's (``CompareOptions``) and the zoo's (``ZooOptions``); one registry of the adaptive mode's estimators.
"""

from __future__ import annotations

import dataclasses
import inspect
import math

import pytest

from adaptive_ff.compensation.adaptive_feedforward import RobustAdaptiveFeedforward
from adaptive_ff.compensation.eq4_feedforward import AdaptiveFrictionFeedforward
from adaptive_ff.identification.regression import RegressionModel
from controllers.experiments.compare import DESIGNED, EXPERIMENT_DEFAULTS, EXPERIMENT_LOOP, CompareOptions
from controllers.experiments.zoo import PER_JOINT, ZooOptions
from controllers.simulation import compensators
from controllers.simulation.compensators import ESTIMATOR_BUILDERS, LoopConfig, build_mode
from controllers.simulation.estimators import DEFAULT_ESTIMATOR, ESTIMATORS
from controllers.simulation.loop_config import FLAT_PATHS
from plant import preset
from plant.errors import ParameterError


def _defaults(cls) -> dict:
    if cls is LoopConfig:  # the nested config: its settings by their flat keywords
        return LoopConfig().to_flat()
    return {f.name: f.default for f in dataclasses.fields(cls) if f.default is not dataclasses.MISSING}


def test_compare_carries_the_loops_config_with_the_loops_defaults_or_a_named_override():
    loop, cmp = LoopConfig().to_flat(), CompareOptions().loop.to_flat()
    differ = {k for k in loop if cmp[k] != loop[k] or type(cmp[k]) is not type(loop[k])}
    assert differ == set(EXPERIMENT_DEFAULTS), "the experiment's overrides are EXPERIMENT_DEFAULTS, and only they"
    assert CompareOptions().loop == EXPERIMENT_LOOP == LoopConfig.from_flat(**EXPERIMENT_DEFAULTS)
    # the four that differ on purpose
    assert (cmp["warmup"], loop["warmup"]) == (50, 200) and (cmp["stick_samples"], loop["stick_samples"]) == (50, 10)
    assert (cmp["u_max"], loop["u_max"]) == (None, math.inf) and (cmp["noise_std"], loop["noise_std"]) == (1e-3, 0)
    # one stick-band default, the loop's: sized from the configured sensor (3 x its velocity noise)
    assert cmp["stick_band"] is None and loop["stick_band"] is None
    # no setting is declared twice: the experiment's own fields and the loop's paths are apart
    assert not {f.name for f in dataclasses.fields(CompareOptions)} & set(FLAT_PATHS)
    o = CompareOptions.from_flat(duration=2.0, warmup=77, lam=0.99, estimator="eq4")
    assert (o.duration, o.loop.feedforward.warmup, o.loop.estimator.lam, o.loop.estimator.name) == (2.0, 77, 0.99, "eq4")
    r = o.replace(warmup=5, seed=3)
    assert (r.loop.feedforward.warmup, r.seed, r.loop.estimator.name, o.loop.feedforward.warmup) == (5, 3, "eq4", 77)
    assert all(o.flat(k) == o.loop.flat(k) for k in FLAT_PATHS if k not in DESIGNED)
    with pytest.raises(ParameterError, match="^Kp: the comparison sets it"):
        CompareOptions.from_flat(Kp=1.0)
    with pytest.raises(TypeError, match="unknown option 'lamda'"):
        CompareOptions.from_flat(lamda=0.9)


def test_the_zoo_holds_a_comparison_and_declares_none_of_its_settings():
    own = {f.name for f in dataclasses.fields(ZooOptions)}
    # none of the comparison's settings re-declared; own compensators by import path (picklable for the workers)
    # instead of the comparison's callables
    assert own & set(CompareOptions.flat_names()) == {"compensators"}
    assert ZooOptions().compare == CompareOptions() and ZooOptions().compare_options() == CompareOptions()
    o = ZooOptions.from_flat(n=3, duration=4.0, seed=5, estimator="eq4", iv_map_stderr=0.2, switch_in=False, delay=1)
    c = o.compare_options()
    assert (o.n, c.duration, c.seed, c.loop.estimator.name, c.loop.estimator.iv_map_stderr, c.loop.observer.switch_in,
            c.loop.sensor.delay) == (3, 4.0, 5, "eq4", 0.2, False, 1)
    assert c == CompareOptions.from_flat(duration=4.0, seed=5, estimator="eq4", iv_map_stderr=0.2, switch_in=False,
                                         delay=1)
    # the settings of one plant are each joint's: a comparison's torque limit and design inertia are not used
    per_joint = ZooOptions(compare=CompareOptions.from_flat(duration=4.0, u_max=9.0, J_design=0.5)).compare_options()
    assert (per_joint.loop.drive.u_max, per_joint.loop.controller.J_design) == (None, None)
    assert set(PER_JOINT) <= set(CompareOptions.flat_names())
    with pytest.raises(ParameterError, match="compare must be a CompareOptions"):
        ZooOptions(compare={"duration": 4.0})


@pytest.mark.parametrize("kw,match", [(dict(estimator="kalman"), "estimator must be one of"),
                                      (dict(estimator="eq4-iv"), "is now 'eq4'"),
                                      (dict(iv_map_stderr=0.0), "iv_map_stderr"), (dict(switch_in="yes"), "switch_in"),
                                      (dict(noise_std=-1.0), "noise_std"), (dict(ff_input="both"), "ff_input"),
                                      (dict(delay=-1), "delay"), (dict(encoder_counts=0), "encoder_counts"),
                                      (dict(slew_rate=0.0), "slew_rate"), (dict(sign_input="x"), "sign_input")])
def test_each_shared_knob_is_checked_by_the_loops_options_for_every_bundle(kw, match):
    for make in (lambda **k: LoopConfig.from_flat(Kp=1.0, Ki=0.0, **k), lambda **k: CompareOptions.from_flat(duration=2.0, **k),
                 lambda **k: ZooOptions.from_flat(n=1, duration=2.0, **k)):
        try:
            make(**kw)
        except TypeError:  # a knob the bundle does not carry (the zoo carries a few)
            continue
        except ParameterError as e:
            assert match in str(e), str(e)
            continue
        raise AssertionError(f"{kw} accepted")


def test_the_estimators_have_one_registry_used_by_options_builders_and_the_cli():
    from controllers.cli.main import build_parser

    assert tuple(ESTIMATOR_BUILDERS) == ESTIMATORS and DEFAULT_ESTIMATOR == "sliding"
    assert _defaults(LoopConfig)["estimator"] == CompareOptions().flat("estimator") == DEFAULT_ESTIMATOR
    compare = next(a for a in build_parser()._subparsers._group_actions[0].choices["compare"]._actions
                   if "--estimator" in a.option_strings)
    assert tuple(compare.choices) == ESTIMATORS and compare.default is None and compare.dest == "estimator"
    # construction is a lookup: no branch on an estimator's name in the builders
    src = inspect.getsource(compensators)
    assert "estimator ==" not in src and "estimator in (" not in src
    P = preset("paper")
    model = RegressionModel(P.Vs, P.delta)
    kinds = {"sliding": (RobustAdaptiveFeedforward, None), "eq4": (AdaptiveFrictionFeedforward, True),
             "eq4-rls": (AdaptiveFrictionFeedforward, False)}
    assert set(kinds) == set(ESTIMATORS)
    for e, (cls, iv) in kinds.items():
        o = LoopConfig.from_flat(Kp=69.28, Ki=786.1, J_design=P.J, Vs=P.Vs, delta=P.delta, model=model, estimator=e,
                        switch_in=False, supervise=False)
        ff = ESTIMATOR_BUILDERS[e](o, P.J, 75.0)
        assert type(ff) is cls and (iv is None or ff.iv is iv)
        _, _, comp = build_mode(P, "adaptive", o)
        assert type(getattr(comp, "feedforward", comp)) is cls  # over the sliding estimator: in AdaptiveCompensator


def test_compare_and_compare_arm_take_changes_through_one_helper():
    from controllers.experiments.compare import compare
    from controllers.experiments.comparison import options_with_changes

    o = CompareOptions()
    assert options_with_changes(o, {}, where="x") is o
    assert options_with_changes(o, {"duration": 30.0}, where="x") == dataclasses.replace(o, duration=30.0)
    with pytest.raises(ParameterError, match=r"^compare: .*no_such_field"):
        compare(preset("paper"), no_such_field=1)
    pytest.importorskip("pinocchio", reason="the [arm] extra is not installed")
    from controllers.experiments.compare_arm import compare_arm

    with pytest.raises(ParameterError, match=r"^compare_arm: .*no_such_field"):
        compare_arm(None, "arm.json", no_such_field=1)


def test_the_compare_flags_are_paths_of_the_loops_config_with_the_registries_choices_and_its_defaults():
    import re

    from controllers.cli.compare import loop_flags

    o = CompareOptions()
    flags = loop_flags()
    assert {name for name, _ in flags.values()} <= set(FLAT_PATHS) - set(DESIGNED)
    assert flags["--estimator"] == ("estimator", flags["--estimator"][1]) and \
        tuple(flags["--estimator"][1]["choices"]) == ESTIMATORS
    checked = 0
    for flag, (name, kw) in flags.items():  # a default the help states is the comparison's (no second default)
        m = re.search(r"\(default (inf|[-+0-9.e]+)", kw["help"])
        if m and o.flat(name) is not None:
            assert float(m.group(1)) == o.flat(name), flag
            checked += 1
    assert checked == 4  # --iv-map-stderr, --omega-q, --Ts, --noise


def test_the_loops_config_has_one_path_per_setting_and_one_map_from_the_flat_names():
    from controllers.simulation.loop_config import GROUPS

    paths = [(g, f.name) for g, cls in GROUPS.items() for f in dataclasses.fields(cls)]
    assert sorted(FLAT_PATHS.values()) == sorted(paths) and len(set(paths)) == len(paths) == len(FLAT_PATHS) == 61
    assert FLAT_PATHS["estimator"] == ("estimator", "name") and FLAT_PATHS["supervise"] == ("supervisor", "enabled")
    assert FLAT_PATHS["supervise_window"] == ("supervisor", "window") and FLAT_PATHS["sensor_gate"] == ("sensor", "gate")
    o = LoopConfig.from_flat(Kp=2.0, Ki=30.0, estimator="eq4-rls", supervise_window=4.0, encoder_counts=4096)
    assert (o.controller.Kp, o.controller.Ki, o.estimator.name, o.supervisor.window, o.sensor.encoder_counts) == \
        (2.0, 30.0, "eq4-rls", 4.0, 4096)
    assert LoopConfig.from_flat(**o.to_flat()) == o and o.flat("supervise_window") == 4.0
    r = o.replace(lam=0.99, omega_r=800.0)
    assert (r.estimator.lam, r.observer.omega_r, r.estimator.name, o.estimator.lam) == (0.99, 800.0, "eq4-rls", None)
    assert r.controller is o.controller and r.sensor is o.sensor  # untouched groups are shared, not copied
    with pytest.raises(ParameterError, match="unknown loop setting 'lamda'"):
        LoopConfig.from_flat(lamda=0.9)
    with pytest.raises(ParameterError, match=r"^Ts = 0.0105 s must be a positive multiple of Tc"):  # ties two groups
        LoopConfig.from_flat(Tc=1e-3, Ts=0.0105)
    with pytest.raises(ParameterError, match="estimator must be a EstimatorSettings"):
        LoopConfig(estimator="eq4")
    with pytest.raises(ParameterError, match="u_max is None"):  # sized by a comparison: a run needs a number
        build_mode(preset("paper"), "none", LoopConfig.from_flat(u_max=None))


@pytest.mark.parametrize("kw,says", [
    (dict(encoder_counts=0), "encoder_counts must be an integer >= 1 (encoder counts per joint revolution) or None, "
                             "got 0 (sensor.encoder_counts; the Sensor's counts_per_rev)"),
    (dict(encoder_counts="x"), "encoder_counts must be an integer >= 1"),
    (dict(delay=-1), "delay must be an integer number of periods in 0..32, got -1 (sensor.delay)"),
    (dict(encoder_counts=8, velocity="kalman", velocity_bandwidth=500.0),
     "velocity_bandwidth must be below the Nyquist frequency 500 Hz"),
    (dict(encoder_counts=8, velocity="kalman", velocity_model="cj"), "velocity_model must be one of ['cv', 'ca']"),
    (dict(slew_rate=0.0), "slew_rate must be > 0 (N·m/s; math.inf for none), got 0.0 (drive.slew_rate)"),
    (dict(slew_rate=True), "slew_rate must be > 0")])
def test_the_sensor_and_the_drive_are_checked_once_by_their_components_naming_the_setting(kw, says):
    from controllers.simulation.loop_config import DriveSettings, SensorSettings

    g, = {FLAT_PATHS[k][0] for k in kw if FLAT_PATHS[k][0] in ("sensor", "drive")}
    group = {"sensor": SensorSettings, "drive": DriveSettings}[g](**{FLAT_PATHS[k][1]: v for k, v in kw.items()})
    assert isinstance(group, (SensorSettings, DriveSettings))  # the group itself leaves the range to its component
    with pytest.raises(ParameterError) as e:
        LoopConfig.from_flat(**kw)
    assert says in str(e.value)
