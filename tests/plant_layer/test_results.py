"""The result protocol (plant.results) and the result objects of design, quasi-static runs, data and Kalman velocity."""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from adaptive_ff.io.data import MeasuredData
from adaptive_ff.io.logs import KalmanSettings, LogUnits, velocity_from_position
from controllers.design.loop_analysis import analyse_design
from controllers.design.pi import closed_loop_step, design_pi
from controllers.experiments.paper_figures import PaperFigureOptions, PaperFigures
from controllers.experiments.quasi_static import quasi_static_runs
from plant.errors import ParameterError
from plant.friction import preset
from plant.results import axes_or_new, json_safe, to_json

P = preset("paper")


def _strict(d):
    """Round trip through strict JSON (raises on NaN/inf or non-JSON types)."""
    return json.loads(json.dumps(d, allow_nan=False))


# ---------------------------------------------------------------------------------------------------- helpers
def test_json_safe_maps_non_finite_to_none_and_numpy_to_python():
    src = {
        "a": float("nan"), "b": np.inf, "c": -np.float32(np.inf), "d": np.float64(1.5), "e": np.int64(7),
        "f": np.array([[1.0, np.nan], [np.inf, 2.0]]), "g": (1, np.bool_(True)), "h": {3: Path("x/y")},
        "i": {2, 1}, "j": np.array(4.0), "k": None, "l": "s",
    }
    out = json_safe(src)
    assert out == {"a": None, "b": None, "c": None, "d": 1.5, "e": 7, "f": [[1.0, None], [None, 2.0]],
                   "g": [1, True], "h": {"3": "x/y"}, "i": [1, 2], "j": 4.0, "k": None, "l": "s"}
    assert type(out["d"]) is float and type(out["e"]) is int and type(out["g"][1]) is bool
    assert _strict(out) == out
    assert json.loads(to_json(src)) == out


def test_json_safe_uses_to_dict_and_dataclass_fields():
    class R:
        def to_dict(self):
            return {"x": math.inf}

    assert json_safe([R()]) == [{"x": None}]
    assert json_safe(LogUnits(time_unit="ms")) == {"current_to_torque": None, "time_unit": "ms",
                                                   "velocity_unit": "rad/s", "position_unit": "rad",
                                                   "counts_per_rev": None}


@pytest.mark.parametrize("bad", [object(), 1j, np.array(["a"]), {"k": object()}])
def test_json_safe_rejects_what_json_cannot_hold(bad):
    with pytest.raises(TypeError, match="json_safe"):
        json_safe(bad)


def test_to_json_refuses_allow_nan_and_axes_helper():
    with pytest.raises(TypeError, match="allow_nan"):
        to_json({}, allow_nan=True)
    ax = axes_or_new()
    assert ax.figure is not None and axes_or_new(ax) is ax
    with pytest.raises(TypeError, match="Axes"):
        axes_or_new("ax")


# ---------------------------------------------------------------------------------------------------- objects
def test_pi_design_and_step_protocol():
    d = design_pi(4.0, sigma=40.0, crossover=100.0, phase_margin=60.0, Tc=1e-3)
    j = _strict(d.to_dict())
    assert j["Kp"] == d.Kp and j["Ki"] == d.Ki and j["crossover"] == d.crossover
    assert j["gain_margin_db"] == pytest.approx(20 * math.log10(d.gain_margin), rel=1e-12)
    assert "Kp = " in d.summary() and "phase margin 60.00 deg" in d.summary()
    ax = d.plot()
    assert ax.get_ylabel() == "magnitude (dB)" and len(ax.get_lines()) >= 4
    s = closed_loop_step(d, t_end=0.2)
    js = _strict(s.to_dict())
    assert js["w"] == s.w.tolist() and len(js["t"]) == 201
    assert "w(end)" in s.summary() and s.plot().get_xlabel() == "time t (s)"


def test_loop_analysis_to_dict_is_strict_and_matches_design():
    d = design_pi(4.0, crossover=20.0, phase_margin=60.0, Tc=1e-3)
    a = analyse_design(d, t_end=1.0)
    j = _strict(a.to_dict())
    assert j == a.to_json_dict()
    assert {k: j[k] for k in d.to_dict()} == _strict(d.to_dict())
    assert j["step"]["overshoot_percent"] == a.overshoot and j["bandwidth"] == a.bandwidth
    assert a.plot().get_ylabel() == "velocity w (rad/s)"


def test_gain_margin_inf_becomes_none():
    d = design_pi(4.0, crossover=20.0, phase_margin=60.0, Tc=1e-3)
    import dataclasses

    d_inf = dataclasses.replace(d, gain_margin=math.inf, phase_crossover=math.nan)
    j = _strict(d_inf.to_dict())
    assert j["gain_margin"] is None and j["gain_margin_db"] is None and j["phase_crossover"] is None
    assert "inf (no phase crossover" in d_inf.summary()


def test_quasi_static_data_protocol():
    r = quasi_static_runs(P, [-0.2, 0.2], settle=0.5, hold=0.3)
    j = _strict(r.to_dict())
    assert j["u_mean"] == r.u_mean.tolist() and j["design"]["Kp"] == r.design.Kp and j["hold"] == r.hold
    assert "2 constant-velocity runs" in r.summary()
    assert r.plot().get_ylabel() == "torque u (N·m)"


def test_measured_data_and_velocity_estimate_protocol():
    t = np.cumsum(np.r_[0.0, np.full(49, 0.01)])
    t[10:] += 0.005  # one longer interval: not uniform
    data = MeasuredData(t, np.sin(t), np.cos(t), source="demo")
    j = _strict(data.to_dict())
    assert j["n_samples"] == 50 and j["uniform"] is False and j["Ts_max"] == pytest.approx(0.015)
    assert "t" not in j and _strict(data.to_dict(arrays=True))["w"] == data.w.tolist()
    assert data.summary().startswith("demo: 50 samples")
    assert data.plot().get_ylabel() == "velocity w (rad/s)"
    tt = np.arange(400) * 1e-3
    est = velocity_from_position(tt, np.sin(tt), bandwidth=20.0, position_noise=1e-6)
    je = _strict(est.to_dict())
    assert je["bandwidth"] == 20.0 and je["smoothed"] is True and je["n_samples"] == 400
    assert len(_strict(est.to_dict(arrays=True))["w_std"]) == 400
    assert "bandwidth 20 Hz" in est.summary() and est.plot().get_xlabel() == "time t (s)"


def test_paper_figures_result_and_options(tmp_path):
    numbers = {"stribeck": {"Fc": 1.0, "Fs": 2.0, "Vs": 0.1, "delta": 1.0, "sigma": float("nan"), "n_points": 4},
               "simulation": {"ls_fit_one_step": 99.0, "ls_fit_free_run": 98.0, "rls_fit": 97.0},
               "experiment": {"Ts_mean": 0.022, "ls_fit_one_step": 90.0, "ls_fit_free_run": 80.0, "rls_fit": 85.0}}
    res = PaperFigures(out_dir=tmp_path, figures={"fig08_stribeck": tmp_path / "f.png"}, captions={},
                       numbers=numbers)
    j = _strict(res.to_dict())
    assert j["summary"]["stribeck"]["sigma"] is None and j["figures"]["fig08_stribeck"].endswith("f.png")
    assert "Fig. 8" in res.summary() and "22.00 ms" in res.summary()
    o = PaperFigureOptions(seed=3, n_speeds=4)
    assert _strict(o.to_dict())["seed"] == 3 and o.sim_duration == 30.0


@pytest.mark.parametrize("kwargs, exc, name", [
    (dict(sim_duration=1.0), ParameterError, "sim_duration"),
    (dict(exp_duration=-1.0), ParameterError, "exp_duration"),
    (dict(n_speeds=2), ParameterError, "n_speeds"),
    (dict(n_speeds=3.0), TypeError, "n_speeds"),
    (dict(noise_std=-1e-3), ParameterError, "noise_std"),
    (dict(lam_exp=1.5), ParameterError, "lam_exp"),
    (dict(P0=0.0), ParameterError, "P0"),
    (dict(seed=-1), ParameterError, "seed"),
])
def test_paper_figure_options_validated(kwargs, exc, name):
    with pytest.raises(exc, match=name):
        PaperFigureOptions(**kwargs)
    with pytest.raises(TypeError):
        PaperFigureOptions(0)  # keyword-only


@pytest.mark.parametrize("cls, kwargs, name", [
    (LogUnits, dict(time_unit="h"), "time_unit"),
    (LogUnits, dict(position_unit="counts"), "counts_per_rev"),
    (LogUnits, dict(counts_per_rev=0.0), "counts_per_rev"),
    (LogUnits, dict(current_to_torque=float("nan")), "current_to_torque"),
    (KalmanSettings, dict(model="cj"), "kalman_model"),
    (KalmanSettings, dict(bandwidth=-1.0), "kalman_bandwidth"),
    (KalmanSettings, dict(position_noise=0.0), "position_noise"),
])
def test_log_options_validated(cls, kwargs, name):
    with pytest.raises(ParameterError, match=name):
        cls(**kwargs)
    with pytest.raises(TypeError):
        cls("s")  # keyword-only


def test_physical_params_reads_each_symbol_from_params_and_names_a_missing_one():
    from adaptive_ff.identification.result_file import IdentifiedJoint
    from plant.results import PhysicalParams

    vals = {"J": 0.031, "Fc": 0.72, "Fs": 0.9, "sigma": 0.045, "tau": 2.5e-3}
    joint = IdentifiedJoint(method="paper", params=dict(vals))
    assert isinstance(joint, PhysicalParams)
    assert [joint.J, joint.Fc, joint.Fs, joint.sigma, joint.tau] == list(vals.values())
    with pytest.raises(KeyError, match="tau"):
        IdentifiedJoint(method="paper", params={k: v for k, v in vals.items() if k != "tau"}).tau
