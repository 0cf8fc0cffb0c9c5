"""The product speaks in the present tense: no dates, commit hashes or zoo joint numbers in the package's code, its
C sources and headers, or any subcommand's ``--help`` (history lives in CHANGELOG.md and git)."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("plant", "adaptive_ff", "controllers")
#: A date, a commit named as one, or a zoo joint named by its number ("#550", "joint 7 of"); CSS colours are not.
HISTORY = re.compile(r"\b20\d\d-\d\d-\d\d\b|\bcommits? `?[0-9a-f]{7,40}\b|(?<![\w&:])#\d{1,4}\b(?![0-9a-fA-F]{2})")


def _sources():
    for pkg in PACKAGES:
        for path in sorted((ROOT / pkg).rglob("*")):
            if path.suffix in (".py", ".c", ".h") and "build" not in path.parts:
                yield path


def test_the_pattern_finds_history_and_nothing_else():
    assert HISTORY.search("as before 2026-11-23") and HISTORY.search("commit 041944d")
    assert HISTORY.search("the zoo's Karnopp joint #550") and HISTORY.search("(#25 reached 1.065)")
    for text in ("color:#222;", "#include \"aff.h\"", "x = y  # a comment", "sha256 of 1a2b3c4d", "issue #"):
        assert not HISTORY.search(text), text


def test_no_dates_commits_or_joint_numbers_in_the_package():
    found = [f"{p.relative_to(ROOT)}:{i}: {line.strip()[:100]}"
             for p in _sources() for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
             if HISTORY.search(line)]
    assert not found, "history in the product (move it to CHANGELOG.md):\n" + "\n".join(found)


@pytest.mark.parametrize("command", ["compare", "compare-arm", "identify", "identify-arm", "design", "stribeck", "export-c",
                                     "paper-figures", "sweep"])
def test_no_history_in_help(command):
    out = subprocess.run([sys.executable, "-m", "controllers.cli.main", command, "--help"], capture_output=True,
                         text=True, cwd=ROOT, timeout=120)
    assert out.returncode == 0, out.stderr
    assert not HISTORY.search(out.stdout), HISTORY.search(out.stdout)
