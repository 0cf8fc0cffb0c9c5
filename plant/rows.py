"""The plant's parameter row and state: layout, packing, the friction map the steps evaluate, the up-front check.

The steps themselves are in :mod:`plant.dynamics` (RK4, :func:`plant.dynamics.plant_step`) and
:mod:`plant.stiff` (the implicit steps of stiff plants); :mod:`plant.dynamics` re-exports every name of
this module.

Every friction model of the package (:mod:`plant.friction` lagged Stribeck,
:mod:`plant.asymmetric`, :mod:`plant.karnopp`, :mod:`plant.lugre`) is packed by
:func:`plant_params` into one float64 row of :data:`PLANT_NPAR` entries; its
state is a float64 array of :data:`PLANT_NSTATE` entries made by
:func:`plant_state`. The compiled :func:`plant.dynamics.plant_step` advances the state by one
step with the input held, in place; :func:`plant.dynamics.plant_friction` returns the friction
torque. The Python classes (``make_step``, :func:`plant.joint.simulate`), the
identification simulator and the closed-loop engine all call these kernels.

Model (Ruderman, eqs. 1-3) of the lagged models::

    J*dw/dt = u - f
    tau*df/dt + f = F(w)        (f = F(w) algebraically if tau == 0)

with ``F`` eq. 3 per direction (asymmetric levels: Canudas de Wit, Åström,
Braun 1987) and, for Karnopp's model, the stick band ``|w| < dv`` (see
:class:`plant.karnopp.KarnoppParams`). LuGre (Canudas de Wit et al. 1995)::

    dz/dt = w - sigma0*|w|/g(w)*z,   g(w) = F(|w|) with sigma = 0
    J*dw/dt = u - sigma0*z - sigma1*dz/dt - sigma2*w

Parameter row (index: meaning; unused entries 0)

====  ==============  ===========================================================
slot  name            meaning
====  ==============  ===========================================================
0     ``code``        model: 0 lagged Stribeck, 1 asymmetric, 2 Karnopp, 3 LuGre
1     ``J``           inertia (kg·m²)
2     ``Vs``          Stribeck velocity (rad/s)
3     ``delta``       shape factor
4     ``tau``         friction lag (s); 0 for LuGre
5-8   ``*_pos``       ``Fc``, ``Fs - Fc`` (N·m), ``sigma`` (N·m·s/rad), cut-off speed
                      (:func:`plant.stribeck_map.stribeck_cutoff`, rad/s) for ``w > 0``
                      (LuGre: its ``Fc``, ``Fs - Fc``, ``sigma2``, cut-off)
9-12  ``*_neg``       the same for ``w < 0`` (equal to 5-8 but for the asymmetric model)
13    ``Fs_stick``    Karnopp: friction limit in the band (``Fs``, N·m)
14    ``dv``          Karnopp: half-width of the stick band (rad/s); 0 = no band
15    ``sigma0``      LuGre bristle stiffness (N·m/rad)
16    ``sigma1``      LuGre bristle damping (N·m·s/rad)
17    ``g_min``       LuGre ``min(Fc, Fs)`` (N·m)
18    ``g_max``       LuGre ``max(Fc, Fs)`` (N·m)
19    ``base_rate``   LuGre ``(sigma1 + sigma2)/J + sqrt(sigma0/J)`` (1/s)
20    ``rate``        lagged models: the fastest stable mode (1/s, :func:`lagged_rate`); where
                      ``rate*dt > RK4_RATE_MAX`` the RK4 step is cut into ``int(rate*dt) + 1``
                      equal sub-steps, beyond ``LAGGED_RK4_MAX`` the stiff step (below)
21    ``inv_J``       ``1/J`` (1/(kg·m²)): the lagged models' right-hand side multiplies by it
22    ``inv_tau``     ``1/tau`` (1/s), 0 for ``tau = 0``
23    ``key``         fingerprint of slots 0-22 (an integer in [1, 2**52)), see state slot 2
====  ==============  ===========================================================

State (:data:`PLANT_NSTATE` = 3): ``st[0]`` velocity ``w`` (rad/s);
``st[1]`` the model's internal state (the friction torque ``f`` in N·m, for
LuGre the bristle deflection ``z`` in rad); ``st[2]`` equals ``key`` when
``st[1]`` is ``F(st[0])`` of these parameters with ``tau == 0`` (set by
:func:`plant.dynamics.plant_step` and :func:`plant_state`), so the next step reuses it instead
of evaluating eq. 3 again; any other value (e.g. NaN) means "not cached".
Swapping the parameter row (a drifting plant) invalidates it by the key. For
LuGre, and for a lagged model after a step of :func:`~plant.stiff.lagged_stiff_step`, ``st[2]``
holds the last sub-step of the stiff integrator (s) or NaN.

Stiff lagged models (a rising Stribeck map, ``delta < 0``, whose steepest slope
sits at tiny speeds; a viscous slope far above ``J/dt``; a lag far below the
step) take :func:`~plant.stiff.lagged_stiff_step` (error-controlled, extrapolated backward
Euler, each sub-step one scalar bracketed solve that sticks on a jump of eq. 3
where the friction is set-valued) for every step whose velocity range
(:func:`~plant.stiff.lagged_local_rate`) would need more than :data:`~plant.stiff.LAGGED_RK4_MAX` RK4
sub-steps; no lagged model is refused for stiffness.

Stiff LuGre joints (a stiff bristle, ``sigma0`` up to 1e8 N·m/rad and more, on
a small inertia) are integrated by :func:`~plant.stiff.lugre_stiff_step` (error-controlled,
extrapolated backward Euler) once the RK4 sub-step count of a step would exceed
:data:`~plant.stiff.LUGRE_RK4_MAX`; :func:`check_integrable` refuses, before a run, plants
whose step cannot be computed accurately.
"""

from __future__ import annotations

import math
from dataclasses import fields, is_dataclass

import numpy as np

from plant.errors import ParameterError, check_positive
from plant.jit import kernel
from plant.stribeck_map import stribeck_cutoff, stribeck_scalar, stribeck_slope_scalar

__all__ = ["PLANT_NPAR", "PLANT_NSTATE", "PLANT_SLOTS", "MODEL_CODES", "plant_params", "plant_rows", "lagged_params",
           "plant_state", "plant_states", "plant_target", "check_integrable", "integrable_rows", "lagged_rate", "steepest_rise",
           "RK4_RATE_MAX", "LUGRE_STIFF_MAX"]

#: Model codes of slot 0.
MODEL_CODES = {"lagged-stribeck": 0, "asymmetric": 1, "karnopp": 2, "lugre": 3}
#: Slot names of the parameter row -> index (see the module docstring).
PLANT_SLOTS = {name: i for i, name in enumerate((
    "code", "J", "Vs", "delta", "tau", "Fc_pos", "dF_pos", "sigma_pos", "wcut_pos", "Fc_neg", "dF_neg",
    "sigma_neg", "wcut_neg", "Fs_stick", "dv", "sigma0", "sigma1", "g_min", "g_max", "base_rate", "rate", "inv_J",
    "inv_tau", "key"))}
#: Length of the parameter row.
PLANT_NPAR = len(PLANT_SLOTS)
#: Length of the state array: w, the model's internal state, the eq. 3 cache key.
PLANT_NSTATE = 3

_LUGRE = 3.0
_KEY = PLANT_SLOTS["key"]
_RATE = PLANT_SLOTS["rate"]
_INV_J = PLANT_SLOTS["inv_J"]
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
        raise TypeError(f"p must be a frozen JointParams, AsymmetricParams, KarnoppParams or LuGreParams (for a "
                        f"FrictionDrift use p.at(t)), got {type(p).__name__}")
    return model


def lagged_params(J: float, Fc: float, Fs: float, Vs: float, delta: float, sigma: float, tau: float) -> np.ndarray:
    """Parameter row of the lagged Stribeck joint (eqs. 1-3) from plain numbers, not validated.

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
    ndarray, shape (PLANT_NPAR,)
        The row (layout in the module docstring), model code 0.
    """
    return np.array(_lagged_list(0.0, J, Fc, Fs, Vs, delta, sigma, tau, 0.0, 0.0))


def _lagged_list(code, J, Fc, Fs, Vs, delta, sigma, tau, Fs_stick, dv) -> list:
    """The keyed row of a lagged Stribeck or Karnopp joint as a list of Python floats."""
    J, Fc, Fs, Vs = float(J), float(Fc), float(Fs), float(Vs)
    delta, sigma, tau = float(delta), float(sigma), float(tau)
    dF = Fs - Fc
    wcut = stribeck_cutoff(Fc, dF, Vs, delta)
    return _keyed([float(code), J, Vs, delta, tau, Fc, dF, sigma, wcut, Fc, dF, sigma, wcut, float(Fs_stick),
                   float(dv), 0.0, 0.0, 0.0, 0.0, 0.0, lagged_rate(J, dF, Vs, delta, sigma, tau)])


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


def _keyed(v: list) -> list:
    """Append ``inv_J``, ``inv_tau`` and the fingerprint ``key`` to the list of slots 0-20 (Python floats) of a
    row, in place; returns it."""
    J, tau = v[1], v[4]
    v.append(1.0 / J if J != 0.0 else math.inf)
    v.append(1.0 / tau if tau > 0.0 else 0.0)
    v.append(float(1 + hash(tuple(v)) % (2**52 - 1)))
    return v


def plant_params(p) -> np.ndarray:
    """Pack a frozen plant model into the parameter row of :func:`~plant.dynamics.plant_step`.

    Parameters
    ----------
    p : JointParams, AsymmetricParams, KarnoppParams or LuGreParams
        A validated (frozen) plant model; a drifting plant is packed per
        period from ``p.at(t)``.

    Returns
    -------
    ndarray, shape (PLANT_NPAR,)
        The row (layout in the module docstring), C-contiguous float64.

    Raises
    ------
    TypeError
        ``p`` is not one of the four frozen models.

    Notes
    -----
    Ruderman, eqs. 1-3, and the models of :mod:`plant.asymmetric`,
    :mod:`plant.karnopp`, :mod:`plant.lugre`.
    """
    return np.array(_row_list(p))


def _row_list(p) -> list:
    """The row of :func:`plant_params` as a list of Python floats."""
    model = _model_of(p)
    if model == "lagged-stribeck":
        return _lagged_list(0.0, p.J, p.Fc, p.Fs, p.Vs, p.delta, p.sigma, p.tau, 0.0, 0.0)
    if model == "karnopp":
        return _lagged_list(MODEL_CODES[model], p.J, p.Fc, p.Fs, p.Vs, p.delta, p.sigma, p.tau, p.Fs, p.dv)
    r = [0.0] * _INV_J
    r[0] = float(MODEL_CODES[model])
    r[1:4] = float(p.J), float(p.Vs), float(p.delta)
    if model == "asymmetric":
        r[4] = float(p.tau)
        r[5:9] = _levels(p.Fc_pos, p.Fs_pos, p.sigma_pos, p.Vs, p.delta)
        r[9:13] = _levels(p.Fc_neg, p.Fs_neg, p.sigma_neg, p.Vs, p.delta)
        r[_RATE] = max(lagged_rate(p.J, p.Fs_pos - p.Fc_pos, p.Vs, p.delta, p.sigma_pos, p.tau),
                       lagged_rate(p.J, p.Fs_neg - p.Fc_neg, p.Vs, p.delta, p.sigma_neg, p.tau))
        return _keyed(r)
    r[5:9] = r[9:13] = _levels(p.Fc, p.Fs, p.sigma2, p.Vs, p.delta)
    r[15:20] = (float(p.sigma0), float(p.sigma1), float(min(p.Fc, p.Fs)), float(max(p.Fc, p.Fs)),
                float((p.sigma1 + p.sigma2) / p.J + math.sqrt(p.sigma0 / p.J)))
    return _keyed(r)


def _levels(Fc, Fs, sigma, Vs, delta) -> list:
    """Slots ``Fc, Fs - Fc, sigma, cut-off`` of one direction (Python floats)."""
    return [float(Fc), float(Fs - Fc), float(sigma), float(stribeck_cutoff(Fc, Fs - Fc, Vs, delta))]


def plant_rows(plants) -> np.ndarray:
    """Pack B frozen plant models into a parameter table, one row of :func:`plant_params` each.

    Parameters
    ----------
    plants : sequence of JointParams, AsymmetricParams, KarnoppParams or LuGreParams, length B
        Validated (frozen) plant models, possibly of different classes.

    Returns
    -------
    ndarray, shape (B, PLANT_NPAR)
        Row ``b`` equals ``plant_params(plants[b])`` bit for bit (one list per plant, one array at the end).

    Raises
    ------
    TypeError
        An entry is not one of the four frozen models.

    Notes
    -----
    Ruderman, eqs. 1-3 (as :func:`plant_params`).
    """
    return np.array([_row_list(p) for p in plants], dtype=float).reshape(-1, PLANT_NPAR)


def plant_state(p, w0: float = 0.0) -> np.ndarray:
    """State of steady motion at velocity ``w0`` (what ``p.initial_state(w0)`` gives), for :func:`plant_step`.

    Parameters
    ----------
    p : JointParams, AsymmetricParams, KarnoppParams or LuGreParams
        Frozen plant model.
    w0 : float
        Velocity (rad/s).

    Returns
    -------
    ndarray, shape (PLANT_NSTATE,)
        ``[w0, s0, key]``: ``s0`` the friction ``F(w0)`` (lagged models, eq. 3;
        0 at rest) or the LuGre deflection ``sgn(w0) g(w0)/sigma0``; the cache
        slot is set where ``tau == 0`` (module docstring), else NaN.

    Raises
    ------
    TypeError
        ``p`` is not one of the four frozen models.
    ParameterError
        ``w0`` not finite.
    """
    model = _model_of(p)
    w0 = float(w0)
    if not math.isfinite(w0):
        raise ParameterError(f"w0 must be finite, got {w0!r}")
    if model == "lugre":
        return np.array([w0, float(p.initial_state(w0)), math.nan])
    return plant_states((p,), plant_params(p)[None, :], w0)[0]


#: Largest ``rate*dt`` of a stable mode that the explicit RK4 step of the lagged models accepts (RK4's
#: stability interval on the negative real axis ends at 2.785; Hairer & Wanner, *Solving ODEs II*, Sec. IV.2).
RK4_RATE_MAX = 2.5
#: Largest pre-sliding frequency ``sqrt(sigma0/J)*dt`` of a LuGre joint that
#: :func:`~plant.stiff.lugre_stiff_step` accepts.
LUGRE_STIFF_MAX = 1e4


def check_integrable(rows, dt: float) -> None:
    """Refuse, before a run, plants whose step over ``dt`` cannot be computed accurately.

    Parameters
    ----------
    rows : ndarray, shape (PLANT_NPAR,) or (K, PLANT_NPAR)
        Parameter rows of :func:`plant_params` (a drifting plant: all its rows).
    dt : float
        Step (s) the plant is advanced by, > 0.

    Raises
    ------
    ParameterError
        The first offending row and the reason: a LuGre joint whose pre-sliding frequency ``sqrt(sigma0/J)``
        exceeds ``LUGRE_STIFF_MAX/dt`` (it would run for hours), or a row with a non-finite or out-of-range
        entry (inertia, lag, levels; possible only for rows not made by :func:`plant_params`). Every valid lagged
        model (lagged Stribeck, asymmetric, Karnopp, any lag, slope or inertia) is integrable: beyond
        :data:`~plant.stiff.LAGGED_RK4_MAX` RK4 sub-steps :func:`~plant.dynamics.plant_step` takes the implicit
        :func:`~plant.stiff.lagged_stiff_step`.

    Notes
    -----
    The LuGre rate is the eigenvalue of the linearised model at rest (Canudas de Wit et al. 1995); the lagged
    models' stiff step is L-stable (backward Euler; Hairer & Wanner, *Solving ODEs II*, Sec. IV.3).
    """
    dt = check_positive("dt", dt)
    r = np.atleast_2d(np.asarray(rows, dtype=float))
    ok = integrable_rows(r, dt)
    if ok.all():
        return
    j = int(np.argmin(ok))
    row = r[j].tolist()
    code, J, tau = row[0], row[1], row[4]
    if code == _LUGRE:
        ratio = row[15] / J if J != 0.0 else math.inf
        wp = math.sqrt(ratio) if ratio >= 0.0 else math.nan
        raise ParameterError(
            f"LuGre plant (row {j}): the pre-sliding frequency sqrt(sigma0/J) = {wp:.3g} rad/s is more than "
            f"{LUGRE_STIFF_MAX:g}/dt = {LUGRE_STIFF_MAX / dt:.3g} rad/s (sigma0 = {row[15]:g} N·m/rad, "
            f"J = {J:g} kg·m², dt = {dt:g} s): the engine cannot integrate it accurately")
    levels = [row[k] for k in _CHECKED]
    raise ParameterError(
        f"plant (row {j}, model code {int(code)}): J = {J!r} kg·m² must be finite and > 0, tau = {tau!r} s "
        f"finite and >= 0, and the friction parameters (Fc, Fs - Fc, sigma per direction, Vs, delta, Fs, dv) "
        f"finite, got {levels!r}: the engine cannot integrate it")


#: Slots that must be finite in a lagged row: Fc, Fs - Fc, sigma per direction, Vs, delta, Fs_stick, dv.
_CHECKED = [5, 6, 7, 9, 10, 11, 2, 3, 13, 14]


def integrable_rows(rows, dt: float) -> np.ndarray:
    """Which parameter rows :func:`check_integrable` accepts (one array pass over a whole table).

    Parameters
    ----------
    rows : ndarray, shape (K, PLANT_NPAR)
        Parameter rows of :func:`plant_params` (e.g. :func:`plant_rows` of a batch).
    dt : float
        Step (s), > 0 (not checked here).

    Returns
    -------
    ndarray of bool, shape (K,)
        LuGre rows: ``sqrt(sigma0/J)*dt <= LUGRE_STIFF_MAX``; lagged rows: ``J`` finite and > 0, ``tau``
        finite and >= 0 and the friction slots finite (the conditions of :func:`check_integrable`).

    Notes
    -----
    Canudas de Wit et al. (1995) for the LuGre rate at rest; the same IEEE operations (division, square
    root) as a scalar evaluation, so a row passes here exactly when it passes one by one.
    """
    r = np.asarray(rows, dtype=float)
    J, tau = r[:, 1], r[:, 4]
    with np.errstate(all="ignore"):
        wp = np.sqrt(np.where(J != 0.0, r[:, 15] / np.where(J != 0.0, J, 1.0), np.inf))
        lugre_ok = wp * dt <= LUGRE_STIFF_MAX
    lagged_ok = ((J > 0.0) & np.isfinite(J) & (tau >= 0.0) & (tau < np.inf)
                 & np.isfinite(r[:, _CHECKED]).all(axis=1))
    return np.where(r[:, 0] == _LUGRE, lugre_ok, lagged_ok)


@kernel
def _steady_states(rows, w0, out):
    """``out[b] = [w0, F(w0), key or NaN]`` of the lagged rows (eq. 3 with the levels of the direction of w0)."""
    for b in range(rows.shape[0]):
        par = rows[b]
        i = 5 if w0 > 0.0 else 9
        out[b, 0] = w0
        out[b, 1] = stribeck_scalar(w0, par[i], par[i + 1], par[2], par[3], par[i + 2], par[i + 3])
        out[b, 2] = par[_KEY] if par[4] == 0.0 else math.nan


def plant_states(plants, rows, w0: float) -> np.ndarray:
    """States of steady motion at ``w0`` of B plants (:func:`plant_state` of each), in one compiled pass.

    Parameters
    ----------
    plants : sequence of plant models, length B
        The frozen models of ``rows`` (LuGre entries are initialised by :func:`plant_state`).
    rows : ndarray, shape (B, PLANT_NPAR)
        Their rows (:func:`plant_rows`).
    w0 : float
        Velocity (rad/s), finite.

    Returns
    -------
    ndarray, shape (B, PLANT_NSTATE)
        Row ``b`` equals ``plant_state(plants[b], w0)`` bit for bit: the lagged models' ``F(w0)`` is
        :func:`plant.stribeck_map.stribeck_scalar` with the row's levels of the direction of ``w0`` (what
        ``initial_state`` evaluates through :func:`plant.stribeck_map.stribeck`).

    Raises
    ------
    ParameterError
        ``w0`` not finite.

    Notes
    -----
    Ruderman, eq. 3; LuGre: Canudas de Wit et al. (1995).
    """
    w0 = float(w0)
    if not math.isfinite(w0):
        raise ParameterError(f"w0 must be finite, got {w0!r}")
    r = np.ascontiguousarray(rows, dtype=float).reshape(-1, PLANT_NPAR)
    out = np.empty((r.shape[0], PLANT_NSTATE))
    _steady_states(r, w0, out)
    for b in np.flatnonzero(r[:, 0] == _LUGRE).tolist():
        out[b] = plant_state(plants[b], w0)
    return out


@kernel(inline="always")
def plant_target(par, w, sgn):
    """The friction map the RK4 stages evaluate, at velocity ``w``.

    Parameters
    ----------
    par : ndarray, shape (PLANT_NPAR,)
        Parameter row of :func:`plant_params`.
    w : float
        Velocity (rad/s).
    sgn : float
        Karnopp breakaway direction (``sgn(u)``) when the step started in the
        stick band, else 0.

    Returns
    -------
    float
        Lagged models: ``Fs_stick*sgn`` inside the Karnopp band ``|w| < dv``,
        else eq. 3 with the levels of the direction of ``w`` (N·m). LuGre: the
        Stribeck level ``g(w) = Fc + (Fs - Fc)*exp(-|w/Vs|**delta)`` (N·m),
        its limit at ``w = 0``.

    Notes
    -----
    Ruderman, eq. 3 (:func:`plant.stribeck_map.stribeck_scalar`, one call site so
    the compiled code holds one copy of it); Karnopp (1985); Canudas de Wit et
    al. (1995), eq. 3.
    """
    if par[0] == _LUGRE:
        x = w if w >= 0.0 else -w
        if not x > 0.0:
            return par[5] + par[6] if par[3] > 0 else par[5]
        Fc, dF, sigma, wcut = par[5], par[6], 0.0, par[8]
    else:
        x = w
        if w > 0.0:
            if w < par[14]:
                return par[13] * sgn
            Fc, dF, sigma, wcut = par[5], par[6], par[7], par[8]
        else:
            if -w < par[14]:
                return par[13] * sgn
            Fc, dF, sigma, wcut = par[9], par[10], par[11], par[12]
    return stribeck_scalar(x, Fc, dF, par[2], par[3], sigma, wcut)


