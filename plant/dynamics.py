"""The plant as one compiled component: parameter row, state, the one RK4 step and the friction torque.

Every friction model of the package (:mod:`plant.friction` lagged Stribeck,
:mod:`plant.asymmetric`, :mod:`plant.karnopp`, :mod:`plant.lugre`) is packed by
:func:`plant_params` into one float64 row of :data:`PLANT_NPAR` entries; its
state is a float64 array of :data:`PLANT_NSTATE` entries made by
:func:`plant_state`. The compiled :func:`plant_step` advances the state by one
step with the input held, in place; :func:`plant_friction` returns the friction
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
                      (:func:`plant.stribeck.stribeck_cutoff`, rad/s) for ``w > 0``
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
:func:`plant_step` and :func:`plant_state`), so the next step reuses it instead
of evaluating eq. 3 again; any other value (e.g. NaN) means "not cached".
Swapping the parameter row (a drifting plant) invalidates it by the key. For
LuGre, and for a lagged model after a step of :func:`lagged_stiff_step`, ``st[2]``
holds the last sub-step of the stiff integrator (s) or NaN.

Stiff lagged models (a rising Stribeck map, ``delta < 0``, whose steepest slope
sits at tiny speeds; a viscous slope far above ``J/dt``; a lag far below the
step) take :func:`lagged_stiff_step` (error-controlled, extrapolated backward
Euler, each sub-step one scalar bracketed solve that sticks on a jump of eq. 3
where the friction is set-valued) for every step whose velocity range
(:func:`lagged_local_rate`) would need more than :data:`LAGGED_RK4_MAX` RK4
sub-steps; no lagged model is refused for stiffness.

Stiff LuGre joints (a stiff bristle, ``sigma0`` up to 1e8 N·m/rad and more, on
a small inertia) are integrated by :func:`lugre_stiff_step` (error-controlled,
extrapolated backward Euler) once the RK4 sub-step count of a step would exceed
:data:`LUGRE_RK4_MAX`; :func:`check_integrable` refuses, before a run, plants
whose step cannot be computed accurately.
"""

from __future__ import annotations

import math
from dataclasses import fields, is_dataclass
from typing import Callable

import numpy as np

from plant.errors import ParameterError, check_positive
from plant.jit import kernel
from plant.stribeck import stribeck_cutoff, stribeck_scalar

__all__ = ["PLANT_NPAR", "PLANT_NSTATE", "PLANT_SLOTS", "MODEL_CODES", "plant_params", "lagged_params", "plant_state",
           "plant_target", "plant_rk4", "plant_step", "plant_friction", "plant_simulate", "make_plant_step",
           "lugre_jacobian", "lugre_implicit_step", "lugre_stiff_step", "lagged_implicit_step", "lagged_stiff_step", "lagged_local_rate",
           "check_integrable", "lagged_rate", "RK4_RATE_MAX", "LAGGED_RK4_MAX", "LAGGED_RTOL", "LAGGED_FTOL",
           "LAGGED_MAX_SUBSTEPS", "LUGRE_STIFF_MAX", "LUGRE_RK4_MAX", "LUGRE_RTOL", "LUGRE_ZTOL", "LUGRE_MAX_SUBSTEPS"]

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
_INV_TAU = PLANT_SLOTS["inv_tau"]
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
    J, Fc, Fs, Vs, delta, sigma, tau = (float(v) for v in (J, Fc, Fs, Vs, delta, sigma, tau))
    r = np.zeros(PLANT_NPAR)
    r[1:5] = J, Vs, delta, tau
    r[5:9] = r[9:13] = Fc, Fs - Fc, sigma, stribeck_cutoff(Fc, Fs - Fc, Vs, delta)
    r[_RATE] = lagged_rate(J, Fs - Fc, Vs, delta, sigma, tau)
    return _keyed(r)


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
    Derivative of eq. 3: ``d/d|w| dF*exp(-x**delta) = -dF*delta*x**(delta-1)*exp(-x**delta)/Vs``,
    ``x = |w|/Vs``, largest at ``x**delta = 1 - 1/delta`` (``delta >= 1`` or ``delta < 0``).
    """
    rise = 0.0
    if dF * delta < 0.0:
        y = 1.0 - 1.0 / delta if (delta >= 1.0 or delta < 0.0) else 1e-3 ** delta
        x = y ** (1.0 / delta) if y > 0.0 else 0.0
        shape = (x ** (delta - 1.0) if x > 0.0 else (1.0 if delta == 1.0 else 0.0)) * math.exp(-y)
        rise = abs(dF * delta) * shape / Vs
    s = max(sigma, 0.0) + rise
    if tau > 0.0:
        return max(1.0 / tau, math.sqrt(s / (J * tau)))
    return s / J


def _keyed(r: np.ndarray) -> np.ndarray:
    r[_INV_J] = 1.0 / r[1] if r[1] != 0.0 else math.inf
    r[_INV_TAU] = 1.0 / r[4] if r[4] > 0.0 else 0.0
    r[_KEY] = 1 + hash(tuple(r[:_KEY].tolist())) % (2**52 - 1)
    return r


def plant_params(p) -> np.ndarray:
    """Pack a frozen plant model into the parameter row of :func:`plant_step`.

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
    model = _model_of(p)
    if model in ("lagged-stribeck", "karnopp"):
        r = lagged_params(p.J, p.Fc, p.Fs, p.Vs, p.delta, p.sigma, p.tau)
        if model == "karnopp":
            r[0] = MODEL_CODES[model]
            r[13:15] = p.Fs, p.dv
        return _keyed(r)
    r = np.zeros(PLANT_NPAR)
    r[0] = MODEL_CODES[model]
    r[1:4] = p.J, p.Vs, p.delta
    if model == "asymmetric":
        r[4] = p.tau
        r[5:9] = p.Fc_pos, p.Fs_pos - p.Fc_pos, p.sigma_pos, stribeck_cutoff(p.Fc_pos, p.Fs_pos - p.Fc_pos, p.Vs,
                                                                                p.delta)
        r[9:13] = p.Fc_neg, p.Fs_neg - p.Fc_neg, p.sigma_neg, stribeck_cutoff(p.Fc_neg, p.Fs_neg - p.Fc_neg, p.Vs,
                                                                                 p.delta)
        r[_RATE] = max(lagged_rate(p.J, p.Fs_pos - p.Fc_pos, p.Vs, p.delta, p.sigma_pos, p.tau),
                       lagged_rate(p.J, p.Fs_neg - p.Fc_neg, p.Vs, p.delta, p.sigma_neg, p.tau))
        return _keyed(r)
    r[5:9] = r[9:13] = p.Fc, p.Fs - p.Fc, p.sigma2, stribeck_cutoff(p.Fc, p.Fs - p.Fc, p.Vs, p.delta)
    r[15:20] = (p.sigma0, p.sigma1, min(p.Fc, p.Fs), max(p.Fc, p.Fs),
                (p.sigma1 + p.sigma2) / p.J + math.sqrt(p.sigma0 / p.J))
    return _keyed(r)


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
    cached = model != "lugre" and p.tau == 0.0
    return np.array([w0, float(p.initial_state(w0)), plant_params(p)[_KEY] if cached else math.nan])


#: Largest ``rate*dt`` of a stable mode that the explicit RK4 step of the lagged models accepts (RK4's
#: stability interval on the negative real axis ends at 2.785; Hairer & Wanner, *Solving ODEs II*, Sec. IV.2).
RK4_RATE_MAX = 2.5
#: Largest pre-sliding frequency ``sqrt(sigma0/J)*dt`` of a LuGre joint that :func:`lugre_stiff_step` accepts.
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
        :data:`LAGGED_RK4_MAX` RK4 sub-steps :func:`plant_step` takes the implicit :func:`lagged_stiff_step`.

    Notes
    -----
    The LuGre rate is the eigenvalue of the linearised model at rest (Canudas de Wit et al. 1995); the lagged
    models' stiff step is L-stable (backward Euler; Hairer & Wanner, *Solving ODEs II*, Sec. IV.3).
    """
    dt = check_positive("dt", dt)
    r = np.atleast_2d(np.asarray(rows, dtype=float))
    for j in range(r.shape[0]):
        code, J, tau = r[j, 0], r[j, 1], r[j, 4]
        if code == _LUGRE:
            wp = math.sqrt(r[j, 15] / J)
            if not wp * dt <= LUGRE_STIFF_MAX:
                raise ParameterError(
                    f"LuGre plant (row {j}): the pre-sliding frequency sqrt(sigma0/J) = {wp:.3g} rad/s is more than "
                    f"{LUGRE_STIFF_MAX:g}/dt = {LUGRE_STIFF_MAX / dt:.3g} rad/s (sigma0 = {r[j, 15]:g} N·m/rad, "
                    f"J = {J:g} kg·m², dt = {dt:g} s): the engine cannot integrate it accurately")
            continue
        J, tau = float(J), float(tau)
        levels = [float(v) for v in (*r[j, 5:8], *r[j, 9:12], r[j, 2], r[j, 3], r[j, 13], r[j, 14])]
        if not (J > 0.0 and math.isfinite(J) and 0.0 <= tau < math.inf and all(math.isfinite(v) for v in levels)):
            raise ParameterError(
                f"plant (row {j}, model code {int(code)}): J = {J!r} kg·m² must be finite and > 0, tau = {tau!r} s "
                f"finite and >= 0, and the friction parameters (Fc, Fs - Fc, sigma per direction, Vs, delta, Fs, dv) "
                f"finite, got {levels!r}: the engine cannot integrate it")


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
    Ruderman, eq. 3 (:func:`plant.stribeck.stribeck_scalar`, one call site so
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


@kernel(inline="always")
def _rhs(par, w, s, u, Fw):
    """``(dw/dt, ds/dt)`` at ``(w, s)`` with input ``u`` and ``Fw = plant_target(par, w, .)``.

    Lagged models: ``(u - s)*(1/J)`` and ``(Fw - s)*(1/tau)`` with the reciprocals of the parameter row (two
    multiplications instead of the two divisions, the largest cost of a step after ``exp``; within an ulp of
    the quotients). LuGre divides as before."""
    J = par[1]
    if par[0] == _LUGRE:
        aw = w if w >= 0.0 else -w
        zdot = w - par[15] * aw / Fw * s
        return (u - par[15] * s - par[16] * zdot - par[7] * w) / J, zdot
    if par[4] == 0.0:
        return (u - Fw) * par[_INV_J], 0.0
    return (u - s) * par[_INV_J], (Fw - s) * par[_INV_TAU]


@kernel(inline="always")
def plant_rk4(par, w, s, Fw, u0, um, u1, h, sgn):
    """One classic fourth-order Runge-Kutta step of the plant, with the input given at three instants.

    Parameters
    ----------
    par : ndarray, shape (PLANT_NPAR,)
        Parameter row of :func:`plant_params`.
    w, s : float
        Velocity (rad/s) and internal state (``f`` N·m, LuGre ``z`` rad) at the step start.
    Fw : float
        ``plant_target(par, w, sgn)``, passed in so a caller can reuse a value it has.
    u0, um, u1 : float
        Input torque (N·m) at the start, the middle and the end of the step
        (``u0 = um = u1``: zero-order hold; ``um = (u0 + u1)/2``: first-order hold).
    h : float
        Step (s), > 0.
    sgn : float
        Karnopp breakaway direction, see :func:`plant_target`.

    Returns
    -------
    (float, float)
        ``(w, s)`` after the step. With ``tau == 0`` (lagged models) the
        friction is algebraic: RK4 integrates ``w`` alone and ``s`` is returned
        unchanged (the caller sets ``f = F(w)``).

    Notes
    -----
    Classic RK4 (Hairer, Nørsett, Wanner, *Solving ODEs I*, Sec. II.1) of
    eqs. 1-2 (lagged models) or of the LuGre equations (module docstring); the
    operations are those of the former Python steps, in the same order.
    """
    h2 = 0.5 * h
    h6 = h / 6.0
    k1w, k1s = _rhs(par, w, s, u0, Fw)
    wa = w + h2 * k1w
    sa = s + h2 * k1s
    k2w, k2s = _rhs(par, wa, sa, um, plant_target(par, wa, sgn))
    wb = w + h2 * k2w
    sb = s + h2 * k2s
    k3w, k3s = _rhs(par, wb, sb, um, plant_target(par, wb, sgn))
    wc = w + h * k3w
    sc = s + h * k3s
    k4w, k4s = _rhs(par, wc, sc, u1, plant_target(par, wc, sgn))
    return (w + h6 * (k1w + 2.0 * k2w + 2.0 * k3w + k4w),
            s + h6 * (k1s + 2.0 * k2s + 2.0 * k3s + k4s))


@kernel
def plant_step(par, st, u, dt):
    """Advance the plant state ``st`` in place by one step of ``dt`` (s) with the torque ``u`` (N·m) held.

    Parameters
    ----------
    par : ndarray, shape (PLANT_NPAR,)
        Parameter row of :func:`plant_params`.
    st : ndarray, shape (PLANT_NSTATE,)
        State (module docstring), updated in place.
    u : float
        Input torque (N·m), zero-order hold over the step.
    dt : float
        Step (s), > 0.

    Notes
    -----
    Lagged models: one :func:`plant_rk4` step (eqs. 1-3; ``tau == 0``: RK4 on
    ``w``, then ``f = F(w)``, which the next step reuses through the cache
    slot). Karnopp: in the band ``|w| < dv`` with ``|u| <= Fs`` the joint
    sticks (``w = 0``, ``f = u``); with ``|u| > Fs`` it breaks away (RK4 with
    the band target ``Fs*sgn(u)``). A lagged model whose fastest mode
    (:func:`lagged_rate`) needs sub-steps takes ``int(rate*dt) + 1`` equal RK4
    sub-steps, and beyond :data:`LAGGED_RK4_MAX` of them (unless the step's own
    velocity range is mild, :func:`lagged_local_rate`) :func:`lagged_stiff_step`
    with the same Karnopp direction. LuGre: ``n`` equal RK4 sub-steps, ``n``
    chosen from the stiffness at the step start so that each stays well inside
    RK4's stability region (:meth:`plant.lugre.LuGreParams.make_step`); with
    ``n > LUGRE_RK4_MAX`` (a stiff bristle) :func:`lugre_stiff_step` instead; a
    non-finite state or input gives NaN. Bit for bit the former Python steps
    of each model. One RK4 call site for all models (the lagged ones run one
    sub-step), which keeps the compiled step small and fast.

    A compiled call, not inlined at the numba IR level: the model dispatch
    (LuGre's implicit step included) would otherwise be re-typed inside every
    kernel that steps a plant, which made the closed-loop engine take minutes
    to compile; its small callees (RK4, right-hand side, eq. 3) are inlined
    here. A calling loop that allocates nothing can be compiled with
    ``_nrt=False`` (as :func:`plant_simulate`), which removes numba's
    reference counting around the call.
    """
    w = st[0]
    s = st[1]
    sgn = 0.0
    n = 1
    h = dt
    lugre = par[0] == _LUGRE
    if lugre:
        aw = w if w >= 0.0 else -w
        # bound |w| over the step by its start value plus the largest acceleration
        rate = par[15] * (aw + (abs(u) + par[18] + par[7] * aw) * dt / par[1]) / par[17] + par[19]
        x = rate * dt
        if not x < 1e15:  # non-finite state or input: no step count exists
            st[0] = math.nan
            st[1] = math.nan
            return
        n = int(x) + 1
        h = dt / n
        if n > LUGRE_RK4_MAX:  # stiff: the bristle state and the joint integrated as a linear system per sub-step
            lugre_stiff_step(par, st, u, dt)
            return
    else:
        dv = par[14]
        if -dv < w < dv:  # Karnopp stick band (dv = 0: never)
            Fs = par[13]
            if -Fs <= u <= Fs:
                st[0] = 0.0
                st[1] = u
                st[2] = math.nan
                return
            sgn = 1.0 if u > 0.0 else -1.0
        x = par[_RATE] * dt
        if x > RK4_RATE_MAX:  # a stiff mode: equal sub-steps with rate*h < 1 (accurate, not only stable)
            if not x < LAGGED_RK4_MAX and sgn == 0.0:  # the stiffness of this step alone
                x = lagged_local_rate(par, w, s, u, dt) * dt
            if not x < LAGGED_RK4_MAX:  # more than LAGGED_RK4_MAX sub-steps: implicit, error-controlled
                lagged_stiff_step(par, st, u, dt, sgn)
                return
            if x > RK4_RATE_MAX:
                n = int(x) + 1
                h = dt / n
    static = par[4] == 0.0 and not lugre
    cached = static and sgn == 0.0 and st[2] == par[_KEY]  # s = F(w) of these parameters
    for i in range(n):
        Fw = s if cached and i == 0 else plant_target(par, w, sgn)
        w, s = plant_rk4(par, w, s, Fw, u, u, u, h, sgn)
    if static:
        s = plant_target(par, w, sgn)
        st[2] = par[_KEY]
    else:
        st[2] = math.nan
    st[0] = w
    st[1] = s


#: Lagged-model steps whose RK4 sub-step count (``int(rate*dt) + 1``, :func:`lagged_rate`) would exceed this use
#: :func:`lagged_stiff_step`; at or below it the RK4 sub-steps (and their results, bit for bit) are kept.
LAGGED_RK4_MAX = 64
#: Relative tolerance (to ``|w| + Vs``) of the sub-step error control of :func:`lagged_stiff_step` on the velocity.
LAGGED_RTOL = 1e-5
#: Tolerance of the same error control on the friction state (``tau > 0``), relative to the largest friction level.
LAGGED_FTOL = 1e-4
#: Most sub-steps :func:`lagged_stiff_step` takes in one step before it gives up (NaN state: diverged).
LAGGED_MAX_SUBSTEPS = 200000


@kernel
def lagged_local_rate(par, w, f, u, dt):
    """Fastest stable mode (1/s) of a lagged model over the velocities it can reach within ``dt`` from ``(w, f)``.

    Parameters
    ----------
    par : ndarray, shape (PLANT_NPAR,)
        Parameter row of a lagged model.
    w, f : float
        Velocity (rad/s) and friction state (N·m) at the step start.
    u : float
        Torque (N·m), held.
    dt : float
        Step (s).

    Returns
    -------
    float
        :func:`lagged_rate` with the steepest rise of the map taken over ``|w| +- D`` only,
        ``D = 2*dt*(|u| + max(|f|, Fmax + sigma*|w|))/J`` (twice the largest speed change: the joint cannot leave
        this range within the step); ``inf`` when the range reaches a jump of the map (``w = 0``, the Karnopp band
        ``|w| <= dv``) or the state is not finite.

    Notes
    -----
    The rise of eq. 3, ``-dF*delta*x**(delta-1)*exp(-x**delta)/Vs`` at ``x = |w|/Vs`` where ``dF*delta < 0``, is
    largest at ``x**delta = 1 - 1/delta`` (:func:`lagged_rate`); over an interval it is largest at that point
    clipped into the interval (one maximum; for ``0 < delta < 1`` it falls with ``x``).
    """
    J = par[1]
    tau = par[4]
    aw = w if w >= 0.0 else -w
    pos = w > 0.0
    dF = par[6] if pos else par[10]
    sig = par[7] if pos else par[11]
    Fmax = max(max(par[5], par[5] + par[6]), max(par[9], par[9] + par[10]), par[13])
    D = 2.0 * dt * (abs(u) + max(abs(f), Fmax + max(par[7], par[11]) * aw)) / J
    lo = aw - D
    if not lo > par[14]:  # reaches the jump at 0 or the Karnopp band (or a NaN state)
        return math.inf
    delta = par[3]
    Vs = par[2]
    rise = 0.0
    if dF * delta < 0.0:
        x = 0.0
        if delta >= 1.0 or delta < 0.0:
            x = (1.0 - 1.0 / delta) ** (1.0 / delta)
        xl = lo / Vs
        xh = (aw + D) / Vs
        x = xl if x < xl else (xh if x > xh else x)
        y = x ** delta
        rise = abs(dF * delta) * x ** (delta - 1.0) * math.exp(-y) / Vs
    s = (sig if sig > 0.0 else 0.0) + rise
    if tau > 0.0:
        return max(1.0 / tau, math.sqrt(s / (J * tau)))
    return s / J


@kernel(inline="always")
def _be_residual(par, w, sgn, c, k, r, w0, d):
    """``d*(c*(w - w0) + k*F(w) - r)``: the backward-Euler residual of :func:`lagged_implicit_step`, oriented."""
    return d * (c * (w - w0) + k * plant_target(par, w, sgn) - r)


@kernel
def _be_root(par, sgn, c, k, r, w0, d, lo, plo, hi, phi):
    """A root of the oriented residual in the bracket ``(lo, hi)`` (``plo < 0 <= phi``): Illinois regula falsi,
    with a bisection after three iterations that did not halve the bracket (Dahlquist & Björck, *Numerical
    Methods*, Sec. 6.2). Returns ``hi`` once ``|hi - lo| <= 1e-13*(|lo| + |hi| + Vs)``."""
    tol = 1e-13 * (abs(lo) + abs(hi) + par[2])
    side = 0
    stall = 0
    for _ in range(300):
        width = abs(hi - lo)
        if not width > tol:
            break
        x = hi - phi * (hi - lo) / (phi - plo)
        if stall >= 3 or not (abs(x - lo) < width and abs(x - hi) < width):
            x = 0.5 * (lo + hi)
            stall = 0
        px = _be_residual(par, x, sgn, c, k, r, w0, d)
        if px >= 0.0:
            hi = x
            phi = px
            if side == 1:
                plo *= 0.5
            side = 1
            if px == 0.0:
                break
        else:
            lo = x
            plo = px
            if side == -1:
                phi *= 0.5
            side = -1
        stall = stall + 1 if abs(hi - lo) > 0.5 * width else 0
    return hi


@kernel
def lagged_implicit_step(par, w0, f0, u, h, sgn):
    """One backward-Euler step of a lagged model (lagged Stribeck, asymmetric, Karnopp) over ``h`` (s).

    Parameters
    ----------
    par : ndarray, shape (PLANT_NPAR,)
        Parameter row of a lagged model (:func:`plant_params`).
    w0, f0 : float
        Velocity (rad/s) and friction state (N·m) at the start (``f0`` unused for ``tau == 0``).
    u : float
        Torque (N·m), held.
    h : float
        Step (s), > 0.
    sgn : float
        Karnopp breakaway direction (:func:`plant_target`).

    Returns
    -------
    (float, float, float)
        ``(w, f, Fstar)`` after ``h``: the velocity, the friction state (``tau == 0``: the friction) and the
        value ``Fstar`` of the static map the step used (at a jump of the map, the value inside the jump that
        balances the step: sticking).

    Notes
    -----
    ``J*(w - w0) = h*(u - f)`` and ``tau*(f - f0) = h*(F(w) - f)`` (eqs. 1-2; ``f = F(w)`` for ``tau == 0``)
    reduce to one scalar equation ``c*(w - w0) + k*F(w) = r`` with ``a = h/tau``, ``c = J*(1 + a)``, ``k = h*a``,
    ``r = h*((1 + a)*u - f0)`` (``tau == 0``: ``c = J``, ``k = h``, ``r = h*u``). It is solved in the direction
    ``d = sgn(r - k*F(w0))`` the joint accelerates in, between ``w0`` and a bound where the ``c`` term dominates
    ``F`` (at most the largest level plus ``sigma*|w0|``), walking across the jumps of ``F`` (at ``w = 0``, or at
    the Karnopp band edges ``±dv``): where the residual jumps across zero the map is set-valued there (Filippov;
    Karnopp 1985) and the step ends on the jump (the joint sticks at ``w = 0``, ``|u|`` inside the static band).
    A rising map (``delta < 0`` or a viscous slope) makes the residual increasing, so the root is unique; backward
    Euler is L-stable (Hairer & Wanner, *Solving ODEs II*, Sec. IV.3), so any slope is damped for every ``h``.
    """
    J = par[1]
    tau = par[4]
    dv = par[14]
    if tau > 0.0:
        a = h / tau
        c = J * (1.0 + a)
        k = h * a
        r = h * ((1.0 + a) * u - f0)
    else:
        a = 0.0
        c = J
        k = h
        r = h * u
    start = w0
    if (w0 == 0.0 and dv == 0.0) or (dv > 0.0 and (w0 == dv or w0 == -dv)):  # on a jump of the map
        Flo = plant_target(par, np.nextafter(w0, -math.inf), sgn)
        Fhi = plant_target(par, np.nextafter(w0, math.inf), sgn)
        if k * Flo <= r <= k * Fhi:  # F(w0) is the interval [Flo, Fhi] and holds the joint: it stays
            Fstar = r / k
            return w0, (f0 + a * Fstar) / (1.0 + a) if tau > 0.0 else Fstar, Fstar
        d = 1.0 if r > k * Fhi else -1.0
        start = np.nextafter(w0, d * math.inf)
    else:
        g = r - k * plant_target(par, w0, sgn)
        if g == 0.0 or not g == g:
            Fstar = plant_target(par, w0, sgn) if g == g else math.nan
            return w0 if g == g else math.nan, (f0 + a * Fstar) / (1.0 + a) if tau > 0.0 else Fstar, Fstar
        d = 1.0 if g > 0.0 else -1.0
    Fbar = max(max(par[5], par[5] + par[6]), max(par[9], par[9] + par[10]), par[13])
    Fbar += max(par[7], par[11]) * abs(w0)
    hi = w0 + d * (abs(r) + k * Fbar) / c
    hi = hi + d * 1e-15 * (abs(hi) + par[2])  # strictly past the bound
    plo = _be_residual(par, start, sgn, c, k, r, w0, d)
    phi = _be_residual(par, hi, sgn, c, k, r, w0, d)
    for i in range(2):  # the jumps of the map ahead of the start, in the direction of motion
        p = (0.0 if i == 0 else math.nan) if dv == 0.0 else (-d * dv if i == 0 else d * dv)
        if not (d * (p - start) > 0.0 and d * (hi - p) > 0.0):
            continue
        before = np.nextafter(p, -d * math.inf)
        pb = _be_residual(par, before, sgn, c, k, r, w0, d)
        if pb >= 0.0:
            hi = before
            phi = pb
            break
        after = np.nextafter(p, d * math.inf)
        pa = _be_residual(par, after, sgn, c, k, r, w0, d)
        if pa >= 0.0:  # the residual jumps across zero: the step ends on the jump
            Fstar = (r - c * (p - w0)) / k
            return p, (f0 + a * Fstar) / (1.0 + a) if tau > 0.0 else Fstar, Fstar
        start = after
        plo = pa
    if phi <= 0.0:
        w = hi
    elif plo >= 0.0:
        w = start
    else:
        w = _be_root(par, sgn, c, k, r, w0, d, start, plo, hi, phi)
    Fstar = (r - c * (w - w0)) / k
    return w, (f0 + a * Fstar) / (1.0 + a) if tau > 0.0 else Fstar, Fstar


@kernel(inline="always")
def _region(par, w):
    """Which smooth piece of the lagged map ``w`` lies on: -2/2 below/above the jump(s), 0 inside the Karnopp band,
    odd on a jump point (``w = 0``, or ``w = -dv``/``dv``)."""
    dv = par[14]
    if dv == 0.0:
        return -2 if w < 0.0 else (2 if w > 0.0 else 1)
    if w < -dv:
        return -2
    if w > dv:
        return 2
    return -1 if w == -dv else (1 if w == dv else 0)


@kernel
def lagged_stiff_step(par, st, u, dt, sgn):
    """Advance a stiff lagged model by ``dt`` (s) with ``u`` (N·m) held: error-controlled implicit sub-steps.

    Parameters
    ----------
    par : ndarray, shape (PLANT_NPAR,)
        Parameter row of a lagged model (lagged Stribeck, asymmetric, Karnopp).
    st : ndarray, shape (PLANT_NSTATE,)
        ``[w, f, h]``: velocity (rad/s), friction state (N·m), the last sub-step (s; any value outside
        ``(0, dt]``: none yet, then ``dt``); updated in place. NaN state for a non-finite state or input or after
        :data:`LAGGED_MAX_SUBSTEPS` sub-steps (treated as diverged).
    u : float
        Torque (N·m).
    dt : float
        Step (s), > 0.
    sgn : float
        Karnopp breakaway direction (:func:`plant_target`), fixed over the step as in the RK4 path.

    Notes
    -----
    The scheme of :func:`lugre_stiff_step` on eqs. 1-3: a sub-step ``h`` of :func:`lagged_implicit_step` and two
    of ``h/2`` give the error estimate (step doubling, Hairer, Nørsett & Wanner, *Solving ODEs I*, Sec. II.4),
    accepted when ``|w_(h/2) - w_h| <= LAGGED_RTOL*(|w| + Vs)`` and (``tau > 0``)
    ``|f_(h/2) - f_h| <= LAGGED_FTOL*max level``. Where all three solutions stay on one smooth piece of the map
    (:func:`_region`) the result is the extrapolation ``2*y_(h/2) - y_h`` (second order, A-stable, *Solving ODEs
    II*, Sec. IV.9); across a jump of the map (a reversal, a stick) it is ``y_(h/2)`` itself, which the
    set-valued solve keeps on the jump. The next ``h`` scales with ``0.9/sqrt(err)``, clipped to [0.2, 2].
    """
    w = st[0]
    f = st[1]
    h = st[2]
    if not (h > 0.0 and h <= dt):
        h = dt
    tau = par[4]
    Vs = par[2]
    tol_f = LAGGED_FTOL * max(max(par[5], par[5] + par[6]), max(par[9], par[9] + par[10]), par[13], 1e-300)
    t = 0.0
    count = 0
    while t < dt:
        if count >= LAGGED_MAX_SUBSTEPS or not (w - w == 0.0 and f - f == 0.0 and u - u == 0.0):
            st[0] = math.nan
            st[1] = math.nan
            st[2] = math.nan
            return
        count += 1
        last = h >= dt - t
        hh = dt - t if last else h
        w1, f1, F1 = lagged_implicit_step(par, w, f, u, hh, sgn)
        wm, fm, Fm = lagged_implicit_step(par, w, f, u, 0.5 * hh, sgn)
        w2, f2, F2 = lagged_implicit_step(par, wm, fm, u, 0.5 * hh, sgn)
        err = abs(w2 - w1) / (LAGGED_RTOL * (abs(w2) + Vs))
        if tau > 0.0:
            ef = abs(f2 - f1) / tol_f
            err = err if err > ef else ef
        if not err == err:
            err = math.inf
        if err <= 1.0:
            t = dt if last else t + hh
            reg = _region(par, w2)
            we = 2.0 * w2 - w1
            smooth = reg % 2 == 0 and _region(par, w) == reg and _region(par, w1) == reg and _region(par, wm) == reg
            if smooth and _region(par, we) == reg:
                w = we
                f = 2.0 * f2 - f1 if tau > 0.0 else plant_target(par, we, sgn)
            else:
                w = w2
                f = f2
        fac = 0.9 / math.sqrt(err) if err > 0.0 else 2.0
        h = hh * (2.0 if fac > 2.0 else (0.2 if fac < 0.2 else fac))
    st[0] = w
    st[1] = f
    st[2] = h


#: LuGre steps whose RK4 sub-step count (stiffness bound of :func:`plant_step`) exceeds this use
#: :func:`lugre_stiff_step`; at or below it the RK4 sub-steps (and their results) are kept.
LUGRE_RK4_MAX = 64
#: Relative tolerance of the sub-step error control of :func:`lugre_stiff_step`.
LUGRE_RTOL = 1e-5
#: Tolerance of the same error control on the bristle deflection, relative to the largest one ``max(Fc, Fs)/sigma0``
#: (the deflection relaxes at the rate ``sigma0*|w|/g(w)``: its error does not accumulate while sliding).
LUGRE_ZTOL = 1e-3
#: Most sub-steps :func:`lugre_stiff_step` takes in one step before it gives up (NaN state: diverged).
LUGRE_MAX_SUBSTEPS = 200000


@kernel
def lugre_jacobian(par, w, z, u):
    """Right-hand side of the LuGre joint and its Jacobian at ``(w, z)`` with the torque ``u`` (N·m).

    Parameters
    ----------
    par : ndarray, shape (PLANT_NPAR,)
        LuGre parameter row (:func:`plant_params`).
    w, z : float
        Velocity (rad/s), bristle deflection (rad).
    u : float
        Torque (N·m).

    Returns
    -------
    (float, float, float, float, float, float)
        ``dw/dt, dz/dt`` and the Jacobian entries ``d(dw/dt)/dw, d(dw/dt)/dz, d(dz/dt)/dw, d(dz/dt)/dz``.

    Notes
    -----
    Canudas de Wit et al. (1995) (module docstring): with ``a(w) = sigma0*|w|/g(w)``,
    ``a'(w) = sgn(w)*sigma0*(g - |w|*dg/d|w|)/g**2`` and ``|w|*dg/d|w| = -(g - Fc)*delta*(|w|/Vs)**delta``
    (derivative of eq. 3; ``g`` from :func:`plant_target`); ``a'(0) = 0`` (the kink of ``|w|``).
    """
    J = par[1]
    s0 = par[15]
    s1 = par[16]
    s2 = par[7]
    aw = w if w >= 0.0 else -w
    g = plant_target(par, w, 0.0)
    a = s0 * aw / g
    fz = w - a * z
    fw = (u - s0 * z - s1 * fz - s2 * w) / J
    da = 0.0
    if aw > 0.0:
        x = aw / par[2]
        p = x if par[3] == 1.0 else x ** par[3]
        r = g - par[5]
        da = s0 * (g + (r * par[3] * p if r != 0.0 else 0.0)) / (g * g)
        if w < 0.0:
            da = -da
    dzw = 1.0 - da * z
    return fw, fz, (-s1 * dzw - s2) / J, (-s0 + s1 * a) / J, dzw, -a


@kernel
def lugre_implicit_step(par, w0, z0, u, h):
    """One backward-Euler step of the LuGre joint over ``h`` (s), solved by Newton's method.

    Parameters
    ----------
    par : ndarray, shape (PLANT_NPAR,)
        LuGre parameter row.
    w0, z0 : float
        Velocity (rad/s) and deflection (rad) at the start.
    u : float
        Torque (N·m), held.
    h : float
        Step (s), > 0.

    Returns
    -------
    (float, float, bool)
        ``(w, z)`` after ``h`` and whether Newton's iteration converged (at most 30 iterations, to ``1e-12``
        relative to ``|w| + Vs`` and to ``max(Fc, Fs)/sigma0``).

    Notes
    -----
    ``y1 = y0 + h f(y1)`` (Hairer & Wanner, *Solving ODEs II*, Sec. IV.3: L-stable, so the stiff bristle modes
    are damped for every ``h``), Jacobian of :func:`lugre_jacobian`.
    """
    w = w0
    z = z0
    zs = par[18] / par[15]
    for _ in range(30):
        fw, fz, jww, jwz, jzw, jzz = lugre_jacobian(par, w, z, u)
        g1 = w - w0 - h * fw
        g2 = z - z0 - h * fz
        m11 = 1.0 - h * jww
        m12 = -h * jwz
        m21 = -h * jzw
        m22 = 1.0 - h * jzz
        det = m11 * m22 - m12 * m21
        dw = (g1 * m22 - m12 * g2) / det
        dz = (m11 * g2 - m21 * g1) / det
        w -= dw
        z -= dz
        if abs(dw) <= 1e-12 * (abs(w) + par[2]) and abs(dz) <= 1e-12 * zs:
            return w, z, True
    return w, z, False


@kernel
def lugre_stiff_step(par, st, u, dt):
    """Advance a stiff LuGre joint by ``dt`` (s) with ``u`` (N·m) held: error-controlled implicit sub-steps.

    Parameters
    ----------
    par : ndarray, shape (PLANT_NPAR,)
        LuGre parameter row.
    st : ndarray, shape (PLANT_NSTATE,)
        ``[w, z, h]``: velocity (rad/s), deflection (rad), the last sub-step (s; NaN: none yet, then ``dt``);
        updated in place. NaN state after :data:`LUGRE_MAX_SUBSTEPS` sub-steps (treated as diverged).
    u : float
        Torque (N·m).
    dt : float
        Step (s), > 0.

    Notes
    -----
    Extrapolated backward Euler (Hairer & Wanner, *Solving ODEs II*, Sec. IV.9): a sub-step ``h`` of
    :func:`lugre_implicit_step` and two of ``h/2`` give ``y = 2*y_(h/2) - y_h`` (second order; its stability
    function ``2/(1 - z/2)**2 - 1/(1 - z)`` is A-stable and vanishes at infinity); accepted when
    ``|w_(h/2) - w_h| <= rtol*(|w| + Vs)`` and ``|z_(h/2) - z_h| <= ztol*max(Fc, Fs)/sigma0``
    (:data:`LUGRE_RTOL`, :data:`LUGRE_ZTOL`; step doubling, *Solving ODEs I*, Sec. II.4); the next ``h``
    scales with ``0.9/sqrt(err)``, clipped to [0.2, 2]. No sub-step crosses the end of ``dt``.
    """
    w = st[0]
    z = st[1]
    h = st[2]
    if not (h > 0.0 and h <= dt):
        h = dt
    tol_z = LUGRE_ZTOL * par[18] / par[15]
    t = 0.0
    count = 0
    while t < dt:
        if count >= LUGRE_MAX_SUBSTEPS or not (w == w and z == z):
            st[0] = math.nan
            st[1] = math.nan
            st[2] = math.nan
            return
        count += 1
        last = h >= dt - t
        hh = dt - t if last else h
        w1, z1, ok1 = lugre_implicit_step(par, w, z, u, hh)
        wm, zm, ok2 = lugre_implicit_step(par, w, z, u, 0.5 * hh)
        w2, z2, ok3 = lugre_implicit_step(par, wm, zm, u, 0.5 * hh)
        err = math.inf
        if ok1 and ok2 and ok3:
            ew = abs(w2 - w1) / (LUGRE_RTOL * (abs(w2) + par[2]))
            ez = abs(z2 - z1) / tol_z
            err = ew if ew > ez else ez
        if err <= 1.0:
            t = dt if last else t + hh
            w = 2.0 * w2 - w1
            z = 2.0 * z2 - z1
        fac = 0.9 / math.sqrt(err) if err > 0.0 else 2.0
        h = hh * (2.0 if fac > 2.0 else (0.2 if fac < 0.2 else fac))
    st[0] = w
    st[1] = z
    st[2] = h


@kernel
def plant_friction(par, st):
    """Friction torque (N·m) of the plant in state ``st``.

    Parameters
    ----------
    par : ndarray, shape (PLANT_NPAR,)
        Parameter row of :func:`plant_params`.
    st : ndarray, shape (PLANT_NSTATE,)
        State.

    Returns
    -------
    float
        Lagged models: the friction state ``f`` (eq. 1). LuGre:
        ``sigma0*z + sigma1*dz/dt + sigma2*w`` (Canudas de Wit et al. 1995, eq. 3).
    """
    if par[0] != _LUGRE:
        return st[1]
    w = st[0]
    z = st[1]
    aw = abs(w)
    g = plant_target(par, w, 0.0)  # g(|w|); any positive value at w = 0, where aw/g = 0
    zdot = w - par[15] * aw / g * z
    return par[15] * z + par[16] * zdot + par[7] * w


@kernel(_nrt=False)
def plant_simulate(par, st, u, dt, W, S):
    """Open loop: ``plant_step`` over the inputs ``u`` (N·m, each held for ``dt`` s), recording every state.

    Parameters
    ----------
    par : ndarray, shape (PLANT_NPAR,)
        Parameter row.
    st : ndarray, shape (PLANT_NSTATE,)
        Initial state, advanced in place to the final one.
    u : ndarray, shape (N,)
        Inputs (N·m).
    dt : float
        Step (s).
    W, S : ndarray, shape (N + 1,)
        Filled with the velocity (rad/s) and the internal state, initial state included.
    """
    W[0] = st[0]
    S[0] = st[1]
    for k in range(u.shape[0]):
        plant_step(par, st, u[k], dt)
        W[k + 1] = st[0]
        S[k + 1] = st[1]


@kernel
def _step_ws(par, st, w, s, u, dt):
    st[0] = w
    st[1] = s
    st[2] = math.nan
    plant_step(par, st, u, dt)
    return st[0], st[1]


def make_plant_step(p, dt: float) -> Callable[[float, float, float], tuple]:
    """One step ``(w, s, u) -> (w, s)`` of the plant model ``p`` over ``dt`` (s), ``u`` held: :func:`plant_step`.

    Parameters
    ----------
    p : JointParams, AsymmetricParams, KarnoppParams or LuGreParams
        Frozen plant model.
    dt : float
        Step (s), > 0.

    Returns
    -------
    callable
        ``step(w, s, u)`` returning the state after ``dt`` as a tuple of floats
        (``s``: the friction state, or the LuGre deflection). Each call starts
        without the eq. 3 cache (``tau == 0``: ``F(w)`` is evaluated afresh).

    Raises
    ------
    ParameterError
        ``dt`` not > 0.
    TypeError
        ``p`` is not one of the four frozen models.
    """
    dt = check_positive("dt", dt)
    par = plant_params(p)
    st = np.empty(PLANT_NSTATE)

    def step(w: float, s: float, u: float) -> tuple:
        return _step_ws(par, st, float(w), float(s), float(u), dt)

    return step
