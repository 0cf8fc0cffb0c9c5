"""A velocity reference from a recorded trajectory: time and velocity, or time and position, from a file.

A robot's own motion (a recorded or planned joint trajectory) as the reference of a comparison: the file is
read by :func:`adaptive_ff.io.tables.read_columns` (CSV with a header, ``.mat``, ``.npz``; errors name the
file, the column and the row), converted to SI units, a position differentiated, and the result resampled to
the controller's step. The generated references (point-to-point moves, reversals) are in :mod:`plant.motion`.
"""

from __future__ import annotations

import math

import numpy as np

from adaptive_ff.io.logs import LogUnits
from adaptive_ff.io.tables import CsvFormat, read_columns
from adaptive_ff.io.units import TIME_UNITS, VELOCITY_UNITS
from plant.errors import ParameterError, SignalError, check_positive
from plant.excitation import Reference

__all__ = ["load_reference"]


def _position_to_rad(units: LogUnits) -> float:
    """Factor from the position unit of ``units`` to rad (``counts``: ``2*pi/counts_per_rev``)."""
    if units.position_unit == "counts":
        return 2.0 * math.pi / units.counts_per_rev
    return {"rad": 1.0, "deg": math.pi / 180.0}[units.position_unit]


def load_reference(path, *, time: str = "t", velocity: str | None = None, position: str | None = None,
                   dt: float = 1e-3, units: LogUnits = LogUnits(), csv_format: CsvFormat | None = None,
                   max_samples: int | None = None) -> Reference:
    """Read a velocity reference from a file of time and velocity, or time and position.

    Parameters
    ----------
    path : str or os.PathLike
        ``.csv``/``.txt`` with a header row, ``.mat`` or ``.npz`` (:func:`adaptive_ff.io.tables.read_columns`).
    time : str, keyword-only
        Name of the time column, default ``"t"``.
    velocity, position : str, keyword-only
        Name of the velocity column or of the position column: exactly one. A position is differentiated by
        second-order central differences on its own time stamps (``numpy.gradient``), for a planned or
        smooth recorded trajectory; a noisy measured position wants
        :func:`adaptive_ff.io.kalman_velocity.velocity_from_position` first.
    dt : float, keyword-only
        Step of the returned reference (s), > 0, default 1 ms: the file is resampled by linear interpolation
        from its first time stamp, which becomes ``t = 0``, to its last.
    units : LogUnits, keyword-only
        Units of the file's columns (:class:`adaptive_ff.io.logs.LogUnits`, as a drive log's): ``time_unit``
        ``"s"``, ``"ms"``, ``"us"``; ``velocity_unit`` ``"rad/s"``, ``"deg/s"``, ``"rpm"``; ``position_unit``
        ``"rad"``, ``"deg"``, ``"counts"`` (with ``counts_per_rev``). Default SI. A reference has no torque
        column: ``current_to_torque`` must be None.
    csv_format : CsvFormat, keyword-only, optional
        Layout of a text file (lines to skip, delimiter, ...).
    max_samples : int, keyword-only, optional
        Most samples of the resampled reference: a file that spans longer is refused before anything is
        allocated (e.g. the samples that fit into the memory available); default no limit.

    Returns
    -------
    Reference
        ``t`` from 0 in steps of ``dt``, ``w`` (rad/s) and ``dw`` (rad/s², central differences of the resampled
        ``w``; one-sided at the ends).

    Raises
    ------
    FileNotFoundError
        No such file.
    SignalError
        The file's own errors (a missing column, a cell that is not a finite number, naming the file, column
        and row), fewer than two rows, or time stamps not strictly increasing (naming the row and the value).
    ParameterError
        Neither or both of ``velocity`` and ``position``, ``units`` not a :class:`LogUnits` or with a
        ``current_to_torque``, ``dt`` not > 0, a file shorter than two steps of ``dt``, or one longer than
        ``max_samples`` steps.
    """
    if (velocity is None) == (position is None):
        raise ParameterError(f"give exactly one of velocity= and position= (the column's name), got "
                             f"velocity={velocity!r}, position={position!r}")
    if not isinstance(units, LogUnits) or units.current_to_torque is not None:
        raise ParameterError(f"units must be a LogUnits without current_to_torque (a reference has no torque "
                             f"column), got {units!r}")
    dt = check_positive("dt", dt)
    kt = TIME_UNITS[units.time_unit]
    role = "w" if velocity is not None else "q"
    k = VELOCITY_UNITS[units.velocity_unit] if role == "w" else _position_to_rad(units)
    table = read_columns(path, {"t": time, role: velocity if role == "w" else position}, csv_format=csv_format)
    t = table.columns["t"] * kt
    x = table.columns[role] * k
    if t.shape[0] < 2:
        raise SignalError(f"{table.source}: {t.shape[0]} row(s), a reference needs at least two")
    bad = np.flatnonzero(~(np.diff(t) > 0))
    if bad.size:
        i = int(bad[0]) + 1
        raise SignalError(f"{table.source}: {table.column('t')} must be strictly increasing; {table.row(i)} has "
                          f"{float(table.columns['t'][i])!r} after {float(table.columns['t'][i - 1])!r}")
    w = np.gradient(x, t) if role == "q" else x
    span = float(t[-1] - t[0])
    steps = span / dt * (1.0 + 1e-12)
    if max_samples is not None and not steps < max_samples:
        raise ParameterError(f"{table.source}: the file spans {span:g} s, {steps:.3g} samples at dt = {dt:g} s: "
                             f"more than the {max_samples:,} that fit")
    n = int(math.floor(steps)) + 1
    if n < 2:
        raise ParameterError(f"{table.source}: the file spans {span!r} s, shorter than two steps of dt = {dt!r} s")
    tr = np.arange(n) * dt
    wr = np.interp(tr + t[0], t, w)
    return Reference(t=tr, w=wr, dw=np.gradient(wr, dt))
