"""The documentation builds without a warning, documents every public name, and its gallery script
makes the README's and Getting started's figures.

The build runs Sphinx on a copy of ``docs/`` in a temporary folder, beside links to the rest of the
checkout (nothing is written into the checkout), with ``-W --keep-going``; the gallery is rendered without running the scripts
(``ADAPTIVE_FF_DOCS_PLOT_GALLERY=0``), the figure script runs once on its own below.
"""

from __future__ import annotations

import importlib
import os
import re
import shutil
import subprocess
import sys
from html import unescape
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
PACKAGES = ("plant", "adaptive_ff", "controllers")


def _env(**extra) -> dict:
    env = {**os.environ, "MPLBACKEND": "Agg", **extra}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    return env


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """Build the site once for this module; returns the HTML output folder."""
    pytest.importorskip("sphinx", reason="documentation tools not installed: pip install -e '.[docs]'")
    for extra in ("numpydoc", "myst_parser", "sphinx_gallery"):
        pytest.importorskip(extra, reason="documentation tools not installed: pip install -e '.[docs]'")
    tmp = tmp_path_factory.mktemp("docs")
    # docs/ is copied, everything beside it linked, so that links such as ../examples/x.py resolve
    for entry in ROOT.iterdir():
        if entry.name not in ("docs", ".git") and not entry.name.startswith(".venv"):
            (tmp / entry.name).symlink_to(entry, target_is_directory=entry.is_dir())
    src, out = tmp / "docs", tmp / "_html"
    shutil.copytree(DOCS, src, ignore=shutil.ignore_patterns("_build", "api", "auto_examples", "_gallery_src",
                                                             "sg_execution_times.rst", "__pycache__"))
    r = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
                        str(src), str(out)], cwd=tmp, capture_output=True, text=True, timeout=1800,
                       env=_env(ADAPTIVE_FF_DOCS_ROOT=str(ROOT), ADAPTIVE_FF_DOCS_PLOT_GALLERY="0"))
    assert r.returncode == 0, f"Sphinx build failed or warned:\n{r.stderr[-6000:]}"
    assert "WARNING" not in r.stderr and "ERROR" not in r.stderr, r.stderr[-6000:]
    return out


def test_site_builds_without_warnings_with_every_page(site):
    for page in ("index", "getting_started", "your_drive", "theory", "api", "benchmarks/index",
                 "auto_examples/index", "auto_examples/plot_compare_modes"):
        assert (site / f"{page}.html").exists(), page
    for md in sorted((DOCS / "benchmarks").glob("*.md")):  # every benchmark page is in the site
        assert (site / "benchmarks" / f"{md.stem}.html").exists(), md.name
    index = (site / "index.html").read_text(encoding="utf-8")
    for page in ("getting_started", "your_drive", "theory", "benchmarks/index", "api"):
        assert f'href="{page}.html"' in index, page  # every topic one click from the start page
    pages = [md.relative_to(DOCS).with_suffix("").as_posix() for md in DOCS.rglob("*.md")
             if not any(part.startswith(("_", ".")) or part == "auto_examples" for part in md.relative_to(DOCS).parts)]
    unlinked = [page for page in pages if page != "index" and f'href="{page}.html"' not in index]
    assert not unlinked, f"pages not linked from the start page: {unlinked}"


def test_every_public_name_is_documented(site):
    pages = {p.name for p in (site / "api" / "generated").glob("*.html")}
    missing = []
    for package in PACKAGES:
        mod = importlib.import_module(package)
        for name in mod.__all__:
            home = (getattr(getattr(mod, name), "__module__", None) or package).split(".")[0]
            owner = home if home in PACKAGES else package  # a re-export is documented where it is defined
            # a class or function gets <package>.<name>.html, a constant <defining module>.<name>.html
            if not any(page.startswith(owner + ".") and page.endswith(f".{name}.html") for page in pages):
                missing.append(f"{package}.{name}")
    assert not missing, f"public names without an API page: {missing}"


def test_theory_page_has_the_erratum(site):
    html = (site / "theory.html").read_text(encoding="utf-8")
    text = " ".join(unescape(re.sub(r"<[^>]+>", "", html)).split())
    for fragment in ("(2*J*tau + J*Ts)/D", "(Ts^2 + tau*Ts)/D", "tau*Ts/D", "1 - a1 + a2 = sigma*Ts^2/D"):
        assert fragment in text, fragment


def test_gallery_script_makes_the_readme_and_docs_figures(tmp_path):
    """The gallery script writes the figures the README and Getting started show, the same files as committed."""
    from PIL import Image

    r = subprocess.run([sys.executable, str(ROOT / "examples" / "plot_compare_modes.py"), str(tmp_path)],
                       cwd=tmp_path, capture_output=True, text=True, timeout=1800, env=_env())
    assert r.returncode == 0, r.stdout + r.stderr
    made = sorted(p.name for p in tmp_path.glob("*.png"))
    assert made == ["compare_error.png", "compare_eta.png", "compare_friction.png", "compare_rls_convergence.png",
                    "reversal.png"]
    shown = set(re.findall(r"_static/([\w.]+\.png)", (DOCS / "getting_started.md").read_text(encoding="utf-8")))
    assert shown == set(made)  # Getting started shows every figure the script makes
    for name in made:  # the committed figures are what the script draws now (same size in pixels)
        assert (tmp_path / name).stat().st_size > 10_000, name
        with Image.open(tmp_path / name) as new, Image.open(DOCS / "_static" / name) as committed:
            assert new.size == committed.size, name
    rows = {ln.split()[0]: ln.split() for ln in r.stdout.splitlines() if ln.strip()}
    col = 5  # mode, RMS, max, reversal RMS, u RMS, eta (second half), eta full, dev, t_on
    assert rows["none"][col] == "0.000" and rows["frictionless"][col] == "1.000"  # eta by definition
    assert float(rows["adaptive"][col]) > 0.9  # the figure shows what the README says it shows
