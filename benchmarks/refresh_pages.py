"""Re-measure the benchmark pages: run each measured section's command at the current commit and rewrite its output.

Run:  python -m benchmarks.refresh_pages [PAGE ...] [--list] [--allow-dirty] [--only TEXT]

A page of ``docs/benchmarks/`` is made of measured sections, each in this form::

    ```bash
    python benchmarks/tracking.py
    ```

    Measured at commit `abc1234` on 2026-11-26 (2-core machine; 15 s wall).

    ```
    (what the command prints)
    ```

(a bash block with one command; a paragraph that starts ``Measured at commit `HASH` on DATE``; the command's output:
a plain fenced block, Markdown under a ``## Output`` heading up to the next level-2 heading, or Markdown between the
lines ``<!-- output -->`` and ``<!-- end output -->``). Refreshing a section runs its command in a temporary folder
that links each top-level entry of the repository root (what a command writes into its working folder stays out of
the checkout; ``python`` is this interpreter, ``adaptive-ff`` this checkout's
CLI, ``PYTHONPATH`` the root), replaces the output with what it printed (standard output; standard error goes to the
terminal, where the progress bars are), and in the paragraph the commit, the date and a wall time given as ``N s
wall`` or ``N min wall``. The rest of the paragraph (the machine, what the columns mean) is kept. A section whose
bash block holds more than one command is listed as not refreshable.

The package code must be that of the commit the page will name: with uncommitted changes under ``plant/``,
``adaptive_ff/``, ``controllers/`` or ``benchmarks/`` the script refuses (``--allow-dirty``: it runs and says
``(uncommitted changes)`` after the commit). A command that fails leaves its section unchanged and the script exits 1
after the other sections.

``--list`` prints every section of the pages (refreshable or not) without running anything; ``--only TEXT`` refreshes
just the sections whose command contains ``TEXT`` (e.g. a script's name).
"""

from __future__ import annotations

import argparse
import datetime
import os
import re
import shlex
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from benchmarks.numeric_paths import numpy_paths

ROOT = Path(__file__).resolve().parents[1]
PAGES = ROOT / "docs" / "benchmarks"
CODE = ("plant", "adaptive_ff", "controllers", "benchmarks")

SECTION = re.compile(
    r"^```bash\n(?P<cmds>(?:(?!```).*\n)*?)```[ \t]*\n\n"
    r"(?P<measured>Measured at commit `(?P<commit>[0-9a-f]{7,40})`(?P<dirty> \(uncommitted changes\))? on "
    r"(?P<date>\d{4}-\d{2}-\d{2}).*(?:\n.+)*)\n\n"
    r"(?P<out>```\n(?:(?!```).*\n)*?```[ \t]*$|## Output\n[\s\S]*?(?=^## |\Z)"
    r"|<!-- output -->\n[\s\S]*?^<!-- end output -->[ \t]*$)",
    re.M)
WALL = re.compile(r"(?<![\w.-])(?P<n>\d+(?:\.\d+)?) (?P<unit>s|min) wall\b")


@dataclass
class Section:
    """One measured section of a page: its command(s), its ``Measured at`` paragraph and its output's span."""

    page: Path
    line: int
    commands: list[str]
    match: re.Match

    @property
    def refreshable(self) -> bool:
        return len(self.commands) == 1

    @property
    def form(self) -> str:
        """How the output is written: ``"fenced"``, ``"section"`` (``## Output``) or ``"marked"`` (Markdown
        between ``<!-- output -->`` and ``<!-- end output -->``)."""
        out = self.match.group("out")
        return "section" if out.startswith("## Output") else "marked" if out.startswith("<!--") else "fenced"


def commands_of(block: str) -> list[str]:
    """The commands of a bash block: its logical lines (backslash continuations joined), comments and blanks out."""
    out, cur = [], ""
    for line in block.splitlines():
        cur += line[:-1] + " " if line.endswith("\\") else line
        if line.endswith("\\"):
            continue
        if cur.strip() and not cur.lstrip().startswith("#"):
            out.append(" ".join(cur.split()))
        cur = ""
    return out


def sections(page: Path) -> list[Section]:
    """The measured sections of ``page`` in page order."""
    text = page.read_text(encoding="utf-8")
    return [Section(page, text.count("\n", 0, m.start()) + 1, commands_of(m.group("cmds")), m)
            for m in SECTION.finditer(text)]


def environment(bin_dir: Path) -> dict:
    """The environment of a documented command: this interpreter as ``python``, this checkout's CLI as
    ``adaptive-ff`` (shims written into ``bin_dir``, first on ``PATH``; ``PYTHONPATH`` the repository root),
    ``MPLBACKEND=Agg``, ``PYTHONUNBUFFERED=1``, numpy and OpenBLAS on their AVX2 paths
    (:mod:`benchmarks.numeric_paths`), no ``COLUMNS`` (help texts at their default width) and ``GIT_DIR``,
    ``GIT_WORK_TREE`` this checkout's (git run from the temporary folder answers for it). Also the environment of the
    docs' command tests (``tests/doc_commands.py``)."""
    bin_dir.mkdir(parents=True, exist_ok=True)
    exe = shlex.quote(sys.executable)
    cli = shlex.quote("import sys; from controllers.cli import main; sys.exit(main(sys.argv[1:]))")
    (bin_dir / "adaptive-ff").write_text(f'#!/bin/sh\nexec {exe} -c {cli} "$@"\n', encoding="utf-8")
    for name in ("python", "python3"):
        (bin_dir / name).write_text(f'#!/bin/sh\nexec {exe} "$@"\n', encoding="utf-8")
    for f in bin_dir.iterdir():
        f.chmod(0o755)
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONUNBUFFERED": "1", **numpy_paths(os.environ)}
    env["PATH"] = os.pathsep.join([str(bin_dir), env.get("PATH", "")])
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    env.pop("COLUMNS", None)
    # git in the temporary folder answers for this checkout (a script printing its commit and whether it is dirty)
    env["GIT_DIR"], env["GIT_WORK_TREE"] = str(ROOT / ".git"), str(ROOT)
    return env


def code_state(root: Path = ROOT) -> tuple[str, bool]:
    """The short hash of HEAD and whether the package or benchmark code differs from it."""
    head = subprocess.run(["git", "rev-parse", "--short=7", "HEAD"], cwd=root, capture_output=True, text=True,
                          check=True).stdout.strip()
    status = subprocess.run(["git", "status", "--porcelain", "--", *CODE], cwd=root, capture_output=True, text=True,
                            check=True).stdout.strip()
    return head, bool(status)


def measured_paragraph(old: str, commit: str, dirty: bool, date: str, wall: float) -> str:
    """``old`` with the new commit, date and wall time (its other words kept)."""
    head = f"Measured at commit `{commit}`{' (uncommitted changes)' if dirty else ''} on {date}"
    new = re.sub(r"^Measured at commit `[0-9a-f]+`(?: \(uncommitted changes\))? on \d{4}-\d{2}-\d{2}", head, old)

    def wall_text(m: re.Match) -> str:
        return f"{wall / 60:.0f} min wall" if m.group("unit") == "min" else f"{wall:.0f} s wall"

    return WALL.sub(wall_text, new, count=1)


def rewritten(text: str, section: Section, printed: str, *, commit: str, dirty: bool, date: str,
              wall: float) -> str:
    """``text`` (the page) with ``section``'s paragraph and output replaced."""
    m = section.match
    body = printed.rstrip("\n")
    out = {"section": f"## Output\n\n{body}\n", "marked": f"<!-- output -->\n{body}\n<!-- end output -->",
           "fenced": f"```\n{body}\n```"}[section.form]
    para = measured_paragraph(m.group("measured"), commit, dirty, date, wall)
    a, b = m.span("measured")
    c, d = m.span("out")
    return text[:a] + para + text[b:c] + out + text[d:]


def work_folder(folder: Path) -> Path:
    """A folder that looks like the repository root (a link to each of its top-level entries) for the commands to run
    in, so that what they write into their working folder (figures, ``out/``) stays out of the checkout."""
    work = folder / "work"
    work.mkdir()
    for entry in ROOT.iterdir():
        if entry.name not in (".git", "out"):
            (work / entry.name).symlink_to(entry)
    return work


def run(command: str, env: dict, cwd: Path = ROOT) -> tuple[int, str, float]:
    """Run ``command`` through bash in ``cwd``: (exit status, standard output, wall s)."""
    t0 = time.perf_counter()
    r = subprocess.run(["bash", "-c", command], cwd=cwd, env=env, stdout=subprocess.PIPE, text=True)
    return r.returncode, r.stdout, time.perf_counter() - t0


def refresh(page: Path, env: dict, *, commit: str, dirty: bool, date: str, cwd: Path = ROOT,
            only: str | None = None) -> int:
    """Refresh every refreshable section of ``page`` (last first, so that spans stay valid), its commands run in
    ``cwd`` (:func:`work_folder`); with ``only``, just the sections whose command contains that text; the failures."""
    failed = 0
    for s in reversed(sections(page)):
        if only is not None and not any(only in c for c in s.commands):
            continue
        if not s.refreshable:
            print(f"{page.name}:{s.line}: not refreshable ({len(s.commands)} commands)", file=sys.stderr)
            continue
        print(f"{page.name}:{s.line}: $ {s.commands[0]}", file=sys.stderr, flush=True)
        code, printed, wall = run(s.commands[0], env, cwd)
        if code != 0:
            print(f"{page.name}:{s.line}: exit {code}; the section is left as it was", file=sys.stderr)
            failed += 1
            continue
        text = page.read_text(encoding="utf-8")
        page.write_text(rewritten(text, s, printed, commit=commit, dirty=dirty, date=date, wall=wall),
                        encoding="utf-8")
        print(f"{page.name}:{s.line}: {wall:.0f} s wall", file=sys.stderr)
    return failed


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("pages", nargs="*", help="page names or paths (default: every page of docs/benchmarks)")
    ap.add_argument("--list", action="store_true", help="print the sections, run nothing")
    ap.add_argument("--allow-dirty", action="store_true", help="run with uncommitted package or benchmark code")
    ap.add_argument("--only", metavar="TEXT", help="refresh only the sections whose command contains TEXT")
    a = ap.parse_args(argv)
    pages = []
    for p in a.pages or sorted(PAGES.glob("*.md")):
        path = Path(p) if Path(p).is_file() else PAGES / (p if str(p).endswith(".md") else f"{p}.md")
        if not path.is_file():
            print(f"refresh_pages: no page {p!r} (looked for {path})", file=sys.stderr)
            return 2
        pages.append(path)
    if a.list:
        for page in pages:
            for s in sections(page):
                state = "refreshable" if s.refreshable else f"{len(s.commands)} commands"
                print(f"{page.name}:{s.line}: [{state}] {' ; '.join(s.commands)}")
        return 0
    commit, dirty = code_state()
    if dirty and not a.allow_dirty:
        print("refresh_pages: the package or benchmark code has uncommitted changes; commit them first "
              "(or --allow-dirty)", file=sys.stderr)
        return 2
    date = datetime.datetime.now(datetime.timezone.utc).date().isoformat()
    with tempfile.TemporaryDirectory() as tmp:
        env = environment(Path(tmp))
        work = work_folder(Path(tmp))
        failed = sum(refresh(page, env, commit=commit, dirty=dirty, date=date, cwd=work, only=a.only)
                     for page in pages)
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
