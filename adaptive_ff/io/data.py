"""Measured input/velocity records: loading (CSV, EMPS .mat), validation, uniform resampling.

Identification by eq. 4 needs ``u(k)``, ``w(k)`` on a uniform grid of sample time
``Ts``. This module turns files into a validated :class:`MeasuredData` record and,
where the time stamps jitter by more than a tolerance, resamples it to a uniform
grid (:func:`to_uniform`).

EMPS preprocessing (:func:`load_emps`) follows the benchmark's reference
procedure (Janot, Gautier, Brunot, "Data Set and Reference Models of EMPS",
2019): the encoder position is low-pass filtered forward and backward with a
4th-order Butterworth filter and differentiated by central differences; the
first 49 samples are dropped. Here the force ``u`` passes through the same
zero-phase filter, so that ``u`` and ``w`` cover the same delay-free band.

Choice of the 100 Hz cutoff (measured on ``DATA_EMPS.mat``): the encoder quantum
is 5e-8 m, and the power spectrum of the raw central-difference velocity is
1.7e3 times its quantisation floor at 40-60 Hz, 16 times at 100-120 Hz and 1.3
times at 300-320 Hz, so above about 100 Hz the velocity is mostly encoder noise.
The Coulomb + viscous LS estimates (``lag=False``) hardly move for cutoffs from
50 to 300 Hz (J 95.52 +- 0.01, sigma 200.1-200.6, Fc 20.57-20.63); below 50 Hz
they drift (30 Hz: sigma -2.5 %, Fc +2.1 % from published). 100 Hz, the
benchmark's value, lies in the middle of that plateau.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from adaptive_ff.io.tables import number_cell
from plant.errors import ParameterError, SignalError, check_not_special, check_positive, check_signal, check_time
from plant.results import axes_or_new, json_safe

__all__ = [
    "MeasuredData",
    "MIN_SAMPLES",
    "EMPS_CUTOFF",
    "EMPS_SKIP",
    "load_csv",
    "load_emps",
    "load_measurements",
    "is_uniform",
    "to_uniform",
]

#: Fewest samples a CSV record may have.
MIN_SAMPLES = 20
#: Default cutoff (Hz) of the zero-phase Butterworth filter for EMPS (see module docstring).
EMPS_CUTOFF = 100.0
#: Samples the EMPS benchmark drops at the start of the record.
EMPS_SKIP = 49
#: Variables a valid EMPS .mat file must hold.
_EMPS_VARS = ("t", "qm", "vir", "gtau")


def _frozen_copy(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float, copy=True)
    a.flags.writeable = False
    return a


@dataclass(frozen=True)
class MeasuredData:
    """A measured record of input and velocity at common time stamps.

    Parameters
    ----------
    t : array_like, shape (N,)
        Time stamps (s), finite and strictly increasing; need not be uniform.
    u : array_like, shape (N,)
        Input torque (N·m) or force (N, prismatic axis).
    w : array_like, shape (N,)
        Velocity (rad/s) or (m/s, prismatic axis).
    source : str, optional
        Where the data come from (file path or description).
    notes : tuple of str, optional
        Preprocessing applied (filters, dropped samples, resampling).
    w_from_position : bool, optional
        True when ``w`` was derived from a measured position (an encoder: the EMPS records of :func:`load_emps`,
        a log whose position column ``q`` :func:`adaptive_ff.io.logs.load_log` differentiated); False (default)
        for a measured velocity. :func:`adaptive_ff.identification.identify.choose_method` picks the inverse
        dynamic model (IDIM) for such a log.

    Raises
    ------
    SignalError
        Non-finite values, shapes differ, fewer than 2 samples, or ``t`` not
        strictly increasing (via :func:`plant.errors.check_time` /
        :func:`plant.errors.check_signal`).

    Notes
    -----
    The arrays are stored as read-only copies, so the record is immutable.
    """

    t: np.ndarray
    u: np.ndarray
    w: np.ndarray
    source: str = ""
    notes: tuple[str, ...] = field(default_factory=tuple)
    w_from_position: bool = False

    def __post_init__(self):
        t = check_time("t", self.t)
        u = check_signal("u", self.u, n=t.shape[0])
        w = check_signal("w", self.w, n=t.shape[0])
        object.__setattr__(self, "t", _frozen_copy(t))
        object.__setattr__(self, "u", _frozen_copy(u))
        object.__setattr__(self, "w", _frozen_copy(w))
        object.__setattr__(self, "source", str(self.source))
        object.__setattr__(self, "notes", tuple(str(n) for n in self.notes))
        if not isinstance(self.w_from_position, (bool, np.bool_)):
            raise TypeError(f"w_from_position must be a bool, got {self.w_from_position!r}")
        object.__setattr__(self, "w_from_position", bool(self.w_from_position))

    @property
    def n_samples(self) -> int:
        """Number of samples ``N``."""
        return int(self.t.shape[0])

    @property
    def Ts(self) -> float:
        """Median sample interval (s)."""
        return float(np.median(np.diff(self.t)))

    def to_dict(self, *, arrays: bool = False) -> dict:
        """Record description as strict JSON; with ``arrays=True`` also ``t`` (s), ``u`` (N·m), ``w`` (rad/s).

        Keys: ``source``, ``notes``, ``n_samples``, ``duration`` (s), ``Ts``
        (median interval, s), ``Ts_min``, ``Ts_max`` (s), ``uniform``
        (:func:`is_uniform` at 1 %), ``w_from_position``.
        """
        d = np.diff(self.t)
        out = {"source": self.source, "notes": list(self.notes), "n_samples": self.n_samples,
               "duration": float(self.t[-1] - self.t[0]), "Ts": self.Ts, "Ts_min": float(d.min()),
               "Ts_max": float(d.max()), "uniform": is_uniform(self.t), "w_from_position": self.w_from_position}
        if arrays:
            out.update(t=self.t, u=self.u, w=self.w)
        return json_safe(out)

    def summary(self) -> str:
        """One line: source, samples, duration and sample time."""
        d = np.diff(self.t)
        return (f"{self.source or 'data'}: {self.n_samples} samples over {float(self.t[-1] - self.t[0]):.4g} s, "
                f"sample time median {1e3 * self.Ts:.4g} ms (min {1e3 * float(d.min()):.4g}, "
                f"max {1e3 * float(d.max()):.4g})")

    def plot(self, ax=None):
        """Velocity (rad/s, left axis) and input torque (N·m, right axis) over time (s).

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes for the velocity; default a new figure. The torque goes on ``ax.twinx()``.

        Returns
        -------
        matplotlib.axes.Axes
            The velocity axes.
        """
        ax = axes_or_new(ax)
        ax.plot(self.t, self.w, color="C0", lw=0.8, label="velocity w")
        ax.set_xlabel("time t (s)")
        ax.set_ylabel("velocity w (rad/s)", color="C0")
        ax2 = ax.twinx()
        ax2.plot(self.t, self.u, color="C1", lw=0.6, alpha=0.8, label="input u")
        ax2.set_ylabel("input u (N·m)", color="C1")
        ax.grid(True, alpha=0.3)
        ax.set_title(self.source, fontsize=9, loc="left")
        return ax


def is_uniform(t, *, rtol: float = 0.01) -> bool:
    """True if every interval of ``t`` is within ``rtol`` of the median interval.

    Parameters
    ----------
    t : array_like, shape (N,)
        Time stamps (s), strictly increasing, N >= 2.
    rtol : float, keyword-only
        Relative tolerance, > 0 (default 1 %).

    Returns
    -------
    bool
        ``max |diff(t) - median(diff(t))| <= rtol * median(diff(t))``.

    Raises
    ------
    SignalError
        ``t`` not finite, not 1-D or not strictly increasing.
    ParameterError
        ``rtol`` not > 0.
    """
    rtol = check_positive("rtol", rtol)
    t = check_time("t", t)
    dt = np.diff(t)
    Ts = float(np.median(dt))
    return bool(np.max(np.abs(dt - Ts)) <= rtol * Ts)


def to_uniform(data: MeasuredData, *, rtol: float = 0.01) -> MeasuredData:
    """Return ``data`` on a uniform time grid, resampling if the sampling is not uniform.

    Parameters
    ----------
    data : MeasuredData
        The record.
    rtol : float, keyword-only
        Tolerance of :func:`is_uniform` (default 1 %).

    Returns
    -------
    MeasuredData
        ``data`` itself if :func:`is_uniform` holds; otherwise ``u`` and ``w``
        linearly interpolated (``numpy.interp``) onto ``t[0] + k*Ts``,
        ``Ts = median(diff(t))``, ``k = 0 .. floor((t[-1] - t[0])/Ts)``, with a
        note saying so.

    Raises
    ------
    TypeError
        ``data`` is not a :class:`MeasuredData`.
    ParameterError
        ``rtol`` not > 0.

    Notes
    -----
    Linear interpolation is a stop-gap: it low-pass filters the signals and
    invents values across long gaps. The paper (Sec. V-D) identifies on the
    irregular samples directly; regressors with per-sample ``Ts(k)`` are future
    work.
    """
    if not isinstance(data, MeasuredData):
        raise TypeError(f"data must be a MeasuredData, got {type(data).__name__}")
    if is_uniform(data.t, rtol=rtol):
        return data
    tu, note = _uniform_grid(data.t, rtol)
    return MeasuredData(tu, np.interp(tu, data.t, data.u), np.interp(tu, data.t, data.w), source=data.source,
                        notes=data.notes + (note + "; u, w linearly interpolated",), w_from_position=data.w_from_position)


def _uniform_grid(t: np.ndarray, rtol: float) -> tuple[np.ndarray, str]:
    """Uniform grid ``t[0] + k*Ts`` at the median interval over the span of ``t``, and a note."""
    dt = np.diff(t)
    Ts = float(np.median(dt))
    n = int(math.floor((t[-1] - t[0]) / Ts * (1 + 1e-12))) + 1
    note = (f"resampled to a uniform grid: intervals ranged {dt.min():.6g}..{dt.max():.6g} s "
            f"(more than {100 * rtol:g} % from the median {Ts:.6g} s); {n} samples at Ts = {Ts:.6g} s")
    return t[0] + Ts * np.arange(n), note


def _check_record(where: str, t: np.ndarray, u: np.ndarray, lines: list[int] | None = None,
                  u_name: str = "u") -> None:
    """Record-level checks shared by the loaders: length, increasing time, non-constant u."""
    def at(i: int) -> str:
        return f"row {i + 1} (line {lines[i]})" if lines is not None else f"index {i}"

    if t.shape[0] < MIN_SAMPLES:
        raise SignalError(f"{where}: {t.shape[0]} samples, at least {MIN_SAMPLES} needed")
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise SignalError(f"{where}: column 't' must be strictly increasing; {at(i)} has t = {float(t[i])!r} "
                          f"<= t = {float(t[i - 1])!r} at {at(i - 1)}")
    if np.all(u == u[0]):
        raise SignalError(f"{where}: column {u_name!r} is constant ({float(u[0])!r} in all {u.shape[0]} samples); "
                          "the input does not excite the plant")


def load_csv(path) -> MeasuredData:
    """Read a measured record from a CSV file with columns ``t, u, w``.

    Parameters
    ----------
    path : str or os.PathLike
        CSV file. Blank lines are skipped. The first other line is the header;
        a leading ``#`` on it is ignored (as written by ``numpy.savetxt`` with
        its default ``comments``). Later lines starting with ``#`` are comments.
        Columns are found by name (case-insensitive, surrounding spaces
        ignored); ``t`` in s, ``u`` in N·m (or N), ``w`` in rad/s (or m/s).
        Other columns are ignored.

    Returns
    -------
    MeasuredData
        Time stamps as read (not resampled; see :func:`to_uniform`).

    Raises
    ------
    FileNotFoundError
        No such file.
    SignalError
        Empty file; a required column missing from the header; a row too
        short, a cell that is not a number, or a NaN/inf cell (the message
        names the file, the column and the row: data row ``i`` counted from 1
        and its line number in the file); fewer than :data:`MIN_SAMPLES` rows;
        ``t`` not strictly increasing; ``u`` constant.
    """
    path = Path(path)
    where = str(path)
    with path.open(newline="") as fh:
        reader = csv.reader(fh)
        header = None
        rows: list[list[str]] = []
        lines: list[int] = []
        for row in reader:
            line = reader.line_num
            if not row or all(not c.strip() for c in row):
                continue
            if header is None:
                row = list(row)
                row[0] = row[0].strip().lstrip("#")
                header = [c.strip().lower() for c in row]
                continue
            if row[0].lstrip().startswith("#"):
                continue
            rows.append(row)
            lines.append(line)
    if header is None:
        raise SignalError(f"{where}: empty file, expected a header row with columns t, u, w")
    idx = {}
    for name in ("t", "u", "w"):
        if name not in header:
            raise SignalError(f"{where}: column {name!r} missing from the header {header!r} "
                              "(need t, u, w)")
        idx[name] = header.index(name)
    data = {name: np.empty(len(rows)) for name in idx}
    for i, (row, line) in enumerate(zip(rows, lines)):
        for name, j in idx.items():
            at = f"{where}: column {name!r}, row {i + 1} (line {line})"
            if j >= len(row):
                raise SignalError(f"{at}: missing cell (the row has {len(row)} fields, the header {len(header)})")
            data[name][i] = number_cell(at, row[j])
    _check_record(where, data["t"], data["u"], lines)
    return MeasuredData(data["t"], data["u"], data["w"], source=where)


def _emps_variable(mat: dict, where: str, name: str, n: int | None = None) -> np.ndarray:
    """Variable ``name`` of a loaded .mat as a finite 1-D array (length ``n`` if given)."""
    try:
        return check_signal(name, mat[name], n=n)
    except SignalError as exc:
        raise SignalError(f"{where}: {exc}") from None


def load_emps(path, *, cutoff: float = EMPS_CUTOFF, order: int = 4, skip: int = EMPS_SKIP) -> MeasuredData:
    """Read an EMPS benchmark .mat file and derive force and filtered velocity.

    Parameters
    ----------
    path : str or os.PathLike
        ``DATA_EMPS.mat`` or ``DATA_EMPS_PULSES.mat`` (MATLAB 5 format) with the
        variables ``t`` (s), ``qm`` (m, encoder position on the load side),
        ``vir`` (V, controller output) and ``gtau`` (N/V, drive gain).
    cutoff : float, keyword-only
        Cutoff (Hz) of the Butterworth low-pass, in (0, fs/2). Default 100 Hz,
        the benchmark's value; see the module docstring for the measurement.
    order : int, keyword-only
        Butterworth order (>= 1) of one pass; filtering forward and backward
        squares the magnitude response. Default 4, as the benchmark.
    skip : int, keyword-only
        Samples dropped at the start (>= 0). Default 49, as the benchmark.

    Returns
    -------
    MeasuredData
        ``t`` (s), ``u = gtau*vir`` (N) and ``w`` (m/s), each shape ``(N - skip,)``;
        ``u`` and ``w`` filtered by the same zero-phase filter.

    Raises
    ------
    FileNotFoundError
        No such file.
    SignalError
        Not a readable .mat file, a variable missing, of the wrong shape or
        non-finite, time not strictly increasing, or too few samples.
    ParameterError
        ``cutoff`` not in (0, fs/2), ``order`` not an integer >= 1, ``skip``
        not an integer >= 0.
    TypeError
        ``cutoff`` not a real number.

    Notes
    -----
    ``w = d/dt [filtfilt(qm)]`` by central differences (``numpy.gradient`` with
    ``t``) and ``u = filtfilt(gtau*vir)`` with ``filtfilt`` =
    ``scipy.signal.sosfiltfilt`` of ``scipy.signal.butter(order, cutoff)``;
    both are linear and time-invariant, so they commute with the linear part
    of the plant and leave ``u``, ``w`` aligned (Janot et al., 2019, reference
    IDIM-LS procedure; the benchmark filters only the position and later
    low-pass filters the regressors, decimating by 10 - here ``Ts`` stays 1 ms).
    If the time stamps are not uniform within 1 %, ``qm`` and ``vir`` are first
    interpolated onto a uniform grid (:func:`to_uniform`) and a note is added.
    """
    from scipy.io import loadmat
    from scipy.signal import butter, sosfiltfilt

    cutoff = check_positive("cutoff", cutoff)
    if isinstance(order, bool) or not isinstance(order, (int, np.integer)) or order < 1:
        raise ParameterError(f"order must be an integer >= 1, got {order!r}")
    if isinstance(skip, bool) or not isinstance(skip, (int, np.integer)) or skip < 0:
        raise ParameterError(f"skip must be an integer >= 0, got {skip!r}")
    path = Path(path)
    where = str(path)
    check_not_special(path, "EMPS file (.mat)", error=SignalError)
    if not path.is_file():
        raise FileNotFoundError(f"EMPS file not found: {where}")
    try:
        mat = loadmat(str(path))
    except Exception as exc:  # noqa: BLE001 - scipy's parser raises many types on damaged bytes
        size = path.stat().st_size
        raise SignalError(f"{where}: not a readable MATLAB .mat file "
                          f"({'the file is empty (0 bytes)' if size == 0 else exc})") from None
    missing = [v for v in _EMPS_VARS if v not in mat]
    if missing:
        present = sorted(k for k in mat if not k.startswith("__"))
        raise SignalError(f"{where}: EMPS variables {missing} missing (found {present}); "
                          f"need {list(_EMPS_VARS)}")
    t = _emps_variable(mat, where, "t")
    qm = _emps_variable(mat, where, "qm", t.shape[0])
    vir = _emps_variable(mat, where, "vir", t.shape[0])
    gtau = _emps_variable(mat, where, "gtau", 1)[0]
    if gtau <= 0:
        raise SignalError(f"{where}: drive gain gtau must be > 0, got {float(gtau)!r}")
    _check_record(where, t, vir, u_name="vir")
    notes = []
    if not is_uniform(t):
        tu, note = _uniform_grid(t, 0.01)
        qm, vir, t = np.interp(tu, t, qm), np.interp(tu, t, vir), tu
        notes.append(note + "; qm, vir linearly interpolated before filtering")
    u_raw = gtau * vir
    fs = 1.0 / float(np.median(np.diff(t)))
    if not cutoff < fs / 2:
        raise ParameterError(f"cutoff must be below the Nyquist frequency {fs / 2:g} Hz, got {cutoff!r}")
    sos = butter(int(order), cutoff, btype="low", fs=fs, output="sos")
    pad = 3 * (2 * sos.shape[0] + 1)
    if t.shape[0] <= max(pad, skip + MIN_SAMPLES):
        raise SignalError(f"{where}: {t.shape[0]} samples are too few to filter (need > {pad}) "
                          f"and keep {MIN_SAMPLES} after dropping {skip}")
    w = np.gradient(sosfiltfilt(sos, qm), t)
    u = sosfiltfilt(sos, u_raw)
    notes += [f"u = gtau*vir with gtau = {gtau:.6g} N/V",
              f"w = central difference of qm after a zero-phase (forward-backward) Butterworth low-pass, "
              f"order {int(order)}, cutoff {cutoff:g} Hz; u filtered by the same filter",
              f"first {int(skip)} samples dropped"]
    return MeasuredData(t[skip:], u[skip:], w[skip:], source=where, notes=tuple(notes), w_from_position=True)


def load_measurements(path, **options) -> MeasuredData:
    """Load a measured record, choosing the reader by the file suffix.

    Parameters
    ----------
    path : str or os.PathLike
        ``.csv`` -> :func:`load_csv`; ``.mat`` -> :func:`load_emps` (EMPS layout).
    **options
        Keyword options of the chosen reader (``cutoff``, ``order``, ``skip``
        for ``.mat``; none for ``.csv``).

    Returns
    -------
    MeasuredData

    Raises
    ------
    SignalError
        Unsupported suffix, or any error of the chosen reader.
    TypeError
        Options the chosen reader does not take.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".csv":
        return load_csv(path, **options)
    if suffix == ".mat":
        return load_emps(path, **options)
    raise SignalError(f"{path}: unsupported file type {path.suffix!r}; expected .csv (t,u,w) or .mat (EMPS)")
