"""Scenario files (controllers/experiments/scenario.py): one TOML file for plant, reference, sensor, drive, design,
modes and a user's compensators; `compare --scenario`, `Scenario.compare`, `assert_tracking_bound(scenario)`.

Independent checks: a scenario's comparison equals the one built by hand from the same objects (plant, reference
of plant.motion, CompareOptions) bit for bit; the design's encoder noise level equals the empirical standard
deviation of a quantised ramp's backward difference; bad files name the file, the key and the value.
"""

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from controllers import CompareOptions, compare
from controllers.cli.main import main
from controllers.experiments.compare import measurement_noise
from controllers.experiments.scenario import Scenario, ScenarioError, load_scenario, scenario_from_dict
from controllers.testing import TrackingBoundError, assert_tracking_bound
from plant import ParameterError, preset
from plant.motion import point_to_point_reference, reversing_reference

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples" / "scenarios"

SMALL = """
name = "small"
seed = 2
modes = ["none", "fixed", "adaptive"]
[plant]
preset = "paper"
[reference]
kind = "point-to-point"
targets = [0.3, -0.1]
repeat = 3
v_max = 0.4
a_max = 4.0
dwell = 0.3
[sensor]
encoder_counts = 65536
delay = 1
[drive]
u_max = 150.0
slew_rate = 1e5
[bounds]
mode = "adaptive"
min_eta = 0.5
"""


def write(tmp_path, text, name="s.toml"):
    f = tmp_path / name
    f.write_text(text, encoding="utf-8")
    return f


def test_a_scenario_is_the_comparison_built_by_hand(tmp_path):
    s = load_scenario(write(tmp_path, SMALL))
    ref = point_to_point_reference([0.3, -0.1] * 3, v_max=0.4, a_max=4.0, dwell=0.3)
    o = CompareOptions.from_flat(seed=2, modes=("none", "fixed", "adaptive"), reference=ref, encoder_counts=65536, delay=1,
                       noise_std=0.0, u_max=150.0, slew_rate=1e5)
    by_hand = compare(preset("paper"), o, progress=False)
    mine = s.compare(progress=False)
    assert s.name == "small" and s.options.duration == pytest.approx(ref.t.size * 1e-3)
    for mode in ("none", "fixed", "adaptive", "frictionless"):
        np.testing.assert_array_equal(mine.results[mode].w, by_hand.results[mode].w)
        assert mine.eta[mode] == by_hand.eta[mode]
    # the encoder and the delay act: the measured velocity of `none` is the counts' difference quotient,
    # one period late (res/Tc steps), and differs from the true velocity
    r = mine.results["none"]
    step = 2 * math.pi / 65536 / 1e-3
    q = np.round(r.w_meas[200:3000] / step)
    np.testing.assert_allclose(r.w_meas[200:3000], q * step, rtol=0, atol=1e-9)
    assert np.max(np.abs(r.w_meas - r.w)) > 0.5 * step
    # the slew limit holds on the applied torque
    assert np.max(np.abs(np.diff(r.u))) <= 1e5 * 1e-3 * (1 + 1e-12)


def test_the_encoder_noise_level_of_the_design_is_the_quantised_difference_quotient():
    """measurement_noise: sqrt(noise^2 + res^2/(6 Tc^2)); checked on a slow ramp through many counts."""
    counts, Tc = 4096, 1e-3
    res = 2 * math.pi / counts
    rng = np.random.default_rng(5)
    w = 0.37 + 0.05 * rng.standard_normal()  # rad/s: positions sweep the counts evenly
    q = 0.123 + w * Tc * np.arange(200_001)
    v = np.diff(res * np.floor(q / res)) / Tc
    o = CompareOptions.from_flat(encoder_counts=counts, noise_std=0.0, Tc=Tc, duration=1.0)
    assert np.std(v - w) == pytest.approx(measurement_noise(o), rel=0.02)
    o2 = CompareOptions.from_flat(encoder_counts=counts, noise_std=0.01, Tc=Tc, duration=1.0)
    assert measurement_noise(o2) == pytest.approx(math.hypot(0.01, measurement_noise(o)), rel=1e-12)
    assert measurement_noise(CompareOptions.from_flat(noise_std=0.003, duration=1.0)) == 0.003


def test_the_cli_runs_a_scenario_with_an_own_compensator(tmp_path, capsys):
    f = EXAMPLES / "robot_base.toml"
    assert main(["compare", "--scenario", str(f), "--json", "--quiet", "--out", str(tmp_path),
                 "--report", str(tmp_path / "report")]) == 0
    d = json.loads(capsys.readouterr().out)
    html = Path(d["report"]).read_text(encoding="utf-8")
    assert html.count("lugre-model") >= 1 and "adaptive-dob" in html  # the own compensator's row in the report
    assert "longest settling (s)" in html and "RMS error in motion" in html  # the columns of a reference with stops
    assert len(d["figures"]) >= 3 and all(Path(x).stat().st_size > 10_000 for x in d["figures"])
    assert set(d["modes"]) == {"none", "fixed", "adaptive", "adaptive-dob", "dob", "frictionless", "lugre-model"}
    assert d["scenario"]["name"] == "robot base joint, pick and place"
    assert d["scenario"]["sensor"] == {"encoder_counts": 131072, "delay": 1, "noise_std": 0.0, "velocity": "kalman"}
    assert d["scenario"]["reference"]["stops"] == 16
    for mode, row in d["modes"].items():  # every mode ran and made the loop no worse than a tenth of none's RMS
        assert row["rms"] is not None and math.isfinite(row["rms"]), mode
    assert d["modes"]["adaptive-dob"]["eta"] >= 0.8


@pytest.mark.parametrize("name", ["robot_base", "linear_axis", "wrist_payload"])
def test_the_example_scenarios_meet_their_own_bounds(name):
    s = load_scenario(EXAMPLES / f"{name}.toml")
    assert s.bounds is not None
    comp = assert_tracking_bound(s)
    assert comp.eta[s.bounds.mode] >= s.bounds.min_eta


def test_assert_tracking_bound_takes_a_path_and_reports_the_scenario(tmp_path):
    f = write(tmp_path, SMALL)
    comp = assert_tracking_bound(f)  # [bounds]: adaptive, min_eta 0.5
    assert set(comp.results) == {"none", "adaptive", "frictionless"}
    with pytest.raises(TrackingBoundError, match=r"mode 'adaptive' on scenario 'small' \(seed 2, 8.65 s\): "
                                                 r"eta [0-9.]+ < min_eta 1.5000"):
        assert_tracking_bound(str(f), min_eta=1.5)
    with pytest.raises(ParameterError, match="mode must be one of"):
        assert_tracking_bound(f, mode="magic", min_eta=0.1)


def test_an_own_compensator_by_file_path_with_keywords(tmp_path):
    (tmp_path / "mine.py").write_text(
        "class Const:\n"
        "    def __init__(self, ctx, level):\n"
        "        self.level, self.J = level, ctx.J\n"
        "    def compensate(self, w_meas, w_ref):\n"
        "        return self.level if w_ref > 0 else -self.level if w_ref < 0 else 0.0\n"
        "    def observe(self, u, w_meas):\n"
        "        pass\n", encoding="utf-8")
    text = SMALL.replace('modes = ["none", "fixed", "adaptive"]', 'modes = ["none"]').replace(
        "[bounds]", '[compensators.const]\nfactory = "mine.py:Const"\nlevel = 25.0\n[bounds]').replace(
        'mode = "adaptive"', 'mode = "const"')
    s = load_scenario(write(tmp_path, text))
    comp = s.compare(progress=False)
    r = comp.results["const"]
    moving = r.w_ref != 0
    np.testing.assert_array_equal(r.u_ff[moving], np.where(r.w_ref[moving] > 0, 25.0, -25.0))
    assert comp.eta["const"] > 0.3  # a Coulomb feedforward at the true level helps


BAD = [
    ("modes = ['none', 'magic']", "modes = 'magic'"),
    ("[plant]\npreset = 'paper'\n[sensor]\nencoders = 5", "[sensor] encoders = 5: unknown key"),
    ("[plant]\npreset = 'nope'", "[plant] preset = 'nope': unknown preset"),
    ("[plant]\nmodel = 'lagged-stribeck'\nJ = -1.0\nFc = 1.0\nFs = 1.0\nVs = 0.1\ndelta = 1.0\nsigma = 0.0\n"
     "tau = 0.0", "[plant] J = -1.0: J must be"),
    ("[plant]\npreset = 'paper'\n[sensor]\nencoder_counts = 0", "[sensor] encoder_counts must be an integer >= 1"),
    ("[plant]\npreset = 'paper'\n[sensor]\ndelay = 40", "[sensor] delay must be an integer number of periods"),
    ("[plant]\npreset = 'paper'\n[drive]\nu_max = -3.0", "[drive] u_max must be"),
    ("[plant]\npreset = 'paper'\n[reference]\nkind = 'spiral'", "[reference] kind = 'spiral': unknown kind"),
    ("[plant]\npreset = 'paper'\n[reference]\nkind = 'point-to-point'\ntargets = []\nv_max = 1.0\na_max = 1.0",
     "[reference] targets = []"),
    ("[plant]\npreset = 'paper'\n[reference]\nkind = 'point-to-point'\ntargets = [1.0]\nv_max = -1.0\na_max = 1.0",
     r"re:\[reference\] \(kind = 'point-to-point'\): v_max must be > 0, got -1.0"),
    ("[plant]\npreset = 'paper'\n[reference]\nkind = 'reversing'\nspeed = 0.3\nhold = 1.0\naccel = 3.0",
     r"re:\[reference\] \(kind = 'reversing'\).*n_reversals"),
    ("[plant]\npreset = 'paper'\n[reference]\nkind = 'file'\npath = 'nowhere.csv'\nvelocity = 'w'",
     r"re:\[reference\] \(kind = 'file'\).*nowhere.csv"),
    ("[plant]\npreset = 'paper'\n[compensators.x]\nfactory = 'no_such_module_xyz:F'",
     "[compensators.x] factory = 'no_such_module_xyz:F': cannot import it"),
    ("[plant]\npreset = 'paper'\n[compensators.adaptive]\nfactory = 'math:sin'", "is a built-in mode's name"),
    ("[plant]\npreset = 'paper'\n[compensators.x]\nfactory = 'math:nothing'", "math has no callable 'nothing'"),
    ("[plant]\npreset = 'paper'\n[bounds]\nmode = 'adaptive'\nmin_eta = 'high'", "[bounds] min_eta = 'high'"),
    ("[plant]\npreset = 'paper'\n[bounds]\nmode = 'dob'", "[bounds]: give at least one"),
    ("[plant]\npreset = 'paper'\n[compensation]\nduration = 5.0", "[compensation] duration = 5.0: unknown key"),
    ("[plant]\npreset = 'paper'\n[compensation]\nestimator = 'magic'", "estimator must be one of"),
    ("seed = -1\n[plant]\npreset = 'paper'", "seed = -1: must be an integer >= 0"),
    ("[reference]\nkind = 'multisine'", "missing table [plant]"),
    # wrong types in [plant], unknown factory keywords and the derived checks: named, before any simulation
    ("[plant]\nmodel = 'lagged-stribeck'\nJ = 'six'\nFc = 1.0\nFs = 1.0\nVs = 0.1\ndelta = 1.0\nsigma = 0.0\n"
     "tau = 0.0", "[plant] J = 'six': J must be a real number"),
    ("[plant]\nmodel = 'lagged-stribeck'\nJ = 4.0\nFc = 1.0\nFs = 1.0\nVs = 0.1\ndelta = 1.0\nsigma = 0.0\n"
     "tau = 0.0\ndrift = {Fc_change = 'x', Fs_change = 0.1, t_start = 0.0, t_end = 1.0}",
     "[plant] drift.Fc_change = 'x': Fc_change must be a real number"),
    ("[plant]\npreset = 'paper'\n[sensor]\nencoder_counts = 1", "[sensor] encoder_counts = 1: its quantisation"),
    ("[plant]\npreset = 'paper'\n[sensor]\nnoise_std = 10.0", "[sensor] noise_std = 10.0 rad/s: the measured"),
    ("[plant]\npreset = 'paper'\n[controller]\ncrossover = 0", "[controller] crossover must be > 0, got 0"),
    ("[plant]\npreset = 'paper'\n[controller]\nTs = 0.0015",
     "[controller] Ts = 0.0015 s must be a positive multiple of Tc = 0.001 s"),
    ("[plant]\npreset = 'paper'\n[drive]\nu_max = 30.0", "[plant] Fs = 35 N·m is above u_max = 30 N·m"),
    ("[plant]\npreset = 'paper'\n[compensators.x]\nfactory = 'math:sin'\nbogus = 3",
     "[compensators.x] bogus = 3: math:sin takes no keyword 'bogus'"),
    ("[plant]\npreset = 'paper'\n[compensators.x]\nfactory = 'fractions:Fraction'",
     "[compensators.x] factory = 'fractions:Fraction': the class Fraction has no method compensate and no method "
     "observe"),
    ("[plant\npreset = 'paper'", "not valid TOML"),
]


@pytest.mark.parametrize("text, message", BAD)
def test_bad_scenario_files_name_the_file_the_key_and_the_value(tmp_path, text, message):
    f = write(tmp_path, text, "bad.toml")
    with pytest.raises(ScenarioError) as info:
        load_scenario(f)
    msg = str(info.value)
    assert msg.startswith(str(f)), msg
    pattern = message[3:] if message.startswith("re:") else re.escape(message)
    assert re.search(pattern, msg), msg


def test_the_cli_refuses_options_the_file_sets_and_missing_files(tmp_path, capsys):
    f = write(tmp_path, SMALL)
    assert main(["compare", "--scenario", str(f), "--seed", "3", "--quiet"]) == 2
    assert "--seed cannot be combined with --scenario: the scenario file sets it (seed)" in capsys.readouterr().err
    assert main(["compare", "--scenario", str(tmp_path / "none.toml"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "none.toml: no such scenario file" in err and "Traceback" not in err


def test_compare_options_check_the_reference_and_the_sensor():
    ref = reversing_reference(0.3, hold=1.0, accel=3.0, n_reversals=2)
    o = CompareOptions.from_flat(reference=ref, duration=999.0)
    assert o.duration == pytest.approx(ref.t.size * 1e-3)  # the reference's length wins
    with pytest.raises(ParameterError, match=r"reference: the time step t\[1\] - t\[0\] = 0.002 s differs from Tc"):
        CompareOptions.from_flat(reference=reversing_reference(0.3, hold=1.0, accel=3.0, n_reversals=2, dt=2e-3))
    bad = reversing_reference(0.3, hold=1.0, accel=3.0, n_reversals=2)
    bad.w[7] = math.nan
    with pytest.raises(ParameterError, match=r"reference.w\[7\] = nan is not a finite number"):
        CompareOptions.from_flat(reference=bad)
    for kw, msg in (({"encoder_counts": 2.5}, "encoder_counts must be"), ({"delay": -1}, "delay must be"),
                    ({"slew_rate": 0.0}, "slew_rate must be"), ({"noise_std": -1.0}, "noise_std")):
        with pytest.raises(ParameterError, match=msg):
            CompareOptions.from_flat(**kw)


def test_scenario_to_dict_is_strict_json_and_the_summary_names_what_runs(tmp_path):
    s = load_scenario(write(tmp_path, SMALL))
    text = json.dumps(s.to_dict(), allow_nan=False)
    d = json.loads(text)
    assert d["reference"] == {"stops": 6, "reversals": 0} and d["drive"]["slew_rate"] == 1e5
    assert "65536-count encoder (difference), 1 period(s) delay" in s.summary()
    assert isinstance(scenario_from_dict({"plant": {"preset": "paper"}}), Scenario)


def test_an_identification_run_too_short_to_fit_falls_back_with_notes():
    """A 3.7 s reference makes a 3.7 s identification run; a Karnopp joint of the zoo hardly leaves zero velocity
    in it: fixed takes the pre-fit's map and the adaptive start the loop's time constant, each with a note (before:
    compare raised the fit's ExcitationError)."""
    from controllers.experiments.zoo import draw_plants
    from plant.models import plant_from_dict

    ref = point_to_point_reference([0.4, -0.2, 0.3], v_max=0.5, a_max=4.0, dwell=0.4)
    p = plant_from_dict(draw_plants(3, ref, seed=4)[0])
    c = compare(p, reference=ref, encoder_counts=2 ** 16, delay=1, seed=4, modes=("fixed", "adaptive"), progress=False)
    assert c.offline is None
    assert any(n.startswith("the identification run could not be fitted (only 0 regression rows") for n in c.notes)
    fixed = [n for n in c.notes if n.startswith("fixed: the offline fit of the identification run failed")]
    assert fixed and "the pre-fit's static map is used instead" in fixed[0]
    assert c.eta["fixed"] > 0.3 and c.eta["adaptive"] > 0.1  # both run and help (adaptive about 0.2)


def test_the_kalman_velocity_reaches_the_runs_and_the_design_noise_level(tmp_path):
    """[sensor] velocity = "kalman": the runs' measured velocity is the C filter's (not the difference quotient's
    0.048 rad/s steps), and the design's noise level is the filter's steady-state P[1, 1] (an independent DARE
    solution with scipy here)."""
    from scipy.linalg import solve_discrete_are

    text = SMALL.replace("delay = 1", 'delay = 0\nvelocity = "kalman"\nvelocity_bandwidth = 50.0')
    sc = load_scenario(write(tmp_path, text))
    o = sc.options
    assert (o.loop.sensor.velocity, o.loop.sensor.velocity_bandwidth, o.loop.sensor.velocity_model) == ("kalman", 50.0,
                                                                                                  "cv")
    res, Tc = 2 * math.pi / 65536, 1e-3
    r = res * res / 12
    wb = 2 * math.pi * 50.0
    S = wb ** 4 * r * Tc  # the tuning rule of adaptive_ff.io.kalman_velocity for cv: (2 pi fb)^(2n) r T
    F = np.array([[1.0, Tc], [0.0, 1.0]])
    Q = S * np.array([[Tc ** 3 / 3, Tc ** 2 / 2], [Tc ** 2 / 2, Tc]])
    H = np.array([[1.0, 0.0]])
    P = solve_discrete_are(F.T, H.T, Q, np.array([[r]]))
    K = P @ H.T / (H @ P @ H.T + r)
    P_post = (np.eye(2) - K @ H) @ P
    assert measurement_noise(o) == pytest.approx(math.sqrt(P_post[1, 1]), rel=1e-6)
    c = sc.compare(progress=False, modes=("none",))
    step = res / Tc
    wm = c.results["none"].w_meas
    wm = wm[np.abs(wm) > step]  # while the joint moves
    assert np.mean(np.abs(wm / step - np.round(wm / step)) > 1e-6) > 0.9  # not on the difference quotient's grid
    with pytest.raises(ParameterError, match=r"velocity_model must be one of \['cv', 'ca'\]"):
        CompareOptions.from_flat(encoder_counts=65536, velocity="kalman", velocity_model="cj")


def test_the_wrist_scenario_has_its_payload_step_and_the_cli_says_so(capsys, tmp_path):
    from plant import PayloadStep

    s = load_scenario(EXAMPLES / "wrist_payload.toml")
    assert isinstance(s.plant, PayloadStep) and s.plant.J_after == 0.08 and s.plant.t_step == 12.0
    assert s.plant.at(11.999).J == 0.05 and s.plant.at(12.0).J == 0.08
    assert main(["compare", "--scenario", str(EXAMPLES / "wrist_payload.toml"), "--quiet", "--no-figures",
                 "--modes", "none"]) == 2  # the file sets the modes
    assert "--modes cannot be combined with --scenario" in capsys.readouterr().err
    assert main(["compare", "--scenario", str(EXAMPLES / "wrist_payload.toml"), "--quiet", "--no-figures",
                 "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "payload step: J 0.05 -> 0.08 kg·m² at t = 12 s" in out and "settle max [s]" in out


def test_the_residual_observer_is_no_faster_than_the_kalman_velocity():
    """With the encoder's Kalman velocity (cv, 100 Hz) adaptive-dob's residual observer is capped at 2*pi*100 rad/s:
    on the small-inertia variant with point-to-point moves and one period of delay eta is 0.68 with a 1000 rad/s
    observer and 1.00 with the capped one."""
    from controllers.experiments.compare import prepare_comparison
    from plant.variant_plants import variant

    ref = point_to_point_reference([0.5, -0.2, 0.4, 0.0, 0.6, -0.3] * 3, v_max=0.5, a_max=4.0, dwell=0.5)
    kw = dict(reference=ref, encoder_counts=2 ** 17, delay=1, noise_std=0.0, u_max=150.0, modes=("none", "adaptive-dob"))
    p = variant("small-inertia")
    s = prepare_comparison(p, CompareOptions.from_flat(velocity="kalman", **kw))
    assert s.mode_options["adaptive-dob"].observer.omega_r == pytest.approx(2 * math.pi * 100.0, rel=1e-12)
    s2 = prepare_comparison(p, CompareOptions.from_flat(velocity="difference", **kw))
    assert s2.mode_options["adaptive-dob"].observer.omega_r == 1000.0
    c = compare(p, CompareOptions.from_flat(velocity="kalman", **kw), progress=False)
    assert c.eta["adaptive-dob"] >= 0.95
