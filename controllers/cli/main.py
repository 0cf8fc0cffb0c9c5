"""Command-line interface ``adaptive-ff`` (the package's top layer: it may import everything).

Subcommands
-----------
compare   run the closed loop in all friction-compensation modes and compare tracking
identify  identify friction (offline LS and RLS) from a measured log (CSV t,u,w or the EMPS .mat)
compare-arm    every joint of a simulated arm in its velocity loop: the compensators per joint, eta per joint
identify-arm   every joint's friction and the rigid body of an arm from a multi-joint log and its URDF
stribeck       fit the Stribeck curve (Vs, delta) from quasi-static data, Fig. 8
design         discrete PI velocity controller: gains, margins, Bode, step
paper-figures  regenerate the paper's Figs. 4, 5, 8-12 from simulation
sweep     grid / Monte-Carlo study over plants, gains, modes and seeds (resumable; local cores or Dask)
export-c  the adaptive feedforward as a C library for a drive (C99, <math.h> only)
"""

from __future__ import annotations

import argparse
import sys

__all__ = ["main", "build_parser"]


def _version() -> str:
    """The installed distribution's version (``importlib.metadata``), or ``unknown`` when not installed."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("adaptive-ff")
    except PackageNotFoundError:
        return "unknown (not installed)"


def build_parser() -> argparse.ArgumentParser:
    """The ``adaptive-ff`` argument parser; each subcommand lives in its own module of :mod:`controllers.cli`."""
    from controllers.cli import compare as cli_compare, design as cli_design, identify as cli_identify
    from controllers.cli import paper_figures as cli_paper_figures, stribeck as cli_stribeck, sweep as cli_sweep
    from controllers.cli import compare_arm as cli_compare_arm, export_c as cli_export_c
    from controllers.cli import identify_arm as cli_identify_arm

    ap = argparse.ArgumentParser(prog="adaptive-ff", description=(
        "Identify sliding dynamic friction (Ruderman's discrete-time model: LS, RLS) and compare "
        "friction compensation modes in a PI velocity loop."))
    ap.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    sub = ap.add_subparsers(dest="command", required=True)
    for module in (cli_compare, cli_compare_arm, cli_identify, cli_identify_arm, cli_stribeck, cli_design,
                   cli_paper_figures, cli_sweep, cli_export_c):
        module.register(sub)
    return ap


def main(argv=None) -> int:
    """Entry point of the ``adaptive-ff`` console script; returns the exit status.

    Exit status: 0 success; 2 a usage error or a package error (bad parameters,
    bad data, a file that cannot be read or written, a run too long for the
    memory: refused before it starts, or a ``MemoryError`` on the way), printed as
    ``adaptive-ff: error: ...`` naming the file, argument, row or value; 3 a
    refusal by a command (e.g. ``design --from`` on a warned identification);
    130 interrupted by Ctrl-C (SIGINT), also where the ``KeyboardInterrupt``
    comes from your own compensator; a ``SystemExit`` raised there exits with
    its code; 1 an unexpected internal error (a ``GeneratorExit`` from your
    compensator among them), printed on one line (set ``ADAPTIVE_FF_DEBUG=1``
    for the traceback). No traceback otherwise.
    """
    args = build_parser().parse_args(argv)  # --help and usage errors exit here, before numpy is imported
    try:
        return args.func(args)
    except KeyboardInterrupt:
        print("adaptive-ff: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into e.g. head: stop quietly
        sys.stderr.close()
        return 0
    except SystemExit:  # argparse's, or one raised by a user's compensator: its code
        raise
    except BaseException as exc:  # noqa: BLE001 - the top-level guard: one line, never a traceback
        return _report_error(exc)


def _report_error(exc: BaseException) -> int:
    """Print ``exc`` as one ``adaptive-ff: error:`` line; 2 for package/file errors and lack of memory, 1 for
    anything else."""
    import os

    from plant.errors import FrictionError

    if os.environ.get("ADAPTIVE_FF_DEBUG"):
        raise exc
    if isinstance(exc, (FrictionError, OSError)):
        msg = str(exc)
        if isinstance(exc, OSError) and exc.filename is not None and str(exc.filename) not in msg:
            msg = f"{exc.filename}: {msg}"
        elif isinstance(exc, OSError) and exc.strerror and exc.filename is not None:
            msg = f"{exc.filename}: {exc.strerror}"
        print(f"adaptive-ff: error: {msg}", file=sys.stderr)
        return 2
    text = " ".join(str(exc).split()) or "(no message)"
    if isinstance(exc, MemoryError):  # a resource, not a defect: what was asked needs more memory than there is
        print(f"adaptive-ff: error: out of memory ({text}); a shorter --duration or a smaller input needs less",
              file=sys.stderr)
        return 2
    print(f"adaptive-ff: internal error: {type(exc).__name__}: {text} (please report it; "
          "ADAPTIVE_FF_DEBUG=1 shows the traceback)", file=sys.stderr)
    return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
