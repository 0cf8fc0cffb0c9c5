"""Shared command-line options for reading drive logs (column map, units, Kalman velocity) and the report path.

Used by ``adaptive-ff stribeck`` and meant for ``adaptive-ff identify``:
:func:`add_data_arguments` adds the options to a subparser and
:func:`load_data_from_args` reads the file with them
(:func:`adaptive_ff.io.logs.load_log`; an EMPS benchmark .mat without ``--columns``
goes through :func:`adaptive_ff.io.data.load_measurements` as before).
"""

from __future__ import annotations

import shlex
import sys
from pathlib import Path

__all__ = ["add_data_arguments", "load_data_from_args", "io_options_from_args", "progress_from_args",
           "command_line", "DATA_EPILOG"]

#: Text for a subcommand's ``--help`` epilog: how to map columns and units.
DATA_EPILOG = """\
data files: CSV/TXT (header row of names; comma, semicolon, tab or whitespace separated; '#' comments),
MATLAB .mat (v5-v7; 'log.time' reaches into a struct) or NumPy .npz (read without pickle). Roles: t (time),
u (torque; motor current with --current-to-torque), w (velocity) or q (position). Map roles to your
column names with --columns, e.g. --columns t=time,u=current,w=vel; unmapped roles use their own name.
Time stamps may be non-uniform. Position (--columns q=NAME) is turned into velocity by a Kalman filter
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
                                        "t=time,u=current,w=vel (default: columns named t, u, w)")
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
        ``{"units": LogUnits, "kalman": KalmanSettings}``, to pass as ``load_log(path, **options)``.

    Raises
    ------
    ParameterError
        A unit or Kalman setting out of range (from :class:`adaptive_ff.io.logs.LogUnits`,
        :class:`adaptive_ff.io.logs.KalmanSettings`).
    """
    from adaptive_ff.io.logs import KalmanSettings, LogUnits

    return {"units": LogUnits(current_to_torque=args.current_to_torque, time_unit=args.time_unit,
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
    except (ValueError, TypeError, OSError, NotImplementedError):
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
