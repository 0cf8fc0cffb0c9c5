"""benchmarks/zoo_estimators.py: the zoo joint by joint, each estimator against the default.

Constructed results of ``benchmarks/zoo.py --json`` (four joints, eta chosen by hand) whose counts follow from the
definitions: below ``min(reference, 1) - gap``, below the reference raw, worse than none, the hand-over count.
"""

import importlib.util
import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("zoo_estimators", ROOT / "benchmarks" / "zoo_estimators.py")
zoo_estimators = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(zoo_estimators)


def _write(path, estimator, adaptive, dob):
    d = {"plants": [{} for _ in adaptive], "eta": {"adaptive": adaptive, "adaptive-dob": dob},
         "options": {"compare": {"estimator": estimator, "seed": 3}}}
    path.write_text(json.dumps(d, allow_nan=False))
    return str(path)


def test_counts_follow_the_definitions(tmp_path):
    # joint 0: reference beyond the frictionless loop (1.5); 0.95 is 0.55 below it raw but only 0.05 below 1
    # joint 1: 0.85 against 0.99: below by 0.14 both ways; joint 2: eta undefined (None): not counted
    # joint 3: worse than none (-0.05) against 0.9, and adaptive-dob >= 0.95 there with adaptive < 0.8
    ref = _write(tmp_path / "s.json", "sliding", [1.5, 0.99, None, 0.9], [0.99, 0.99, None, 0.96])
    other = _write(tmp_path / "e.json", "eq4", [0.95, 0.85, 0.5, -0.05], [0.99, 0.97, 0.4, 0.96])
    lines = zoo_estimators.compare_files([ref, other], gap=0.1)
    row = next(x for x in lines if x.startswith("eq4") and " adaptive " in x)
    cells = row.split()
    assert cells[2:6] == ["3", "2", "3", "1"]  # joints, below min(ref, 1) - 0.1, below raw, worse than none
    assert "2 of 3" in row  # adaptive >= 0.8 where adaptive-dob >= 0.95: joints 0 and 1 of 0, 1, 3
    assert "#3: -0.050 / 0.900" in row and "#1: 0.850 / 0.990" in row and "#0" not in row
    own = next(x for x in lines if x.startswith("sliding") and " adaptive " in x)
    assert own.split()[2:6] == ["3", "0", "0", "0"]


def test_a_file_that_is_not_a_zoo_result_is_refused(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text("{}")
    with pytest.raises(SystemExit, match="bad.json: not a benchmarks/zoo.py --json result"):
        zoo_estimators.compare_files([str(bad)])
    with pytest.raises(SystemExit, match="cannot read a zoo result"):
        zoo_estimators.compare_files([str(tmp_path / "missing.json")])


def test_quantile_rows_follow_the_definitions(tmp_path):
    # eta defined on joints 0, 1, 3 of the reference: sorted 0.9, 0.99, 1.5; numpy's default (linear) quantiles
    # by hand: q05 at position 0.1 -> 0.9 + 0.1*0.09, q25 at 0.5 -> 0.945, the median 0.99
    ref = _write(tmp_path / "s.json", "sliding", [1.5, 0.99, None, 0.9], [0.99, 0.99, None, 0.96])
    # the other: sorted -0.05, 0.5, 0.85, 0.95: q05 at 0.15 -> -0.05 + 0.15*0.55, q25 at 0.75, the median at 1.5
    other = _write(tmp_path / "e.json", "eq4", [0.95, 0.85, 0.5, -0.05], [0.99, 0.97, 0.4, 0.96])
    rows = zoo_estimators.quantile_rows([ref, other], gap=0.1)
    assert rows[2] == "| seed 3, 3 joints | sliding | adaptive | 0.900 | 0.909 | 0.945 | 0.990 | 0 |  |"
    # below min(reference, 1) - 0.1 where both are defined: joints 1 (0.85 < 0.89) and 3 (-0.05 < 0.8)
    assert rows[4] == "| seed 3, 4 joints | eq4 | adaptive | -0.050 | 0.033 | 0.362 | 0.675 | 1 | 2 |"
    assert len(rows) == 2 + 4  # the header, and adaptive and adaptive-dob of each file
