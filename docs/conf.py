"""Sphinx configuration of the adaptive-ff documentation.

Build (from the repository root)::

    pip install -e '.[docs]'
    python -m sphinx -W --keep-going -b html docs docs/_build/html

The API pages (``api/<package>.rst``) are written here at build time from each package's
``__all__``, so every public name is documented without a hand-kept list. The gallery runs the
scripts in ``examples/`` (``ADAPTIVE_FF_DOCS_PLOT_GALLERY=0`` renders them without running, as
``tests/test_docs.py`` does). No network is needed: there is no intersphinx.
"""

from __future__ import annotations

import importlib
import inspect
import logging
import os
import re
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
# The repository root; tests/test_docs.py builds a copy of docs/ elsewhere and points here.
ROOT = Path(os.environ.get("ADAPTIVE_FF_DOCS_ROOT", HERE.parent)).resolve()
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(HERE / "_ext"))  # figure_scraper: the gallery's scraper of pyplot-free figures
os.environ.setdefault("MPLBACKEND", "Agg")

project = "adaptive-ff"
author = "adaptive-ff contributors"
copyright = "2026, adaptive-ff contributors"
try:
    from importlib.metadata import version as _dist_version

    release = _dist_version("adaptive-ff")
except Exception:  # not installed: read it from pyproject  # pragma: no cover
    release = "0.1.0"
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "_gallery_src", "**/README.md", "auto_examples/*.ipynb", "auto_examples/*.py",
                    "auto_examples/*.zip", "auto_examples/*.json", "auto_examples/*.md5"]
templates_path = []
html_theme = "alabaster"
html_static_path = ["_static"]
html_title = f"adaptive-ff {release}"
html_theme_options = {"description": "Sliding-friction identification and adaptive friction feedforward",
                      "page_width": "1100px", "sidebar_width": "240px"}

myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3

autosummary_generate = True
autosummary_imported_members = True
autodoc_default_options = {"members": False}
autodoc_typehints = "none"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_validation_checks: set[str] = set()

nitpicky = False
# Pages that other work adds (docs/cli.md, docs/your_loop.md, docs/benchmarks/*.md) enter the
# toctrees through globs; a glob that matches nothing yet is not an error (the warning carries no
# type to suppress, so it is filtered by its text, for these patterns only).
OPTIONAL_GLOBS = ("cli*", "your_*")

# --- the API pages: one per package, every name of __all__ --------------------------------------
PACKAGES = {
    "plant": "plant — the joint, friction models, sampling and excitation",
    "adaptive_ff": "adaptive_ff — identification, logs and the adaptive feedforward",
    "controllers": "controllers — PI design, closed loop, experiments, peers, reports",
}


def public_names(package: str) -> list[str]:
    """The public names of ``package``: its ``__all__``, in order, without duplicates."""
    mod = importlib.import_module(package)
    seen: list[str] = []
    for name in getattr(mod, "__all__", []):
        if name not in seen:
            seen.append(name)
    return seen


def data_home(package: str, name: str, obj) -> str | None:
    """The module of ``package`` that defines the constant ``name`` with a ``#:`` doc comment, if any."""
    from sphinx.pycode import ModuleAnalyzer

    for modname in sorted(m for m in list(sys.modules) if m.startswith(package + ".")):
        module = sys.modules[modname]
        if getattr(module, "__dict__", {}).get(name) is not obj:
            continue
        try:
            if ("", name) in ModuleAnalyzer.for_module(modname).find_attr_docs():
                return modname
        except Exception:  # no source: try the next module
            continue
    return None


def api_entries(package: str) -> tuple[list[str], list[str], list[tuple[str, str]]]:
    """Autosummary entries of ``package``: (names, fully qualified constants, re-exports (name, home))."""
    mod = importlib.import_module(package)
    names, constants, elsewhere = [], [], []
    for name in public_names(package):
        obj = getattr(mod, name)
        home = getattr(obj, "__module__", None)
        if home is None or not (inspect.isclass(obj) or callable(obj) or inspect.ismodule(obj)):
            defining = data_home(package, name, obj)
            (constants.append(f"{defining}.{name}") if defining else names.append(name))
        elif home.split(".")[0] in PACKAGES and home.split(".")[0] != package:
            elsewhere.append((name, home.split(".")[0]))
        else:
            names.append(name)
    return names, constants, elsewhere


def write_api_pages(outdir: Path = HERE / "api") -> None:
    """Write ``api/<package>.rst`` (an autosummary table of every public name) for each package."""
    outdir.mkdir(exist_ok=True)
    table = [".. autosummary::", "   :toctree: generated", "   :nosignatures:", ""]
    for package, title in PACKAGES.items():
        names, constants, elsewhere = api_entries(package)
        lines = [title, "=" * len(title), "", f".. automodule:: {package}", "   :no-members:", "",
                 f".. currentmodule:: {package}", "", *table]
        lines += [f"   {name}" for name in names]
        if constants:
            lines += ["", "Constants (documented in the module that defines them):", "", *table]
            lines += [f"   {target[len(package) + 1:]}" for target in constants]  # relative to the package
        if elsewhere:
            lines += ["", "Also exported here, documented where they are defined: "
                      + ", ".join(f":obj:`{root}.{name}`" for name, root in elsewhere) + "."]
        text = "\n".join(lines) + "\n"
        path = outdir / f"{package}.rst"
        if not path.exists() or path.read_text(encoding="utf-8") != text:
            path.write_text(text, encoding="utf-8")


write_api_pages()

# --- the examples gallery ---------------------------------------------------------------------
GALLERY_SRC = HERE / "_gallery_src"


def copy_examples(src: Path = ROOT / "examples", dst: Path = GALLERY_SRC) -> None:
    """Copy ``examples/`` for sphinx-gallery, underlining each script's first docstring line.

    sphinx-gallery takes an example's title from a reStructuredText title at the top of its
    docstring; the scripts start with a one-line summary, which this underlines where the script
    does not already (the scripts themselves stay plain Python).
    """
    import shutil

    shutil.rmtree(dst, ignore_errors=True)
    shutil.copytree(src, dst, ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "out"))
    for script in dst.glob("*.py"):
        text = script.read_text(encoding="utf-8")
        m = re.match(r'(?P<pre>\s*[rRuU]?(?P<q>"""|\'\'\'))(?P<title>[^\n]+)\n(?P<next>[^\n]*)', text)
        if m is None or set(m.group("next").strip()) == {"="}:
            continue
        title = m.group("title").strip()
        head = f"{m.group('pre')}{title}\n{'=' * len(title)}\n"
        script.write_text(head + ("\n" if m.group("next").strip() else "") + text[m.end("title") + 1:],
                          encoding="utf-8")


copy_examples()
_plot_gallery = os.environ.get("ADAPTIVE_FF_DOCS_PLOT_GALLERY", "1") not in ("0", "false", "False")
sphinx_gallery_conf = {
    "examples_dirs": "_gallery_src",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",          # run the plot_*.py scripts; the others are shown as code
    "ignore_pattern": r"__init__\.py|test_[^/\\]*\.py$",  # pytest files are not gallery scripts
    "plot_gallery": _plot_gallery,
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "abort_on_example_error": True,
    "show_signature": False,
    "write_computation_times": False,
    # the package's figures are pyplot-free Figure objects: see docs/_ext/figure_scraper.py
    "image_scrapers": ("matplotlib", "figure_scraper.pyplot_free_figures"),
}


# --- docstrings: plain-text |x| is an absolute value, not a substitution ------------------------
_LITERAL = re.compile(r"(``.*?``|:[a-z]+:`[^`]*`|`[^`]*`_?)")
_TABLE = re.compile(r"^\+[-=+]+\+$")
_BARS = re.compile(r"(?<![\\|\w])\|(?=[^\s|])([^|]*?[^\s|\\])\|(?![\w|])")


def _escape_bars(line: str) -> str:
    """Escape ``|text|`` outside inline literals and roles so docutils reads it as text."""
    parts = _LITERAL.split(line)
    for i in range(0, len(parts), 2):
        parts[i] = _BARS.sub(lambda m: "\\|" + m.group(1) + "\\|", parts[i])
    return "".join(parts)


def escape_abs_bars(app, what, name, obj, options, lines) -> None:
    """``autodoc-process-docstring`` hook: the package's docstrings write ``|w|`` for an absolute
    value; reStructuredText would read it as a substitution reference (an error). Literal blocks
    (after ``::``) and table lines are left as they are."""
    literal_indent = None
    for i, line in enumerate(lines):
        stripped = line.strip()
        indent = len(line) - len(line.lstrip())
        if literal_indent is not None and stripped and indent <= literal_indent:
            literal_indent = None
        table = _TABLE.match(stripped) or (stripped.startswith("| ") and stripped.endswith(" |"))
        if literal_indent is None and stripped and not table:
            lines[i] = _escape_bars(line)
        if stripped.endswith("::"):
            literal_indent = indent


class _OptionalGlobFilter(logging.Filter):
    """Drop the "toctree glob pattern ... didn't match" warning for :data:`OPTIONAL_GLOBS`."""

    def filter(self, record: logging.LogRecord) -> bool:
        msg = record.getMessage()
        return not ("didn't match any documents" in msg and any(f"'{g}'" in msg for g in OPTIONAL_GLOBS))


def setup(app):
    app.connect("autodoc-process-docstring", escape_abs_bars)
    logging.getLogger("sphinx.sphinx.directives.other").addFilter(_OptionalGlobFilter())
