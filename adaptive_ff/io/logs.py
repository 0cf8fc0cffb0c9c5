r"""Reading measured drive logs: CSV, MATLAB .mat and NumPy .npz, with column maps and unit conversion.

A log from a drive holds a time stamp, the input (torque, or motor current) and
either the velocity or the position. :func:`load_log` reads such a file into
an :class:`adaptive_ff.io.data.MeasuredData` record in SI units, so that
identification (:func:`adaptive_ff.identification.identify.identify`) and the Stribeck
pre-fit (:mod:`adaptive_ff.identification.steady_state`) can use it.

The column map, the file formats and the errors of a file are described in :mod:`adaptive_ff.io.tables`
(:func:`read_columns`, :func:`parse_column_map`, :class:`CsvFormat`), the velocity from position in
:mod:`adaptive_ff.io.kalman_velocity` (:func:`velocity_from_position`); their names are re-exported here.

Units
-----
``u = K*i`` with ``K = current_to_torque`` (N·m/A, the motor torque constant
times the gear ratio, referred to the joint side; paper Sec. V-B); velocity in
rad/s, deg/s or rpm; position in rad, deg or encoder counts (``counts_per_rev``
counts per joint revolution); time in s, ms or us. Prismatic axes: read N for
N·m and m for rad and keep the SI ("rad") units, which are not converted.

Checks
------
Beyond the file's own errors (:mod:`adaptive_ff.io.tables`), :func:`load_log` refuses fewer than
:data:`adaptive_ff.io.data.MIN_SAMPLES` samples, time stamps that are not strictly increasing or jump by
more than 1e6 median intervals, a constant input and any sample beyond :data:`MAX_MAGNITUDE`, each
with a :class:`plant.errors.SignalError` naming the file, the column, the row and the value.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from adaptive_ff.io.data import MIN_SAMPLES, MeasuredData
from adaptive_ff.io.kalman_velocity import VelocityEstimate, estimate_position_noise, velocity_from_position
from adaptive_ff.io.tables import DELIMITER_NAMES, CsvFormat, Table, parse_column_map, read_columns
from adaptive_ff.io.units import KALMAN_MODELS, POSITION_UNITS, ROLES, TIME_UNITS, VELOCITY_UNITS
from plant.errors import ParameterError, SignalError, check_positive

__all__ = [
    "ROLES",
    "TIME_UNITS",
    "VELOCITY_UNITS",
    "POSITION_UNITS",
    "KALMAN_MODELS",
    "Table",
    "CsvFormat",
    "DELIMITER_NAMES",
    "MAX_MAGNITUDE",
    "LogUnits",
    "KalmanSettings",
    "VelocityEstimate",
    "parse_column_map",
    "read_columns",
    "velocity_from_position",
    "estimate_position_noise",
    "load_log",
]


# --------------------------------------------------------------------------- load a log


def _check_choice(name: str, value, choices) -> str:
    if value not in choices:
        raise ParameterError(f"{name} must be one of {list(choices)}, got {value!r}")
    return value


def _optional_positive(name: str, value) -> float | None:
    return None if value is None else check_positive(name, value)


@dataclass(frozen=True, kw_only=True)
class LogUnits:
    """Units of a drive log's columns, for :func:`load_log` (keyword-only, validated).

    Parameters
    ----------
    current_to_torque : float, optional
        ``K`` (N·m/A), > 0: the ``u`` column holds motor current ``i`` (A) and
        the torque is ``u = K*i`` (paper Sec. V-B). Default None: ``u`` is torque.
    time_unit : {"s", "ms", "us"}
        Unit of the time column (:data:`TIME_UNITS`).
    velocity_unit : {"rad/s", "deg/s", "rpm"}
        Unit of the velocity column (:data:`VELOCITY_UNITS`; ``rad/s``: not
        converted, use it for m/s).
    position_unit : {"rad", "deg", "counts"}
        Unit of the position column (:data:`POSITION_UNITS`).
    counts_per_rev : float, optional
        Encoder counts per joint revolution (> 0), required for ``counts``
        (for a motor-side encoder: counts per motor revolution times the gear ratio).

    Raises
    ------
    ParameterError
        Unknown unit, ``counts`` without ``counts_per_rev``, or a factor not > 0
        (the message names the field and the value).
    TypeError
        A factor is not a real number.
    """

    current_to_torque: float | None = None
    time_unit: str = "s"
    velocity_unit: str = "rad/s"
    position_unit: str = "rad"
    counts_per_rev: float | None = None

    def __post_init__(self):
        _check_choice("time_unit", self.time_unit, TIME_UNITS)
        _check_choice("velocity_unit", self.velocity_unit, VELOCITY_UNITS)
        _check_choice("position_unit", self.position_unit, POSITION_UNITS)
        object.__setattr__(self, "current_to_torque", _optional_positive("current_to_torque", self.current_to_torque))
        object.__setattr__(self, "counts_per_rev", _optional_positive("counts_per_rev", self.counts_per_rev))
        if self.position_unit == "counts" and self.counts_per_rev is None:
            raise ParameterError("position_unit='counts' needs counts_per_rev (encoder counts per joint revolution)")


@dataclass(frozen=True, kw_only=True)
class KalmanSettings:
    """Settings of the Kalman velocity estimate from position (:func:`velocity_from_position`), keyword-only.

    Parameters
    ----------
    model : {"cv", "ca"}
        Constant-velocity or constant-acceleration model (:data:`KALMAN_MODELS`).
    bandwidth : float, optional
        Estimator bandwidth (Hz), > 0; default a tenth of the sample rate.
    position_noise : float, optional
        Position noise standard deviation (rad), > 0; default the encoder
        quantisation noise for counts, else estimated from the data.
    smooth : bool
        Filter + Rauch-Tung-Striebel smoother (default) or the causal filter only.

    Raises
    ------
    ParameterError
        Unknown model, or ``bandwidth``/``position_noise`` not > 0 (the message
        names the field as the ``kalman_``-prefixed option of the command line).
    TypeError
        A value is not a real number.
    """

    model: str = "cv"
    bandwidth: float | None = None
    position_noise: float | None = None
    smooth: bool = True

    def __post_init__(self):
        _check_choice("kalman_model", self.model, KALMAN_MODELS)
        object.__setattr__(self, "bandwidth", _optional_positive("kalman_bandwidth", self.bandwidth))
        object.__setattr__(self, "position_noise", _optional_positive("position_noise", self.position_noise))
        object.__setattr__(self, "smooth", bool(self.smooth))


def _column_names(columns) -> dict:
    """``{role: file name}`` of the roles to read, from a column map (mapping, text or None)."""
    if columns is None:
        cmap: dict = {}
    elif isinstance(columns, str):
        cmap = parse_column_map(columns)
    else:
        cmap = {str(k): str(v) for k, v in dict(columns).items()}
        unknown = [k for k in cmap if k not in ROLES]
        if unknown:
            raise ParameterError(f"unknown role(s) {unknown} in the column map; roles are {list(ROLES)}")
    if "w" in cmap and "q" in cmap:
        raise ParameterError(f"map either w (velocity, {cmap['w']!r}) or q (position, {cmap['q']!r}), not both")
    names = {"t": cmap.get("t", "t"), "u": cmap.get("u", "u")}
    if "q" in cmap:
        names["q"] = cmap["q"]
    else:
        names["w"] = cmap.get("w", "w")
    digits = [r for r, v in names.items() if v.strip().isdigit()]
    if digits and len(digits) != len(names):
        raise ParameterError(f"column map {names}: map every role by 0-based index (a headerless file, e.g. "
                             "t=0,u=1,w=2) or every role by name, not a mix")
    return names


#: Largest plausible magnitude of a torque (N·m), velocity (rad/s) or position (rad) sample. A value
#: beyond it is a corrupt cell (e.g. 1e308) and would overflow the regression sums.
MAX_MAGNITUDE = 1e12


def _check_magnitude(table: Table, role: str, x: np.ndarray, unit: str) -> None:
    """SignalError naming file, column, row and value of the first sample with ``|x| > MAX_MAGNITUDE``."""
    bad = np.flatnonzero(np.abs(x) > MAX_MAGNITUDE)
    if bad.size:
        i = int(bad[0])
        raise SignalError(f"{table.source}: {table.column(role)}, {table.row(i)}: value {float(table.columns[role][i])!r} "
                          f"is outside the plausible range |{role}| <= {MAX_MAGNITUDE:g} {unit} (a corrupt cell?)")


def _check_time_and_input(table: Table, t: np.ndarray, u: np.ndarray, min_samples: int) -> None:
    """SignalError naming file, column and row for too few rows, time not increasing, or constant input."""
    where = table.source
    n = t.shape[0]
    if n < min_samples:
        raise SignalError(f"{where}: {n} samples, at least {min_samples} needed")
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        now, before = float(table.columns["t"][i]), float(table.columns["t"][i - 1])
        raise SignalError(f"{where}: {table.column('t')} must be strictly increasing; {table.row(i)} has "
                          f"{now!r} <= {before!r} at {table.row(i - 1)}")
    dt = np.diff(t)
    med = float(np.median(dt))
    gap = np.flatnonzero(dt > 1e6 * med)
    if gap.size:
        i = int(gap[0]) + 1
        raise SignalError(f"{where}: {table.column('t')}, {table.row(i)}: time stamp {float(table.columns['t'][i])!r} "
                          f"jumps by {float(dt[i - 1]):.3g} s, more than 1e6 times the median interval {med:.3g} s "
                          "(a corrupt cell?)")
    if np.all(u == u[0]):
        raise SignalError(f"{where}: {table.column('u')} is constant ({float(u[0])!r} in all {n} rows, "
                          f"{table.row(0)} to {table.row(n - 1)}); the input does not excite the plant")


def _velocity(table: Table, t: np.ndarray, units: LogUnits, kalman: KalmanSettings, progress, notes: list):
    """Velocity (rad/s) from the ``w`` column, or from ``q`` by the Kalman estimate; appends to ``notes``."""
    if "w" in table.columns:
        w_scale = VELOCITY_UNITS[units.velocity_unit]
        if w_scale != 1.0:
            notes.append(f"velocity converted from {units.velocity_unit} to rad/s")
        return table.columns["w"] * w_scale
    q = table.columns["q"]
    sd = kalman.position_noise
    if units.position_unit == "counts":
        cpr = units.counts_per_rev
        step = 2.0 * math.pi / cpr
        q = q * step
        sd = sd if sd is not None else step / math.sqrt(12.0)
        notes.append(f"position from counts: {cpr:g} counts/rev, step {step:.6g} rad")
    elif units.position_unit == "deg":
        q = q * (math.pi / 180.0)
        notes.append("position converted from deg to rad")
    est = velocity_from_position(t, q, model=kalman.model, bandwidth=kalman.bandwidth, position_noise=sd,
                                 smooth=kalman.smooth, progress=progress)
    notes.append(f"w from position by a Kalman {'filter + RTS smoother' if kalman.smooth else 'filter'} "
                 f"({'constant-velocity' if kalman.model == 'cv' else 'constant-acceleration'} model, "
                 f"bandwidth {est.bandwidth:.4g} Hz, position noise {est.position_noise:.3g} rad)")
    return est.w


def load_log(path, *, columns: Mapping | str | None = None, units: LogUnits | None = None,
             kalman: KalmanSettings | None = None, min_samples: int = MIN_SAMPLES,
             progress: bool | None = False, csv_format: CsvFormat | None = None) -> MeasuredData:
    """Read a drive log (CSV, .mat, .npz) into a :class:`MeasuredData` record in SI units.

    Parameters
    ----------
    path : str or os.PathLike
        The file (see :func:`read_columns` for the formats).
    columns : mapping or str, keyword-only, optional
        Column map ``{role: name}`` or its text form ``"t=time,u=current,w=vel"``
        (:func:`parse_column_map`). Roles ``t`` and ``u`` default to their own
        names; ``w`` defaults to ``"w"`` unless ``q`` (position) is mapped.
        Mapping both ``w`` and ``q`` is an error.
    units : LogUnits, keyword-only, optional
        Units of the columns (current-to-torque factor, time, velocity and
        position units, encoder counts per revolution); default ``LogUnits()``:
        s, N·m, rad/s, rad.
    kalman : KalmanSettings, keyword-only, optional
        Settings of :func:`velocity_from_position` when ``q`` is mapped; default
        ``KalmanSettings()``. The default noise for counts is the quantisation
        noise ``(2*pi/counts_per_rev)/sqrt(12)``.
    min_samples : int, keyword-only
        Fewest samples accepted (default :data:`adaptive_ff.io.data.MIN_SAMPLES`), >= 4.
    progress : bool or None, keyword-only
        Progress bar of the Kalman pass (None: when on a terminal; default off).
    csv_format : CsvFormat, keyword-only, optional
        Layout of a text log: lines to skip, header line, delimiter
        (:class:`CsvFormat`); map roles to 0-based indices in ``columns`` for
        a file without a header.

    Returns
    -------
    MeasuredData
        ``t`` (s, as read: not resampled, may be non-uniform), ``u`` (N·m),
        ``w`` (rad/s); ``source`` is the path and ``notes`` list the
        conversions applied.

    Raises
    ------
    FileNotFoundError
        No such file.
    SignalError
        See :func:`read_columns`; plus fewer than ``min_samples`` rows, time
        stamps not strictly increasing, constant input, or a torque, velocity
        or position beyond :data:`MAX_MAGNITUDE` (SI units); each message names
        the file, the column, the row and the value.
    ParameterError
        Bad column map, ``min_samples`` < 4, or a bad Kalman bandwidth for the
        data (bad units and settings are rejected by :class:`LogUnits` and
        :class:`KalmanSettings` themselves).
    TypeError
        ``units`` or ``kalman`` of the wrong type.

    Notes
    -----
    ``u = K*i`` with the motor torque constant times the gear ratio ``K``
    (Ruderman, Sec. V-B); velocity from position as in the module docstring.
    """
    units = LogUnits() if units is None else units
    kalman = KalmanSettings() if kalman is None else kalman
    if not isinstance(units, LogUnits):
        raise TypeError(f"units must be a LogUnits, got {type(units).__name__}")
    if not isinstance(kalman, KalmanSettings):
        raise TypeError(f"kalman must be a KalmanSettings, got {type(kalman).__name__}")
    if isinstance(min_samples, bool) or not isinstance(min_samples, (int, np.integer)) or min_samples < 4:
        raise ParameterError(f"min_samples must be an integer >= 4, got {min_samples!r}")

    table = read_columns(path, _column_names(columns), csv_format=csv_format)
    t_scale = TIME_UNITS[units.time_unit]
    t = table.columns["t"] * t_scale
    u = table.columns["u"]
    _check_time_and_input(table, t, u, min_samples)
    notes = [f"read {t.shape[0]} rows of {table.kind.upper()}: "
             + ", ".join(f"{r}={nm!r}" for r, nm in table.names.items())]
    if t_scale != 1.0:
        notes.append(f"time converted from {units.time_unit} to s")
    K = units.current_to_torque
    if K is not None:
        u = K * u
        notes.append(f"u = K*i with K = current_to_torque = {K:g} N·m/A (paper Sec. V-B)")
    _check_magnitude(table, "u", u, "N·m")
    if "q" in table.columns:
        _check_magnitude(table, "q", table.columns["q"], "(position unit)")
    w = _velocity(table, t, units, kalman, progress, notes)
    if "w" in table.columns:
        _check_magnitude(table, "w", w, "rad/s")
    return MeasuredData(t, u, w, source=table.source, notes=tuple(notes), w_from_position="w" not in table.columns)
