"""The plant's parameters and state as C structs: packing, the friction map the steps evaluate, the up-front check.

The steps themselves are in :mod:`plant.dynamics` (RK4, :func:`plant.dynamics.plant_step`) and
:mod:`plant.stiff` (the implicit steps of stiff plants); :mod:`plant.dynamics` re-exports every name of
this module.

Every friction model of the package (:mod:`plant.friction` lagged Stribeck,
:mod:`plant.asymmetric`, :mod:`plant.karnopp`, :mod:`plant.lugre`) is packed by
:func:`plant_params` into one C struct ``plant_params`` (``plant/csrc/plant_params.h``,
cffi: ``plant._cplant.ffi``); its state is a ``plant_state`` struct made by
:func:`plant_state`. A table of B plants (a batch; a drifting plant's K rows) is a
cffi array ``plant_params[B]`` (:func:`plant_rows`, :func:`stack_params`) with the states
``plant_state[B]`` (:func:`plant_states`); an element is ``rows[b]`` (a struct, copied by
value on assignment) and ``rows + b`` is a pointer to it. The C :func:`plant.dynamics.plant_step`
advances the state by one step with the input held, in place; :func:`plant.dynamics.plant_friction`
returns the friction torque. The Python classes (``make_step``, :func:`plant.joint.simulate`),
the identification simulator and the closed-loop engine all call these C functions.
cffi objects do not pickle: pack in the process that steps.

Model (Ruderman, eqs. 1-3) of the lagged models::

    J*dw/dt = u - f
    tau*df/dt + f = F(w)        (f = F(w) algebraically if tau == 0)

with ``F`` eq. 3 per direction (asymmetric levels: Canudas de Wit, Åström,
Braun 1987) and, for Karnopp's model, the stick band ``|w| < dv`` (see
:class:`plant.karnopp.KarnoppParams`). LuGre (Canudas de Wit et al. 1995)::

    dz/dt = w - sigma0*|w|/g(w)*z,   g(w) = F(|w|) with sigma = 0
    J*dw/dt = u - sigma0*z - sigma1*dz/dt - sigma2*w

Fields of ``plant_params`` (unused ones 0)

================  ==================================================================
field             meaning
================  ==================================================================
``model``         ``plant_model`` enum (:data:`MODEL_CODES`): 0 lagged Stribeck
                  (``PLANT_LAGGED_STRIBECK``), 1 asymmetric, 2 Karnopp, 3 LuGre
``J``             inertia (kg·m²)
``tau``           friction lag (s); 0 for LuGre
``pos``           eq. 3 for ``w > 0`` (a ``plant_stribeck``): ``Fc``, ``dF = Fs - Fc``
                  (N·m), ``Vs`` (rad/s), ``delta``, ``sigma`` (N·m·s/rad), cut-off
                  speed ``wcut`` (:func:`plant.stribeck_map.stribeck_cutoff`, rad/s)
                  (LuGre: its ``Fc``, ``Fs - Fc``, ``Vs``, ``delta``, ``sigma2``, cut-off)
``neg``           the same for ``w < 0`` (equal to ``pos`` but for the asymmetric model)
``Fs_stick``      Karnopp: friction limit in the band (``Fs``, N·m)
``dv``            Karnopp: half-width of the stick band (rad/s); 0 = no band
``sigma0``        LuGre bristle stiffness (N·m/rad)
``sigma1``        LuGre bristle damping (N·m·s/rad)
``g_min``         LuGre ``min(Fc, Fs)`` (N·m)
``g_max``         LuGre ``max(Fc, Fs)`` (N·m)
``base_rate``     LuGre ``(sigma1 + sigma2)/J + sqrt(sigma0/J)`` (1/s)
``rate``          lagged models: the fastest stable mode (1/s, :func:`lagged_rate`); where
                  ``rate*dt > RK4_RATE_MAX`` the RK4 step is cut into ``int(rate*dt) + 1``
                  equal sub-steps, beyond ``LAGGED_RK4_MAX`` the stiff step (below)
``inv_J``         ``1/J`` (1/(kg·m²)): the lagged models' right-hand side multiplies by it
``inv_tau``       ``1/tau`` (1/s), 0 for ``tau = 0``
``ripple_a``      friction ripple amplitude ``a`` (0 <= a < 1; 0: none), :class:`plant.ripple.FrictionRipple`
``ripple_n``      ripple periods per joint revolution ``n``
``ripple_phase``  ripple phase (rad)
``key``           fingerprint of the fields above (an integer in [1, 2**52)), see ``aux``
================  ==================================================================

With a friction ripple (``ripple_a != 0``) the friction map is ``F(w)*R(q)``,
``R(q) = 1 + a*sin(n*q + phase)``, ``q`` the joint position (the lagged models'
target, the Karnopp stick limit included; LuGre's ``g(w)`` and ``sigma2*w``);
``ripple_a == 0`` gives every result bit for bit (``plant/csrc/plant_params.h``).

Fields of ``plant_state``: ``w`` velocity (rad/s); ``s`` the model's internal
state (the friction torque ``f`` in N·m, for LuGre the bristle deflection ``z``
in rad); ``q`` the joint position (rad, ``dq/dt = w``, 0 at the start of a run;
only the ripple reads it); ``aux`` equals ``key`` when ``s`` is ``F(w)`` of these parameters with
``tau == 0`` (set by :func:`plant.dynamics.plant_step` and :func:`plant_state`), so
the next step reuses it instead of evaluating eq. 3 again; any other value (e.g.
NaN) means "not cached". Swapping the parameters (a drifting plant) invalidates it
by the key. For LuGre, and for a lagged model after a step of
:func:`~plant.stiff.lagged_stiff_step`, ``aux`` holds the last sub-step of the
stiff integrator (s) or NaN.

Stiff lagged models (a rising Stribeck map, ``delta < 0``, whose steepest slope
sits at tiny speeds; a viscous slope far above ``J/dt``; a lag far below the
step) take :func:`~plant.stiff.lagged_stiff_step` (error-controlled, extrapolated backward
Euler, each sub-step one scalar bracketed solve that sticks on a jump of eq. 3
where the friction is set-valued) for every step whose velocity range
(:func:`~plant.stiff.lagged_local_rate`) would need more than :data:`~plant.stiff.LAGGED_RK4_MAX` RK4
sub-steps; no lagged model is refused for stiffness.

Stiff LuGre joints (a stiff bristle, ``sigma0`` up to 1e8 N·m/rad and more, on
a small inertia; a bristle damping ``sigma1`` up to critical, ``2*sqrt(sigma0*J)``,
and beyond, whose ``J/sigma1`` is far below the step) are integrated by :func:`~plant.stiff.lugre_stiff_step` (error-controlled,
extrapolated backward Euler) once the RK4 sub-step count of a step would exceed
:data:`~plant.stiff.LUGRE_RK4_MAX`; :func:`check_integrable` refuses, before a run, plants
whose step cannot be computed accurately.
"""

from __future__ import annotations

import math
from dataclasses import fields, is_dataclass

import numpy as np

from plant._cplant import ffi, lib
from plant.errors import ParameterError, check_positive
from plant.stribeck_map import stribeck_cutoff, stribeck_slope_scalar

__all__ = ["MODEL_CODES", "plant_params", "plant_rows", "lagged_params", "plant_state", "params_state", "plant_states",
           "stack_params", "stack_states", "plant_target", "check_integrable", "integrable_rows", "lagged_rate",
           "steepest_rise", "RK4_RATE_MAX", "LUGRE_STIFF_MAX"]

#: Model name -> value of the ``plant_model`` enum (field ``model`` of ``plant_params``).
MODEL_CODES = {"lagged-stribeck": lib.PLANT_LAGGED_STRIBECK, "asymmetric": lib.PLANT_ASYMMETRIC,
               "karnopp": lib.PLANT_KARNOPP, "lugre": lib.PLANT_LUGRE}

_LUGRE = lib.PLANT_LUGRE
_PARAMS = ffi.typeof("plant_params")
_PARAMS_PTR = ffi.typeof("plant_params *")
_STATE = ffi.typeof("plant_state")
_STATE_PTR = ffi.typeof("plant_state *")
_FIELDS = {
    "lagged-stribeck": ("J", "Fc", "Fs", "Vs", "delta", "sigma", "tau"),
    "asymmetric": ("J", "Fc_pos", "Fc_neg", "Fs_pos", "Fs_neg", "Vs", "delta", "sigma_pos", "sigma_neg", "tau"),
    "karnopp": ("J", "Fc", "Fs", "Vs", "delta", "sigma", "tau", "dv"),
    "lugre": ("J", "Fc", "Fs", "Vs", "delta", "sigma0", "sigma1", "sigma2"),
}


def _model_of(p) -> str:
    model = getattr(p, "MODEL", None)
    names = tuple(f.name for f in fields(p)) if is_dataclass(p) and not isinstance(p, type) else None
    frozen = names is not None and type(p).__dataclass_params__.frozen
    if model not in _FIELDS or names != _FIELDS[model] or not frozen:
        raise TypeError(f"p must be a frozen JointParams, AsymmetricParams, KarnoppParams or LuGreParams, or a "
                        f"FrictionRipple around one (for a FrictionDrift use p.at(t), as for a PayloadStep), got "
                        f"{type(p).__name__}")
    return model


def lagged_params(J: float, Fc: float, Fs: float, Vs: float, delta: float, sigma: float, tau: float):
    """Parameters of the lagged Stribeck joint (eqs. 1-3) from plain numbers, not validated.

    For inner loops that explore parameters (the output-error fits of
    :mod:`adaptive_ff.identification.simulator`); validated models go through
    :func:`plant_params`.

    Parameters
    ----------
    J : float
        Inertia (kg·m²), non-zero.
    Fc, Fs : float
        Coulomb and static levels (N·m).
    Vs : float
        Stribeck velocity (rad/s), > 0.
    delta : float
        Shape factor, non-zero.
    sigma : float
        Viscous coefficient (N·m·s/rad).
    tau : float
        Friction lag (s), >= 0.

    Returns
    -------
    cffi ``plant_params *``
        A new struct (fields in the module docstring), model ``PLANT_LAGGED_STRIBECK``.
    """
    return ffi.new(_PARAMS_PTR, _init(_lagged_list(0.0, J, Fc, Fs, Vs, delta, sigma, tau, 0.0, 0.0)))


def _lagged_list(code, J, Fc, Fs, Vs, delta, sigma, tau, Fs_stick, dv, keyed: bool = True) -> list:
    """The keyed values of a lagged Stribeck or Karnopp joint as a list of Python floats (order: :func:`_init`);
    ``keyed=False``: the 21 values without ``inv_J``, ``inv_tau``, the ripple and the key."""
    J, Fc, Fs, Vs = float(J), float(Fc), float(Fs), float(Vs)
    delta, sigma, tau = float(delta), float(sigma), float(tau)
    dF = Fs - Fc
    wcut = stribeck_cutoff(Fc, dF, Vs, delta)
    v = [float(code), J, Vs, delta, tau, Fc, dF, sigma, wcut, Fc, dF, sigma, wcut, float(Fs_stick),
         float(dv), 0.0, 0.0, 0.0, 0.0, 0.0, lagged_rate(J, dF, Vs, delta, sigma, tau)]
    return _keyed(v) if keyed else v


def lagged_rate(J: float, dF: float, Vs: float, delta: float, sigma: float, tau: float) -> float:
    """Fastest stable mode (1/s) of the lagged Stribeck joint (eqs. 1-3), linearised where friction rises most.

    Parameters
    ----------
    J, dF, Vs, delta, sigma, tau : float
        Inertia (kg·m²), ``Fs - Fc`` (N·m), Stribeck velocity (rad/s), shape factor, viscous coefficient
        (N·m·s/rad), lag (s).

    Returns
    -------
    float
        With ``s`` the steepest rise of the static map ``dF/d|w|`` (``sigma`` plus the Stribeck term where it
        rises: ``dF*delta < 0``), ``s/J`` for ``tau = 0`` and ``max(1/tau, sqrt(s/(J*tau)))`` otherwise (the
        eigenvalues of ``[[0, -1/J], [s/tau, -1/tau]]``). Where the Stribeck term falls (the usual dip) it adds
        nothing: that mode is unstable physics, not stiffness. For ``0 < delta < 1`` with ``Fs < Fc`` the rise
        at standstill is unbounded and is bounded here at ``|w| = 1e-3*Vs``.

    Notes
    -----
    Derivative of eq. 3 (:func:`plant.stribeck_map.stribeck_slope_scalar`), ``x = |w|/Vs``, largest at
    ``x**delta = 1 - 1/delta`` (``delta >= 1`` or ``delta < 0``).
    """
    s = steepest_rise(dF, Vs, delta, sigma)
    if tau > 0.0:
        return max(1.0 / tau, math.sqrt(s / (J * tau)))
    return s / J


def steepest_rise(dF: float, Vs: float, delta: float, sigma: float) -> float:
    """Steepest rise ``dF/d|w|`` (N·m·s/rad) of one direction of the static map (eq. 3).

    Parameters
    ----------
    dF, Vs, delta, sigma : float
        ``Fs - Fc`` (N·m), Stribeck velocity (rad/s), shape factor, viscous coefficient (N·m·s/rad).

    Returns
    -------
    float
        ``max(sigma, 0)`` plus the Stribeck term's largest slope where it rises (``dF*delta < 0``), at
        ``x**delta = 1 - 1/delta`` (``x = |w|/Vs``; ``delta >= 1`` or ``delta < 0``), bounded at ``|w| =
        1e-3*Vs`` for ``0 < delta < 1`` (unbounded at standstill there); where the term falls it adds nothing.

    Notes
    -----
    Derivative of eq. 3: :func:`plant.stribeck_map.stribeck_slope_scalar`. Used by :func:`lagged_rate` and
    :func:`plant.stiff.lagged_oscillation`.
    """
    rise = 0.0
    if dF * delta < 0.0:
        y = 1.0 - 1.0 / delta if (delta >= 1.0 or delta < 0.0) else 1e-3 ** delta
        x = y ** (1.0 / delta) if y > 0.0 else 0.0
        rise = float(stribeck_slope_scalar(x, dF, Vs, delta))
    return max(sigma, 0.0) + rise


def _keyed(v: list, ripple: tuple = (0.0, 0.0, 0.0)) -> list:
    """Append ``inv_J``, ``inv_tau``, the ripple ``(a, n, phase)`` and the fingerprint ``key`` to the list of the
    21 values before them (Python floats, order of :func:`_init`), in place; returns it."""
    J, tau = v[1], v[4]
    v.append(1.0 / J if J != 0.0 else math.inf)
    v.append(1.0 / tau if tau > 0.0 else 0.0)
    v.extend(float(x) for x in ripple)
    v.append(float(1 + hash(tuple(v)) % (2**52 - 1)))
    return v


def _init(v: list) -> dict:
    """The initialiser of a ``plant_params`` struct from the list ``[model, J, Vs, delta, tau, Fc, dF, sigma,
    wcut (w > 0), Fc, dF, sigma, wcut (w < 0), Fs_stick, dv, sigma0, sigma1, g_min, g_max, base_rate, rate,
    inv_J, inv_tau, ripple_a, ripple_n, ripple_phase, key]``."""
    return {"model": int(v[0]), "J": v[1], "tau": v[4],
            "pos": (v[5], v[6], v[2], v[3], v[7], v[8]), "neg": (v[9], v[10], v[2], v[3], v[11], v[12]),
            "Fs_stick": v[13], "dv": v[14], "sigma0": v[15], "sigma1": v[16], "g_min": v[17], "g_max": v[18],
            "base_rate": v[19], "rate": v[20], "inv_J": v[21], "inv_tau": v[22], "ripple_a": v[23],
            "ripple_n": v[24], "ripple_phase": v[25], "key": v[26]}


def plant_params(p):
    """Pack a frozen plant model into the ``plant_params`` struct of :func:`~plant.dynamics.plant_step`.

    Parameters
    ----------
    p : JointParams, AsymmetricParams, KarnoppParams or LuGreParams
        A validated (frozen) plant model; a drifting plant is packed per
        period from ``p.at(t)``.

    Returns
    -------
    cffi ``plant_params *``
        A new struct owned by the returned object (fields in the module docstring).

    Raises
    ------
    TypeError
        ``p`` is not one of the four frozen models.

    Notes
    -----
    Ruderman, eqs. 1-3, and the models of :mod:`plant.asymmetric`,
    :mod:`plant.karnopp`, :mod:`plant.lugre`.
    """
    return ffi.new(_PARAMS_PTR, _init(_row_list(p)))


def _row_list(p, models: dict | None = None) -> list:
    """The values of :func:`plant_params` as a list of Python floats (order: :func:`_init`); ``models``: the model
    name of each class checked so far (:func:`_model_list`)."""
    ripple = getattr(p, "ripple_fields", None)
    if ripple is None:
        return _keyed(_model_list(p, models))
    a = float(ripple[0])
    v = _model_list(p.base, models)
    if a != 0.0:  # the map and its slopes up to (1 + a) times the base's (plant_params.h)
        if int(v[0]) == _LUGRE:
            v[19] = (v[16] + v[7] * (1.0 + a)) / v[1] + math.sqrt(v[15] / v[1])
        else:
            v[20] = max(lagged_rate(v[1], v[6] * (1.0 + a), v[2], v[3], v[7] * (1.0 + a), v[4]),
                        lagged_rate(v[1], v[10] * (1.0 + a), v[2], v[3], v[11] * (1.0 + a), v[4]))
    return _keyed(v, ripple)


def _model_list(p, models: dict | None = None) -> list:
    """The 21 model values of :func:`_row_list` (without ``inv_J``, ``inv_tau``, the ripple and the key); ``models``
    (a dict, or None): class -> model name of the classes :func:`_model_of` checked so far, so that the plants of one
    :func:`plant_rows` call have their class checked once each."""
    if models is None:
        model = _model_of(p)
    else:
        model = models.get(type(p))
        if model is None:
            model = models[type(p)] = _model_of(p)
    if model == "lagged-stribeck":
        return _lagged_list(0.0, p.J, p.Fc, p.Fs, p.Vs, p.delta, p.sigma, p.tau, 0.0, 0.0, keyed=False)
    if model == "karnopp":
        return _lagged_list(MODEL_CODES[model], p.J, p.Fc, p.Fs, p.Vs, p.delta, p.sigma, p.tau, p.Fs, p.dv,
                            keyed=False)
    r = [0.0] * 21
    r[0] = float(MODEL_CODES[model])
    r[1:4] = float(p.J), float(p.Vs), float(p.delta)
    if model == "asymmetric":
        r[4] = float(p.tau)
        r[5:9] = _levels(p.Fc_pos, p.Fs_pos, p.sigma_pos, p.Vs, p.delta)
        r[9:13] = _levels(p.Fc_neg, p.Fs_neg, p.sigma_neg, p.Vs, p.delta)
        r[20] = max(lagged_rate(p.J, p.Fs_pos - p.Fc_pos, p.Vs, p.delta, p.sigma_pos, p.tau),
                    lagged_rate(p.J, p.Fs_neg - p.Fc_neg, p.Vs, p.delta, p.sigma_neg, p.tau))
        return r
    r[5:9] = r[9:13] = _levels(p.Fc, p.Fs, p.sigma2, p.Vs, p.delta)
    r[15:20] = (float(p.sigma0), float(p.sigma1), float(min(p.Fc, p.Fs)), float(max(p.Fc, p.Fs)),
                float((p.sigma1 + p.sigma2) / p.J + math.sqrt(p.sigma0 / p.J)))
    return r


def _levels(Fc, Fs, sigma, Vs, delta) -> list:
    """``Fc, Fs - Fc, sigma, cut-off`` of one direction (Python floats)."""
    return [float(Fc), float(Fs - Fc), float(sigma), float(stribeck_cutoff(Fc, Fs - Fc, Vs, delta))]


def plant_rows(plants):
    """Pack B frozen plant models into a table of ``plant_params`` structs, one :func:`plant_params` each.

    Parameters
    ----------
    plants : sequence of JointParams, AsymmetricParams, KarnoppParams or LuGreParams, length B
        Validated (frozen) plant models, possibly of different classes.

    Returns
    -------
    cffi ``plant_params[B]``
        A new array; element ``b`` equals ``plant_params(plants[b])[0]`` byte for byte (``rows + b`` is a
        pointer to it).

    Raises
    ------
    TypeError
        An entry is not one of the four frozen models.

    Notes
    -----
    Ruderman, eqs. 1-3 (as :func:`plant_params`).
    """
    models = {}  # each distinct class of the plants checked once, in this call
    return ffi.new("plant_params[]", [_init(_row_list(p, models)) for p in plants])


def _table(rows, what: str, item, ptr):
    """``(pointer to the first struct, count)`` of a cffi struct pointer, struct or array of ``item``."""
    try:
        t = ffi.typeof(rows)
    except TypeError:
        raise TypeError(f"{what} must be a cffi {item.cname} pointer or array (plant.rows), got "
                        f"{type(rows).__name__}") from None
    if t is ptr:
        return rows, 1
    if t is item:
        return ffi.addressof(rows), 1
    if t.kind == "array" and t.item is item:
        return ffi.cast(ptr, rows), len(rows)
    raise TypeError(f"{what} must be a cffi {item.cname} pointer or array (plant.rows), got {t.cname}")


def stack_params(items):
    """Copy plant parameter structs into one table (a batch, a drifting plant's rows).

    Parameters
    ----------
    items : sequence of cffi ``plant_params *`` or ``plant_params`` (e.g. of :func:`plant_params`), length B

    Returns
    -------
    cffi ``plant_params[B]``
        A new array; element ``b`` is a copy of ``items[b]``.

    Raises
    ------
    TypeError
        An entry is not a ``plant_params`` struct or pointer.
    """
    out = ffi.new("plant_params[]", len(items))
    for b, x in enumerate(items):
        out[b] = _table(x, f"items[{b}]", _PARAMS, _PARAMS_PTR)[0][0]
    return out


def stack_states(items):
    """Copy plant state structs into one table.

    Parameters
    ----------
    items : sequence of cffi ``plant_state *`` or ``plant_state`` (e.g. of :func:`plant_state`), length B

    Returns
    -------
    cffi ``plant_state[B]``
        A new array; element ``b`` is a copy of ``items[b]``.

    Raises
    ------
    TypeError
        An entry is not a ``plant_state`` struct or pointer.
    """
    out = ffi.new("plant_state[]", len(items))
    for b, x in enumerate(items):
        out[b] = _table(x, f"items[{b}]", _STATE, _STATE_PTR)[0][0]
    return out


def plant_state(p, w0: float = 0.0):
    """State of steady motion at velocity ``w0`` (what ``p.initial_state(w0)`` gives), for :func:`plant_step`.

    Parameters
    ----------
    p : JointParams, AsymmetricParams, KarnoppParams or LuGreParams
        Frozen plant model.
    w0 : float
        Velocity (rad/s).

    Returns
    -------
    cffi ``plant_state *``
        A new struct ``{w: w0, s: s0, aux}``: ``s0`` the friction ``F(w0)`` (lagged models, eq. 3;
        0 at rest) or the LuGre deflection ``sgn(w0) g(w0)/sigma0``; ``aux`` the cache key where
        ``tau == 0`` (module docstring), else NaN. C: ``plant_steady_state``.

    Raises
    ------
    TypeError
        ``p`` is not one of the four frozen models.
    ParameterError
        ``w0`` not finite.
    """
    return params_state(plant_params(p), w0)


def params_state(par, w0: float = 0.0):
    """:func:`plant_state` of a packed plant: the state of steady motion at ``w0`` of the parameters ``par``.

    Parameters
    ----------
    par : cffi ``plant_params *`` or ``plant_params[K]``
        Parameters of :func:`plant_params` (of a table: its first row), e.g. the first row of a run's table.
    w0 : float
        Velocity (rad/s).

    Returns
    -------
    cffi ``plant_state *``
        A new struct, as :func:`plant_state` of the model ``par`` was packed from. C: ``plant_steady_state``.

    Raises
    ------
    TypeError
        ``par`` is not a ``plant_params`` pointer or array.
    ParameterError
        ``w0`` not finite.
    """
    par = _table(par, "par", _PARAMS, _PARAMS_PTR)[0]
    w0 = float(w0)
    if not math.isfinite(w0):
        raise ParameterError(f"w0 must be finite, got {w0!r}")
    st = ffi.new(_STATE_PTR)
    lib.plant_steady_state(par, w0, st)
    return st


#: Largest ``rate*dt`` of a stable mode that the explicit RK4 step of the lagged models accepts (RK4's
#: stability interval on the negative real axis ends at 2.785; Hairer & Wanner, *Solving ODEs II*, Sec. IV.2).
RK4_RATE_MAX = lib.plant_rk4_rate_max  # 2.5, C plant_dynamics.h
#: Largest pre-sliding frequency ``sqrt(sigma0/J)*dt`` of a LuGre joint that
#: :func:`~plant.stiff.lugre_stiff_step` accepts.
LUGRE_STIFF_MAX = lib.plant_lugre_stiff_max  # 1e4, C plant_params.h


def check_integrable(rows, dt: float) -> None:
    """Refuse, before a run, plants whose step over ``dt`` cannot be computed accurately.

    Parameters
    ----------
    rows : cffi ``plant_params *`` or ``plant_params[K]``
        Parameters of :func:`plant_params` (a drifting plant: all its K structs, :func:`plant_rows`).
    dt : float
        Step (s) the plant is advanced by, > 0.

    Raises
    ------
    ParameterError
        The first offending row and the reason: a LuGre joint whose pre-sliding frequency ``sqrt(sigma0/J)``
        exceeds ``LUGRE_STIFF_MAX/dt`` (it would run for hours), or a row with a non-finite or out-of-range
        field (inertia, lag, levels; possible only for structs not made by :func:`plant_params`). Every valid
        lagged model (lagged Stribeck, asymmetric, Karnopp, any lag, slope or inertia) is integrable: beyond
        :data:`~plant.stiff.LAGGED_RK4_MAX` RK4 sub-steps :func:`~plant.dynamics.plant_step` takes the implicit
        :func:`~plant.stiff.lagged_stiff_step`.
    TypeError
        ``rows`` is not a ``plant_params`` pointer or array.

    Notes
    -----
    The LuGre rate is the eigenvalue of the linearised model at rest (Canudas de Wit et al. 1995); the lagged
    models' stiff step is L-stable (backward Euler; Hairer & Wanner, *Solving ODEs II*, Sec. IV.3). The
    conditions are C (``plant_integrable`` in ``plant/csrc/plant_params.c``).
    """
    dt = check_positive("dt", dt)
    ptr, _ = _table(rows, "rows", _PARAMS, _PARAMS_PTR)
    ok = integrable_rows(rows, dt)
    if ok.all():
        return
    j = int(np.argmin(ok))
    row = ptr[j]
    code, J, tau = int(row.model), row.J, row.tau
    ripple = [row.ripple_a, row.ripple_n, row.ripple_phase]
    if not (ripple[0] == 0.0 or (0.0 < ripple[0] < 1.0 and 0.0 < ripple[1] < math.inf
                                 and math.isfinite(ripple[2]))):
        raise ParameterError(f"plant (row {j}, model code {code}): the friction ripple (a, n, phase) = {ripple!r} "
                             f"must have a = 0, or 0 < a < 1 with n > 0 and n, phase finite: the engine cannot "
                             f"integrate it")
    if code == _LUGRE:
        ratio = row.sigma0 / J if J != 0.0 else math.inf
        wp = math.sqrt(ratio) if ratio >= 0.0 else math.nan
        raise ParameterError(
            f"LuGre plant (row {j}): the pre-sliding frequency sqrt(sigma0/J) = {wp:.3g} rad/s is more than "
            f"{LUGRE_STIFF_MAX:g}/dt = {LUGRE_STIFF_MAX / dt:.3g} rad/s (sigma0 = {row.sigma0:g} N·m/rad, "
            f"J = {J:g} kg·m², dt = {dt:g} s): the engine cannot integrate it accurately")
    levels = [row.pos.Fc, row.pos.dF, row.pos.sigma, row.neg.Fc, row.neg.dF, row.neg.sigma, row.pos.Vs,
              row.pos.delta, row.Fs_stick, row.dv]
    raise ParameterError(
        f"plant (row {j}, model code {code}): J = {J!r} kg·m² must be finite and > 0, tau = {tau!r} s "
        f"finite and >= 0, and the friction parameters (Fc, Fs - Fc, sigma per direction, Vs, delta, Fs, dv) "
        f"finite, got {levels!r}: the engine cannot integrate it")


def integrable_rows(rows, dt: float) -> np.ndarray:
    """Which parameter structs :func:`check_integrable` accepts (one C pass over a whole table).

    Parameters
    ----------
    rows : cffi ``plant_params[K]`` (or one ``plant_params *``)
        Parameters of :func:`plant_params` (e.g. :func:`plant_rows` of a batch).
    dt : float
        Step (s), > 0 (not checked here).

    Returns
    -------
    ndarray of bool, shape (K,)
        LuGre: ``sqrt(sigma0/J)*dt <= LUGRE_STIFF_MAX``; lagged models: ``J`` finite and > 0, ``tau``
        finite and >= 0 and the friction fields (``Fc``, ``dF``, ``sigma``, ``Vs``, ``delta`` per direction,
        ``Fs_stick``, ``dv``) finite (the conditions of :func:`check_integrable`).

    Raises
    ------
    TypeError
        ``rows`` is not a ``plant_params`` pointer or array.

    Notes
    -----
    Canudas de Wit et al. (1995) for the LuGre rate at rest. C: ``plant_integrable_array``.
    """
    ptr, n = _table(rows, "rows", _PARAMS, _PARAMS_PTR)
    ok = np.empty(n, dtype=np.intc)
    lib.plant_integrable_array(ptr, n, float(dt), ffi.from_buffer("int[]", ok))
    return ok.astype(bool)


def plant_states(rows, w0: float):
    """States of steady motion at ``w0`` of B plants (:func:`plant_state` of each), in one C pass.

    Parameters
    ----------
    rows : cffi ``plant_params[B]`` (or one ``plant_params *``)
        The plants' parameters (:func:`plant_rows`).
    w0 : float
        Velocity (rad/s), finite.

    Returns
    -------
    cffi ``plant_state[B]``
        Element ``b`` equals ``plant_state(plants[b], w0)[0]`` bit for bit (C ``plant_steady_states``): the lagged
        models' ``F(w0)`` is eq. 3 with the levels of the direction of ``w0`` (what ``initial_state``
        evaluates through :func:`plant.stribeck_map.stribeck`), LuGre's ``sgn(w0) g(w0)/sigma0``.

    Raises
    ------
    ParameterError
        ``w0`` not finite.
    TypeError
        ``rows`` is not a ``plant_params`` table.

    Notes
    -----
    Ruderman, eq. 3; LuGre: Canudas de Wit et al. (1995).
    """
    ptr, n = _table(rows, "rows", _PARAMS, _PARAMS_PTR)
    w0 = float(w0)
    if not math.isfinite(w0):
        raise ParameterError(f"w0 must be finite, got {w0!r}")
    out = ffi.new("plant_state[]", n)
    lib.plant_steady_states(ptr, n, w0, out)
    return out


def plant_target(par, w: float, sgn: float, q: float | None = None) -> float:
    """The friction map the RK4 stages evaluate, at velocity ``w``.

    Parameters
    ----------
    par : cffi ``plant_params *``
        Parameters of :func:`plant_params` (an element ``b`` of a table: ``rows + b``).
    w : float
        Velocity (rad/s).
    sgn : float
        Karnopp breakaway direction (``sgn(u)``) when the step started in the
        stick band, else 0.
    q : float, optional
        Joint position (rad): the map times the ripple ``R(q)`` (C ``plant_target_at``); None: without it.

    Returns
    -------
    float
        Lagged models: ``Fs_stick*sgn`` inside the Karnopp band ``|w| < dv``,
        else eq. 3 with the levels of the direction of ``w`` (N·m). LuGre: the
        Stribeck level ``g(w) = Fc + (Fs - Fc)*exp(-|w/Vs|**delta)`` (N·m),
        its limit at ``w = 0``. With ``q``: times ``1 + ripple_a*sin(ripple_n*q + ripple_phase)``.

    Notes
    -----
    Ruderman, eq. 3 (C ``plant_target`` in ``plant/csrc/plant_params.c`` over
    ``plant_stribeck_eval``, the one eq. 3); Karnopp (1985); Canudas de Wit et
    al. (1995), eq. 3.
    """
    if q is not None:
        return lib.plant_target_at(par, w, q, sgn)
    return lib.plant_target(par, w, sgn)
