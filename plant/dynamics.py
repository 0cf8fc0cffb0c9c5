"""The plant as one compiled component: the one RK4 step, the step of every model, and the friction torque.

Every friction model of the package (:mod:`plant.friction` lagged Stribeck, :mod:`plant.asymmetric`,
:mod:`plant.karnopp`, :mod:`plant.lugre`) is packed by :func:`plant_params` into one float64 row of
:data:`PLANT_NPAR` entries, with a state of :data:`PLANT_NSTATE` entries (:func:`plant_state`); the layout, the
models' equations and the friction map :func:`plant_target` are in :mod:`plant.rows`. The compiled
:func:`plant_step` advances the state by one step with the input held, in place (RK4 sub-steps; the implicit steps
of :mod:`plant.stiff` where the plant is stiff); :func:`plant_friction` returns the friction torque. The Python
classes (``make_step``, :func:`plant.joint.simulate`), the identification simulator and the closed-loop engine all
call these kernels. This module re-exports the names of :mod:`plant.rows` and :mod:`plant.stiff`.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from plant.errors import check_positive
from plant.jit import kernel
from plant.rows import (LUGRE_STIFF_MAX, MODEL_CODES, PLANT_NPAR, PLANT_NSTATE, PLANT_SLOTS, RK4_RATE_MAX,
                        check_integrable, integrable_rows, lagged_params, lagged_rate, plant_params, plant_rows,
                        plant_state, plant_states, plant_target)
from plant.stiff import (LAGGED_FTOL, LAGGED_MAX_SUBSTEPS, LAGGED_RK4_MAX, LAGGED_RTOL, LUGRE_MAX_SUBSTEPS,
                         LUGRE_RK4_MAX, LUGRE_RTOL, LUGRE_ZTOL, lagged_implicit_step, lagged_local_rate,
                         lagged_stiff_step, lugre_implicit_step, lugre_jacobian, lugre_stiff_step,
                         static_jump_in_reach)

__all__ = ["PLANT_NPAR", "PLANT_NSTATE", "PLANT_SLOTS", "MODEL_CODES", "plant_params", "lagged_params", "plant_state",
           "plant_target", "plant_rk4", "plant_step", "plant_friction", "plant_simulate", "make_plant_step",
           "lugre_jacobian", "lugre_implicit_step", "lugre_stiff_step", "lagged_implicit_step", "lagged_stiff_step",
           "lagged_local_rate", "check_integrable", "lagged_rate", "RK4_RATE_MAX", "LAGGED_RK4_MAX", "LAGGED_RTOL",
           "LAGGED_FTOL", "LAGGED_MAX_SUBSTEPS", "LUGRE_STIFF_MAX", "LUGRE_RK4_MAX", "LUGRE_RTOL", "LUGRE_ZTOL",
           "LUGRE_MAX_SUBSTEPS", "plant_rows", "plant_states", "integrable_rows"]

_LUGRE = float(MODEL_CODES["lugre"])
_KEY = PLANT_SLOTS["key"]
_RATE = PLANT_SLOTS["rate"]
_INV_J = PLANT_SLOTS["inv_J"]
_INV_TAU = PLANT_SLOTS["inv_tau"]


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
    eqs. 1-2 (lagged models) or of the LuGre equations (module docstring).
    tests/test_plant_kernels.py checks every step against an RK4 tableau on
    arrays written from the equations (tests/plant_oracle.py) to 1e-13.
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
def _single_rk4(par, w, dt):
    """True where :func:`plant_step` takes exactly one RK4 step of ``dt`` with ``sgn = 0``: a lagged model, ``w``
    outside the Karnopp band, no sub-steps (the branch conditions of its general path)."""
    if par[0] == _LUGRE:
        return False
    dv = par[14]
    if -dv < w < dv:
        return False
    return not par[_RATE] * dt > RK4_RATE_MAX


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
    slot). ``tau == 0`` without a Karnopp band: the map jumps at ``w = 0``, and
    a step that can reach it (:func:`plant.stiff.static_jump_in_reach`) is the
    set-valued :func:`lagged_stiff_step` instead (Filippov: at rest while
    ``-F(0-) <= u <= F(0+)``, with ``f = u``; RK4 would creep and chatter
    through the jump). Karnopp: in the band ``|w| < dv`` with ``|u| <= Fs`` the joint
    sticks (``w = 0``, ``f = u``); with ``|u| > Fs`` it breaks away (RK4 with
    the band target ``Fs*sgn(u)``). A lagged model whose fastest mode
    (:func:`lagged_rate`) needs sub-steps takes ``int(rate*dt) + 1`` equal RK4
    sub-steps, and beyond :data:`LAGGED_RK4_MAX` of them (unless the step's own
    velocity range is mild, :func:`lagged_local_rate`) :func:`lagged_stiff_step`
    with the same Karnopp direction. LuGre: ``n`` equal RK4 sub-steps, ``n``
    chosen from the stiffness at the step start so that each stays well inside
    RK4's stability region (:meth:`plant.lugre.LuGreParams.make_step`); with
    ``n > LUGRE_RK4_MAX`` (a stiff bristle) :func:`lugre_stiff_step` instead; a
    non-finite state or input gives NaN. Checked step by step against the
    equations (tests/test_plant_kernels.py), the static steps that reach the
    jump against a Radau + Filippov oracle (tests/test_static_stick.py). The common case (a lagged model with ``tau > 0`` outside the
    Karnopp band, one RK4 step: :func:`_single_rk4`) is tested first and runs
    the same operations without the dispatch below. The general path has one
    RK4 call site for all models (the lagged ones run one sub-step).

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
    if par[4] != 0.0 and _single_rk4(par, w, dt):  # the common case: a lagged model, one RK4 step
        w, s = plant_rk4(par, w, s, plant_target(par, w, 0.0), u, u, u, dt, 0.0)
        st[0] = w
        st[1] = s
        st[2] = math.nan
        return
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
        elif dv == 0.0 and par[4] == 0.0 and static_jump_in_reach(par, w, u, dt):  # F jumps at w = 0: set-valued
            st[2] = math.nan
            lagged_stiff_step(par, st, u, dt, 0.0)
            return
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
