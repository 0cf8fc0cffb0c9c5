"""Friction drift during operation: Coulomb and static friction changing with time (warming, load, wear).

The reason to adapt online (paper Sec. II-A: friction depends on temperature,
load, dwell time and wear). :class:`FrictionDrift` wraps any plant model with
fields ``Fc`` and ``Fs`` and ramps them linearly by a relative amount over a
time window; :meth:`FrictionDrift.at` returns the frozen plant at time ``t``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from plant.errors import ParameterError, check_finite_scalar, check_nonnegative, check_positive

__all__ = ["FrictionDrift"]

_FC_FIELDS = ("Fc", "Fc_pos", "Fc_neg")
_FS_FIELDS = ("Fs", "Fs_pos", "Fs_neg")


@dataclass(frozen=True)
class FrictionDrift:
    """A plant whose ``Fc`` and ``Fs`` ramp linearly from ``t_start`` to ``t_end`` and then stay.

    Parameters
    ----------
    base : plant model
        The plant at ``t <= t_start`` (any model of :mod:`plant.models`): its
        Coulomb fields (``Fc``, or ``Fc_pos``/``Fc_neg``) scale with
        ``Fc_change``, its static fields (``Fs``, or ``Fs_pos``/``Fs_neg``)
        with ``Fs_change``.
    Fc_change, Fs_change : float
        Relative change reached at ``t_end`` (0.5 = +50 %), > -1.
    t_start, t_end : float
        Ramp window (s), ``0 <= t_start < t_end``.
    period : float
        The runner re-freezes the plant every ``period`` seconds (s), > 0;
        default 10 ms (the ramp is then a staircase of tiny steps).

    Raises
    ------
    ParameterError
        Values out of range, ``base`` without Coulomb/static friction fields, or ``base`` time-varying itself
        (wrap the drift instead: ``PayloadStep(FrictionDrift(...))``, ``FrictionRipple(FrictionDrift(...))``).

    Notes
    -----
    ``Fc(t) = Fc0*(1 + Fc_change*r(t))``, ``Fs(t) = Fs0*(1 + Fs_change*r(t))``
    with ``r(t) = clip((t - t_start)/(t_end - t_start), 0, 1)``. Everything else
    of the plant (J, the lag, the pre-sliding, ...) is unchanged. Attribute
    access not defined here (``J``, ``Vs``, ``friction``, ``make_step``, ...)
    is delegated to the plant at ``t = 0``.
    """

    base: Any
    Fc_change: float = 0.5
    Fs_change: float = 0.5
    t_start: float = 0.0
    t_end: float = 60.0
    period: float = 0.01

    def __post_init__(self):
        for k in ("Fc_change", "Fs_change"):
            v = check_finite_scalar(k, getattr(self, k))
            if v <= -1.0:
                raise ParameterError(f"{k} must be > -1 (friction stays >= 0), got {v!r}")
            object.__setattr__(self, k, v)
        object.__setattr__(self, "t_start", check_nonnegative("t_start", self.t_start))
        object.__setattr__(self, "t_end", check_positive("t_end", self.t_end))
        if not self.t_end > self.t_start:
            raise ParameterError(f"t_end must be > t_start = {self.t_start!r}, got {self.t_end!r}")
        object.__setattr__(self, "period", check_positive("period", self.period))
        if hasattr(self.base, "at"):
            raise ParameterError(f"the base of a FrictionDrift must not vary with time itself, got "
                                 f"{type(self.base).__name__}: wrap the drift instead "
                                 f"(PayloadStep(FrictionDrift(...)))")
        model = self.base
        while hasattr(model, "ripple_fields"):  # a FrictionRipple: the fields of the model it wraps
            model = model.base
        names = getattr(model, "__dataclass_fields__", {})
        fc = [k for k in _FC_FIELDS if k in names]
        fs = [k for k in _FS_FIELDS if k in names]
        if not (fc and fs and hasattr(self.base, "replace")):
            raise ParameterError(f"drift needs a plant model with Coulomb and static friction fields "
                                 f"({_FC_FIELDS}, {_FS_FIELDS}), got {type(self.base).__name__}")
        object.__setattr__(self, "_fields", (tuple(fc), tuple(fs)))

    MODEL = property(lambda self: self.base.MODEL)

    def ramp(self, t: float) -> float:
        """Ramp fraction ``r(t)`` in [0, 1]."""
        return min(max((t - self.t_start) / (self.t_end - self.t_start), 0.0), 1.0)

    def at(self, t: float):
        """The frozen plant at time ``t`` (s), same type as ``base``."""
        r = self.ramp(float(t))
        if r == 0.0:
            return self.base
        fc, fs = self._fields
        changes = {k: getattr(self.base, k) * (1.0 + self.Fc_change * r) for k in fc}
        changes.update({k: getattr(self.base, k) * (1.0 + self.Fs_change * r) for k in fs})
        return self.base.replace(**changes)

    def row_starts(self, t, Tc: float) -> np.ndarray:
        """Samples of a run where the engine re-freezes the plant
        (:func:`controllers.simulation.closed_loop.plant_table`).

        Parameters
        ----------
        t : ndarray, shape (N,)
            Time of the run (s).
        Tc : float
            Controller period (s).

        Returns
        -------
        ndarray of int64
            ``0, seg, 2*seg, ...`` below ``N``, ``seg = max(round(period/Tc), 1)``; ``[0]`` at least.
        """
        seg = max(int(round(self.period / Tc)), 1)
        return np.arange(0, max(len(t), 1), seg, dtype=np.int64)

    def make_step(self, dt: float) -> Callable[[float, float, float], tuple]:
        """Integration step of the plant at ``t = 0`` (callers re-make it from :meth:`at` as time passes)."""
        return self.base.make_step(dt)

    def __getattr__(self, name):
        if name.startswith("__") or name in ("base", "_fields"):
            raise AttributeError(name)
        return getattr(self.base, name)

    def to_dict(self) -> dict:
        """The base plant's dict plus ``"drift": {Fc_change, Fs_change, t_start, t_end, period}``."""
        d = self.base.to_dict()
        d = d if "model" in d else {"model": self.base.MODEL, **d}
        d["drift"] = {"Fc_change": self.Fc_change, "Fs_change": self.Fs_change, "t_start": self.t_start,
                      "t_end": self.t_end, "period": self.period}
        return d
