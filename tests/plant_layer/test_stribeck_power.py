"""Eq. 3's power ``x**delta`` (C ``plant_stribeck_power``): correctly rounded at the profile grid's shapes
``delta`` 2 and 0.5, checked against exact rational arithmetic (:class:`fractions.Fraction`), not against the
floating-point operations the C takes; libm's ``pow`` at any other ``delta``."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest

from plant._cplant import lib
from plant.stribeck_map import stribeck_shape_scalar

RNG_SEED = 20261129


def _samples(n: int = 20000) -> np.ndarray:
    """``n`` seeded normalised speeds ``|w|/Vs`` spread over 2**-30 .. 2**10 (log-uniform)."""
    rng = np.random.default_rng(RNG_SEED)
    return np.exp2(rng.uniform(-30.0, 10.0, n))


def _correctly_rounded_sqrt(x: float, r: float) -> bool:
    """Whether ``r`` is the double nearest to the exact square root of ``x``: ``x`` lies between the squares of the
    midpoints from ``r`` to its neighbours (exact rational arithmetic)."""
    lo = (Fraction(r) + Fraction(math.nextafter(r, 0.0))) / 2
    hi = (Fraction(r) + Fraction(math.nextafter(r, math.inf))) / 2
    return lo * lo <= Fraction(x) <= hi * hi


def test_square_is_the_correctly_rounded_square():
    """The seeded sample holds 11 values on which glibc 2.36's ``pow(x, 2.0)`` returns the other neighbour."""
    for x in _samples():
        exact = float(Fraction(float(x)) ** 2)  # the exact square rounded once (Python's int division rounds)
        assert lib.plant_stribeck_power(float(x), 2.0) == exact, x


def test_square_root_is_the_correctly_rounded_square_root():
    for x in _samples():
        r = lib.plant_stribeck_power(float(x), 0.5)
        assert _correctly_rounded_sqrt(float(x), r), x


@pytest.mark.parametrize("delta", [1.5, 0.7, 3.0, -0.5])
def test_other_shapes_take_the_power_function(delta):
    for x in _samples(500):
        assert lib.plant_stribeck_power(float(x), delta) == math.pow(float(x), delta), (x, delta)


def test_delta_one_is_exact_and_nan_propagates():
    for x in _samples(500):
        assert lib.plant_stribeck_power(float(x), 1.0) == float(x)
    for delta in (0.5, 1.0, 2.0, 1.5):
        assert math.isnan(lib.plant_stribeck_power(math.nan, delta))


def test_the_stribeck_shape_uses_it():
    """exp(-|w/Vs|**delta) of eq. 3 at delta 2 and 0.5: the exponential of the correctly rounded power of the
    correctly rounded quotient."""
    rng = np.random.default_rng(RNG_SEED + 1)
    for w, Vs in zip(rng.uniform(-2.0, 2.0, 2000), rng.uniform(0.01, 1.0, 2000)):
        x = abs(float(w)) / float(Vs)
        assert stribeck_shape_scalar(float(w), float(Vs), 2.0) == math.exp(-float(Fraction(x) ** 2))
        r = stribeck_shape_scalar(float(w), float(Vs), 0.5)
        assert r == math.exp(-math.sqrt(x)) and _correctly_rounded_sqrt(x, math.sqrt(x))
