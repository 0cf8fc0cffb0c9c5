r"""The transmission between an arm's motors and its joints: gear ratios, a coupling matrix, position offsets.

Many arms log motor-side signals: the motor encoders' angles and the motor torques (or currents). With ``G`` the
gear matrix, ``q_m = G (q - q_0)`` for the motor angles ``q_m`` and the joint positions ``q`` (``q_0`` the joint
offsets: the joint positions where the encoders read zero), and the power balance ``tau^T dq = tau_m^T dq_m``
gives the joint torques from the motor torques:

.. math::

    G = \operatorname{diag}(r)\, C, \qquad q = G^{-1} q_m + q_0, \qquad \dot q = G^{-1} \dot q_m, \qquad
    \tau = G^{T} (k_t \odot \tau_m),

with ``r`` a ratio per joint (motor turns per joint turn, signed), ``C`` the coupling matrix (the identity unless
the mechanism couples joints: a wrist whose last motor also turns with the joint before it has ``C[N-1, N-2] =
1``) and ``k_t`` the torque constant per motor (N·m per unit of the log's torque column; 1 when the log holds
motor torques). The friction identified afterwards is the joint side's: a motor's own friction shows, through
``G^T``, in every joint that the motor drives.

A transmission file is TOML (the standard library's :mod:`tomllib`; Python 3.10 needs the ``tomli`` package)::

    # motor side to joint side of a 6-axis arm whose joint 6 motor also turns with joint 5
    ratio = [32.0, 32.0, 45.0, -48.0, 45.0, 32.0]     # required: one per joint
    coupling = [[1, 0, 0, 0, 0, 0],                    # optional: N x N, identity by default
                [0, 1, 0, 0, 0, 0],
                [0, 0, 1, 0, 0, 0],
                [0, 0, 0, 1, 0, 0],
                [0, 0, 0, 0, 1, 0],
                [0, 0, 0, 0, 1, 1]]
    offset = [0.0, -1.5707963267948966, 1.5707963267948966, 0.0, 0.0, 0.0]   # optional, rad or m
    torque_constant = [1.0, 1.0, 1.0, 1.0, 1.0, 1.0]  # optional, N·m per log unit
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from plant.errors import ParameterError

from adaptive_ff.arm.arm_log import ArmLog

__all__ = ["Transmission", "read_transmission", "KEYS"]

#: The keys of a transmission file (``ratio`` required).
KEYS = ("ratio", "coupling", "offset", "torque_constant")

#: Reciprocal condition number of ``G`` below which the transmission counts as singular.
RCOND_MIN = 1e-12


@dataclass(frozen=True)
class Transmission:
    """Gear ratios, coupling matrix, joint offsets and torque constants of an N-joint arm (module docstring).

    Attributes
    ----------
    ratio : ndarray, shape (N,)
        Motor turns per joint turn (signed, nonzero).
    coupling : ndarray, shape (N, N)
        ``C`` in ``G = diag(ratio) C``; the identity for uncoupled joints.
    offset : ndarray, shape (N,)
        Joint positions (rad or m) where the motor encoders read zero.
    torque_constant : ndarray, shape (N,)
        N·m per unit of the log's torque columns (1 for motor torques).
    source : str
        The file (for messages).
    """

    ratio: np.ndarray
    coupling: np.ndarray
    offset: np.ndarray
    torque_constant: np.ndarray
    source: str = "transmission"

    @property
    def G(self) -> np.ndarray:
        """The gear matrix ``diag(ratio) @ coupling``, shape (N, N): motor angles per joint angle."""
        return self.ratio[:, None] * self.coupling

    def to_joint(self, log: ArmLog) -> ArmLog:
        """The joint-side log of the motor-side ``log``: ``q = G^-1 q_m + offset``, ``dq = G^-1 dq_m``,
        ``tau = G^T (k_t * tau_m)``.

        Parameters
        ----------
        log : ArmLog
            Motor angles (rad) in ``q``, motor velocities (rad/s) in ``dq`` if given, motor torques (or what
            ``torque_constant`` turns into N·m) in ``tau``.

        Returns
        -------
        ArmLog
            The same times and source, joint-side signals.

        Raises
        ------
        ParameterError
            The log's joint count differs from the transmission's (both named).
        """
        n = self.ratio.shape[0]
        if log.n_joints != n:
            raise ParameterError(f"{self.source}: a transmission of {n} joints for a log of {log.n_joints} "
                                 f"({log.source})")
        Ginv = np.linalg.inv(self.G)
        q = log.q @ Ginv.T + self.offset
        dq = log.dq @ Ginv.T if log.dq is not None else None
        tau = (log.tau * self.torque_constant) @ self.G
        return replace(log, q=q, dq=dq, tau=tau)

    def shared_motors(self) -> list:
        """``[(motor, joints), ...]``: each motor (0-based) that turns more than one joint, with those joints
        (0-based, the nonzero entries of its row of ``G``)."""
        G = self.G
        return [(i, tuple(int(j) for j in np.flatnonzero(G[i]))) for i in range(G.shape[0])
                if np.count_nonzero(G[i]) > 1]

    def with_coupling_warnings(self, result):
        """``result`` (an :class:`~adaptive_ff.arm.result.ArmIdentification`) with a ``model_form`` warning on
        every joint that a shared motor turns: that motor's own friction acts on its speed, a combination of the
        joints' speeds, which no per-joint friction column holds, so the joints' ``Fc`` and ``sigma`` absorb part
        of it (and differ from a model with a column for it).

        Raises
        ------
        ParameterError
            The result's joint count differs from the transmission's.
        """
        from dataclasses import replace as _replace

        from adaptive_ff.identification.plausibility import IdentificationWarning

        joints = list(result.joints)
        if len(joints) != self.ratio.shape[0]:
            raise ParameterError(f"{self.source}: a transmission of {self.ratio.shape[0]} joints for an arm of "
                                 f"{len(joints)}")
        for motor, driven in self.shared_motors():
            names = [joints[j].name for j in driven]
            for j in driven:
                others = ", ".join(repr(n) for n in names if n != joints[j].name)
                w = IdentificationWarning(
                    "model_form", "Fc",
                    f"joint {joints[j].name!r} shares motor {motor + 1} with {others} ({self.source}: coupling): "
                    f"that motor's own friction acts on a combination of the speeds of {', '.join(map(repr, names))}, "
                    f"which no per-joint friction column holds; Fc and sigma of {joints[j].name!r} absorb part of it")
                joints[j] = _replace(joints[j], warnings=tuple(joints[j].warnings) + (w,))
        return _replace(result, joints=tuple(joints))

    def to_dict(self) -> dict:
        """The transmission as plain lists (strict JSON)."""
        return {"ratio": self.ratio.tolist(), "coupling": self.coupling.tolist(), "offset": self.offset.tolist(),
                "torque_constant": self.torque_constant.tolist(), "source": self.source}

    def summary(self) -> str:
        """A few lines: the ratios, the coupling terms off the diagonal, the offsets."""
        n = self.ratio.shape[0]
        off = [f"C[{i + 1},{j + 1}]={self.coupling[i, j]:g}" for i in range(n) for j in range(n)
               if i != j and self.coupling[i, j] != 0.0]
        return "\n".join([f"transmission {self.source}: {n} joints",
                          "  ratio: " + ", ".join(f"{v:g}" for v in self.ratio),
                          "  coupling: " + (", ".join(off) if off else "none"),
                          "  offset: " + ", ".join(f"{v:g}" for v in self.offset),
                          "  torque constant: " + ", ".join(f"{v:g}" for v in self.torque_constant)])


def _load_toml(path: Path) -> dict:
    try:
        import tomllib
    except ImportError:  # Python 3.10
        try:
            import tomli as tomllib
        except ImportError:
            raise ParameterError(f"{path}: reading a TOML transmission file needs Python >= 3.11 or the tomli "
                                 "package") from None
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise ParameterError(f"{path}: not a readable TOML transmission file ({exc})") from None
    except UnicodeDecodeError:
        raise ParameterError(f"{path}: not a readable TOML transmission file (not UTF-8 text)") from None


def _array(path, key, value, shape) -> np.ndarray:
    """``value`` as a finite float array of ``shape``, or a ParameterError naming the file and the key."""
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        a = None
    want = " x ".join(str(s) for s in shape)
    if a is None or a.shape != shape:
        got = "not a numeric array" if a is None else f"shape {' x '.join(str(s) for s in a.shape) or 'scalar'}"
        raise ParameterError(f"{path}: {key} must be {want} numbers (one per joint of the URDF), got {got}")
    if not np.all(np.isfinite(a)):
        raise ParameterError(f"{path}: {key} has a value that is not finite")
    return a


def read_transmission(path, n_joints: int) -> Transmission:
    """Read a transmission file (TOML; module docstring: the keys and the equations).

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    n_joints : int
        N, the URDF's joint count: every vector has N entries, the coupling N x N.

    Returns
    -------
    Transmission

    Raises
    ------
    FileNotFoundError
        No such file.
    ParameterError
        Not TOML; an unknown key; ``ratio`` missing; a vector or matrix of the wrong size, not numeric or not
        finite; a ratio or torque constant of zero; a singular gear matrix ``diag(ratio) C``. The message names
        the file and the key.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(2, "No such transmission file", str(path))
    doc = _load_toml(path)
    unknown = sorted(set(doc) - set(KEYS))
    if unknown:
        raise ParameterError(f"{path}: unknown key {unknown[0]!r} in the transmission file (keys: "
                             f"{', '.join(KEYS)})")
    if "ratio" not in doc:
        raise ParameterError(f"{path}: the transmission file has no 'ratio' (a gear ratio per joint)")
    n = int(n_joints)
    ratio = _array(path, "ratio", doc["ratio"], (n,))
    coupling = _array(path, "coupling", doc.get("coupling", np.eye(n).tolist()), (n, n))
    offset = _array(path, "offset", doc.get("offset", [0.0] * n), (n,))
    kt = _array(path, "torque_constant", doc.get("torque_constant", [1.0] * n), (n,))
    for key, v in (("ratio", ratio), ("torque_constant", kt)):
        if np.any(v == 0.0):
            j = int(np.flatnonzero(v == 0.0)[0])
            raise ParameterError(f"{path}: {key} of joint {j + 1} is zero")
    sv = np.linalg.svd(ratio[:, None] * coupling, compute_uv=False)
    if sv[-1] <= RCOND_MIN * sv[0]:
        raise ParameterError(f"{path}: the gear matrix diag(ratio) @ coupling is singular (singular values "
                             f"{sv[0]:.3g} to {sv[-1]:.3g}): the motor angles do not determine the joint positions")
    return Transmission(ratio=ratio, coupling=coupling, offset=offset, torque_constant=kt, source=str(path))
