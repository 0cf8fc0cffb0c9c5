"""The suite's configuration: the ``slow`` marker and ``--run-slow``.

``python -m pytest`` runs the quick part of the suite (a few minutes on two cores); ``python -m pytest --run-slow``
runs the whole suite, as CI does (``.ci/run``, the README's test command). A test is slow when it simulates or fits
for many seconds (output-error fits with their bootstrap, the documentation pages run command by command, the
fuzzers); such a test carries ``@pytest.mark.slow``, or its file is in :data:`SLOW_FILES`.
"""

from __future__ import annotations

import os
import sys
import warnings
from pathlib import Path

import pytest

#: tests/: the shared helpers (oracles, doc_commands, golden_cases, ...) and data beside this file. The test files are
#: grouped in folders below (tools/regroup_tests.py); every one of them imports the helpers by module name.
TESTS = Path(__file__).resolve().parent
if str(TESTS) not in sys.path:
    sys.path.insert(0, str(TESTS))
if str(TESTS.parent) not in sys.path:
    sys.path.insert(0, str(TESTS.parent))

from benchmarks.numeric_paths import numpy_paths  # noqa: E402

#: numpy and OpenBLAS on their AVX2 paths on an AVX-512 machine, before anything imports numpy
#: (benchmarks/numeric_paths.py: the suite's measured numbers and the quoted outputs are those paths'); the workers
#: of -n inherit them.
_PATHS = numpy_paths(os.environ)
if _PATHS and "numpy" in sys.modules:
    warnings.warn("numpy was imported before tests/conftest.py could hold it to its AVX2 paths: measured numbers "
                  "may differ from the quoted ones on this AVX-512 machine", stacklevel=1)
os.environ.update(_PATHS)

#: Test files whose every test is slow (tens of seconds to minutes each; together about two thirds of the suite's
#: time): the output-error and closed-loop fits, the documentation pages run as written, the fuzzers.
SLOW_FILES = frozenset({
    "test_closed_loop_id.py", "test_physical_id.py", "test_your_drive.py", "test_docs.py", "test_readme.py",
    "test_identify_method.py", "test_fuzz_c.py", "test_fuzz_cli.py", "test_properties.py", "test_stiff_lugre.py",
    "test_figures_quality.py", "test_stiff_lagged.py", "test_examples.py", "test_arm.py", "test_arm_tx40.py",
})

#: The test files of about 20 s or more (``-n 0 --run-slow --durations=0`` on a loaded two-core machine), longest
#: first. ``--dist loadfile`` gives a worker a whole file, and xdist hands the files out in collection order
#: (``--no-loadscope-reorder``, pyproject.toml; its default order, most tests first, can start a long file of few
#: tests late, beside an idle core): these files go first, longest first, and the many short files fill both
#: workers' ends (longest-processing-time-first scheduling). A file missing here only starts later; the order
#: decides no result.
LONG_FILES = (
    "test_your_arm.py", "test_compare_arm.py", "test_physical_id.py", "test_closed_loop_id.py", "test_your_drive.py",
    "test_kernel_adaptive.py", "test_coverage_small_zoo.py", "test_properties.py", "test_docs.py", "test_sweep.py",
    "test_zoo.py", "test_figures_quality.py", "test_fuzz_cli.py", "test_readme.py", "test_plant_options.py",
    "test_arm_lag.py", "test_arm_coverage.py", "test_fuzz_c.py", "test_stiff_lagged.py", "test_arm.py",
    "test_examples.py",
    "test_atomic_commands.py", "test_identify_auto.py", "test_plausibility.py", "test_batch.py",
    "test_identify_method.py", "test_model_forms.py", "test_static_stick.py", "test_adaptive_dob.py",
    "test_delay_profile.py", "test_scenario.py", "test_stiff_lugre.py", "test_plant.py",
)


def pytest_addoption(parser):
    parser.addoption("--run-slow", action="store_true", default=False,
                     help="also run the tests marked slow: the whole suite, as CI runs it")


def pytest_configure(config):
    config.addinivalue_line("markers", "slow: a test of many seconds; run only with --run-slow (tests/conftest.py)")


@pytest.hookimpl(trylast=True)  # after pytest's own reordering by fixture
def pytest_collection_modifyitems(config, items):
    rank = {name: i for i, name in enumerate(LONG_FILES)}
    items.sort(key=lambda item: rank.get(Path(str(item.fspath)).name, len(rank)))  # stable: a file keeps its order
    for item in items:
        if Path(str(item.fspath)).name in SLOW_FILES:
            item.add_marker(pytest.mark.slow)
    if config.getoption("--run-slow"):
        return
    skip = pytest.mark.skip(reason="slow: run with --run-slow (the whole suite, as CI does)")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip)
