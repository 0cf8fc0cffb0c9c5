"""numpy's SIMD code paths for the quoted outputs and the test suite: the same on every x86-64 machine.

numpy picks, when it is imported, the SIMD code of its element-wise functions (``exp``, ``log``, ``sin``, ...) for
the machine's CPU. On a CPU with AVX-512 it takes paths whose results differ from the AVX2 paths in the last bit;
the package's fits and closed loops then land elsewhere by more than that bit: an output-error fit's profiled input
delay 0 instead of 0.625 ms on the coverage zoo's joint of seed 1, a 17-bit encoder loop's `adaptive` eta 0.22
instead of 0.46 (one realisation of a loop that sticks at its reversals, docs/getting_started.md). The numbers the
documentation quotes and the suite checks are those of the AVX2 paths: :func:`numpy_paths` gives the variable that
holds numpy to them on an AVX-512 machine (numpy >= 2.0 reads ``NPY_ENABLE_CPU_FEATURES``); ``tests/conftest.py``
sets it before numpy is imported, and :func:`benchmarks.refresh_pages.environment` for every documented command.
Elsewhere (another architecture, a CPU without AVX-512, a variable the user set) it gives nothing.

This does not import numpy: it must run before numpy is imported.
"""

from __future__ import annotations

import platform
from collections.abc import Mapping
from importlib import metadata
from pathlib import Path

__all__ = ["AVX2_PATHS", "numpy_paths"]

#: The CPU features numpy may dispatch to: x86-64's baseline up to AVX2 with FMA3 (numpy's names).
AVX2_PATHS = "SSE,SSE2,SSE3,SSSE3,SSE41,POPCNT,SSE42,AVX,F16C,FMA3,AVX2"


def numpy_paths(env: Mapping[str, str], cpuinfo: Path = Path("/proc/cpuinfo")) -> dict[str, str]:
    """The environment variables that hold numpy to its AVX2 paths, or ``{}`` where none are needed.

    Parameters
    ----------
    env : mapping
        The environment the process runs in (``os.environ``): a user's own ``NPY_ENABLE_CPU_FEATURES`` or
        ``NPY_DISABLE_CPU_FEATURES`` is left to decide.
    cpuinfo : Path
        The kernel's CPU description (Linux); unreadable: ``{}``.

    Returns
    -------
    dict
        ``{"NPY_ENABLE_CPU_FEATURES": AVX2_PATHS}`` on an x86-64 Linux machine whose CPU has AVX-512F, AVX2, FMA
        and F16C, with numpy 2.0 or newer installed; else ``{}``.
    """
    if env.get("NPY_ENABLE_CPU_FEATURES") or env.get("NPY_DISABLE_CPU_FEATURES"):
        return {}
    if platform.machine().lower() not in ("x86_64", "amd64"):
        return {}
    try:
        flags = set(cpuinfo.read_text(encoding="ascii", errors="replace").split())
        major = int(metadata.version("numpy").split(".")[0])
    except (OSError, ValueError, metadata.PackageNotFoundError):
        return {}
    if major < 2 or not {"avx512f", "avx2", "fma", "f16c"} <= flags:
        return {}
    return {"NPY_ENABLE_CPU_FEATURES": AVX2_PATHS}
