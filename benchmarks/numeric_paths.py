"""numpy's and OpenBLAS's SIMD code paths for the quoted outputs and the test suite: the same on every x86-64 machine.

numpy picks, when it is imported, the SIMD code of its element-wise functions (``exp``, ``log``, ``sin``, ...) for
the machine's CPU, and OpenBLAS, when it is loaded, the kernels of its matrix products. On a CPU with AVX-512 both
take paths whose results differ from the AVX2 paths in the last bits; a fit whose cost has near-equal minima (an
output-error fit's profiled input delay) or a loop that sits at a tie (a quantised encoder's loop that sticks at its
reversals) then lands elsewhere by more than that (docs/getting_started.md). The numbers the documentation quotes
and the suite checks are those of the AVX2 paths: :func:`numpy_paths` gives the variables that hold numpy (>= 2.0:
``NPY_ENABLE_CPU_FEATURES``) and OpenBLAS (``OPENBLAS_CORETYPE=Haswell``, its AVX2 kernels) to them on an AVX-512
machine; ``tests/conftest.py`` sets them before numpy is imported, and :func:`benchmarks.refresh_pages.environment`
for every documented command. Elsewhere (another architecture, a CPU without AVX-512, a variable the user set) it
gives nothing for that library.

Run:  python -m benchmarks.numeric_paths      (prints the ``export`` lines for a shell, nothing where none is needed)

This does not import numpy: it must run before numpy is imported.
"""

from __future__ import annotations

import os
import platform
from collections.abc import Mapping
from importlib import metadata
from pathlib import Path

__all__ = ["AVX2_PATHS", "OPENBLAS_AVX2", "numpy_paths", "main"]

#: The CPU features numpy may dispatch to: x86-64's baseline up to AVX2 with FMA3 (numpy's names).
AVX2_PATHS = "SSE,SSE2,SSE3,SSSE3,SSE41,POPCNT,SSE42,AVX,F16C,FMA3,AVX2"
#: OpenBLAS's core type whose kernels are AVX2 with FMA3.
OPENBLAS_AVX2 = "Haswell"


def numpy_paths(env: Mapping[str, str], cpuinfo: Path = Path("/proc/cpuinfo")) -> dict[str, str]:
    """The environment variables that hold numpy and OpenBLAS to their AVX2 paths, or ``{}`` where none are needed.

    Parameters
    ----------
    env : mapping
        The environment the process runs in (``os.environ``): a user's own ``NPY_ENABLE_CPU_FEATURES`` or
        ``NPY_DISABLE_CPU_FEATURES`` is left to decide numpy's paths, a user's ``OPENBLAS_CORETYPE`` OpenBLAS's.
    cpuinfo : Path
        The kernel's CPU description (Linux); unreadable: ``{}``.

    Returns
    -------
    dict
        On an x86-64 Linux machine whose CPU has AVX-512F, AVX2, FMA and F16C: ``NPY_ENABLE_CPU_FEATURES``
        (:data:`AVX2_PATHS`, with numpy 2.0 or newer installed) and ``OPENBLAS_CORETYPE`` (:data:`OPENBLAS_AVX2`),
        each unless ``env`` sets its library's own; else ``{}``.
    """
    if platform.machine().lower() not in ("x86_64", "amd64"):
        return {}
    try:
        flags = set(cpuinfo.read_text(encoding="ascii", errors="replace").split())
    except OSError:
        return {}
    if not {"avx512f", "avx2", "fma", "f16c"} <= flags:
        return {}
    out = {}
    if not (env.get("NPY_ENABLE_CPU_FEATURES") or env.get("NPY_DISABLE_CPU_FEATURES")):
        try:
            if int(metadata.version("numpy").split(".")[0]) >= 2:
                out["NPY_ENABLE_CPU_FEATURES"] = AVX2_PATHS
        except (ValueError, metadata.PackageNotFoundError):
            pass
    if not env.get("OPENBLAS_CORETYPE"):
        out["OPENBLAS_CORETYPE"] = OPENBLAS_AVX2
    return out


def main(argv=None) -> int:
    """Print ``export NAME=VALUE`` for each variable :func:`numpy_paths` gives here (``eval`` them in a shell to run a
    documented command on the quoted outputs' paths). Returns 0."""
    for name, value in numpy_paths(os.environ).items():
        print(f"export {name}={value}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
