"""The result of the whole-arm identification: every joint's friction and inertia, the rigid body's base
parameters, with 95 % intervals and warnings (:class:`ArmIdentification`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["ArmJoint", "ArmIdentification", "JOINT_PARAMETERS", "read_arm_joint", "read_arm_entries",
           "is_arm_identification"]

#: A joint's parameters in its JSON entry (the top-level keys of ``adaptive-ff identify --json``).
JOINT_PARAMETERS = ("J", "Fc", "Fs", "Vs", "delta", "sigma", "tau", "offset")


def _num(x):
    """A finite float, or None (strict JSON: null, never NaN)."""
    return float(x) if x is not None and math.isfinite(float(x)) else None


@dataclass(frozen=True)
class ArmJoint:
    """One joint of an identified arm (SI units).

    Attributes
    ----------
    name : str
        The URDF's joint name.
    params : dict
        ``{"J", "Fc", "Fs", "Vs", "delta", "sigma", "tau", "offset"}``; ``J`` the joint's own diagonal inertia
        ``M_jj`` at the log's mean configuration (rigid body and armature: what the joint's own PI sees), ``tau``
        the friction lag by output error on the joint's rigid-body-removed record (NaN where the log does not
        determine it: :mod:`adaptive_ff.arm.lag`).
    interval95 : dict
        ``{name: (low, high)}`` for each of ``params`` (NaN where there is none).
    std : dict
        Bootstrap standard errors of ``J, Fc, Fs, sigma, offset``.
    warnings : tuple of adaptive_ff.identification.plausibility.IdentificationWarning
        What the log does not determine for this joint (``code``, ``parameter``, message).
    noise_std : float
        The joint's white velocity-noise estimate (rad/s; ``excitation.noise_std`` of ``identify --json``: the
        stick band of its compensator is three times it); NaN if none.
    lag_info : dict
        The lag fit's ``samples``, ``rate``, ``n_simulations``, ``predictor``, ``estimate`` (empty where none ran).
    min_speed : float
        The lowest speed of the joint's rows (rad/s, the filtered velocity; ``excitation.min_speed``): the
        placeholder ``Vs`` of its compensator where it keeps no Stribeck term
        (:func:`adaptive_ff.identification.stribeck_fit.placeholder_shape`); NaN if unknown.
    """

    name: str
    params: dict
    interval95: dict
    std: dict
    warnings: tuple = ()
    noise_std: float = math.nan
    lag_info: dict = field(default_factory=dict)
    min_speed: float = math.nan

    def friction(self, w) -> np.ndarray:
        """The identified static friction ``F(w)`` (eq. 3) plus the offset, at velocities ``w`` (rad/s)."""
        from plant.stribeck_map import stribeck_shape

        p = self.params
        w = np.asarray(w, dtype=float)
        s = stribeck_shape(w, p["Vs"], p["delta"]) if math.isfinite(p["Vs"]) else np.zeros_like(w)
        return np.sign(w) * (p["Fc"] + (p["Fs"] - p["Fc"]) * s) + p["sigma"] * w + p["offset"]

    def to_dict(self) -> dict:
        """The joint's entry: the layout of ``adaptive-ff identify --json``'s top level (``method`` ``"arm"``) plus
        ``name``, ``interval95``, ``excitation: {"noise_std", "min_speed"}`` (``noise_std`` as ``identify
        --json``'s) and ``lag`` (the lag
        fit's ``lag_info``); warnings as ``{"code", "parameter", "message"}``; non-finite values are null."""
        from plant.results import json_safe

        return {"name": self.name, "method": "arm", **{k: _num(self.params[k]) for k in JOINT_PARAMETERS},
                "std": {k: _num(v) for k, v in self.std.items()},
                "interval95": {k: [_num(lo), _num(hi)] for k, (lo, hi) in self.interval95.items()},
                "excitation": {"noise_std": _num(self.noise_std), "min_speed": _num(self.min_speed)}, "lag": json_safe(dict(self.lag_info)),
                "warnings": [w.to_dict() for w in self.warnings]}


@dataclass(frozen=True)
class ArmIdentification:
    """Every joint's friction and the rigid body of an arm, from one log (:func:`adaptive_ff.arm.fit.identify_arm`).

    Attributes
    ----------
    joints : tuple of ArmJoint
        In the URDF's order.
    base_names : tuple of str
        The base parameters (:class:`adaptive_ff.arm.robot.BaseParameters`), in SI units.
    base_values : ndarray, shape (r,)
        Their estimates (the URDF's values with ``rigid_body="urdf"``).
    base_interval : ndarray, shape (r, 2)
        95 % intervals (NaN with ``rigid_body="urdf"``).
    cond : float
        Condition number of the column-scaled weighted regressor (rigid body and friction).
    rigid_body : str
        ``"fit"`` (identified with the friction) or ``"urdf"`` (the URDF's inertias as given).
    info : dict
        ``cutoff`` (Hz), ``rows`` (per joint, used), ``bootstrap`` (replicates, valid, block), ``rms`` residual per
        joint (N·m), ``lagged_columns`` per joint the lag (s) its friction columns carry in the reported fit, None
        where none, ``lag_ranges`` per joint the lag range ``[low, high]`` (s) whose ends the intervals carry, None
        where none (:mod:`adaptive_ff.arm.fit`, "Lag").
    curves : tuple
        Per joint ``(dq, friction torque)`` of the log: the torque minus the identified rigid body (for
        :meth:`plot`).
    warnings : tuple of adaptive_ff.identification.plausibility.IdentificationWarning
        What concerns the whole arm (a badly conditioned regressor: the log does not excite every base parameter).
    """

    joints: tuple
    base_names: tuple
    base_values: np.ndarray
    base_interval: np.ndarray
    cond: float
    rigid_body: str = "fit"
    info: dict = field(default_factory=dict)
    curves: tuple = ()
    warnings: tuple = ()

    def joint(self, name: str) -> ArmJoint:
        """The joint called ``name``; KeyError listing the joints otherwise."""
        for j in self.joints:
            if j.name == name:
                return j
        raise KeyError(f"no joint {name!r}; the arm's joints are {[j.name for j in self.joints]}")

    def to_dict(self) -> dict:
        """``{"joints": [...], "rigid_body": {"mode", "base_parameters", "interval95", "cond"}, "info": {...}}``
        (strict JSON values: null, never NaN)."""
        from plant.results import json_safe

        rb = {"mode": self.rigid_body,
              "base_parameters": {n: _num(v) for n, v in zip(self.base_names, self.base_values)},
              "interval95": {n: [_num(lo), _num(hi)] for n, (lo, hi) in zip(self.base_names, self.base_interval)},
              "cond": _num(self.cond)}
        return {"joints": [j.to_dict() for j in self.joints], "rigid_body": rb, "info": json_safe(self.info),
                "warnings": [w.to_dict() for w in self.warnings]}

    def summary(self) -> str:
        """A table per joint (value and 95 % interval of each parameter, SI), the base parameters, the warnings."""
        units = {"J": "kg·m²", "Fc": "N·m", "Fs": "N·m", "Vs": "rad/s", "delta": "1", "sigma": "N·m·s/rad",
                 "tau": "s", "offset": "N·m"}
        lines = []
        for j in self.joints:
            lines += [f"joint {j.name}", f"  {'parameter':<9}{'value':>12}  {'95 % interval':<27}unit"]
            for k in JOINT_PARAMETERS:
                v, (lo, hi) = j.params[k], j.interval95[k]
                iv = f"[{lo:.4g}, {hi:.4g}]" if math.isfinite(lo) else "-"
                lines.append(f"  {k:<9}{v:>12.5g}  {iv:<27}{units[k]}")
            lines += [f"  WARNING: {w}" for w in j.warnings]
        lines += ["", f"rigid body ({self.rigid_body}): {len(self.base_names)} base parameters, cond {self.cond:.3g}"]
        lines += [f"WARNING: {w}" for w in self.warnings]
        for n, v, (lo, hi) in zip(self.base_names, self.base_values, self.base_interval):
            iv = f"[{lo:.4g}, {hi:.4g}]" if math.isfinite(lo) else "-"
            lines.append(f"  {v:>12.5g}  {iv:<27}{n}")
        return "\n".join(lines)

    def plot(self, ax=None):
        """Each joint's friction: the log's torque minus the identified rigid body against the velocity (dots) and
        the identified curve ``F(w) + offset`` (line); one axes per joint.

        Parameters
        ----------
        ax : sequence of matplotlib.axes.Axes, optional
            One axes per joint; None: a new figure (not managed by pyplot) with a row of axes.

        Returns
        -------
        list of matplotlib.axes.Axes
        """
        if ax is None:
            from matplotlib.figure import Figure

            fig = Figure(figsize=(4.0 * len(self.joints), 3.5), layout="constrained")
            ax = fig.subplots(1, len(self.joints), squeeze=False)[0]
        axes = list(np.atleast_1d(ax))
        for a, j, (w, f) in zip(axes, self.joints, self.curves):
            a.plot(w, f, ".", ms=2, alpha=0.4, label="torque - rigid body")
            grid = np.linspace(np.min(w), np.max(w), 400)
            a.plot(grid, j.friction(grid), "-", color="C3", label="identified F(w) + offset")
            a.set_title(j.name)
            a.set_xlabel("velocity (rad/s)")
            a.set_ylabel("friction torque (N·m)")
            a.grid(True, alpha=0.3)
        axes[0].legend(loc="best", fontsize="small")
        return axes


def read_arm_entries(path) -> list:
    """The joints' entries of an ``adaptive-ff identify-arm --json`` file, in its order (each in the layout of
    ``identify --json``'s top level, with its ``name``).

    Parameters
    ----------
    path : str or os.PathLike
        The JSON file.

    Returns
    -------
    list of dict

    Raises
    ------
    FileNotFoundError
        No such file.
    ParameterError
        Not JSON, no ``joints`` list of objects (not an ``identify-arm`` output), or a joint without a string
        ``name``.
    """
    from plant.errors import ParameterError
    from plant.models import read_json

    d = read_json(path, what="JSON arm identification (adaptive-ff identify-arm --json)")
    joints = d.get("joints") if isinstance(d, dict) else None
    if not isinstance(joints, list) or not joints or not all(isinstance(j, dict) for j in joints):
        raise ParameterError(f"{path}: no 'joints' list of objects: not an identify-arm --json output (--joint "
                             "picks one of its joints)")
    for k, j in enumerate(joints):
        if not isinstance(j.get("name"), str):
            raise ParameterError(f"{path}: joint {k + 1} has no 'name' (a string)")
    return joints


def is_arm_identification(d) -> bool:
    """True if ``d`` (a parsed JSON value) is an ``identify-arm --json`` output: an object with a ``joints`` list and
    a ``rigid_body`` object."""
    return isinstance(d, dict) and isinstance(d.get("joints"), list) and isinstance(d.get("rigid_body"), dict)


def read_arm_joint(path, name: str) -> dict:
    """One joint's entry of an ``adaptive-ff identify-arm --json`` file (the layout of ``identify --json``'s top
    level, read by :func:`adaptive_ff.identification.result_file.identification_from_dict`).

    Parameters
    ----------
    path : str or os.PathLike
        The JSON file.
    name : str
        The joint's URDF name.

    Returns
    -------
    dict

    Raises
    ------
    FileNotFoundError
        No such file.
    ParameterError
        Not JSON, no ``joints`` list of objects (not an ``identify-arm`` output), or no joint ``name`` (the joints
        of the file listed).
    """
    from plant.errors import ParameterError

    joints = read_arm_entries(path)
    for j in joints:
        if j.get("name") == name:
            return j
    raise ParameterError(f"{path}: no joint {name!r}; its joints are {[j.get('name') for j in joints]}")
