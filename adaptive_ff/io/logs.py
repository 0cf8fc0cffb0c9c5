r"""Reading measured drive logs: CSV, MATLAB .mat and NumPy .npz, with column maps and unit conversion.

A log from a drive holds a time stamp, the input (torque, or motor current) and
either the velocity or the position. :func:`load_log` reads such a file into
an :class:`adaptive_ff.io.data.MeasuredData` record in SI units, so that
identification (:func:`adaptive_ff.identification.identify.identify`) and the Stribeck
pre-fit (:mod:`adaptive_ff.identification.steady_state`) can use it.

Roles and column map
--------------------
Every signal has a *role*: ``t`` (time), ``u`` (input torque; motor current if
``current_to_torque`` is given), ``w`` (velocity) or ``q`` (position). A
column map names the file's column (CSV header name) or variable (.mat/.npz)
for each role, e.g. ``{"t": "time", "u": "current", "w": "vel"}`` or, as
text, ``"t=time,u=current,w=vel"`` (:func:`parse_column_map`). Roles not in
the map are looked up under their own name (``t``, ``u``, ``w``); mapping
``q`` makes the velocity come from the position.

Units
-----
``u = K*i`` with ``K = current_to_torque`` (N·m/A, the motor torque constant
times the gear ratio, referred to the joint side; paper Sec. V-B); velocity in
rad/s, deg/s or rpm; position in rad, deg or encoder counts (``counts_per_rev``
counts per joint revolution); time in s, ms or us. Prismatic axes: read N for
N·m and m for rad and keep the SI ("rad") units, which are not converted.

Velocity from position: Kalman filter
-------------------------------------
Position ``q`` (rad) is turned into velocity by a linear Kalman filter
(``filterpy.kalman.KalmanFilter``) on a kinematic model, followed by the
Rauch-Tung-Striebel smoother (zero phase lag, as an offline identification
wants; ``smooth=False`` keeps the causal filter). Time stamps may be
non-uniform: the transition and process-noise matrices are built for each
interval ``h = t[k] - t[k-1]``:

* ``"cv"`` (constant velocity, state ``[q, w]``): white acceleration noise of
  spectral density ``S`` (rad²/s³), ``F = [[1, h], [0, 1]]``,
  ``Q = S*[[h³/3, h²/2], [h²/2, h]]``;
* ``"ca"`` (constant acceleration, state ``[q, w, a]``): white jerk noise,
  ``Q = S*[[h⁵/20, h⁴/8, h³/6], [h⁴/8, h³/3, h²/2], [h³/6, h²/2, h]]``

(Bar-Shalom, Li, Kirubarajan, *Estimation with Applications to Tracking and
Navigation*, 2001, Sec. 6.2-6.3). Measurement ``z = q + v``, ``var v = r``.

Tuning is by one number, the **bandwidth** ``fb`` (Hz) of the estimator. For
the model of order ``n`` (2 for cv, 3 for ca) the steady-state Kalman filter
has its poles on a Butterworth circle of radius ``wb = (S/(r*T))**(1/(2n))``
(spectral factorisation of ``1 + S/(r T) |1/s**n|²``, with ``r*T`` the
measurement noise density at the nominal interval ``T = median(diff(t))``),
so ``S = (2*pi*fb)**(2n) * r * T`` sets the bandwidth directly. The causal
filter's velocity estimate then responds to the true velocity as
``H(s) = wb²/(s² + sqrt(2) wb s + wb²)`` for cv (a 2nd-order Butterworth
low-pass, -3 dB at ``fb``) and ``H(s) = (2 wb² s + wb³)/((s + wb)(s² + wb s + wb²))``
for ca (no lag at low frequency to second order, but a resonance of 1.68
(4.5 dB) at ``0.83 fb`` and -3 dB at ``1.7 fb``); the RTS smoother applies
the filter forward and backward (``|H|²``, zero phase). Choose ``fb``
above the motion content you want to keep (the friction lag ``1/(2*pi*tau)``
included) and below where position noise dominates; the default is a tenth of
the sampling rate. The noise ``r`` is ``position_noise**2``; by default the
quantisation noise ``Δ²/12`` of the encoder step ``Δ = 2*pi/counts_per_rev``
for counts, and for rad/deg the larger of a robust estimate from third
differences (``var(Δ³q) = 20 r`` for white noise, median absolute deviation)
and the smallest position step over ``sqrt(12)`` (the apparent quantum).

Errors
------
Every problem with a file raises :class:`plant.errors.SignalError` naming the
file, the column (and its role) and the row: missing column or variable, a
cell that is not a number, NaN/inf, time stamps not strictly increasing, fewer
than :data:`adaptive_ff.io.data.MIN_SAMPLES` samples, constant input. Rows of a
CSV are data rows counted from 1 with their line number in the file; rows of
.mat/.npz vectors are counted from 1 with the 0-based index. Files are never
unpickled (``numpy.load(..., allow_pickle=False)``; ``scipy.io.loadmat``
reads MATLAB data, not Python objects).
"""

from __future__ import annotations

import csv
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from adaptive_ff.io.data import MIN_SAMPLES, MeasuredData
from adaptive_ff.io.units import KALMAN_MODELS, POSITION_UNITS, ROLES, TIME_UNITS, VELOCITY_UNITS
from plant.errors import ParameterError, SignalError, check_positive, check_signal, check_time
from plant.results import axes_or_new, json_safe

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

_SUFFIXES = (".csv", ".txt", ".mat", ".npz")


# --------------------------------------------------------------------------- column maps


def parse_column_map(text: str, *, roles=tuple(ROLES)) -> dict:
    """Parse a column map written as ``"role=name,role=name"``, e.g. ``"t=time,u=current,w=vel"``.

    Parameters
    ----------
    text : str
        Comma-separated ``role=name`` pairs; spaces around items are ignored.
        For .mat files ``name`` may be a dotted path into a struct
        (``log.time``).
    roles : sequence of str, keyword-only
        Allowed roles (default :data:`ROLES`: ``t, u, w, q``).

    Returns
    -------
    dict
        ``{role: name}``.

    Raises
    ------
    ParameterError
        An item without ``=``, an empty role or name, an unknown role, or a
        role given twice (the item is quoted).
    TypeError
        ``text`` is not a string.
    """
    if not isinstance(text, str):
        raise TypeError(f"the column map must be a string like 't=time,u=current,w=vel', got {text!r}")
    out: dict = {}
    for item in (s.strip() for s in text.split(",")):
        if not item:
            continue
        role, sep, name = (s.strip() for s in item.partition("="))
        if not sep or not role or not name:
            raise ParameterError(f"column map item {item!r} must be role=name, e.g. 'w=velocity'")
        if role not in roles:
            raise ParameterError(f"column map item {item!r}: unknown role {role!r}; roles are {list(roles)}")
        if role in out:
            raise ParameterError(f"column map gives role {role!r} twice ({out[role]!r} and {name!r})")
        out[role] = name
    if not out:
        raise ParameterError(f"empty column map {text!r}; expected e.g. 't=time,u=current,w=vel'")
    return out


# --------------------------------------------------------------------------- reading


@dataclass(frozen=True)
class Table:
    """Columns read from a file, by role, before unit conversion.

    Attributes
    ----------
    source : str
        The file path.
    kind : str
        ``"csv"``, ``"mat"`` or ``"npz"``.
    columns : dict
        ``{role: ndarray, shape (N,)}``, finite floats.
    names : dict
        ``{role: column or variable name in the file}``.
    lines : ndarray or None
        For CSV: the file line number of each data row (shape (N,)); None otherwise.
    """

    source: str
    kind: str
    columns: dict
    names: dict
    lines: np.ndarray | None = None

    @property
    def n_rows(self) -> int:
        """Number of rows ``N``."""
        return int(next(iter(self.columns.values())).shape[0]) if self.columns else 0

    def row(self, i: int) -> str:
        """Human-readable location of 0-based row ``i``: ``row 5 (line 7)`` (CSV) or ``row 5 (index 4)``."""
        if self.lines is not None:
            return f"row {i + 1} (line {int(self.lines[i])})"
        return f"row {i + 1} (index {i})"

    def column(self, role: str) -> str:
        """``"column 'vel' (w)"``: the file's name of a role, for messages."""
        return f"column {self.names[role]!r} ({role})"


#: Spellings of ``CsvFormat.delimiter`` for characters that are awkward on a command line.
DELIMITER_NAMES = {"comma": ",", "semicolon": ";", "tab": "\t", "\\t": "\t", "space": None, "whitespace": None,
                   "pipe": "|"}


@dataclass(frozen=True, kw_only=True)
class CsvFormat:
    """Layout of a text (CSV/TXT) log, for files that are not a plain header + rows table (keyword-only).

    Parameters
    ----------
    skip_rows : int
        File lines to skip before anything else (>= 0), e.g. a scope's preamble.
    header_line : int, optional
        1-based file line of the header row (>= 1); data start on the next line.
        Default: found automatically (the first line, a ``# name,...`` comment as
        written by ``numpy.savetxt``, or the last text line before the first
        numeric row, which skips a vendor preamble).
    delimiter : str, optional
        Field separator: one character, or ``comma``, ``semicolon``, ``tab``,
        ``pipe``, ``space``/``whitespace`` (runs of blanks). Default: guessed
        from the header (comma, semicolon, tab, else whitespace).

    Raises
    ------
    ParameterError
        A negative ``skip_rows``, ``header_line`` < 1, or a delimiter that is
        not one character or a known name; each message names the field.

    Notes
    -----
    Headerless files: map the roles to 0-based column indices
    (``columns="t=0,u=2,w=1"`` in :func:`load_log`).
    """

    skip_rows: int = 0
    header_line: int | None = None
    delimiter: str | None = None

    def __post_init__(self):
        if isinstance(self.skip_rows, bool) or not isinstance(self.skip_rows, int) or self.skip_rows < 0:
            raise ParameterError(f"skip_rows must be an integer >= 0, got {self.skip_rows!r}")
        h = self.header_line
        if h is not None and (isinstance(h, bool) or not isinstance(h, int) or h < 1):
            raise ParameterError(f"header_line must be an integer >= 1 (a 1-based line number), got {h!r}")
        d = self.delimiter
        if d is not None:
            if not isinstance(d, str) or not (len(d) == 1 or d.lower() in DELIMITER_NAMES) or d in "\r\n\"":
                raise ParameterError(f"delimiter must be one character or one of {sorted(DELIMITER_NAMES)}, "
                                     f"got {d!r}")

    @property
    def separator(self) -> str | None:
        """The delimiter character, ``None`` for whitespace (also when not given: see :attr:`guess`)."""
        d = self.delimiter
        if d is None or d == " ":
            return None
        return DELIMITER_NAMES.get(d.lower(), d) if len(d) > 1 else d

    @property
    def guess(self) -> bool:
        """True when the delimiter is guessed from the file."""
        return self.delimiter is None


def _split(line: str, delimiter: str | None) -> list[str]:
    if delimiter is None:
        return line.split()
    try:
        return next(csv.reader([line], delimiter=delimiter))
    except (csv.Error, StopIteration):
        return line.split(delimiter)


def _guess_delimiter(line: str) -> str | None:
    return next((d for d in (",", ";", "\t") if d in line), None)


def _is_number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


def _numeric_line(line: str, delimiter: str | None) -> bool:
    cells = [c.strip() for c in _split(line, delimiter)]
    cells = [c for c in cells if c]
    return bool(cells) and all(_is_number(c) for c in cells)


def _index_map(names: dict) -> bool:
    """True when every column name of the map is a 0-based index (a headerless file)."""
    return all(str(v).strip().isdigit() for v in names.values())


def _csv_lines(path: Path, fmt: CsvFormat) -> list[tuple[int, str]]:
    """``(line number, text)`` of the non-blank lines after ``fmt.skip_rows``; typed errors for bad bytes."""
    where = str(path)
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise SignalError(f"{where}: not a UTF-8 text (CSV) file: byte {exc.start} ({exc.reason}); "
                          "export the log as UTF-8 or ASCII text") from None
    if "\x00" in text:
        raise SignalError(f"{where}: not a text (CSV) file (it holds NUL bytes); give .mat or .npz files "
                          "their own suffix")
    raw = [(i + 1, ln) for i, ln in enumerate(text.splitlines()) if ln.strip() and i >= fmt.skip_rows]
    if not raw:
        extra = f" after skipping {fmt.skip_rows} lines" if fmt.skip_rows else ""
        raise SignalError(f"{where}: empty file{extra}, expected a header row with column names")
    return raw


def _find_header(where: str, raw: list, fmt: CsvFormat, names: dict) -> tuple:
    """``(header line number or None, header text or None, body lines)`` of a text log (see :class:`CsvFormat`)."""
    if fmt.header_line is not None:
        k = next((i for i, (ln, _) in enumerate(raw) if ln == fmt.header_line), None)
        if k is None:
            raise SignalError(f"{where}: --header-line {fmt.header_line}: no such non-blank line "
                              f"(lines {raw[0][0]}..{raw[-1][0]} after skipping {fmt.skip_rows})")
        return raw[k][0], raw[k][1].lstrip().lstrip("#"), raw[k + 1:]
    content = [(i, ln, s) for i, (ln, s) in enumerate(raw) if not s.lstrip().startswith("#")]
    if not content:
        raise SignalError(f"{where}: only comment lines, no data")

    def numeric(s):
        return _numeric_line(s, fmt.separator if not fmt.guess else _guess_delimiter(s))

    first_num = next((c for c in content if numeric(c[2])), None)
    if _index_map(names):  # headerless: a text first line is taken as a header and skipped
        i0 = content[0][0]
        if numeric(raw[i0][1]):
            return None, None, raw[i0:]
        return raw[i0][0], raw[i0][1], raw[i0 + 1:]
    i0, ln0, s0 = content[0]
    if numeric(s0):
        if i0 > 0 and raw[i0 - 1][1].lstrip().startswith("#"):  # numpy.savetxt: '# t,u,w'
            return raw[i0 - 1][0], raw[i0 - 1][1].lstrip()[1:], raw[i0:]
        raise SignalError(f"{where}: line {ln0} is numeric ({s0.strip()[:60]!r}), not a header of column names; "
                          "no header? use --columns with indices, e.g. --columns t=0,u=1,w=2 (0-based), or "
                          "--header-line N")
    candidates = [content[0]]
    if first_num is not None and first_num[0] > 0:
        prev = next((c for c in reversed(content) if c[0] < first_num[0]), None)
        if prev is not None and prev is not content[0]:
            candidates.append(prev)
    for i, ln, s in candidates:  # the first line, or the last text line before the data (after a preamble)
        header = [c.strip().lower() for c in _split(s, fmt.separator if not fmt.guess else _guess_delimiter(s))]
        if all(v.lower() in header for v in names.values()):
            return ln, s, raw[i + 1:]
    i, ln, s = candidates[-1]
    return ln, s, raw[i + 1:]


def _read_csv(path: Path, names: dict, optional: set, fmt: CsvFormat | None = None) -> Table:
    """Text log (comma, semicolon, tab or whitespace separated; see :class:`CsvFormat` for the layout)."""
    fmt = CsvFormat() if fmt is None else fmt
    where = str(path)
    raw = _csv_lines(path, fmt)
    h_line, header_text, body = _find_header(where, raw, fmt, names)
    delimiter = fmt.separator if not fmt.guess else _guess_delimiter(header_text or (body[0][1] if body else ""))
    header = [c.strip() for c in _split(header_text, delimiter)] if header_text is not None else []
    lower = [c.lower() for c in header]
    idx, found = {}, {}
    for role, name in names.items():
        if _index_map(names):
            idx[role], found[role] = int(name), (header[int(name)] if int(name) < len(header) else f"#{name}")
        elif name.lower() in lower:
            idx[role], found[role] = lower.index(name.lower()), name
        elif role not in optional:
            hint = ("" if h_line == raw[0][0] else
                    f" (header taken from line {h_line}; lines before it skipped as a preamble)")
            raise SignalError(f"{where}: column {name!r} (role {role}: {ROLES.get(role, role)}) missing from the "
                              f"header on line {h_line}{hint}; columns are {header}. Choose the header with "
                              "--header-line N, or map columns by 0-based index with --columns t=0,u=1,w=2")
    rows = [(ln, _split(s, delimiter)) for ln, s in body if not s.lstrip().startswith("#")]
    if not rows:
        raise SignalError(f"{where}: no data rows after the header on line {h_line}")
    cols = {role: np.empty(len(rows)) for role in idx}
    lines = np.array([ln for ln, _ in rows], dtype=np.int64)
    for i, (ln, row) in enumerate(rows):
        for role, j in idx.items():
            col = f"column {found[role]!r} ({role})"
            if j >= len(row) or not row[j].strip():
                raise SignalError(f"{where}: {col}, row {i + 1} (line {ln}): missing cell "
                                  f"(the row has {len(row)} fields{'' if not header else f', the header {len(header)}'})")
            cell = row[j].strip()
            try:
                x = float(cell)
            except ValueError:
                raise SignalError(f"{where}: {col}, row {i + 1} (line {ln}): {cell!r} is not a number") from None
            if not math.isfinite(x):
                raise SignalError(f"{where}: {col}, row {i + 1} (line {ln}): non-finite value {cell!r}")
            cols[role][i] = x
    return Table(source=where, kind="csv", columns=cols, names=found, lines=lines)


def _vector(where: str, role: str, name: str, value) -> np.ndarray:
    """A .mat/.npz variable as a finite 1-D float array, or a SignalError naming it."""
    col = f"variable {name!r} ({role})"
    arr = np.asarray(value)
    if arr.dtype == object or not (np.issubdtype(arr.dtype, np.number) or arr.dtype == bool):
        raise SignalError(f"{where}: {col} is not numeric (dtype {arr.dtype}); expected a vector of numbers")
    if np.iscomplexobj(arr):
        raise SignalError(f"{where}: {col} is complex; expected real numbers")
    arr = arr.astype(float)
    if arr.ndim == 2 and 1 in arr.shape:
        arr = arr.reshape(-1)
    if arr.ndim != 1:
        raise SignalError(f"{where}: {col} must be a vector, got shape {arr.shape}")
    bad = np.flatnonzero(~np.isfinite(arr))
    if bad.size:
        i = int(bad[0])
        raise SignalError(f"{where}: {col}, row {i + 1} (index {i}): non-finite value {float(arr[i])!r}")
    return arr


def _lookup_mat(mat: dict, name: str):
    """Variable ``name`` of a loaded .mat dict; dotted names go into structs (loadmat simplify_cells)."""
    cur = mat
    for part in name.split("."):
        if isinstance(cur, Mapping) and part in cur:
            cur = cur[part]
        else:
            raise KeyError(name)
    return cur


def _read_mat(path: Path, names: dict, optional: set) -> Table:
    from scipy.io import loadmat

    where = str(path)
    try:
        mat = loadmat(str(path), simplify_cells=True)
    except NotImplementedError:
        raise SignalError(f"{where}: MATLAB v7.3 (HDF5) files are not supported; save with "
                          "save(..., '-v7') or export CSV") from None
    except Exception as exc:  # noqa: BLE001 - scipy's parser raises many types on damaged bytes
        raise SignalError(f"{where}: not a readable MATLAB .mat file ({_reason(exc, path)})") from None
    present = sorted(k for k in mat if not k.startswith("__"))
    cols, found = {}, {}
    for role, name in names.items():
        try:
            value = _lookup_mat(mat, name)
        except KeyError:
            if role in optional:
                continue
            raise SignalError(f"{where}: variable {name!r} (role {role}: {ROLES.get(role, role)}) missing; "
                              f"variables are {present}") from None
        cols[role] = _vector(where, role, name, value)
        found[role] = name
    _check_lengths(where, cols, found, "variable")
    return Table(source=where, kind="mat", columns=cols, names=found)


def _read_npz(path: Path, names: dict, optional: set) -> Table:
    where = str(path)
    try:
        npz = np.load(str(path), allow_pickle=False)
    except Exception as exc:  # noqa: BLE001 - zipfile/zlib/numpy raise many types on damaged bytes
        raise SignalError(f"{where}: not a readable NumPy .npz file ({_reason(exc, path)})") from None
    if not hasattr(npz, "files"):
        raise SignalError(f"{where}: a single .npy array, not an .npz archive of named arrays")
    with npz:
        cols, found = {}, {}
        for role, name in names.items():
            if name not in npz.files:
                if role in optional:
                    continue
                raise SignalError(f"{where}: array {name!r} (role {role}: {ROLES.get(role, role)}) missing; "
                                  f"arrays are {sorted(npz.files)}")
            try:
                value = npz[name]
            except ValueError as exc:  # object arrays need pickle, which is refused
                if "pickle" not in str(exc):
                    raise SignalError(f"{where}: array {name!r} ({role}) is damaged ({exc})") from None
                raise SignalError(f"{where}: array {name!r} ({role}) cannot be read without pickle ({exc}); "
                                  "store plain numeric arrays") from None
            except Exception as exc:  # noqa: BLE001 - a truncated member: zipfile/zlib/EOF errors
                raise SignalError(f"{where}: array {name!r} ({role}) is damaged or truncated "
                                  f"({_reason(exc, path)})") from None
            cols[role] = _vector(where, role, name, value)
            found[role] = name
    _check_lengths(where, cols, found, "array")
    return Table(source=where, kind="npz", columns=cols, names=found)


def _reason(exc: Exception, path: Path) -> str:
    """Short reason of a reader failure: the exception text, or the file size for an empty file."""
    try:
        if path.stat().st_size == 0:
            return "the file is empty (0 bytes)"
    except OSError:
        pass
    text = str(exc).strip() or type(exc).__name__
    return text if len(text) < 200 else text[:200] + "..."


def _check_lengths(where: str, cols: dict, names: dict, what: str) -> None:
    lengths = {r: c.shape[0] for r, c in cols.items()}
    if len(set(lengths.values())) > 1:
        desc = ", ".join(f"{what} {names[r]!r} ({r}): {n}" for r, n in lengths.items())
        raise SignalError(f"{where}: the signals have different lengths ({desc})")


def read_columns(path, names: Mapping, *, optional=(), csv_format: CsvFormat | None = None) -> Table:
    """Read named columns (CSV) or variables (.mat, .npz) from a file, by role.

    Parameters
    ----------
    path : str or os.PathLike
        ``.csv`` or ``.txt`` (header row of names; comma, semicolon, tab or
        whitespace separated; blank lines and ``#`` comment lines skipped; a
        ``# name,name`` header as written by ``numpy.savetxt`` is recognised),
        ``.mat`` (MATLAB up to v7; dotted names reach into structs) or
        ``.npz`` (named arrays, read without pickle).
    names : mapping
        ``{role: column name}``. CSV names match case-insensitively.
    optional : collection of str, keyword-only
        Roles that may be absent (they are left out of the result).
    csv_format : CsvFormat, keyword-only, optional
        Layout of a text file (lines to skip, header line, delimiter); with
        every name of ``names`` a 0-based index (``"0"``, ``"2"``) the file
        has no header and columns are taken by position.

    Returns
    -------
    Table
        Finite float columns of equal length ``N`` (not yet checked for
        length, order or units).

    Raises
    ------
    FileNotFoundError
        No such file.
    SignalError
        Unsupported suffix; unreadable file; a required column missing (the
        available ones are listed); a cell that is not a number, empty, or
        NaN/inf; a variable not a numeric vector; lengths differ. Messages name
        the file, the column with its role, and the row.
    """
    path = Path(path)
    if path.is_dir():
        raise SignalError(f"{path}: is a directory, expected a data file")
    if not path.is_file():
        raise FileNotFoundError(f"no such file: {path}")
    if csv_format is not None and not isinstance(csv_format, CsvFormat):
        raise TypeError(f"csv_format must be a CsvFormat, got {type(csv_format).__name__}")
    names = {str(k): str(v) for k, v in dict(names).items()}
    optional = set(optional)
    suffix = path.suffix.lower()
    if suffix in (".csv", ".txt"):
        return _read_csv(path, names, optional, csv_format)
    if suffix == ".mat":
        return _read_mat(path, names, optional)
    if suffix == ".npz":
        return _read_npz(path, names, optional)
    raise SignalError(f"{path}: unsupported file type {path.suffix!r}; expected one of {list(_SUFFIXES)}")


# --------------------------------------------------------------------------- velocity from position


@dataclass(frozen=True)
class VelocityEstimate:
    """Velocity estimated from position by :func:`velocity_from_position`.

    Attributes
    ----------
    t : ndarray, shape (N,)
        Time stamps (s).
    w : ndarray, shape (N,)
        Velocity estimate (rad/s).
    w_std : ndarray, shape (N,)
        Its standard deviation from the filter/smoother covariance (rad/s).
    q : ndarray, shape (N,)
        Filtered position (rad).
    model : str
        ``"cv"`` or ``"ca"``.
    bandwidth : float
        Estimator bandwidth ``fb`` (Hz).
    position_noise : float
        Measurement noise standard deviation ``sqrt(r)`` (rad).
    process_noise : float
        Spectral density ``S`` of the white acceleration (cv, rad²/s³) or jerk
        (ca, rad²/s⁵) noise.
    smoothed : bool
        True if the Rauch-Tung-Striebel smoother was applied.
    """

    t: np.ndarray
    w: np.ndarray
    w_std: np.ndarray
    q: np.ndarray
    model: str
    bandwidth: float
    position_noise: float
    process_noise: float
    smoothed: bool

    def to_dict(self, *, arrays: bool = False) -> dict:
        """Settings and velocity statistics as strict JSON; with ``arrays=True`` also ``t``, ``w``, ``w_std``, ``q``.

        Keys: ``model``, ``bandwidth`` (Hz), ``position_noise`` (rad),
        ``process_noise``, ``smoothed``, ``n_samples``, ``w_std_median`` (rad/s).
        """
        d = {"model": self.model, "bandwidth": self.bandwidth, "position_noise": self.position_noise,
             "process_noise": self.process_noise, "smoothed": self.smoothed, "n_samples": int(self.t.shape[0]),
             "w_std_median": float(np.median(self.w_std))}
        if arrays:
            d.update(t=self.t, w=self.w, w_std=self.w_std, q=self.q)
        return json_safe(d)

    def summary(self) -> str:
        """One line: estimator, bandwidth, noise and the typical velocity uncertainty."""
        kind = "filter + RTS smoother" if self.smoothed else "causal filter"
        return (f"Kalman {kind} ({self.model}), {self.t.shape[0]} samples, bandwidth {self.bandwidth:.4g} Hz, "
                f"position noise {self.position_noise:.3g} rad; velocity std median "
                f"{float(np.median(self.w_std)):.3g} rad/s")

    def plot(self, ax=None):
        """Velocity estimate (rad/s) over time (s) with its ±2 std band.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on; default a new figure.

        Returns
        -------
        matplotlib.axes.Axes
        """
        ax = axes_or_new(ax)
        ax.fill_between(self.t, self.w - 2 * self.w_std, self.w + 2 * self.w_std, color="C0", alpha=0.25, lw=0,
                        label="±2 std")
        ax.plot(self.t, self.w, color="C0", lw=0.9, label=f"Kalman velocity ({self.model}, {self.bandwidth:.3g} Hz)")
        ax.set_xlabel("time t (s)")
        ax.set_ylabel("velocity w (rad/s)")
        ax.legend(fontsize=8)
        ax.grid(True, alpha=0.3)
        return ax


def estimate_position_noise(q) -> float:
    """Measurement-noise standard deviation (rad) of a position record, for the Kalman filter's ``r``.

    Parameters
    ----------
    q : array_like, shape (N,), N >= 4
        Position samples (rad).

    Returns
    -------
    float
        ``max(sigma_3, dq_min/sqrt(12))``: ``sigma_3 = 1.4826*MAD(diff(q, 3))/sqrt(20)``
        (third differences of white noise have variance ``20*r``; smooth motion
        sampled fast hardly contributes; MAD makes it robust) and ``dq_min``
        the smallest non-zero position step, whose uniform quantisation noise
        has variance ``dq_min**2/12``. If both are 0 (noise-free polynomial
        motion), ``1e-9`` times the position range (or 1e-12 rad).

    Raises
    ------
    SignalError
        Fewer than 4 samples or non-finite values.
    """
    q = check_signal("q", q, min_len=4)
    d3 = np.diff(q, 3)
    sigma3 = 1.4826 * float(np.median(np.abs(d3 - np.median(d3)))) / math.sqrt(20.0)
    steps = np.abs(np.diff(q))
    steps = steps[steps > 0]
    quantum = float(steps.min()) / math.sqrt(12.0) if steps.size else 0.0
    out = max(sigma3, quantum)
    if out == 0.0:
        span = float(np.ptp(q))
        out = 1e-9 * span if span > 0 else 1e-12
    return out


def _cv_matrices(h: float, S: float):
    F = np.array([[1.0, h], [0.0, 1.0]])
    Q = S * np.array([[h**3 / 3, h**2 / 2], [h**2 / 2, h]])
    return F, Q


def _ca_matrices(h: float, S: float):
    F = np.array([[1.0, h, h * h / 2], [0.0, 1.0, h], [0.0, 0.0, 1.0]])
    Q = S * np.array([[h**5 / 20, h**4 / 8, h**3 / 6],
                      [h**4 / 8, h**3 / 3, h**2 / 2],
                      [h**3 / 6, h**2 / 2, h]])
    return F, Q


def _kalman_pass(t: np.ndarray, q: np.ndarray, n: int, r: float, S: float, sd: float, smooth: bool, progress):
    """Kalman filter (and RTS smoother) over ``q``; state means ``(N, n, 1)`` and covariances ``(N, n, n)``."""
    from filterpy.kalman import KalmanFilter
    from tqdm.auto import tqdm

    T = float(np.median(np.diff(t)))
    mats = _cv_matrices if n == 2 else _ca_matrices
    kf = KalmanFilter(dim_x=n, dim_z=1)
    kf.H = np.zeros((1, n))
    kf.H[0, 0] = 1.0
    kf.R = np.array([[r]])
    v0 = (q[1] - q[0]) / (t[1] - t[0])
    kf.x = np.zeros((n, 1))
    kf.x[0, 0], kf.x[1, 0] = q[0], v0
    vscale = max(float(np.max(np.abs(np.diff(q) / np.diff(t)))), sd / T)
    kf.P = np.diag([r, vscale**2, (vscale / T) ** 2][:n])
    N = t.shape[0]
    xs = np.empty((N, n, 1))
    Ps = np.empty((N, n, n))
    Fs = [np.eye(n)] * N
    Qs = [np.zeros((n, n))] * N
    kf.update(q[0])
    xs[0], Ps[0] = kf.x, kf.P
    h_all = np.diff(t).tolist()
    q_list = q.tolist()
    for k in tqdm(range(1, N), desc="Kalman velocity", disable=(None if progress is None else not progress),
                  leave=False, mininterval=0.5):
        F, Q = mats(h_all[k - 1], S)
        kf.predict(F=F, Q=Q)
        kf.update(q_list[k])
        xs[k], Ps[k] = kf.x, kf.P
        Fs[k], Qs[k] = F, Q
    if smooth:
        # rts_smoother uses Fs[k+1], Qs[k+1] to go from k to k+1: the list is aligned that way
        xs, Ps, _, _ = kf.rts_smoother(xs, Ps, Fs=Fs, Qs=Qs)
    return xs, Ps


def velocity_from_position(t, q, *, model: str = "cv", bandwidth: float | None = None,
                           position_noise: float | None = None, smooth: bool = True,
                           progress: bool | None = False) -> VelocityEstimate:
    """Estimate velocity from (possibly irregularly) sampled position by a Kalman filter and RTS smoother.

    Parameters
    ----------
    t : array_like, shape (N,)
        Time stamps (s), strictly increasing, need not be uniform; N >= 4.
    q : array_like, shape (N,)
        Position (rad).
    model : {"cv", "ca"}, keyword-only
        Kinematic model: constant velocity (white acceleration noise) or
        constant acceleration (white jerk noise). ``"ca"`` follows fast
        velocity changes (reversals) with less lag at the same bandwidth but
        amplifies motion and noise around ``0.83*fb`` by up to 1.68 (module docstring).
    bandwidth : float, keyword-only, optional
        Estimator bandwidth ``fb`` (Hz), > 0 and below the Nyquist frequency
        ``0.5/T`` of the median interval ``T``. Default ``0.1/T``.
    position_noise : float, keyword-only, optional
        Position measurement noise standard deviation (rad), > 0. Default
        :func:`estimate_position_noise` of ``q``.
    smooth : bool, keyword-only
        Apply the Rauch-Tung-Striebel smoother (default; zero lag, for offline
        identification). False: the causal Kalman filter (lags by about
        ``1/(2*pi*fb)``).
    progress : bool or None, keyword-only
        tqdm progress bar over the samples (None: when on a terminal; default off).

    Returns
    -------
    VelocityEstimate

    Raises
    ------
    SignalError
        Bad ``t``/``q`` (lengths, non-finite, time not strictly increasing).
    ParameterError
        Unknown ``model``; ``bandwidth`` or ``position_noise`` not > 0, or the
        bandwidth at or above the Nyquist frequency.

    Notes
    -----
    See the module docstring for the model matrices and the tuning rule
    ``S = (2*pi*fb)**(2n) * r * T`` (n = 2 for cv, 3 for ca), which puts the
    poles of the steady-state filter on a Butterworth circle of radius
    ``2*pi*fb``. Filter: ``filterpy.kalman.KalmanFilter`` (``predict`` with the
    per-interval ``F``, ``Q``; ``update``); smoother:
    ``KalmanFilter.rts_smoother`` (Rauch, Tung, Striebel 1965). Initial state:
    the first position, the first finite-difference velocity, zero
    acceleration, with a covariance wide enough to be forgotten within a few
    samples.
    """
    if model not in KALMAN_MODELS:
        raise ParameterError(f"model must be one of {list(KALMAN_MODELS)}, got {model!r}")
    t = check_time("t", t, min_len=4)
    q = check_signal("q", q, n=t.shape[0])
    T = float(np.median(np.diff(t)))
    fb = 0.1 / T if bandwidth is None else check_positive("bandwidth", bandwidth)
    if fb >= 0.5 / T:
        raise ParameterError(f"bandwidth must be below the Nyquist frequency {0.5 / T:.6g} Hz of the median "
                             f"interval {T:.6g} s, got {fb!r} Hz")
    sd = estimate_position_noise(q) if position_noise is None else check_positive("position_noise", position_noise)
    n = KALMAN_MODELS[model]
    r = sd * sd
    S = (2.0 * math.pi * fb) ** (2 * n) * r * T
    xs, Ps = _kalman_pass(t, q, n, r, S, sd, smooth, progress)
    return VelocityEstimate(t=t.copy(), w=xs[:, 1, 0].copy(), w_std=np.sqrt(np.maximum(Ps[:, 1, 1], 0.0)),
                            q=xs[:, 0, 0].copy(), model=model, bandwidth=float(fb), position_noise=float(sd),
                            process_noise=float(S), smoothed=bool(smooth))


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
    return MeasuredData(t, u, w, source=table.source, notes=tuple(notes))
