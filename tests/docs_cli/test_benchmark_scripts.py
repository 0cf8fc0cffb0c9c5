"""Every script of ``benchmarks/`` imports against the current package and has a ``main``: a script that names a
function the package no longer has fails here, not in front of a reader who runs it."""

from __future__ import annotations

import importlib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPTS = sorted(p.stem for p in (ROOT / "benchmarks").glob("*.py") if p.stem != "__init__")


def test_there_are_scripts():
    assert len(SCRIPTS) >= 30, SCRIPTS


@pytest.mark.parametrize("name", SCRIPTS)
def test_the_script_imports_and_has_a_main(name):
    module = importlib.import_module(f"benchmarks.{name}")
    assert callable(getattr(module, "main", None)), f"benchmarks/{name}.py has no main()"
