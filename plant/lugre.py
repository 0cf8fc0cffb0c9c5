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
from dataclasses import asdict, dataclass, replace
from typing import Callable, ClassVar

import numpy as np

from plant._mapping import plant_from_mapping
from plant.errors import ParameterError, check_finite_scalar, check_nonnegative, check_positive
from plant.friction import JointParams, stribeck_shape

__all__ = ["LuGreParams"]


@dataclass(frozen=True)
class LuGreParams:
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
        object.__setattr__(self, "J", check_positive("J", self.J))
        object.__setattr__(self, "Fc", check_positive("Fc", self.Fc))
        object.__setattr__(self, "Fs", check_positive("Fs", self.Fs))
        object.__setattr__(self, "Vs", check_positive("Vs", self.Vs))
        delta = check_finite_scalar("delta", self.delta)
        if delta == 0.0:
            raise ParameterError("delta must be non-zero, got 0.0")
        object.__setattr__(self, "delta", delta)
        object.__setattr__(self, "sigma0", check_positive("sigma0", self.sigma0))
        object.__setattr__(self, "sigma1", check_nonnegative("sigma1", self.sigma1))
        object.__setattr__(self, "sigma2", check_nonnegative("sigma2", self.sigma2))

    @property
    def sigma(self) -> float:
        """Viscous coefficient of the steady-state map (``sigma2``), N·m·s/rad."""
        return self.sigma2

    def g(self, w):
        """Stribeck level ``g(w) = Fc + (Fs - Fc)*exp(-|w/Vs|**delta)`` (N·m), > 0."""
        return self.Fc + (self.Fs - self.Fc) * stribeck_shape(w, self.Vs, self.delta)

    def friction(self, w):
        """Steady-sliding friction (N·m): ``sgn(w)*g(w) + sigma2*w`` (eq. 3 with ``sigma = sigma2``)."""
        w = np.asarray(w, dtype=float)
        out = np.sign(w) * self.g(w) + self.sigma2 * w
        return float(out) if np.ndim(out) == 0 else out

    def friction_torque(self, w: float, z: float) -> float:
        """Friction torque (N·m) in state ``(w, z)``: ``sigma0*z + sigma1*dz/dt + sigma2*w``."""
        aw = abs(w)
        g = self.Fc + (self.Fs - self.Fc) * math.exp(-((aw / self.Vs) ** self.delta)) if aw > 0.0 else (
            self.Fs if self.delta > 0 else self.Fc)
        zdot = w - self.sigma0 * aw / g * z
        return self.sigma0 * z + self.sigma1 * zdot + self.sigma2 * w

    def initial_state(self, w: float) -> float:
        """Bristle deflection of steady motion at ``w``: ``sgn(w)*g(w)/sigma0`` (0 at rest), rad."""
        w = float(w)
        return math.copysign(float(self.g(w)), w) / self.sigma0 if w != 0.0 else 0.0

    def make_step(self, dt: float) -> Callable[[float, float, float], tuple]:
        """One integration step ``(w, z, u) -> (w, z)`` over ``dt`` (s) with ``u`` held.

        Classic RK4 on ``(w, z)`` with ``n`` equal sub-steps, ``n`` chosen at each
        call from the current stiffness ``sigma0*|w|/g(w) + (sigma1 + sigma2)/J +
        sqrt(sigma0/J)`` so that each sub-step stays well inside RK4's stability
        region (rate times sub-step <= 1; the region ends near 2.8).

        Raises
        ------
        ParameterError
            ``dt`` not > 0.
        """
        dt = check_positive("dt", dt)
        J, Fc, dF, Vs, delta = self.J, self.Fc, self.Fs - self.Fc, self.Vs, self.delta
        s0, s1, s2 = self.sigma0, self.sigma1, self.sigma2
        g_min, g_max = min(self.Fc, self.Fs), max(self.Fc, self.Fs)
        base_rate = (s1 + s2) / J + math.sqrt(s0 / J)
        exp = math.exp

        def rhs(w, z, u):
            aw = w if w >= 0.0 else -w
            gw = Fc + dF * exp(-((aw / Vs) ** delta)) if aw > 0.0 else (Fc + dF if delta > 0 else Fc)
            zdot = w - s0 * aw / gw * z
            return (u - s0 * z - s1 * zdot - s2 * w) / J, zdot

        def step(w: float, z: float, u: float) -> tuple:
            aw = w if w >= 0.0 else -w
            # bound |w| over the step by its start value plus the largest acceleration
            rate = s0 * (aw + (abs(u) + g_max + s2 * aw) * dt / J) / g_min + base_rate
            n = int(rate * dt) + 1
            h = dt / n
            h2, h6 = 0.5 * h, h / 6.0
            for _ in range(n):
                k1w, k1z = rhs(w, z, u)
                k2w, k2z = rhs(w + h2 * k1w, z + h2 * k1z, u)
                k3w, k3z = rhs(w + h2 * k2w, z + h2 * k2z, u)
                k4w, k4z = rhs(w + h * k3w, z + h * k3z, u)
                w = w + h6 * (k1w + 2.0 * k2w + 2.0 * k3w + k4w)
                z = z + h6 * (k1z + 2.0 * k2z + 2.0 * k3z + k4z)
            return w, z

        return step

    def frictionless(self) -> JointParams:
        """The same inertia without friction (the compensation limit)."""
        return JointParams(J=self.J, Fc=0.0, Fs=0.0, Vs=self.Vs, delta=1.0, sigma=0.0, tau=0.0)

    def replace(self, **changes) -> "LuGreParams":
        """Copy with some fields changed (validated again)."""
        return replace(self, **changes)

    def to_dict(self) -> dict:
        """``{"model": "lugre", J, Fc, Fs, Vs, delta, sigma0, sigma1, sigma2}`` (SI units)."""
        return {"model": self.MODEL, **asdict(self)}

    @classmethod
    def from_dict(cls, d: dict) -> "LuGreParams":
        """Build from a mapping with the keys of :meth:`to_dict` (``model`` optional).

        Raises
        ------
        ParameterError
            Missing or unknown keys, wrong ``model``, or values out of range.
        """
        return plant_from_mapping(cls, d)
