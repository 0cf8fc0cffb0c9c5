"""A simulated arm: Pinocchio's articulated-body algorithm plus a lagged Stribeck friction per joint, in a velocity
PI loop per joint, with sensor noise; its log in the layout of :func:`adaptive_ff.arm.arm_log.read_arm_log`.

Each joint's friction follows eqs. 1-3 of the paper: ``tau_j df_j/dt + f_j = F_j(dq_j)`` with
``F(w) = sgn(w) (Fc + (Fs - Fc) exp(-|w/Vs|**delta)) + sigma w`` (``tau_j = 0``: ``f_j = F_j(dq_j)``). The arm
``M(q) ddq + C(q, dq) dq + g(q) = u - f`` is integrated by the classical Runge-Kutta method (4th order) at
``dt/substeps``, the torque ``u`` held over each controller period ``dt``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from plant.errors import ParameterError

from adaptive_ff.arm.arm_log import ArmLog
from adaptive_ff.arm.robot import ArmModel, require_pinocchio

__all__ = ["JointFriction", "SensorNoise", "simulate_arm", "friction_torque"]


@dataclass(frozen=True)
class JointFriction:
    """One joint's friction (eqs. 1-3) and its torque sensor's offset, SI units.

    Attributes
    ----------
    Fc, Fs : float
        Coulomb and static levels (N·m).
    Vs : float
        Stribeck velocity (rad/s), > 0.
    delta : float
        Stribeck shape factor, > 0.
    sigma : float
        Viscous coefficient (N·m·s/rad).
    tau : float
        Friction lag (s), >= 0.
    offset : float
        Constant added to the logged torque (N·m): a sensor or current offset.
    """

    Fc: float
    Fs: float
    Vs: float
    delta: float
    sigma: float
    tau: float = 0.0
    offset: float = 0.0


@dataclass(frozen=True)
class SensorNoise:
    """Standard deviations of the white sensor noise added to the log: position (rad), velocity (rad/s), torque
    (N·m)."""

    q: float = 1e-5
    dq: float = 2e-3
    tau: float = 0.1


def friction_torque(w, fr) -> np.ndarray:
    """The static map ``F(w)`` (eq. 3) of each joint: ``w`` shape (N,) or (n, N), ``fr`` a sequence of N
    :class:`JointFriction`."""
    w = np.asarray(w, dtype=float)
    from plant.stribeck_map import stribeck

    w = np.atleast_2d(w)
    out = np.column_stack([stribeck(w[:, j], Fc=f.Fc, Fs=f.Fs, Vs=f.Vs, delta=f.delta, sigma=f.sigma)
                           for j, f in enumerate(fr)])
    return out.reshape(-1) if out.shape[0] == 1 else out


def _reference(n: int, duration: float, dt: float, rng, amplitude: float):
    """Velocity references (n_t, n) of a multisine position trajectory per joint (5 sines, 0.1-1 Hz, random
    phases) and its time grid."""
    t = np.arange(int(round(duration / dt)) + 1) * dt
    f = np.geomspace(0.1, 1.0, 5)
    w = np.zeros((t.shape[0], n))
    for j in range(n):
        ph = rng.uniform(0, 2 * np.pi, f.shape[0])
        a = amplitude / f.shape[0] * rng.uniform(0.6, 1.0, f.shape[0])
        w[:, j] = np.sum(a * 2 * np.pi * f * np.cos(2 * np.pi * f * t[:, None] + ph), axis=1)
    return t, w


def simulate_arm(arm: ArmModel, friction, *, duration: float = 20.0, dt: float = 1e-3, seed: int = 0,
                 noise: SensorNoise | None = None, amplitude: float = 0.8, substeps: int = 2,
                 armature=None) -> ArmLog:
    """Simulate ``arm`` with ``friction`` in a velocity PI loop per joint and return its noisy log.

    Parameters
    ----------
    arm : ArmModel
        The rigid body (:func:`adaptive_ff.arm.robot.load_urdf`); its URDF inertias are the truth.
    friction : sequence of JointFriction
        One per joint, in the URDF's order.
    duration, dt : float, keyword-only
        Length (s) and controller/log sample time (s).
    seed : int, keyword-only
        Seeds the reference phases and the sensor noise.
    noise : SensorNoise, keyword-only
        Sensor noise (default :class:`SensorNoise`'s values).
    amplitude : float, keyword-only
        Position amplitude (rad) of each joint's multisine reference, summed over its 5 sines.
    substeps : int, keyword-only
        Runge-Kutta steps per controller period.
    armature : array_like, shape (N,), keyword-only
        Rotor inertias reflected to the joints (kg·m², Pinocchio's ``model.armature``); default zero (the URDF's).

    Returns
    -------
    ArmLog
        ``t``, measured ``q``, ``dq``, and the logged torque ``u + offset`` with noise; ``u`` at ``t_k`` is the mean
        of the torques held before and after ``t_k`` (the drive's torque at the sampling instant: logging the
        value held after it would put the torque half a sample ahead of the positions).

    Raises
    ------
    ParameterError
        ``friction`` not one per joint, a non-positive ``Vs``/``delta``, a negative ``tau``, or the arm leaving
        its URDF limits (the amplitude is too large for them).

    Notes
    -----
    The PI gains per joint: ``Kp = 2 pi 10 Hz M_jj(0)``, ``Ki = 2 pi 2 Hz Kp`` (``M(0)`` the mass matrix at
    ``q = 0`` with the armatures, Pinocchio's CRBA); the integral also takes up gravity. The true dynamic
    parameters of the log are ``arm.theta_urdf`` with its last N entries (the armatures) set to ``armature``.
    """
    pin = require_pinocchio()
    fr = list(friction)
    if len(fr) != arm.n:
        raise ParameterError(f"friction: {len(fr)} entries for the {arm.n} joints of {arm.source}")
    for j, f in enumerate(fr):
        if not (f.Vs > 0 and f.delta > 0 and f.tau >= 0):
            raise ParameterError(f"friction of joint {arm.names[j]!r}: Vs, delta must be > 0 and tau >= 0, got {f}")
    noise = SensorNoise() if noise is None else noise
    model = arm.model.copy()
    if armature is not None:
        model.armature = np.asarray(armature, dtype=float).reshape(arm.n)
    data = model.createData()
    rng = np.random.default_rng(seed)
    t, w_ref = _reference(arm.n, duration, dt, rng, amplitude)
    M0 = np.diag(pin.crba(model, data, np.zeros(arm.n)))
    Kp = 2 * np.pi * 10.0 * M0
    Ki = 2 * np.pi * 2.0 * Kp
    lag = np.array([f.tau for f in fr])
    h = dt / substeps

    def deriv(x, u):
        q, dq, fz = x[: arm.n], x[arm.n: 2 * arm.n], x[2 * arm.n:]
        F = friction_torque(dq, fr)
        f_now = np.where(lag > 0, fz, F)
        ddq = pin.aba(model, data, q, dq, u - f_now)
        df = np.where(lag > 0, (F - fz) / np.where(lag > 0, lag, 1.0), 0.0)
        return np.concatenate([dq, ddq, df])

    x = np.zeros(3 * arm.n)
    Q, DQ, U = (np.empty((t.shape[0], arm.n)) for _ in range(3))
    integ = np.zeros(arm.n)
    for k in range(t.shape[0]):
        Q[k], DQ[k] = x[: arm.n], x[arm.n: 2 * arm.n]
        e = w_ref[k] - DQ[k]
        integ += e * dt
        U[k] = Kp * e + Ki * integ
        for _ in range(substeps):
            k1 = deriv(x, U[k])
            k2 = deriv(x + 0.5 * h * k1, U[k])
            k3 = deriv(x + 0.5 * h * k2, U[k])
            k4 = deriv(x + h * k3, U[k])
            x = x + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
    arm.check_positions(Q, "simulate_arm")
    offset = np.array([f.offset for f in fr])
    n_shape = Q.shape
    U[1:] = 0.5 * (U[1:] + U[:-1])  # the torque at the sampling instant (between the two held values)
    return ArmLog(t=t, q=Q + noise.q * rng.standard_normal(n_shape), dq=DQ + noise.dq * rng.standard_normal(n_shape),
                  tau=U + offset + noise.tau * rng.standard_normal(n_shape), source="simulate_arm")
