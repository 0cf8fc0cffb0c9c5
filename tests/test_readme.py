"""The README tells the truth: the main job's quoted output is what the command prints, the Python
example runs, the links resolve, and the file stays short (issue 13 item 2: at most 12 KB).

Refresh the quoted output after a change of the main job (one command, from the repository root)::

    python -m tests.test_readme --update
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
OUTPUT_START = re.compile(r"<!-- main-job-output: adaptive-ff (?P<args>[^(]*?) \(.*?-->\n```\n")
OUTPUT_END = "```\n<!-- /main-job-output -->"
EXAMPLE = re.compile(r"<!-- readme-example: .*?-->\n```python\n(?P<code>.*?)```\n", re.S)
MAX_BYTES = 12 * 1024


def _env() -> dict:
    env = {**os.environ, "MPLBACKEND": "Agg"}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    return env


def quoted_output(text: str) -> tuple[list[str], str, int, int]:
    """The quoted main job of the README: (command arguments, output, start, end offsets)."""
    m = OUTPUT_START.search(text)
    if m is None:
        raise AssertionError("README: no '<!-- main-job-output: adaptive-ff ... -->' block")
    end = text.index(OUTPUT_END, m.end())
    return m.group("args").split(), text[m.end():end], m.end(), end


def run_main_job(args: list[str], cwd: Path) -> str:
    """Run ``adaptive-ff ARGS`` (this checkout's code) in ``cwd``; return its standard output."""
    code = "import sys; from controllers.cli import main; sys.exit(main(sys.argv[1:]))"
    r = subprocess.run([sys.executable, "-c", code, *args], cwd=cwd, capture_output=True, text=True,
                       env=_env(), timeout=1800)
    if r.returncode != 0:
        raise AssertionError(f"adaptive-ff {' '.join(args)} failed ({r.returncode}):\n{r.stdout}\n{r.stderr}")
    return r.stdout


def test_readme_is_short():
    size = len(README.read_bytes())
    assert size <= MAX_BYTES, f"README.md is {size} bytes (at most {MAX_BYTES}): move detail into docs/"


def test_main_job_output_is_quoted_verbatim(tmp_path):
    text = README.read_text(encoding="utf-8")
    args, quoted, _, _ = quoted_output(text)
    assert args[:1] == ["compare"], args
    printed = run_main_job(args, tmp_path)
    assert printed == quoted, ("the README's main-job output differs from what the command prints; "
                               "refresh it with: python -m tests.test_readme --update")
    assert (tmp_path / "out" / "tracking.png").exists()


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


def test_your_drive_recipe_is_ten_lines():
    text = README.read_text(encoding="utf-8")
    m = re.search(r"## Your drive in ten lines\n\n```bash\n(?P<body>.*?)```", text, re.S)
    assert m is not None, "README: no '## Your drive in ten lines' bash block"
    lines = m.group("body").strip().splitlines()
    assert 4 <= len(lines) <= 10, len(lines)
    for step in ("adaptive-ff stribeck", "adaptive-ff identify", "adaptive-ff design", "adaptive-ff compare"):
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
    """Issue 13: a newcomer reaches any topic of the docs from the README within two clicks (as the
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


def update() -> int:
    """Rewrite the README's quoted main-job output with what the command prints now."""
    import tempfile

    text = README.read_text(encoding="utf-8")
    args, quoted, start, end = quoted_output(text)
    with tempfile.TemporaryDirectory() as tmp:
        printed = run_main_job(args, Path(tmp))
    if printed == quoted:
        print("README.md: main-job output already current")
        return 0
    README.write_text(text[:start] + printed + text[end:], encoding="utf-8")
    print(f"README.md: main-job output of 'adaptive-ff {' '.join(args)}' refreshed")
    return 0


if __name__ == "__main__":
    if sys.argv[1:] != ["--update"]:
        print("usage: python -m tests.test_readme --update", file=sys.stderr)
        sys.exit(2)
    sys.exit(update())
