"""A payload step: the joint's inertia changes at a given time (a tool or a payload picked up or put down).

:class:`PayloadStep` wraps any plant (a model of :mod:`plant.models`, a :class:`plant.ripple.FrictionRipple`,
a :class:`plant.drift.FrictionDrift`) and switches its inertia ``J`` to ``J_after`` at ``t_step``; the friction
stays as it is. The closed-loop engine switches the plant's parameter row at the first sample at or after
``t_step`` (:func:`controllers.simulation.closed_loop.plant_table`); the state (velocity, friction, position)
carries over: the momentum is not conserved, the velocity is (a payload gripped at rest relative to the joint's
end, or a load added by a stiff coupling that the 1 kHz loop does not resolve).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from plant.errors import ParameterError, check_finite_scalar

__all__ = ["PayloadStep"]


@dataclass(frozen=True)
class PayloadStep:
    """A plant whose inertia is ``J`` before ``t_step`` and ``J_after`` from ``t_step`` on.

    Parameters
    ----------
    base : plant model, FrictionRipple, FrictionDrift or PayloadStep
        The plant before the step (its ``J`` until ``t_step``); a time-varying base keeps varying (a drifting
        plant drifts on with the new inertia; a second PayloadStep switches again).
    t_step : float
        Time of the step (s), >= 0, finite. The engine applies it from the first sample ``t[k] >= t_step``.
    J_after : float
        Inertia after the step (kg·m²), > 0, finite.

    Raises
    ------
    ParameterError
        ``t_step < 0``, ``J_after <= 0``, a value not finite, or ``base`` not a plant; the key and value named.
    TypeError
        A value not a real number (a string, a bool).

    Notes
    -----
    ``at(t)`` is the frozen plant at ``t`` (``base.at(t)`` for a time-varying base) with ``J = J_after`` where
    ``t >= t_step``. Attribute access not defined here (``Vs``, ``friction``, a drift's ``Fc_change``, ...) is
    delegated to ``base`` (and so to the plant at ``t = 0``, as :class:`plant.drift.FrictionDrift`), ``J`` is
    ``at(0.0).J``: the design inertia ``J_design`` a compensator gets
    by default is the plant's ``J`` at ``t = 0`` in a single run (``at(0.0).J``; with ``t_step = 0`` that is
    ``J_after``; ``compare`` identifies it on the plant at ``t = 0``): nothing
    of the true plant after ``t = 0`` reaches a compensator, which must cope with the new inertia itself. The plant
    file (:mod:`plant.models`) carries it as ``"payload": {"t_step": t, "J_after": J}``.
    """

    base: Any
    t_step: float
    J_after: float

    def __post_init__(self):
        t = check_finite_scalar("t_step", self.t_step)
        if t < 0.0:
            raise ParameterError(f"t_step must be >= 0 (s), got {self.t_step!r}")
        J = check_finite_scalar("J_after", self.J_after)
        if not J > 0.0:
            raise ParameterError(f"J_after must be > 0 (kg·m²), got {self.J_after!r}")
        if not hasattr(self.base, "MODEL"):
            raise ParameterError(f"base must be a plant model (plant.models), a FrictionRipple, a FrictionDrift or a "
                                 f"PayloadStep, got {type(self.base).__name__}")
        object.__setattr__(self, "t_step", t)
        object.__setattr__(self, "J_after", J)

    MODEL = property(lambda self: self.base.MODEL)

    def at(self, t: float):
        """The frozen plant at time ``t`` (s): the base's, with ``J = J_after`` from ``t_step`` on."""
        t = float(t)
        p = self.base.at(t) if hasattr(self.base, "at") else self.base
        return p.replace(J=self.J_after) if t >= self.t_step else p

    def row_starts(self, t, Tc: float) -> np.ndarray:
        """Samples of a run where the engine switches the plant's parameters (the base's and the step's).

        Parameters
        ----------
        t : ndarray, shape (N,)
            Time of the run (s), increasing.
        Tc : float
            Controller period (s).

        Returns
        -------
        ndarray of int64
            Sorted, unique, starting with 0: the base's start samples (a time-varying base) and the first sample
            ``k`` with ``t[k] >= t_step`` (if one exists and ``k > 0``).
        """
        t = np.asarray(t, dtype=float)
        starts = set(np.asarray(self.base.row_starts(t, Tc)).tolist()) if hasattr(self.base, "at") else {0}
        k = int(np.searchsorted(t, self.t_step, side="left"))
        if 0 < k < t.shape[0]:
            starts.add(k)
        return np.array(sorted(starts | {0}), dtype=np.int64)

    def __getattr__(self, name):
        if name.startswith("__") or name in ("base", "t_step", "J_after"):
            raise AttributeError(name)
        if name == "J":  # the inertia at t = 0 (J_after where t_step == 0)
            return self.at(0.0).J
        return getattr(self.base, name)  # the base's (a drift's Fc_change; the friction of the plant at t = 0)

    def frictionless(self):
        """The same payload step on the base plant without friction."""
        return PayloadStep(self.base.frictionless(), t_step=self.t_step, J_after=self.J_after)

    def make_step(self, dt: float):
        """Integration step of the plant at ``t = 0`` (callers re-make it from :meth:`at` as time passes)."""
        return self.at(0.0).make_step(dt)

    def to_dict(self) -> dict:
        """The base plant's dict plus ``"payload": {"t_step", "J_after"}``.

        Raises
        ------
        ParameterError
            The base has a payload step itself (a plant file holds one).
        """
        d = self.base.to_dict()
        d = d if "model" in d else {"model": self.base.MODEL, **d}
        if "payload" in d:
            raise ParameterError("a plant file holds one payload step; this plant has two (PayloadStep(PayloadStep))")
        d["payload"] = {"t_step": self.t_step, "J_after": self.J_after}
        return d
