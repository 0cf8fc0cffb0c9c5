"""Build script of plant's C core: cffi in API mode, run by ``pip install`` (setup.py's ``cffi_modules``).

The C sources are ``plant/csrc/*.c``; their headers are the one statement of
each component's struct and functions, and cffi reads its declarations from
them (:func:`cdef_text`), so nothing is declared twice. The module it builds,
``plant._cplant``, is imported by the Python wrappers of :mod:`plant` only.
The build scripts of the higher layers (``adaptive_ff/_cbuild.py``,
``controllers/_cbuild.py``) include this one (``ffi.include``: the same C
types in every module) and compile these sources into their own module, so
the layering ``plant <- adaptive_ff <- controllers`` holds for the C code too
(a plant source never includes a higher layer's header; tests/docs_cli/test_c_layers.py).
"""

from __future__ import annotations

import os
import re
import sys
from pathlib import Path

from cffi import FFI

CSRC = Path(__file__).resolve().parent / "csrc"

#: Headers read by cffi, in dependency order (aff_real.h is replaced by its double typedef).
HEADERS = [
    "plant_stribeck.h",
    "plant_params.h",
    "plant_stiff.h",
    "plant_dynamics.h",
]

_ARRAY_MACRO = re.compile(r"\[\s*[A-Z_][A-Z0-9_]*(\s*[*+]\s*[A-Z0-9_]+)*\s*\]")


def cdef_text(header: Path) -> str:
    """The declarations of ``header`` as cffi's ``cdef`` reads them.

    Preprocessor lines are dropped (the include guards and ``#include``; a header of the core declares
    types and functions only, no function-like macros), and an array length written as a macro
    (``double theta[AFF_RLS_NMAX]``) becomes ``[...]``: the C compiler supplies it.
    """
    body = "\n".join(line for line in header.read_text().splitlines() if not line.lstrip().startswith("#"))
    return _ARRAY_MACRO.sub("[...]", body)


def compile_args() -> list[str]:
    """C99, optimised, and no contraction of ``a*b + c`` into a fused multiply-add: the same numbers on every
    compiler and CPU (MSVC: its default ``/fp:precise`` does not contract either).

    ``-O3`` without ``-ffast-math`` keeps every floating-point operation and its order (vectorising or
    inlining does not reassociate), so the results equal those of ``-O2`` (tests/controllers_layer/test_golden.py); it made the
    engine 20-25 % faster per step (docs/benchmarks/perf.md). ``-fno-tree-slp-vectorize`` (GCC; Clang reads it
    as ``-fno-slp-vectorize``) keeps straight-line code scalar: packing pairs of independent scalar operations
    into vector registers (the RK4 stages, the filter chains, the covariance update) puts shuffles on the loops'
    dependency chains, a quarter to three quarters more time per engine step and per RLS update at about the
    same instruction count; the same operations, so the same numbers. On Linux, ``-fno-semantic-interposition`` lets
    the compiler inline the components' exported functions into their callers inside the module (an ELF
    shared object otherwise keeps every exported call interposable).
    """
    if sys.platform == "win32":
        return ["/O2"]
    args = ["-std=c99", "-O3", "-ffp-contract=off", "-fno-fast-math", "-fno-tree-slp-vectorize"]
    if sys.platform.startswith("linux"):
        args.append("-fno-semantic-interposition")
    return args


def link_libraries() -> list[str]:
    """The math library named at link time (not on Windows, whose C runtime holds it): the extension then binds
    glibc's current ``exp`` (``exp@@GLIBC_2.29``, the same result, a wrapper one instruction shorter) rather than
    the compatibility symbol an unversioned reference resolves to (docs/benchmarks/perf.md)."""
    return [] if sys.platform == "win32" else ["m"]


def sources(csrc: Path) -> list[str]:
    """The ``.c`` files of a ``csrc`` folder, relative to the project root (setuptools wants relative paths)."""
    root = csrc.parent.parent
    return [os.path.relpath(p, root) for p in sorted(csrc.glob("*.c"))]


def unity_source(layers: list[tuple[Path, list[str]]]) -> str:
    """The module's C source: the declared headers, then every ``.c`` file of ``layers`` included in order.

    One translation unit per extension module (a "unity build"), so the compiler inlines across the
    components' files as it does within one (the plant's RK4 step calls eq. 3 four times per period; the
    engine calls the compensator through its ops table): the same sources, no link-time optimiser needed,
    on every compiler. The components' file-local (``static``) names are therefore unique across all
    layers (tests/docs_cli/test_c_layers.py).
    """
    includes = "".join(f'#include "{h}"\n' for _, hs in layers for h in hs)
    return includes + "".join(f'#include "{Path(s).name}"\n' for d, _ in layers for s in sources(d))


def make_ffi(module: str, layers: list[tuple[Path, list[str]]], include: FFI | None = None) -> FFI:
    """An FFI that declares the headers of the last layer and compiles the sources of all ``layers``.

    Parameters
    ----------
    module : str
        Dotted name of the extension module (``"plant._cplant"``).
    layers : list of (Path, list of str)
        ``(csrc folder, headers)`` from the lowest layer up; the last is the module's own.
    include : FFI, optional
        The FFI of the layer below (its declarations are shared, not repeated).
    """
    ffi = FFI()
    if include is not None:
        ffi.include(include)
    else:
        ffi.cdef("typedef double aff_real;")
    own_dir, own_headers = layers[-1]
    ffi.cdef("\n".join(cdef_text(own_dir / h) for h in own_headers))
    root = own_dir.parent.parent
    ffi.set_source(module, unity_source(layers),
                   include_dirs=[os.path.relpath(d, root) for d, _ in layers],
                   depends=[s for d, _ in layers for s in sources(d)]
                   + [os.path.relpath(h, root) for d, _ in layers for h in sorted(d.glob("*.h"))],
                   extra_compile_args=compile_args(), libraries=link_libraries())
    return ffi


ffibuilder = make_ffi("plant._cplant", [(CSRC, HEADERS)])

if __name__ == "__main__":
    ffibuilder.compile(verbose=True)
