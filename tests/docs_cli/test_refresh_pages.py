"""``benchmarks/refresh_pages.py`` finds the measured sections of the benchmark pages and rewrites exactly their
output and their ``Measured at`` paragraph's commit, date and wall time."""

from __future__ import annotations

import tempfile
from pathlib import Path

from benchmarks import refresh_pages as rp

PAGE = """# A page

Text before.

```bash
python -c "print('alpha 1.5'); print('beta 2')"
```

Measured at commit `abcdef0` on 2026-01-02 (2-core machine; 99 s wall). The columns
are what they are.

```
alpha 1.0
```

## Two commands

```bash
python -c "print(1)"
python -c "print(2)"
```

Measured at commit `abcdef0` on 2026-01-02 (old):

```
1
```

## Marked

```bash
python -c "print('| a |'); print('|---|')"
```

Measured at commit `abcdef0` on 2026-01-02 (3 min wall):

<!-- output -->
| old |
<!-- end output -->

Text after.
"""


def refreshed(text: str) -> tuple[str, int]:
    with tempfile.TemporaryDirectory() as tmp:
        page = Path(tmp) / "page.md"
        page.write_text(text, encoding="utf-8")
        env = rp.environment(Path(tmp))
        failed = rp.refresh(page, env, commit="1234567", dirty=False, date="2026-11-26")
        return page.read_text(encoding="utf-8"), failed


def test_sections_are_found_with_their_commands_and_forms(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(PAGE, encoding="utf-8")
    found = rp.sections(page)
    assert [(s.line, s.refreshable, s.form) for s in found] == [(5, True, "fenced"), (18, False, "fenced"),
                                                                 (31, True, "marked")]
    assert found[0].commands == ["python -c \"print('alpha 1.5'); print('beta 2')\""]


def test_a_refresh_rewrites_the_output_and_the_commit_date_and_wall_time_only():
    new, failed = refreshed(PAGE)
    assert failed == 0
    assert "alpha 1.5\nbeta 2\n```" in new and "alpha 1.0" not in new
    assert "Measured at commit `1234567` on 2026-11-26 (2-core machine; 0 s wall). The columns\nare what they are." in new
    assert "Measured at commit `abcdef0` on 2026-01-02 (old):\n\n```\n1\n```" in new  # two commands: untouched
    assert "<!-- output -->\n| a |\n|---|\n<!-- end output -->\n\nText after.\n" in new
    assert "Measured at commit `1234567` on 2026-11-26 (0 min wall):" in new
    assert new.startswith("# A page\n\nText before.\n")
    again, _ = refreshed(new)
    assert again == new  # idempotent


def test_only_refreshes_just_the_sections_whose_command_holds_the_text(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(PAGE, encoding="utf-8")
    failed = rp.refresh(page, rp.environment(tmp_path), commit="1234567", dirty=False, date="2026-11-26",
                        only="print('|")
    new = page.read_text(encoding="utf-8")
    assert failed == 0
    assert "<!-- output -->\n| a |\n|---|\n<!-- end output -->" in new  # the marked section: its command holds it
    assert "alpha 1.0" in new and "alpha 1.5\nbeta 2\n```" not in new  # the first section: left as it was
    assert new.count("`1234567`") == 1


def test_a_failing_command_leaves_its_section_and_is_counted():
    bad = PAGE.replace("print('alpha 1.5'); print('beta 2')", "import sys; sys.exit(3)")
    new, failed = refreshed(bad)
    assert failed == 1
    assert "Measured at commit `abcdef0` on 2026-01-02 (2-core machine; 99 s wall)" in new
    assert "<!-- output -->\n| a |\n" in new  # the other section still refreshed


def test_the_benchmark_pages_have_refreshable_sections():
    pages = {p.name: rp.sections(p) for p in rp.PAGES.glob("*.md")}
    refreshable = {name for name, found in pages.items() if any(s.refreshable for s in found)}
    assert {"tracking.md", "variants.md", "scenarios.md", "prefit.md", "emps.md", "online_ukf.md",
            "paper_figures.md", "compensation.md", "figures.md"} <= refreshable, sorted(refreshable)


def test_the_commands_run_in_a_folder_that_looks_like_the_root_and_write_nothing_into_the_checkout(tmp_path):
    work = rp.work_folder(tmp_path)
    assert (work / "benchmarks" / "refresh_pages.py").is_file() and not (work / ".git").exists()
    code, printed, _ = rp.run("python -c \"open('left_behind.txt', 'w').write('x'); print('ok')\"",
                              rp.environment(tmp_path), work)
    assert (code, printed) == (0, "ok\n")
    assert (work / "left_behind.txt").is_file() and not (rp.ROOT / "left_behind.txt").exists()
