"""The one check of an object-or-None knob (plant.errors.check_optional), of a number-in-a-range-or-None knob
(plant.errors.check_optional_number) and the settings classes' refusal of an unknown keyword
(plant.errors.known_fields): a ParameterError naming the argument and what was given."""

import math

import numpy as np
import pytest

from adaptive_ff.compensation.feedforward import FrictionFeedforward
from controllers.experiments.compare import CompareOptions
from controllers.experiments.zoo import ZooOptions
from adaptive_ff.identification.lag_profile import lag_profile_search
from adaptive_ff.identification.oe_options import OutputErrorOptions
from plant.errors import ParameterError, UnknownFieldError, check_optional, check_optional_number


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


def test_check_optional_number_passes_none_and_values_in_range_as_their_kind():
    assert check_optional_number("x", None, low=0.0, strict=True) is None
    x = check_optional_number("x", np.float32(0.5), low=0.0, high=1.0)
    assert x == 0.5 and type(x) is float
    n = check_optional_number("n", np.int64(3), integer=True, low=1)
    assert n == 3 and type(n) is int
    assert check_optional_number("x", 0.0, low=0.0) == 0.0 and check_optional_number("x", 1.0, high=1.0) == 1.0


@pytest.mark.parametrize("value, options, error, message", [
    (0.0, dict(low=0.0, strict=True), ParameterError, r"^f_scale must be > 0 \(or None\), got 0\.0$"),
    (-1e-3, dict(low=0.0, unit="s", none="profiled"), ParameterError,
     r"^f_scale must be >= 0 s \(or None: profiled\), got -0\.001$"),
    (1.0, dict(low=0.0, high=1.0, strict=True), ParameterError, r"^f_scale must be > 0 and < 1 \(or None\), got 1\.0$"),
    (1.5, dict(high=1.0), ParameterError, r"^f_scale must be <= 1 \(or None\), got 1\.5$"),
    (math.nan, dict(low=0.0), ParameterError, r"^f_scale must be >= 0 \(or None\), got nan$"),
    (math.inf, {}, ParameterError, r"^f_scale must be a finite number \(or None\), got inf$"),
    ("1", dict(low=0.0), TypeError, r"^f_scale must be >= 0 \(or None\), got '1' \(str\)$"),
    (True, dict(low=0.0), TypeError, r"^f_scale must be >= 0 \(or None\), got True \(bool\)$"),
    (0, dict(integer=True, low=1), ParameterError, r"^f_scale must be an integer >= 1 \(or None\), got 0$"),
    (2.0, dict(integer=True, low=1), ParameterError, r"^f_scale must be an integer >= 1 \(or None\), got 2\.0$"),
    (True, dict(integer=True), ParameterError, r"^f_scale must be an integer \(or None\), got True$"),
])
def test_check_optional_number_names_the_argument_and_the_value_out_of_range(value, options, error, message):
    with pytest.raises(error, match=message):
        check_optional_number("f_scale", value, **options)


@pytest.mark.parametrize("name, value, message", [
    ("f_scale", -0.5, r"^f_scale must be > 0 \(or None\), got -0\.5$"),
    ("bootstrap_lag_refits", 0, r"^bootstrap_lag_refits must be an integer >= 1 \(or None\), got 0$"),
    ("bootstrap_workers", 1.0, r"^bootstrap_workers must be an integer >= 1 \(or None\), got 1\.0$"),
    ("input_delay", -1.0, r"^input_delay must be >= 0 s \(or None: profiled\), got -1\.0$"),
])
def test_output_error_options_check_their_optional_numbers_by_name(name, value, message):
    assert getattr(OutputErrorOptions(**{name: None}), name) is None
    with pytest.raises(ParameterError, match=message):
        OutputErrorOptions(**{name: value})


def test_lag_profile_search_refuses_a_bad_n_refit_before_it_touches_the_problem():
    # a bare object as the problem: any use of it would raise AttributeError, not the ParameterError
    with pytest.raises(ParameterError, match=r"^n_refit must be an integer >= 1 \(or None\), got 0$"):
        lag_profile_search(object(), (1.0, np.zeros(5)), n_refit=0)
