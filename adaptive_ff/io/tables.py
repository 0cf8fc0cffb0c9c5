r"""Reading the columns of a measured log: CSV/TXT (header, preamble, delimiter, no header), MATLAB .mat and
NumPy .npz.

:func:`read_columns` returns the raw columns of the roles asked for as a :class:`Table` (no unit conversion);
:func:`adaptive_ff.io.logs.load_log` builds the SI record from it (and re-exports these names).

Roles and column map
--------------------
Every signal has a *role*: ``t`` (time), ``u`` (input torque; motor current if
``current_to_torque`` is given), ``w`` (velocity) or ``q`` (position). A
column map names the file's column (CSV header name) or variable (.mat/.npz)
for each role, e.g. ``{"t": "time", "u": "current", "w": "vel"}`` or, as
text, ``"t=time,u=current,w=vel"`` (:func:`parse_column_map`). Roles not in
the map are looked up under their own name (``t``, ``u``, ``w``); mapping
``q`` makes the velocity come from the position.

Errors
------
Every problem with a file raises :class:`plant.errors.SignalError` naming the
file, the column (and its role) and the row: missing column or variable, a
cell that is not a number, NaN/inf, columns of different lengths (the checks of
the record itself are :func:`adaptive_ff.io.logs.load_log`'s). Rows of a
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

from adaptive_ff.io.units import ROLES
from plant.errors import ParameterError, SignalError, check_not_special, check_optional

__all__ = ["Table", "CsvFormat", "DELIMITER_NAMES", "number_cell", "parse_column_map", "read_columns"]

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
    (``columns="t=0,u=2,w=1"`` in :func:`~adaptive_ff.io.logs.load_log`).
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
            at = f"{where}: column {found[role]!r} ({role}), row {i + 1} (line {ln})"
            if j >= len(row) or not row[j].strip():
                raise SignalError(f"{at}: missing cell "
                                  f"(the row has {len(row)} fields{'' if not header else f', the header {len(header)}'})")
            cols[role][i] = number_cell(at, row[j])
    return Table(source=where, kind="csv", columns=cols, names=found, lines=lines)


def number_cell(at: str, cell: str) -> float:
    """A text cell of a log as a finite number: the one parser of the CSV readers' cells.

    Parameters
    ----------
    at : str
        Where the cell is, the start of an error's message (``"log.csv: column 'w' (w), row 3 (line 4)"``).
    cell : str
        The cell's text; surrounding spaces are ignored.

    Returns
    -------
    float
        The cell's value, finite.

    Raises
    ------
    SignalError
        ``"{at}: '<cell>' is not a number"`` or ``"{at}: non-finite value '<cell>'"`` (NaN or inf).
    """
    cell = cell.strip()
    try:
        x = float(cell)
    except ValueError:
        raise SignalError(f"{at}: {cell!r} is not a number") from None
    if not math.isfinite(x):
        raise SignalError(f"{at}: non-finite value {cell!r}")
    return x


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
    check_not_special(path, "data file", error=SignalError)
    if not path.is_file():
        raise FileNotFoundError(f"no such file: {path}")
    check_optional("csv_format", csv_format, CsvFormat, error=TypeError)
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
