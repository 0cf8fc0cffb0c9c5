"""Command-line interface ``adaptive-ff`` (the package's top layer: it may import everything).

Subcommands
-----------
compare   run the closed loop in all friction-compensation modes and compare tracking
identify  identify friction (offline LS and RLS) from a measured log (CSV t,u,w or the EMPS .mat)
stribeck       fit the Stribeck curve (Vs, delta) from quasi-static data, Fig. 8
design         discrete PI velocity controller: gains, margins, Bode, step
paper-figures  regenerate the paper's Figs. 4, 5, 8-12 from simulation
sweep     grid / Monte-Carlo study over plants, gains, modes and seeds (resumable; local cores or Dask)
"""

from __future__ import annotations

import argparse
import sys

__all__ = ["main", "build_parser"]


def build_parser() -> argparse.ArgumentParser:
    """The ``adaptive-ff`` argument parser; each subcommand lives in its own module of :mod:`controllers.cli`."""
    from controllers.cli import compare as cli_compare, design as cli_design, identify as cli_identify
    from controllers.cli import paper_figures as cli_paper_figures, stribeck as cli_stribeck, sweep as cli_sweep

    ap = argparse.ArgumentParser(prog="adaptive-ff", description=(
        "Identify sliding dynamic friction (Ruderman's discrete-time model: LS, RLS) and compare "
        "friction compensation modes in a PI velocity loop."))
    sub = ap.add_subparsers(dest="command", required=True)
    for module in (cli_compare, cli_identify, cli_stribeck, cli_design, cli_paper_figures, cli_sweep):
        module.register(sub)
    return ap


def main(argv=None) -> int:
    """Entry point of the ``adaptive-ff`` console script; returns the exit status.

    Package errors (bad parameters, bad data) are printed as ``adaptive-ff: error: ...``
    with exit status 2, without a traceback.
    """
    args = build_parser().parse_args(argv)  # --help and usage errors exit here, before numpy is imported
    from plant.errors import FrictionError

    try:
        return args.func(args)
    except (FrictionError, FileNotFoundError) as exc:
        print(f"adaptive-ff: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
