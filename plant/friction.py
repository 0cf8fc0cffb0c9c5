"""The joint's physical parameters (eqs. 1-3); the Stribeck map of eq. 3 is re-exported from :mod:`plant.stribeck_map`.

Symbols (SI units, joint side; for a prismatic axis read N for N·m and m for rad):

==========  ==============  ================================================
symbol      unit            meaning
==========  ==============  ================================================
``J``       kg·m²           lumped inertia
``Fc``      N·m             Coulomb friction level
``Fs``      N·m             static (stiction / adhesion) friction level
``Vs``      rad/s           Stribeck velocity
``delta``   1               Stribeck shape factor (positive or negative, not 0)
``sigma``   N·m·s/rad       viscous friction coefficient
``tau``     s               friction lag time constant (eq. 1), 0 = static map
==========  ==============  ================================================
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Callable, ClassVar

from plant.dynamics import make_plant_step
from plant.errors import ParameterError, check_finite_scalar, check_nonnegative, check_positive
from plant.mapping import plant_from_mapping
from plant.stribeck_map import stribeck, stribeck_cutoff, stribeck_scalar, stribeck_shape

__all__ = ["JointParams", "stribeck_shape", "stribeck", "stribeck_scalar", "stribeck_cutoff", "PRESETS", "preset"]


@dataclass(frozen=True)
class JointParams:
    """Physical parameters of the lumped-mass joint with lagged Stribeck friction.

    Parameters
    ----------
    J : float
        Inertia (kg·m²), > 0.
    Fc : float
        Coulomb friction (N·m), >= 0.
    Fs : float
        Static friction (N·m), >= 0.
    Vs : float
        Stribeck velocity (rad/s), > 0.
    delta : float
        Stribeck shape factor (1), finite and non-zero.
    sigma : float
        Viscous coefficient (N·m·s/rad), >= 0.
    tau : float
        Friction lag (s), >= 0; ``tau = 0`` makes friction the static map, which is set-valued at ``w = 0``
        (the joint sticks while ``|u|`` is below the map's level at standstill, see :func:`plant.dynamics.plant_step`).

    Raises
    ------
    ParameterError
        A value is out of range; the message quotes it.
    TypeError
        A value is not a real number.

    Notes
    -----
    Model (Ruderman, eqs. 1-3)::

        J*dw/dt = u - f
        tau*df/dt + f = F(w)
        F(w) = sgn(w)*(Fc + (Fs - Fc)*exp(-|w/Vs|**delta)) + sigma*w

    Plant protocol (shared with the variants in :mod:`plant.lugre`,
    :mod:`plant.karnopp`, :mod:`plant.asymmetric`, :mod:`plant.drift`): ``J``,
    ``friction(w)`` (steady-state map), ``make_step(dt)`` (one integration step
    ``(w, s, u) -> (w, s)`` of velocity and the model's internal state ``s``,
    here the friction torque ``f``), ``friction_torque(w, s)``,
    ``initial_state(w)``, ``frictionless()`` and ``MODEL`` (the ``"model"`` key
    of the plant JSON, see :func:`plant.models.plant_from_dict`).
    """

    #: Name of this friction model in plant JSON files (``"model"`` key).
    MODEL: ClassVar[str] = "lagged-stribeck"

    J: float
    Fc: float
    Fs: float
    Vs: float
    delta: float
    sigma: float
    tau: float

    def __post_init__(self):
        object.__setattr__(self, "J", check_positive("J", self.J))
        object.__setattr__(self, "Fc", check_nonnegative("Fc", self.Fc))
        object.__setattr__(self, "Fs", check_nonnegative("Fs", self.Fs))
        object.__setattr__(self, "Vs", check_positive("Vs", self.Vs))
        delta = check_finite_scalar("delta", self.delta)
        if delta == 0.0:
            raise ParameterError("delta must be non-zero (|w/Vs|**0 is constant), got 0.0")
        object.__setattr__(self, "delta", delta)
        object.__setattr__(self, "sigma", check_nonnegative("sigma", self.sigma))
        object.__setattr__(self, "tau", check_nonnegative("tau", self.tau))

    def friction(self, w):
        """Static friction ``F(w)`` (N·m) of these parameters, eq. 3; see :func:`stribeck`."""
        return stribeck(w, Fc=self.Fc, Fs=self.Fs, Vs=self.Vs, delta=self.delta, sigma=self.sigma)

    def make_step(self, dt: float) -> Callable[[float, float, float], tuple]:
        """One RK4 step ``(w, f, u) -> (w, f)`` of this joint over ``dt`` (s), ``u`` held (eqs. 1-3).

        The C :func:`plant.dynamics.plant_step` behind a Python call; for
        ``tau == 0`` the returned ``f`` is ``F(w)`` at the new velocity.

        Raises
        ------
        ParameterError
            ``dt`` not > 0.
        """
        return make_plant_step(self, dt)

    def friction_torque(self, w: float, s: float) -> float:
        """Friction torque (N·m) in state ``(w, s)``: the lag state ``s = f`` itself (eq. 1)."""
        return s

    def initial_state(self, w: float) -> float:
        """Internal state of steady motion at velocity ``w``: ``f = F(w)`` (0 at rest)."""
        return float(self.friction(float(w)))

    def frictionless(self) -> "JointParams":
        """The same joint with ``Fc = Fs = sigma = 0`` (the compensation limit)."""
        return replace(self, Fc=0.0, Fs=0.0, sigma=0.0)

    def replace(self, **changes) -> "JointParams":
        """Return a copy with some fields changed (validated again)."""
        return replace(self, **changes)

    def to_dict(self) -> dict:
        """Parameters as a plain ``dict`` (SI units)."""
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "JointParams":
        """Build from a mapping with exactly the keys ``J, Fc, Fs, Vs, delta, sigma, tau``.

        An optional ``"model": "lagged-stribeck"`` entry is accepted (other
        models: :func:`plant.models.plant_from_dict`).

        Raises
        ------
        ParameterError
            A key is missing or unknown, a value out of range, or ``model``
            names another friction model.
        """
        return plant_from_mapping(cls, d, hint="; read such plants with plant.models.plant_from_dict / load_plant")

    @classmethod
    def from_json(cls, path) -> "JointParams":
        """Read parameters (SI units) from a JSON object file, see :meth:`from_dict`.

        Raises
        ------
        ParameterError
            The file is not a JSON object, or keys/values are invalid.
        FileNotFoundError
            The file does not exist.
        """
        path = Path(path)
        try:
            d = json.loads(path.read_text())
        except json.JSONDecodeError as exc:
            raise ParameterError(f"{path}: not valid JSON ({exc})") from None
        if not isinstance(d, dict):
            raise ParameterError(f"{path}: expected a JSON object with plant parameters")
        try:
            return cls.from_dict(d)
        except ParameterError as exc:
            raise ParameterError(f"{path}: {exc}") from None


#: Named parameter sets. ``paper``: the base joint of a medium industrial robot
#: (about 10 kg payload, 1.5 m reach, arm in the vertical configuration of the
#: paper's Sec. V-A), joint side. J = 4 kg·m²: about 2.5 kg·m² of arm about the
#: vertical axis plus the reflected motor inertia (1e-4 kg·m² times a gear ratio of
#: about 120 squared). Fc = 25 N·m is 5-8 % of the rated torque of such a joint,
#: typical of a large reduction gear; Fs = 35 N·m (stiction 40 % above Coulomb);
#: Vs = 0.02 rad/s (about 1.1 deg/s, the low end of the paper's 1-20 deg/s range);
#: delta = 1; sigma = 40 N·m·s/rad adds 14 N·m at 20 deg/s; tau = 20 ms, of the
#: order of the paper's sampling time, which is what makes the lag matter.
PRESETS: dict[str, JointParams] = {
    "paper": JointParams(J=4.0, Fc=25.0, Fs=35.0, Vs=0.02, delta=1.0, sigma=40.0, tau=0.02),
}


def preset(name: str) -> JointParams:
    """Return the named parameter set from :data:`PRESETS`.

    Raises
    ------
    ParameterError
        Unknown name (the known names are listed).
    """
    try:
        return PRESETS[name]
    except KeyError:
        raise ParameterError(f"unknown preset {name!r}; known: {sorted(PRESETS)}") from None


