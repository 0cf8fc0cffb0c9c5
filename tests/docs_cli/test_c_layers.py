"""The C core keeps the package layers: ``plant`` <- ``adaptive_ff`` <- ``controllers``, and portable C99.

A C source or header of a layer includes only headers of its own layer or of the layers below it (the
Python layering of tests/docs_cli/test_architecture.py, for the compiled code), only ``<math.h>``, ``<stdint.h>``,
``<stddef.h>`` and ``<string.h>`` from the C library, and no header calls ``malloc`` or does I/O.
"""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
LAYERS = ("plant", "adaptive_ff", "controllers")
PREFIX = {"plant": ("plant_", "aff_real"), "adaptive_ff": ("aff_",), "controllers": ("ctl_",)}
SYSTEM = {"math.h", "stdint.h", "stddef.h", "string.h"}
FILES = [(layer, p) for layer in LAYERS for p in sorted((ROOT / layer / "csrc").glob("*.[ch]"))]


def _owner(header: str) -> str | None:
    for layer, prefixes in PREFIX.items():
        if header.startswith(prefixes):
            return layer
    return None


def test_every_layer_has_c_sources():
    assert {layer for layer, _ in FILES} == set(LAYERS)


@pytest.mark.parametrize("layer,path", FILES, ids=[f"{p.parent.parent.name}/{p.name}" for _, p in FILES])
def test_includes_follow_the_layers(layer, path):
    text = path.read_text()
    allowed = LAYERS[:LAYERS.index(layer) + 1]
    for inc in re.findall(r'#include\s+"([^"]+)"', text):
        owner = _owner(inc)
        assert owner is not None, f"{path.name} includes {inc!r}: not a header of the C core"
        assert owner in allowed, f"{path.name} ({layer}) includes {inc} of the higher layer {owner}"
        assert (ROOT / owner / "csrc" / inc).is_file(), f"{path.name} includes {inc}, which is not in {owner}/csrc"
    for inc in re.findall(r"#include\s+<([^>]+)>", text):
        assert inc in SYSTEM, f"{path.name} includes <{inc}>: the core uses only {sorted(SYSTEM)}"
    code = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    for call in ("malloc", "calloc", "realloc", "free", "printf", "fopen", "exit"):
        assert not re.search(rf"\b{call}\s*\(", code), f"{path.name} calls {call}()"


def test_a_layer_prefix_names_every_file():
    for layer, path in FILES:
        assert _owner(path.name) == layer, f"{layer}/csrc/{path.name}: the file name must carry the layer's prefix"


def _file_local_names(code: str) -> set[str]:
    """Names a C source declares ``static`` at file scope (functions and constants)."""
    code = re.sub(r"/\*.*?\*/", "", code, flags=re.S)
    return set(re.findall(r"^static\s+(?:const\s+)?[A-Za-z_][\w ]*?[\s*]+([A-Za-z_]\w*)\s*[(=\[;]", code, re.M))


def test_file_local_names_are_unique_across_the_core():
    """Each extension module compiles its layers' sources as one translation unit (plant/_cbuild.py,
    ``unity_source``): a file-local name declared in two sources would collide there."""
    seen: dict[str, str] = {}
    for _, path in FILES:
        if path.suffix != ".c":
            continue
        for name in _file_local_names(path.read_text()):
            assert name not in seen, f"static {name} is declared in {seen[name]} and in {path.name}"
            seen[name] = path.name
    assert {"rhs", "row_at", "sense", "FC_INFO_FRACTION", "NOISE_GAIN"} <= set(seen)  # the pattern finds them


def test_the_module_source_includes_every_c_file_once():
    """The unity source of the engine's module names each header it declares and every .c of the three layers."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("plant_cbuild_for_test", ROOT / "plant" / "_cbuild.py")
    build = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(build)
    layers = [(ROOT / layer / "csrc", []) for layer in LAYERS]
    text = build.unity_source(layers)
    included = re.findall(r'#include "([^"]+\.c)"', text)
    assert sorted(included) == sorted(p.name for _, p in FILES if p.suffix == ".c")
