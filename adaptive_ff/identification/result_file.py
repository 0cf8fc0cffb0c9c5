"""Reading an identification file (``adaptive-ff identify --json``, :meth:`IdentificationReport.to_dict`).

One reader for every consumer (``design --from``, ``export-c --from``, the Python API): the identified joint is
the top level of the file, the answer of the method that was chosen (``"method"``), with the paper's eq. 4
LS/RLS values nested under ``"baselines"``::

    {"method": "sliding", "form": {...}, "J": 4.1, "Fc": 25.0, "Fs": 37.2, "sigma": 40.1, "tau": 0.021,
     "offset": 0.001, "Vs": 0.02, "delta": 1.0, "std": {...}, ...,
     "baselines": {"eq4_ls": {"J": 171.6, ...}, "eq4_rls": {...}}, "excitation": {...}, "warnings": [...]}

Files written before that layout carried the eq. 4 LS values at the top level and the chosen method's values
under ``physical.params`` (for a method other than ``"paper"``); :func:`read_identification` reads them from
there. A file of neither layout raises :class:`IdentificationFileError` naming the file and the missing key.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from plant.errors import ParameterError
from plant.results import PhysicalParams

__all__ = ["IdentifiedJoint", "IdentificationFileError", "read_identification", "identification_from_dict",
           "is_identification", "JOINT_KEYS", "LAYOUTS"]

#: The joint parameters an identification file gives (``offset`` optional, 0 if absent).
JOINT_KEYS = ("J", "Fc", "Fs", "sigma", "tau", "offset")

#: Layouts :func:`identification_from_dict` reads: ``"top"`` (the chosen method's values at the top level,
#: baselines nested), ``"physical"`` (older files: the chosen method's values under ``physical.params``),
#: ``"eq4"`` (older files of method ``"paper"``: the eq. 4 LS values, the answer, at the top level).
LAYOUTS = ("top", "physical", "eq4")

#: Keys that mark a JSON object as an identification (and not a plant file or a design output).
_MARKERS = ("method", "physical", "baselines")


class IdentificationFileError(ParameterError):
    """An identification file (or dict) of no known layout; ``path`` and ``key`` name the file and the missing key.

    Attributes
    ----------
    path : str
        The file (or ``"identification"`` for a dict).
    key : str
        The key that was missing or invalid, e.g. ``"J"`` or ``"physical.params.J"``.
    """

    def __init__(self, path, key: str, message: str):
        super().__init__(f"{path}: {message}")
        self.path = str(path)
        self.key = key


@dataclass(frozen=True)
class IdentifiedJoint(PhysicalParams):
    """The identified joint of an identification file, whatever its layout.

    Attributes
    ----------
    method : str
        The identification method whose values these are (``"paper"``, ``"sliding"``, ``"output_error"``,
        ``"closed_loop"``).
    params : dict
        ``{"J": kg·m², "Fc": N·m, "Fs": N·m, "sigma": N·m·s/rad, "tau": s, "offset": N·m}``, floats (NaN where the
        file has ``null``: a non-finite estimate; ``Fs`` also where the file has none).
    stderr : dict
        Standard errors of ``params`` the file gives (same keys and units; may be empty).
    Vs, delta : float or None
        The Stribeck velocity (rad/s) and shape factor, None for the Coulomb + viscous structure.
    noise_std : float or None
        Velocity noise estimate of the record (rad/s, ``excitation.noise_std``), None if absent.
    min_speed : float or None
        The lowest speed the identification used (rad/s, ``excitation.min_speed``; ``identify-arm --json``'s
        entries give it), None if absent.
    layout : str
        One of :data:`LAYOUTS`: where the values were found.
    source : str
        The file (or ``"identification"``).
    """

    method: str
    params: dict
    stderr: dict = field(default_factory=dict)
    Vs: float | None = None
    delta: float | None = None
    noise_std: float | None = None
    min_speed: float | None = None
    layout: str = "top"
    source: str = "identification"

    def plant_dict(self) -> dict:
        """A plant file (:mod:`plant.models`, lagged Stribeck) of the identified joint, for ``compare --plant``.

        Returns
        -------
        dict
            ``{"J", "Fc", "Fs", "Vs", "delta", "sigma", "tau"}`` (SI units). A Coulomb + viscous identification
            (``Fs == Fc``) without ``Vs``, ``delta`` gets ``Vs = 1``, ``delta = 1``, which have no effect when
            ``Fs = Fc``; the offset is not part of a plant file.

        Raises
        ------
        IdentificationFileError
            A Stribeck identification (``Fs != Fc``) without ``Vs`` or ``delta``, or a non-finite parameter.
        """
        p = {k: self.params[k] for k in ("J", "Fc", "Fs", "sigma", "tau")}
        bad = [k for k, v in p.items() if not math.isfinite(v)]
        if bad:
            raise IdentificationFileError(self.source, bad[0], f"{bad[0]} is not a finite number (null in the "
                                          "identification): no plant file")
        Vs, delta = self.Vs, self.delta
        if Vs is None or delta is None:
            if p["Fs"] != p["Fc"]:
                raise IdentificationFileError(self.source, "Vs", "a Stribeck identification (Fs != Fc) without "
                                              "'Vs' and 'delta': no plant file")
            Vs, delta = 1.0, 1.0  # Fs = Fc: the Stribeck term vanishes
        return {"J": p["J"], "Fc": p["Fc"], "Fs": p["Fs"], "Vs": Vs, "delta": delta, "sigma": p["sigma"],
                "tau": p["tau"]}


def is_identification(d) -> bool:
    """True if ``d`` (a parsed JSON value) is an identification: an object with ``method``, ``physical`` or
    ``baselines``."""
    return isinstance(d, dict) and any(k in d for k in _MARKERS)


def _value(d: dict, key: str, where, prefix: str, *, required: bool = True):
    """``d[key]`` as a float (``None`` -> NaN); IdentificationFileError naming ``prefix + key`` otherwise."""
    if key not in d:
        if required:
            raise IdentificationFileError(where, prefix + key, f"no {prefix + key!r} (a number) in the identification "
                                          "(adaptive-ff identify --json)")
        return None
    v = d[key]
    if v is None:
        return math.nan
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise IdentificationFileError(where, prefix + key, f"{prefix + key!r} must be a finite number, got {v!r}")
    return float(v)


def _numbers(d, where, prefix: str) -> dict:
    """The finite-or-NaN numbers of a ``{name: value}`` object (other entries skipped)."""
    if not isinstance(d, dict):
        return {}
    return {k: (math.nan if v is None else float(v)) for k, v in d.items()
            if v is None or (isinstance(v, (int, float)) and not isinstance(v, bool))}


def identification_from_dict(d, *, where="identification") -> IdentifiedJoint:
    """The identified joint of a parsed identification (any of :data:`LAYOUTS`).

    Parameters
    ----------
    d : dict
        The parsed JSON of ``adaptive-ff identify --json`` (or :meth:`IdentificationReport.to_dict`).
    where : str or os.PathLike, keyword-only
        What to name in errors (the file).

    Returns
    -------
    IdentifiedJoint

    Raises
    ------
    IdentificationFileError
        Not an object, or no ``J``, ``Fc``, ``Fs``, ``sigma``, ``tau`` where its layout keeps them (the key is
        named, e.g. ``'physical.params.Fs'``), or a value that is not a number.
    """
    if not isinstance(d, dict):
        raise IdentificationFileError(where, "", f"expected a JSON object (adaptive-ff identify --json), "
                                      f"got {type(d).__name__}")
    method = d.get("method")
    phys = d.get("physical")
    if "baselines" in d:
        layout, src, prefix, std = "top", d, "", d.get("std")
    elif phys is not None:
        if not isinstance(phys, dict) or not isinstance(phys.get("params"), dict):
            raise IdentificationFileError(where, "physical.params", "'physical' has no 'params' object: not an "
                                          "identification of a known layout (adaptive-ff identify --json)")
        layout, src, prefix, std = "physical", phys["params"], "physical.params.", phys.get("stderr")
        method = method if isinstance(method, str) else phys.get("method")
    else:
        layout, src, prefix, std = "eq4", d, "", d.get("std")
    if not isinstance(method, str):
        method = "paper"
    params = {k: _value(src, k, where, prefix, required=k != "Fs") for k in JOINT_KEYS[:-1]}
    if params["Fs"] is None:  # absent as null: no Stribeck level (Fs = Fc where a compensator is built)
        params["Fs"] = math.nan
    off = _value(src, "offset", where, prefix, required=False)
    params["offset"] = 0.0 if off is None else off
    Vs = _value(d, "Vs", where, "", required=False)
    delta = _value(d, "delta", where, "", required=False)
    exc = d.get("excitation")
    noise, slowest = ((_value(exc, k, where, "excitation.", required=False) for k in ("noise_std", "min_speed"))
                      if isinstance(exc, dict) else (None, None))
    return IdentifiedJoint(method=method, params=params, stderr=_numbers(std, where, prefix), Vs=Vs, delta=delta,
                           noise_std=noise, min_speed=slowest, layout=layout, source=str(where))


def read_identification(path) -> IdentifiedJoint:
    """Read an identification file (``adaptive-ff identify --json``) of any of :data:`LAYOUTS`.

    Parameters
    ----------
    path : str or os.PathLike
        The JSON file.

    Returns
    -------
    IdentifiedJoint
        The chosen method's joint parameters (``J``, ``Fc``, ``Fs``, ``sigma``, ``tau``, ``offset``), their
        standard errors, ``Vs``, ``delta`` and the record's velocity noise.

    Raises
    ------
    FileNotFoundError
        No such file.
    ParameterError
        Not UTF-8 JSON (:func:`plant.models.read_json`).
    IdentificationFileError
        A JSON value of no known layout (the file and the missing key named).

    Examples
    --------
    >>> joint = read_identification("id.json")                     # doctest: +SKIP
    >>> joint.J, joint.method                                      # doctest: +SKIP
    (4.10, 'sliding')
    """
    from plant.models import read_json

    path = Path(path)
    return identification_from_dict(read_json(path, what="JSON identification (adaptive-ff identify --json)"),
                                    where=path)
