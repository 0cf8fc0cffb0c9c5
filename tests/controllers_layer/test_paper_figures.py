"""``adaptive-ff paper-figures``: the paper's figures from simulation, their numbers, axes and data files."""

import argparse
import json
import math

import numpy as np
import pytest

from adaptive_ff.identification.identify import identify
from adaptive_ff.io.logs import LogUnits, load_log
from adaptive_ff.identification.ls import fit_ls
from adaptive_ff.identification.regression import RegressionModel, theta_from_physical
from controllers.cli import paper_figures as cli_paper_figures
from controllers.experiments.paper_figures import (DEMO_COUNTS_PER_REV, DEMO_CURRENT_TO_TORQUE, FIGURE_CAPTIONS,
                                       identification_figures, plot_parameter_convergence, plot_sample_times,
                                       plot_velocity_fit, rls_pass, save_figures)
from plant import bandlimited_noise, preset

PNG = b"\x89PNG\r\n\x1a\n"
P = preset("paper")


def run(argv):
    ap = argparse.ArgumentParser(prog="adaptive-ff")
    cli_paper_figures.register(ap.add_subparsers(dest="command", required=True))
    args = ap.parse_args(["paper-figures", *argv])
    return args.func(args)


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    out = tmp_path_factory.mktemp("paper")
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert run(["--out", str(out), "--sim-duration", "8", "--exp-duration", "10", "--speeds", "6",
                    "--save-data", "--report", str(out), "--json", "--quiet"]) == 0
    return out, json.loads(buf.getvalue())


def test_all_figures_written(result):
    out, d = result
    assert set(d["figures"]) == set(FIGURE_CAPTIONS)
    for stem, path in d["figures"].items():
        assert path.endswith(f"{stem}.png")
        assert open(path, "rb").read(8) == PNG
    html = (out / "report.html").read_text()
    assert html.count("data:image/png;base64,") == len(FIGURE_CAPTIONS)
    assert "Fig. 12: parameter convergence of RLS identification" in html


def test_numbers_behind_the_figures(result):
    _, d = result
    s = d["summary"]
    for name in ("Fc", "Fs", "Vs", "delta", "sigma"):  # Fig. 8 with 1e-3 rad/s noise: within 5 %
        assert s["stribeck"][name] == pytest.approx(getattr(P, name), rel=0.05), name
    assert s["simulation"]["ls_fit_one_step"] > 99.0  # Fig. 4, noise-free 10 ms data
    assert s["simulation"]["rls_fit"] > 99.0  # Fig. 5
    ex = s["experiment"]
    # Fig. 10 pattern: 20 ms +- 1 ms, every 10th interval 40 ms +- 1 ms -> mean (9*20 + 40)/10 = 22 ms
    assert ex["Ts_mean"] == pytest.approx(0.022, abs=5e-4)
    assert ex["Ts_min"] >= 0.019 - 1e-9 and ex["Ts_max"] <= 0.041 + 1e-9
    assert ex["n_samples"] == pytest.approx(10.0 / 0.022, rel=0.02)
    assert 50.0 < ex["ls_fit_one_step"] <= 100.0


def test_demo_logs_load_with_units(result):
    out, d = result
    logs = d["data_files"]
    assert set(logs) == {"quasi_static_log", "robot_log", "controller_log", "controller", "plant"}
    data = load_log(logs["robot_log"], columns="t=time_ms,u=current_A,q=encoder_counts",
                    units=LogUnits(time_unit="ms", current_to_torque=DEMO_CURRENT_TO_TORQUE, position_unit="counts",
                                   counts_per_rev=DEMO_COUNTS_PER_REV))
    ref = load_log(logs["robot_log"], columns="t=time_ms,u=current_A,w=velocity_deg_s",
                   units=LogUnits(time_unit="ms", current_to_torque=DEMO_CURRENT_TO_TORQUE, velocity_unit="deg/s"))
    np.testing.assert_allclose(data.u, ref.u, rtol=1e-12)
    np.testing.assert_allclose(np.diff(data.t).mean(), 0.022, atol=5e-4)
    # Kalman velocity from counts vs the logged (noisy, 1e-3 rad/s) velocity
    assert np.sqrt(np.mean((data.w - ref.w) ** 2)) < 0.03 * np.sqrt(np.mean(ref.w**2))
    assert json.loads(open(logs["plant"]).read()) == P.to_dict()
    # the controller's own 1 kHz record of the same run: the slow readout's torque is its sample, quantised
    ctl = load_log(logs["controller_log"], columns="t=time_ms,u=current_A,w=velocity_deg_s",
                   units=LogUnits(time_unit="ms", current_to_torque=DEMO_CURRENT_TO_TORQUE, velocity_unit="deg/s"))
    np.testing.assert_allclose(np.diff(ctl.t), 1e-3, rtol=1e-6)
    k = np.rint(ref.t / 1e-3).astype(int)
    np.testing.assert_allclose(ref.u, np.round(ctl.u[np.maximum(k - 1, 0)] / 0.6) * 0.6, atol=1e-9)
    # the commanded velocity at the stamps and the PI of the loop, for --method closed_loop
    from adaptive_ff.io.logs import read_columns
    from controllers.experiments.closed_loop_id import ControllerSpec

    r = read_columns(logs["robot_log"], {"t": "time_ms", "r": "reference_deg_s"}).columns["r"]
    c = read_columns(logs["controller_log"], {"t": "time_ms", "r": "reference_deg_s"}).columns["r"]
    np.testing.assert_allclose(r, c[k], rtol=0, atol=1e-12)
    spec = ControllerSpec.from_json(logs["controller"])
    assert spec.Kp == pytest.approx(d["summary"]["experiment"]["controller"]["Kp"], rel=1e-12)
    assert spec.Ki == pytest.approx(d["summary"]["experiment"]["controller"]["Ki"], rel=1e-12)
    assert spec.Tc == 1e-3 and math.isfinite(spec.u_max) and spec.u_max > 0


def test_rls_pass_equals_ridge_least_squares():
    """lam = 1, theta0 = 0, P0*I: after N updates RLS is the ridge solution with weight 1/P0 (independent LS)."""
    _, u = bandlimited_noise(5.0, dt=0.01, cutoff=1.0, std=50.0, rng=np.random.default_rng(1))
    model = RegressionModel(stribeck=False, lag=True)
    th = theta_from_physical(P.replace(Fs=P.Fc), 0.01)
    w = model.simulate([dict(zip(("a1", "a2", "b0", "b1", "c1", "d1", "o1"), th))[k] for k in model.names],
                       u, [0.0, 0.0])
    w_pred, hist = rls_pass(model, u, w, lam=1.0, P0=1e3)
    ridge = fit_ls(model, u, w, Ts=0.01, ridge=1e-3)
    np.testing.assert_allclose(hist[-1], ridge.theta, rtol=1e-6)
    X, y = model.regressors(u, w)
    np.testing.assert_allclose(w_pred[2:][1:], [X[i] @ hist[i - 1] for i in range(1, X.shape[0])], rtol=1e-9,
                               atol=1e-12)  # a-priori predictions


def test_plots_have_units_on_the_axes():
    t = np.linspace(0, 1, 50)
    f = plot_velocity_fit(t, np.sin(t), (np.sin(t) + 0.01, "m"))
    assert f.axes[0].get_ylabel() == "velocity w (rad/s)" and f.axes[1].get_xlabel() == "time t (s)"
    f = plot_sample_times(np.cumsum(np.full(50, 0.02)))
    assert "(ms)" in f.axes[0].get_ylabel() and "(ms)" in f.axes[1].get_xlabel()
    f = plot_parameter_convergence(t, np.ones((50, 2)), ["a1", "b0"], true=[1, 1])
    assert f.axes[1].get_ylabel() == "b0 ((rad/s)/(N·m))"


def test_identification_figures_for_a_log(result):
    out, d = result
    data = load_log(d["data_files"]["quasi_static_log"])
    rep = identify(data, method="paper")
    figs = identification_figures(rep, data)
    assert set(figs) == {"ls_fit", "rls_fit", "rls_parameters", "sample_time"}
    assert len(figs["rls_parameters"].axes) >= len(rep.model.names)
    paths = save_figures(figs, out / "id")
    assert [p.name for p in paths] == ["ls_fit.png", "rls_fit.png", "rls_parameters.png", "sample_time.png"]
    assert all(p.read_bytes()[:8] == PNG for p in paths)


def test_experiment_moves_like_the_robot(result):
    """Sec. V-B: 1-20 deg/s with frequent reversals, rarely stuck (a 20 rad/s loop sticks ~40 % of the time)."""
    _, d = result
    mo = d["summary"]["experiment"]["motion"]
    assert mo["stuck_fraction"] < 0.10
    assert 10.0 < np.rad2deg(mo["speed_p95"]) <= 21.0 and np.rad2deg(mo["speed_max"]) <= 22.0
    assert mo["reversals"] >= 5  # 10 s of a 0.01-1 Hz multi-sine


def test_joint_motion_counts():
    from controllers.experiments.paper_figures import joint_motion

    w = np.deg2rad(np.array([5.0, 0.1, -0.1, -5.0, -6.0, 0.0, 7.0, 7.0]))
    m = joint_motion(w)
    assert m["stuck_fraction"] == pytest.approx(3 / 8)
    assert m["reversals"] == 2 and m["speed_max"] == pytest.approx(np.deg2rad(7.0))


def test_deg_units_and_unclipped_windup():
    from controllers.experiments.paper_figures import plot_input_torque

    t = np.linspace(0, 10, 500)
    w = 0.3 * np.sin(t)
    f = plot_velocity_fit(t, w, (w + 0.01, "m"), units="deg")
    assert f.axes[0].get_ylabel() == "velocity w (deg/s)"
    assert max(abs(y) for y in f.axes[0].get_ylim()) >= np.rad2deg(0.3)  # data drawn in deg/s
    th = np.ones((500, 2))
    th[250, 1] = 5e3  # a windup burst of plain RLS
    f = plot_parameter_convergence(t, th, ["a1", "c1"], true=[1.0, 1.0], units="deg")
    ax = f.axes[1]
    assert ax.get_ylabel() == "c1 (deg/s)" and ax.get_ylim()[1] >= np.rad2deg(5e3)  # not clipped away
    assert ax.get_yscale() == "symlog" and f.axes[0].get_yscale() == "linear"
    f = plot_input_torque(t, np.round(30 * np.sign(w) / 0.6) * 0.6)
    assert len(f.axes) == 3 and all(a.get_ylabel() == "torque u (N·m)" for a in f.axes)
    with pytest.raises(Exception, match="units"):
        plot_velocity_fit(t, w, (w, "m"), units="grad")
