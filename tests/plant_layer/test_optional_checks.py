"""The one check of an object-or-None knob (plant.errors.check_optional) and the settings classes' refusal of an
unknown keyword (plant.errors.known_fields): a ParameterError naming the argument and what was given."""

import pytest

from adaptive_ff.compensation.feedforward import FrictionFeedforward
from controllers.experiments.compare import CompareOptions
from controllers.experiments.zoo import ZooOptions
from plant.errors import ParameterError, UnknownFieldError, check_optional


def test_check_optional_passes_none_and_instances_and_names_a_wrong_value():
    assert check_optional("x", None, int) is None
    assert check_optional("x", 3, int) == 3
    with pytest.raises(ParameterError, match=r"^x must be a int or float or None, got str '3'$"):
        check_optional("x", "3", (int, float))
    with pytest.raises(TypeError, match=r"^ax must be a matplotlib Axes or None, got list \[\]$"):
        check_optional("ax", [], int, what="a matplotlib Axes", error=TypeError)


@pytest.mark.parametrize("knob", ["loop_model", "sign_observer"])
def test_a_component_knob_names_itself_and_the_wrong_type(knob):
    with pytest.raises(ParameterError, match=rf"^{knob} must be a \w+ or None, got dict \{{\}}$"):
        FrictionFeedforward(None, dt=1e-3, **{knob: {}})


@pytest.mark.parametrize("cls, name, hint, known", [(ZooOptions, "duration", "compare=CompareOptions", "n"),
                                                     (CompareOptions, "bogus", "CompareOptions.from_flat", "seed")])
def test_options_refuse_an_unknown_field_by_name(cls, name, hint, known):
    with pytest.raises(UnknownFieldError, match=rf"{cls.__name__}: '{name}' is no field of it .*{hint}") as e:
        cls(**{name: 30.0})
    assert isinstance(e.value, TypeError) and isinstance(e.value, ParameterError)
    assert getattr(cls(**{known: 7}), known) == 7  # a field is still taken
