"""A robot arm from its URDF (Pinocchio): joints, limits, the joint-torque regressor and its base parameters.

The rigid-body torques are linear in the dynamic parameters: ``tau = Y(q, dq, ddq) theta`` with ten parameters per
link (``m, m*cx, m*cy, m*cz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz`` in the joint frame, Pinocchio's
``Inertia.toDynamicParameters``) and here one armature (rotor inertia) ``Ia`` per joint, column ``ddq_j``. Not
all of them show in the torques: the base parameters are the independent combinations that do, found by a QR
decomposition with column pivoting of the regressor stacked over random states (Gautier, "Numerical calculation of
the base inertial parameters of robots", J. Robotic Systems 8(4), 1991).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from plant.errors import ParameterError

__all__ = ["ArmModel", "BaseParameters", "load_urdf", "LINK_PARAMETERS", "require_pinocchio"]

#: The ten dynamic parameters of a link, in Pinocchio's order (``Inertia.toDynamicParameters``).
LINK_PARAMETERS = ("m", "mx", "my", "mz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")

#: Relative tolerance of the rank decision on the pivoted R diagonal (``|R_kk| > tol * |R_00|``).
RANK_TOL = 1e-8


def require_pinocchio():
    """The ``pinocchio`` module; ParameterError naming the extra to install when it is missing."""
    try:
        import pinocchio
    except ImportError:
        raise ParameterError("the whole-arm identification needs Pinocchio: pip install 'adaptive-ff[arm]' "
                             "(the PyPI package pin)") from None
    return pinocchio


@dataclass(frozen=True)
class BaseParameters:
    """The base parameters of a regressor: ``beta = theta[independent] + K @ theta[dependent]``.

    Attributes
    ----------
    independent, dependent : ndarray of int
        Columns of the full regressor kept (in pivot order) and expressed through them.
    K : ndarray, shape (r, p - r)
        ``R11^-1 R12`` of the pivoted QR, entries below ``1e-10`` set to zero.
    names : tuple of str
        A name per base parameter: its kept column's name, with ``+ k*name`` for every dependent column it absorbs.
    """

    independent: np.ndarray
    dependent: np.ndarray
    K: np.ndarray
    names: tuple

    def of(self, theta) -> np.ndarray:
        """The base parameters of the full parameter vector ``theta`` (shape (p,))."""
        theta = np.asarray(theta, dtype=float)
        return theta[self.independent] + self.K @ theta[self.dependent]


class ArmModel:
    """A fixed-base arm of revolute or prismatic joints read from a URDF.

    Parameters
    ----------
    model : pinocchio.Model
        The arm (every joint one degree of freedom).
    source : str
        The URDF (for messages).

    Attributes
    ----------
    names : tuple of str
        Joint names in the URDF's (Pinocchio's) order.
    lower, upper : ndarray, shape (N,)
        Position limits (rad or m; ``-inf``/``inf`` where the URDF gives none).
    theta_urdf : ndarray, shape (10 N + N,)
        The URDF's dynamic parameters, armatures zero (Pinocchio's ``model.armature``, zero from a URDF).
    parameter_names : tuple of str
        ``m1, mx1, ..., Izz1, ..., IaN``.
    """

    def __init__(self, model, source: str = "URDF"):
        self.model = model
        self.data = model.createData()
        self.source = str(source)
        self.n = int(model.nv)
        self.names = tuple(model.names[i] for i in range(1, model.njoints))
        self.lower = np.where(np.asarray(model.lowerPositionLimit) > -1e20, model.lowerPositionLimit, -np.inf)
        self.upper = np.where(np.asarray(model.upperPositionLimit) < 1e20, model.upperPositionLimit, np.inf)
        self.theta_urdf = np.concatenate([np.asarray(model.inertias[i].toDynamicParameters()).reshape(-1)
                                          for i in range(1, model.njoints)] + [np.zeros(self.n)])
        self.parameter_names = tuple(f"{p}{j + 1}" for j in range(self.n) for p in LINK_PARAMETERS) + tuple(
            f"Ia{j + 1}" for j in range(self.n))

    def regressor(self, q, dq, ddq) -> np.ndarray:
        """The joint-torque regressor of the samples, stacked sample by sample.

        Parameters
        ----------
        q, dq, ddq : array_like, shape (n, N)
            Positions, velocities, accelerations (SI).

        Returns
        -------
        ndarray, shape (n, N, 11 N)
            ``Y[k] @ theta`` is the rigid-body torque (with armatures) of sample ``k``
            (:func:`pinocchio.computeJointTorqueRegressor`, plus ``diag(ddq)``).
        """
        pin = require_pinocchio()
        q, dq, ddq = (np.ascontiguousarray(np.asarray(x, dtype=float).reshape(-1, self.n)) for x in (q, dq, ddq))
        out = np.empty((q.shape[0], self.n, 11 * self.n))
        for k in range(q.shape[0]):
            out[k, :, : 10 * self.n] = pin.computeJointTorqueRegressor(self.model, self.data, q[k], dq[k], ddq[k])
            out[k, :, 10 * self.n:] = np.diag(ddq[k])
        return out

    def rnea(self, q, dq, ddq) -> np.ndarray:
        """The URDF model's inverse dynamics (:func:`pinocchio.rnea`) of one sample, shape (N,)."""
        pin = require_pinocchio()
        return np.asarray(pin.rnea(self.model, self.data, *(np.asarray(x, dtype=float) for x in (q, dq, ddq))))

    def base_parameters(self, *, samples: int = 200, seed: int = 0) -> BaseParameters:
        """The base parameters, from the regressor at ``samples`` random states (seeded, so reproducible).

        Positions are drawn uniformly within the limits (``±pi`` where a limit is infinite), velocities and
        accelerations standard normal: the identifiable combinations are a property of the arm's structure,
        not of a log.
        """
        rng = np.random.default_rng(seed)
        lo = np.where(np.isfinite(self.lower), self.lower, -np.pi)
        hi = np.where(np.isfinite(self.upper), self.upper, np.pi)
        q = rng.uniform(lo, hi, size=(samples, self.n))
        W = self.regressor(q, rng.standard_normal((samples, self.n)), rng.standard_normal((samples, self.n)))
        return reduce_columns(W.reshape(-1, W.shape[-1]), self.parameter_names)

    def check_positions(self, q, where) -> None:
        """ParameterError naming ``where``, the joint, the sample and the value of a position beyond its limits
        (by more than 1e-6 of the range, or 1e-6)."""
        q = np.asarray(q, dtype=float)
        span = np.where(np.isfinite(self.upper - self.lower), self.upper - self.lower, 1.0)
        slack = 1e-6 * np.maximum(span, 1.0)
        for j, name in enumerate(self.names):
            bad = np.flatnonzero((q[:, j] < self.lower[j] - slack[j]) | (q[:, j] > self.upper[j] + slack[j]))
            if bad.size:
                k = int(bad[0])
                raise ParameterError(f"{where}: joint {j + 1} ({name!r}) position {q[k, j]:.6g} at sample {k} is "
                                     f"beyond the URDF limits [{self.lower[j]:.6g}, {self.upper[j]:.6g}] "
                                     f"({self.source}); {bad.size} of {q.shape[0]} samples out of range")


def reduce_columns(W, names) -> BaseParameters:
    """Base parameters of the columns of ``W`` (shape (m, p)) by QR with column pivoting (rank: ``|R_kk| >
    RANK_TOL |R_00|``)."""
    from scipy.linalg import qr

    _, R, piv = qr(np.asarray(W, dtype=float), mode="economic", pivoting=True)
    d = np.abs(np.diag(R))
    r = int(np.sum(d > RANK_TOL * d[0]))
    K = np.linalg.solve(R[:r, :r], R[:r, r:])
    K[np.abs(K) < 1e-10] = 0.0
    ind, dep = piv[:r], piv[r:]
    labels = []
    for i, col in enumerate(ind):
        terms = [names[col]] + [f"{'+' if K[i, k] > 0 else '-'} {abs(K[i, k]):.4g}*{names[c]}"
                                for k, c in enumerate(dep) if K[i, k] != 0.0]
        labels.append(" ".join(terms))
    return BaseParameters(independent=np.asarray(ind), dependent=np.asarray(dep), K=K, names=tuple(labels))


def load_urdf(path) -> ArmModel:
    """Read an arm from a URDF file (fixed base; every joint revolute or prismatic, one degree of freedom).

    Parameters
    ----------
    path : str or os.PathLike
        The URDF.

    Returns
    -------
    ArmModel

    Raises
    ------
    FileNotFoundError
        No such file.
    ParameterError
        Pinocchio missing, the file does not parse as a URDF (Pinocchio's reason quoted), no moving joint, or a
        joint of more than one degree of freedom (a continuous or floating joint: named).
    """
    pin = require_pinocchio()
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(2, "No such URDF file", str(path))
    try:
        model = pin.buildModelFromUrdf(str(path))
    except (ValueError, RuntimeError) as exc:
        reason = " ".join(str(exc).split())[:300]
        raise ParameterError(f"{path}: not a URDF Pinocchio can read ({reason})") from None
    if model.nv == 0:
        raise ParameterError(f"{path}: the URDF has no moving joint")
    for i in range(1, model.njoints):
        j = model.joints[i]
        if j.nq != 1 or j.nv != 1:
            raise ParameterError(f"{path}: joint {model.names[i]!r} ({j.shortname()}) has {j.nq} position "
                                 "coordinates; identify-arm takes revolute and prismatic joints (a continuous "
                                 "joint: give it limits, type revolute)")
    return ArmModel(model, source=str(path))
