"""A fuzz smoke of the exported C API: tests/fuzz_aff.c under libFuzzer, AddressSanitizer and UBSan.

Random call sequences (``aff_step``, ``aff_step_gated``, ``aff_observe`` in and out of order, ``aff_status``, a
restart) with random and special values (NaN, +-inf, huge, subnormal, beyond the guard's bounds) from five states
of a clean closed loop: every output and transfer finite and within +-``AFF_FF_MAX``, no sanitizer finding. 15 s
per precision here (``benchmarks/fuzz_c.py`` runs it for minutes and prints executions and coverage). clang with
libFuzzer is a skip where missing on a developer's machine and a failure in CI (``.ci/run`` installs it).
"""

from __future__ import annotations

import json
import os
import shutil

import pytest

from controllers.cli.main import main
from export_c_helpers import ID_JSON, U_MAX, build_fuzzer, run_fuzzer

SECONDS = 15


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    d = tmp_path_factory.mktemp("fuzz")
    (d / "id.json").write_text(json.dumps(ID_JSON))
    out = d / "drive_ff"
    assert main(["export-c", "--from", str(d / "id.json"), "--u-max", str(U_MAX), "--out", str(out), "--quiet"]) == 0
    return out


@pytest.mark.parametrize("precision", ["double", "float"])
def test_the_exported_api_survives_random_call_sequences(exported, tmp_path, precision):
    clang = shutil.which("clang")
    if clang is None:
        if os.environ.get("CI"):
            pytest.fail("clang is missing: .ci/run installs it")
        pytest.skip("clang is not installed (apt-get install clang)")
    exe = build_fuzzer(clang, exported, tmp_path / "fuzz", *(["-DAFF_FLOAT"] if precision == "float" else []))
    r = run_fuzzer(exe, tmp_path / "corpus", SECONDS)
    print(f"\n{precision}: {r['executions']} executions, cov {r['coverage']}, ft {r['features']}")
    assert r["returncode"] == 0, r["log"]
    assert r["executions"] > 1000 and r["coverage"] > 100, r["log"]
