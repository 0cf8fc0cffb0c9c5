"""The estimators of mode ``adaptive`` by name: the registry the options, the builders and the CLI share.

This module imports no C extension, so that ``adaptive-ff compare --help`` lists the choices without loading the
C core. :data:`controllers.simulation.compensators.ESTIMATOR_BUILDERS` holds the builder of each name (the same
names, in this order, checked at its import); :class:`controllers.simulation.loop_config.LoopConfig` checks a name
against :data:`ESTIMATORS` and the compare CLI's ``--estimator`` offers them as its choices.
"""

from __future__ import annotations

from plant.errors import ParameterError

__all__ = ["ESTIMATORS", "ESTIMATOR_INFO", "DEFAULT_ESTIMATOR", "check_estimator"]

#: Estimator name -> what it is (one line). The sliding-regime inverse-dynamics RLS (the default); the paper's eq. 4
#: estimated consistently in the closed loop by recursive IV on the sliding samples (``eq4``, docs/theory.md); eq. 4
#: by the paper's RLS as printed (eqs. 10-13) at Ts (``eq4-rls``, the baseline: biased in the closed loop).
ESTIMATOR_INFO = {
    "sliding": "sliding-regime inverse-dynamics RLS",
    "eq4": "the paper's eq. 4 by recursive IV on the sliding samples",
    "eq4-rls": "eq. 4 by the paper's RLS, eqs. 10-13 as printed",
}

#: The names, in the registry's order.
ESTIMATORS = tuple(ESTIMATOR_INFO)

#: The default estimator (the first).
DEFAULT_ESTIMATOR = ESTIMATORS[0]


def check_estimator(name: str, value) -> None:
    """Raise :class:`plant.errors.ParameterError` naming ``name`` unless ``value`` is one of :data:`ESTIMATORS`;
    the former name ``"eq4-iv"`` (the instrumental-variable estimator, now ``"eq4"``; the paper's RLS is
    ``"eq4-rls"``) is refused with its new name."""
    if value == "eq4-iv":
        raise ParameterError(f"{name}: the estimator 'eq4-iv' is now 'eq4' (and the paper's RLS as printed, "
                             f"formerly 'eq4', is 'eq4-rls')")
    if value not in ESTIMATORS:
        raise ParameterError(f"{name} must be one of {ESTIMATORS}, got {value!r}")
