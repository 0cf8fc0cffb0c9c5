"""The packages' public names are imported lazily (``lazy_loader.attach`` in each ``__init__.py``) and still
resolve to the objects of their defining modules, whatever was imported before.

Each check runs in a fresh interpreter, so that the import order is the one the check sets up: a package
attribute that a submodule import binds (``import plant.friction`` sets ``plant.friction``) would win over the
lazy ``__getattr__`` if a public name were spelled like a direct submodule, so none may be.
"""

from __future__ import annotations

import json
import os
import pkgutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("plant", "adaptive_ff", "controllers")

#: Prints, as JSON, {package: {name: a description of the object}} for every name of every package's
#: ``__all__`` (subpackages too), after importing first every module of the three packages ("all") or nothing
#: ("none"). A class or function is described by where it is defined and whether it is the object of that name
#: there, a module by its name, any other value by its type and repr (addresses left out); a top-level package
#: also by its ``dir()``.
_PROBE = textwrap.dedent("""
    import importlib, json, pkgutil, re, sys, types
    packages = {packages!r}
    first = {first!r}
    tops = [importlib.import_module(p) for p in packages]
    loaded_before = sorted(m for m in sys.modules if m.split(".")[0] in packages and "." in m)
    modules = []
    for p, pkg in zip(packages, tops):  # (walk_packages imports the subpackages)
        modules += [p] + [m.name for m in pkgutil.walk_packages(pkg.__path__, p + ".")]
    if first == "all":
        for m in modules:
            importlib.import_module(m)

    def describe(obj):
        if isinstance(obj, types.ModuleType):
            return ["module", obj.__name__]
        if isinstance(obj, type) or callable(obj) and hasattr(obj, "__qualname__"):
            home = sys.modules.get(getattr(obj, "__module__", None) or "")
            return ["defined", obj.__module__, obj.__qualname__, getattr(home, obj.__qualname__, None) is obj]
        return ["value", type(obj).__name__, re.sub("0x[0-9a-f]+", "0x", repr(obj))[:200]]

    out = {{}}
    for m in modules:
        mod = importlib.import_module(m)
        if hasattr(mod, "__all__"):
            out[m] = {{name: describe(getattr(mod, name)) for name in mod.__all__}}
            out[m]["__all__"] = list(mod.__all__)
            if m in packages:
                out[m]["__dir__"] = sorted(dir(mod))
    print(json.dumps({{"loaded_before": loaded_before, "names": out}}))
""")


def _run(code: str) -> str:
    env = {**os.environ, "MPLBACKEND": "Agg"}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-4000:]
    return r.stdout


@pytest.fixture(scope="module")
def probes() -> dict[str, dict]:
    """The probe's answer with nothing imported first ("none") and with every module imported first ("all")."""
    return {first: json.loads(_run(_PROBE.format(packages=PACKAGES, first=first)).splitlines()[-1])
            for first in ("none", "all")}


def test_import_loads_no_submodule(probes):
    """``import plant, adaptive_ff, controllers`` (the probe's first step) imports none of their modules."""
    assert probes["none"]["loaded_before"] == []


def test_names_do_not_depend_on_import_order(probes):
    none, every = probes["none"]["names"], probes["all"]["names"]
    assert set(none) >= set(PACKAGES)
    assert none == every
    for package, names in none.items():
        for name in names["__all__"]:
            assert names[name][0] != "module", f"{package}.{name} is a module"


def test_dir_is_all(probes):
    """The lazy table of each top-level package names exactly ``__all__`` (``dir`` lists the table)."""
    for package in PACKAGES:
        names = probes["none"]["names"][package]
        assert sorted(names["__dir__"]) == sorted(names["__all__"]), package
        assert len(set(names["__all__"])) == len(names["__all__"]), package


def test_re_exports_are_the_defining_modules_objects(probes):
    """A re-exported class or function is the object its module defines (so ``plant.stribeck`` is the map of
    :mod:`plant.stribeck_map`, re-exported by :mod:`plant.friction`)."""
    for first in ("none", "all"):
        for package in PACKAGES:
            names = probes[first]["names"][package]
            for name in names["__all__"]:
                kind, *where = names[name]
                if kind == "defined":
                    module, qualname, same = where
                    assert module.split(".")[0] in PACKAGES and qualname == name and same, (first, package, name)


def test_no_public_name_is_spelled_like_a_direct_submodule():
    """Importing ``pkg.x`` binds ``pkg.x`` to the module, past the lazy ``__getattr__``: so no name of
    ``__all__`` may be a direct submodule's name (as a module ``plant/stribeck.py`` beside the function
    ``plant.stribeck`` would be)."""
    import importlib

    for package in PACKAGES:
        mod = importlib.import_module(package)
        children = {m.name for m in pkgutil.iter_modules(mod.__path__)}
        assert not children & set(mod.__all__), (package, children & set(mod.__all__))


def test_stribeck_and_variants_are_functions_after_their_modules():
    """The names that once shared a module's spelling: each import route, after the modules are imported."""
    out = _run(textwrap.dedent("""
        import plant.stribeck_map, plant.variant_plants, plant.friction, adaptive_ff.errors, plant.errors
        import plant, adaptive_ff
        from plant import stribeck, variants
        print(stribeck is plant.stribeck is plant.friction.stribeck is plant.stribeck_map.stribeck,
              variants is plant.variants is plant.variant_plants.variants,
              callable(stribeck) and callable(variants),
              adaptive_ff.ParameterError is plant.ParameterError is plant.errors.ParameterError)
    """))
    assert out.split() == ["True", "True", "True", "True"]
