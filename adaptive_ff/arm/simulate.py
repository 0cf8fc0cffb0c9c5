"""A simulated arm: Pinocchio's articulated-body algorithm plus a lagged Stribeck friction per joint, in a velocity
PI loop per joint, with sensor noise; its log in the layout of :func:`adaptive_ff.arm.arm_log.read_arm_log`.

Each joint's friction follows eqs. 1-3 of the paper: ``tau_j df_j/dt + f_j = F_j(dq_j)`` with
``F(w) = sgn(w) (Fc + (Fs - Fc) exp(-|w/Vs|**delta)) + sigma w`` (``tau_j = 0``: ``f_j = F_j(dq_j)``). The arm
``M(q) ddq + C(q, dq) dq + g(q) = u - f`` is integrated by the classical Runge-Kutta method (4th order) at
``dt/substeps``, the torque ``u`` held over each controller period ``dt``; optionally (``stop_refine``) at a
tenth of that through each period in which a joint comes to rest or reverses.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from plant.errors import ParameterError
from plant.stribeck_map import static_friction

from adaptive_ff.arm.arm_log import ArmLog
from adaptive_ff.arm.robot import ArmModel, require_pinocchio

#: Runge-Kutta steps per step of a period in which a joint stops or reverses (:meth:`ArmPlant.step`).
STOP_REFINE = 10

__all__ = ["STOP_REFINE", "ArmPlant", "ArmSimulation", "JointFriction", "SensorNoise", "arm_reference",
           "load_arm_plant", "simulate_arm", "friction_torque"]


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


@dataclass(frozen=True)
class ArmSimulation:
    """The settings of one simulated run of the arm (:func:`simulate_arm`): its length, the controller and log
    period, the amplitude of each joint's reference and the integration steps per period (validated on construction).

    Attributes
    ----------
    duration : float
        Length (s), > 0; default 20.
    dt : float
        Controller and log sample time (s), > 0; default 1e-3.
    amplitude : float
        Position amplitude (rad) of each joint's multisine reference (:func:`arm_reference`), summed over its
        5 sines, > 0; default 0.8.
    substeps : int
        Runge-Kutta steps per controller period, >= 1; default 2.
    stop_refine : int
        Runge-Kutta steps per step in a period in which a joint stops or reverses (:meth:`ArmPlant.step`, each
        joint's band :meth:`ArmPlant.stop_band` at the start position), >= 1; 1 (default): none. A lagged joint
        rings through zero velocity at its stops faster than a 1 ms step resolves
        (:func:`adaptive_ff.identification.simulator.stop_intervals`); :data:`STOP_REFINE` integrates those periods
        as a finely stepped arm does (``benchmarks/arm_stops.py``).

    Raises
    ------
    ParameterError
        A value out of range (the field named).
    """

    duration: float = 20.0
    dt: float = 1e-3
    amplitude: float = 0.8
    substeps: int = 2
    stop_refine: int = 1

    def __post_init__(self):
        import math

        for name in ("duration", "dt", "amplitude"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)) \
                    or not (math.isfinite(v) and v > 0):
                raise ParameterError(f"ArmSimulation.{name} must be a finite number > 0, got {v!r}")
        for name in ("substeps", "stop_refine"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
                raise ParameterError(f"ArmSimulation.{name} must be an integer >= 1, got {v!r}")


def friction_torque(w, fr) -> np.ndarray:
    """The static map ``F(w)`` (eq. 3) of each joint: ``w`` shape (N,) or (n, N), ``fr`` a sequence of N
    :class:`JointFriction`."""
    w = np.asarray(w, dtype=float)
    from plant.stribeck_map import stribeck

    w = np.atleast_2d(w)
    out = np.column_stack([stribeck(w[:, j], Fc=f.Fc, Fs=f.Fs, Vs=f.Vs, delta=f.delta, sigma=f.sigma)
                           for j, f in enumerate(fr)])
    return out.reshape(-1) if out.shape[0] == 1 else out


def arm_reference(n: int, duration: float, dt: float, rng, amplitude: float) -> tuple:
    """Velocity references of a multisine position trajectory per joint (5 sines, 0.1-1 Hz, random phases).

    Parameters
    ----------
    n : int
        Joints.
    duration, dt : float
        Length and sample time (s).
    rng : numpy.random.Generator
        Draws the phases and amplitudes (joint by joint).
    amplitude : float
        Position amplitude (rad) of each joint, summed over its 5 sines.

    Returns
    -------
    t : ndarray, shape (n_t,)
        ``k*dt`` for ``k = 0 .. round(duration/dt)``.
    w : ndarray, shape (n_t, n)
        Velocity reference (rad/s), the derivative of a position multisine that starts at 0 offset.
    """
    t = np.arange(int(round(duration / dt)) + 1) * dt
    f = np.geomspace(0.1, 1.0, 5)
    w = np.zeros((t.shape[0], n))
    for j in range(n):
        ph = rng.uniform(0, 2 * np.pi, f.shape[0])
        a = amplitude / f.shape[0] * rng.uniform(0.6, 1.0, f.shape[0])
        w[:, j] = np.sum(a * 2 * np.pi * f * np.cos(2 * np.pi * f * t[:, None] + ph), axis=1)
    return t, w


class ArmPlant:
    """The simulated arm as a plant stepped period by period: ``M(q) ddq + C(q, dq) dq + g(q) = u - f`` with the
    friction ``f_j`` of eqs. 1-3 per joint, integrated by the classical Runge-Kutta method (4th order) at
    ``dt/substeps`` with ``u`` held over the period.

    Parameters
    ----------
    arm : ArmModel
        The rigid body (its URDF inertias are the truth).
    friction : sequence of JointFriction or None
        One per joint, in the URDF's order; None: the frictionless arm (the same rigid body, ``f = 0``).
    armature : array_like, shape (N,), optional
        Rotor inertias reflected to the joints (kg·m²); default zero.

    Attributes
    ----------
    q, dq : ndarray, shape (N,)
        Positions (rad) and velocities (rad/s), zero at the start.
    armature : ndarray, shape (N,)
        The armatures in use (kg·m²).
    f : ndarray, shape (N,)
        The lagged friction states (N·m) of the joints with ``tau > 0`` (the others' entries unused).

    Raises
    ------
    ParameterError
        ``friction`` not one per joint, a non-positive ``Vs``/``delta`` or a negative ``tau``.

    Notes
    -----
    A joint with ``tau = 0`` takes ``f = F(dq)`` in every Runge-Kutta stage (``F(0) = 0``): the map is
    discontinuous at rest, and a joint near rest chatters by about ``F*h/M_jj`` (rad/s); give a lag (eq. 1) for a
    smooth joint. With one joint whose inertia does not depend on ``q`` and no gravity torque, a lagged joint
    steps as :func:`plant.joint.simulate` steps the one-joint plant (the same Runge-Kutta stages).
    """

    def __init__(self, arm: ArmModel, friction, *, armature=None):
        self.pin = require_pinocchio()
        self.arm = arm
        self.n = arm.n
        if friction is None:
            self.friction = None
        else:
            fr = list(friction)
            if len(fr) != arm.n:
                raise ParameterError(f"friction: {len(fr)} entries for the {arm.n} joints of {arm.source}")
            for j, f in enumerate(fr):
                if not (f.Vs > 0 and f.delta > 0 and f.tau >= 0):
                    raise ParameterError(f"friction of joint {arm.names[j]!r}: Vs, delta must be > 0 and tau >= 0, "
                                         f"got {f}")
            self.friction = fr
        self.model = arm.model.copy()
        if armature is not None:
            self.model.armature = np.asarray(armature, dtype=float).reshape(arm.n)
        self.armature = np.array(self.model.armature, dtype=float).reshape(arm.n)
        self.data = self.model.createData()
        self.lag = np.array([f.tau for f in self.friction]) if self.friction is not None else np.zeros(arm.n)
        self._lagged = self.lag > 0
        self._lag_div = np.where(self._lagged, self.lag, 1.0)
        self.q = np.zeros(arm.n)
        self.dq = np.zeros(arm.n)
        self.f = np.zeros(arm.n)

    def set_state(self, q, dq) -> None:
        """Positions ``q`` (rad) and velocities ``dq`` (rad/s), shape (N,); each lagged friction state at its steady
        value ``F(dq)`` (the joint has been moving at ``dq``)."""
        self.q = np.array(q, dtype=float).reshape(self.n)
        self.dq = np.array(dq, dtype=float).reshape(self.n)
        F = friction_torque(self.dq, self.friction) if self.friction is not None else np.zeros(self.n)
        self.f = np.where(self._lagged, F, 0.0)

    def mass_matrix(self, q=None) -> np.ndarray:
        """The joint-space inertia ``M(q)`` with the armatures (Pinocchio's CRBA), shape (N, N); default at the
        current ``q``."""
        q = self.q if q is None else np.asarray(q, dtype=float)
        M = np.array(self.pin.crba(self.model, self.data, q))
        return np.triu(M) + np.triu(M, 1).T

    def friction_now(self) -> np.ndarray:
        """The friction torque (N·m) acting now, shape (N,): the lagged state, or ``F(dq)`` where ``tau = 0``."""
        if self.friction is None:
            return np.zeros(self.n)
        return np.where(self._lagged, self.f, friction_torque(self.dq, self.friction))

    def _deriv(self, q, dq, fz, u):
        if self.friction is None:
            return dq, self.pin.aba(self.model, self.data, q, dq, u), np.zeros(self.n)
        F = friction_torque(dq, self.friction)
        f_now = np.where(self._lagged, fz, F)
        return dq, self.pin.aba(self.model, self.data, q, dq, u - f_now), np.where(self._lagged, (F - fz) / self._lag_div, 0.0)

    def step(self, u, dt: float, substeps: int = 1, *, stop_band=None, stop_refine: int = STOP_REFINE) -> None:
        """Advance by ``dt`` (s) with the torques ``u`` (N·m, shape (N,)) held, in ``substeps`` Runge-Kutta steps.

        ``stop_band`` (rad/s, shape (N,), or None: not used): a period in which some joint's velocity starts inside
        ``(-stop_band_j, stop_band_j)`` or changes sign is taken in ``substeps * stop_refine`` steps (a period that
        reverses a joint is retaken), where a lagged joint rings through zero velocity at its stops faster than
        ``dt / substeps`` resolves (:func:`adaptive_ff.identification.simulator.stop_intervals`)."""
        u = np.asarray(u, dtype=float)
        if stop_band is None or stop_refine == 1:
            self.q, self.dq, self.f = self._advance(u, dt, substeps)
            return
        if np.any(np.abs(self.dq) < stop_band):
            self.q, self.dq, self.f = self._advance(u, dt, substeps * stop_refine)
            return
        q, dq, fz = self._advance(u, dt, substeps)
        if np.any(np.sign(dq) != np.sign(self.dq)):
            q, dq, fz = self._advance(u, dt, substeps * stop_refine)
        self.q, self.dq, self.f = q, dq, fz

    def _advance(self, u, dt: float, substeps: int) -> tuple:
        """``(q, dq, f)`` after ``dt`` (s) from the current state in ``substeps`` Runge-Kutta steps (the state kept)."""
        h = dt / substeps
        q, dq, fz = self.q, self.dq, self.f
        for _ in range(substeps):
            a1, b1, c1 = self._deriv(q, dq, fz, u)
            a2, b2, c2 = self._deriv(q + 0.5 * h * a1, dq + 0.5 * h * b1, fz + 0.5 * h * c1, u)
            a3, b3, c3 = self._deriv(q + 0.5 * h * a2, dq + 0.5 * h * b2, fz + 0.5 * h * c2, u)
            a4, b4, c4 = self._deriv(q + h * a3, dq + h * b3, fz + h * c3, u)
            q = q + h / 6.0 * (a1 + 2 * a2 + 2 * a3 + a4)
            dq = dq + h / 6.0 * (b1 + 2 * b2 + 2 * b3 + b4)
            fz = fz + h / 6.0 * (c1 + 2 * c2 + 2 * c3 + c4)
        return q, dq, fz

    def stop_band(self, dt: float) -> np.ndarray:
        """Each joint's band (rad/s, shape (N,)) of :meth:`step`'s ``stop_band`` for the period ``dt`` (s): the
        velocity its static friction takes off in ``dt`` at its inertia ``M_jj(q)`` at the current position,
        ``max(|Fc|, |Fs|) dt / M_jj`` (:func:`plant.stribeck_map.static_friction`; the frictionless arm: zeros)."""
        if self.friction is None:
            return np.zeros(self.n)
        Fs = np.array([static_friction(f.Fc, f.Fs) for f in self.friction])
        return Fs * dt / np.diag(self.mass_matrix())


def simulate_arm(arm: ArmModel, friction, *, run: ArmSimulation = ArmSimulation(), seed: int = 0,
                 noise: SensorNoise | None = None, armature=None) -> ArmLog:
    """Simulate ``arm`` with ``friction`` in a velocity PI loop per joint and return its noisy log.

    Parameters
    ----------
    arm : ArmModel
        The rigid body (:func:`adaptive_ff.arm.robot.load_urdf`); its URDF inertias are the truth.
    friction : sequence of JointFriction
        One per joint, in the URDF's order.
    run : ArmSimulation, keyword-only
        Length (s), controller/log sample time (s), reference amplitude (rad) and Runge-Kutta steps per period
        (default :class:`ArmSimulation`'s values).
    seed : int, keyword-only
        Seeds the reference phases and the sensor noise.
    noise : SensorNoise, keyword-only
        Sensor noise (default :class:`SensorNoise`'s values).
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
    plant = ArmPlant(arm, friction, armature=armature)
    fr = plant.friction
    noise = SensorNoise() if noise is None else noise
    rng = np.random.default_rng(seed)
    dt = run.dt
    t, w_ref = arm_reference(arm.n, run.duration, dt, rng, run.amplitude)
    M0 = np.diag(pin.crba(plant.model, plant.data, np.zeros(arm.n)))
    Kp = 2 * np.pi * 10.0 * M0
    Ki = 2 * np.pi * 2.0 * Kp
    band = plant.stop_band(dt)
    Q, DQ, U = (np.empty((t.shape[0], arm.n)) for _ in range(3))
    integ = np.zeros(arm.n)
    for k in range(t.shape[0]):
        Q[k], DQ[k] = plant.q, plant.dq
        e = w_ref[k] - DQ[k]
        integ += e * dt
        U[k] = Kp * e + Ki * integ
        plant.step(U[k], dt, run.substeps, stop_band=band, stop_refine=run.stop_refine)
    arm.check_positions(Q, "simulate_arm")
    offset = np.array([f.offset for f in fr])
    n_shape = Q.shape
    U[1:] = 0.5 * (U[1:] + U[:-1])  # the torque at the sampling instant (between the two held values)
    return ArmLog(t=t, q=Q + noise.q * rng.standard_normal(n_shape), dq=DQ + noise.dq * rng.standard_normal(n_shape),
                  tau=U + offset + noise.tau * rng.standard_normal(n_shape), source="simulate_arm")


#: The keys of a joint's friction in an arm plant file (:func:`load_arm_plant`): required, then optional.
PLANT_KEYS = ("Fc", "Fs", "Vs", "delta", "sigma")
PLANT_OPTIONAL = ("tau", "offset")


def load_arm_plant(path, arm: ArmModel) -> ArmPlant:
    """The simulated arm of a JSON plant file: ``arm``'s rigid body, the file's armatures and friction per joint.

    The file: ``{"armature": [Ia1, ..., IaN], "joints": [{"name": "shoulder", "Fc": 2.0, "Fs": 2.6, "Vs": 0.1,
    "delta": 1.0, "sigma": 0.8, "tau": 0.002}, ...]}`` (SI units; ``armature`` optional, default zero; ``tau``
    and ``offset`` optional, default 0; every joint of the URDF once, by name, in any order).

    Parameters
    ----------
    path : str or os.PathLike
        The JSON file.
    arm : ArmModel
        The arm whose joints the file names.

    Returns
    -------
    ArmPlant

    Raises
    ------
    FileNotFoundError
        No such file.
    ParameterError
        Not JSON, a joint of the URDF missing or given twice, a name the URDF does not have, a key missing, a
        value not a finite number, ``Vs``/``delta`` not > 0, ``tau`` < 0, ``Fc``/``Fs``/``sigma`` < 0, or
        armatures not one finite value >= 0 per joint (the file, the joint and the key named).
    """
    import math

    from plant.models import read_json

    d = read_json(path, what="arm plant file")
    joints = d.get("joints") if isinstance(d, dict) else None
    if not isinstance(joints, list) or not all(isinstance(j, dict) for j in joints):
        raise ParameterError(f"{path}: no 'joints' list of objects (an arm plant file: {{\"armature\": [...], "
                             f"\"joints\": [{{\"name\", \"Fc\", \"Fs\", \"Vs\", \"delta\", \"sigma\", \"tau\"}}, ...]}})")
    by_name = {}
    for k, j in enumerate(joints):
        name = j.get("name")
        if name not in arm.names:
            raise ParameterError(f"{path}: joint {k + 1} is named {name!r}, which the URDF ({arm.source}) does not "
                                 f"have (its joints: {', '.join(arm.names)})")
        if name in by_name:
            raise ParameterError(f"{path}: joint {name!r} is given twice")
        by_name[name] = j
    missing = [n for n in arm.names if n not in by_name]
    if missing:
        raise ParameterError(f"{path}: no friction for joint(s) {missing} of the URDF ({arm.source})")

    def number(j, name, key, default=None):
        v = j.get(key, default)
        if v is None:
            raise ParameterError(f"{path}: joint {name!r} has no {key!r} (a number)")
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ParameterError(f"{path}: joint {name!r}: {key!r} must be a finite number, got {v!r}")
        return float(v)

    fr = []
    for name in arm.names:
        j = by_name[name]
        vals = {k: number(j, name, k) for k in PLANT_KEYS}
        vals.update({k: number(j, name, k, 0.0) for k in PLANT_OPTIONAL})
        for k in ("Fc", "Fs", "sigma", "tau"):
            if vals[k] < 0:
                raise ParameterError(f"{path}: joint {name!r}: {k!r} must be >= 0, got {vals[k]!r}")
        for k in ("Vs", "delta"):
            if not vals[k] > 0:
                raise ParameterError(f"{path}: joint {name!r}: {k!r} must be > 0, got {vals[k]!r}")
        fr.append(JointFriction(**vals))
    arma = d.get("armature")
    if arma is not None:
        ok = isinstance(arma, list) and len(arma) == arm.n and all(
            not isinstance(a, bool) and isinstance(a, (int, float)) and math.isfinite(a) and a >= 0 for a in arma)
        if not ok:
            raise ParameterError(f"{path}: 'armature' must be a list of {arm.n} finite numbers >= 0 (kg·m², one per "
                                 f"joint of {arm.source}), got {arma!r}")
    return ArmPlant(arm, fr, armature=arma)
