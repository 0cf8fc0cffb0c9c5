"""adaptive_ff.identification.log_scale.from_log: the one way back from a positive parameter's log scale."""

import math

from adaptive_ff.identification.log_scale import from_log


def test_from_log_is_exp_of_the_clipped_log():
    assert from_log(math.log(0.02)) == math.exp(math.log(0.02))  # the same float as exp, no rounding of its own
    assert abs(from_log(math.log(0.02)) - 0.02) <= 0.02 * 4e-16
    assert from_log(-3.0, -2.0, 5.0) == math.exp(-2.0)  # below the box: its lower end
    assert from_log(9.0, -2.0, 5.0) == math.exp(5.0)  # above: its upper end
    assert from_log(1e6, -700.0, 700.0) == math.exp(700.0) and math.isfinite(from_log(1e6, -700.0, 700.0))
    assert from_log(-1e6, -700.0, 700.0) == math.exp(-700.0) > 0.0


def test_from_log_passes_a_nan_through_for_the_caller_to_refuse():
    assert math.isnan(from_log(math.nan, -1.0, 1.0))


def test_from_log_overflows_to_inf_as_numpy_exp_does():
    # an unbounded optimiser step far up the log scale: inf for the caller's plausibility check, not an exception
    import numpy as np

    with np.errstate(over="ignore"):
        assert from_log(800.0) == float(np.exp(800.0)) == math.inf
    assert from_log(709.0) == float(np.exp(709.0)) < math.inf
    assert from_log(-800.0) == 0.0  # underflow: 0, as exp
