"""Strict construction of the plant-model dataclasses from mappings (used by every plant model's ``from_dict``)."""

from __future__ import annotations

from dataclasses import fields

from plant.errors import ParameterError

__all__ = ["plant_from_mapping"]


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
    names = [f.name for f in fields(cls)]
    missing = [k for k in names if k not in d]
    unknown = [k for k in d if k not in names]
    if missing:
        raise ParameterError(f"{cls.MODEL!r} plant parameters miss the key(s) {missing}; need {names}")
    if unknown:
        raise ParameterError(f"unknown {cls.MODEL!r} plant parameter key(s) {unknown}; allowed {names}")
    return cls(**d)
