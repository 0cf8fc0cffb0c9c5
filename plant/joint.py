"""Lumped-mass joint with lagged friction, integrated by fixed-step RK4 (eqs. 1-3).

State ``x = (w, f)``: velocity (rad/s) and friction torque (N·m)::

    dw/dt = (u - f) / J
    df/dt = (F(w) - f) / tau          (f = F(w) algebraically if tau == 0)

The input ``u`` (N·m) is held constant over each step (zero-order hold), as a
digital drive applies it. The paper simulates this structure (its Fig. 2) with
a fixed-step solver at 1 kHz; ``dt = 1e-3`` s is the default here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from plant.errors import check_finite_scalar, check_positive, check_signal
from plant.friction import JointParams

__all__ = ["make_rk4_step", "lagged_rk4_step", "simulate", "PlantResponse", "DT_DEFAULT"]

#: Default integration step (s): the paper's 1 kHz fixed-step solver.
DT_DEFAULT = 1e-3


def _friction_scalar(p: JointParams) -> Callable[[float], float]:
    """Return a fast scalar F(w) (eq. 3) for parameters ``p`` (plain floats, no numpy)."""
    Fc, dF, Vs, delta, sigma = p.Fc, p.Fs - p.Fc, p.Vs, p.delta, p.sigma

    def F(w: float) -> float:
        if w == 0.0:
            return 0.0
        try:
            s = math.exp(-((abs(w) / Vs) ** delta))
        except OverflowError:  # |w/Vs|**delta beyond the float range (delta < 0, w tiny): shape -> 0
            s = 0.0
        if w > 0.0:
            return Fc + dF * s + sigma * w
        return -(Fc + dF * s) + sigma * w

    return F


def make_rk4_step(p: JointParams, dt: float = DT_DEFAULT) -> Callable[[float, float, float], tuple]:
    """Build one classic RK4 step ``(w, f, u) -> (w, f)`` of the joint, for speed-critical loops.

    Parameters
    ----------
    p : JointParams or another plant model
        Plant parameters. Any other object with a ``make_step(dt)`` method (the
        variants in :mod:`plant.lugre`, :mod:`plant.karnopp`,
        :mod:`plant.asymmetric`) is delegated to it; the second state slot is
        then that model's internal state (e.g. the LuGre bristle deflection ``z``).
    dt : float
        Step (s), > 0.

    Returns
    -------
    callable
        ``step(w, f, u)`` returning the state after ``dt`` with ``u`` held.
        For ``tau == 0`` the returned ``f`` is ``F(w)`` at the new velocity.

    Raises
    ------
    ParameterError
        ``dt`` not > 0.

    Notes
    -----
    Classic fourth-order Runge-Kutta (e.g. Hairer, Nørsett, Wanner, *Solving
    ODEs I*, Sec. II.1). ``F`` is discontinuous at ``w = 0``; with ``tau > 0``
    the lag integrates it, so ``dw/dt`` stays continuous.
    """
    if not isinstance(p, JointParams):
        make = getattr(p, "make_step", None)
        if make is None:
            raise TypeError(f"p must be JointParams or a plant model with make_step(dt), got {type(p).__name__}")
        return make(dt)
    dt = check_positive("dt", dt)
    return lagged_rk4_step(_friction_scalar(p), J=p.J, tau=p.tau, dt=dt)


def lagged_rk4_step(F: Callable[[float], float], *, J: float, tau: float,
                    dt: float) -> Callable[[float, float, float], tuple]:
    """RK4 step ``(w, f, u) -> (w, f)`` of ``J*dw/dt = u - f``, ``tau*df/dt + f = F(w)`` for any scalar map ``F``.

    Parameters
    ----------
    F : callable
        Static friction map ``F(w)`` (N·m) on plain floats, e.g. eq. 3 or an asymmetric variant.
    J : float, keyword-only
        Inertia (kg·m²).
    tau : float, keyword-only
        Friction lag (s); 0 makes ``f = F(w)`` algebraic (RK4 on ``w`` alone).
    dt : float, keyword-only
        Step (s).

    Returns
    -------
    callable
        The step function used by :func:`make_rk4_step` (see its Notes).
    """
    h2, h6 = dt / 2.0, dt / 6.0

    if tau == 0.0:

        def step_static(w: float, f: float, u: float) -> tuple:
            k1 = (u - F(w)) / J
            k2 = (u - F(w + h2 * k1)) / J
            k3 = (u - F(w + h2 * k2)) / J
            k4 = (u - F(w + dt * k3)) / J
            w = w + h6 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
            return w, F(w)

        return step_static

    def step(w: float, f: float, u: float) -> tuple:
        k1w = (u - f) / J
        k1f = (F(w) - f) / tau
        w2, f2 = w + h2 * k1w, f + h2 * k1f
        k2w = (u - f2) / J
        k2f = (F(w2) - f2) / tau
        w3, f3 = w + h2 * k2w, f + h2 * k2f
        k3w = (u - f3) / J
        k3f = (F(w3) - f3) / tau
        w4, f4 = w + dt * k3w, f + dt * k3f
        k4w = (u - f4) / J
        k4f = (F(w4) - f4) / tau
        return (w + h6 * (k1w + 2.0 * k2w + 2.0 * k3w + k4w),
                f + h6 * (k1f + 2.0 * k2f + 2.0 * k3f + k4f))

    return step


@dataclass(frozen=True)
class PlantResponse:
    """Open-loop response at the integration rate.

    Attributes
    ----------
    t : ndarray, shape (N + 1,)
        Time (s), ``t[k] = k*dt``.
    u : ndarray, shape (N + 1,)
        Input torque (N·m); ``u[k]`` is held over ``[t[k], t[k+1])`` (the last
        entry repeats ``u[N-1]``).
    w : ndarray, shape (N + 1,)
        Velocity (rad/s).
    f : ndarray, shape (N + 1,)
        Friction torque state (N·m).
    dt : float
        Integration step (s).
    """

    t: np.ndarray
    u: np.ndarray
    w: np.ndarray
    f: np.ndarray
    dt: float


def simulate(p: JointParams, u, *, dt: float = DT_DEFAULT, w0: float = 0.0, f0: float = 0.0) -> PlantResponse:
    """Simulate the joint open loop under a sampled input torque.

    Parameters
    ----------
    p : JointParams or another plant model (see :func:`make_rk4_step`)
        Plant parameters.
    u : array_like, shape (N,)
        Input torque (N·m), ``u[k]`` held over step ``k``.
    dt : float, optional
        Integration step (s); default 1 ms (1 kHz, as in the paper).
    w0, f0 : float, optional
        Initial velocity (rad/s) and friction state (N·m; for other plant
        models their internal state, e.g. the LuGre deflection in rad).

    Returns
    -------
    PlantResponse
        Time series of length ``N + 1`` (initial state included).

    Raises
    ------
    SignalError
        ``u`` not 1-D, empty, or non-finite.
    ParameterError
        ``dt`` not > 0 or non-finite initial state.

    Notes
    -----
    Model: eqs. 1-3 of Ruderman; integrator: :func:`make_rk4_step`.
    """
    u = check_signal("u", u)
    w = check_finite_scalar("w0", w0)
    f = check_finite_scalar("f0", f0)
    step = make_rk4_step(p, dt)
    if isinstance(p, JointParams) and p.tau == 0.0:
        f = float(p.friction(w))  # static friction: the state is algebraic
    n = u.shape[0]
    W = np.empty(n + 1)
    Fr = np.empty(n + 1)
    W[0], Fr[0] = w, f
    for k, uk in enumerate(u.tolist()):
        w, f = step(w, f, uk)
        W[k + 1], Fr[k + 1] = w, f
    U = np.append(u, u[-1])
    return PlantResponse(t=np.arange(n + 1) * dt, u=U, w=W, f=Fr, dt=dt)
