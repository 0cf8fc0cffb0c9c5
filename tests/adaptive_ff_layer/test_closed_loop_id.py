"""Identification on a closed-loop log read out slower than the loop (method 'closed_loop').

The record is the paper's robot experiment (Sec. V-B) as ``paper-figures --save-data`` makes it, shorter: a PI
velocity loop at 1 kHz (crossover 200 rad/s) tracks a multi-sine while the velocity and the (quantised) torque
are read out every 20-40 ms, irregularly, with noise. The open-loop output-error fit, which interpolates the
torque between readouts, is biased there; simulating the known controller on the logged reference is not.
"""

import json

import numpy as np
import pytest

from adaptive_ff.identification.identify import choose_method, identify
from adaptive_ff.identification.physical_id import fit_physical
from adaptive_ff.io.data import MeasuredData
from controllers.cli.main import main
from controllers.design.pi import design_pi
from controllers.experiments.closed_loop_id import (ClosedLoopIdOptions, ControllerSpec, fit_closed_loop,
                                                     identify_closed_loop)
from controllers.experiments.synthetic_logs import closed_loop_readout, write_log_csv
from plant import preset
from plant.errors import ParameterError

P = preset("paper")
VS, DELTA = 0.0197756, 1.01582  # the Stribeck pre-fit of the README's quasi-static log (true 0.02, 1)
TRUE = {"J": P.J, "Fc": P.Fc, "Fs": P.Fs, "sigma": P.sigma, "tau": P.tau}


def _errors(params: dict) -> dict:
    return {k: params[k] / TRUE[k] - 1.0 for k in TRUE}


def _within_targets(err: dict) -> bool:
    """The targets: J, tau within 10 %, Fc, Fs, sigma within 5 %."""
    return (max(abs(err["J"]), abs(err["tau"])) < 0.10
            and max(abs(err["Fc"]), abs(err["Fs"]), abs(err["sigma"])) < 0.05)


@pytest.fixture(scope="module")
def record():
    """30 s of the robot experiment: the 1 kHz loop (sensor noise 1e-3 rad/s seen by the PI), read out at the
    irregular Fig. 10 stamps with noise and a 0.6 N·m torque quantum; the reference at the stamps."""
    exp = closed_loop_readout(P, 30.0, seeds=3)  # crossover 200 rad/s, noise 1e-3 rad/s, quantum 0.6 N·m
    m = exp.measurement
    return MeasuredData(m.t, m.u, m.w), exp.w_ref, ControllerSpec(**exp.controller())


@pytest.fixture(scope="module")
def fit(record):
    m, w_ref, spec = record
    return fit_closed_loop(m, w_ref, controller=spec, Vs=VS, delta=DELTA,
                           options=ClosedLoopIdOptions(n_bootstrap=4))  # few refits: the test's time budget


def test_closed_loop_fit_within_targets(fit):
    err = _errors(fit.params)
    assert _within_targets(err), err
    assert fit.method == "closed_loop" and fit.warnings == ()
    # the simulated loop reproduces the logged velocity; the torque up to the PI's reaction to sensor noise
    # (Kp * 1e-3 rad/s = 0.7 N·m) and the quantum
    assert fit.nrmse > 95.0 and fit.info["fit_u_percent"] > 90.0
    assert 0.6 < fit.info["residual_rms_u"] < 1.3
    assert all(0 < fit.stderr[k] < 0.1 * abs(fit.params[k]) for k in TRUE)
    assert fit.info["hac_lags"] >= 1 and fit.info["stderr_white"].keys() == fit.stderr.keys()
    # bootstrap errors by default (the HAC ones kept), the loop simulated with sensor noise
    boot = fit.info["bootstrap"]
    assert fit.info["stderr_kind"] == "bootstrap" and boot["n"] == 4 and boot["n_valid"] == 4
    assert fit.info["stderr_hac"].keys() == fit.stderr.keys() and boot["block"] >= 3
    # the replicates draw the loop's noise afresh and refit through the start search; t intervals of 4 dof
    assert boot["loop_noise"] == "fresh realisation per replicate" and boot["refit"].startswith("whole estimator")
    # ... with the fit's noise model (its level and common random numbers: redrawn ones covered less,
    # docs/benchmarks/output_error.md)
    assert boot["noise_model"] == "the fit's (its sensor-noise level and common random numbers)"
    # torque residual: mostly (here all) Kp * noise, clipped at 0; velocity: mostly readout noise
    assert 0.0 <= boot["residual_scale"]["u"] < 0.8 < boot["residual_scale"]["w"] <= 1.0
    assert boot["t_quantile"] == pytest.approx(2.7764451051977934, rel=1e-9) and len(boot["replicates"]) == 4
    for k in TRUE:
        reps = np.array([r[k] for r in boot["replicates"]])
        assert fit.stderr[k] == pytest.approx(np.sqrt(np.mean((reps - fit.params[k]) ** 2)), rel=1e-12)
        assert boot["interval95"][k] == pytest.approx([fit.params[k] - 2.7764451051977934 * fit.stderr[k],
                                                        fit.params[k] + 2.7764451051977934 * fit.stderr[k]], rel=1e-9)
    assert fit.info["n_noise"] == 8 and 0.8e-3 < fit.info["sensor_noise"] < 1.3e-3  # the log's level (1e-3)
    d = fit.to_dict()
    json.dumps(d, allow_nan=False)
    assert d["method"] == "closed_loop" and d["info"]["controller"]["u_max"] == pytest.approx(
        fit.info["controller"]["u_max"])


def test_open_loop_output_error_misses_the_targets_on_the_same_record(record):
    """Why the method exists: the torque varies within a readout interval (the PI reacts at 1 kHz)."""
    m, _, _ = record
    oe = fit_physical(m.t, m.u, m.w, Vs=VS, delta=DELTA, method="output_error", offset=False,
                      n_bootstrap=0)  # the estimate only: its standard errors are not the point here
    err = _errors(oe.params)
    assert not _within_targets(err), err
    assert abs(err["tau"]) > 0.2 or abs(err["Fs"]) > 0.08, err  # measured on such logs: tau -40..-50 %, Fs -15 %


def test_identify_closed_loop_auto_chooses_it_and_names_it(record):
    m, w_ref, spec = record
    data = MeasuredData(m.t, m.u, m.w, source="slow robot readout")
    # without reference and controller: the eq. 4 LS, whose free run below 50 % marks the slow closed-loop readout
    free_run = identify(data, Vs=VS, delta=DELTA, lag=True, method="paper",
                        method_options={"n_bootstrap": 0}).ls.fit_free_run
    assert free_run < 50.0 and choose_method(data, Vs=VS, eq4_free_run=free_run)[0] == "paper"
    method, reason = choose_method(data, Vs=VS, controller_Tc=spec.Tc)
    assert method == "closed_loop" and "slower than the controller period 1 ms" in reason
    rep = identify_closed_loop(data, w_ref, controller=spec, Vs=VS, delta=DELTA, lag=True,
                               options=ClosedLoopIdOptions(n_bootstrap=0))
    assert rep.physical.method == "closed_loop" and rep.to_dict()["method"] == "closed_loop"
    assert any("'closed_loop' chosen automatically" in n for n in rep.notes)
    assert any("standard errors HAC (Newey-West, asymptotic; too small" in n for n in rep.notes)
    assert _within_targets(_errors(rep.physical.params))
    # eq. 4 warnings are kept as baseline notes, none refuses the answer
    assert [w for w in rep.warnings if w.refusing] == []
    # a controller-rate record still goes to the sliding regression
    fast = MeasuredData(np.arange(200) * 1e-3, np.sin(np.arange(200) / 7.0), np.cos(np.arange(200) / 9.0))
    assert choose_method(fast, Vs=VS, controller_Tc=1e-3)[0] == "sliding"


def test_paper_identify_refuses_closed_loop_and_says_how(record):
    m, _, _ = record
    data = MeasuredData(m.t, m.u, m.w)
    with pytest.raises(ParameterError, match="identify_closed_loop"):
        identify(data, Vs=VS, delta=DELTA, method="closed_loop")
    rep = identify(data, Vs=VS, delta=DELTA, lag=True, method="auto")  # no reference/controller: eq. 4 ...
    w = [x for x in rep.warnings if x.parameter == "J" and "free run" in x]
    assert len(w) == 1 and "--reference-column" in w[0] and "--controller" in w[0]  # ... says what to add


def test_controller_spec_validation(tmp_path):
    with pytest.raises(ParameterError, match="Kp"):
        ControllerSpec(Kp=-1.0, Ki=1.0, Tc=1e-3)
    with pytest.raises(ParameterError, match="Tc"):
        ControllerSpec(Kp=1.0, Ki=1.0, Tc=0.0)
    with pytest.raises(ParameterError, match="u_max"):
        ControllerSpec(Kp=1.0, Ki=1.0, Tc=1e-3, u_max=-5.0)
    spec = ControllerSpec(Kp=2.0, Ki=3.0, Tc=1e-3)
    assert ControllerSpec.from_dict(json.loads(json.dumps(spec.to_dict()))) == spec  # u_max inf <-> null
    bad = tmp_path / "c.json"
    bad.write_text('{"Kp": 1, "Ki": 2}')
    with pytest.raises(ParameterError, match="missing \\['Tc'\\]"):
        ControllerSpec.from_json(bad)
    with pytest.raises(ParameterError, match="cannot read"):
        ControllerSpec.from_json(tmp_path / "none.json")
    with pytest.raises(ParameterError, match="u_delay"):
        ClosedLoopIdOptions(u_delay=2)


def test_fit_closed_loop_bad_input(record):
    m, w_ref, spec = record
    with pytest.raises(ParameterError, match="faster"):
        fit_closed_loop(m, w_ref, controller=ControllerSpec(Kp=1.0, Ki=1.0, Tc=0.1), Vs=VS, delta=DELTA)
    with pytest.raises(ParameterError, match="ControllerSpec"):
        fit_closed_loop(m, w_ref, controller={"Kp": 1}, Vs=VS, delta=DELTA)
    with pytest.raises(Exception, match="reference never changes sign"):
        fit_closed_loop(m, np.abs(w_ref) + 0.1, controller=spec, Vs=VS, delta=DELTA)
    with pytest.raises(TypeError, match="data must be a MeasuredData, got tuple"):
        fit_closed_loop((m.t, m.u, m.w), w_ref, controller=spec, Vs=VS, delta=DELTA)


def _write_robot_log(tmp_path, record) -> tuple:
    """The record as ``paper-figures --save-data`` writes it: robot_log.csv (ms, A, deg/s) and controller.json."""
    m, w_ref, spec = record
    csv = write_log_csv(tmp_path / "robot_log.csv",
                        {"time_ms": np.round(m.t * 1e3, 6), "current_A": m.u / 60.0, "velocity_deg_s": np.rad2deg(m.w),
                         "reference_deg_s": np.rad2deg(w_ref)})
    ctl = tmp_path / "controller.json"
    ctl.write_text(json.dumps({"Kp": spec.Kp, "Ki": spec.Ki, "Tc": spec.Tc, "u_max": spec.u_max}))
    return csv, ctl


COMMON = ["--time-unit", "ms", "--velocity-unit", "deg/s", "--current-to-torque", "60", "--Vs", str(VS),
          "--delta", str(DELTA), "--quiet"]


def test_cli_auto_names_closed_loop_and_design_accepts_it(record, tmp_path, capsys):
    csv, ctl = _write_robot_log(tmp_path, record)
    assert main(["identify", str(csv), "--columns", "t=time_ms,u=current_A,w=velocity_deg_s,r=reference_deg_s",
                 "--controller", str(ctl), "--lag", "--json", "--bootstrap", "2", *COMMON]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["method"] == "closed_loop"
    assert out["info"]["stderr_kind"] == "bootstrap" and out["info"]["bootstrap"]["n"] == 2
    assert "physical" not in out and _within_targets(_errors({k: out[k] for k in ("J", "Fc", "Fs", "sigma", "tau")}))
    assert not [w for w in out["warnings"] if w["code"] in ("implausible", "identifiability", "conditioning")]
    idj = tmp_path / "id.json"
    idj.write_text(json.dumps(out))
    assert main(["design", "--from", str(idj), "--no-figures", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["J"] == pytest.approx(out["J"]) and "method 'closed_loop'" in d["source"]


def test_cli_text_report_names_the_choice(record, tmp_path, capsys):
    csv, ctl = _write_robot_log(tmp_path, record)
    m, w_ref, spec = record
    assert main(["identify", str(csv), "--columns", "t=time_ms,u=current_A,w=velocity_deg_s",
                 "--reference-column", "reference_deg_s", "--Kp", repr(spec.Kp), "--Ki", repr(spec.Ki),
                 "--Tc", "0.001", "--u-max", repr(spec.u_max), "--bootstrap", "0", *COMMON]) == 0
    text = capsys.readouterr().out
    assert "method 'closed_loop' chosen automatically" in text and "method 'closed_loop': lagged Stribeck" in text
    assert "note: --bootstrap 0: the closed_loop standard errors are HAC (Newey-West, asymptotic)" in text


@pytest.mark.parametrize("value, message", [("-1", "--bootstrap must be an integer >= 0"),
                                            ("2.5", "invalid int value"), ("many", "invalid int value")])
def test_cli_bad_bootstrap_exits_2_before_reading(tmp_path, capsys, value, message):
    # checked before the file is read: the missing file is not what is reported
    try:
        status = main(["identify", str(tmp_path / "missing.csv"), "--bootstrap", value, "--quiet"])
    except SystemExit as exc:  # argparse's own usage error (not an integer)
        status = exc.code
    assert status == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and "missing.csv" not in err


def test_closed_loop_options_validation():
    for bad in ({"n_bootstrap": -1}, {"n_bootstrap": 1.5}, {"bootstrap_seed": True}, {"n_noise": 0},
                {"sensor_noise": -1e-3}, {"sensor_noise": float("nan")}):
        with pytest.raises(ParameterError, match=next(iter(bad))):
            ClosedLoopIdOptions(**bad)
    assert ClosedLoopIdOptions(sensor_noise=0).sensor_noise == 0.0


def test_cli_closed_loop_without_reference_exits_2_naming_what_to_add(record, tmp_path, capsys):
    csv, ctl = _write_robot_log(tmp_path, record)
    assert main(["identify", str(csv), "--columns", "t=time_ms,u=current_A,w=velocity_deg_s", "--method",
                 "closed_loop", "--controller", str(ctl), *COMMON]) == 2
    err = capsys.readouterr().err
    assert "--reference-column" in err and "Traceback" not in err
    assert main(["identify", str(csv), "--columns", "t=time_ms,u=current_A,w=velocity_deg_s", "--Kp", "1",
                 "--reference-column", "reference_deg_s", *COMMON]) == 2
    assert "--Ki" in capsys.readouterr().err
    assert main(["identify", str(csv), "--columns", "t=time_ms,u=current_A,w=velocity_deg_s", "--reference-column",
                 "nope", "--controller", str(ctl), *COMMON]) == 2
    assert "nope" in capsys.readouterr().err


def test_closed_loop_readout_is_the_one_robot_experiment():
    """The readout stays inside the simulated span; an int seed is four consecutive seeds; bad seeds are named."""
    a = closed_loop_readout(P, 2.0, seeds=7)
    b = closed_loop_readout(P, 2.0, seeds=(7, 8, 9, 10))
    m, r = a.measurement, a.run.response
    assert np.array_equal(m.t, b.measurement.t) and np.array_equal(m.u, b.measurement.u)
    assert m.t[0] == 0.0 and m.t[-1] <= r.t[-1] and 0.0185 < np.diff(m.t).min() <= np.diff(m.t).max() < 0.0415
    k = np.rint(m.t / 1e-3).astype(int)
    assert np.array_equal(a.w_ref, a.run.w_ref[k]) and np.array_equal(m.w_true, r.w[k])
    assert np.all(np.abs(m.u / 0.6 - np.rint(m.u / 0.6)) < 1e-9)  # the 0.6 N·m quantum
    c = a.controller()
    assert c == {"Kp": a.design.Kp, "Ki": a.design.Ki, "Tc": 1e-3, "u_max": a.u_max}
    d = design_pi(P.J, crossover=200.0, phase_margin=60.0, Tc=1e-3)
    assert (a.design.Kp, a.design.Ki) == (d.Kp, d.Ki)
    with pytest.raises(ParameterError, match="seeds"):
        closed_loop_readout(P, 2.0, seeds=(1, 2))
