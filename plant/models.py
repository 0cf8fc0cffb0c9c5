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
(:class:`plant.drift.FrictionDrift`, all keys optional), a friction ripple
``"ripple": {"amplitude": 0.1, "harmonic": 100, "phase": 0}`` (:class:`plant.ripple.FrictionRipple`, ``phase``
optional) and a payload step ``"payload": {"t_step": 5, "J_after": 0.08}`` (:class:`plant.payload.PayloadStep`,
both keys needed). Loaded as ``PayloadStep(FrictionRipple(FrictionDrift(model)))`` (the parts present); the
drift scales the levels, the ripple multiplies the map, the payload changes ``J``: any order is the same plant.

Every plant class provides ``J``, ``Vs``, ``delta``, ``friction(w)`` (steady
sliding map), ``make_step(dt)`` (one integration step ``(w, s, u) -> (w, s)``
with the model's internal state ``s``), ``friction_torque(w, s)``,
``initial_state(w)``, ``frictionless()``, ``to_dict()`` and ``MODEL``. The
C step behind all of them is :func:`plant.dynamics.plant_step` on the
``plant_params`` struct :func:`plant.dynamics.plant_params` packs for any of these classes.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from plant.asymmetric import AsymmetricParams
from plant.drift import FrictionDrift
from plant.errors import ParameterError, check_not_special
from plant.friction import JointParams
from plant.karnopp import KarnoppParams
from plant.lugre import LuGreParams
from plant.payload import PayloadStep
from plant.ripple import FrictionRipple
from plant.rows import check_integrable, plant_params

__all__ = ["MODELS", "PLAUSIBLE_RANGE", "plant_from_dict", "plant_to_dict", "load_plant", "read_json",
           "check_plausible"]

#: ``"model"`` name -> plant class.
MODELS = {cls.MODEL: cls for cls in (JointParams, LuGreParams, KarnoppParams, AsymmetricParams)}

_DRIFT_KEYS = ("Fc_change", "Fs_change", "t_start", "t_end", "period")
_RIPPLE_KEYS = ("amplitude", "harmonic", "phase")
_PAYLOAD_KEYS = ("t_step", "J_after")

#: Plausible magnitude range of every plant parameter in SI units (kg·m², N·m, N·m·s/rad, rad/s, s, ...).
#: Values outside it are almost always a unit slip (g·mm² for kg·m², mN·m for N·m) and overflow the
#: design or the simulation; zero stays allowed where the model allows it.
PLAUSIBLE_RANGE = (1e-9, 1e9)

#: Viscous coefficients (N·m·s/rad) of the lagged models (lagged Stribeck, Karnopp, asymmetric) that set their
#: fastest mechanical time constant J/sigma. LuGre has none here: its ``sigma1`` is the bristle damping and its
#: viscous ``sigma2`` enters the eigenvalues of the bristle-mass system, from which the LuGre step chooses its
#: RK4 sub-steps or the implicit step (:meth:`plant.lugre.LuGreParams.make_step`); no LuGre damping is too stiff.
_VISCOUS_KEYS = ("sigma", "sigma_pos", "sigma_neg")


def plant_from_dict(d: dict):
    """Build a plant model from a mapping (see the module docstring for the keys).

    Parameters
    ----------
    d : dict
        Parameters under their standard symbols; ``"model"`` defaults to
        ``"lagged-stribeck"``; optional ``"drift"``, ``"ripple"`` and ``"payload"`` mappings.

    Returns
    -------
    JointParams, LuGreParams, KarnoppParams, AsymmetricParams, FrictionDrift, FrictionRipple or PayloadStep
        ``PayloadStep(FrictionRipple(FrictionDrift(model)))`` with the parts present.

    Raises
    ------
    ParameterError
        Not a mapping, unknown model (the known ones are listed), missing or
        unknown keys, or values out of range (the key and value named).
    """
    if not isinstance(d, dict):
        raise ParameterError(f"plant parameters must be a JSON object / dict, got {type(d).__name__}")
    d = dict(d)
    model = d.pop("model", JointParams.MODEL)
    drift = d.pop("drift", None)
    ripple = d.pop("ripple", None)
    payload = d.pop("payload", None)
    if model not in MODELS:
        raise ParameterError(f"unknown friction model {model!r}; known: {sorted(MODELS)}")
    p = MODELS[model].from_dict(d)
    if drift is not None:
        p = FrictionDrift(p, **_table("drift", drift, _DRIFT_KEYS, ()))
    if ripple is not None:
        kw = _table("ripple", ripple, _RIPPLE_KEYS, ("amplitude", "harmonic"))
        p = FrictionRipple(p, **{k: _value("ripple", k, v) for k, v in kw.items()})
    if payload is not None:
        kw = _table("payload", payload, _PAYLOAD_KEYS, _PAYLOAD_KEYS)
        p = PayloadStep(p, **{k: _value("payload", k, v) for k, v in kw.items()})
    return p


def _table(name: str, value, allowed: tuple, required: tuple) -> dict:
    """The keys of the plant file's ``name`` object, checked against ``allowed`` and ``required``."""
    if not isinstance(value, dict):
        raise ParameterError(f"{name!r} must be an object with keys {list(allowed)}, got {value!r}")
    unknown = [k for k in value if k not in allowed]
    if unknown:
        raise ParameterError(f"unknown {name} key(s) {unknown}; allowed {list(allowed)}")
    missing = [k for k in required if k not in value]
    if missing:
        raise ParameterError(f"{name} needs key(s) {missing}; got {sorted(value)}")
    return dict(value)


def _value(name: str, key: str, v):
    """A plant-file number of the ``name`` object (not a bool, not a string), else a ParameterError naming it."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ParameterError(f"{name}.{key} must be a number, got {v!r}")
    return v


def plant_to_dict(p) -> dict:
    """The JSON-ready dict of a plant model, with its ``"model"`` key (inverse of :func:`plant_from_dict`)."""
    d = p.to_dict()
    return d if "model" in d else {"model": p.MODEL, **d}


def read_json(path, *, what: str = "JSON file"):
    """Read a UTF-8 JSON file with every failure turned into a typed error naming the file.

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    what : str, keyword-only
        What the file is, for messages (``"plant file"``, ``"sweep spec"``).

    Returns
    -------
    object
        The parsed JSON value (``NaN``/``Infinity`` literals are refused: RFC 8259).

    Raises
    ------
    FileNotFoundError
        No such file.
    ParameterError
        A directory, unreadable (permissions), not UTF-8, empty, not valid JSON
        (line and column named), or nested too deeply.
    """
    path = Path(path)
    if path.is_dir():
        raise ParameterError(f"{path}: is a directory, expected a {what}")
    check_not_special(path, what)
    if not path.exists():
        raise FileNotFoundError(f"{what} not found: {path}")
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ParameterError(f"{path}: not a UTF-8 text file (byte {exc.start}: {exc.reason}); "
                             f"expected a {what} in JSON") from None
    except OSError as exc:
        raise ParameterError(f"{path}: cannot read the {what} ({exc.strerror or exc})") from None
    if not text.strip():
        raise ParameterError(f"{path}: empty file, expected a {what} in JSON")

    def _no_constants(name):
        raise ValueError(f"{name} is not valid JSON (use a finite number)")

    try:
        return json.loads(text, parse_constant=_no_constants)
    except json.JSONDecodeError as exc:
        raise ParameterError(f"{path}: not valid JSON at line {exc.lineno}, column {exc.colno} "
                             f"({exc.msg})") from None
    except (ValueError, RecursionError) as exc:
        raise ParameterError(f"{path}: not a usable {what} ({exc})") from None


def check_plausible(p, *, dt: float = 1e-3, where: str = "plant") -> None:
    """Raise unless plant ``p`` has physically plausible parameters that a ``dt`` simulation can integrate.

    Parameters
    ----------
    p : plant model
        Any model of :data:`MODELS` (or a :class:`plant.drift.FrictionDrift` around one).
    dt : float, keyword-only
        Integration step of the simulation (s), default 1 ms (the 1 kHz plant).
    where : str, keyword-only
        Prefix of the message (a file name).

    Raises
    ------
    ParameterError
        A parameter's magnitude outside :data:`PLAUSIBLE_RANGE` (zero excepted);
        for the lagged models (lagged Stribeck, Karnopp, asymmetric) a mechanical
        time constant ``J/sigma`` below ``dt/2`` (RK4 is stable for
        ``dt*sigma/J < 2.78`` on ``J dw/dt = -sigma w``; Butcher, *Numerical
        Methods for ODEs*, 2008, Sec. 238: such a ``sigma`` is almost always a
        unit slip); for LuGre a pre-sliding frequency ``sqrt(sigma0/J)`` beyond
        :data:`plant.rows.LUGRE_STIFF_MAX` ``/dt`` (:func:`plant.rows.check_integrable`).
        The message names the parameter, its value and unit, and the likely cause.

    Notes
    -----
    LuGre joints are not held to ``J/sigma``: ``sigma1`` is the bristle damping
    (critical damping ``2*sqrt(sigma0*J)`` is the textbook choice, far above
    ``2*J/dt`` for a stiff bristle) and ``sigma2`` the viscous coefficient;
    both enter the eigenvalues of the linearised bristle-mass system, from which
    the LuGre step takes enough RK4 sub-steps or the implicit step
    (:meth:`plant.lugre.LuGreParams.make_step`), so every ``sigma1, sigma2 >= 0``
    simulates. Physically meaningless LuGre parameters (``sigma0 <= 0``, a
    negative damping, ``J <= 0``, non-finite values) are refused by
    :class:`plant.lugre.LuGreParams` itself.
    """
    base = p
    while hasattr(base, "base"):  # the model inside the drift, ripple and payload wrappers
        base = base.base
    for q in _wrappers(p):  # the payload's inertia after the step is a plant's J too
        if isinstance(q, PayloadStep):
            check_plausible(base.replace(J=q.J_after), dt=dt, where=f"{where} (after the payload step)")
    d = {k: v for k, v in plant_to_dict(base).items() if isinstance(v, (int, float)) and not isinstance(v, bool)}
    lo, hi = PLAUSIBLE_RANGE
    for k, v in d.items():
        if not math.isfinite(v) or (v != 0 and not lo <= abs(v) <= hi):
            raise ParameterError(f"{where}: {k} = {v!r} is outside the plausible range {lo:g}..{hi:g} (SI units: "
                                 f"kg·m², N·m, N·m·s/rad, rad/s, s); check the units")
    if isinstance(base, LuGreParams):
        try:
            check_integrable(plant_params(base), dt)
        except ParameterError as exc:
            raise ParameterError(f"{where}: {exc}") from None
        return
    J = d.get("J")
    visc = max((abs(d[k]) for k in _VISCOUS_KEYS if k in d), default=0.0)
    if J is not None and visc > 0 and J / visc < dt / 2:
        key = max((k for k in _VISCOUS_KEYS if k in d), key=lambda k: abs(d[k]))
        raise ParameterError(f"{where}: J = {J!r} kg·m² with {key} = {d[key]!r} N·m·s/rad gives a mechanical time "
                             f"constant J/{key} = {J / visc:.3g} s, below half the simulation step {dt:g} s: not a "
                             "plausible joint (check the units of J and the viscous coefficient)")


def _wrappers(p) -> list:
    """``p`` and the wrappers inside it (drift, ripple, payload), outermost first, the model last."""
    out = [p]
    while hasattr(out[-1], "base"):
        out.append(out[-1].base)
    return out


def load_plant(path, *, dt: float = 1e-3):
    """Read a plant model from a JSON file (see the module docstring) and check it is plausible.

    Parameters
    ----------
    path : str or os.PathLike
        The plant file (UTF-8 JSON object).
    dt : float, keyword-only
        Simulation step (s) the plant must be integrable at (:func:`check_plausible`), default 1 ms.

    Raises
    ------
    ParameterError
        A directory, not UTF-8, not valid JSON (:func:`read_json`), invalid
        content, or implausible values (:func:`check_plausible`); the file is named.
    FileNotFoundError
        The file does not exist.
    """
    path = Path(path)
    d = read_json(path, what="plant file")
    try:
        p = plant_from_dict(d)
    except (ParameterError, TypeError, OverflowError) as exc:
        raise ParameterError(f"{path}: {exc}") from None
    check_plausible(p, dt=dt, where=str(path))
    return p
