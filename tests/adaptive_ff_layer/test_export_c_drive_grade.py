"""The exported C is drive-grade: strict builds, float end to end on a Cortex-M4F, its size and stack as documented.

* Both precisions of ``aff.c`` and ``aff_config.c`` build clean with gcc and clang at ``-std=c99 -pedantic -Wall
  -Wextra -Wconversion -Wshadow -Wdouble-promotion -Werror``.
* The float build, cross-compiled for a Cortex-M4F (``-mcpu=cortex-m4 -mthumb -mfpu=fpv4-sp-d16
  -mfloat-abi=hard``, Debian's ``gcc-arm-none-eabi``), references no soft-double helper of the ARM EABI
  (``__aeabi_d*``, ``__aeabi_f2d``, ``__aeabi_d2f``): its arithmetic is float end to end.
* The code size, the size of ``AFF_CONFIG`` and of ``aff``, and the worst stack of the drive's calls (gcc's
  ``-fcallgraph-info=su``: the largest sum of static frames along a call path) of the double build (the host's gcc,
  x86-64) and of the float build (Cortex-M4F) are those of the table in docs/api_c.md, within 10 %; the worst
  stack is at most 1 kB.

A tool that is missing is a skip on a developer's machine and a failure in CI (``.ci/run`` installs clang and
``gcc-arm-none-eabi``).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from controllers.cli.main import main
from export_c_helpers import CORTEX_M4F, ENTRY_POINTS, ID_JSON, SOFT_DOUBLE, STRICT, U_MAX, worst_stack

ROOT = Path(__file__).resolve().parents[2]


def _tool(name: str) -> str:
    path = shutil.which(name)
    if path is None:
        if os.environ.get("CI"):
            pytest.fail(f"{name} is missing: .ci/run installs it")
        pytest.skip(f"{name} is not installed (apt-get install clang gcc-arm-none-eabi)")
    return path


@pytest.fixture(scope="module")
def exported(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("grade")
    (d / "id.json").write_text(json.dumps(ID_JSON))
    out = d / "drive_ff"
    assert main(["export-c", "--from", str(d / "id.json"), "--u-max", str(U_MAX), "--out", str(out), "--quiet"]) == 0
    return out


def _run(cmd: list, **kw) -> subprocess.CompletedProcess:
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300, **kw)
    assert r.returncode == 0 and not r.stderr.strip(), f"{' '.join(map(str, cmd))}\n{r.stderr}"
    return r


@pytest.mark.parametrize("compiler", ["gcc", "clang"])
@pytest.mark.parametrize("precision", ["double", "float"])
def test_both_precisions_build_clean_at_strict_warnings(exported, tmp_path, compiler, precision):
    cc = _tool(compiler)
    flags = STRICT + (["-DAFF_FLOAT"] if precision == "float" else [])
    for src in ("aff.c", "aff_config.c"):
        _run([cc, *flags, "-O2", "-c", str(exported / src), "-o", str(tmp_path / (src + ".o"))])


def _arm(exported: Path, tmp_path: Path, precision: str) -> dict:
    """Cross-compile the export for a Cortex-M4F: the objects' text sizes, sizeof(aff), the worst stacks."""
    cc = _tool("arm-none-eabi-gcc")
    flags = [f for f in CORTEX_M4F if precision == "float" or f != "-DAFF_FLOAT"]
    return _measure(exported, tmp_path, cc, flags, _tool("arm-none-eabi-size"), _tool("arm-none-eabi-nm"))


def _measure(exported: Path, tmp_path: Path, cc: str, flags: list, size: str, nm: str) -> dict:
    obj = tmp_path / "aff.o"
    _run([cc, *flags, "-c", str(exported / "aff.c"), "-o", str(obj), "-fcallgraph-info=su"], cwd=tmp_path)
    _run([cc, *flags, "-c", str(exported / "aff_config.c"), "-o", str(tmp_path / "aff_config.o")], cwd=tmp_path)
    probe = tmp_path / "probe.c"
    probe.write_text('#include "aff.h"\naff aff_sizeof_probe;\n')
    _run([cc, *flags, f"-I{exported}", "-c", str(probe), "-o", str(tmp_path / "probe.o")], cwd=tmp_path)

    def text(o: str) -> int:
        return int(_run([size, str(tmp_path / o)]).stdout.splitlines()[1].split()[0])

    sym = _run([nm, "-S", str(tmp_path / "probe.o")]).stdout
    sizeof = int(next(line.split()[1] for line in sym.splitlines() if line.endswith("aff_sizeof_probe")), 16)
    stacks = worst_stack((tmp_path / "aff.ci").read_text())
    return {"code": text("aff.o"), "config": text("aff_config.o"), "sizeof": sizeof,
            "stack": max(stacks.values()), "stacks": stacks, "undefined": _run([nm, "-u", str(obj)]).stdout}


def test_float_build_needs_no_soft_double_helper_on_a_cortex_m4f(exported, tmp_path):
    m = _arm(exported, tmp_path, "float")
    helpers = [s for s in m["undefined"].split() if s.startswith(SOFT_DOUBLE)]
    assert not helpers, helpers
    assert "expf" in m["undefined"] and "exp\n" not in m["undefined"]  # the float functions of <math.h>


def _documented() -> dict:
    """docs/api_c.md's table "Size and stack": build -> (code, config, sizeof, stack) in bytes."""
    text = (ROOT / "docs" / "api_c.md").read_text()
    rows = {}
    for line in text.split("## Size and stack", 1)[1].splitlines():
        m = re.match(r"\| (double|float), [^|]+" + r"\|\s*([\d ]+) B " * 4 + r"\|", line)
        if m:
            rows[m.group(1)] = tuple(int(g.replace(" ", "")) for g in m.groups()[1:])
    assert set(rows) == {"double", "float"}, rows
    return rows


def test_size_and_worst_stack_are_the_documented_ones(exported, tmp_path):
    doc = _documented()
    host = _measure(exported, tmp_path, _tool("gcc"), ["-O2", "-std=c99", "-ffp-contract=off"], _tool("size"),
                    _tool("nm"))
    (tmp_path / "arm").mkdir()
    arm = _arm(exported, tmp_path / "arm", "float")
    for build, m in (("double", host), ("float", arm)):
        got = (m["code"], m["config"], m["sizeof"], m["stack"])
        print(f"\n{build}: code {got[0]} B, AFF_CONFIG {got[1]} B, sizeof(aff) {got[2]} B, worst stack {got[3]} B "
              f"({m['stacks']})")
        assert set(m["stacks"]) == set(ENTRY_POINTS)
        assert m["stack"] <= 1024, (build, m["stacks"])
        for name, g, d in zip(("code", "AFF_CONFIG", "sizeof(aff)", "worst stack"), got, doc[build]):
            assert abs(g - d) <= 0.1 * d, f"{build} {name}: measured {g} B, docs/api_c.md says {d} B"
