"""Friction-model registry: plant JSON files with a ``"model"`` key, and the plant protocol they share.

A plant file is a JSON object with the parameters under their standard
symbols (SI units, joint side) and an optional ``"model"`` key:

==================  =====================================================  =============================
``"model"``         keys                                                   class
==================  =====================================================  =============================
lagged-stribeck     ``J, Fc, Fs, Vs, delta, sigma, tau`` (the default)     :class:`~plant.JointParams`
lugre               ``J, Fc, Fs, Vs, delta, sigma0, sigma1, sigma2``       :class:`~plant.lugre.LuGreParams`
karnopp             ``J, Fc, Fs, Vs, delta, sigma, tau, dv``               :class:`~plant.karnopp.KarnoppParams`
asymmetric          ``J, Fc_pos, Fc_neg, Fs_pos, Fs_neg, Vs, delta,``      :class:`~plant.asymmetric.AsymmetricParams`
                    ``sigma_pos, sigma_neg, tau``
==================  =====================================================  =============================

Any of them may carry ``"drift": {"Fc_change": 0.5, "Fs_change": 0.5, "t_start": 0, "t_end": 60}``
(:class:`plant.drift.FrictionDrift`, all keys optional).

Every plant class provides ``J``, ``Vs``, ``delta``, ``friction(w)`` (steady
sliding map), ``make_step(dt)`` (one integration step ``(w, s, u) -> (w, s)``
with the model's internal state ``s``), ``friction_torque(w, s)``,
``initial_state(w)``, ``frictionless()``, ``to_dict()`` and ``MODEL``. The
compiled step behind all of them is :func:`plant.dynamics.plant_step` on the
parameter row :func:`plant.dynamics.plant_params` packs for any of these classes.
"""

from __future__ import annotations

import json
from pathlib import Path

from plant.asymmetric import AsymmetricParams
from plant.drift import FrictionDrift
from plant.errors import ParameterError
from plant.friction import JointParams
from plant.karnopp import KarnoppParams
from plant.lugre import LuGreParams

__all__ = ["MODELS", "plant_from_dict", "plant_to_dict", "load_plant"]

#: ``"model"`` name -> plant class.
MODELS = {cls.MODEL: cls for cls in (JointParams, LuGreParams, KarnoppParams, AsymmetricParams)}

_DRIFT_KEYS = ("Fc_change", "Fs_change", "t_start", "t_end", "period")


def plant_from_dict(d: dict):
    """Build a plant model from a mapping (see the module docstring for the keys).

    Parameters
    ----------
    d : dict
        Parameters under their standard symbols; ``"model"`` defaults to
        ``"lagged-stribeck"``; optional ``"drift"`` mapping.

    Returns
    -------
    JointParams, LuGreParams, KarnoppParams, AsymmetricParams or FrictionDrift

    Raises
    ------
    ParameterError
        Not a mapping, unknown model (the known ones are listed), missing or
        unknown keys, or values out of range.
    """
    if not isinstance(d, dict):
        raise ParameterError(f"plant parameters must be a JSON object / dict, got {type(d).__name__}")
    d = dict(d)
    model = d.pop("model", JointParams.MODEL)
    drift = d.pop("drift", None)
    if model not in MODELS:
        raise ParameterError(f"unknown friction model {model!r}; known: {sorted(MODELS)}")
    p = MODELS[model].from_dict(d)
    if drift is None:
        return p
    if not isinstance(drift, dict):
        raise ParameterError(f"'drift' must be an object with keys {list(_DRIFT_KEYS)}, got {drift!r}")
    unknown = [k for k in drift if k not in _DRIFT_KEYS]
    if unknown:
        raise ParameterError(f"unknown drift key(s) {unknown}; allowed {list(_DRIFT_KEYS)}")
    return FrictionDrift(p, **drift)


def plant_to_dict(p) -> dict:
    """The JSON-ready dict of a plant model, with its ``"model"`` key (inverse of :func:`plant_from_dict`)."""
    d = p.to_dict()
    return d if "model" in d else {"model": p.MODEL, **d}


def load_plant(path):
    """Read a plant model from a JSON file (see the module docstring).

    Raises
    ------
    ParameterError
        Not valid JSON, or invalid content (the file is named).
    FileNotFoundError
        The file does not exist.
    """
    path = Path(path)
    try:
        d = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise ParameterError(f"{path}: not valid JSON ({exc})") from None
    try:
        return plant_from_dict(d)
    except (ParameterError, TypeError) as exc:
        raise ParameterError(f"{path}: {exc}") from None
