"""Sphinx configuration of the adaptive-ff documentation.

Build (from the repository root)::

    pip install -e '.[docs]'
    python -m sphinx -W --keep-going -b html docs docs/_build/html

The API pages (``api/<package>.rst``) are written here at build time from each package's
``__all__``, so every public name is documented without a hand-kept list; so are the module pages
(``api/modules.rst`` and ``api/modules/<module>.rst``, every module's docstring, found by walking
the packages). The gallery runs the scripts in ``examples/`` (``ADAPTIVE_FF_DOCS_PLOT_GALLERY=0``
renders them without running, as ``tests/docs_cli/test_docs.py`` does). No network is needed: there is no intersphinx.
"""

from __future__ import annotations

import functools
import importlib
import inspect
import logging
import os
import re
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
# The repository root; tests/docs_cli/test_docs.py builds a copy of docs/ elsewhere and points here.
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
templates_path = ["_templates"]
html_theme = "alabaster"
html_static_path = ["_static"]
html_title = f"adaptive-ff {release}"
html_theme_options = {"description": "Sliding-friction identification and adaptive friction feedforward",
                      "page_width": "1100px", "sidebar_width": "240px"}

myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3

autosummary_generate = True
autosummary_imported_members = True
# class pages (docs/_templates/autosummary/class.rst) document their methods and properties; module pages say
# ``:no-members:`` themselves
autodoc_default_options: dict = {}
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

# --- the module pages: one per module of the three packages, its docstring ----------------------
# ``api/modules.rst`` lists every module by package and subpackage; ``api/modules/<module>.rst``
# shows the module's docstring (``:no-members:``: the members are documented once, on the package
# pages, and a module's page links to those it defines). Modules are found by walking the packages,
# so a new module gets its page without a list to edit; a module whose name (or a parent's) starts
# with ``_`` is private and left out.


def module_tree(package: str) -> dict[str, list[str]]:
    """``{package or subpackage: its modules, then its subpackages, each sorted}`` under ``package``."""
    import pkgutil

    root = importlib.import_module(package)
    tree: dict[str, list[str]] = {package: []}
    for info in pkgutil.walk_packages(root.__path__, prefix=package + "."):
        parent = info.name.rpartition(".")[0]
        if info.name.rpartition(".")[2].startswith("_") or parent not in tree:  # private, or in a private package
            continue
        tree[parent].append(info.name)
        if info.ispkg:
            tree[info.name] = []
    return {pkg: sorted(subs, key=lambda m: (m in tree, m)) for pkg, subs in tree.items()}


def defined_names(package: str) -> dict[str, list[str]]:
    """``{module: the public names of package defined there}``, as the package page writes them
    (``name`` for a class or function, ``module.NAME`` for a constant, relative to ``package``)."""
    mod = importlib.import_module(package)
    names, constants, _ = api_entries(package)
    out: dict[str, list[str]] = {}
    for name in names:
        out.setdefault(getattr(getattr(mod, name), "__module__", None) or package, []).append(name)
    for target in constants:
        out.setdefault(target.rpartition(".")[0], []).append(target[len(package) + 1:])
    return out


def shadowed(module: str) -> bool:
    """Whether a public name of the package has the module's full name (as a function ``plant.stribeck``
    would beside a module ``plant/stribeck.py``): the two cannot share one target, so the
    module's page is not indexed (``:no-index:``) and is linked as a page, not as ``:mod:``."""
    package, _, name = module.rpartition(".")
    return package in PACKAGES and name in public_names(package)


def summary(module: str) -> str:
    """The first paragraph of the module's docstring, on one line (``|x|`` escaped as in docstrings)."""
    doc = inspect.getdoc(importlib.import_module(module)) or ""
    return _escape_bars(" ".join(doc.split("\n\n")[0].split()))


def module_table(modules: list[str], pages: str) -> list[str]:
    """A table of ``modules`` (a link, the docstring's first paragraph) like autosummary's; ``pages``
    is the path from the page that shows it to the folder of the module pages."""
    rows = [".. list-table::", "   :class: autosummary longtable", "   :widths: 40 60", ""]
    for m in modules:
        link = f":doc:`{m} <{pages}{m}>`" if shadowed(m) else f":mod:`{m}`"
        rows += [f"   * - {link}", f"     - {summary(m)}"]
    return rows + [""]


def module_page(module: str, tree: dict[str, list[str]], defined: dict[str, list[str]]) -> str:
    """The page of ``module``: its docstring, its submodules if a package, the public names it defines."""
    package = module.split(".")[0]
    lines = [module, "=" * len(module), "", f".. automodule:: {module}", "   :no-members:"]
    lines += ["   :no-index:", "", f"In the package's namespace, ``{module}`` is :obj:`{module}`, defined in this "
              f"module; ``import {module}`` imports the module shown here."] if shadowed(module) else []
    lines.append("")
    # sections, not rubrics: after the docstring's own sections a rubric would read as part of the last one
    if tree.get(module):
        lines += ["Modules", "-------", "", *module_table(tree[module], ""),
                  ".. toctree::", "   :hidden:", "", *(f"   {m}" for m in tree[module]), ""]
    if defined.get(module):
        lines += ["Public names defined here", "-------------------------", "",
                  f"Documented with the package, :doc:`../{package}`.", "", f".. currentmodule:: {package}", "",
                  ".. autosummary::", "   :nosignatures:", "", *(f"   {n}" for n in defined[module]), ""]
    return "\n".join(lines)


def write_module_pages(outdir: Path = HERE / "api") -> int:
    """Write ``api/modules.rst`` and ``api/modules/<module>.rst``; returns the number of module pages."""
    index = ["Modules", "=======", "",
             "Every module of the three packages with its docstring: the equations, the sources and the",
             "design decisions of what it holds. The public names are documented once, with their package",
             "(:doc:`plant`, :doc:`adaptive_ff`, :doc:`controllers`); a module's page lists those it",
             "defines. A package's own docstring is on the package's page.", ""]
    toc = [".. toctree::", "   :hidden:", ""]
    pages: dict[str, str] = {}
    for package in PACKAGES:
        tree, defined = module_tree(package), defined_names(package)
        index += [package, "-" * len(package), "", f"The package's own page, its docstring and every public name: :doc:`{package}`.", ""]
        for pkg, subs in tree.items():
            if subs:
                index += ([pkg, "~" * len(pkg), ""] if pkg != package else []) + module_table(subs, "modules/")
            for m in subs:
                pages[m] = module_page(m, tree, defined)
        toc += [f"   modules/{m}" for m in tree[package]]
    pages_dir = outdir / "modules"
    pages_dir.mkdir(parents=True, exist_ok=True)
    for stale in set(pages_dir.glob("*.rst")) - {pages_dir / f"{m}.rst" for m in pages}:
        stale.unlink()  # a module that was removed or renamed
    files = {outdir / "modules.rst": "\n".join(index + toc) + "\n",
             **{pages_dir / f"{m}.rst": text for m, text in pages.items()}}
    for path, text in files.items():
        if not path.exists() or path.read_text(encoding="utf-8") != text:
            path.write_text(text, encoding="utf-8")  # an unchanged page keeps its time: no rebuild
    return len(pages)


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


# --- references by the defining module: resolved to the public name's page -------------------
# A docstring names an object where it is defined (``plant.stribeck_map.stribeck_shape``, or
# ``stribeck_shape`` inside that module), the package pages document it under its public name
# (``plant.stribeck_shape``). A reference that Sphinx does not find and that imports to the very
# object documented under a public name links to that name's page, its text unchanged; any other
# reference stays unresolved (``nitpicky`` reports it).
_MISSING = object()


def _load(path: str):
    """The object at the dotted ``path`` under one of :data:`PACKAGES` (a module, then attributes), or None."""
    parts = path.split(".")
    if parts[0] not in PACKAGES:
        return None
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for attr in parts[i:]:
            obj = getattr(obj, attr, _MISSING)
            if obj is _MISSING:
                return None
        return obj
    return None


@functools.lru_cache(maxsize=None)
def documented_homes() -> tuple[dict[int, str], dict[str, tuple[str, object]]]:
    """``({id of a documented class or function: its documented name}, {constant's name: (its
    documented name, the object)})`` over the package pages."""
    objects, constants = {}, {}
    for package in PACKAGES:
        mod = importlib.import_module(package)
        names, fq_constants, _ = api_entries(package)
        for name in names:
            obj = getattr(mod, name)
            if callable(obj):  # a class or function: known by identity
                objects[id(obj)] = f"{package}.{name}"
            else:
                constants[name] = (f"{package}.{name}", obj)
        for target in fq_constants:
            constants[target.rpartition(".")[2]] = (target, _load(target))
    return objects, constants


def resolve_by_definition(app, env, node, contnode):
    """``missing-reference`` hook: a Python reference to a documented object by its defining
    module (or relative to the module, class or docstring it is in) links to its page."""
    if node.get("refdomain") != "py" or node.get("reftype") == "mod":
        return None
    objects, constants = documented_homes()
    target, module, cls = node["reftarget"].lstrip("."), node.get("py:module"), node.get("py:class")
    candidates = [f"{module}.{cls}.{target}" if module and cls else None, f"{module}.{target}" if module else None]
    # in a docstring shown on a package page, a relative name is relative to where the object is defined
    where = re.search(r"docstring of ([\w.]+)", getattr(node, "source", None) or "")
    if where:
        parts = where.group(1).split(".")
        candidates += [".".join(parts[:i] + [target]) for i in range(len(parts), 0, -1)]
    candidates.append(target)
    for path in filter(None, candidates):
        obj = _load(path)
        if obj is None:
            continue
        home = objects.get(id(obj))
        name = path.rpartition(".")[2]
        if home is None and name in constants and constants[name][1] is obj:
            home = constants[name][0]
        if home is None:  # the nearest object of that name is not documented: so is the reference
            return None
        return env.get_domain("py").resolve_xref(env, node["refdoc"], app.builder, node["reftype"], home,
                                                 node, contnode)
    return None


class _OptionalGlobFilter(logging.Filter):
    """Drop the "toctree glob pattern ... didn't match" warning for :data:`OPTIONAL_GLOBS`."""

    def filter(self, record: logging.LogRecord) -> bool:
        msg = record.getMessage()
        return not ("didn't match any documents" in msg and any(f"'{g}'" in msg for g in OPTIONAL_GLOBS))


write_module_pages()  # here, after _escape_bars, which the summaries use


def setup(app):
    app.connect("autodoc-process-docstring", escape_abs_bars)
    app.connect("missing-reference", resolve_by_definition)
    logging.getLogger("sphinx.sphinx.directives.other").addFilter(_OptionalGlobFilter())
