"""Lagged Stribeck joint with direction-dependent friction levels (asymmetric friction).

Real joints rarely show the same friction in both directions (gear
preload, seals, gravity-loaded bearings). Canudas de Wit, Åström and Braun
(1987) model it with separate Coulomb and viscous coefficients per
direction; here each direction has its own ``Fc``, ``Fs`` and ``sigma`` in the
Stribeck map of eq. 3, with the lag of eq. 1.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from plant.errors import check_nonnegative, check_positive
from plant.friction import JointParams, stribeck
from plant.mapping import LaggedPlantModel

__all__ = ["AsymmetricParams"]


@dataclass(frozen=True)
class AsymmetricParams(LaggedPlantModel):
    """Lumped joint with lagged, direction-dependent Stribeck friction.

    Parameters
    ----------
    J : float
        Inertia (kg·m²), > 0.
    Fc_pos, Fs_pos, sigma_pos : float
        Coulomb, static (N·m) and viscous (N·m·s/rad) friction for ``w > 0``, >= 0.
    Fc_neg, Fs_neg, sigma_neg : float
        The same for ``w < 0`` (magnitudes, >= 0).
    Vs, delta : float
        Stribeck velocity (rad/s) and shape factor (shared by both directions).
    tau : float
        Friction lag (s), >= 0.

    Raises
    ------
    ParameterError
        A value out of range (the message quotes it).

    Notes
    -----
    ``F(w) = Fc_pos + (Fs_pos - Fc_pos)*exp(-|w/Vs|**delta) + sigma_pos*w`` for
    ``w > 0``, ``-(Fc_neg + (Fs_neg - Fc_neg)*exp(-|w/Vs|**delta)) + sigma_neg*w``
    for ``w < 0``, ``F(0) = 0``; ``tau*df/dt + f = F(w)`` and ``J*dw/dt = u - f``
    (Ruderman eqs. 1-3 with the direction-dependent levels of Canudas de Wit,
    Åström, Braun, IEEE J. Robotics Automation 3(6), 1987).
    """

    MODEL: ClassVar[str] = "asymmetric"

    J: float
    Fc_pos: float
    Fc_neg: float
    Fs_pos: float
    Fs_neg: float
    Vs: float
    delta: float
    sigma_pos: float
    sigma_neg: float
    tau: float

    def __post_init__(self):
        for k in ("Fc_pos", "Fc_neg", "Fs_pos", "Fs_neg", "sigma_pos", "sigma_neg", "tau"):
            object.__setattr__(self, k, check_nonnegative(k, getattr(self, k)))
        JointParams(J=self.J, Fc=self.Fc_pos, Fs=self.Fs_pos, Vs=self.Vs, delta=self.delta, sigma=self.sigma_pos,
                    tau=self.tau)  # validates J, Vs, delta
        object.__setattr__(self, "J", check_positive("J", self.J))
        object.__setattr__(self, "Vs", float(self.Vs))
        object.__setattr__(self, "delta", float(self.delta))

    @property
    def Fc(self) -> float:
        """Mean Coulomb level of both directions (N·m)."""
        return 0.5 * (self.Fc_pos + self.Fc_neg)

    @property
    def Fs(self) -> float:
        """Mean static level of both directions (N·m)."""
        return 0.5 * (self.Fs_pos + self.Fs_neg)

    @property
    def sigma(self) -> float:
        """Mean viscous coefficient of both directions (N·m·s/rad)."""
        return 0.5 * (self.sigma_pos + self.sigma_neg)

    def friction(self, w):
        """Static direction-dependent map ``F(w)`` (N·m), see the class Notes: eq. 3 with each direction's levels."""
        w = np.asarray(w, dtype=float)
        pos = stribeck(w, Fc=self.Fc_pos, Fs=self.Fs_pos, Vs=self.Vs, delta=self.delta, sigma=self.sigma_pos)
        neg = stribeck(w, Fc=self.Fc_neg, Fs=self.Fs_neg, Vs=self.Vs, delta=self.delta, sigma=self.sigma_neg)
        out = np.where(w > 0, pos, neg)  # F(0) = 0 in both
        return float(out) if np.ndim(out) == 0 else out

    def frictionless(self) -> JointParams:
        """The same inertia without friction (the compensation limit)."""
        return JointParams(J=self.J, Fc=0.0, Fs=0.0, Vs=self.Vs, delta=self.delta, sigma=0.0, tau=0.0)
