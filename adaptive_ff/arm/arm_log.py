"""A multi-joint log (``t, q1..qN, dq1..dqN, tau1..tauN``): reading, writing, and the filtered derivatives.

Velocities and accelerations come from the positions by zero-phase filtered differentiation: a 4th-order
Butterworth low-pass run forwards and backwards (:func:`scipy.signal.filtfilt`, so no lag) on the positions, then
central differences (:func:`numpy.gradient`). The torques go through the same filter, so that both sides of the
inverse dynamic model see the same filter (Gautier's parallel filtering, IEEE TRA 13(1), 1997), and the rows are
then decimated to about 5 times the cutoff (the filter has removed what lies above it).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from plant.errors import ParameterError, SignalError

__all__ = ["ArmLog", "ParallelFilter", "read_arm_log", "write_arm_log", "filtered_states", "parallel_filter",
           "column_names", "DEFAULT_CUTOFF"]

#: Default cutoff (Hz) of the zero-phase low-pass before differentiation: the arm's rigid-body motion of an
#: identification trajectory lies well below it, the sensor noise mostly above.
DEFAULT_CUTOFF = 20.0


@dataclass(frozen=True)
class ArmLog:
    """A multi-joint log in SI units.

    Attributes
    ----------
    t : ndarray, shape (n,)
        Time (s), increasing.
    q, tau : ndarray, shape (n, N)
        Joint positions (rad or m) and torques (N·m or N).
    dq : ndarray or None, shape (n, N)
        Measured velocities, or None (then they come from ``q``).
    source : str
        The file (for messages).
    """

    t: np.ndarray
    q: np.ndarray
    tau: np.ndarray
    dq: np.ndarray | None = None
    source: str = "log"

    @property
    def n_joints(self) -> int:
        """Number of joints N."""
        return int(self.q.shape[1])


def column_names(n: int, columns: str | None = None) -> dict:
    """``{role: column name}`` of an N-joint log: ``t, q1..qN, dq1..dqN, tau1..tauN`` unless ``columns`` (a map
    ``role=name,...`` with those roles) renames some.

    Raises
    ------
    ParameterError
        An item without ``=``, a role that is not one of the log's, or a role given twice.
    """
    roles = {"t": "t", **{f"{p}{j + 1}": f"{p}{j + 1}" for p in ("q", "dq", "tau") for j in range(n)}}
    if columns:
        seen = set()
        for item in (x.strip() for x in columns.split(",") if x.strip()):
            role, sep, name = (s.strip() for s in item.partition("="))
            if not sep or not role or not name:
                raise ParameterError(f"--columns item {item!r}: expected role=name, e.g. q1=shoulder_pos")
            if role not in roles:
                raise ParameterError(f"--columns item {item!r}: unknown role {role!r} for a {n}-joint arm "
                                     f"(roles t, q1..q{n}, dq1..dq{n}, tau1..tau{n})")
            if role in seen:
                raise ParameterError(f"--columns names role {role!r} twice")
            seen.add(role)
            roles[role] = name
    return roles


def read_arm_log(path, n_joints: int, *, columns: str | None = None, joint_names=None, urdf=None) -> ArmLog:
    """Read an N-joint log (CSV/TXT with a header, .mat, .npz; :func:`adaptive_ff.io.tables.read_columns`).

    The columns are ``t, q1..qN, [dq1..dqN], tau1..tauN`` (joints in the URDF's order), or named after the
    joints: ``q_<joint>``, ``[dq_<joint>]``, ``tau_<joint>`` with the URDF's joint names (any order, names
    matched without case; CSV/TXT and .npz), or mapped by ``columns``.

    Parameters
    ----------
    path : str or os.PathLike
        The log.
    n_joints : int
        N, the URDF's joint count.
    columns : str, optional
        Column map ``role=name,...`` (roles ``t``, ``qJ``, ``dqJ``, ``tauJ``).
    joint_names : sequence of str, optional
        The URDF's joint names, for messages and for columns named after joints.
    urdf : str or os.PathLike, optional
        The URDF, for messages.

    Returns
    -------
    ArmLog
        ``dq`` None when the log has no velocity columns (all of them absent).

    Raises
    ------
    FileNotFoundError, SignalError
        From the reader: a missing column (named, with the joint), a cell that is not a number.
    SignalError
        Fewer than 50 rows, time not strictly increasing, some but not all velocity columns; the log and the URDF
        disagree: more or fewer joint columns than the URDF has joints, a column named after a joint the URDF
        does not have, a URDF joint without its named column (file, column and joint named).
    """
    from adaptive_ff.io.tables import read_columns

    header = None if columns else _header(path)
    names = column_names(n_joints, columns)
    if header is not None and joint_names:
        names = _joint_named_columns(path, header, joint_names, urdf) or names
    dq_roles = [f"dq{j + 1}" for j in range(n_joints)]
    label = (lambda j: f"joint {j + 1} ({joint_names[j]!r})") if joint_names else (lambda j: f"joint {j + 1}")
    try:
        table = read_columns(path, names, optional=dq_roles)
    except SignalError as exc:
        m = re.search(r"column '[^']*' \(role (\w+):", str(exc))
        if m is None or m.group(1) == "t":
            raise
        j = int(re.sub(r"\D", "", m.group(1))) - 1
        _check_joint_count(path, header, n_joints, joint_names, urdf, j)
        text = str(exc).split(". Choose the header")[0]
        raise SignalError(f"{text}: the {m.group(1)} column of {label(j)} of the URDF (map yours with --columns "
                          f"{m.group(1)}=NAME)") from None
    extra = _extra_joint_column(header, n_joints)
    if extra is not None:
        raise SignalError(f"{path}: the log has a column {extra!r} but the URDF{_of(urdf)} has {n_joints} joints: "
                          "the log and the URDF disagree on the joint count")
    c = table.columns
    t = c["t"]
    if t.shape[0] < 50:
        raise SignalError(f"{path}: {t.shape[0]} rows; the whole-arm identification needs at least 50")
    if np.any(np.diff(t) <= 0):
        k = int(np.flatnonzero(np.diff(t) <= 0)[0])
        raise SignalError(f"{path}: time {names['t']!r} is not strictly increasing at row {k + 1}")
    have = [r for r in dq_roles if r in c]
    if have and len(have) != n_joints:
        j = next(i for i, r in enumerate(dq_roles) if r not in c)
        raise SignalError(f"{path}: velocity column {names[dq_roles[j]]!r} of {label(j)} is missing while others "
                          "are given: give every dqJ or none (then they come from the positions)")
    stack = (lambda p: np.column_stack([c[f"{p}{j + 1}"] for j in range(n_joints)]))
    return ArmLog(t=t, q=stack("q"), tau=stack("tau"), dq=stack("dq") if have else None, source=str(path))


def _of(urdf) -> str:
    return f" ({urdf})" if urdf else ""


def _header(path) -> list | None:
    """The column names of a CSV/TXT log's header (the first line that is neither blank nor a comment) or the
    arrays of an .npz; None for other files or a file that does not open (the reader says why)."""
    path = Path(path)
    suffix = path.suffix.lower()
    try:
        if suffix == ".npz":
            with np.load(path, allow_pickle=False) as npz:
                return list(npz.files)
        if suffix not in (".csv", ".txt"):
            return None
        with open(path, encoding="utf-8", errors="replace") as fh:
            for line in fh:
                if line.strip() and not line.lstrip().startswith("#"):
                    return [x.strip() for x in re.split(r"[,;\t]|\s+", line.strip()) if x.strip()]
    except (OSError, ValueError, AttributeError, TypeError):
        return None
    return None


_NAMED = re.compile(r"^(q|dq|tau)_(.+)$", re.IGNORECASE)


def _joint_named_columns(path, header, joint_names, urdf) -> dict | None:
    """The role map of a log whose columns are named after joints (``q_<joint>``, ``dq_<joint>``,
    ``tau_<joint>``), None when they are not (no ``q_<name>`` column, or numbered ``q1`` columns)."""
    named = {}
    for h in header:
        m = _NAMED.match(h)
        if m:
            named[(m.group(1).lower(), m.group(2).lower())] = h
    log_joints = [j for (p, j) in named if p == "q"]
    if not log_joints or "q1" in {h.lower() for h in header}:
        return None
    urdf_names = [n.lower() for n in joint_names]
    for j in log_joints:
        if j not in urdf_names:
            raise SignalError(f"{path}: column {named[('q', j)]!r} names joint {j!r}, which the URDF{_of(urdf)} "
                              f"does not have (its joints: {', '.join(joint_names)}): the log and the URDF disagree "
                              "on the joint names")
    roles = {"t": "t"}
    for k, n in enumerate(joint_names):
        for p in ("q", "dq", "tau"):
            if (p, n.lower()) in named:
                roles[f"{p}{k + 1}"] = named[(p, n.lower())]
            elif p != "dq":
                raise SignalError(f"{path}: no column '{p}_{n}' for joint {k + 1} ({n!r}) of the URDF{_of(urdf)}; "
                                  f"the log's columns name the joints {log_joints}: the log and the URDF disagree "
                                  "on the joints")
            else:
                roles[f"{p}{k + 1}"] = f"dq_{n}"  # absent: optional
    return roles


def _check_joint_count(path, header, n, joint_names, urdf, j) -> None:
    """A SignalError naming the joint count when the log's numbered columns stop before the URDF's joints do
    (``q1..qm``, ``tau1..taum`` with ``m < n``, and the missing column is of joint ``j >= m``)."""
    if header is None:
        return
    lower = {h.lower() for h in header}
    m = 0
    while f"q{m + 1}" in lower or f"tau{m + 1}" in lower:
        m += 1
    if 0 < m < n and j >= m and not any(f"{p}{k + 1}" in lower for p in ("q", "tau") for k in range(m, n)):
        missing = f" ({joint_names[m]!r})" if joint_names else ""
        raise SignalError(f"{path}: the log has the columns of {m} joint{'s' if m > 1 else ''} (q1..q{m}, "
                          f"tau1..tau{m}), the URDF{_of(urdf)} has {n}: the log and the URDF disagree on the joint "
                          f"count (joint {m + 1}{missing} has no column)")


def _extra_joint_column(header, n: int) -> str | None:
    """``q{n+1}`` or ``tau{n+1}`` when the log's header has it (the log has more joints than the URDF)."""
    if header is None:
        return None
    lower = {h.lower() for h in header}
    for p in ("q", "tau"):
        if f"{p}{n + 1}" in lower:
            return f"{p}{n + 1}"
    return None


def write_arm_log(log: ArmLog, path) -> Path:
    """Write ``log`` as CSV with the header ``t,q1..qN,dq1..dqN,tau1..tauN`` (``dq`` columns only when given)."""
    path = Path(path)
    n = log.n_joints
    blocks = [log.t[:, None], log.q] + ([log.dq] if log.dq is not None else []) + [log.tau]
    head = ["t"] + [f"q{j + 1}" for j in range(n)] + ([f"dq{j + 1}" for j in range(n)] if log.dq is not None
                                                      else []) + [f"tau{j + 1}" for j in range(n)]
    np.savetxt(path, np.hstack(blocks), delimiter=",", header=",".join(head), comments="", fmt="%.10g")
    return path


@dataclass(frozen=True)
class ParallelFilter:
    """The zero-phase low-pass and decimation of :func:`filtered_states`, to put any signal of the log's rate through
    what the torque goes through.

    Attributes
    ----------
    b, a : ndarray
        The 4th-order Butterworth low-pass (:func:`scipy.signal.butter`), run forwards and backwards.
    keep : slice
        The rows kept: the filter's start-up at both ends left out, then every ``step``-th sample.
    """

    b: np.ndarray
    a: np.ndarray
    keep: slice

    def __call__(self, x) -> np.ndarray:
        """``x`` (n,) or (n, N) at the log's rate, filtered and decimated as the torque of :func:`filtered_states`."""
        from scipy.signal import filtfilt

        return filtfilt(self.b, self.a, np.asarray(x, dtype=float), axis=0)[self.keep]


def parallel_filter(log: ArmLog, cutoff: float = DEFAULT_CUTOFF) -> ParallelFilter:
    """The filter and decimation of :func:`filtered_states` for ``log`` and ``cutoff`` (its checks and errors)."""
    from scipy.signal import butter

    dt = np.diff(log.t)
    Ts = float(np.median(dt))
    if np.max(np.abs(dt - Ts)) > 0.01 * Ts:
        raise SignalError(f"{log.source}: time stamps not uniform (intervals {dt.min():.6g} to {dt.max():.6g} s); "
                          "the filtered differentiation needs one sample time")
    nyq = 0.5 / Ts
    if not (np.isfinite(cutoff) and 0.0 < cutoff < nyq):
        raise ParameterError(f"--cutoff must be in (0, {nyq:.6g}) Hz (the log's Nyquist frequency), got {cutoff!r}")
    b, a = butter(4, cutoff / nyq)
    if log.t.shape[0] <= 3 * max(len(a), len(b)) * 4:
        raise SignalError(f"{log.source}: {log.t.shape[0]} rows are too few for the {cutoff:g} Hz filter")
    step = max(1, int(nyq / (2.5 * cutoff)))
    edge = min(int(round(1.0 / (cutoff * Ts))), log.t.shape[0] // 10)  # the filter's start-up at both ends
    return ParallelFilter(b=b, a=a, keep=slice(edge, log.t.shape[0] - edge, step))


def filtered_states(log: ArmLog, cutoff: float = DEFAULT_CUTOFF, *, decimate: bool = True) -> tuple:
    """Zero-phase filtered ``(t, q, dq, ddq, tau)`` of ``log``, decimated to about ``5 * cutoff`` samples per second.

    Parameters
    ----------
    log : ArmLog
        The log; its time stamps must be uniform within 1 % (their median is the sample time).
    cutoff : float
        Cutoff (Hz) of the 4th-order Butterworth low-pass (filtfilt), below the Nyquist frequency.
    decimate : bool, keyword-only
        True (default): the rows of :func:`parallel_filter` (start-up at both ends left out, decimated); False:
        every sample of the log (``m = n``).

    Returns
    -------
    tuple of ndarray
        ``t`` (m,), ``q, dq, ddq, tau`` (m, N). ``dq``: the measured velocity filtered, or the derivative of the
        filtered position; ``ddq``: the derivative of that velocity.

    Raises
    ------
    SignalError
        Irregular time stamps, or a log shorter than the filter needs.
    ParameterError
        ``cutoff`` not positive or not below the Nyquist frequency.
    """
    from scipy.signal import filtfilt

    pf = parallel_filter(log, cutoff)
    b, a, keep = pf.b, pf.a, (pf.keep if decimate else slice(None))
    Ts = float(np.median(np.diff(log.t)))
    q = filtfilt(b, a, log.q, axis=0)
    dq = filtfilt(b, a, log.dq, axis=0) if log.dq is not None else np.gradient(q, Ts, axis=0)
    ddq = np.gradient(dq, Ts, axis=0)
    tau = filtfilt(b, a, log.tau, axis=0)
    return log.t[keep], q[keep], dq[keep], ddq[keep], tau[keep]
