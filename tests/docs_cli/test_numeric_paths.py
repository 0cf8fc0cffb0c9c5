"""benchmarks/numeric_paths.py: numpy held to its AVX2 paths only on an x86-64 machine with AVX-512, never over a
user's own choice; the suite runs with what it gives (tests/conftest.py)."""

import os
import platform
from importlib import metadata

import pytest

from benchmarks.numeric_paths import AVX2_PATHS, main, numpy_paths

X86 = platform.machine().lower() in ("x86_64", "amd64")
NUMPY2 = int(metadata.version("numpy").split(".")[0]) >= 2


def cpu(tmp_path, flags):
    path = tmp_path / "cpuinfo"
    path.write_text(f"processor\t: 0\nflags\t\t: fpu sse sse2 {flags}\n", encoding="ascii")
    return path


@pytest.mark.skipif(not (X86 and NUMPY2), reason="numpy >= 2 on x86-64 only")
def test_an_avx512_cpu_gets_the_avx2_paths(tmp_path):
    assert numpy_paths({}, cpu(tmp_path, "avx2 fma f16c avx512f avx512bw")) == {
        "NPY_ENABLE_CPU_FEATURES": AVX2_PATHS, "OPENBLAS_CORETYPE": "Haswell"}
    assert AVX2_PATHS.split(",")[-1] == "AVX2" and "AVX512F" not in AVX2_PATHS


def test_nothing_where_it_is_not_needed_or_the_user_chose(tmp_path):
    assert numpy_paths({}, cpu(tmp_path, "avx2 fma f16c")) == {}  # no AVX-512: numpy's AVX2 paths already
    avx512 = cpu(tmp_path, "avx2 fma f16c avx512f")
    assert numpy_paths({"NPY_ENABLE_CPU_FEATURES": "AVX2", "OPENBLAS_CORETYPE": "Zen"}, avx512) == {}
    assert numpy_paths({"NPY_DISABLE_CPU_FEATURES": "AVX512F"}, avx512) == {"OPENBLAS_CORETYPE": "Haswell"}
    assert numpy_paths({}, tmp_path / "missing") == {}


def test_the_suite_runs_with_what_it_gives(capsys):
    given = numpy_paths({k: v for k, v in os.environ.items()
                         if k not in ("NPY_ENABLE_CPU_FEATURES", "OPENBLAS_CORETYPE")})
    for key in given:
        assert os.environ.get(key)  # the suite's own, or the user's
    assert main([]) == 0 and capsys.readouterr().out == "".join(
        f"export {k}={v}\n" for k, v in numpy_paths(os.environ).items())
