"""Velocity references a robot joint runs: point-to-point moves with dwell, and constant velocity with reversals.

The multi-sine of :func:`plant.excitation.multisine_reference` (the paper's Sec. V-B) excites friction well;
a robot in production moves from one position to the next and stops. :func:`point_to_point_reference` builds
such a motion from a list of target positions: each move has a trapezoidal velocity profile (limits ``v_max``,
``a_max``) or, with ``j_max``, a jerk-limited "S-curve" one, and the joint dwells at standstill after it.
:func:`reversing_reference` holds a constant speed and reverses through zero with a bounded acceleration, the
classic test of friction compensation at velocity reversals.

Both return a :class:`plant.excitation.Reference` (``t``, ``w``, ``dw`` on the grid of step ``dt``); its
:meth:`~plant.excitation.Reference.stops` and :meth:`~plant.excitation.Reference.reversals` give the times of
the stops and the reversals. A reference from a recorded trajectory (a CSV of time and velocity or position):
:func:`adaptive_ff.io.references.load_reference`.

Source: the trapezoidal profile and the jerk-limited profile as a trapezoid filtered by a moving average of
length ``a_max/j_max`` (L. Biagiotti and C. Melchiorri, *Trajectory Planning for Automatic Machines and
Robots*, Springer 2008, Sec. 3.2 and 3.4; the filter form: Biagiotti & Melchiorri, "FIR filters for online
trajectory planning with time- and frequency-domain specifications", Control Engineering Practice 20 (2012)).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from plant.errors import ParameterError, check_finite_scalar, check_nonnegative, check_positive
from plant.excitation import Reference

__all__ = ["point_to_point_reference", "reversing_reference", "trapezoid_profile"]


def trapezoid_profile(distance: float, v_max: float, a_max: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Velocity and acceleration samples of one rest-to-rest move of ``distance`` (rad, >= 0), trapezoidal.

    Parameters
    ----------
    distance : float
        Length of the move (rad), >= 0.
    v_max, a_max : float
        Speed limit (rad/s) and acceleration limit (rad/s²), > 0.
    dt : float
        Sample step (s), > 0.

    Returns
    -------
    w, dw : ndarray, shape (M,)
        Velocity (rad/s, >= 0) and its derivative (rad/s²) at ``t_k = k*dt``, ``k = 1 .. M``, after a start at
        rest at ``t = 0``: the last sample is the first at rest again (``M = 0`` for a zero distance). ``sum(w)*dt``
        equals ``distance`` to rounding: the samples are scaled so. (The profile is piecewise linear; the sum
        of its samples is its integral by the trapezoidal rule, exact but on the steps holding one of its
        corners, an error of at most ``a_max*dt**2/2`` in all; the scale factor differs from 1 by at most
        ``a_max*dt**2/(2*distance)``.)

    Notes
    -----
    Acceleration ``a_max`` for ``Ta = v_max/a_max``, cruise at ``v_max``, deceleration; a short move that cannot
    reach ``v_max`` (``distance < v_max²/a_max``) peaks at ``sqrt(distance*a_max)`` (a triangle).
    """
    distance = check_nonnegative("distance", distance)
    v_max, a_max, dt = (check_positive(k, v) for k, v in (("v_max", v_max), ("a_max", a_max), ("dt", dt)))
    if distance == 0.0:
        return np.zeros(0), np.zeros(0)
    v_peak = min(v_max, math.sqrt(distance * a_max))
    Ta = v_peak / a_max
    Tc = distance / v_peak - Ta  # >= 0: cruise
    T = 2.0 * Ta + Tc
    n = max(1, int(math.ceil(T / dt - 1e-9)))  # the last sample at T (to rounding) or after it: set to rest below
    t = np.arange(1, n + 1) * dt
    w = np.minimum.reduce([a_max * t, np.full(n, v_peak), a_max * (T - t)])
    w = np.maximum(w, 0.0)
    dw = np.where(t < Ta, a_max, np.where(t < Ta + Tc, 0.0, np.where(t < T, -a_max, 0.0)))
    w[-1] = 0.0
    dw[-1] = 0.0
    total = float(np.sum(w)) * dt
    if total <= 0.0:  # a move shorter than a step (distance < a_max*dt**2/4): one sample carries it
        return np.array([distance / dt, 0.0]), np.array([distance / dt ** 2, -distance / dt ** 2])
    w *= distance / total
    return w, dw


def _moving_average(x: np.ndarray, m: int) -> np.ndarray:
    """Causal moving average over ``m`` samples of ``x`` followed by ``m - 1`` zeros (length ``len(x) + m - 1``)."""
    if m <= 1:
        return x.copy()
    return np.convolve(x, np.full(m, 1.0 / m))


def _move(distance: float, v_max: float, a_max: float, j_max: float | None, dt: float) -> tuple:
    w, dw = trapezoid_profile(abs(distance), v_max, a_max, dt)
    if w.size == 0:
        return w, dw
    if j_max is not None:
        m = int(math.ceil(a_max / j_max / dt))  # window >= a_max/j_max: the jerk a_max/(m*dt) <= j_max
        w, dw = _moving_average(w, m), _moving_average(dw, m)
    s = 1.0 if distance > 0 else -1.0
    return s * w, s * dw


def point_to_point_reference(targets: Sequence[float], *, v_max: float, a_max: float, j_max: float | None = None,
                             dwell: float = 0.5, start_dwell: float = 0.5, q0: float = 0.0,
                             dt: float = 1e-3) -> Reference:
    """Rest-to-rest moves through ``targets`` with a dwell at standstill after each (a pick-and-place cycle).

    Parameters
    ----------
    targets : sequence of float
        Joint positions (rad) to move to, in order, starting from ``q0``; at least one. A target equal to the
        position before it adds a dwell only.
    v_max : float, keyword-only
        Speed limit (rad/s), > 0.
    a_max : float, keyword-only
        Acceleration limit (rad/s²), > 0.
    j_max : float or None, keyword-only
        Jerk limit (rad/s³), > 0: a jerk-limited (S-curve) profile whose acceleration ramps over
        ``a_max/j_max`` (rounded up to whole steps); None (default): trapezoidal velocity, the acceleration
        jumps.
    dwell : float, keyword-only
        Standstill after each move (s), >= 0, default 0.5 s.
    start_dwell : float, keyword-only
        Standstill before the first move (s), >= 0, default 0.5 s.
    q0 : float, keyword-only
        Start position (rad), default 0.
    dt : float, keyword-only
        Step (s), > 0, default 1 ms.

    Returns
    -------
    Reference
        ``w`` exactly 0 during each dwell; the position ``q0 + cumsum(w)*dt`` reaches each target at the end of
        its move to rounding; ``|dw| <= a_max`` and ``|w| <= v_max*(1 + (a_max*dt/v_max)**2)`` (the scaling
        of :func:`trapezoid_profile`).
        :meth:`~plant.excitation.Reference.stops` gives the time each move ends.

    Raises
    ------
    ParameterError
        Empty or non-finite ``targets``, a non-positive limit or step, a negative dwell (the message names
        the argument and the value).
    """
    try:
        arr = None if isinstance(targets, (str, bytes)) else np.asarray(targets, dtype=float)
    except (TypeError, ValueError):
        arr = None
    if arr is None or arr.ndim != 1 or arr.size == 0:
        raise ParameterError(f"targets must be a non-empty sequence of positions (rad), got {targets!r}")
    targets = [check_finite_scalar(f"targets[{i}]", q) for i, q in enumerate(arr.tolist())]
    v_max, a_max, dt = (check_positive(k, v) for k, v in (("v_max", v_max), ("a_max", a_max), ("dt", dt)))
    if j_max is not None:
        j_max = check_positive("j_max", j_max)
    dwell, start_dwell = check_nonnegative("dwell", dwell), check_nonnegative("start_dwell", start_dwell)
    q = check_finite_scalar("q0", q0)
    hold, hold0 = int(round(dwell / dt)), int(round(start_dwell / dt))
    w_parts, dw_parts = [np.zeros(hold0)], [np.zeros(hold0)]
    for qt in targets:
        w, dw = _move(qt - q, v_max, a_max, j_max, dt)
        w_parts += [w, np.zeros(hold)]
        dw_parts += [dw, np.zeros(hold)]
        q = qt
    w = np.concatenate(w_parts)
    dw = np.concatenate(dw_parts)
    if w.size < 2:
        raise ParameterError(f"targets {targets} with dwell {dwell!r} s and start_dwell {start_dwell!r} s make a "
                             f"reference shorter than two steps of dt = {dt!r} s")
    return Reference(t=np.arange(w.size) * dt, w=w, dw=dw)


def reversing_reference(speed: float, *, hold: float, accel: float, n_reversals: int, start_dwell: float = 0.5,
                        end_dwell: float = 0.5, dt: float = 1e-3) -> Reference:
    """Constant speed ``±speed`` held for ``hold`` seconds, reversed ``n_reversals`` times through zero.

    Parameters
    ----------
    speed : float
        Speed of each constant-velocity segment (rad/s), > 0.
    hold : float, keyword-only
        Time at constant speed between reversals (s), > 0.
    accel : float, keyword-only
        Acceleration of each ramp (rad/s²), > 0: a reversal from ``+speed`` to ``-speed`` takes
        ``2*speed/accel`` seconds and crosses zero in its middle.
    n_reversals : int, keyword-only
        Number of reversals, >= 1; the reference starts at rest, ramps to ``+speed`` and ends with a ramp to
        rest after the last segment.
    start_dwell : float, keyword-only
        Standstill before the first ramp (s), >= 0, default 0.5 s.
    end_dwell : float, keyword-only
        Standstill after the last ramp (s), >= 0, default 0.5 s: the final stop, long enough for its settling to
        be measured (0: the reference reaches rest on its last sample, a stop the run ends in).
    dt : float, keyword-only
        Step (s), > 0, default 1 ms.

    Returns
    -------
    Reference
        ``|w| <= speed``, ``|dw| <= accel``; :meth:`~plant.excitation.Reference.reversals` holds
        ``n_reversals`` times, :meth:`~plant.excitation.Reference.stops` one (the final rest).

    Raises
    ------
    ParameterError
        A non-positive speed, hold, acceleration or step, ``n_reversals`` not an integer >= 1.
    """
    speed, hold, accel, dt = (check_positive(k, v) for k, v in
                              (("speed", speed), ("hold", hold), ("accel", accel), ("dt", dt)))
    if isinstance(n_reversals, bool) or int(n_reversals) != n_reversals or n_reversals < 1:
        raise ParameterError(f"n_reversals must be an integer >= 1, got {n_reversals!r}")
    start_dwell = check_nonnegative("start_dwell", start_dwell)
    end_dwell = check_nonnegative("end_dwell", end_dwell)
    # piecewise-linear breakpoints (time, velocity): a ramp up, then per segment a hold and a ramp to the other sign
    tr = speed / accel
    times, vals = [0.0, start_dwell, start_dwell + tr], [0.0, 0.0, speed]
    s = 1.0
    for _ in range(int(n_reversals)):
        times += [times[-1] + hold, times[-1] + hold + 2.0 * tr]
        vals += [s * speed, -s * speed]
        s = -s
    times += [times[-1] + hold, times[-1] + hold + tr]
    vals += [s * speed, 0.0]
    if end_dwell > 0:
        times.append(times[-1] + end_dwell)
        vals.append(0.0)
    n = int(math.ceil(times[-1] / dt)) + 1
    t = np.arange(n) * dt
    w = np.interp(t, times, vals)
    knots = np.asarray(times)
    slope = np.diff(vals) / np.maximum(np.diff(knots), 1e-300)
    seg = np.clip(np.searchsorted(knots, t, side="right") - 1, 0, slope.size - 1)
    dw = np.where(t < knots[-1], slope[seg], 0.0)
    return Reference(t=t, w=w, dw=dw)
