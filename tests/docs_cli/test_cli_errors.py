"""``adaptive-ff`` never shows a traceback: every bad input exits 2 naming the file, argument, row or value.

Each case runs ``main()`` in-process (fast) and checks the exit status and the
one-line message; one subprocess case checks that stderr holds no traceback at all.
"""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from controllers.cli.main import main

ROOT = Path(__file__).resolve().parents[2]
CLI = "import sys; from controllers.cli import main; sys.exit(main())"
PAPER = {"J": 4.0, "Fc": 25.0, "Fs": 35.0, "Vs": 0.02, "delta": 1.0, "sigma": 40.0, "tau": 0.02}


def _err(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return err


def _log(path, cells, n=200):
    t = np.arange(n) * 1e-3
    u = np.sin(7 * t) * 30 + 5 * np.sign(np.sin(3 * t))
    w = np.cos(7 * t)
    rows = ["t,u,w"] + [f"{float(a)!r},{float(b)!r},{float(c)!r}" for a, b, c in zip(t, u, w)]
    for (row, col), text in cells.items():
        parts = rows[row].split(",")
        parts[col] = text
        rows[row] = ",".join(parts)
    path.write_text("\n".join(rows) + "\n")
    return path


@pytest.mark.parametrize("command", ["identify", "stribeck"])
def test_empty_mat_and_truncated_npz(tmp_path, capsys, command):
    empty = tmp_path / "empty.mat"
    empty.write_bytes(b"")
    t = np.arange(100) * 1e-3
    good = tmp_path / "good.npz"
    np.savez(good, t=t, u=np.sin(t), w=np.cos(t))
    trunc = tmp_path / "trunc.npz"
    trunc.write_bytes(good.read_bytes()[: good.stat().st_size // 2])
    extra = ["--no-figures"] if command == "stribeck" else []
    assert main([command, str(empty), *extra]) == 2
    assert f"{empty}: not a readable MATLAB .mat file (the file is empty (0 bytes))" in _err(capsys)
    assert main([command, str(trunc), *extra]) == 2
    assert f"{trunc}: not a readable NumPy .npz file" in _err(capsys)


def test_plant_file_directory_non_utf8_and_nan(tmp_path, capsys):
    assert main(["compare", "--plant", str(tmp_path), "--no-figures", "--quiet"]) == 2
    assert f"{tmp_path}: is a directory, expected a plant file" in _err(capsys)
    bad = tmp_path / "latin1.json"
    bad.write_bytes('{"J": 4, "note": "Ü"}'.encode("latin-1"))
    assert main(["compare", "--plant", str(bad), "--no-figures", "--quiet"]) == 2
    assert f"{bad}: not a UTF-8 text file (byte 18" in _err(capsys)
    nan = tmp_path / "nan.json"
    nan.write_text(json.dumps({**PAPER, "J": float("nan")}))
    assert main(["compare", "--plant", str(nan), "--no-figures", "--quiet"]) == 2
    assert "NaN is not valid JSON" in _err(capsys)


@pytest.mark.parametrize("key, value, message", [
    ("J", 1e308, "J = 1e+308 is outside the plausible range 1e-09..1e+09"),
    ("J", 1e-12, "J = 1e-12 is outside the plausible range 1e-09..1e+09"),
    ("sigma", 1e9, "mechanical time constant J/sigma = 4e-09 s, below half the simulation step 0.001 s"),
    ("J", 10**400, "int too large to convert to float"),  # an integer beyond the float range
])
def test_implausible_plants_get_a_range_message(tmp_path, capsys, monkeypatch, key, value, message):
    import controllers.experiments.compare as cmp

    monkeypatch.setattr(cmp, "compare", lambda *a, **k: pytest.fail("simulation started"))
    f = tmp_path / "plant.json"
    f.write_text(json.dumps({**PAPER, key: value}))
    for argv in (["compare", "--plant", str(f), "--no-figures", "--quiet"], ["paper-figures", "--plant", str(f)]):
        assert main(argv) == 2
        err = _err(capsys)
        assert str(f) in err and message in err
        assert "samples" not in err


def test_design_rejects_implausible_inertia(capsys):
    assert main(["design", "--J", "1e308", "--no-figures"]) == 2
    assert "J = 1e+308 kg·m² (from command line) is outside the plausible range" in _err(capsys)


@pytest.mark.parametrize("argv", [["compare", "--seed", "-1"], ["paper-figures", "--seed", "x"],
                                  ["sweep", "s.json", "--workers", "0"], ["identify", "a.csv", "--skip-rows", "-2"]])
def test_bad_integers_are_usage_errors(capsys, argv):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = _err(capsys)
    assert f"argument {argv[-2]}: must be" in err and repr(argv[-1]) in err


def test_outputs_are_checked_before_any_simulation(tmp_path, capsys, monkeypatch):
    import controllers.experiments.compare as cmp
    import controllers.experiments.paper_figures as pf

    monkeypatch.setattr(cmp, "compare", lambda *a, **k: pytest.fail("simulation started"))
    monkeypatch.setattr(pf, "paper_figures", lambda *a, **k: pytest.fail("simulation started"))
    existing = tmp_path / "taken"
    existing.write_text("x")
    cases = [["compare", "--out", str(existing)], ["compare", "--no-figures", "--report", str(existing)],
             ["compare", "--out", str(existing / "sub")], ["paper-figures", "--out", str(existing)],
             ["design", "--J", "4", "--out", str(existing)], ["stribeck", "x.csv", "--out", str(existing)],
             ["identify", "x.csv", "--plot", str(existing)], ["sweep", "x.json", "--out", str(tmp_path)]]
    for argv in cases:
        assert main(argv) == 2, argv
        err = _err(capsys)
        assert str(existing if "sweep" not in argv else tmp_path) in err and ("--out" in err or "--report" in err
                                                                               or "--plot" in err), err


def test_csv_with_1e308_is_blamed_on_the_cell(tmp_path, capsys):
    f = _log(tmp_path / "log.csv", {(17, 1): "1e308"})
    assert main(["identify", str(f)]) == 2
    err = _err(capsys)
    assert f"{f}: column 'u' (u), row 17 (line 18): value 1e+308 is outside the plausible range" in err
    assert "excitation" not in err
    f = _log(tmp_path / "t.csv", {(200, 0): "1e308"})
    assert main(["identify", str(f)]) == 2
    assert "column 't' (t), row 200 (line 201): time stamp 1e+308 jumps by" in _err(capsys)


def _spec(tmp_path, text):
    f = tmp_path / "spec.json"
    f.write_text(text if isinstance(text, str) else json.dumps(text))
    return f


@pytest.mark.parametrize("spec, message", [
    ("{'grid': {}}", "not valid JSON at line 1, column 2"),
    ([1, 2], "a sweep spec must be a JSON/TOML object"),
    ({"grid": {"Fc": 20}}, "grid['Fc'] must be a list of numbers, got 20"),
    ({"grid": {"Fc": [20, "a"]}}, "grid['Fc'] holds 'a', not a finite number"),
    ({"seeds": [-1]}, "every seed must be an integer >= 0, got -1"),
    ({"modes": ["adaptive", "magic"]}, "unknown mode(s) ['magic']"),
    ({"duration": "long"}, "duration must be a number > 0 (s), got 'long'"),
    ({"options": {"turbo": True}}, "options key(s) ['turbo'] unknown"),
    ({"monte_carlo": {"n": 2, "J": {"uniform": [2, 1]}}}, "need lo <= hi"),
    ({"monte_carlo": {"n": 10**9}}, "more than 1000000"),
    ({"plant": {"J": -4}}, "J must be > 0"),
    ({"grid": {"J": [1e-12]}}, "J = 1e-12 is outside the plausible range"),
])
def test_bad_sweep_specs(tmp_path, capsys, spec, message):
    f = _spec(tmp_path, spec)
    assert main(["sweep", str(f), "--out", str(tmp_path / "r.csv"), "--quiet"]) == 2
    err = _err(capsys)
    assert message in err, err
    assert not (tmp_path / "r.csv").exists()  # nothing ran


def test_unexpected_errors_become_one_line(capsys, monkeypatch):
    import controllers.cli.design as design

    def boom(args):
        raise RuntimeError("something\nbroke")

    monkeypatch.setattr(design, "run", boom)  # register() binds design.run when main() builds the parser
    assert main(["design", "--J", "4"]) == 1
    err = _err(capsys)
    assert err.count("\n") == 1 and "internal error: RuntimeError: something broke" in err


def test_version_preset_choices_and_units_option(capsys):
    from controllers.cli.data import PRESET_NAMES
    from plant.friction import PRESETS

    assert tuple(PRESETS) == PRESET_NAMES
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0 and capsys.readouterr().out.startswith("adaptive-ff ")
    with pytest.raises(SystemExit):
        main(["compare", "--help"])
    out = capsys.readouterr().out
    assert "--preset {paper}" in out and "--units {deg,rad}" in out
    with pytest.raises(SystemExit) as exc:
        main(["compare", "--preset", "nope"])
    assert exc.value.code == 2 and "invalid choice: 'nope' (choose from 'paper')" in _err(capsys)


def test_compare_table_units():
    from types import SimpleNamespace

    from controllers.cli.compare import comparison_table

    rows = [{"mode": "none", "rms": 0.01, "max": 0.05, "rms_reversal": 0.02, "u_rms": 30.0, "eta": 0.0},
            {"mode": "adaptive", "rms": 0.002, "max": 0.01, "rms_reversal": 0.004, "u_rms": 31.0,
             "eta": float("nan")}]
    comp = SimpleNamespace(rows=lambda: rows)
    deg = comparison_table(comp, SimpleNamespace(units="deg")).splitlines()
    rad = comparison_table(comp, SimpleNamespace(units="rad")).splitlines()
    assert "RMS [deg/s]" in deg[0] and "reversal RMS [deg/s]" in deg[0] and "u RMS [N·m]" in deg[0]
    assert "eta [-]" in deg[0] and "RMS [rad/s]" in rad[0]
    assert float(deg[2].split()[1]) == pytest.approx(np.rad2deg(0.01), abs=1e-4)
    assert float(rad[2].split()[1]) == pytest.approx(0.01, abs=1e-4)
    assert deg[3].split()[-1] == "n/a"


def test_design_report_holds_its_figures(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["design", "--J", "4", "--report", "rep"]) == 0
    assert (tmp_path / "rep" / "bode.png").is_file() and (tmp_path / "rep" / "step.png").is_file()
    assert not (tmp_path / "out").exists()


def test_no_traceback_in_a_real_process(tmp_path):
    empty = tmp_path / "e.mat"
    empty.write_bytes(b"")
    r = subprocess.run([sys.executable, "-c", CLI, "identify", str(empty)], cwd=ROOT,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert r.stderr.strip().splitlines() == [f"adaptive-ff: error: {empty}: not a readable MATLAB .mat file "
                                             "(the file is empty (0 bytes))"]
