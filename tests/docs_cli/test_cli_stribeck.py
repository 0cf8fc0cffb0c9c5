"""``adaptive-ff stribeck``: from a log or a table of support points to the Stribeck fit, Fig. 8 and the report."""

import argparse
import json

import numpy as np
import pytest

from controllers.cli import stribeck as cli_stribeck
from controllers.experiments.quasi_static import bidirectional_velocities
from controllers.experiments.synthetic_logs import quasi_static_log, write_log_csv
from plant import preset
from plant.errors import ExcitationError

P = preset("paper")
PNG = b"\x89PNG\r\n\x1a\n"


def run(argv):
    ap = argparse.ArgumentParser(prog="adaptive-ff")
    cli_stribeck.register(ap.add_subparsers(dest="command", required=True))
    args = ap.parse_args(["stribeck", *argv])
    return args.func(args)


@pytest.fixture(scope="module")
def log_csv(tmp_path_factory):
    """A noise-free log of 16 constant-velocity runs, time in ms and velocity in deg/s, as a drive exports it."""
    d = quasi_static_log(P, bidirectional_velocities(0.2 * P.Vs, 0.4, 8), hold=1.0, settle=1.0)
    path = tmp_path_factory.mktemp("qs") / "runs.csv"
    return write_log_csv(path, {"time_ms": 1e3 * d.t, "torque": d.u, "speed_dps": np.rad2deg(d.w)},
                         header_comment="quasi-static runs")


def test_log_to_fit_json_figure_and_report(log_csv, tmp_path, capsys):
    out, rep = tmp_path / "out", tmp_path / "rep"
    assert run([str(log_csv), "--columns", "t=time_ms,u=torque,w=speed_dps", "--time-unit", "ms",
                "--velocity-unit", "deg/s", "--out", str(out), "--report", str(rep), "--json", "--quiet"]) == 0
    d = json.loads(capsys.readouterr().out)
    for name in ("Fc", "Fs", "Vs", "delta", "sigma"):  # noise-free steady state: u = F(w) exactly
        assert d[name] == pytest.approx(getattr(P, name), rel=1e-3), name
        lo, hi = d["confidence_95"][name]
        assert lo <= d[name] <= hi
    assert d["support_points"]["method"] == "segments" and len(d["support_points"]["w_mean"]) == 16
    assert (out / "fig08_stribeck.png").read_bytes()[:8] == PNG
    table = np.loadtxt(out / "support_points.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(table[:, 2], P.friction(table[:, 0]), rtol=1e-6)
    html = (rep / "report.html").read_text()
    assert f"{d['Vs']:.6g}" in html and "data:image/png;base64," in html


def test_text_output_gives_the_next_command(log_csv, tmp_path, capsys):
    assert run([str(log_csv), "--columns", "t=time_ms,u=torque,w=speed_dps", "--time-unit", "ms",
                "--velocity-unit", "deg/s", "--method", "bins", "--no-figures"]) == 0
    text = capsys.readouterr().out
    assert "support points:" in text and "(bins)" in text
    assert "next: adaptive-ff identify LOG --Vs 0.0" in text and "--delta" in text


def test_points_table(tmp_path, capsys):
    """A table of averaged points (w, F, spread) as published: the fit returns eq. 3's parameters exactly."""
    w = bidirectional_velocities(0.004, 0.4, 7)
    path = write_log_csv(tmp_path / "points.csv", {"speed": w, "torque": P.friction(w), "spread": 0.1 + 0 * w})
    assert run([str(path), "--points", "--columns", "w=speed,F=torque,F_std=spread", "--weighted", "--json",
                "--no-figures"]) == 0
    d = json.loads(capsys.readouterr().out)
    for name in ("Fc", "Fs", "Vs", "delta", "sigma"):
        assert d[name] == pytest.approx(getattr(P, name), rel=1e-6), name


def test_too_few_runs_is_an_excitation_error(tmp_path):
    d = quasi_static_log(P, [-0.2, 0.2], hold=1.0, settle=1.0)
    path = write_log_csv(tmp_path / "two.csv", {"t": d.t, "u": d.u, "w": d.w})
    with pytest.raises(ExcitationError, match=r"two\.csv: only \d+ support point"):
        run([str(path), "--method", "segments", "--no-figures"])


def test_emps_mat_without_columns_keeps_the_benchmark_loader():
    """controllers.cli.data: the EMPS .mat goes through adaptive_ff.io.data.load_measurements unless --columns is given."""
    from pathlib import Path

    from adaptive_ff.io.data import load_measurements
    from controllers.cli.data import load_data_from_args

    emps = Path(__file__).resolve().parents[2] / "data" / "emps" / "DATA_EMPS.mat"
    ap = argparse.ArgumentParser()
    from controllers.cli.data import add_data_arguments

    add_data_arguments(ap)
    ap.add_argument("file")
    d = load_data_from_args(ap.parse_args([str(emps)]))
    ref = load_measurements(emps)
    np.testing.assert_array_equal(d.w, ref.w)
    raw = load_data_from_args(ap.parse_args([str(emps), "--columns", "t=t,u=vir,q=qm"]))
    assert raw.n_samples == d.n_samples + 49  # generic reader: no samples dropped, velocity by the Kalman filter
