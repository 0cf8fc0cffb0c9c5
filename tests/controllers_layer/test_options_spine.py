"""One default and one check per knob across the option bundles: the loop's options (``LoopConfig``), the
comparison's (``CompareOptions``) and the zoo's (``ZooOptions``); one registry of the adaptive mode's estimators.
"""

from __future__ import annotations

import dataclasses
import inspect

import pytest

from adaptive_ff.compensation.adaptive_feedforward import RobustAdaptiveFeedforward
from adaptive_ff.compensation.eq4_feedforward import AdaptiveFrictionFeedforward
from adaptive_ff.identification.regression import RegressionModel
from controllers.experiments.compare import EXPERIMENT_DEFAULTS, LOOP_KNOBS, CompareOptions
from controllers.experiments.zoo import SHARED_FIELDS, ZooOptions
from controllers.simulation import compensators
from controllers.simulation.compensators import ESTIMATOR_BUILDERS, LoopConfig, build_mode
from controllers.simulation.estimators import DEFAULT_ESTIMATOR, ESTIMATORS
from plant import preset
from plant.errors import ParameterError


def _defaults(cls) -> dict:
    if cls is LoopConfig:  # the nested config: its settings by their flat keywords
        return LoopConfig().to_flat()
    return {f.name: f.default for f in dataclasses.fields(cls) if f.default is not dataclasses.MISSING}


def test_a_knob_compare_shares_with_the_loop_has_the_loops_default_or_a_named_override():
    loop, cmp = _defaults(LoopConfig), _defaults(CompareOptions)
    shared = set(loop) & set(cmp)
    assert shared == set(LOOP_KNOBS), "a knob both carry must be registered in LOOP_KNOBS (one default, one check)"
    differ = {k for k in shared if cmp[k] != loop[k] or type(cmp[k]) is not type(loop[k])}
    assert differ == set(EXPERIMENT_DEFAULTS), "the experiment's overrides are EXPERIMENT_DEFAULTS, and only they"
    for k, v in EXPERIMENT_DEFAULTS.items():
        assert cmp[k] == v
    # the four that differ on purpose
    assert (cmp["warmup"], loop["warmup"]) == (50, 200) and (cmp["stick_samples"], loop["stick_samples"]) == (50, 10)
    assert (cmp["stick_band"], loop["stick_band"]) == (None, 0.0) and (cmp["noise_std"], loop["noise_std"]) == (1e-3, 0)
    o = CompareOptions(duration=2.0, warmup=77, lam=0.99, estimator="eq4")
    assert o.loop_fields() == {k: getattr(o, k) for k in LOOP_KNOBS} and o.loop_fields()["warmup"] == 77


def test_the_zoo_takes_the_knobs_it_shares_with_compare_from_compare():
    zoo, cmp = _defaults(ZooOptions), _defaults(CompareOptions)
    shared = set(zoo) & set(cmp)
    assert shared - {"compensators"} == set(SHARED_FIELDS)  # the zoo's own compensators are import paths
    for k in SHARED_FIELDS:
        assert zoo[k] == cmp[k] and type(zoo[k]) is type(cmp[k]), k
    o = ZooOptions(n=3, duration=4.0, seed=5, estimator="eq4", iv_map_stderr=0.2, switch_in=False, delay=1)
    c = o.compare_options()
    assert (c.duration, c.seed, c.estimator, c.iv_map_stderr, c.switch_in, c.delay) == (4.0, 5, "eq4", 0.2, False, 1)
    assert {k: getattr(c, k) for k in LOOP_KNOBS if k not in SHARED_FIELDS} == \
        {k: getattr(CompareOptions(duration=4.0), k) for k in LOOP_KNOBS if k not in SHARED_FIELDS}


@pytest.mark.parametrize("kw,match", [(dict(estimator="kalman"), "estimator must be one of"),
                                      (dict(estimator="eq4-iv"), "is now 'eq4'"),
                                      (dict(iv_map_stderr=0.0), "iv_map_stderr"), (dict(switch_in="yes"), "switch_in"),
                                      (dict(noise_std=-1.0), "noise_std"), (dict(ff_input="both"), "ff_input"),
                                      (dict(delay=-1), "delay"), (dict(encoder_counts=0), "encoder_counts"),
                                      (dict(slew_rate=0.0), "slew_rate"), (dict(sign_input="x"), "sign_input")])
def test_each_shared_knob_is_checked_by_the_loops_options_for_every_bundle(kw, match):
    for make in (lambda **k: LoopConfig.from_flat(Kp=1.0, Ki=0.0, **k), lambda **k: CompareOptions(duration=2.0, **k),
                 lambda **k: ZooOptions(n=1, duration=2.0, **k)):
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
    assert _defaults(LoopConfig)["estimator"] == _defaults(CompareOptions)["estimator"] == DEFAULT_ESTIMATOR
    compare = next(a for a in build_parser()._subparsers._group_actions[0].choices["compare"]._actions
                   if "--estimator" in a.option_strings)
    assert tuple(compare.choices) == ESTIMATORS and compare.default == DEFAULT_ESTIMATOR
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
