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
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as lc:
        remote = tmp_path / "dask.csv"
        run_sweep(spec, remote, scheduler=lc.scheduler_address, progress=False)
    assert _rows(remote) == _rows(local)
