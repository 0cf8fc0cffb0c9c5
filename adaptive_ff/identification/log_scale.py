"""The log-scale parametrisation of a positive parameter.

The fits and filters that estimate a positive parameter (the inertia ``J``, the lag ``tau``, the Stribeck velocity
``Vs``, the magnitude of ``delta``) work on its logarithm, so that every real value an optimiser or a filter's
sigma point tries maps to a value > 0 and a relative step is a step of the same size at every scale (the
parametrisation of scipy's ``least_squares`` starts here and of the UKF's state). :func:`from_log` is the one way
back from that scale.
"""

from __future__ import annotations

import math

__all__ = ["from_log"]


def from_log(x: float, low: float = -math.inf, high: float = math.inf) -> float:
    """A positive parameter from its log-scale value: ``exp(x)``, with ``x`` first clipped to ``[low, high]``.

    Parameters
    ----------
    x : float
        The natural logarithm of the parameter (of its value in SI units, e.g. ``log(Vs / (rad/s))``).
    low, high : float, optional
        Bounds on ``x`` (default none): a box the estimate is kept in, or ``±700`` to keep ``exp`` finite and
        > 0 whatever an optimiser tries.

    Returns
    -------
    float
        ``exp(min(max(x, low), high))``, in the parameter's unit: > 0 and finite for finite bounds within
        ``±700``; ``inf`` where that exceeds the largest float (as ``numpy.exp``: the caller's plausibility check
        refuses it); NaN for a NaN ``x`` (the caller's optimiser or filter step sees and refuses it).
    """
    try:
        return math.exp(min(max(float(x), low), high))
    except OverflowError:
        return math.inf
