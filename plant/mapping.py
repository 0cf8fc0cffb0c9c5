"""The plant-model dataclasses' shared methods: strict construction from mappings (every plant model's
``from_dict``), the copy, the dict and the C step (:class:`PlantModel`), and the state of a lagged model
(:class:`LaggedPlantModel`)."""

from __future__ import annotations

import dataclasses
from typing import Callable

from plant.dynamics import make_plant_step
from plant.errors import ParameterError

__all__ = ["plant_from_mapping", "PlantModel", "LaggedPlantModel"]


def plant_from_mapping(cls, d: dict, *, hint: str = ""):
    """Build the plant dataclass ``cls`` from ``d``: exactly its fields, plus an optional ``"model"`` = ``cls.MODEL``.

    Parameters
    ----------
    cls : type
        A plant-model dataclass with a ``MODEL`` class attribute (e.g.
        :class:`plant.lugre.LuGreParams`).
    d : dict
        Parameters under the field names (SI units).
    hint : str, keyword-only
        Appended to the message of a wrong ``model`` (where such a plant is read instead); default none.

    Returns
    -------
    cls
        The validated model.

    Raises
    ------
    ParameterError
        Wrong ``model``, missing or unknown keys (all named), or a value out of range.
    """
    d = dict(d)
    model = d.pop("model", cls.MODEL)
    if model != cls.MODEL:
        raise ParameterError(f"model {model!r} is not {cls.MODEL!r}{hint}")
    names = [f.name for f in dataclasses.fields(cls)]
    missing = [k for k in names if k not in d]
    unknown = [k for k in d if k not in names]
    if missing:
        raise ParameterError(f"{cls.MODEL!r} plant parameters miss the key(s) {missing}; need {names}")
    if unknown:
        raise ParameterError(f"unknown {cls.MODEL!r} plant parameter key(s) {unknown}; allowed {names}")
    return cls(**d)


class PlantModel:
    """Base of a frozen plant-model dataclass with a class attribute ``MODEL`` (its name in plant files): the copy,
    the dict of its fields and back, and the C step every model shares."""

    MODEL: str = ""

    def make_step(self, dt: float) -> Callable[[float, float, float], tuple]:
        """One step ``(w, s, u) -> (w, s)`` over ``dt`` (s) with ``u`` held: the C :func:`plant.dynamics.plant_step`
        behind a Python call (the model's integrator: the class Notes).

        Raises
        ------
        ParameterError
            ``dt`` not > 0.
        """
        return make_plant_step(self, dt)

    def replace(self, **changes):
        """Copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict:
        """``{"model": MODEL, <field>: value, ...}`` (SI units): what :meth:`from_dict` reads."""
        return {"model": self.MODEL, **dataclasses.asdict(self)}

    @classmethod
    def from_dict(cls, d: dict):
        """Build from a mapping with the keys of :meth:`to_dict` (``model`` optional): :func:`plant_from_mapping`.

        Raises
        ------
        ParameterError
            Missing or unknown keys, wrong ``model``, or values out of range.
        """
        return plant_from_mapping(cls, d)


class LaggedPlantModel(PlantModel):
    """Base of a plant model whose friction state is the lagged friction torque ``s = f`` (``tau*df/dt + f = F(w)``)
    with the static map ``friction(w)``."""

    def friction_torque(self, w: float, s: float) -> float:
        """Friction torque (N·m) in state ``(w, s)``: the lag state ``s = f``."""
        return s

    def initial_state(self, w: float) -> float:
        """Friction state of steady motion at ``w`` (0 at rest), N·m."""
        return float(self.friction(float(w)))
