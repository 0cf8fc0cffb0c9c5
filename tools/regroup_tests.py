#!/usr/bin/env python3
"""Group the test files of ``tests/`` by the layer they test; run from the repository root::

    python tools/regroup_tests.py            # move, rewrite, check; then review ``git status`` and commit
    python tools/regroup_tests.py --count    # the same, with the suite collected before and after (about 3 min)
    python tools/regroup_tests.py --dry-run  # print what it would do, change nothing
    python tools/regroup_tests.py --check    # only the checks (exit 1 on a problem)
    python tools/regroup_tests.py --explain  # every file: its folder in the table and by the rule

It is idempotent and meant to be run again after merging branches that add or change flat test files
(``tests/test_*.py``): a file already in a folder stays where it is, and every reference is rewritten again.

1. Each flat ``tests/test_*.py`` gets its folder from :data:`FOLDER_OF`; a file not in the table gets it from
   :func:`rule_folder` (printed, for a human to check and add to the table). A test file that imports another test
   module goes to that module's folder (printed); two table entries that disagree so are an error.
2. ``git mv`` to ``tests/<folder>/``; in the moved file each ``Path(__file__)`` parent expression goes one level up
   (``.parent`` -> ``.parents[1]``, ``.parent.parent`` and ``.parents[1]`` -> ``.parents[2]``), so that it points
   where it pointed (the repository root, ``tests/`` and its helpers and data).
3. References ``tests/test_NAME.py`` (also ``tests/test_NAME::...`` and the module form ``tests.test_NAME``) to a
   grouped file are rewritten to ``tests/<folder>/test_NAME.py`` in README.md, CHANGELOG.md (its "Unreleased"
   section only), pyproject.toml, setup.py, .ci/, docs/, benchmarks/, examples/, plant/, adaptive_ff/, controllers/
   and tests/ (tracked text files).
4. tests/conftest.py puts ``tests/`` on ``sys.path`` (inserted when missing), so that the grouped files import the
   shared helpers (oracles, ``doc_commands``, ``golden_cases``, ...), which stay in ``tests/`` with the data
   (``tests/golden/``, ``tests/*.json``, ``tests/fuzz_aff.c``). Its ``SLOW_FILES`` names files by base name, which a
   move does not change.
5. Checks: test base names are unique (pytest imports them by base name), no folder is named like an importable
   module, and in a grouped file no ``Path(__file__)`` expression points into the file's own folder, sets ``ROOT`` to
   anything but the repository root, or starts a path (``/ "name"``) that does not exist (a line that came in by a
   merge, written for the flat layout).
"""

from __future__ import annotations

import argparse
import ast
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path.cwd()
TESTS = ROOT / "tests"

#: The folders under tests/ and what their files test.
FOLDERS = {
    "plant_layer": "plant: friction maps, joint dynamics and its C steps, plant variants, stiff steps, references",
    "adaptive_ff_layer": "adaptive_ff: identification, logs and files, the compensation (feedforward, estimators, "
                         "gates, supervisor), the drive's C code and its export",
    "controllers_layer": "controllers: the engine and batch runs, PI design, peers, experiments (compare, zoo, "
                         "sweep, scenarios), metrics, figures and reports, golden records",
    "docs_cli": "the product as a whole: README and docs run as written, examples, the command line, the "
                "architecture and the project's rules",
}

#: The table: test file -> folder. Tests of one layer's component through a higher layer (an estimator run in the
#: engine's loop) go with the component's layer.
FOLDER_OF = {name: folder for folder, names in {
    "plant_layer": """
        test_batch_packing test_motion_references test_plant test_plant_kernels test_plant_options
        test_plant_variants test_results test_static_stick test_stiff_lagged test_stiff_lugre
        test_stiff_lugre_damping test_stribeck_slope""",
    "adaptive_ff_layer": """
        test_arm test_arm_export test_arm_tx40 test_bad_input_components test_closed_loop_id
        test_closed_loop_logs test_compensation_estimator test_compensation_faults test_configs
        test_counters_at_maximum test_covariance test_data test_diagnostics test_drive_guard
        test_emps_crosstest test_emps_validation test_eq4_component test_eq4_determinacy test_export_c
        test_export_c_drive_grade test_export_c_joints test_export_c_options test_fast_start test_fuzz_c
        test_fuzz_readers test_gates test_identification_file test_identification_pin
        test_identification_results test_identify_emps test_identify_identifiability test_identify_idim
        test_identify_method test_idim test_io test_ivrls test_lag_memory test_lag_profile
        test_lag_zero_projection test_loop_model test_model_error test_model_forms test_oe_no_prefit
        test_oe_sensitivity test_online_ukf test_output test_physical_id test_plausibility
        test_point_to_point_adaptive test_prefit_pipeline test_prefit_robust test_real_logs test_regression
        test_residual_bootstrap test_rest_withdrawal test_rls test_sign_observer test_simulator
        test_steady_state test_steady_state_check test_stribeck_fit test_supervisor test_supervisor_restore
        test_supervisor_tracking test_switch_on_robust test_units_table test_windup""",
    "controllers_layer": """
        test_adaptive_dob test_batch test_closed_loop test_compare_faults test_compare_offline_json
        test_compare_user_loop test_compensation_helper test_compensation_regression test_edge_inputs
        test_engine_golden test_engine_results test_estimator_rows test_exported_library test_figures_quality
        test_first_inertia test_golden test_kalman_loop test_kernel_adaptive test_metrics
        test_metrics_whole_run test_motion_metrics test_paper_figures test_peer_components test_peers test_pi
        test_pi_pickle test_properties test_quasi_static test_regression_models test_report
        test_residual_cutoff test_scenario test_sensor_drive test_sweep test_switch_in test_user_compensator
        test_user_compensator_faults test_zoo test_zoo_estimators""",
    "docs_cli": """
        test_architecture test_atomic_commands test_c_layers test_cli test_cli_design test_cli_errors
        test_cli_regressions test_cli_stribeck test_cli_units test_docs test_examples test_fuzz_cli
        test_lazy_imports test_no_truth test_own_loop_example test_present_tense test_readme
        test_runs_anywhere test_special_files test_work_bounds test_your_drive""",
}.items() for name in names.split()}

#: The rule for a file not in the table, first match wins: a name prefix of the product-level tests; else the
#: layer the module docstring names first (``plant``, ``adaptive_ff``, ``controllers`` as a module or a path);
#: else the deepest layer the file imports; else docs_cli (a test that imports no layer: docs, architecture).
NAME_PREFIXES = (("test_cli", "docs_cli"), ("test_doc", "docs_cli"), ("test_readme", "docs_cli"),
                 ("test_example", "docs_cli"), ("test_architecture", "docs_cli"), ("test_present_tense", "docs_cli"))
LAYERS = ("plant", "adaptive_ff", "controllers")  # lowest first
LAYER_FOLDER = {"plant": "plant_layer", "adaptive_ff": "adaptive_ff_layer", "controllers": "controllers_layer"}
DOC_LAYER = re.compile(r"\b(plant|adaptive_ff|controllers)[./]\w")

#: Where references to test files are rewritten (tracked text files); CHANGELOG.md only in its "Unreleased" section.
REFERENCE_ROOTS = ("README.md", "CHANGELOG.md", "pyproject.toml", "setup.py", ".ci", "docs", "benchmarks",
                   "examples", "plant", "adaptive_ff", "controllers", "tests")

#: ``Path(__file__)`` followed by parent steps: ``.parent`` (one or more) or ``.parents[n]``, optionally resolved.
FILE_EXPR = re.compile(r"(?P<base>(?:pathlib\.)?Path\(__file__\))(?P<res>\.resolve\(\))?"
                       r"(?P<up>(?:\.parent(?![s\w]))+|\.parents\[(?P<n>\d+)\])")
#: The literal path parts after an expression: ``/ "examples" / "x.toml"``.
TAIL = re.compile(r"""\s*/\s*(["'])([^"'\n]+)\1""")
PATH_REF = re.compile(r"(?<![\w.-])tests/(test_\w+)")
MODULE_REF = re.compile(r"(?<![\w.-])tests\.(test_\w+)\b")
CONFTEST_PATH_BLOCK = '''
#: tests/: the shared helpers (oracles, doc_commands, golden_cases, ...) and data beside this file. The test files are
#: grouped in folders below (tools/regroup_tests.py); every one of them imports the helpers by module name.
TESTS = Path(__file__).resolve().parent
if str(TESTS) not in sys.path:
    sys.path.insert(0, str(TESTS))
'''


def git(*args: str) -> str:
    return subprocess.run(["git", *args], cwd=ROOT, check=True, capture_output=True, text=True).stdout


def flat_tests() -> list[Path]:
    """The tracked test files directly in tests/ (untracked ones are named, not moved)."""
    tracked = {ROOT / p for p in git("ls-files", "tests").split()}
    flat = sorted(p for p in TESTS.glob("test_*.py"))
    for p in flat:
        if p not in tracked:
            print(f"NOT MOVED (untracked, git add it first): {p.relative_to(ROOT)}")
    return [p for p in flat if p in tracked]


def grouped_tests() -> dict[str, Path]:
    """Test module name -> path, for the files already in a folder."""
    return {p.stem: p for folder in FOLDERS for p in sorted((TESTS / folder).glob("test_*.py"))}


def imported_names(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            names.add(node.module)
    return names


def rule_folder(path: Path) -> tuple[str, str]:
    """The folder of a file not in the table, and why (see NAME_PREFIXES)."""
    for prefix, folder in NAME_PREFIXES:
        if path.stem.startswith(prefix):
            return folder, f"name starts with {prefix}"
    doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or ""
    m = DOC_LAYER.search(doc)
    if m:
        return LAYER_FOLDER[m[1]], f"its docstring names {m[1]} first"
    layers = {n.split(".")[0] for n in imported_names(path)} & set(LAYERS)
    if layers:
        deepest = max(layers, key=LAYERS.index)
        return LAYER_FOLDER[deepest], f"the deepest layer it imports is {deepest}"
    return "docs_cli", "it imports no layer"


def plan(flat: list[Path], grouped: dict[str, Path]) -> dict[Path, str]:
    """Flat file -> folder; a file that imports a test module follows it (see the module docstring)."""
    dest, why = {}, {}
    for p in flat:
        if p.stem in FOLDER_OF:
            dest[p.stem], why[p.stem] = FOLDER_OF[p.stem], "table"
        else:
            dest[p.stem], why[p.stem] = rule_folder(p)
    where = {**{m: p.parent.name for m, p in grouped.items()}, **dest}
    for p in flat:
        for other in sorted(imported_names(p) & set(where) - {p.stem}):
            if where[other] != dest[p.stem]:
                if why[p.stem] == "table":
                    sys.exit(f"ERROR: {p.name} ({dest[p.stem]} in the table) imports {other} ({where[other]}): "
                             f"put them in one folder in FOLDER_OF")
                dest[p.stem], why[p.stem] = where[other], f"it imports the test module {other}"
    for p in flat:
        if why[p.stem] != "table":
            print(f"NOT IN THE TABLE, check: {p.name} -> tests/{dest[p.stem]}/ ({why[p.stem]})")
    return {p: dest[p.stem] for p in flat}


def deeper(text: str) -> str:
    """Every ``Path(__file__)`` parent expression of a file moved one folder down, pointing where it pointed."""
    def one(m):
        n = int(m["n"]) + 1 if m["n"] is not None else m["up"].count(".parent")
        return f"{m['base']}{m['res'] or ''}.parents[{n}]"
    return FILE_EXPR.sub(one, text)


def move(moves: dict[Path, str], dry_run: bool) -> None:
    for src, folder in moves.items():
        dst = TESTS / folder / src.name
        print(f"git mv {src.relative_to(ROOT)} {dst.relative_to(ROOT)}")
        if dry_run:
            continue
        dst.parent.mkdir(exist_ok=True)
        git("mv", str(src.relative_to(ROOT)), str(dst.relative_to(ROOT)))
        text = dst.read_text(encoding="utf-8")
        new = deeper(text)
        if new != text:
            dst.write_text(new, encoding="utf-8")
            print(f"  Path(__file__) one level deeper in {dst.relative_to(ROOT)}")


def reference_files() -> list[Path]:
    out = []
    for rel in git("ls-files", "--", *REFERENCE_ROOTS).splitlines():
        p = ROOT / rel
        if p.is_file() and not p.is_symlink():
            try:
                p.read_text(encoding="utf-8")
            except UnicodeDecodeError:
                continue
            out.append(p)
    return out


def rewrite_refs(text: str, grouped: dict[str, Path], unknown: set[str]) -> str:
    def path_ref(m):
        if m[1] in grouped:
            return f"tests/{grouped[m[1]].parent.name}/{m[1]}"
        if not (TESTS / f"{m[1]}.py").exists():
            unknown.add(m[0])
        return m[0]

    def module_ref(m):
        return f"tests.{grouped[m[1]].parent.name}.{m[1]}" if m[1] in grouped else m[0]
    return MODULE_REF.sub(module_ref, PATH_REF.sub(path_ref, text))


def unreleased_span(text: str) -> tuple[int, int]:
    """Start and end of CHANGELOG.md's "Unreleased" section (empty when it has none)."""
    m = re.search(r"^## \[?Unreleased\]?.*$", text, re.M | re.I)
    if not m:
        return 0, 0
    nxt = re.compile(r"^## ", re.M).search(text, m.end())
    return m.start(), nxt.start() if nxt else len(text)


def rewrite_references(grouped: dict[str, Path], dry_run: bool) -> None:
    unknown: set[str] = set()
    for p in reference_files():
        text = p.read_text(encoding="utf-8")
        if p == ROOT / "CHANGELOG.md":
            a, b = unreleased_span(text)
            new = text[:a] + rewrite_refs(text[a:b], grouped, unknown) + text[b:]
        else:
            new = rewrite_refs(text, grouped, unknown)
        if new != text:
            n = sum(1 for x, y in zip(text.splitlines(), new.splitlines()) if x != y)
            print(f"references rewritten: {p.relative_to(ROOT)} ({n} lines)")
            if not dry_run:
                p.write_text(new, encoding="utf-8")
    for ref in sorted(unknown):
        print(f"NOTE: a reference to a test file that does not exist: {ref}")


def ensure_conftest_path(dry_run: bool) -> None:
    """tests/conftest.py puts tests/ on sys.path (CONFTEST_PATH_BLOCK after its imports), once."""
    conftest = TESTS / "conftest.py"
    text = conftest.read_text(encoding="utf-8")
    if "sys.path.insert(0, str(TESTS))" in text:
        return
    m = re.search(r"^import pytest\n", text, re.M)
    if not m:
        sys.exit("ERROR: tests/conftest.py has no top-level 'import pytest': put tests/ on sys.path there by hand")
    new = text[:m.end()] + CONFTEST_PATH_BLOCK + text[m.end():]
    if not re.search(r"^import sys$", new, re.M):
        new = re.sub(r"^from pathlib import Path$", "import sys\nfrom pathlib import Path", new, count=1, flags=re.M)
    print("tests/conftest.py: tests/ put on sys.path")
    if not dry_run:
        conftest.write_text(new, encoding="utf-8")


def file_expr_problems(path: Path) -> list[str]:
    """The ``Path(__file__)`` expressions of a grouped file that look written for the flat layout."""
    text, out = path.read_text(encoding="utf-8"), []
    here = path.resolve()
    for m in FILE_EXPR.finditer(text):
        n = int(m["n"]) + 1 if m["n"] is not None else m["up"].count(".parent")
        target = here.parents[n - 1]
        line = text.count("\n", 0, m.start()) + 1
        tail = TAIL.match(text, m.end())
        assigned = re.search(r"(\w+)\s*=\s*$", text[text.rfind("\n", 0, m.start()) + 1:m.start()])
        if tail and not (target / tail[2].split("/")[0]).exists():
            out.append(f"{path.relative_to(ROOT)}:{line}: {m[0]} / {tail[2]!r} does not exist")
        elif not tail and target == here.parent:
            out.append(f"{path.relative_to(ROOT)}:{line}: {m[0]} is the file's own folder")
        elif not tail and assigned and assigned[1] == "ROOT" and target != ROOT.resolve():
            out.append(f"{path.relative_to(ROOT)}:{line}: ROOT = {m[0]} is not the repository root")
    for i, line in enumerate(text.splitlines(), 1):
        rest = FILE_EXPR.sub("", line).replace("Path(__file__).name", "")
        if re.search(r"(?<![.\w])__file__", rest):
            out.append(f"{path.relative_to(ROOT)}:{i}: __file__ used in a way this script does not rewrite: "
                       f"{line.strip()[:90]}")
    return out


def check() -> list[str]:
    problems = []
    names: dict[str, list[Path]] = {}
    for p in list(TESTS.glob("test_*.py")) + [p for f in FOLDERS for p in (TESTS / f).glob("test_*.py")]:
        names.setdefault(p.stem, []).append(p)
    problems += [f"two test files named {n}.py: {', '.join(str(p.relative_to(ROOT)) for p in ps)}"
                 for n, ps in sorted(names.items()) if len(ps) > 1]
    modules = {p.stem for p in TESTS.glob("*.py")} | set(LAYERS)
    problems += [f"folder tests/{f}/ shadows the module {f}" for f in FOLDERS if f in modules]
    for folder in FOLDERS:
        for p in sorted((TESTS / folder).glob("*.py")):
            problems += file_expr_problems(p)
            for other in sorted(imported_names(p) & set(names) - {p.stem}):
                if names[other][0].parent != p.parent:
                    problems.append(f"{p.relative_to(ROOT)} imports {other}, which is in "
                                    f"{names[other][0].parent.relative_to(ROOT)}/")
    return problems


def collect(*opts: str) -> set[str]:
    """The test ids pytest collects, each with its file's base name (the folder left out)."""
    r = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider", *opts],
                       cwd=ROOT, capture_output=True, text=True)
    lines = r.stdout.strip().splitlines()
    print(f"  python -m pytest --collect-only -q {' '.join(opts)}: {lines[-1] if lines else r.stderr[-300:]}")
    return {Path(x.split("::")[0]).name + "::" + x.split("::", 1)[1] for x in lines if "::" in x}


COUNT_RUNS = ((), ("--run-slow",), ("-m", "slow"))


def explain(flat: list[Path], grouped: dict[str, Path]) -> None:
    for p in sorted(flat + list(grouped.values()), key=lambda p: p.name):
        table = FOLDER_OF.get(p.stem, "-")
        folder, why = rule_folder(p)
        mark = "" if table in ("-", folder) else "   <- the rule differs"
        print(f"{p.name:40s} table {table:18s} rule {folder:18s} ({why}){mark}")


def summary() -> None:
    print("folder                 files")
    for folder, what in FOLDERS.items():
        print(f"tests/{folder + '/':19s} {len(list((TESTS / folder).glob('test_*.py'))):4d}  {what}")
    left = sorted(p.name for p in TESTS.glob("test_*.py"))
    print(f"tests/ (flat)          {len(left):4d}  {' '.join(left)}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--dry-run", action="store_true", help="print what would change, change nothing")
    ap.add_argument("--check", action="store_true", help="only the checks")
    ap.add_argument("--explain", action="store_true", help="every file's folder in the table and by the rule")
    ap.add_argument("--count", action="store_true", help="collect the suite before and after and compare the ids")
    args = ap.parse_args()
    if not (TESTS / "conftest.py").is_file() or not (ROOT / "pyproject.toml").is_file():
        sys.exit("run from the repository root: python tools/regroup_tests.py")
    flat, grouped = flat_tests(), grouped_tests()
    if args.explain:
        explain(flat, grouped)
        return 0
    if not args.check:
        moves = plan(flat, grouped)
        before = [collect(*o) for o in COUNT_RUNS] if args.count and not args.dry_run else None
        move(moves, args.dry_run)
        ensure_conftest_path(args.dry_run)
        grouped = grouped_tests() if not args.dry_run else {**grouped, **{p.stem: TESTS / f / p.name
                                                                         for p, f in moves.items()}}
        rewrite_references(grouped, args.dry_run)
        if before is not None:
            after = [collect(*o) for o in COUNT_RUNS]
            for opts, b, a in zip(COUNT_RUNS, before, after):
                same = "the same ids" if a == b else f"DIFFERENT: {len(b - a)} lost, {len(a - b)} new"
                print(f"  {' '.join(opts) or '(quick)':10s} before {len(b)}, after {len(a)}: {same}")
        summary()
    problems = check()
    for p in problems:
        print("PROBLEM:", p)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
