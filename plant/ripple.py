"""Position-dependent friction ripple: the friction of harmonic drives and gearboxes varying along the revolution.

A harmonic drive's or a gearbox's friction is not a function of the velocity alone: it varies with the
position of the wave generator or the tooth mesh, periodically along the joint's revolution (the
position-dependent torque of harmonic drives: Tuttle & Seering, "A nonlinear model of a harmonic drive gear
transmission", IEEE Trans. Robot. Autom. 12(3), 1996; Taghirad & Bélanger, "Modeling and parameter
identification of harmonic drive systems", J. Dyn. Sys. Meas. Control 120, 1998). The simplest such model, one
harmonic of the position, is the one here: :class:`FrictionRipple` multiplies a plant's friction map by

    R(q) = 1 + a*sin(n*q + phase)

with ``q`` the joint position (rad), a state the plant integrates with the same steps as the velocity
(``dq/dt = w``, ``q = 0`` at the start of a run).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from plant.errors import ParameterError, check_finite_scalar

__all__ = ["FrictionRipple"]


@dataclass(frozen=True)
class FrictionRipple:
    """A plant whose friction map is multiplied by ``1 + amplitude*sin(harmonic*q + phase)``, ``q`` its position.

    Parameters
    ----------
    base : plant model, FrictionDrift or PayloadStep
        The plant without ripple: any model of :mod:`plant.models` (lagged Stribeck, asymmetric, Karnopp,
        LuGre), or a time-varying plant around one (:class:`plant.drift.FrictionDrift`,
        :class:`plant.payload.PayloadStep`), whose every frozen state gets the ripple.
    amplitude : float
        ``a``, the ripple's relative amplitude (dimensionless), ``0 <= a < 1`` (the friction keeps its sign).
        0: the plant itself, bit for bit.
    harmonic : float
        ``n``, ripple periods per joint revolution (> 0; not necessarily an integer). A harmonic drive of gear
        ratio ``N`` on the joint side: ``2*N`` (two per revolution of the wave generator).
    phase : float
        Phase (rad) of the ripple at ``q = 0``; default 0.

    Raises
    ------
    ParameterError
        ``amplitude`` not in [0, 1), ``harmonic`` not > 0, a value not finite (NaN, inf), or ``base`` a
        FrictionRipple itself (one ripple per plant) or not a plant model; the key and value named.
    TypeError
        A value not a real number (a string, a bool).

    Notes
    -----
    Physics, per model (C ``plant/csrc/plant_params.h``, ``plant_target_at``):

    * lagged models (lagged Stribeck, asymmetric, Karnopp; Ruderman, eqs. 1-3): the target of the lag is
      ``F(w)*R(q)``, ``tau*df/dt + f = F(w)*R(q)`` (``f = F(w)*R(q)`` for ``tau = 0``), the Karnopp stick limit
      ``Fs*R(q)`` too: the whole sliding friction, Coulomb, Stribeck and viscous parts, scales with the
      position-dependent load of the teeth;
    * LuGre (Canudas de Wit et al. 1995): the Stribeck level ``g(w)`` and the viscous term ``sigma2*w`` are
      scaled by ``R(q)``, so the steady sliding friction is ``(g(w)*sgn(w) + sigma2*w)*R(q)``, the lagged models'
      ``F(w)*R(q)``; the bristles' stiffness ``sigma0`` and damping ``sigma1`` (the contact's elasticity, the
      pre-sliding) are not position dependent.

    A wrapper rather than fields of every model: the ripple is a property of the transmission, not of the
    friction law, and it composes the same way with all four models and with the time-varying plants (the
    models, their fields and everything that reads them stay as they are). Attribute access not defined here
    (``J``, ``Vs``, ``tau``, ``friction``, ...) is delegated to ``base`` (for a time-varying base: its plant at
    ``t = 0``, as :class:`plant.drift.FrictionDrift`); ``friction(w)`` there is the map without the ripple (its
    mean over a revolution). The plant file (:mod:`plant.models`) carries it as
    ``"ripple": {"amplitude": a, "harmonic": n, "phase": phase}``. The design inertia a compensator gets
    (``J_design``) is by default the plant's ``J`` at ``t = 0`` in a single run (``compare`` identifies it on the plant
    at ``t = 0``); nothing of the ripple reaches a compensator.

    The open-loop :func:`plant.joint.simulate` and the closed-loop engine
    (:func:`controllers.simulation.closed_loop.run_closed_loop`, ``run_mode``, ``run_own``, ``run_batch``,
    ``compare``) run it; ``make_step`` (a step without the position state) refuses it.
    """

    base: Any
    amplitude: float
    harmonic: float
    phase: float = 0.0

    def __post_init__(self):
        a = check_finite_scalar("amplitude", self.amplitude)
        if not 0.0 <= a < 1.0:
            raise ParameterError(f"amplitude must be in [0, 1) (the friction keeps its sign), got {self.amplitude!r}")
        n = check_finite_scalar("harmonic", self.harmonic)
        if not n > 0.0:
            raise ParameterError(f"harmonic must be > 0 (ripple periods per revolution), got {self.harmonic!r}")
        phase = check_finite_scalar("phase", self.phase)
        if isinstance(self.base, FrictionRipple):
            raise ParameterError("base is a FrictionRipple already: one ripple per plant")
        if not hasattr(self.base, "MODEL"):
            raise ParameterError(f"base must be a plant model (plant.models), a FrictionDrift or a PayloadStep, got "
                                 f"{type(self.base).__name__}")
        object.__setattr__(self, "amplitude", a)
        object.__setattr__(self, "harmonic", n)
        object.__setattr__(self, "phase", phase)

    MODEL = property(lambda self: self.base.MODEL)

    @property
    def ripple_fields(self) -> tuple:
        """``(amplitude, harmonic, phase)``: the fields ``ripple_a``, ``ripple_n``, ``ripple_phase`` of the C
        ``plant_params`` (:func:`plant.rows.plant_params`)."""
        return self.amplitude, self.harmonic, self.phase

    def ripple(self, q):
        """The factor ``R(q) = 1 + amplitude*sin(harmonic*q + phase)`` at the position ``q`` (rad; array or float)."""
        return 1.0 + self.amplitude * np.sin(self.harmonic * np.asarray(q, dtype=float) + self.phase)

    def __getattr__(self, name):
        if name.startswith("__") or name in ("base", "amplitude", "harmonic", "phase"):
            raise AttributeError(name)
        if name in ("at", "row_starts") and not hasattr(self.base, "at"):
            raise AttributeError(name)  # a static ripple is a frozen plant: no time dependence
        if name == "at":
            return lambda t: replace(self, base=self.base.at(t))
        return getattr(self.base, name)  # a time-varying base delegates on to its plant at t = 0

    def replace(self, **changes):
        """The ripple around ``base.replace(**changes)`` (e.g. ``J``: :class:`plant.payload.PayloadStep`; ``Fc``,
        ``Fs``: :class:`plant.drift.FrictionDrift`)."""
        return replace(self, base=self.base.replace(**changes))

    def frictionless(self):
        """The base plant without friction (the ripple of zero friction is zero)."""
        return self.base.frictionless()

    def make_step(self, dt: float):
        """Refused: a step ``(w, s, u) -> (w, s)`` has no position state.

        Raises
        ------
        ParameterError
            Always; use :func:`plant.joint.simulate` (open loop) or the closed-loop engine.
        """
        raise ParameterError("a FrictionRipple plant needs its position state: use plant.joint.simulate or the "
                             "closed-loop engine (run_closed_loop, run_mode, run_batch), not make_step")

    def to_dict(self) -> dict:
        """The base plant's dict plus ``"ripple": {"amplitude", "harmonic", "phase"}``."""
        d = self.base.to_dict()
        d = d if "model" in d else {"model": self.base.MODEL, **d}
        d["ripple"] = {"amplitude": self.amplitude, "harmonic": self.harmonic, "phase": self.phase}
        return d
