"""Command-line interface ``adaptive-ff``: one module per subcommand, :mod:`controllers.cli.main` builds the parser."""

from controllers.cli.main import build_parser, main

__all__ = ["main", "build_parser"]
