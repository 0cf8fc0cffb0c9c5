"""docs/your_arm.md runs as written: its Python block (the simulated planar arm's log ``arm_log.csv`` and its plant
file), then every command of the page, in page order in an empty folder (with ``examples/`` of the repository, as a
reader in the repository root has it), and every output it quotes is what the current code prints, to the digits
:func:`stable_digits_arm` states.

Refresh the quoted outputs after a change of the code (one command, from the repository root)::

    python -m tests.docs_cli.test_your_arm --update
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # also as ``python -m tests.docs_cli.test_your_arm``

from doc_commands import (FENCE, ROOT, Step, Tol, check_page, parse_page, run_page, stable_digits,  # noqa: E402
                          timings, update_page)

PAGE = ROOT / "docs" / "your_arm.md"

# Which digits are stable. The page's runs are deterministic on one machine: the simulation, the bootstrap and
# the lag fits are seeded, and tests/conftest.py (``benchmarks.numeric_paths``, also in the commands' environment)
# pins numpy's and OpenBLAS's code paths. Across CPUs and library versions the last bits of sums and solvers move;
# the rule of ``doc_commands.stable_digits`` (two units in the last printed place; compare's table per mode)
# covers the smooth numbers. Evidence (this machine): the simulated friction's Fc, Fs, sigma moved by k*2**-48
# relative (k = 1..3; the log then differs in 11-37 printed digits) and the log's torques moved by k*1e-10
# relative (k = 1..3): identify-arm printed its whole table to the character as quoted, the lag lines too.
# Wider, as a margin for what those runs cannot show:
# * the lag line and its warning (``tau``: an optimiser's stopping point and a bootstrap of 10 partial refits,
#   which another scipy may end elsewhere): 0.2 % of the value (the warning's ms: 0.02 ms), tight enough that the
#   page's stale quote of the shoulder's interval, [0.806, 1.271] ms for the [0.7983, 1.279] printed, fails;
# * compare-arm's per-joint rows: ARM_ROW_TOL (its measurement there);
# * the C example loop's estimator update counts (its stub joint's gate, compiled by another C compiler): 2 %.

# compare-arm's per-joint rows: none, fixed, adaptive, frictionless RMS (deg/s), eta fixed, eta adaptive. Evidence
# (this machine): the plant file's Fc, Fs, sigma moved by k*2**-48 relative (k = 1..5) printed the rows to the
# character as quoted (the sensor noise, not a breakaway's timing, sets these loops' errors). The margin for other
# platforms: 0.2 % of each RMS (compare's smooth rows' rule), and eta what 0.2 % of the mode's RMS moves it by on
# the shoulder (whose none RMS lies 1.0 deg/s above the frictionless one's, the smallest span eta divides by): 0.01.
ARM_ROW_TOL = (Tol(rel=0.002), Tol(rel=0.002), Tol(rel=0.002), Tol(rel=0.002), Tol(abs=0.01), Tol(abs=0.01))
LAG_LINE = re.compile(r"^\s*tau\s+-?\d")
LAG_WARNING = re.compile(r"^\s*WARNING: no friction lag")
ARM_ROW = re.compile(r"^[a-z_0-9]+(\s+-?\d+\.\d+){6}\s*$")
UPDATES = re.compile(r"^joint \w+ after \d+ s: .* \d+ estimator updates$")


def stable_digits_arm(line: str, k: int) -> Tol:
    """The tolerance of the ``k``-th number of a quoted ``line`` of this page (the rule: comment above)."""
    if LAG_LINE.match(line):
        return Tol(rel=0.002, units=2)
    if LAG_WARNING.match(line):
        return Tol(abs=0.02, units=2)
    if ARM_ROW.match(line):
        return ARM_ROW_TOL[k]
    if UPDATES.match(line) and k == len(re.findall(r"\d+", line)) - 1:
        return Tol(rel=0.02)
    return stable_digits(line, k)


def arm_page():
    """The page's steps, after two of the test's own: ``examples/`` linked in, then the page's Python block run;
    without the benchmark scripts (below)."""
    page = parse_page(PAGE)
    # the benchmark scripts of its bash blocks (the 6-axis arm's closed loop: 100 s of CPU) quote no output a
    # command here checks: their tables are the benchmarks' (docs/benchmarks/, benchmarks/refresh_pages.py)
    page.steps = [s for s in page.steps if not (s.kind == "bash" and s.quoted is None
                                                and s.command.startswith("python -m benchmarks."))]
    blocks = [m for m in FENCE.finditer(page.text) if m.group("info").strip() == "python"]
    assert len(blocks) == 1, f"{PAGE.name}: {len(blocks)} python blocks, one expected (the simulated log)"
    body = blocks[0].group("body")
    line = page.text.count("\n", 0, blocks[0].start("body")) + 1
    page.steps[:0] = [Step(command=f"ln -s {ROOT / 'examples'} examples", kind="bash", line=line),
                      Step(command=f"python - <<'PAGE_PYTHON_BLOCK'\n{body}PAGE_PYTHON_BLOCK", kind="bash", line=line)]
    return page


@pytest.fixture(scope="module")
def ran(tmp_path_factory):
    page = run_page(arm_page(), tmp_path_factory.mktemp("your_arm"))
    print("\n" + timings(page))
    return page


def test_the_page_quotes_the_output_of_its_commands():
    page = arm_page()
    quoted = [s.command.split(" > ")[0] for s in page.steps if s.quoted is not None]
    for c in ("adaptive-ff identify-arm arm_log.csv --urdf examples/planar3.urdf", "head -n 8 arm.json",
              "adaptive-ff design --from arm.json --joint elbow --no-figures", "make -s -C arm_ff run",
              "cat planar3_plant.json"):
        assert c in quoted, (c, quoted)
    for c in ("adaptive-ff compare --from arm.json", "adaptive-ff export-c --from arm.json", "adaptive-ff compare-arm"):
        assert any(q.startswith(c) for q in quoted), (c, quoted)
    assert [s.split(": ", 1)[1] for s in page.skipped] == ["\"pip install -e '.[arm]'\" -> ''"], page.skipped


@pytest.mark.slow
def test_every_command_prints_what_the_page_quotes(ran):
    bad = check_page(ran, stable_digits_arm)
    assert not bad, ("docs/your_arm.md quotes outputs the commands no longer print; refresh them with "
                     "python -m tests.docs_cli.test_your_arm --update\n\n" + "\n\n".join(bad))


@pytest.mark.slow
def test_the_commands_make_what_the_page_says(ran):
    for f in ("arm_log.csv", "planar3_plant.json", "arm.json", "elbow_true.json", "arm_ff/aff_config.h",
              "arm_ff/aff_config.c"):
        assert (ran.folder / f).is_file(), f
    # the page's table and its JSON are one identification: the JSON's values printed to the table's digits
    import json

    table = next(s for s in ran.steps if s.command == "adaptive-ff identify-arm arm_log.csv --urdf "
                 "examples/planar3.urdf").printed
    joints = json.loads((ran.folder / "arm.json").read_text(encoding="utf-8"))["joints"]
    assert [j["name"] for j in joints] == ["shoulder", "elbow", "wrist"]
    for j in joints:
        block = table.split(f"joint {j['name']}\n")[1]
        for key in ("J", "Fc", "Fs", "sigma", "offset", "tau"):
            printed = float(re.search(rf"^\s*{key}\s+(\S+)", block, re.M).group(1))
            if j[key] is None:  # null in JSON, nan in the table
                assert printed != printed, (j["name"], key, printed)
            else:
                assert printed == pytest.approx(j[key], rel=1e-4), (j["name"], key, printed, j[key])


def update() -> int:
    """The ``--update`` mode: :func:`doc_commands.update_page` on the page as the tests run it (its Python block
    first), with this page's stable digits; the prose is left as it is: read it against the new outputs (git diff)."""
    return update_page(PAGE, page=arm_page(), digits=stable_digits_arm)


if __name__ == "__main__":
    if sys.argv[1:] != ["--update"]:
        print("usage: python -m tests.docs_cli.test_your_arm --update", file=sys.stderr)
        sys.exit(2)
    sys.exit(update())
