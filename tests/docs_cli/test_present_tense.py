"""The product speaks in the present tense: no dates, commit hashes or zoo joint numbers in the package's code, its
C sources and headers, or any subcommand's ``--help``; no dates or commit hashes in examples/ and docs/ but the
benchmark pages' "measured at commit X on DATE" lines and the run headers their quoted outputs begin with (history
lives in CHANGELOG.md and git)."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("plant", "adaptive_ff", "controllers")
#: A date, a commit named as one, or a zoo joint named by its number ("#550", "joint 7 of"); CSS colours are not.
HISTORY = re.compile(r"\b20\d\d-\d\d(?:-\d\d)?\b|\bcommits? `?[0-9a-f]{7,40}\b|(?<![\w&:])#\d{1,4}\b(?![0-9a-fA-F]{2})")


#: In examples/ and docs/: a date (a year-month too) or a commit named as one.
DOC_HISTORY = re.compile(r"\b20\d\d-\d\d(?:-\d\d)?\b|\bcommits? `?[0-9a-f]{7,40}\b")
#: What a benchmark page (docs/benchmarks/*.md) may say of when its numbers were taken: "measured at commit `X` on
#: DATE" (the form benchmarks/refresh_pages.py writes, "(uncommitted changes)" after the commit too; or without the
#: date where the page says which rows it covers) ...
MEASURED_AT = re.compile(r"[Mm]easured at commit `[0-9a-f]{7,40}`(?: \(uncommitted changes\))?(?: on 20\d\d-\d\d-\d\d)?")
#: ... and, inside a fenced code block, the header line a benchmark script prints above its output.
RUN_HEADER = re.compile(r"^# 20\d\d-\d\d-\d\d \d\d:\d\d UTC, commit [0-9a-f]{7,40}(?:\+dirty)?, ")
DOC_SUFFIXES = (".md", ".rst", ".py", ".json", ".txt")


def _doc_history(path: Path) -> list:
    """``(line number, line)`` of the history a docs/ or examples/ file carries, less the allowed forms."""
    page = path.parent.name == "benchmarks" and path.suffix == ".md"
    found, fenced, marked = [], False, False  # in a fenced block; in a measured output between the markers
    for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if line.lstrip().startswith("```"):
            fenced = not fenced
            continue
        if line.strip() in ("<!-- output -->", "<!-- end output -->"):
            marked = line.strip() == "<!-- output -->"
            continue
        text = MEASURED_AT.sub("", line) if page else line
        if page and (fenced or marked) and RUN_HEADER.match(line.strip()):
            continue
        if DOC_HISTORY.search(text):
            found.append((i, line))
    return found


def _sources():
    for pkg in PACKAGES:
        for path in sorted((ROOT / pkg).rglob("*")):
            if path.suffix in (".py", ".c", ".h") and "build" not in path.parts:
                yield path


def test_the_pattern_finds_history_and_nothing_else():
    assert HISTORY.search("as before 2026-11-23") and HISTORY.search("commit 041944d")
    assert HISTORY.search("since 2026-11") and DOC_HISTORY.search("the rows of 2026-11")
    assert HISTORY.search("the zoo's Karnopp joint #550") and HISTORY.search("(#25 reached 1.065)")
    for text in ("color:#222;", "#include \"aff.h\"", "x = y  # a comment", "sha256 of 1a2b3c4d", "issue #"):
        assert not HISTORY.search(text), text


def test_no_dates_commits_or_joint_numbers_in_the_package():
    found = [f"{p.relative_to(ROOT)}:{i}: {line.strip()[:100]}"
             for p in _sources() for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
             if HISTORY.search(line)]
    assert not found, "history in the product (move it to CHANGELOG.md):\n" + "\n".join(found)


def test_the_pages_allowance_is_narrow(tmp_path):
    page = tmp_path / "benchmarks" / "x.md"
    page.parent.mkdir()
    page.write_text("Measured at commit `abc1234` on 2026-11-26 (2 cores).\n"
                    "```\n# 2026-11-26 16:22 UTC, commit abc1234+dirty, x86_64, cores 2\nzoo: 3 joints\n```\n"
                    "Faster since 2026-11 (commit abc1234).\n```\n2026-11-26 a date in an output\n```\n"
                    "# 2026-11-26 16:22 UTC, commit abc1234, outside a block\n"
                    "<!-- output -->\n# 2026-11-26 16:22 UTC, commit abc1234, velocity kalman\n| a |\n"
                    "<!-- end output -->\n# 2026-11-26 16:22 UTC, commit abc1234, after the markers\n")
    assert [i for i, _ in _doc_history(page)] == [6, 8, 10, 15]
    other = tmp_path / "guide.md"
    other.write_text("Measured at commit `abc1234` on 2026-11-26.\n")
    assert [i for i, _ in _doc_history(other)] == [1]


def test_no_dates_or_commits_in_docs_and_examples():
    found = [f"{p.relative_to(ROOT)}:{i}: {line.strip()[:100]}"
             for d in ("docs", "examples") for p in sorted((ROOT / d).rglob("*"))
             if p.is_file() and p.suffix in DOC_SUFFIXES for i, line in _doc_history(p)]
    assert not found, "history in the docs (move it to CHANGELOG.md; a page's numbers: one measured-at line):\n" + \
        "\n".join(found)


@pytest.mark.parametrize("command", ["compare", "compare-arm", "identify", "identify-arm", "design", "stribeck", "export-c",
                                     "paper-figures", "sweep"])
def test_no_history_in_help(command):
    out = subprocess.run([sys.executable, "-m", "controllers.cli.main", command, "--help"], capture_output=True,
                         text=True, cwd=ROOT, timeout=120)
    assert out.returncode == 0, out.stderr
    assert not HISTORY.search(out.stdout), HISTORY.search(out.stdout)
