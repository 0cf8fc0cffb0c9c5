"""LuGre dynamic friction with pre-sliding (Canudas de Wit, Olsson, Åström, Lischinsky 1995) on the lumped joint.

A plant variant for robustness studies: the adaptive feedforward assumes the
paper's lagged Stribeck model (eqs. 1-3); LuGre adds pre-sliding (elastic
bristle deflection ``z`` before gross sliding) and its own frictional lag.

Symbols (SI units, joint side): ``J, Fc, Fs, Vs, delta`` as in
:mod:`plant.friction`; ``sigma0`` (N·m/rad) bristle stiffness, ``sigma1``
(N·m·s/rad) bristle damping, ``sigma2`` (N·m·s/rad) viscous coefficient.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Callable, ClassVar

import numpy as np

from plant._cplant import ffi
from plant.dynamics import make_plant_step, plant_friction, plant_params
from plant.errors import ParameterError, check_finite_scalar
from plant.friction import JointParams, stribeck
from plant.mapping import PlantModel

__all__ = ["LuGreParams"]


#: Unit and physical meaning of each LuGre parameter, for the messages of :func:`_physical`.
_MEANING = {"J": ("kg·m²", "the joint inertia"), "Fc": ("N·m", "the Coulomb friction level"),
            "Fs": ("N·m", "the static friction level"), "Vs": ("rad/s", "the Stribeck velocity"),
            "sigma0": ("N·m/rad", "the bristle stiffness"), "sigma1": ("N·m·s/rad", "the bristle damping"),
            "sigma2": ("N·m·s/rad", "the viscous friction coefficient")}


def _physical(name: str, value, positive: bool) -> float:
    """``value`` as a float, or a :class:`ParameterError` in physical words: the parameter, its value, unit and meaning.

    ``positive``: the value must be > 0 (else >= 0: a damping or viscous coefficient may vanish, a negative one
    would feed energy into the joint). The messages start as :func:`plant.errors.check_positive`'s
    (``"sigma0 must be > 0, got 0.0"``).
    """
    unit, meaning = _MEANING[name]
    try:
        v = check_finite_scalar(name, value)
    except ParameterError:
        raise ParameterError(f"{name} must be finite, got {float(value)!r} {unit} ({meaning} of a LuGre "
                             "joint)") from None
    if positive and v <= 0.0:
        raise ParameterError(f"{name} must be > 0, got {v!r} {unit}: {meaning} of a LuGre joint is positive")
    if not positive and v < 0.0:
        raise ParameterError(f"{name} must be >= 0, got {v!r} {unit}: {meaning} of a LuGre joint cannot be "
                             "negative (it would feed energy into the joint)")
    return v


@dataclass(frozen=True)
class LuGreParams(PlantModel):
    """Lumped joint with LuGre friction.

    Parameters
    ----------
    J : float
        Inertia (kg·m²), > 0.
    Fc, Fs : float
        Coulomb and static friction levels (N·m), both > 0 (``g(w) > 0``).
    Vs : float
        Stribeck velocity (rad/s), > 0.
    delta : float
        Stribeck shape factor, non-zero (the original LuGre paper uses 2).
    sigma0 : float
        Bristle stiffness (N·m/rad), > 0.
    sigma1 : float
        Bristle (micro-)damping (N·m·s/rad), >= 0.
    sigma2 : float
        Viscous friction coefficient (N·m·s/rad), >= 0.

    Raises
    ------
    ParameterError
        A value out of range (the message quotes it).
    TypeError
        A value is not a real number.

    Notes
    -----
    Canudas de Wit, Olsson, Åström, Lischinsky, "A new model for control of
    systems with friction", IEEE TAC 40(3), 1995, eqs. 2-5::

        dz/dt = w - sigma0*|w|/g(w) * z
        g(w)  = Fc + (Fs - Fc)*exp(-|w/Vs|**delta)
        f     = sigma0*z + sigma1*dz/dt + sigma2*w
        J*dw/dt = u - f

    In steady sliding ``z = sgn(w) g(w)/sigma0`` and ``f`` is the Stribeck
    map of eq. 3 with ``sigma = sigma2`` (:meth:`friction`).
    """

    MODEL: ClassVar[str] = "lugre"

    J: float
    Fc: float
    Fs: float
    Vs: float
    delta: float
    sigma0: float
    sigma1: float
    sigma2: float

    def __post_init__(self):
        for name, positive in (("J", True), ("Fc", True), ("Fs", True), ("Vs", True), ("sigma0", True),
                               ("sigma1", False), ("sigma2", False)):
            object.__setattr__(self, name, _physical(name, getattr(self, name), positive))
        delta = check_finite_scalar("delta", self.delta)
        if delta == 0.0:
            raise ParameterError("delta must be non-zero, got 0.0 (the Stribeck shape factor: g(w) would not "
                                 "depend on the speed)")
        object.__setattr__(self, "delta", delta)

    @property
    def sigma(self) -> float:
        """Viscous coefficient of the steady-state map (``sigma2``), N·m·s/rad."""
        return self.sigma2

    def g(self, w):
        """Stribeck level ``g(w) = Fc + (Fs - Fc)*exp(-|w/Vs|**delta)`` (N·m), > 0; its limit at ``w = 0``.

        ``g(w)`` is eq. 3 at ``|w|`` with ``sigma = 0`` (:func:`plant.stribeck_map.stribeck`).
        """
        aw = np.abs(np.asarray(w, dtype=float))
        lim = self.Fs if self.delta > 0 else self.Fc
        out = np.where(aw > 0, stribeck(aw, Fc=self.Fc, Fs=self.Fs, Vs=self.Vs, delta=self.delta, sigma=0.0), lim)
        return float(out) if np.ndim(out) == 0 else out

    def friction(self, w):
        """Steady-sliding friction (N·m): ``sgn(w)*g(w) + sigma2*w`` (eq. 3 with ``sigma = sigma2``)."""
        return stribeck(w, Fc=self.Fc, Fs=self.Fs, Vs=self.Vs, delta=self.delta, sigma=self.sigma2)

    def friction_torque(self, w: float, z: float) -> float:
        """Friction torque (N·m) in state ``(w, z)``: ``sigma0*z + sigma1*dz/dt + sigma2*w``.

        C (:func:`plant.dynamics.plant_friction`).
        """
        return plant_friction(self._packed, ffi.new("plant_state *", (float(w), float(z), math.nan)))

    def initial_state(self, w: float) -> float:
        """Bristle deflection of steady motion at ``w``: ``sgn(w)*g(w)/sigma0`` (0 at rest), rad."""
        w = float(w)
        return math.copysign(float(self.g(w)), w) / self.sigma0 if w != 0.0 else 0.0

    def make_step(self, dt: float) -> Callable[[float, float, float], tuple]:
        """One integration step ``(w, z, u) -> (w, z)`` over ``dt`` (s) with ``u`` held.

        Classic RK4 on ``(w, z)`` with ``n`` equal sub-steps, ``n`` chosen at each
        call from the current stiffness ``rate = sigma0*|w|/g(w) + (sigma1 + sigma2)/J +
        sqrt(sigma0/J)`` (``|w|`` bounded over the step) so that ``rate*h <= 1``. ``rate``
        bounds the eigenvalues ``l`` of the bristle-mass system linearised at ``(w, z)``
        (``J*l**2 + (d*sigma1 + sigma2 + J*a)*l + d*sigma0 + a*sigma2 = 0`` with
        ``a = sigma0*|w|/g(w)`` and ``d = d(dz/dt)/dw = 1 - z*da/dw``; at rest ``a = 0``,
        ``d = 1``: the damped pre-sliding oscillator, critically damped at
        ``sigma1 + sigma2 = 2*sqrt(sigma0*J)``), the bristle damping ``sigma1`` included,
        so every sub-step stays inside RK4's stability interval (``|l|*h <= 2.78`` on the
        negative real axis; Hairer & Wanner, *Solving ODEs II*, Sec. IV.2) with a margin
        for the transients where the deflection is off its steady value. Beyond
        :data:`plant.dynamics.LUGRE_RK4_MAX` sub-steps (a stiff bristle, or a damping
        ``sigma1/J`` far above ``1/dt``) the error-controlled implicit
        :func:`plant.dynamics.lugre_stiff_step` (extrapolated backward Euler, Newton on
        the Jacobian) takes the step, so any ``sigma0 > 0`` and ``sigma1, sigma2 >= 0``
        simulate at a 1 ms step (up to the pre-sliding frequency of
        :func:`plant.rows.check_integrable`). Where RK4 was chosen its results are bit for
        bit those of before this note (tests/controllers_layer/test_golden.py). The C
        :func:`plant.dynamics.plant_step` behind a Python call.

        Raises
        ------
        ParameterError
            ``dt`` not > 0.
        """
        return make_plant_step(self, dt)

    @cached_property
    def _packed(self):
        """The C struct of :func:`plant.dynamics.plant_params` (cached; not pickled, see ``__getstate__``)."""
        return plant_params(self)

    def __getstate__(self) -> dict:
        """The fields without the cached C struct (cffi objects do not pickle; it is rebuilt on use)."""
        return {k: v for k, v in self.__dict__.items() if k != "_packed"}

    def frictionless(self) -> JointParams:
        """The same inertia without friction (the compensation limit)."""
        return JointParams(J=self.J, Fc=0.0, Fs=0.0, Vs=self.Vs, delta=1.0, sigma=0.0, tau=0.0)
