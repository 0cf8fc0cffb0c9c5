"""The PI a user already has, from a file: the output of ``adaptive-ff design --json`` (or any JSON object with the
same keys), for ``compare --controller FILE``.

Keys (SI, as ``design --json`` writes them whatever ``--units`` printed): ``Kp`` (N·m·s/rad), ``Ki`` (N·m/rad),
``Tc`` (s) and the loop model the gains were designed on, ``J`` (kg·m²) and ``sigma`` (N·m·s/rad, 0 if absent or
null). Other keys (margins, step metrics, targets) are the design's report and are recomputed, not read.
"""

from __future__ import annotations

import math
from pathlib import Path

from controllers.design.pi import PIDesign, analyse_gains
from plant.errors import ParameterError

__all__ = ["read_controller", "CONTROLLER_KEYS"]

#: Keys of a controller file and their units; ``sigma`` may be absent.
CONTROLLER_KEYS = {"Kp": "N·m·s/rad", "Ki": "N·m/rad", "Tc": "s", "J": "kg·m²", "sigma": "N·m·s/rad"}


def _number(d: dict, key: str, path: Path, *, required: bool = True) -> float:
    v = d.get(key)
    if v is None and not required:
        return 0.0
    if v is None:
        raise ParameterError(f"{path}: no '{key}' ({CONTROLLER_KEYS[key]}); a controller file is the output of "
                             f"'adaptive-ff design --json' (keys {', '.join(CONTROLLER_KEYS)})")
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(float(v)):
        raise ParameterError(f"{path}: '{key}' must be a finite number ({CONTROLLER_KEYS[key]}), got {v!r}")
    return float(v)


def read_controller(path) -> PIDesign:
    """The PI of a controller file (module docstring) with its margins on the file's loop model.

    Parameters
    ----------
    path : str or os.PathLike
        JSON file, e.g. written by ``adaptive-ff design --json > design.json``.

    Returns
    -------
    PIDesign
        :func:`controllers.design.pi.analyse_gains` of the file's ``Kp``, ``Ki`` on its ``J``, ``sigma`` at its
        ``Tc``.

    Raises
    ------
    ParameterError
        Not JSON or not an object, a key missing or not a finite number, a value out of range, or gains that do
        not stabilise the file's loop model (the file and the key named).
    FileNotFoundError
        No such file.
    """
    from plant.models import read_json

    path = Path(path)
    d = read_json(path, what="controller file")
    if not isinstance(d, dict):
        raise ParameterError(f"{path}: a controller file is a JSON object (the output of 'adaptive-ff design "
                             f"--json'), got {type(d).__name__}")
    vals = {k: _number(d, k, path, required=k != "sigma") for k in CONTROLLER_KEYS}
    try:
        return analyse_gains(vals["Kp"], vals["Ki"], J=vals["J"], sigma=vals["sigma"], Tc=vals["Tc"])
    except ParameterError as exc:
        raise ParameterError(f"{path}: {exc}") from None
