"""docs/getting_started.md quotes what its measuring commands print now: every command of the page whose output the
page quotes (``python -m benchmarks.getting_started``, ``python -m benchmarks.encoder_velocity``, the controller
design example), run from the repository root, against the quoted output to the stable digits
(``doc_commands.stable_digits``).

Refresh the quoted outputs after a change of the code (one command, from the repository root)::

    python -m tests.docs_cli.test_getting_started --update
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # also as ``python -m tests.docs_cli.test_getting_started``

from doc_commands import ROOT, check_page, environment, parse_page, stable_digits, updated_text  # noqa: E402

PAGE = ROOT / "docs" / "getting_started.md"


def run_quoted(folder: Path):
    """The page with only its quoted commands, each run from the repository root (they read ``examples/``)."""
    page = parse_page(PAGE)
    page.steps = [s for s in page.steps if s.quoted is not None]
    env = environment(folder / "bin")
    for step in page.steps:
        r = subprocess.run(["bash", "-c", step.command], cwd=ROOT, env=env, stdout=subprocess.PIPE,
                           stderr=subprocess.STDOUT, text=True, timeout=900)
        step.printed, step.returncode = r.stdout, r.returncode
        assert r.returncode == 0, f"{PAGE.name}:{step.line}: $ {step.command}\n{r.stdout}"
    return page


def test_the_page_quotes_its_measurements():
    quoted = [s.command for s in parse_page(PAGE).steps if s.quoted is not None]
    assert quoted == ["python -m benchmarks.getting_started", "python -m benchmarks.encoder_velocity",
                      "python examples/controller_design.py --J 4 --crossovers 10 20 40 80"], quoted


def test_the_quoted_scenario_error_is_what_a_bad_file_gets(tmp_path, monkeypatch):
    """The page's example of a wrong scenario file's error: an encoder of 0 counts in a copy of an example."""
    import re

    from controllers.experiments.scenario import ScenarioError, load_scenario

    quoted = re.search(r"`(robot\.toml: \[sensor\] encoder_counts [^`]*)`", PAGE.read_text(encoding="utf-8")).group(1)
    text = (ROOT / "examples" / "scenarios" / "linear_axis.toml").read_text(encoding="utf-8")
    text, n = re.subn(r"(?m)^\[sensor\]$", "[sensor]\nencoder_counts = 0", text)
    assert n == 1
    (tmp_path / "robot.toml").write_text(text, encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ScenarioError) as e:
        load_scenario("robot.toml")
    assert str(e.value) == quoted


@pytest.mark.slow
def test_every_quoted_output_is_what_the_command_prints(tmp_path):
    bad = check_page(run_quoted(tmp_path), stable_digits)
    assert not bad, ("docs/getting_started.md quotes outputs the commands no longer print; refresh them with "
                     "python -m tests.docs_cli.test_getting_started --update\n\n" + "\n\n".join(bad))


if __name__ == "__main__" and "--update" in sys.argv:
    with tempfile.TemporaryDirectory() as tmp:
        text, changed = updated_text(run_quoted(Path(tmp)))
    PAGE.write_text(text, encoding="utf-8")
    print(f"{PAGE.relative_to(ROOT)}: {changed} quoted output(s) rewritten (see git diff)", file=sys.stderr)
