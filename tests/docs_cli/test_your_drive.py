"""docs/your_drive.md runs as written: every command of the page, in page order in an empty folder,
and every output it quotes is what the current code prints (to the digits that are stable across
platforms and package versions: ``doc_commands.stable_digits``).

Refresh the quoted outputs after a change of the code (one command, from the repository root)::

    python -m tests.docs_cli.test_your_drive --update
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # also as ``python -m tests.docs_cli.test_your_drive``

from doc_commands import (ROOT, check_page, parse_page, run_page, stable_digits, timings,  # noqa: E402
                          update_page)

PAGE = ROOT / "docs" / "your_drive.md"


@pytest.fixture(scope="module")
def ran(tmp_path_factory):
    page = run_page(parse_page(PAGE), tmp_path_factory.mktemp("your_drive"))
    print("\n" + timings(page))
    return page


def test_the_page_quotes_the_output_of_its_commands():
    page = parse_page(PAGE)
    quoted = [s for s in page.steps if s.quoted is not None]
    assert len(quoted) >= 10, [s.command for s in quoted]
    assert not page.skipped, page.skipped  # nothing on this page installs anything
    recipe = [s.command for s in page.steps if s.kind == "bash"]
    for step in ("adaptive-ff paper-figures", "adaptive-ff stribeck", "adaptive-ff identify", "adaptive-ff design",
                 "adaptive-ff compare --from id.json"):
        assert any(c.startswith(step) for c in recipe), step


def test_every_command_prints_what_the_page_quotes(ran):
    bad = check_page(ran, stable_digits)
    assert not bad, ("docs/your_drive.md quotes outputs the commands no longer print; refresh them with "
                     "python -m tests.docs_cli.test_your_drive --update\n\n" + "\n\n".join(bad))


def test_the_commands_make_what_the_page_says(ran):
    for f in ("out/paper/controller_log.csv", "out/paper/robot_log.csv", "out/stribeck/fig08_stribeck.png",
              "id.json", "out/design/bode.png", "my_joint.json", "out/compare/report.html", "out/id/report.html",
              "out/id_robot/report.html", "out/design_j4/step.png"):
        assert (ran.folder / f).is_file(), f
    failing = {s.command.split()[2]: s.returncode for s in ran.steps
               if s.command.startswith("adaptive-ff identify") and s.returncode != 0}
    assert failing == {"bad_log.csv": 2, "out/paper/robot_log.csv": 2}, failing  # the two bad files of step 1
    refused = next(s for s in ran.steps if s.command.startswith("adaptive-ff design --from id_robot.json"))
    assert refused.printed.rstrip().endswith("exit 3"), refused.printed


def test_the_plant_file_is_the_identification(ran):
    """my_joint.json holds the sliding-regime estimate of id.json and the pre-fit's Vs, delta (as step 5 says), and
    ``compare --from id.json`` runs the PI of ``design --from id.json`` (design.json), printed per degree."""
    plant = json.loads((ran.folder / "my_joint.json").read_text(encoding="utf-8"))
    ident = json.loads((ran.folder / "id.json").read_text(encoding="utf-8"))
    design = json.loads((ran.folder / "design.json").read_text(encoding="utf-8"))
    compare = next(s for s in ran.steps if s.command.startswith("adaptive-ff compare --from id.json --report"))
    deg = math.pi / 180.0
    assert f"PI: Kp = {design['Kp'] * deg:.6g} N·m·s/deg, Ki = {design['Ki'] * deg:.6g} N·m/deg" in compare.printed
    assert design["J"] == ident["J"] and design["sigma"] == ident["sigma"]
    assert plant == {**{k: ident[k] for k in ("J", "Fc", "Fs", "sigma", "tau")},
                     "Vs": 0.0197756, "delta": 1.01582}
    # the demonstration logs are the paper preset's: the page says the fit is within 2.3 % of it
    truth = {"J": 4.0, "Fc": 25.0, "Fs": 35.0, "sigma": 40.0, "tau": 0.02}
    for k, v in truth.items():
        assert plant[k] == pytest.approx(v, rel=0.025), (k, plant[k])


if __name__ == "__main__":
    if sys.argv[1:] != ["--update"]:
        print("usage: python -m tests.docs_cli.test_your_drive --update", file=sys.stderr)
        sys.exit(2)
    sys.exit(update_page(PAGE))
