"""Every figure the package makes: each axis with numbers has a label with a unit; multi-line axes have a legend
that does not cover the data.

The registry ``FIGURES`` builds each figure from small inputs; ``test_registry_covers_every_plot`` scans the
package for ``plot`` methods and ``plot_*`` functions, so a new one fails until it is registered here.
"""

import ast
import math
import re
from pathlib import Path

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg

ROOT = Path(__file__).resolve().parents[2]
UNIT = re.compile(r"\[[^\]]+\]|\([^)]*\)")  # "[deg/s]", "(N·m)", "[-]", "(1)"
#: At most this share of the data's bounding box may lie under a legend ...
MAX_BBOX_COVER = 0.12
#: ... and at most this share of the plotted vertices.
MAX_POINT_COVER = 0.02


# --------------------------------------------------------------------------- checks


def _numeric_ticklabels(axis) -> bool:
    labels = [t.get_text() for t in axis.get_ticklabels() if t.get_visible() and t.get_text()]
    return bool(labels) and all(re.fullmatch(r"[−\-+0-9.,e×^{}$\\mathdefault ]+", s) for s in labels)


def _labelled_artists(ax):
    arts = [a for a in (*ax.lines, *ax.collections, *ax.patches, *ax.containers)
            if not str(a.get_label()).startswith("_") and a.get_label()]
    return arts


def _data_points(ax):
    """Display coordinates of every plotted line vertex inside the axes."""
    pts = []
    for line in ax.lines:
        xy = line.get_xydata()
        xy = xy[np.all(np.isfinite(xy), axis=1)]
        if xy.shape[0]:
            pts.append(ax.transData.transform(xy))
    if not pts:
        return np.empty((0, 2))
    p = np.concatenate(pts)
    bb = ax.get_window_extent()
    inside = (p[:, 0] >= bb.x0) & (p[:, 0] <= bb.x1) & (p[:, 1] >= bb.y0) & (p[:, 1] <= bb.y1)
    return p[inside]


def _overlap(a, b) -> float:
    w = min(a.x1, b.x1) - max(a.x0, b.x0)
    h = min(a.y1, b.y1) - max(a.y0, b.y0)
    return max(w, 0.0) * max(h, 0.0)


def check_figure(fig, name):
    """Assert the rules of the module docstring on a drawn figure; returns the number of axes checked."""
    FigureCanvasAgg(fig).draw()
    renderer = fig.canvas.get_renderer()
    # a legend may serve several axes (e.g. the velocity and error panels of one zoom): any legend of the figure
    fig_legends = list(fig.legends) + [a.get_legend() for a in fig.axes if a.get_legend() is not None]
    checked = 0
    for ax in fig.axes:
        if not ax.get_visible() or not ax.axison:
            continue
        checked += 1
        for axis, label in ((ax.xaxis, ax.get_xlabel()), (ax.yaxis, ax.get_ylabel())):
            if axis.get_visible() and _numeric_ticklabels(axis):
                assert UNIT.search(label or ""), f"{name}: axis with numbers but label {label!r} has no unit"
        arts = _labelled_artists(ax)
        if len(ax.lines) + len(ax.collections) >= 2 and len(arts) >= 2:
            leg = ax.get_legend() or next((lg for lg in fig_legends
                                           if {t.get_text() for t in lg.get_texts()} >= {a.get_label()
                                                                                         for a in arts}), None)
            assert leg is not None, f"{name}: {len(arts)} labelled artists ({[a.get_label() for a in arts]}) " \
                                    "and no legend"
            lb = leg.get_window_extent(renderer)
            pts = _data_points(ax)
            if pts.shape[0]:
                from matplotlib.transforms import Bbox

                db = Bbox.from_extents(*pts.min(axis=0), *pts.max(axis=0))
                area = max(db.width * db.height, 1e-9)
                cover = _overlap(lb, db) / area
                assert cover <= MAX_BBOX_COVER, f"{name}: legend covers {cover:.0%} of the data's bounding box"
                under = np.mean((pts[:, 0] >= lb.x0) & (pts[:, 0] <= lb.x1) & (pts[:, 1] >= lb.y0)
                                & (pts[:, 1] <= lb.y1))
                assert under <= MAX_POINT_COVER, f"{name}: legend hides {under:.1%} of the plotted points"
    assert checked, f"{name}: no axes"
    return checked


# --------------------------------------------------------------------------- the figures


@pytest.fixture(scope="module")
def comp():
    from controllers.experiments.compare import compare
    from plant.friction import preset

    return compare(preset("paper"), duration=12.0, seed=1, progress=False)


def _compare_figures(comp):
    from controllers.report import figures as F

    out = {f"compare.{f.name}": getattr(F, f"plot_{f.name}")(comp) for f in F._FIGURES}
    out["Comparison.plot"] = comp.plot().figure
    out["ClosedLoopResult.plot"] = comp.results["adaptive"].plot().figure
    return out


def _paper_figures():
    from controllers.experiments import paper_figures as pf
    from adaptive_ff.identification.stribeck_fit import fit_stribeck, plot_stribeck_fit
    from plant.friction import preset

    P = preset("paper")
    rng = np.random.default_rng(0)
    t = np.arange(400) * 0.022 + rng.uniform(0, 0.002, 400)
    w = 0.3 * np.sin(2 * np.pi * 0.2 * t)
    th = np.cumsum(rng.normal(size=(400, 6)), axis=0) * 0.01
    th[200:205, 5] = 1e4  # a windup burst
    ws = np.concatenate([-np.geomspace(0.004, 0.4, 8)[::-1], np.geomspace(0.004, 0.4, 8)])
    fit = fit_stribeck(ws, P.friction(ws))
    out = {}
    for units in ("rad", "deg"):
        out[f"plot_velocity_fit.{units}"] = pf.plot_velocity_fit(t, w, (w + 0.01, "LS"), model2=(w * 0.9, "free run"),
                                                                  units=units)
        out[f"plot_parameter_convergence.{units}"] = pf.plot_parameter_convergence(
            t, th, ["a1", "a2", "b0", "b1", "c1", "d1"], true=np.ones(6), units=units)
        out[f"plot_stribeck_figure.{units}"] = pf.plot_stribeck_figure(fit, ws, P.friction(ws), units=units)
    out["plot_sample_times"] = pf.plot_sample_times(t)
    out["plot_input_torque"] = pf.plot_input_torque(t, np.round(30 * np.sign(w) / 0.6) * 0.6)
    out["plot_stribeck_fit"] = plot_stribeck_fit(fit, ws, P.friction(ws)).figure
    out["StribeckFit.plot"] = fit.plot().figure
    out["FormSelection.plot"] = _form_selection().plot().figure
    from controllers.experiments.quasi_static import StribeckExperiment

    held = np.ones(ws.size, dtype=bool)
    held[0] = False
    out["StribeckExperiment.plot"] = StribeckExperiment(
        setpoints=ws, w_mean=ws, w_std=ws * 0.01, u_mean=P.friction(ws), u_std=ws * 0 + 0.1,
        crossover=ws * 0 + 20.0, held=held, fit=fit, rounds=1, notes=()).plot().figure
    return out


def _result_figures():
    """The plot() of every other result object, built from small inputs."""
    from adaptive_ff.identification.emps_validation import EMPSSimulation, EMPSValidation
    from adaptive_ff.identification.online_ukf import OnlineUKFResult
    from adaptive_ff.identification.steady_state import SupportPoints
    from adaptive_ff.io.data import MeasuredData
    from adaptive_ff.io.logs import VelocityEstimate
    from controllers.design.loop_analysis import analyse_design, plot_bode, plot_step
    from controllers.design.pi import ClosedLoopStep, design_pi
    from controllers.experiments.quasi_static import quasi_static_runs, bidirectional_velocities
    from adaptive_ff.identification.regression import FrictionEstimate
    from plant.friction import preset

    P = preset("paper")
    t = np.arange(300) * 0.01
    w = 0.2 * np.sin(t)
    n = t.shape[0]
    d = design_pi(P.J, crossover=20.0)
    a = analyse_design(d)
    out = {"PIDesign.plot": d.plot().figure, "LoopAnalysis.plot": a.plot().figure, "plot_bode": plot_bode(d),
           "plot_step": plot_step(a),
           "ClosedLoopStep.plot": ClosedLoopStep(t=t, w=1 - np.exp(-t), u=np.exp(-t)).plot().figure,
           "MeasuredData.plot": MeasuredData(t, 30 * np.sign(w), w, source="x").plot().figure,
           "FrictionEstimate.plot": FrictionEstimate(J=4.0, tau=0.02, sigma=40.0, Fc=25.0, Fs=35.0, offset=0.0,
                                                     Vs=0.02, delta=1.0, J_alt=math.nan).plot().figure}
    ws = np.geomspace(0.004, 0.4, 6)
    out["SupportPoints.plot"] = SupportPoints(w_mean=ws, w_std=ws * 0.01, u_mean=P.friction(ws), u_std=ws * 0 + 0.1,
                                              n_samples=np.full(6, 100), t_start=np.arange(6.0),
                                              t_end=np.arange(6.0) + 1, method="plateaus").plot().figure
    qs = quasi_static_runs(P, bidirectional_velocities(0.01, 0.2, 3), rng=np.random.default_rng(0), noise_std=1e-3)
    out["QuasiStaticData.plot"] = qs.plot().figure
    sim = EMPSSimulation(t=t, q=np.cumsum(w) * 0.01, w=w, force=10 * w)
    out["EMPSSimulation.plot"] = sim.plot().figure
    out["EMPSValidation.plot"] = EMPSValidation(velocity_error=1.0, force_error=1.0, position_error=1.0,
                                                idim_force_error=1.0, n_samples=n, source="x",
                                                simulation=sim).plot().figure
    out["VelocityEstimate.plot"] = VelocityEstimate(t=t, w=w, w_std=w * 0 + 0.01, q=np.cumsum(w) * 0.01, model="cv",
                                                    bandwidth=5.0, position_noise=1e-4, process_noise=1.0,
                                                    smoothed=True).plot().figure
    from adaptive_ff.identification.online_ukf import PARAM_NAMES

    theta = {k: np.linspace(0.5, 1.0, n) for k in PARAM_NAMES}
    out["OnlineUKFResult.plot"] = OnlineUKFResult(t=t, theta=theta, theta_std=theta, w_hat=w, f_hat=w, innovation=w,
                                                  final={k: 1.0 for k in PARAM_NAMES}, x=np.zeros(3),
                                                  P=np.eye(3)).plot().figure
    return out


def _form_selection():
    """A model-form selection (sliding regression, two forms) on a 10 s simulated log of the paper's joint."""
    from adaptive_ff import select_form
    from adaptive_ff.io.data import MeasuredData
    from plant.excitation import bandlimited_noise
    from plant.friction import preset
    from plant.joint import simulate
    from plant.sampling import sample

    P = preset("paper")
    rng = np.random.default_rng(0)
    _, u = bandlimited_noise(10.0, dt=1e-3, cutoff=1.0, std=50.0, rng=rng)
    m = sample(simulate(P, u, dt=1e-3), Ts=0.01, noise_std=0.005, rng=rng)
    return select_form(MeasuredData(m.t, m.u, m.w), method="sliding", Vs=P.Vs, delta=P.delta,
                       forms=("coulomb_viscous", "stribeck_lag"))


#: Figure names built by the builders above -> the package names (``Class.plot`` / ``function``) they cover.
COVERED = {"plot_tracking", "plot_error", "plot_friction", "plot_rls_convergence", "plot_eta", "plot_comparison",
           "Comparison.plot", "ClosedLoopResult.plot", "plot_velocity_fit", "plot_parameter_convergence",
           "plot_stribeck_figure", "plot_sample_times", "plot_input_torque", "plot_stribeck_fit", "StribeckFit.plot",
           "PIDesign.plot", "LoopAnalysis.plot", "plot_bode", "plot_step", "ClosedLoopStep.plot",
           "MeasuredData.plot", "FrictionEstimate.plot", "SupportPoints.plot", "QuasiStaticData.plot",
           "StribeckExperiment.plot", "FormSelection.plot",
           "EMPSSimulation.plot", "EMPSValidation.plot", "VelocityEstimate.plot", "OnlineUKFResult.plot",
           # checked through the figures they return, by test_identification_figures below:
           "IdentificationReport.plot", "LSResult.plot",
           # the band's axes of IdentificationReport.plot's figure
           "FrictionBand.plot",
           # the whole arm's per-joint friction figure (needs the [arm] extra: skipped without Pinocchio)
           "ArmIdentification.plot",
           # compare-arm's eta per joint and mode (test_arm_comparison_figure below)
           "ArmComparison.plot"}


def _package_plots():
    names = set()
    for pkg in ("plant", "adaptive_ff", "controllers"):
        for path in (ROOT / pkg).rglob("*.py"):
            tree = ast.parse(path.read_text())
            for node in tree.body:
                if isinstance(node, ast.FunctionDef) and node.name.startswith("plot"):
                    names.add(node.name)
                elif isinstance(node, ast.ClassDef):
                    names.update(f"{node.name}.{f.name}" for f in node.body
                                 if isinstance(f, ast.FunctionDef) and f.name == "plot")
    return names


def test_registry_covers_every_plot():
    missing = _package_plots() - COVERED
    assert not missing, f"figures not checked by this module: {sorted(missing)}"


def test_arm_figure():
    pytest.importorskip("pinocchio", reason="the [arm] extra is not installed")
    from adaptive_ff.arm.fit import identify_arm
    from adaptive_ff.arm.robot import load_urdf
    from adaptive_ff.arm.simulate import ArmSimulation, JointFriction, simulate_arm

    arm = load_urdf(Path(__file__).resolve().parents[2] / "examples" / "planar3.urdf")
    fr = [JointFriction(Fc=2.0, Fs=2.6, Vs=0.1, delta=1.0, sigma=0.8), JointFriction(Fc=1.2, Fs=1.5, Vs=0.08,
          delta=1.0, sigma=0.5), JointFriction(Fc=0.5, Fs=0.7, Vs=0.1, delta=1.0, sigma=0.2)]
    res = identify_arm(simulate_arm(arm, fr, run=ArmSimulation(duration=8.0, substeps=1), seed=0,
                                    armature=[0.2, 0.1, 0.05]), arm,
                       n_bootstrap=10, lag=False)  # the figure draws the friction maps: no lag fit needed
    assert check_figure(res.plot()[0].figure, "ArmIdentification.plot") == 3


def test_arm_comparison_figure():
    pytest.importorskip("pinocchio", reason="the [arm] extra is not installed")
    import json
    import tempfile

    from adaptive_ff.arm.fit import identify_arm
    from adaptive_ff.arm.robot import load_urdf
    from adaptive_ff.arm.simulate import ArmPlant, ArmSimulation, JointFriction, simulate_arm
    from controllers.experiments.compare_arm import compare_arm

    arm = load_urdf(Path(__file__).resolve().parents[2] / "examples" / "planar3.urdf")
    fr = [JointFriction(Fc=2.0, Fs=2.6, Vs=0.1, delta=1.0, sigma=0.8), JointFriction(Fc=1.2, Fs=1.5, Vs=0.08,
          delta=1.0, sigma=0.5), JointFriction(Fc=0.5, Fs=0.7, Vs=0.1, delta=1.0, sigma=0.2)]
    # docs/your_arm.md's
    log = simulate_arm(arm, fr, run=ArmSimulation(duration=20.0, substeps=1), seed=1, armature=[0.2, 0.1, 0.05])
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "arm.json"
        # the comparison figure needs the designs, not the lags: the lag fits (the costliest stage) are skipped
        path.write_text(json.dumps(identify_arm(log, arm, n_bootstrap=10, lag=False).to_dict()))
        res = compare_arm(ArmPlant(arm, fr, armature=[0.2, 0.1, 0.05]), path, duration=2.0, seed=0)
    check_figure(res.plot().figure, "ArmComparison.plot")


def test_compare_figures(comp):
    for name, fig in _compare_figures(comp).items():
        check_figure(fig, name)


def test_paper_figures():
    for name, fig in _paper_figures().items():
        check_figure(fig, name)


def test_result_figures():
    for name, fig in _result_figures().items():
        check_figure(fig, name)


def test_identification_figures():
    from adaptive_ff.identification.identify import identify
    from adaptive_ff.identification.ls import fit_ls
    from adaptive_ff.identification.regression import RegressionModel
    from adaptive_ff.io.data import MeasuredData
    from controllers.experiments.paper_figures import identification_figures
    from plant import bandlimited_noise, preset, simulate
    from plant.sampling import sample

    P = preset("paper")
    _, u = bandlimited_noise(20.0, dt=1e-3, cutoff=1.0, std=60.0, rng=np.random.default_rng(3))
    m = sample(simulate(P, u, dt=1e-3), Ts=0.01, noise_std=1e-3, rng=np.random.default_rng(4))
    data = MeasuredData(m.t, m.u, m.w, source="sim")
    rep = identify(data, method="paper")
    figs = {f"identification_figures.{k}": v for k, v in identification_figures(rep, data).items()}
    figs["IdentificationReport.plot"] = rep.plot().figure
    figs["LSResult.plot"] = fit_ls(RegressionModel(P.Vs, P.delta, lag=True), m.u, m.w, Ts=0.01).plot().figure
    for name, fig in figs.items():
        check_figure(fig, name)


def test_checker_catches_a_bad_figure():
    from matplotlib.figure import Figure

    fig = Figure(figsize=(4, 3))
    ax = fig.subplots()
    x = np.linspace(0, 1, 200)
    ax.plot(x, x, label="a")
    ax.plot(x, 1 - x, label="b")
    ax.set_xlabel("time")
    ax.set_ylabel("velocity [rad/s]")
    with pytest.raises(AssertionError, match="no unit"):
        check_figure(fig, "bad")
    ax.set_xlabel("time [s]")
    with pytest.raises(AssertionError, match="no legend"):
        check_figure(fig, "bad")
    ax.legend(loc="center", fontsize=30)
    with pytest.raises(AssertionError, match="legend"):
        check_figure(fig, "bad")


def test_envelope_keeps_every_extreme():
    from controllers.report.figures import minmax_envelope

    rng = np.random.default_rng(0)
    t = np.arange(100_003) * 1e-3
    y = rng.normal(size=t.size)
    y[77_777] = 50.0
    y[5] = np.nan
    tc, lo, hi = minmax_envelope(t, y, n_bins=1000)
    assert tc.size == lo.size == hi.size <= 1001
    assert np.nanmax(hi) == 50.0 and np.nanmin(lo) == np.nanmin(y)
    short = minmax_envelope(t[:10], y[:10])
    assert np.array_equal(short[1], y[:10], equal_nan=True)


def test_rms_dev_and_reversal_choice(comp):
    from controllers.report.figures import pick_reversal, rms_dev

    ref = comp.results["frictionless"].w
    dev = rms_dev(comp)
    for mode, r in comp.results.items():  # independent: plain numpy over the whole run
        assert dev[mode] == pytest.approx(float(np.sqrt(np.mean((r.w - ref) ** 2))), rel=1e-12, abs=1e-15)
    assert dev["frictionless"] == 0.0 and dev["adaptive"] < dev["none"]
    t0 = pick_reversal(comp, half_window=1.0)
    r = comp.results["none"]
    assert 0.5 * r.t[-1] <= t0 <= r.t[-1] - 1.0
    i = np.searchsorted(r.t, t0)
    assert np.sign(r.w_ref[i - 1]) != np.sign(r.w_ref[i])  # a sign change of the reference


# --------------------------------------------------------------------------- figures drawn by a process pool


def test_figures_drawn_by_a_process_pool_are_the_same_files(comp, tmp_path):
    from controllers.report.figures import plot_comparison

    one = plot_comparison(comp, tmp_path / "one", jobs=1)
    two = plot_comparison(comp, tmp_path / "two", jobs=2)
    assert [p.name for p in one] == [p.name for p in two] == ["tracking.png", "error.png", "friction.png",
                                                              "rls_convergence.png", "eta.png"]
    for a, b in zip(one, two):
        assert a.read_bytes() == b.read_bytes(), a.name


def test_figure_inputs_are_small_and_draw_the_same_files(comp, tmp_path):
    import pickle

    from controllers.report.figures import draw_figures, figure_inputs, minmax_envelope, plot_comparison

    inputs = figure_inputs(comp)
    assert list(inputs) == ["tracking", "error", "friction", "rls_convergence", "eta"]
    sent, runs = len(pickle.dumps(inputs)), len(pickle.dumps(comp))
    n = comp.results["none"].t.size  # 12 000 samples per record here (12 s at 1 kHz)
    assert sent < 1e6 and sent < runs / 5, (sent, runs)  # what a pool worker is sent: not the runs

    def arrays(x):
        if isinstance(x, np.ndarray):
            yield x
        elif isinstance(x, dict):
            for v in x.values():
                yield from arrays(v)
        elif isinstance(x, (list, tuple)):
            for v in x:
                yield from arrays(v)
    assert max(a.shape[0] for a in arrays(inputs) if a.ndim) < n // 4  # every long record decimated (zoom: 2 s)
    r = comp.results["adaptive"]  # the decimated error keeps the record's extremes, in deg/s
    tc, lo, hi = inputs["error"]["envelopes"]["adaptive"]
    e = np.rad2deg(r.w_ref - r.w)
    assert np.nanmax(hi) == np.max(e) and np.nanmin(lo) == np.min(e)
    np.testing.assert_array_equal(tc, minmax_envelope(r.t, e)[0])
    a = draw_figures(pickle.loads(pickle.dumps(inputs)), tmp_path / "a")  # as a pool worker gets them
    b = plot_comparison(comp, tmp_path / "b")
    assert [p.name for p in a] == [p.name for p in b]
    for x, y in zip(a, b):
        assert x.read_bytes() == y.read_bytes(), x.name


def _fig(name, inputs, draw):
    """A figure record of ``controllers.report.figures``."""
    from controllers.report import figures as F

    return F._Figure(name, inputs, draw)


def _no_inputs(_comp):
    return {}


def _tiny_figure(_inputs):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(1, 1))
    fig.subplots().plot([0, 1], [0, 1])
    return fig


def test_figures_without_inputs_or_content_are_skipped_and_errors_raised(monkeypatch, tmp_path):
    from controllers.report import figures as F
    from plant.errors import SignalError

    def raises(inputs):
        raise SignalError("bad record")

    monkeypatch.setattr(F, "_FIGURES", (_fig("a", _no_inputs, _tiny_figure), _fig("b", _no_inputs, lambda d: None),
                                        _fig("c", lambda c: None, raises), _fig("d", _no_inputs, _tiny_figure)))
    paths = F.plot_comparison(None, tmp_path)  # b: nothing to show; c: no inputs, not drawn
    assert paths == [tmp_path / "a.png", tmp_path / "d.png"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.png", "d.png"]
    assert all(p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for p in paths)
    monkeypatch.setattr(F, "_FIGURES", (_fig("a", _no_inputs, _tiny_figure), _fig("b", _no_inputs, raises)))
    with pytest.raises(SignalError, match="bad record"):
        F.plot_comparison(None, tmp_path / "e")


def test_jobs_argument_is_checked(tmp_path):
    from controllers.report.figures import draw_figures, plot_comparison
    from plant.errors import ParameterError

    for bad in (0, -1, 1.5, True, "2"):
        with pytest.raises(ParameterError, match="jobs"):
            plot_comparison(None, tmp_path, jobs=bad)
        with pytest.raises(ParameterError, match="jobs"):
            draw_figures({}, tmp_path, jobs=bad)


def test_friction_history_of_the_eq4_estimators_uses_their_own_regression():
    """The eq. 4 estimators' theta (with the offset column ``o1`` for ``eq4``) converts to the plant's friction."""
    from controllers.experiments.compare import compare
    from controllers.report.figures import estimate_history, figure_inputs
    from plant.friction import preset

    p = preset("paper")
    for est, names in (("eq4", 7), ("eq4-rls", 6)):
        c = compare(p, duration=12.0, seed=1, progress=False, estimator=est, modes=("none", "adaptive"))
        assert len(c.results["adaptive"].info["names"]) == names
        hist = estimate_history(c, [3.0, 6.0, 12.0])
        assert len(hist) == 3
        last = hist[-1]
        assert last["Fc"] == pytest.approx(p.Fc, rel=0.06)        # the converged map: Fc 25.3 / 26.1 N·m
        assert last["sigma"] == pytest.approx(p.sigma, rel=0.06)  # sigma 38.5 / 39.2 N·m·s/rad
        assert abs(last["offset"]) < 0.1
        inputs = figure_inputs(c)
        rls = inputs["rls_convergence"]  # the true plant's coefficients in the estimator's own regression
        assert rls["names"] == c.results["adaptive"].info["names"] and rls["true"].shape == rls["theta"].shape
        wide = inputs["friction"]["columns"][0]  # compare's friction figure draws these estimates
        assert [label for label, *_ in wide["curves"]].count("adaptive at t = 12 s") == 1
        assert sum(label.startswith("adaptive at") for label, *_ in wide["curves"]) == 4
