"""The scripts in examples/ run (fast settings) and print what they promise."""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"


def _run(*args, timeout=120):
    r = subprocess.run([sys.executable, *map(str, args)], cwd=ROOT, capture_output=True, text=True, timeout=timeout,
                       env={**__import__("os").environ, "MPLBACKEND": "Agg"})
    assert r.returncode == 0, r.stdout + r.stderr
    return r.stdout


def test_simulation_benchmark():
    out = _run(EXAMPLES / "simulation_benchmark.py", "--seeds", "2", "--duration", "6", "--Vs", "0.02", "--delta", "1")
    lines = {ln.split()[0]: ln for ln in out.splitlines() if ln.strip()}
    for mode in ("none", "fixed", "adaptive", "oracle", "frictionless"):
        assert mode in lines
    assert lines["none"].split()[-3] == "0.000" and lines["frictionless"].split()[-3] == "1.000"  # eta


def test_controller_design(tmp_path):
    out = _run(EXAMPLES / "controller_design.py", "--J", "4", "--crossovers", "10", "20", "--plot", "20",
               "--out", tmp_path)
    rows = [ln.split() for ln in out.splitlines() if ln.strip() and ln.split()[0] in ("10", "20")]
    assert [r[3] for r in rows] == ["60.00", "60.00"]  # achieved phase margin
    assert (tmp_path / "bode.png").exists() and (tmp_path / "step.png").exists()


def test_tracking_regression_example_passes():
    out = _run("-m", "pytest", "-q", "-p", "no:cacheprovider", EXAMPLES / "test_tracking_regression.py")
    assert "3 passed" in out


def test_lugre_model_example_runs_its_compensator_beside_adaptive_dob():
    out = _run(EXAMPLES / "lugre_model.py", "--duration", "20")
    rows = {ln.split()[0]: ln.split() for ln in out.splitlines() if ln.strip()}
    assert "lugre-model" in rows and "adaptive-dob" in rows
    eta_own, eta_adob = float(rows["lugre-model"][5]), float(rows["adaptive-dob"][5])
    assert 0.5 < eta_own < eta_adob  # the model-based feedforward helps, the adaptive composite more
    assert len((EXAMPLES / "lugre_model.py").read_text().splitlines()) <= 80
