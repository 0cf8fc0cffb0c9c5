"""Run the shell commands of a Markdown page and compare the outputs it quotes with what they print now.

Used by ``tests/docs_cli/test_readme.py`` (README.md) and ``tests/docs_cli/test_your_drive.py`` (docs/your_drive.md).
A page's commands are found in two kinds of fenced blocks:

* ``bash`` blocks: every logical line (backslash continuations joined) is a command, run through
  ``bash`` with ``set -e``. Lines or ``&&``-parts that make an environment (``python3 -m venv``,
  ``. .venv/bin/activate``, ``pip install``) are skipped: the tests already run in the installed
  environment; ``python -m pytest`` is skipped because it is the test run itself. The page may quote
  the output of such a command elsewhere, in a plain fenced block under an HTML comment
  ``<!-- main-job-output: COMMAND (...) -->``.
* console blocks (a plain fence whose first line starts with ``$ ``): each ``$ COMMAND`` (with its
  backslash continuation lines) is followed by the output it prints. The command runs through
  ``bash`` without ``set -e`` (as typed at a prompt: ``cmd; echo "exit $?"`` must reach the
  ``echo``). It must exit with status 0 unless its quoted output shows the command-line error prefix
  ``adaptive-ff: error:``.

A command's output is its standard output and standard error together, as a terminal shows them.
Every page runs in its own fresh folder, its commands in page order, so that a later command sees
the files an earlier one wrote, as a reader who types them does. ``adaptive-ff`` and ``python`` are
this checkout's code on the interpreter running the tests (shims first on ``PATH``), with
``MPLBACKEND=Agg`` and ``PYTHONUNBUFFERED=1`` (standard output and error in the order printed).

The comparison (:func:`mismatches`) asks for the same words, punctuation and line count, runs of
blanks counting as one blank (fixed-width columns move with the width of a number), and every number
within a tolerance that the calling test states per line and column (which digits of which output
are stable across platforms and package versions is the test's rule, with its evidence).
"""

from __future__ import annotations

import re
import resource
import shlex
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from benchmarks.refresh_pages import environment  # the commands' environment, one implementation

ROOT = Path(__file__).resolve().parents[1]

FENCE = re.compile(r"^```(?P<info>[^\n`]*)\n(?P<body>.*?)^```[ \t]*$", re.M | re.S)
MARKER = re.compile(r"<!-- main-job-output: (?P<cmd>[^(]*?) \(.*?-->\n```\n(?P<body>.*?)^```[ \t]*$", re.M | re.S)
NUMBER = re.compile(r"(?<![\w.])[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?(?![\w])")
# Not run: making and filling an environment (the tests already run in the installed one: a second
# install would only test pip and the network) and running the tests (that is this run itself).
SETUP = re.compile(r"^\s*(python3? -m venv\b|\. \S*activate\b|source \S*activate\b|(python3? -m )?pip install\b"
                   r"|python3? -m pytest\b|pytest\b)")
ERROR_PREFIX = "adaptive-ff: error:"


@dataclass
class Step:
    """One command of a page and the output the page quotes for it (None: the page quotes none)."""

    command: str
    kind: str  # "bash" (run with set -e) or "console" (without)
    line: int  # line of the page the command starts on (1-based)
    quoted: str | None = None
    span: tuple[int, int] | None = None  # offsets of the quoted output in the page text
    printed: str | None = None
    returncode: int | None = None
    reused: bool = False  # the output of an identical earlier command of the page (run_page)
    wall: float = 0.0  # s
    cpu: float = 0.0  # s of CPU of the command and its children


@dataclass
class Page:
    """The commands of one Markdown page, in page order, and the commands skipped with the reason."""

    path: Path
    text: str
    steps: list[Step] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    folder: Path | None = None  # where the commands ran (set by run_page)


def _logical_lines(body: str, first_line: int):
    """(line number, logical line) of a bash body, backslash continuations joined as written."""
    out, buf, start = [], [], None
    for i, ln in enumerate(body.splitlines()):
        if not buf:
            start = first_line + i
        buf.append(ln)
        if not ln.endswith("\\"):
            out.append((start, "\n".join(buf)))
            buf = []
    if buf:
        out.append((start, "\n".join(buf)))
    return out


def _strip_setup(cmd: str) -> str:
    """``cmd`` without its ``&&``-parts that set up an environment or run the tests ('' if nothing is left)."""
    parts = [p for p in cmd.split(" && ") if not SETUP.match(p)]
    return " && ".join(p.strip() for p in parts)


def parse_page(path: Path) -> Page:
    """The commands of the bash and console blocks of ``path`` and their quoted outputs (module docstring)."""
    text = path.read_text(encoding="utf-8")
    page = Page(path=path, text=text)
    markers = {m.group("cmd").strip(): m for m in MARKER.finditer(text)}
    for m in FENCE.finditer(text):
        info, body = m.group("info").strip(), m.group("body")
        first = text.count("\n", 0, m.start("body")) + 1
        if info == "bash":
            for line, cmd in _logical_lines(body, first):
                if not cmd.strip() or cmd.lstrip().startswith("#"):
                    continue
                kept = _strip_setup(cmd)
                if kept != cmd.strip():
                    page.skipped.append(f"{path.name}:{line}: {cmd.strip()!r} -> {kept!r}")
                if not kept:
                    continue
                step = Step(command=kept, kind="bash", line=line)
                mk = next((markers.pop(c) for c in list(markers) if command_key(c) == command_key(kept)), None)
                if mk is not None:
                    step.quoted, step.span = mk.group("body"), (mk.start("body"), mk.end("body"))
                page.steps.append(step)
        elif info in ("", "console") and body.startswith("$ "):
            page.steps.extend(_console_steps(body, m.start("body"), first))
    if markers:
        raise AssertionError(f"{path.name}: quoted outputs of commands that no bash block runs: {sorted(markers)}")
    return page


def command_key(cmd: str) -> tuple[str, ...]:
    """The words of a command as bash splits them (continuations joined, quotes and a ``# comment`` removed)."""
    try:
        return tuple(shlex.split(cmd.replace("\\\n", " "), comments=True))
    except ValueError:
        return (cmd.strip(),)


def _console_steps(body: str, offset: int, first: int) -> list[Step]:
    """The ``$ `` commands of a console block body (at ``offset`` of the page, line ``first``) and their outputs."""
    lines = body.splitlines(keepends=True)
    steps, pos, i = [], offset, 0
    while i < len(lines):
        if not lines[i].startswith("$ "):
            raise AssertionError(f"console block line {first + i}: output before any '$ ' command")
        line = first + i
        cmd = [lines[i][2:].rstrip("\n")]
        pos += len(lines[i])
        i += 1
        while cmd[-1].endswith("\\") and i < len(lines):
            cmd.append(lines[i].rstrip("\n"))
            pos += len(lines[i])
            i += 1
        start = pos
        while i < len(lines) and not lines[i].startswith("$ "):
            pos += len(lines[i])
            i += 1
        quoted = body[start - offset:pos - offset]
        steps.append(Step(command="\n".join(cmd), kind="console", line=line, quoted=quoted, span=(start, pos)))
    return steps


def run_page(page: Page, folder: Path, *, timeout: float = 900.0) -> Page:
    """Run every command of ``page`` in page order in ``folder/work`` (created empty); fills ``printed``.

    ``printed`` is standard output and standard error together, as a terminal shows them. A command
    that the page repeats word for word (a recipe line, then the same line with its output) runs once
    and its output stands for both: the page's commands are deterministic and do not change what an
    earlier identical command read. Stops at the first command that fails unexpectedly (a bash
    command with non-zero status, a console command with non-zero status whose quoted output shows
    no ``adaptive-ff: error:``) and raises AssertionError naming it, with what it printed.
    """
    work = folder / "work"
    work.mkdir(parents=True, exist_ok=False)
    page.folder = work
    env = environment(folder / "bin")
    done: dict[tuple[str, ...], Step] = {}
    for step in page.steps:
        key = command_key(step.command)
        if key in done:
            step.printed, step.returncode, step.reused = done[key].printed, done[key].returncode, True
            continue
        t0, c0 = time.perf_counter(), _children_cpu()
        script = ("set -e\n" if step.kind == "bash" else "") + step.command
        r = subprocess.run(["bash", "-c", script], cwd=work, env=env, stdout=subprocess.PIPE,
                           stderr=subprocess.STDOUT, text=True, timeout=timeout)
        step.printed, step.returncode = r.stdout, r.returncode
        step.wall, step.cpu = time.perf_counter() - t0, _children_cpu() - c0
        expected_error = step.kind == "console" and ERROR_PREFIX in (step.quoted or "")
        if r.returncode != 0 and not expected_error:
            raise AssertionError(f"{page.path.name}:{step.line}: command failed (exit {r.returncode}):\n"
                                 f"$ {step.command}\n{step.printed}")
        done[key] = step
    return page


def _children_cpu() -> float:
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def timings(page: Page) -> str:
    """One line per command of a run page: wall and CPU seconds, then the command's first line."""
    rows = [f"{s.wall:7.1f} s {s.cpu:7.1f} s CPU  {page.path.name}:{s.line} {s.command.splitlines()[0][:70]}"
            + ("  (same command as above: output reused)" if s.reused else "") for s in page.steps]
    total = f"{sum(s.wall for s in page.steps):7.1f} s {sum(s.cpu for s in page.steps):7.1f} s CPU  total"
    return "\n".join(rows + [total])


# --- comparison ------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Tol:
    """How far a printed number may be from the quoted one.

    Allowed: ``|printed - quoted| <= max(rel*|quoted|, units * last place, abs)``, or, with ``factor``,
    ``quoted/factor <= printed <= quoted*factor``. ``units`` counts units of the last printed place of
    the quoted number (0.5120: 1e-4); integers (no point, no exponent) are exact unless ``rel``, ``abs``
    or ``factor`` allow more.
    """

    rel: float = 0.0
    units: float = 0.0
    abs: float = 0.0
    factor: float = 0.0

    def allows(self, quoted: str, printed: str) -> bool:
        q, p = float(quoted), float(printed)
        if self.factor and q * p > 0 and 1 / self.factor <= p / q <= self.factor:
            return True
        return abs(p - q) <= max(self.rel * abs(q), self.units * last_place(quoted), self.abs) * (1 + 1e-9)


def last_place(s: str) -> float:
    """The value of one unit in the last printed place of the number ``s`` (integers: 0, exact)."""
    m = re.fullmatch(r"[-+]?(\d*)(?:\.(\d*))?(?:[eE]([-+]?\d+))?", s)
    if m is None or (m.group(2) is None and m.group(3) is None):
        return 0.0
    decimals = len(m.group(2) or "")
    return 10.0 ** (int(m.group(3) or 0) - decimals)


Rule = Callable[[str, int], Tol]  # (quoted line, index of the number in the line) -> tolerance


def _skeleton(line: str) -> tuple[str, list[str]]:
    nums = NUMBER.findall(line)
    return " ".join(NUMBER.sub("#", line).split()), nums


def mismatches(quoted: str, printed: str, rule: Rule) -> list[str]:
    """Where ``printed`` differs from ``quoted`` beyond ``rule`` (empty list: they agree)."""
    q_lines, p_lines = quoted.splitlines(), printed.splitlines()
    if len(q_lines) != len(p_lines):
        return [f"{len(p_lines)} lines printed, {len(q_lines)} quoted"]
    out = []
    for i, (ql, pl) in enumerate(zip(q_lines, p_lines), 1):
        (qs, qn), (ps, pn) = _skeleton(ql), _skeleton(pl)
        if qs != ps or len(qn) != len(pn):
            out.append(f"line {i}: text differs:\n  quoted : {ql}\n  printed: {pl}")
            continue
        for k, (a, b) in enumerate(zip(qn, pn)):
            tol = rule(ql, k)
            if not tol.allows(a, b):
                out.append(f"line {i}, number {k + 1}: printed {b}, quoted {a} (allowed: {tol}):\n  {pl}")
    return out


def check_page(page: Page, rule: Rule) -> list[str]:
    """Every quoted output of a run page against what its command printed, by ``rule``; the mismatches."""
    out = []
    for step in page.steps:
        if step.quoted is None:
            continue
        bad = mismatches(step.quoted, step.printed, rule)
        if bad:
            out.append(f"{page.path.name}:{step.line}: $ {step.command}\n" + "\n".join(bad))
    return out


def updated_text(page: Page) -> tuple[str, int]:
    """The page's text with every quoted output replaced by what its command printed; (text, blocks changed)."""
    text, changed = page.text, 0
    for step in sorted((s for s in page.steps if s.span is not None), key=lambda s: s.span[0], reverse=True):
        a, b = step.span
        new = step.printed if step.printed.endswith("\n") or not step.printed else step.printed + "\n"
        if text[a:b] != new:
            text, changed = text[:a] + new + text[b:], changed + 1
    return text, changed


def update_page(path: Path, *, page: "Page | None" = None, digits: "Rule | None" = None) -> int:
    """Run the page's commands in a temporary folder and rewrite every quoted output that differs from
    what its command printed (the ``--update`` mode of the page's test); prints a summary, returns 0.

    ``page``: the page's steps as the test runs them (default ``parse_page(path)``); ``digits``: the test's rule
    of stable digits (default :func:`stable_digits`), which counts the rewrites beyond it in the summary.
    Re-runnable: only the quoted outputs change, the commands and the prose stay, so running it again
    after a change of the code refreshes the same blocks.
    """
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        page = run_page(parse_page(path) if page is None else page, Path(tmp))
    print(timings(page), file=sys.stderr)
    beyond = len(check_page(page, stable_digits if digits is None else digits))
    text, changed = updated_text(page)
    if changed:
        path.write_text(text, encoding="utf-8")
    print(f"{path.relative_to(ROOT)}: {changed} quoted output(s) rewritten, {beyond} of them beyond the stable "
          "digits (see git diff)", file=sys.stderr)
    return 0


# --- which digits are stable ------------------------------------------------------------------------------
#
# The outputs are deterministic (seeded) on one machine, but not bit for bit across CPUs and numpy,
# scipy, C compiler, libm or BLAS versions: sums, matrix products and library solvers round differently in the
# last bits. Where the simulated joint sticks and slips, such a difference decides whether a velocity
# reversal breaks away a period earlier or later, and the run goes its own way from there: the rows of
# a `compare` table whose compensation leaves stick-slip (none, fixed, canudas). The README once quoted
# canudas max 8.3415 deg/s where another machine printed 8.6843.
#
# Evidence (numpy 2.4, scipy 1.17, numba 0.68): the quoted commands re-run with the
# `paper` preset's J, Fc, Fs, sigma, tau moved by k*2**-48 relative, k = 0..5, and `compare` on 52
# plants (the `paper` preset and the page's my_joint.json, parameters moved by a few units in the last
# place; a numba build for a generic CPU printed the native digits). Full range over these runs:
#   none      RMS 0.4 %, max 0.13 %, reversal RMS 0.7 %, u RMS 0.1 %
#   canudas   RMS 1.4 %, max 12 %, reversal RMS 1.4 %, u RMS 0.1 %, eta 0.009
#   fixed     RMS 3.3 %, max 59 % (one stick-slip peak), reversal RMS 2.9 %, u RMS 0.4 %, eta 0.007
#   adaptive  RMS 0.06 %, max 0.5 %, reversal RMS 0.2 %, u RMS 0.07 %; adaptive-dob, dob, oracle,
#             frictionless: the printed digits did not move (eta, which divides by none's RMS, by 0.001)
#   every other quoted number: no move beyond one unit in its last printed place, except the
#   full-precision floats of a JSON file (17 digits; relative 3e-13)
# Each tolerance below is about twice that range. Both pages re-run in a second environment (numpy
# 1.26, scipy 1.11, numba 0.59, python-control 0.10.2, matplotlib 3.8) agreed within the rule: 179 of
# the 190 quoted lines to the character, the others in the compare tables (none RMS -0.4 %, canudas
# max +4.9 %, fixed max -14 %, oracle eta -0.001) and the JSON floats (relative 5e-13).

# The note of the residual switch-in of `adaptive` ("switched in at 5.28 s; ... raised the loop's mean-square
# error ... by 0.17 times the frictionless loop's and 0.00036 times what the friction would raise it by") reports
# the observer's estimate at the moment the test fired: the residual of a joint that sticks at its reversals, as
# sensitive as fixed's max. Evidence (an AMD EPYC machine, numpy 2.4.6, scipy 1.17.1): there the
# page's `identify` printed my_joint.json's J, Fc, ... a few units in the last place from the quoted ones, and
# `compare --plant my_joint.json` printed 0.29 and 0.00062 for the quoted 0.17 and 0.00036; the quoted joint
# with each of J, Fc, Fs, sigma, tau moved by k*2**-48 relative, k = 0..5 (30 runs of the adaptive mode), switched
# in at 5.109-5.279 s with the two ratios 0.165-0.341 and 0.00036-0.00077 (a factor 2.1). The switch-in time is
# allowed 0.4 s, each ratio a factor 3 (the last place's units do not bound either).
SWITCH_IN_NOTE = re.compile(r"^note: \S+: the residual observer \(as in adaptive-dob\) switched in at ")
SWITCH_IN_TOL = (Tol(abs=0.4), Tol(factor=3.0), Tol(factor=3.0))

#: compare table: tolerance per column (RMS, max, reversal RMS, u RMS, eta) of a row
COMPARE_TOL = {
    "none": (Tol(rel=0.01), Tol(rel=0.01), Tol(rel=0.015), Tol(rel=0.005), Tol(abs=0.001)),
    "canudas": (Tol(rel=0.03), Tol(rel=0.25), Tol(rel=0.03), Tol(rel=0.005), Tol(abs=0.02)),
    "fixed": (Tol(rel=0.07), Tol(factor=2.0), Tol(rel=0.06), Tol(rel=0.01), Tol(abs=0.015)),
}
SMOOTH_TOL = (Tol(rel=0.002, units=2), Tol(rel=0.01, units=2), Tol(rel=0.005, units=2), Tol(rel=0.002, units=2),
              Tol(abs=0.003, units=2))
COMPARE_ROW = re.compile(r"^(?P<mode>[a-z][a-z-]*)(\s+-?\d+\.\d+){5}\s*$")
DEFAULT_TOL = Tol(units=2)
FULL_PRECISION_TOL = Tol(rel=1e-9)


def stable_digits(line: str, k: int) -> Tol:
    """The tolerance of the ``k``-th number of a quoted ``line`` (the rule and its evidence: comment above)."""
    m = COMPARE_ROW.match(line)
    if m is not None:
        return COMPARE_TOL.get(m.group("mode"), SMOOTH_TOL)[k]
    if SWITCH_IN_NOTE.match(line) and k < len(SWITCH_IN_TOL):
        return SWITCH_IN_TOL[k]
    number = NUMBER.findall(line)[k]
    if len(re.sub(r"[eE].*|\D", "", number).lstrip("0")) >= 12:
        return FULL_PRECISION_TOL
    return DEFAULT_TOL
