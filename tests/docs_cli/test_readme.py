"""The README tells the truth: its commands run as written in an empty folder, the main job's quoted
output is what the command prints (to the digits that are stable across platforms and package
versions: ``doc_commands.stable_digits``), the Python example runs, the links resolve, and the file
stays short (at most 12 KB).

Refresh the quoted output after a change of the main job (one command, from the repository root)::

    python -m tests.docs_cli.test_readme --update
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # also as ``python -m tests.docs_cli.test_readme``

from doc_commands import (ROOT, Tol, check_page, mismatches, parse_page, run_page, stable_digits,  # noqa: E402
                          timings, update_page)

README = ROOT / "README.md"
EXAMPLE = re.compile(r"<!-- readme-example: .*?-->\n```python\n(?P<code>.*?)```\n", re.S)
MAX_BYTES = 12 * 1024


def _env() -> dict:
    env = {**os.environ, "MPLBACKEND": "Agg"}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    return env


@pytest.fixture(scope="module")
def ran(tmp_path_factory):
    """The README's commands, run in page order in an empty folder."""
    page = run_page(parse_page(README), tmp_path_factory.mktemp("readme"))
    print("\n" + timings(page))
    return page


def test_readme_is_short():
    size = len(README.read_bytes())
    assert size <= MAX_BYTES, f"README.md is {size} bytes (at most {MAX_BYTES}): move detail into docs/"


def test_commands_are_found_and_setup_lines_skipped():
    page = parse_page(README)
    assert [s.command for s in page.steps][0] == "adaptive-ff compare"  # the quick start, less its pip lines
    assert len(page.skipped) == 2, page.skipped  # the venv/pip install line and the test run
    main_job = page.steps[0]
    assert main_job.quoted is not None and "mode" in main_job.quoted


def test_main_job_output_is_what_the_command_prints(ran):
    bad = check_page(ran, stable_digits)
    assert not bad, ("the README's main-job output differs from what the command prints; refresh it with: "
                     "python -m tests.docs_cli.test_readme --update\n\n" + "\n\n".join(bad))
    assert (ran.folder / "out" / "tracking.png").is_file()


def test_your_drive_block_runs_in_an_empty_folder(ran):
    """The 'Your drive in ten lines' block writes every file it reads (id.json) itself, and its comparison runs the
    identified joint with the PI that its design step printed."""
    for f in ("out/paper/controller_log.csv", "out/stribeck/report.html", "id.json", "out/design/report.html",
              "out/compare/report.html"):
        assert (ran.folder / f).is_file(), f
    ident = json.loads((ran.folder / "id.json").read_text(encoding="utf-8"))
    compare = ran.steps[-1]
    assert compare.command.startswith("adaptive-ff compare --from id.json")
    assert f"plant: the joint identified in id.json: model=lagged-stribeck, J={ident['J']:g} kg·m²" in compare.printed
    design = next(s for s in ran.steps if s.command.startswith("adaptive-ff design --from id.json"))
    gains = re.search(r"PI: Kp = \S+ N·m·s/deg, Ki = \S+ N·m/deg", design.printed).group(0)
    assert gains in compare.printed


def test_the_comparison_tells_stable_digits_from_a_wrong_number():
    """The rule of ``stable_digits`` passes the spread seen across platforms and fails a real change."""
    quoted = ("Stribeck pre-fit (Sec. V-C): Vs=0.02004 rad/s, delta=1.002\n"
              "none                 2.8990       10.1503                 2.2575        26.45    0.000\n"
              "fixed                0.5120        1.3438                 0.4925        29.45    1.000\n"
              "adaptive             0.5162        1.2005                 0.5040        29.47    0.999\n"
              "canudas              1.8763        8.3415                 2.7847        28.78    0.429\n"
              '{"J": 4.091543591653956, "Fc": 25.047089315261}\n')
    # the other machine's canudas max, fixed's max at the other end of its range, last digits moved
    ok = (quoted.replace("8.3415", "8.6843").replace("1.3438", "2.1057").replace("2.8990", "2.9100")
          .replace("1.2005", "1.2052").replace("0.02004", "0.02005").replace("653956", "653938"))
    assert mismatches(quoted, ok, stable_digits) == []
    for wrong in (quoted.replace("0.5162", "0.5262"),  # adaptive RMS +2 %
                  quoted.replace("delta=1.002", "delta=1.012"),  # the pre-fit moved
                  quoted.replace("2.8990", "2.9990"),  # no compensation 3 % worse
                  quoted.replace("8.3415", "11.3415"),  # canudas peak +36 %
                  quoted.replace("1.3438", "2.8159"),  # fixed peak doubled
                  quoted.replace("0.999", "0.989"),  # adaptive eta -0.01
                  quoted.replace("4.091543591653956", "4.0915436"),  # a JSON float cut short
                  quoted.replace("Vs=", "Vs:")):  # text
        assert len(mismatches(quoted, wrong, stable_digits)) == 1, wrong
    assert mismatches(quoted, quoted + "x\n", stable_digits) == ["7 lines printed, 6 quoted"]
    # the switch-in note: its time and ratios within the spread of k*2**-48 moves of the joint (doc_commands), not
    # a switch-in seconds later or a residual five times larger
    note = ("note: adaptive: the residual observer (as in adaptive-dob) switched in at 5.28 s; what the feedforward "
            "leaves raised the loop's mean-square error, as its model predicts, by 0.17 times the frictionless "
            "loop's and 0.00036 times what the friction would raise it by\n")
    assert mismatches(note, note.replace("5.28", "5.11").replace("0.17", "0.34").replace("0.00036", "0.00077"),
                      stable_digits) == []
    for wrong in (note.replace("5.28", "6.28"), note.replace("0.17", "0.85"), note.replace("0.00036", "0.0018")):
        assert len(mismatches(note, wrong, stable_digits)) == 1, wrong
    assert Tol(units=2).allows("0.5120", "0.5122") and not Tol(units=2).allows("0.5120", "0.5123")
    assert not Tol(units=2).allows("4", "5")  # integers are exact


def test_the_runner_runs_pages_as_written(tmp_path):
    """A synthetic page: the install line is skipped, files carry over between commands, a quoted output
    that the command does not print is reported, and a failing recipe line stops the page."""
    page_md = tmp_path / "page.md"
    page_md.write_text("```bash\npip install -e . && printf '1.25\\n' > x.txt   # make x\n```\n\n"
                       "```\n$ cat x.txt\n1.25\n$ cat x.txt; echo \"exit $?\"\n1.28\nexit 0\n```\n",
                       encoding="utf-8")
    page = run_page(parse_page(page_md), tmp_path / "run")
    assert [s.command for s in page.steps] == ["printf '1.25\\n' > x.txt   # make x", "cat x.txt",
                                               'cat x.txt; echo "exit $?"']
    assert page.skipped and page.steps[1].printed == "1.25\n"
    assert check_page(page, stable_digits) == [
        'page.md:8: $ cat x.txt; echo "exit $?"\nline 1, number 1: printed 1.25, quoted 1.28 (allowed: '
        'Tol(rel=0.0, units=2, abs=0.0, factor=0.0)):\n  1.25']
    page_md.write_text("```bash\ncat my_joint.json\necho never\n```\n", encoding="utf-8")
    with pytest.raises(AssertionError, match=r"(?s)page.md:2: command failed \(exit 1\).*cat my_joint.json"):
        run_page(parse_page(page_md), tmp_path / "run2")


def test_python_example_runs(tmp_path):
    text = README.read_text(encoding="utf-8")
    m = EXAMPLE.search(text)
    assert m is not None, "README: no '<!-- readme-example: ... -->' Python block"
    code = m.group("code")
    assert len(code.strip().splitlines()) <= 10
    script = tmp_path / "example.py"
    script.write_text(code, encoding="utf-8")
    r = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True,
                       env=_env(), timeout=1800)
    assert r.returncode == 0, r.stdout + r.stderr
    last = r.stdout.strip().splitlines()[-1]
    assert re.fullmatch(r"adaptive: RMS \d+\.\d{4} rad/s, eta -?\d+\.\d{2}", last), last
    assert "frictionless" in r.stdout and "adaptive" in r.stdout


def test_a_newcomer_reads_it_in_two_minutes():
    """At most 700 words outside code blocks (about two minutes at a reading pace of 350 words a minute)."""
    text = re.sub(r"```.*?```", "", README.read_text(encoding="utf-8"), flags=re.S)
    assert len(text.split()) <= 700, len(text.split())


def test_your_drive_recipe_is_ten_lines():
    text = README.read_text(encoding="utf-8")
    m = re.search(r"## Your drive in ten lines\n\n```bash\n(?P<body>.*?)```", text, re.S)
    assert m is not None, "README: no '## Your drive in ten lines' bash block"
    lines = m.group("body").strip().splitlines()
    assert 4 <= len(lines) <= 10, len(lines)
    for step in ("adaptive-ff stribeck", "adaptive-ff identify", "adaptive-ff design",
                 "adaptive-ff compare --from id.json"):
        assert any(ln.startswith(step) for ln in lines), step


def test_links_and_figure_exist():
    text = README.read_text(encoding="utf-8")
    targets = re.findall(r"\]\(([^)#\s]+)\)", text)
    local = [t for t in targets if "://" not in t]
    assert local, "README links nowhere"
    missing = [t for t in local if not (ROOT / t).exists()]
    assert not missing, f"README links to missing files: {missing}"
    assert "docs/_static/reversal.png" in local
    assert (ROOT / "LICENSE").read_text(encoding="utf-8").startswith("BSD 3-Clause License")


def _links(path: Path) -> set[Path]:
    """The local files a Markdown file links to (``[text](target)``, anchors and URLs dropped)."""
    text = path.read_text(encoding="utf-8")
    text = re.sub(r"```.*?```", "", text, flags=re.S)  # links inside code blocks are not links
    out = set()
    for target in re.findall(r"\]\(([^)\s]+)\)", text):
        target = target.split("#")[0]
        if target and "://" not in target:
            out.add((path.parent / target).resolve())
    return out


def test_every_docs_page_is_two_clicks_from_the_readme():
    """A newcomer reaches any topic of the docs from the README within two clicks (as the
    pages render on a code host: Markdown links only, no Sphinx toctrees or roles)."""
    first = _links(README)
    broken = [str(t.relative_to(ROOT)) for t in first if not t.exists()]
    second = set(first)
    for page in first:
        if page.suffix == ".md" and page.exists():
            links = _links(page)
            broken += [f"{page.relative_to(ROOT)} -> {t}" for t in links if not t.exists()]
            second |= links
    assert not broken, f"links to missing files: {broken}"
    pages = {p.resolve() for p in (ROOT / "docs").rglob("*.md")
             if not any(part.startswith(("_", ".")) or part == "auto_examples" for part in p.relative_to(ROOT / "docs").parts)}
    pages.add((ROOT / "docs" / "api.rst").resolve())
    missing = sorted(str(p.relative_to(ROOT)) for p in pages - second)
    assert not missing, (f"docs pages more than two clicks from the README: {missing}; link them from the README "
                         "or from docs/benchmarks/index.md")


if __name__ == "__main__":
    if sys.argv[1:] != ["--update"]:
        print("usage: python -m tests.docs_cli.test_readme --update", file=sys.stderr)
        sys.exit(2)
    sys.exit(update_page(README))
