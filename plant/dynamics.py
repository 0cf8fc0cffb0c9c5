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
20    ``key``         fingerprint of slots 0-19 (an integer in [1, 2**52)), see state slot 2
====  ==============  ===========================================================

State (:data:`PLANT_NSTATE` = 3): ``st[0]`` velocity ``w`` (rad/s);
``st[1]`` the model's internal state (the friction torque ``f`` in N·m, for
LuGre the bristle deflection ``z`` in rad); ``st[2]`` equals ``key`` when
``st[1]`` is ``F(st[0])`` of these parameters with ``tau == 0`` (set by
:func:`plant_step` and :func:`plant_state`), so the next step reuses it instead
of evaluating eq. 3 again; any other value (e.g. NaN) means "not cached".
Swapping the parameter row (a drifting plant) invalidates it by the key.
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
           "plant_target", "plant_rk4", "plant_step", "plant_friction", "plant_simulate", "make_plant_step"]

#: Model codes of slot 0.
MODEL_CODES = {"lagged-stribeck": 0, "asymmetric": 1, "karnopp": 2, "lugre": 3}
#: Slot names of the parameter row -> index (see the module docstring).
PLANT_SLOTS = {name: i for i, name in enumerate((
    "code", "J", "Vs", "delta", "tau", "Fc_pos", "dF_pos", "sigma_pos", "wcut_pos", "Fc_neg", "dF_neg",
    "sigma_neg", "wcut_neg", "Fs_stick", "dv", "sigma0", "sigma1", "g_min", "g_max", "base_rate", "key"))}
#: Length of the parameter row.
PLANT_NPAR = len(PLANT_SLOTS)
#: Length of the state array: w, the model's internal state, the eq. 3 cache key.
PLANT_NSTATE = 3

_LUGRE = 3.0
_KEY = PLANT_SLOTS["key"]
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
    return _keyed(r)


def _keyed(r: np.ndarray) -> np.ndarray:
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
    """``(dw/dt, ds/dt)`` at ``(w, s)`` with input ``u`` and ``Fw = plant_target(par, w, .)``."""
    J = par[1]
    if par[0] == _LUGRE:
        aw = w if w >= 0.0 else -w
        zdot = w - par[15] * aw / Fw * s
        return (u - par[15] * s - par[16] * zdot - par[7] * w) / J, zdot
    tau = par[4]
    if tau == 0.0:
        return (u - Fw) / J, 0.0
    return (u - s) / J, (Fw - s) / tau


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


@kernel(inline="always")
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
    the band target ``Fs*sgn(u)``). LuGre: ``n`` equal RK4 sub-steps, ``n``
    chosen from the stiffness at the step start so that each stays well inside
    RK4's stability region (:meth:`plant.lugre.LuGreParams.make_step`); a
    non-finite state or input gives NaN. Bit for bit the former Python steps
    of each model. One RK4 call site for all models (the lagged ones run one
    sub-step), which keeps the compiled step small and fast.

    Inlined (numba IR) into the caller. numba adds an atomic reference-count
    increment and decrement of ``par`` and ``st`` around each inlined call; a
    calling loop that allocates nothing can be compiled with ``_nrt=False``
    (as :func:`plant_simulate`), which removes them.
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


@kernel(inline="always")
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
