"""Shared command-line options for reading drive logs (column map, units, Kalman velocity) and the report path.

Used by ``adaptive-ff stribeck`` and meant for ``adaptive-ff identify``:
:func:`add_data_arguments` adds the options to a subparser and
:func:`load_data_from_args` reads the file with them
(:func:`adaptive_ff.io.logs.load_log`; an EMPS benchmark .mat without ``--columns``
goes through :func:`adaptive_ff.io.data.load_measurements` as before).
"""

from __future__ import annotations

import contextlib
import shlex
import sys
from pathlib import Path

from adaptive_ff.io.units import TABLE_UNITS

__all__ = ["add_data_arguments", "load_data_from_args", "io_options_from_args", "progress_from_args",
           "command_line", "DATA_EPILOG", "seed_type", "positive_int", "nonnegative_int", "check_output_dir",
           "check_output_file", "PRESET_NAMES", "TABLE_UNITS", "add_units_argument", "table_unit",
           "per_angle", "named_by"]

#: Text for a subcommand's ``--help`` epilog: how to map columns and units.
DATA_EPILOG = """\
data files: CSV/TXT (header row of names; comma, semicolon, tab or whitespace separated; '#' comments),
MATLAB .mat (v5-v7; 'log.time' reaches into a struct) or NumPy .npz (read without pickle). Roles: t (time),
u (torque; motor current with --current-to-torque), w (velocity) or q (position). Map roles to your
column names with --columns, e.g. --columns t=time,u=current,w=vel; unmapped roles use their own name.
Scope and vendor exports: a preamble before the header is skipped automatically (or --skip-rows N,
--header-line N), --delimiter sets the separator; a file without a header is read by column index
(--columns t=0,u=2,w=1). Values beyond 1e12 (SI) are refused as corrupt cells, naming file, row, column.
Time stamps may be non-uniform: the readers, the Stribeck pre-fit and identify --method output_error
keep them as read; identify's paper method (eq. 4 needs one Ts) resamples them onto a uniform grid and
says so in its output. Position (--columns q=NAME) is turned into velocity by a Kalman filter
+ RTS smoother (filterpy; --kalman-model cv|ca, --kalman-bandwidth Hz, default a tenth of the sample
rate; noise: the encoder quantum for counts, else estimated from the data).
"""


def add_data_arguments(parser, *, columns_help: str | None = None) -> None:
    """Add the data-reading options to an argparse (sub)parser.

    Options: ``--columns``, ``--current-to-torque``, ``--time-unit``,
    ``--velocity-unit``, ``--position-unit``, ``--counts-per-rev``,
    ``--kalman-model``, ``--kalman-bandwidth``, ``--position-noise``, ``--causal``.
    """
    from adaptive_ff.io.units import KALMAN_MODELS, POSITION_UNITS, TIME_UNITS, VELOCITY_UNITS

    g = parser.add_argument_group("data file (columns, units, velocity from position)")
    g.add_argument("--columns", metavar="MAP", default=None,
                   help=columns_help or "column map role=name,... with roles t, u, w or q, e.g. "
                                        "t=time,u=current,w=vel (default: columns named t, u, w); "
                                        "a file without a header: 0-based indices, e.g. t=0,u=2,w=1")
    g.add_argument("--skip-rows", type=nonnegative_int, default=0, metavar="N",
                   help="text files: skip the first N lines (a preamble) before looking for the header")
    g.add_argument("--header-line", type=positive_int, default=None, metavar="N",
                   help="text files: the header is on line N (1-based); default: found automatically "
                        "(first line, '# name,...', or the last text line before the numbers)")
    g.add_argument("--delimiter", default=None, metavar="SEP",
                   help="text files: field separator, one character or comma, semicolon, tab, pipe, space "
                        "(default: guessed from the header)")
    g.add_argument("--current-to-torque", type=float, metavar="K", default=None,
                   help="u column is motor current i (A); torque u = K*i with K in N·m/A (paper Sec. V-B)")
    g.add_argument("--time-unit", choices=list(TIME_UNITS), default="s", help="unit of the time column (default s)")
    g.add_argument("--velocity-unit", choices=list(VELOCITY_UNITS), default="rad/s",
                   help="unit of the velocity column (default rad/s; use rad/s for m/s too)")
    g.add_argument("--position-unit", choices=list(POSITION_UNITS), default="rad",
                   help="unit of the position column (default rad); counts need --counts-per-rev")
    g.add_argument("--counts-per-rev", type=float, metavar="N", default=None,
                   help="encoder counts per joint revolution (motor counts/rev times gear ratio)")
    g.add_argument("--kalman-model", choices=list(KALMAN_MODELS), default="cv",
                   help="velocity from position: constant-velocity (cv, default) or constant-acceleration (ca) model")
    g.add_argument("--kalman-bandwidth", type=float, metavar="HZ", default=None,
                   help="bandwidth of the Kalman velocity estimate in Hz (default: sample rate / 10)")
    g.add_argument("--position-noise", type=float, metavar="RAD", default=None,
                   help="position noise std in rad (default: encoder quantum/sqrt(12), or estimated)")
    g.add_argument("--causal", action="store_true",
                   help="causal Kalman filter only (default: filter + zero-lag RTS smoother)")


def io_options_from_args(args) -> dict:
    """``units`` and ``kalman`` options of :func:`adaptive_ff.io.logs.load_log` from parsed arguments.

    Returns
    -------
    dict
        ``{"csv_format": CsvFormat, "units": LogUnits, "kalman": KalmanSettings}``, to pass as
        ``load_log(path, **options)``.

    Raises
    ------
    ParameterError
        A unit or Kalman setting out of range (from :class:`adaptive_ff.io.logs.LogUnits`,
        :class:`adaptive_ff.io.logs.KalmanSettings`).
    """
    from adaptive_ff.io.logs import CsvFormat, KalmanSettings, LogUnits

    return {"csv_format": CsvFormat(skip_rows=getattr(args, "skip_rows", 0),
                                    header_line=getattr(args, "header_line", None),
                                    delimiter=getattr(args, "delimiter", None)),
            "units": LogUnits(current_to_torque=args.current_to_torque, time_unit=args.time_unit,
                              velocity_unit=args.velocity_unit, position_unit=args.position_unit,
                              counts_per_rev=args.counts_per_rev),
            "kalman": KalmanSettings(model=args.kalman_model, bandwidth=args.kalman_bandwidth,
                                     position_noise=args.position_noise, smooth=not args.causal)}


def progress_from_args(args):
    """``False`` with ``--quiet``, else ``None`` (tqdm: a bar only when stderr is a terminal)."""
    return False if getattr(args, "quiet", False) else None


def _is_emps(path: Path) -> bool:
    from scipy.io import whosmat

    try:
        names = {name for name, _, _ in whosmat(str(path))}
    except Exception:  # noqa: BLE001 - any unreadable file is simply not the EMPS layout; load_log says why
        return False
    return {"t", "qm", "vir", "gtau"} <= names


def load_data_from_args(args, path=None):
    """Read the data file named by ``args.file`` (or ``path``) with the options of :func:`add_data_arguments`.

    Returns
    -------
    adaptive_ff.io.data.MeasuredData

    Raises
    ------
    FileNotFoundError, SignalError, ParameterError
        From :func:`adaptive_ff.io.logs.load_log`.

    Notes
    -----
    A .mat file holding the EMPS benchmark variables (``t, qm, vir, gtau``)
    read without ``--columns`` goes through :func:`adaptive_ff.io.data.load_measurements`
    (the benchmark's own preprocessing); everything else through
    :func:`adaptive_ff.io.logs.load_log`.
    """
    from adaptive_ff.io.logs import load_log

    path = Path(args.file if path is None else path)
    if args.columns is None and path.suffix.lower() == ".mat" and path.is_file() and _is_emps(path):
        from adaptive_ff.io.data import load_measurements

        return load_measurements(path)
    return load_log(path, columns=args.columns, progress=progress_from_args(args), **io_options_from_args(args))


def command_line() -> str | None:
    """The current ``adaptive-ff ...`` command line (for reports), or None when not run as the console script."""
    if not sys.argv or Path(sys.argv[0]).name not in ("adaptive-ff", "cli.py"):
        return None
    return shlex.join(["adaptive-ff", *sys.argv[1:]])


@contextlib.contextmanager
def named_by(path):
    """Prefix an error of the package raised in the ``with`` block with the file it concerns, unless it names it or
    an option (a message starting with ``--``).

    For what is computed from a file's data (support points, fits): ``"w has only 3 distinct speeds"`` becomes
    ``"log.csv: w has only 3 distinct speeds"``, so that every error of a command names its file or option.

    Parameters
    ----------
    path : str or os.PathLike
        The input file.

    Raises
    ------
    FrictionError
        The error raised in the block, of the same type (a ParameterError when that type cannot be rebuilt from a
        message), its message prefixed with ``path``.
    """
    from plant.errors import FrictionError, ParameterError

    try:
        yield
    except FrictionError as exc:
        text = str(exc)
        if str(path) in text or text.startswith("--"):
            raise
        try:
            new = type(exc)(f"{path}: {text}")
        except TypeError:
            new = ParameterError(f"{path}: {text}")
        raise new from None


# --------------------------------------------------------------------------- argument types and output checks


def seed_type(text: str) -> int:
    """argparse ``type=`` of ``--seed``: an integer in ``0 .. 2**63 - 1`` (numpy ``SeedSequence`` entropy).

    Raises
    ------
    argparse.ArgumentTypeError
        Not an integer, or negative (argparse then exits 2 naming the option and the value).
    """
    return _int_type(text, lo=0, hi=2**63 - 1, what="a non-negative integer")


def positive_int(text: str) -> int:
    """argparse ``type=``: an integer >= 1 (``--workers``, ``--header-line``)."""
    return _int_type(text, lo=1, hi=None, what="an integer >= 1")


def nonnegative_int(text: str) -> int:
    """argparse ``type=``: an integer >= 0 (``--skip-rows``)."""
    return _int_type(text, lo=0, hi=None, what="an integer >= 0")


def _int_type(text: str, *, lo: int, hi: int | None, what: str) -> int:
    import argparse

    try:
        value = int(text, 10)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be {what}, got {text!r}") from None
    if value < lo or (hi is not None and value > hi):
        limit = f" (at most {hi})" if hi is not None and value > hi else ""
        raise argparse.ArgumentTypeError(f"must be {what}{limit}, got {text!r}")
    return value


def check_output_dir(path, option: str) -> Path:
    """Check up front that ``path`` can be a directory to write into (before any simulation).

    Parameters
    ----------
    path : str or os.PathLike
        Output directory; it or any of its parents may not exist yet.
    option : str
        The option that named it (``--out``), for the message.

    Returns
    -------
    Path

    Raises
    ------
    ParameterError
        ``path`` or a parent names an existing file, or the nearest existing
        parent directory is not writable.
    """
    from plant.errors import ParameterError

    path = Path(path)
    if path.exists() and not path.is_dir():
        raise ParameterError(f"{option} {path}: an existing file, not a directory; give a directory name")
    _check_parents(path if path.exists() else path.parent, option, path)
    return path


def write_plot(out: dict, plot_dir, name: str, draw) -> dict:
    """Draw one figure into ``plot_dir`` (``--plot``) through a staged folder and list it in ``out["figures"]``.

    Parameters
    ----------
    out : dict
        The command's JSON output; a copy with ``"figures"`` (the PNG's final path) is returned.
    plot_dir : str, os.PathLike or None
        The ``--plot`` folder (checked up front with :func:`check_output_dir`); None: nothing is drawn.
    name : str
        The PNG's file name.
    draw : callable
        ``draw()`` returns the ``matplotlib.figure.Figure`` to save (120 dpi).

    Returns
    -------
    dict
        ``out`` with the staged paths moved to where the folder ends up
        (:meth:`adaptive_ff.io.output.StagedOutputs.relocate`).
    """
    from adaptive_ff.io.output import StagedOutputs

    with StagedOutputs() as staged:
        if plot_dir:
            path = Path(staged.folder(plot_dir, "--plot")) / name
            draw().savefig(path, dpi=120)
            out = {**out, "figures": [str(path)]}
    return staged.relocate(out)


def check_output_file(path, option: str, *, overwrite: bool = True) -> Path:
    """Check up front that file ``path`` can be written (before any simulation).

    Parameters
    ----------
    path : str or os.PathLike
        Output file; its directory may not exist yet.
    option : str
        The option that named it (``--out``), for the message.
    overwrite : bool, keyword-only
        Allow an existing file (default; a resumable results table is appended to).

    Returns
    -------
    Path

    Raises
    ------
    ParameterError
        ``path`` is a directory, exists while ``overwrite`` is False, a parent
        is a file, or the file or directory is not writable.
    """
    import os

    from plant.errors import ParameterError

    path = Path(path)
    if path.is_dir():
        raise ParameterError(f"{option} {path}: is a directory; give a file name")
    if path.exists():
        if not overwrite:
            raise ParameterError(f"{option} {path}: the file exists; remove it or choose another name")
        if not os.access(path, os.W_OK):
            raise ParameterError(f"{option} {path}: the file is not writable")
        return path
    _check_parents(path.parent, option, path)
    return path


def _check_parents(start: Path, option: str, path: Path) -> None:
    import os

    from plant.errors import ParameterError

    cur = start if str(start) else Path(".")
    while not cur.exists():
        cur = cur.parent
    if not cur.is_dir():
        raise ParameterError(f"{option} {path}: {cur} is an existing file, so it cannot hold {path}")
    if not os.access(cur, os.W_OK | os.X_OK):
        raise ParameterError(f"{option} {path}: the directory {cur} is not writable")


#: Named plant parameter sets of :data:`plant.friction.PRESETS`, listed here so that ``--help`` needs no
#: C-module import (tests/docs_cli/test_cli_errors.py checks that the two agree).
PRESET_NAMES = ("paper",)



def add_units_argument(parser, *, extra: str = "") -> None:
    """Add ``--units {deg,rad}``: the velocity unit of printed tables (JSON and CSV stay in rad/s).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The subcommand's parser.
    extra : str, optional
        Sentence appended to the option's help (what else the unit converts, or what it leaves alone).
    """
    parser.add_argument("--units", choices=list(TABLE_UNITS), default="deg",
                        help="velocity unit of the printed tables: deg (deg/s, default) or rad (rad/s); "
                             "JSON and CSV outputs are always SI (rad/s)" + (f". {extra}" if extra else ""))


def table_unit(args) -> tuple[float, str]:
    """``(factor, label)`` converting rad/s to the ``--units`` of the printed tables (default deg/s)."""
    return TABLE_UNITS[getattr(args, "units", "deg") or "deg"]


def per_angle(args) -> tuple[float, str]:
    """``(factor, angle)`` converting a quantity per radian (N·m·s/rad, N·m/rad) to the ``--units`` of ``args``.

    A coefficient per rad/s (sigma, Kp) or per rad (Ki) is multiplied by ``factor``
    (pi/180 for ``deg``, 1 for ``rad``) and labelled per ``angle`` (``"deg"`` or ``"rad"``).
    """
    k, unit = table_unit(args)
    return 1.0 / k, unit.split("/")[0]
