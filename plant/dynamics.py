"""The plant as one C component: the one RK4 step, the step of every model, and the friction torque.

Every friction model of the package (:mod:`plant.friction` lagged Stribeck, :mod:`plant.asymmetric`,
:mod:`plant.karnopp`, :mod:`plant.lugre`) is packed by :func:`plant_params` into one C struct ``plant_params``
with a state struct ``plant_state`` (:func:`plant_state`); the fields, the models' equations and the friction
map :func:`plant_target` are in :mod:`plant.rows`. The C ``plant_step`` (``plant/csrc/plant_dynamics.c``)
advances the state by one step with the input held, in place (RK4 sub-steps; the implicit steps of
:mod:`plant.stiff` where the plant is stiff); ``plant_friction`` returns the friction torque. The Python
classes (``make_step``, :func:`plant.joint.simulate`), the identification simulator and the closed-loop engine
all call these C functions; the functions here are their Python entries. This module re-exports the names of
:mod:`plant.rows` and :mod:`plant.stiff`.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from plant._cplant import ffi, lib
from plant.errors import check_positive
from plant.rows import (LUGRE_STIFF_MAX, MODEL_CODES, RK4_RATE_MAX, check_integrable, integrable_rows,
                        lagged_params, lagged_rate, plant_params, plant_rows, plant_state, plant_states,
                        plant_target, stack_params, stack_states)
from plant.stiff import (LAGGED_FTOL, LAGGED_MAX_SUBSTEPS, LAGGED_RK4_MAX, LAGGED_RTOL, LUGRE_MAX_SUBSTEPS,
                         LUGRE_RK4_MAX, LUGRE_RTOL, LUGRE_ZTOL, lagged_implicit_step, lagged_local_rate,
                         lagged_stiff_step, lugre_implicit_step, lugre_jacobian, lugre_stiff_step,
                         static_jump_in_reach)

__all__ = ["MODEL_CODES", "plant_params", "lagged_params", "plant_state", "plant_target", "plant_rk4", "plant_step",
           "plant_friction", "plant_simulate", "make_plant_step", "lugre_jacobian", "lugre_implicit_step",
           "lugre_stiff_step", "lagged_implicit_step", "lagged_stiff_step", "lagged_local_rate", "check_integrable",
           "lagged_rate", "RK4_RATE_MAX", "LAGGED_RK4_MAX", "LAGGED_RTOL", "LAGGED_FTOL", "LAGGED_MAX_SUBSTEPS",
           "LUGRE_STIFF_MAX", "LUGRE_RK4_MAX", "LUGRE_RTOL", "LUGRE_ZTOL", "LUGRE_MAX_SUBSTEPS", "plant_rows",
           "plant_states", "integrable_rows", "stack_params", "stack_states", "static_jump_in_reach"]


def plant_rk4(par, state: tuple, Fw: float, u: tuple, h: float, sgn: float) -> tuple:
    """One classic fourth-order Runge-Kutta step of the plant, with the input given at three instants.

    Parameters
    ----------
    par : cffi ``plant_params *``
        Parameters of :func:`plant_params`.
    state : tuple of float
        ``(w, s)`` or ``(w, s, q)`` at the step start: velocity (rad/s), internal state (``f`` N·m, LuGre ``z``
        rad) and joint position (rad; read by a friction ripple only, ``Fw`` is then the map at ``q``; default 0).
    Fw : float
        ``plant_target(par, w, sgn)``, passed in so a caller can reuse a value it has.
    u : tuple of float
        ``(u0, um, u1)``: input torque (N·m) at the start, the middle and the end of the step
        (``u0 = um = u1``: zero-order hold; ``um = (u0 + u1)/2``: first-order hold).
    h : float
        Step (s), > 0.
    sgn : float
        Karnopp breakaway direction, see :func:`plant_target`.

    Returns
    -------
    (float, float)
        ``(w, s)`` after the step (the position is advanced too, ``dq/dt = w``, but not returned). With
        ``tau == 0`` (lagged models) the friction is algebraic: RK4 integrates ``w`` alone and ``s`` is
        returned unchanged (the caller sets ``f = F(w)``).

    Notes
    -----
    Classic RK4 (Hairer, Nørsett, Wanner, *Solving ODEs I*, Sec. II.1) of
    eqs. 1-2 (lagged models, multiplying by ``inv_J`` and ``inv_tau``) or of the
    LuGre equations (module docstring of :mod:`plant.rows`): C (``plant/csrc/plant_dynamics.c``,
    ``plant_rk4``, in place on ``double *w, *s``). tests/plant_layer/test_plant_kernels.py checks every step against
    an RK4 tableau on arrays written from the equations (tests/plant_oracle.py) to 1e-13.
    """
    w, s, q = (*state, 0.0) if len(state) == 2 else state
    u0, um, u1 = u
    ws = ffi.new("double[3]", (w, s, q))
    lib.plant_rk4_at(par, ws, ws + 1, ws + 2, Fw, u0, um, u1, h, sgn)
    return ws[0], ws[1]


def plant_step(par, st, u: float, dt: float) -> None:
    """Advance the plant state ``st`` in place by one step of ``dt`` (s) with the torque ``u`` (N·m) held.

    Parameters
    ----------
    par : cffi ``plant_params *``
        Parameters of :func:`plant_params` (an element ``b`` of a table: ``rows + b``).
    st : cffi ``plant_state *``
        State (:mod:`plant.rows`), updated in place.
    u : float
        Input torque (N·m), zero-order hold over the step.
    dt : float
        Step (s), > 0.

    Notes
    -----
    C (``plant/csrc/plant_dynamics.c``, ``plant_step``). Lagged models: one :func:`plant_rk4` step (eqs. 1-3;
    ``tau == 0``: RK4 on ``w``, then ``f = F(w)``, which the next step reuses through the cache field ``aux``).
    ``tau == 0`` without a Karnopp band: the map jumps at ``w = 0``, and a step that can reach it
    (:func:`plant.stiff.static_jump_in_reach`) is the set-valued :func:`lagged_stiff_step` instead (Filippov: at
    rest while ``-F(0-) <= u <= F(0+)``, with ``f = u``; RK4 would creep and chatter through the jump). Karnopp:
    in the band ``|w| < dv`` with ``|u| <= Fs`` the friction is at most ``Fs`` (Karnopp 1985): the joint sticks
    (``w = 0``, ``f = u``) where the step's stopping friction ``u + J*w/dt`` is within ``[-Fs, Fs]``, else it
    slides the step decelerated by ``f = Fs*sgn(w)``; with ``|u| > Fs`` it breaks away (RK4 with the band target
    ``Fs*sgn(u)``). A lagged model whose fastest mode (:func:`lagged_rate`)
    needs sub-steps takes ``int(rate*dt) + 1`` equal RK4 sub-steps, and beyond :data:`LAGGED_RK4_MAX` of them
    (unless the step's own velocity range is mild, :func:`lagged_local_rate`) :func:`lagged_stiff_step` with the
    same Karnopp direction. LuGre: ``n`` equal RK4 sub-steps, ``n`` chosen from the stiffness at the step start so
    that each stays well inside RK4's stability region (:meth:`plant.lugre.LuGreParams.make_step`); with
    ``n > LUGRE_RK4_MAX`` (a stiff bristle) :func:`lugre_stiff_step` instead; a non-finite state or input gives
    NaN. Checked step by step against the equations (tests/plant_layer/test_plant_kernels.py), the static steps that reach
    the jump against a Radau + Filippov oracle (tests/plant_layer/test_static_stick.py).
    """
    lib.plant_step(par, st, u, dt)


def plant_friction(par, st) -> float:
    """Friction torque (N·m) of the plant in state ``st``.

    Parameters
    ----------
    par : cffi ``plant_params *``
        Parameters of :func:`plant_params`.
    st : cffi ``plant_state *``
        State.

    Returns
    -------
    float
        Lagged models: the friction state ``f`` (eq. 1). LuGre:
        ``sigma0*z + sigma1*dz/dt + sigma2*w`` (Canudas de Wit et al. 1995, eq. 3).
        C (``plant/csrc/plant_dynamics.c``, ``plant_friction``).
    """
    return lib.plant_friction(par, st)


def _doubles(name: str, a, n: int):
    """``a`` as a C ``double[]`` of at least ``n`` entries (a C-contiguous float64 array, shared: no copy)."""
    if not (isinstance(a, np.ndarray) and a.dtype == np.float64 and a.ndim == 1 and a.flags.c_contiguous
            and a.shape[0] >= n):
        raise TypeError(f"{name} must be a C-contiguous 1-D float64 array of at least {n} entries, got "
                        f"{type(a).__name__} {getattr(a, 'dtype', '')} {getattr(a, 'shape', '')}")
    return ffi.from_buffer("double[]", a, require_writable=name != "u")


def plant_simulate(par, st, u, dt: float, W, S, Q=None) -> None:
    """Open loop: ``plant_step`` over the inputs ``u`` (N·m, each held for ``dt`` s), recording every state.

    Parameters
    ----------
    par : cffi ``plant_params *``
        Parameters.
    st : cffi ``plant_state *``
        Initial state, advanced in place to the final one.
    u : ndarray, shape (N,)
        Inputs (N·m), C-contiguous float64.
    dt : float
        Step (s).
    W, S : ndarray, shape (N + 1,)
        Filled with the velocity (rad/s) and the internal state, initial state included (C-contiguous float64).
    Q : ndarray, shape (N + 1,), optional
        Filled with the joint position (rad); None: not recorded.

    Raises
    ------
    TypeError
        An array is not C-contiguous float64 of the needed length.

    Notes
    -----
    C (``plant/csrc/plant_dynamics.c``, ``plant_simulate``): one call for the whole trajectory.
    """
    n = u.shape[0] if isinstance(u, np.ndarray) and u.ndim == 1 else -1
    cu = _doubles("u", u, max(n, 0))
    cq = ffi.NULL if Q is None else _doubles("Q", Q, n + 1)
    lib.plant_simulate(par, st, cu, n, dt, _doubles("W", W, n + 1), _doubles("S", S, n + 1), cq)


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
    st = ffi.new("plant_state *")
    step_c = lib.plant_step

    def step(w: float, s: float, u: float) -> tuple:
        st.w = float(w)
        st.s = float(s)
        st.aux = math.nan
        step_c(par, st, float(u), dt)
        return st.w, st.s

    return step
