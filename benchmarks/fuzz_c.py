"""Fuzz the exported C API for minutes: tests/fuzz_aff.c under libFuzzer, AddressSanitizer and UBSan.

Run: ``python benchmarks/fuzz_c.py [--seconds 600] [--precision double|float|both] [--corpus DIR]``.

Exports the paper joint's identification (tests/export_c_helpers.py, as tests/adaptive_ff_layer/test_export_c.py), builds the harness
against it with ``clang -fsanitize=fuzzer,address,undefined`` and runs it (seed 1); prints, per precision, the
executions, libFuzzer's coverage (covered edges ``cov`` and features ``ft``) and whether it found anything (the
crash's report then). Needs clang with libFuzzer (Debian: ``apt-get install clang``). tests/adaptive_ff_layer/test_fuzz_c.py runs the
same for 15 s per precision.
"""

from __future__ import annotations

import argparse
import json
import pathlib
import shutil
import sys
import tempfile

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "tests"))
from export_c_helpers import ID_JSON, U_MAX, build_fuzzer, run_fuzzer  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=600.0, help="per precision (default 600)")
    ap.add_argument("--precision", choices=("double", "float", "both"), default="both")
    ap.add_argument("--corpus", type=pathlib.Path, default=None,
                    help="keep the corpus in this folder (default: a temporary one)")
    args = ap.parse_args(argv)
    if not args.seconds > 0:
        ap.error(f"--seconds must be > 0, got {args.seconds!r}")
    clang = shutil.which("clang")
    if clang is None:
        print("clang is not installed (apt-get install clang)", file=sys.stderr)
        return 2
    from controllers.cli.main import main as cli

    found = 0
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        (tmp / "id.json").write_text(json.dumps(ID_JSON))
        out = tmp / "drive_ff"
        assert cli(["export-c", "--from", str(tmp / "id.json"), "--u-max", str(U_MAX), "--out", str(out),
                    "--quiet"]) == 0
        precisions = ("double", "float") if args.precision == "both" else (args.precision,)
        print(f"{'build':<8}{'seconds':>9}{'executions':>13}{'cov':>7}{'ft':>8}  result")
        for p in precisions:
            exe = build_fuzzer(clang, out, tmp / f"fuzz_{p}", *(["-DAFF_FLOAT"] if p == "float" else []))
            corpus = (args.corpus / p) if args.corpus else tmp / f"corpus_{p}"
            r = run_fuzzer(exe, corpus, args.seconds)
            ok = r["returncode"] == 0
            found += not ok
            print(f"{p:<8}{args.seconds:>9.0f}{r['executions']:>13}{r['coverage']:>7}{r['features']:>8}  "
                  + ("nothing found" if ok else "FOUND (report below)"))
            if not ok:
                print(r["log"])
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
