"""Fuzz of the command line (derandomized Hypothesis, bounded to well under a minute on one core): command lines of
every subcommand with generated input files (CSV logs, plant JSON, scenario TOML, identification JSON, sweep specs)
and option values (valid, at the boundaries, broken), each run in a fresh folder and checked by
:func:`cli_strategies.check_outcome`: exit status 0, 2, 3 or 130, no traceback, an error naming the file or
option, no partial output, strict JSON. ``python benchmarks/fuzz_cli.py`` runs the same strategies for longer.
"""

import tempfile

import pytest
from hypothesis import HealthCheck, given, note, settings

from cli_strategies import check_outcome, cli_cases, run_case

#: Examples per command: the whole file stays within about a minute on one core.
EXAMPLES = {"garbage": 60, "design": 40, "export-c": 40, "identify": 40, "stribeck": 40, "compare": 40,
            "sweep": 15, "paper-figures": 10}


def _settings(n: int):
    return settings(derandomize=True, max_examples=n, deadline=None, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                           HealthCheck.filter_too_much])


def _check(case) -> None:
    with tempfile.TemporaryDirectory(prefix="fuzz_cli_") as folder:
        note(case.describe())
        outcome = run_case(case, folder)
        note(f"exit {outcome.status} in {outcome.seconds:.2f} s; stderr: {outcome.stderr[-1500:]}")
        check_outcome(case, outcome, folder)


def _fuzz(command: str):
    @_settings(EXAMPLES[command])
    @given(case=cli_cases([command]))
    def test(case):
        _check(case)

    test.__name__ = f"test_fuzz_{command.replace('-', '_')}"
    return test


@pytest.mark.parametrize("command", list(EXAMPLES))
def test_fuzz_command_line(command):
    _fuzz(command)()
