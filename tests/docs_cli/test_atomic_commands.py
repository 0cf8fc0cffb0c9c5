"""Every command that writes files stages them: a failure part-way leaves the previous outputs byte for byte, and a
second run into an output in use is refused naming it (adaptive_ff.io.output).

Each output folder starts with the files a previous run left (every name the command writes, with old bytes) and a
file of the user's; a writer late in the command is made to fail (an ``OSError``, or Ctrl-C), and the folder must
hold exactly what it held before. Then a live process holds the output's lock and the command must refuse at once.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from adaptive_ff.io.output import lock_path
from controllers.cli.main import main

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from export_c_helpers import ID_JSON  # noqa: E402

COMPARE_FIGURES = ("tracking.png", "error.png", "friction.png", "eta.png")
IDENTIFY_FIGURES = ("ls_fit.png", "rls_fit.png", "rls_parameters.png", "sample_time.png")


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """The input files: a simulated 1 kHz log of the paper joint, Stribeck support points, an identification,
    a sweep spec."""
    from plant import preset, simulate

    d = tmp_path_factory.mktemp("inputs")
    t = np.arange(0.0, 6.0, 1e-3)
    u = 45.0 * np.sin(2 * np.pi * 0.5 * t) + 10.0 * np.sin(2 * np.pi * 3.1 * t)
    w = simulate(preset("paper"), u, dt=1e-3).w[:-1]
    np.savetxt(d / "log.csv", np.column_stack([t, u, w]), delimiter=",", header="t,u,w", comments="")
    ws = np.concatenate([-np.geomspace(1.0, 0.002, 8), np.geomspace(0.002, 1.0, 8)])
    F = np.sign(ws) * (25.0 + 10.0 * np.exp(-np.abs(ws / 0.02))) + 40.0 * ws
    np.savetxt(d / "points.csv", np.column_stack([ws, F]), delimiter=",", header="w,F", comments="")
    (d / "id.json").write_text(json.dumps(ID_JSON))
    (d / "spec.json").write_text(json.dumps({"preset": "paper", "seeds": [0], "modes": ["none"], "duration": 2.0,
                                             "options": {"Vs": 0.02, "delta": 1.0}}))
    return d


def _case(name, inputs, tmp):
    """``(argv, {output folder: names the command writes there}, dotted writer to fail late)`` of command
    ``name``."""
    out, rep = tmp / "out", tmp / "rep"
    return {
        "compare": (["compare", "--duration", "2", "--modes", "none", "--quiet", "--out", str(out), "--report",
                     str(rep)], {out: COMPARE_FIGURES, rep: ("report.html",)},
                    "controllers.report.html.compare_report"),
        "identify": (["identify", str(inputs / "log.csv"), "--quiet", "--plot", str(out), "--report", str(rep)],
                     {out: IDENTIFY_FIGURES, rep: ("report.html",)}, "controllers.report.html.identify_report"),
        "stribeck": (["stribeck", str(inputs / "points.csv"), "--points", "--out", str(out), "--report", str(rep)],
                     {out: ("fig08_stribeck.png", "support_points.csv"), rep: ("report.html",)},
                     "controllers.report.html.write_report"),
        "design": (["design", "--J", "4", "--out", str(out), "--report", str(rep)],
                   {out: ("bode.png", "step.png"), rep: ("report.html",)}, "controllers.report.html.write_report"),
        "paper-figures": (["paper-figures", "--sim-duration", "4", "--exp-duration", "6", "--speeds", "6", "--quiet",
                           "--save-data", "--out", str(out), "--report", str(rep)],
                          {out: ("fig04_ls_simulation.png", "fig08_stribeck.png", "robot_log.csv", "plant.json"),
                           rep: ("report.html",)}, "controllers.report.html.write_report"),
        "export-c": (["export-c", "--from", str(inputs / "id.json"), "--u-max", "100", "--out", str(out), "--force",
                      "--quiet"], {out: ("aff.h", "aff.c", "aff_config.h", "aff_config.c", "example_loop.c",
                                         "Makefile")}, None),
    }[name]


def _previous(folders) -> dict:
    """Fill each folder with old bytes under every name the command writes, and a file of the user's."""
    for folder, names in folders.items():
        folder.mkdir(parents=True, exist_ok=True)
        for n in names:
            (folder / n).write_bytes(b"previous run: " + n.encode())
        (folder / "notes.txt").write_bytes(b"the user's notes")
    return {f: _tree(f) for f in folders}


def _tree(folder) -> dict:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def _fail_late(monkeypatch, writer, error):
    """Make ``writer`` (dotted name; None: the write of ``aff_config.c``, the fourth exported file) raise ``error``."""
    def boom(*args, **kwargs):
        raise error

    if writer is not None:
        module, name = writer.rsplit(".", 1)
        monkeypatch.setattr(f"{module}.{name}", boom)
        return
    real = Path.write_text

    def write_text(self, *args, **kwargs):
        if self.name == "aff_config.c":
            raise error
        return real(self, *args, **kwargs)

    monkeypatch.setattr(Path, "write_text", write_text)


COMMANDS = ["compare", "identify", "stribeck", "design", "paper-figures", "export-c"]


@pytest.mark.parametrize("name", COMMANDS)
@pytest.mark.parametrize("error, status", [(OSError(28, "No space left on device"), 2), (KeyboardInterrupt(), 130)])
def test_a_failure_part_way_leaves_the_previous_outputs(name, error, status, inputs, tmp_path, monkeypatch, capsys):
    argv, folders, writer = _case(name, inputs, tmp_path)
    before = _previous(folders)
    _fail_late(monkeypatch, writer, error)
    assert main(argv) == status
    err = capsys.readouterr().err
    assert "Traceback" not in err and ("No space left" in err if status == 2 else "interrupted" in err)
    assert {f: _tree(f) for f in folders} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(f.name for f in folders)  # no staging, no lock


@pytest.mark.parametrize("name", ["compare", "design", "export-c"])
def test_a_successful_run_replaces_its_files_and_keeps_the_users(name, inputs, tmp_path, capsys):
    argv, folders, _ = _case(name, inputs, tmp_path)
    before = _previous(folders)
    assert main(argv) == 0
    out = capsys.readouterr().out
    for folder, names in folders.items():
        after = _tree(folder)
        assert after["notes.txt"] == b"the user's notes"
        assert all(after[n] != before[folder][n] for n in names)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(f.name for f in folders)
    if name != "export-c":
        assert f"report: {tmp_path / 'rep' / 'report.html'}" in out  # the final path, not the staging folder's


@pytest.fixture
def live_pid():
    proc = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(120)"])
    yield proc.pid
    proc.kill()
    proc.wait()


@pytest.mark.parametrize("name", COMMANDS + ["sweep"])
def test_a_second_run_into_an_output_in_use_refuses_naming_it(name, inputs, tmp_path, live_pid, monkeypatch, capsys):
    if name == "sweep":
        out = tmp_path / "results.csv"
        argv, option = ["sweep", str(inputs / "spec.json"), "--out", str(out), "--quiet", "--workers", "1"], "--out"
    else:
        argv, folders, _ = _case(name, inputs, tmp_path)
        out = next(iter(folders))
        option = "--plot" if name == "identify" else "--out"
    lock = lock_path(out)
    lock.write_text(f"{live_pid}\n")
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"adaptive-ff: error: {option} {out}: in use by another adaptive-ff run (process {live_pid}" in err
    assert "Traceback" not in err and lock.read_text() == f"{live_pid}\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == [lock.name]  # nothing written


def test_sweep_summary_is_replaced_whole(inputs, tmp_path, monkeypatch, capsys):
    out = tmp_path / "results.csv"
    argv = ["sweep", str(inputs / "spec.json"), "--out", str(out), "--quiet", "--workers", "1"]
    assert main(argv) == 0
    summary = Path(f"{out}.summary.json")
    before = summary.read_bytes()
    real = json.dump

    def half_then_fail(obj, fh, **kw):  # a disk that fills up in the middle of the summary
        fh.write('{"modes": ')
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(json, "dump", half_then_fail)
    assert main(argv) == 2
    monkeypatch.setattr(json, "dump", real)
    assert summary.read_bytes() == before and json.loads(before)["n_cases"] == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results.csv", "results.csv.summary.json"]


def test_a_stale_lock_of_a_crashed_run_is_taken_over(inputs, tmp_path, capsys):
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    out = tmp_path / "out"
    lock_path(out).write_text(f"{dead.pid}\n")
    assert main(["design", "--J", "4", "--out", str(out), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["figures"] == [str(out / "bode.png"), str(out / "step.png")]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"] and sorted(os.listdir(out)) == ["bode.png",
                                                                                                 "step.png"]
