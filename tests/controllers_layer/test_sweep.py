"""Sweeps: case expansion, local parallel == serial, resumability after a crash, Dask LocalCluster == local."""

import csv

import pytest

from controllers.experiments.sweep import expand_cases, load_spec, run_sweep

SPEC = {"preset": "paper", "grid": {"Fc": [20.0, 30.0]}, "seeds": [0, 1], "modes": ["none", "adaptive"],
        "duration": 4.0, "options": {"Vs": 0.02, "delta": 1.0}}


def _rows(path):
    with open(path, newline="") as fh:
        return sorted((r["case_id"], r["mode"], float(r["rms"]), float(r["eta"])) for r in csv.DictReader(fh))


def test_expand_cases_grid_monte_carlo_and_ids():
    spec = load_spec({**SPEC, "controller": {"crossover": [10, 20]},
                      "monte_carlo": {"n": 3, "seed": 5, "sigma": {"uniform": [30, 50]}}})
    cases = expand_cases(spec)
    assert len(cases) == 2 * 3 * 2 * 2
    assert len({c["id"] for c in cases}) == len(cases)
    assert all(30 <= c["plant"]["sigma"] <= 50 for c in cases)
    assert [c["id"] for c in expand_cases(spec)] == [c["id"] for c in cases]  # deterministic


def test_bad_spec_errors_name_the_key():
    with pytest.raises(ValueError, match="grid key 'Q'"):
        load_spec({"grid": {"Q": [1]}})
    with pytest.raises(ValueError, match="unknown key"):
        load_spec({"gird": {}})


def test_parallel_equals_serial_and_resume(tmp_path):
    spec = load_spec(SPEC)
    serial = tmp_path / "serial.csv"
    s = run_sweep(spec, serial, workers=1, progress=False)
    assert s["n_run"] == 4 and s["modes"]["none"]["n"] == 4
    par = tmp_path / "par.csv"
    run_sweep(spec, par, workers=2, progress=False)
    assert _rows(par) == _rows(serial)  # deterministic: identical numbers
    # crash: keep the header, one finished case and a torn line
    lines = serial.read_text().splitlines(keepends=True)
    resumed = tmp_path / "resumed.csv"
    resumed.write_text("".join(lines[:3]) + lines[3][:10])
    s2 = run_sweep(spec, resumed, workers=1, progress=False)
    assert s2["n_skipped"] == 1 and s2["n_run"] == 3
    assert _rows(resumed) == _rows(serial)
    s3 = run_sweep(spec, resumed, workers=1, progress=False)
    assert s3["n_run"] == 0


def test_dask_local_cluster_equals_local_run(tmp_path):
    distributed = pytest.importorskip("dask.distributed")
    spec = load_spec({**SPEC, "grid": {"Fc": [25.0]}})
    local = tmp_path / "local.csv"
    run_sweep(spec, local, workers=1, progress=False)
    # dashboard_address=":0": a free port (None still binds the default 8787, and a second cluster on the machine
    # makes distributed warn that the port is in use)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0") as lc:
        remote = tmp_path / "dask.csv"
        run_sweep(spec, remote, scheduler=lc.scheduler_address, progress=False)
    assert _rows(remote) == _rows(local)


# --------------------------------------------------------------------------- sweeps lose nothing

import json  # noqa: E402
import os  # noqa: E402
import signal  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
# Enough work that the interrupt cannot arrive after the last case even on a slow, loaded machine: with four
# short cases (CI run of 53829ed) all four were written before SIGINT landed. 24 cases of 60 s simulated take
# ~3 s on two idle cores after the first case is written, ~0.3 s per case and worker.
N_SLOW = 24
SLOW = {"preset": "paper", "grid": {"Fc": [20.0 + k for k in range(N_SLOW)]}, "seeds": [0],
        "modes": ["none", "adaptive"], "duration": 60.0, "options": {"Vs": 0.02, "delta": 1.0}}
CLI = "import sys; from controllers.cli import main; sys.exit(main())"


def _cases_in(path):
    """{case_id: [modes]} of the complete rows of a results CSV."""
    out = {}
    with open(path, newline="") as fh:
        for r in csv.DictReader(fh):
            out.setdefault(r["case_id"], []).append(r["mode"])
    return out


def _start(tmp_path, out, *extra, new_session=False):
    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps(SLOW))
    return subprocess.Popen([sys.executable, "-c", CLI, "sweep", str(spec), "--out", str(out),
                             "--workers", "2", "--quiet", *extra], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=new_session)


def _wait_for_cases(proc, out, n, timeout=240.0):
    t_end = time.monotonic() + timeout
    while time.monotonic() < t_end:
        if out.exists() and len(_cases_in(out)) >= n:
            return
        if proc.poll() is not None:
            pytest.fail(f"sweep ended early: {proc.returncode} {proc.stderr.read()}")
        time.sleep(0.05)
    pytest.fail("no case finished in time")


def _children(pid):
    try:
        return [int(x) for x in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]
    except OSError:
        return []


def _alive(pid):
    try:
        return Path(f"/proc/{pid}/stat").read_text().split()[2] != "Z"
    except OSError:
        return False


def test_sigint_stops_workers_keeps_finished_cases_and_exits_130(tmp_path):
    out = tmp_path / "r.csv"
    proc = _start(tmp_path, out)
    _wait_for_cases(proc, out, 1)
    workers = _children(proc.pid)
    assert len(workers) == 2
    t0 = time.monotonic()
    proc.send_signal(signal.SIGINT)
    while any(_alive(p) for p in workers) and time.monotonic() - t0 < 10:
        time.sleep(0.01)
    stop = time.monotonic() - t0
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 130, err
    assert stop < 2.0, f"the workers took {stop:.2f} s to stop"
    assert "interrupted" in err and "rerun the same command to resume" in err and "Traceback" not in err
    done = _cases_in(out)
    assert 1 <= len(done) < N_SLOW and all(sorted(m) == ["adaptive", "none"] for m in done.values())
    # resuming (the rest runs, nothing twice) is tested after kill -9 below


def test_kill_9_then_resume_loses_nothing_and_duplicates_nothing(tmp_path):
    out = tmp_path / "r.csv"
    proc = _start(tmp_path, out, new_session=True)
    _wait_for_cases(proc, out, 1)
    os.killpg(proc.pid, signal.SIGKILL)  # the sweep's own process group: parent and workers
    proc.communicate(timeout=30)
    before = _cases_in(out)
    spec = load_spec(SLOW)
    s = run_sweep(spec, out, workers=2, progress=False)
    assert s["n_skipped"] == len(before) and s["n_cases"] == N_SLOW
    final = _cases_in(out)
    assert len(final) == N_SLOW and all(sorted(m) == ["adaptive", "none"] for m in final.values())


def test_partly_written_case_is_rerun_without_duplicates(tmp_path):
    spec = load_spec({**SPEC, "seeds": [0]})
    full = tmp_path / "full.csv"
    run_sweep(spec, full, workers=1, progress=False)
    lines = full.read_text().splitlines(keepends=True)
    # header, case A complete (2 rows), case B only its first mode row: killed between two rows
    partial = tmp_path / "partial.csv"
    partial.write_text("".join(lines[:4]))
    s = run_sweep(spec, partial, workers=1, progress=False)
    assert s["n_skipped"] == 1 and s["n_run"] == 1
    assert _rows(partial) == _rows(full)
    # a row with an empty metric counts as incomplete too
    broken = tmp_path / "broken.csv"
    cells = lines[2].rstrip("\n").split(",")
    cells[-1] = ""
    broken.write_text("".join(lines[:2]) + ",".join(cells) + "\n")
    s = run_sweep(spec, broken, workers=1, progress=False)
    assert s["n_skipped"] == 0 and _rows(broken) == _rows(full)


def test_results_file_of_another_kind_is_refused(tmp_path):
    other = tmp_path / "other.csv"
    other.write_text("a,b\n1,2\n")
    with pytest.raises(ValueError, match="not a results table of this sweep"):
        run_sweep(load_spec(SPEC), other, workers=1, progress=False)
    assert other.read_text() == "a,b\n1,2\n"


@pytest.mark.parametrize("name", ["sweep_grid.json", "sweep_monte_carlo.json"])
def test_example_specs_run(tmp_path, name, capsys):
    from controllers.cli.main import main

    path = ROOT / "examples" / name
    d = json.loads(path.read_text())  # strict JSON
    spec = load_spec(path)
    assert len(expand_cases(spec)) == 4
    small = tmp_path / name
    small.write_text(json.dumps({**d, "duration": 3.0}))  # the example as shipped, shortened for the test
    out = tmp_path / "r.csv"
    assert main(["sweep", str(small), "--out", str(out), "--workers", "1", "--quiet", "--units", "rad"]) == 0
    text = capsys.readouterr().out
    assert "RMS mean [rad/s]" in text and "eta mean [-]" in text
    assert len(_cases_in(out)) == 4


def test_own_compensator_by_file_runs_in_every_case_in_worker_processes(tmp_path):
    """A spec's compensators (a file beside the spec) run in each case on 2 worker processes: rows under their
    name, equal to compare() with the same factory; a resumed sweep counts their rows."""
    import json

    from controllers import compare
    from plant import preset

    (tmp_path / "coulomb_ff.py").write_text(
        "class CoulombFF:\n"
        "    def __init__(self, ctx, level):\n"
        "        self.F = level  # N·m (the spec gives Vs, delta: no pre-fit, ctx.prefit is None)\n"
        "    def compensate(self, w_meas, w_ref):\n"
        "        return self.F if w_ref > 0 else -self.F if w_ref < 0 else 0.0\n"
        "    def observe(self, u, w_meas):\n"
        "        pass\n", encoding="utf-8")
    spec_file = tmp_path / "spec.json"
    spec_file.write_text(json.dumps({**SPEC, "seeds": [0], "modes": ["none"],
                                     "compensators": {"coulomb": {"factory": "coulomb_ff.py:CoulombFF",
                                                                  "level": 22.0}}}), encoding="utf-8")
    spec = load_spec(spec_file)
    assert spec.compensators["coulomb"]["factory"] == f"{(tmp_path / 'coulomb_ff.py').resolve()}:CoulombFF"
    out = tmp_path / "r.csv"
    s = run_sweep(spec, out, workers=2, progress=False)
    assert s["n_run"] == 2 and s["modes"]["coulomb"]["n"] == 2
    with open(out, newline="") as fh:
        rows = {(r["Fc"], r["mode"]): float(r["rms"]) for r in csv.DictReader(fh)}
    import importlib.util

    mod_spec = importlib.util.spec_from_file_location("coulomb_ff_here", tmp_path / "coulomb_ff.py")
    mod = importlib.util.module_from_spec(mod_spec)
    mod_spec.loader.exec_module(mod)
    c = compare(preset("paper").replace(Fc=30.0), duration=4.0, seed=0, modes=("none",), Vs=0.02, delta=1.0,
                compensators={"coulomb": lambda ctx: mod.CoulombFF(ctx, 22.0)}, progress=False)
    assert rows[("30.0", "coulomb")] == pytest.approx(c.results["coulomb"].metrics.rms_second_half, rel=1e-12)
    assert run_sweep(spec, out, workers=1, progress=False)["n_run"] == 0  # its rows count as the case's
    with pytest.raises(ValueError, match=r"compensators: \[compensators.none\] factory|built-in mode"):
        load_spec({**SPEC, "compensators": {"none": "math:sin"}})


def test_a_sweep_of_random_plants_runs_every_model_as_compare_does(tmp_path):
    # random_plants: joints of any model (here an asymmetric one and a Karnopp one), drawn for the reference of the
    # spec's comparison (spec.compare), each case compare() on its joint
    from controllers.experiments.compare import compare, comparison_reference
    from controllers.experiments.zoo import draw_plants
    from plant.models import plant_from_dict

    spec = load_spec({"random_plants": {"n": 2, "seed": 3}, "seeds": [1], "modes": ["none", "dob", "frictionless"],
                      "duration": 4.0})
    assert (spec.compare.duration, spec.modes) == (4.0, ("none", "dob", "frictionless"))
    plants = draw_plants(2, comparison_reference(spec.compare.replace(seed=0)), seed=3)
    assert [c["plant"] for c in expand_cases(spec)] == plants and plants[0]["model"] == "asymmetric"
    out = tmp_path / "r.csv"
    assert run_sweep(spec, out, workers=1, progress=False)["n_run"] == 2
    rows = list(csv.DictReader(out.open()))
    for j, p in enumerate(plants):
        c = compare(plant_from_dict(p), duration=4.0, seed=1, modes=("none", "dob", "frictionless"), progress=False)
        got = {r["mode"]: float(r["rms"]) for r in rows[3 * j:3 * j + 3]}
        assert got == {m: c.results[m].metrics.rms_second_half for m in ("none", "dob", "frictionless")}
