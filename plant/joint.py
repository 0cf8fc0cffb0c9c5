"""Lumped-mass joint with lagged friction, integrated by fixed-step RK4 (eqs. 1-3): open-loop runs.

State ``x = (w, f)``: velocity (rad/s) and friction torque (N·m)::

    dw/dt = (u - f) / J
    df/dt = (F(w) - f) / tau          (f = F(w) algebraically if tau == 0)

The input ``u`` (N·m) is held constant over each step (zero-order hold), as a
digital drive applies it. The paper simulates this structure (its Fig. 2) with
a fixed-step solver at 1 kHz; ``dt = 1e-3`` s is the default here. The step
itself is the C plant component of :mod:`plant.dynamics` (every friction
model of :mod:`plant.models`); this module runs it over an input sequence.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from plant._cplant import ffi
from plant.drift import FrictionDrift
from plant.dynamics import plant_params, plant_simulate, plant_state
from plant.errors import check_finite_scalar, check_positive, check_signal
from plant.friction import JointParams

__all__ = ["make_rk4_step", "simulate", "PlantResponse", "DT_DEFAULT"]

#: Default integration step (s): the paper's 1 kHz fixed-step solver.
DT_DEFAULT = 1e-3


def _frozen(p):
    """The frozen model :func:`plant.dynamics.plant_params` packs for ``p`` (a time-varying plant, a
    :class:`plant.drift.FrictionDrift` or :class:`plant.payload.PayloadStep`: at ``t = 0``)."""
    return p.at(0.0) if isinstance(p, FrictionDrift) or hasattr(p, "at") else p


def make_rk4_step(p: JointParams, dt: float = DT_DEFAULT) -> Callable[[float, float, float], tuple]:
    """Build one classic RK4 step ``(w, f, u) -> (w, f)`` of the joint, for speed-critical loops.

    Parameters
    ----------
    p : JointParams or another plant model
        Plant parameters. Any other object with a ``make_step(dt)`` method (the
        variants in :mod:`plant.lugre`, :mod:`plant.karnopp`,
        :mod:`plant.asymmetric`, :mod:`plant.drift`) is delegated to it; the second
        state slot is then that model's internal state (e.g. the LuGre bristle
        deflection ``z``).
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
    TypeError
        ``p`` has no ``make_step``.

    Notes
    -----
    Classic fourth-order Runge-Kutta (e.g. Hairer, Nørsett, Wanner, *Solving
    ODEs I*, Sec. II.1) of eqs. 1-3: the C
    :func:`plant.dynamics.plant_step`. ``F`` is discontinuous at ``w = 0``; with
    ``tau > 0`` the lag integrates it, so ``dw/dt`` stays continuous.
    """
    make = getattr(p, "make_step", None)
    if make is None:
        raise TypeError(f"p must be JointParams or a plant model with make_step(dt), got {type(p).__name__}")
    return make(dt)


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
    TypeError
        ``p`` is not a plant model of :mod:`plant.models`.

    Notes
    -----
    Model: eqs. 1-3 of Ruderman (or the variant's equations); integrator: the
    C loop :func:`plant.dynamics.plant_simulate` of
    :func:`plant.dynamics.plant_step`. A :class:`plant.drift.FrictionDrift`
    or :class:`plant.payload.PayloadStep` runs as its plant at ``t = 0`` (as its ``make_step``); a
    :class:`plant.ripple.FrictionRipple` with its position starting at ``q = 0``.
    """
    u = check_signal("u", u)
    w = check_finite_scalar("w0", w0)
    f = check_finite_scalar("f0", f0)
    dt = check_positive("dt", dt)
    q = _frozen(p)
    model = q.base if hasattr(q, "ripple_fields") else q  # a FrictionRipple: the model it wraps
    if isinstance(model, JointParams) and q.tau == 0.0:
        st = plant_state(q, w)  # static friction: the state is algebraic
    else:
        st = ffi.new("plant_state *", (w, f, math.nan))
    n = u.shape[0]
    W = np.empty(n + 1)
    Fr = np.empty(n + 1)
    plant_simulate(plant_params(q), st, u, dt, W, Fr)
    U = np.append(u, u[-1])
    return PlantResponse(t=np.arange(n + 1) * dt, u=U, w=W, f=Fr, dt=dt)
