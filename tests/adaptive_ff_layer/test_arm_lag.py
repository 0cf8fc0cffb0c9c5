"""Each joint's friction lag and velocity noise from the whole-arm log (adaptive_ff.arm.lag, identify-arm), and what
export-c makes of them (--start, the stick band), on a simulated three-link planar arm with a known lag.

The truth: examples/planar3.urdf with armatures, a Stribeck friction with a 10 ms lag on every joint, the default
sensor noise (velocity 2 mrad/s), a velocity PI per joint; 10 s at 1 kHz, seed 1.
"""

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pinocchio", reason="the [arm] extra is not installed: pip install -e '.[arm]'")

from adaptive_ff.arm.fit import identify_arm  # noqa: E402
from adaptive_ff.arm.lag import LAG_SLOPE_MIN, joint_lag  # noqa: E402
from adaptive_ff.arm.robot import load_urdf  # noqa: E402
from adaptive_ff.arm.simulate import ArmSimulation, JointFriction, SensorNoise, simulate_arm  # noqa: E402
from controllers.cli.main import main  # noqa: E402

pytestmark = pytest.mark.slow  # output-error fits of three joints

ROOT = Path(__file__).resolve().parents[2]
URDF = ROOT / "examples" / "planar3.urdf"
TAU = 0.01
FRICTION = (JointFriction(Fc=2.0, Fs=2.6, Vs=0.1, delta=1.0, sigma=0.8, offset=0.1, tau=TAU),
            JointFriction(Fc=1.2, Fs=1.5, Vs=0.08, delta=1.0, sigma=0.5, offset=-0.05, tau=TAU),
            JointFriction(Fc=0.5, Fs=0.7, Vs=0.1, delta=1.0, sigma=0.2, tau=TAU))
ARMATURE = [0.2, 0.1, 0.05]


@pytest.fixture(scope="module")
def arm():
    return load_urdf(URDF)


@pytest.fixture(scope="module")
def log(arm):
    return simulate_arm(arm, FRICTION, run=ArmSimulation(duration=10.0, substeps=1), seed=1, armature=ARMATURE)


@pytest.fixture(scope="module")
def result(arm, log):
    return identify_arm(log, arm, n_bootstrap=20, seed=1)


@pytest.fixture(scope="module")
def result_sliding(arm, log):
    return identify_arm(log, arm, n_bootstrap=20, seed=1, rows="sliding")


@pytest.fixture(scope="module")
def arm_json(result, tmp_path_factory):
    path = tmp_path_factory.mktemp("lag") / "arm.json"
    path.write_text(json.dumps(result.to_dict(), allow_nan=False))
    return path


def test_each_joint_lag_determined(result):
    """The default rows ("moving"): every joint's lag is reported (no warning on ``tau``), with an interval far from
    zero, from the whole 10 s record at 1 kHz."""
    for joint in result.joints:
        lo, hi = joint.interval95["tau"]
        assert 0.8 * TAU < lo and hi < 1.25 * TAU  # determined: an interval far from zero
        assert joint.lag_info["samples"] > 9000 and joint.lag_info["rate"] == pytest.approx(1000.0)
        assert not [w for w in joint.warnings if w.parameter == "tau"]


def test_each_joint_lag_inside_its_interval(result):
    """The default rows ("moving"): each estimate within 4 % of the true 10 ms, the true lag inside every
    interval. Measured: 9.67 [8.90, 10.44], 9.84 [9.34, 10.33] and 9.89 [8.04, 11.73] ms (the wrist's stops refined)."""
    for joint in result.joints:
        lo, hi = joint.interval95["tau"]
        assert lo <= TAU <= hi, (joint.name, joint.params["tau"], (lo, hi))
        assert joint.params["tau"] == pytest.approx(TAU, rel=0.04)


def test_each_joint_lag_inside_its_interval_sliding_rows(result_sliding):
    """rows="sliding" (``--rows sliding``): the static whole-arm fit (the first pass) reads part of the shoulder's lag
    as Stribeck shape (Vs 0.205 rad/s, delta 2 for the true 0.1 and 1), which its lag fit holds; its bootstrap
    refits hold the shapes the whole-arm profile accepts, and its interval holds the true lag. The wrist, whose
    stops its lag fit refines (it sticks: Fc Ts / J above LAG_REFINE_STICK), is null: its fit reads 9.22 [6.33,
    10.66] ms, but its refits read it 0.73 ms (7.9 %) longer on average, above LAG_SHIFT_MAX. Measured: 9.16 [7.62,
    10.70] and 10.15 [9.31, 10.99] ms."""
    from adaptive_ff.arm.lag import LAG_SHIFT_MAX

    assert result_sliding.info["row_selection"] == "sliding"
    for joint in result_sliding.joints[:2]:
        lo, hi = joint.interval95["tau"]
        assert lo <= TAU <= hi, (joint.name, joint.params["tau"], (lo, hi))
    wrist = result_sliding.joints[2]
    info = wrist.lag_info
    assert info["stop_band"] is not None and math.isnan(wrist.params["tau"])
    assert info["estimate"] == pytest.approx(TAU, rel=0.1) and info["interval95"][0] <= TAU <= info["interval95"][1]
    assert LAG_SHIFT_MAX * info["estimate"] < info["bias"] < 1.5 * LAG_SHIFT_MAX * info["estimate"]
    assert [w for w in wrist.warnings if w.parameter == "tau" and "more on average" in w.message]


def test_reported_lag_is_the_low_pass_correction(result):
    """Each reported lag is the output-error estimate corrected for the record's low-pass (adaptive_ff.arm.lag,
    "Reported"): on the secant through the two worlds' (lag, reading) points, the lag that reads as the estimate;
    the interval is centred there, ± the Student-t quantile of the valid refits times their RMS deviation over the
    secant's slope (held within [LAG_SLOPE_MIN, 1]; 1 where not positive)."""
    from scipy import stats

    for joint in result.joints:
        info, (lo, hi) = joint.lag_info, joint.interval95["tau"]
        corr = info["lowpass"]
        (x1, x2), (y1, y2) = corr["worlds"], corr["reads"]
        assert x1 == info["estimate"] and x2 == max(x1 - (y1 - x1), 0.5 * x1) and x2 != x1
        assert LAG_SLOPE_MIN <= corr["slope"] <= 1.0
        secant = (y1 - y2) / (x1 - x2)
        if LAG_SLOPE_MIN <= secant <= 1.0:
            assert corr["slope"] == pytest.approx(secant, rel=1e-12)
        elif 0.0 < secant < LAG_SLOPE_MIN:  # a flatter secant is the two world fits' scatter
            assert corr["slope"] == LAG_SLOPE_MIN
        else:  # the mapping never narrows the interval
            assert corr["slope"] == 1.0
        assert y2 + corr["slope"] * (joint.params["tau"] - x2) == pytest.approx(info["estimate"], rel=1e-12)
        half = stats.t.ppf(0.975, info["n_valid"]) * info["rms"] / corr["slope"]
        assert (lo, hi) == pytest.approx((joint.params["tau"] - half, joint.params["tau"] + half), rel=1e-12)


def test_whole_arm_fit_with_the_lags_in_its_columns(arm, log, result):
    """Each reported lag goes into its joint's friction columns and the whole-arm fit runs again (adaptive_ff.arm.fit,
    "Lag"): the static map without the lag reads every joint's inertia low (the lag of a friction that rises with
    speed acts as an inertia term), outside its interval (measured 1.0559 [1.0525, 1.0593], 0.2277 [0.2255, 0.2299],
    0.05636 [0.05575, 0.05697] kg·m² for the true 1.0602, 0.2318, 0.05737); with the lags, every joint's ``J`` lies
    inside its interval and within 1.5 % of the truth (measured 1.0608 [1.0587, 1.0628], 0.2317 [0.2303, 0.2330],
    0.05795 [0.05714, 0.05879]). The truth: Pinocchio's
    ``M_jj`` at the log's mean position, with the armatures."""
    import pinocchio as pin

    model = arm.model.copy()
    model.armature = np.array(ARMATURE)
    M = pin.crba(model, model.createData(), log.q.mean(axis=0))
    static = identify_arm(log, arm, n_bootstrap=20, seed=1, lag=False)
    assert result.info["lagged_columns"] == [joint.params["tau"] for joint in result.joints]
    assert static.info["lagged_columns"] == [None, None, None]
    for j, (joint, other) in enumerate(zip(result.joints, static.joints)):
        lo, hi = joint.interval95["J"]
        assert lo <= M[j, j] <= hi and joint.params["J"] == pytest.approx(M[j, j], rel=0.015), (joint.name, lo, hi)
        lo, hi = other.interval95["J"]
        assert not lo <= M[j, j] <= hi and other.params["J"] < M[j, j], (joint.name, other.params["J"], lo, hi)


@pytest.mark.parametrize("tau", [0.002, 0.01])
def test_lagged_columns_follow_the_first_order_lag(tau):
    """The friction columns' lag (adaptive_ff.arm.fit._lagger, eq. 1 at the log's rate) against scipy.signal.lsim of
    1/(tau s + 1) on the same sampled signal, linearly interpolated (a sine and a sign that switches, 1 kHz): the
    same to 1e-9 of the signal's amplitude (both exact for that input)."""
    from scipy.signal import lsim

    from adaptive_ff.arm import fit

    Ts = 1e-3
    t = np.arange(2000) * Ts
    x = np.column_stack([np.sin(2 * np.pi * 3 * t), np.sign(np.sin(2 * np.pi * 2 * t + 0.3))])
    lagged = fit._lagger([tau, tau], Ts)(x)
    for k in range(2):
        _, ref, _ = lsim(([1.0], [tau, 1.0]), x[:, k], t, X0=[x[0, k] * tau], interp=True)
        assert np.max(np.abs(lagged[:, k] - ref)) < 1e-9 * np.max(np.abs(x[:, k]))
    assert np.array_equal(fit._lagger([0.0, np.nan], Ts)(x), x)  # no lag: unchanged


def test_noise_estimate_per_joint(result, arm_json):
    """The velocity noise of each joint against the simulated 2 mrad/s (measured 1.982, 1.986, 2.040 mrad/s), in
    the entry as identify --json has it (excitation.noise_std)."""
    noise = SensorNoise().dq
    entries = json.loads(arm_json.read_text())["joints"]
    for joint, entry in zip(result.joints, entries):
        assert joint.noise_std == pytest.approx(noise, rel=0.03)
        assert entry["excitation"] == {"noise_std": joint.noise_std, "min_speed": joint.min_speed}
        assert entry["tau"] == joint.params["tau"] and entry["interval95"]["tau"] == list(joint.interval95["tau"])


def test_export_c_start_from_an_arm_file(result, arm_json, tmp_path, capsys):
    """export-c --from arm.json --start: every joint's start map carries its identified lag, and every joint's stick
    band is three times its noise estimate (the export of an identify --json with that noise)."""
    out = tmp_path / "arm_ff"
    assert main(["export-c", "--from", str(arm_json), "--start", "--u-max", "50", "--out", str(out),
                 "--accept-warnings"]) == 0
    capsys.readouterr()
    header = (out / "aff_config.h").read_text()
    source = (out / "aff_config.c").read_text()
    bands = [float(x) for x in re.findall(r"\.stick_band = \(aff_real\)([0-9.eE+-]+)", source)]
    assert len(bands) == 3
    for joint, band in zip(result.joints, bands):
        m = re.search(rf"#define AFF_{joint.name.upper()}_START_TAU ([0-9.eE+-]+)", header)
        assert m is not None and float(m.group(1)) == joint.params["tau"]
        assert band == 3.0 * joint.noise_std


def test_export_c_start_refuses_a_joint_without_lag(arm, log, tmp_path, capsys):
    """identify_arm(lag=False): tau null with a method warning naming the joint (design and export still take the
    entry); export-c --start exits 2 naming the file, the joint and tau."""
    res = identify_arm(log, arm, n_bootstrap=20, seed=1, lag=False)
    d = res.to_dict()
    for entry in d["joints"]:
        assert entry["tau"] is None and entry["interval95"]["tau"] == [None, None]
        assert {"code": "method", "parameter": "tau", "message": f"no friction lag (tau, eq. 1) for joint "
                f"{entry['name']!r}: not asked for (lag=False; identify-arm --no-lag); tau is null"} \
            in entry["warnings"]
    path = tmp_path / "nolag.json"
    path.write_text(json.dumps(d))
    assert main(["export-c", "--from", str(path), "--start", "--u-max", "50", "--out", str(tmp_path / "x"),
                 "--accept-warnings"]) == 2
    err = capsys.readouterr().err
    assert "nolag.json" in err and "'shoulder'" in err and "tau" in err and "Traceback" not in err


def test_no_reversal_gives_no_lag_and_says_why():
    """A record whose velocity never changes sign determines no lag: NaN, and the output-error fit's reason."""
    t = np.arange(3000) * 1e-3
    lag = joint_lag(t, 1.0 + 0.3 * np.cos(2 * np.pi * t), 0.5 + 0.2 * np.sin(2 * np.pi * t), 0.1, 1.0,
                    n_bootstrap=2)
    assert np.isnan(lag.tau) and np.all(np.isnan(lag.interval95))
    assert "failed" in lag.reason and "no reversals" in lag.reason


def test_lag_options_are_checked(arm):
    from adaptive_ff.arm.lag import LagOptions
    from plant.errors import ParameterError

    with pytest.raises(ParameterError, match="LagOptions.n_bootstrap must be an integer >= 2, got 1"):
        LagOptions(n_bootstrap=1)
    with pytest.raises(ParameterError, match="LagOptions.workers must be an integer >= 1, got 0"):
        LagOptions(workers=0)
    log = simulate_arm(arm, FRICTION, run=ArmSimulation(duration=2.0, substeps=1), seed=3, armature=ARMATURE)
    with pytest.raises(ParameterError, match="lag must be True, False or a LagOptions, got 3"):
        identify_arm(log, arm, lag=3)


def test_lag_records_draw_the_rigid_body_replicates_errors(arm, log):
    """lag_records' error draws are each whole-arm replicate's removed torque less the fit's: a replicate whose
    rigid body adds a constant torque c per joint reads e = -c on every sample; one whose J is larger by dJ reads
    e = dJ ddq, ddq the central difference of the record's (1 kHz, every sample) velocity away from its ends."""
    from adaptive_ff.arm.lag import lag_records

    theta = np.array(arm.theta_urdf, dtype=float)
    J = np.array([0.3, 0.15, 0.06])
    c, dJ = np.array([0.2, -0.1, 0.05]), np.array([0.01, 0.02, -0.005])
    rigid = lambda Y: Y @ theta  # noqa: E731
    t, u, w, e = lag_records(log, arm, rigid, J, 20.0, replicates=[(lambda Y: Y @ theta + c, J), (rigid, J + dJ)])
    t0, u0, w0 = lag_records(log, arm, rigid, J, 20.0)
    assert np.array_equal(t, t0) and np.array_equal(u, u0) and np.array_equal(w, w0) and e.shape == (2,) + u.shape
    np.testing.assert_allclose(e[0], np.broadcast_to(-c, u.shape), rtol=0, atol=1e-12)
    ddq = np.gradient(w, t, axis=0)
    np.testing.assert_allclose(e[1][1:-1], (ddq * dJ)[1:-1], rtol=1e-9, atol=1e-12)


@pytest.fixture(scope="module")
def shoulder_fit(log):
    """``(t, u, w, options, fit)``: 2.5 s of the shoulder's record and its output-error fit with two partial
    bootstrap refits, the plain bootstrap the options' tests compare against."""
    from adaptive_ff.identification.physical_id import fit_physical

    t, u, w = log.t[1000:3500], log.tau[1000:3500, 0], log.dq[1000:3500, 0]
    kw = dict(Vs=0.1, delta=1.0, n_bootstrap=2, bootstrap_refit="partial", bootstrap_workers=1, input_delay=0.0)
    return t, u, w, kw, fit_physical(t, u, w, **kw)


def test_output_error_bootstrap_input_errors(shoulder_fit):
    """fit_physical's bootstrap_input_errors: rows of zeros give the bootstrap without them, bit for bit (each world
    one simulation more); a constant error of 0.05 N·m moves the refits; a row of the wrong length, a NaN or a
    vector is refused by name."""
    from adaptive_ff.identification.physical_id import fit_physical
    from plant.errors import ParameterError

    t, u, w, kw, plain = shoulder_fit
    zero = fit_physical(t, u, w, bootstrap_input_errors=np.zeros((2, t.shape[0])), **kw)
    assert zero.info["interval95"] == plain.info["interval95"] and zero.info["bootstrap"]["input_errors"] == 2
    assert zero.info["bootstrap"]["n_simulations"] == plain.info["bootstrap"]["n_simulations"] + 2
    moved = fit_physical(t, u, w, bootstrap_input_errors=np.full((1, t.shape[0]), 0.05), **kw)
    assert moved.params == plain.params and moved.info["interval95"]["tau"] != plain.info["interval95"]["tau"]
    with pytest.raises(ParameterError, match="bootstrap_input_errors must have one column per sample"):
        fit_physical(t, u, w, bootstrap_input_errors=np.zeros((2, 10)), **kw)
    with pytest.raises(ParameterError, match="bootstrap_input_errors must be a finite"):
        fit_physical(t, u, w, bootstrap_input_errors=np.full((2, t.shape[0]), np.nan), **kw)
    with pytest.raises(ParameterError, match="bootstrap_input_errors must be a finite"):
        fit_physical(t, u, w, bootstrap_input_errors=np.zeros(t.shape[0]), **kw)


def test_output_error_bootstrap_shapes(shoulder_fit):
    """fit_physical's bootstrap_shapes: one row, the held shape, gives the bootstrap without them, bit for bit; a
    shape 3 times slower moves the refits (their world stays the estimate at the held shape) and not the estimate; a
    NaN, a Vs <= 0 or a vector is refused by name."""
    from adaptive_ff.identification.physical_id import fit_physical
    from plant.errors import ParameterError

    t, u, w, kw, plain = shoulder_fit
    held = fit_physical(t, u, w, bootstrap_shapes=[(0.1, 1.0)], **kw)
    assert held.info["interval95"] == plain.info["interval95"] and held.info["bootstrap"]["shapes"] == 1
    assert plain.info["bootstrap"]["shapes"] is None
    moved = fit_physical(t, u, w, bootstrap_shapes=[(0.3, 1.0)], **kw)
    assert moved.params == plain.params and moved.info["bootstrap"]["bias"] != plain.info["bootstrap"]["bias"]
    for bad in ([(np.nan, 1.0)], [(0.0, 1.0)], [0.1, 1.0]):
        with pytest.raises(ParameterError, match="bootstrap_shapes must be a finite"):
            fit_physical(t, u, w, bootstrap_shapes=bad, **kw)


def test_accepted_shapes_drawn_by_likelihood():
    """The shapes a joint's lag refits hold (adaptive_ff.arm.intervals.accepted_shapes): the profile's rows with a Stribeck
    term within the 95 % bound ``max(rss_min, best) + 3.84 ratio rss_min / n_rows``, drawn systematically by weight
    exp(-chi2 / 2). Rows at chi2 0, 2 ln 3 (weight 1/3) and beyond the bound, and the row without the term: 20 draws
    are 15 of the first and 5 of the second; a table with no such row gives None."""
    from adaptive_ff.arm.intervals import accepted_shapes

    rss_min, n_rows, ratio = 100.0, 384, 2.0  # allowance 2.0: chi2 = 1.92 (rss - best)
    chi2_b = 2.0 * np.log(3.0)
    table = [(0.1, 1.0, 100.0, None), (0.2, 2.0, 100.0 + chi2_b / 1.92, None), (0.4, 1.0, 102.5, None),
             (np.nan, np.nan, 100.5, None)]
    out = accepted_shapes([table, [(np.nan, np.nan, 100.0, None)]], rss_min, n_rows, ratio, draws=20)
    assert out[1] is None
    shapes, counts = np.unique(out[0], axis=0, return_counts=True)
    assert shapes.tolist() == [[0.1, 1.0], [0.2, 2.0]] and counts.tolist() == [15, 5]


def test_lag_ranges_of_the_intervals():
    """The lag range each joint's columns take in the intervals' two point fits (adaptive_ff.arm.intervals.lag_ranges): a
    lag in the columns its interval (a lower end at zero: none); a null lag whose fit ran from none to the larger of
    that fit's upper end and the reporting floor (2 samples: 2 ms at 1 kHz); a lag kept out of the columns, or a
    fit that failed, none; no range at all: None."""
    from adaptive_ff.arm.intervals import lag_ranges
    from adaptive_ff.arm.lag import JointLag

    info = {"rate": 1000.0, "interval95": [0.7e-3, 1.1e-3]}
    lags = [JointLag(5e-3, (4e-3, 6e-3), None, {"rate": 1000.0}),
            JointLag(np.nan, (np.nan, np.nan), "floor", info),
            JointLag(np.nan, (np.nan, np.nan), "floor", dict(info, interval95=[2.3e-3, 3.0e-3])),
            JointLag(7e-3, (6e-3, 8e-3), None, {"rate": 1000.0}),
            JointLag(np.nan, (np.nan, np.nan), "failed", {"samples": 100}),
            JointLag(3e-3, (-1e-3, 7e-3), None, {"rate": 1000.0})]
    lagged = np.array([5e-3, np.nan, np.nan, np.nan, np.nan, 3e-3])  # the fourth kept out of the columns
    low, high = lag_ranges(lags, lagged)
    assert np.allclose(low, [4e-3, 0.0, 0.0, np.nan, np.nan, 0.0], equal_nan=True)
    assert np.allclose(high, [6e-3, 2e-3, 3e-3, np.nan, np.nan, 7e-3], equal_nan=True)
    assert lag_ranges(lags[3:5], lagged[3:5]) is None


def test_lag_stays_out_of_the_columns_only_beyond_the_likelihood_bound():
    """adaptive_ff.arm.fit._lag_raises_residual: a joint's residual sum of squares over its kept rows may rise by
    ``3.84 ratio / n_j`` of the lag-free fit's (ratio 5, 1000 rows: 1.92 %) before its lag leaves the columns. Raised
    by 1 % (RMS by 0.5 %): kept; by 3 %: out; lowered: kept."""
    from adaptive_ff.arm import fit

    rng = np.random.default_rng(3)
    e = rng.standard_normal((1000, 3))
    keep = np.ones((1000, 3), bool)
    stage = fit._Stage(*([None] * len(fit._Stage._fields)))._replace(keep_j=keep, resid=e, ratio=5.0)
    new = stage._replace(resid=e * np.sqrt([1.01, 1.03, 0.9]))
    assert fit._lag_raises_residual(stage, fit._residual_rms(keep, new.resid)).tolist() == [False, True, False]


def test_lag_workers_do_not_change_the_result(log):
    """The joints' lag fits in two worker processes give what they give one after the other in this process, bit
    for bit (each joint's bootstrap has its own seed)."""
    from adaptive_ff.arm.lag import LagOptions, joint_lags

    t = log.t[1000:4000]
    u, w = log.tau[1000:4000], log.dq[1000:4000]
    shapes = [(f.Vs, f.delta) for f in FRICTION]
    serial = joint_lags(t, u, w, shapes, options=LagOptions(n_bootstrap=2, workers=1), seed=5)
    parallel = joint_lags(t, u, w, shapes, options=LagOptions(n_bootstrap=2, workers=2), seed=5)
    assert [x.info for x in serial] == [x.info for x in parallel]
    for a, b in zip(serial, parallel):
        assert (a.reason, a.tau, a.interval95) == (b.reason, b.tau, b.interval95) or (
            np.isnan(a.tau) and np.isnan(b.tau) and a.reason == b.reason)


def test_lag_worlds_one_per_joint():
    """joint_lags takes one LagWorld per joint; worlds of another count are a ParameterError naming both counts."""
    from adaptive_ff.arm.lag import LagOptions, LagWorld, joint_lags
    from plant.errors import ParameterError

    t = np.arange(100) * 1e-3
    u = w = np.zeros((100, 3))
    with pytest.raises(ParameterError, match=r"worlds must hold one LagWorld per joint \(3\), got 2"):
        joint_lags(t, u, w, [(0.1, 1.0)] * 3, options=LagOptions(workers=1), worlds=[LagWorld()] * 2)


def test_compare_arm_designs_take_the_noise_and_start_per_joint(arm, result, arm_json, tmp_path):
    """compare-arm's loops: the stick band three times each entry's noise estimate (``--noise`` where an entry has
    none), and with ``start`` a start map on the joints that have a lag only."""
    from controllers.experiments.compare_arm import CompareArmOptions, joint_designs

    d = json.loads(arm_json.read_text())
    d["joints"][1]["tau"] = None  # the elbow without a lag
    del d["joints"][2]["excitation"]  # the wrist without a noise estimate
    path = tmp_path / "mixed.json"
    path.write_text(json.dumps(d))
    designs = joint_designs(path, arm, CompareArmOptions(start=True, noise_std=1e-3, u_max=50.0))
    assert [x.settings["start"] for x in designs] == [True, False, True]
    assert [x.noise_source for x in designs] == ["identification", "identification", "options"]
    assert designs[0].settings["stick_band"] == 3.0 * result.joints[0].noise_std
    assert designs[2].settings["stick_band"] == 3.0 * 1e-3
    assert designs[0].options.feedforward.start is not None and designs[1].options.feedforward.start is None


def _true_records(arm, friction, run, seed):
    """``(t, u, w)`` of lag_records on the planar arm simulated with ``friction`` (``run``, ``seed``, the armatures
    ARMATURE), with the true rigid body removed (the URDF's inertias with those armatures) and the true ``M_jj`` at the
    log's mean configuration added back, at the default cutoff of 20 Hz."""
    from adaptive_ff.arm.lag import lag_records
    from adaptive_ff.arm.simulate import ArmPlant

    log = simulate_arm(arm, friction, run=run, seed=seed, armature=ARMATURE)
    theta = np.array(arm.theta_urdf, dtype=float)
    theta[-arm.n:] = ARMATURE
    J = np.diag(ArmPlant(arm, friction, armature=ARMATURE).mass_matrix(np.mean(log.q, axis=0)))
    return lag_records(log, arm, lambda Y: Y @ theta, J, 20.0)


def test_lag_free_joint_null_and_lagged_joint_covered(arm):
    """The planar arm with a 10 ms lag on the elbow alone (10 s, seed 2): each joint's lag fit on its record with
    the URDF's rigid body removed and its true Stribeck shape held. The lag-free shoulder and wrist, which the
    output-error fit reads as 0.51 [0.35, 0.68] and 0.65 [0.52, 0.77] ms (intervals that exclude zero), are null:
    their intervals reach below two samples of the record (lag_reason); the lagged elbow is reported, 9.46 [8.84,
    10.81] ms, holding the true 10 ms (``benchmarks/arm_lag.py`` has the rates over arms). The wrist's velocity
    noise, low-passed with the record, is what the one-step predictor with its velocity reset to the measurement
    (``injection_gain=1``) reads as a lag of about 8 ms (module docstring of adaptive_ff.arm.lag, "Predictor")."""
    from dataclasses import replace

    from adaptive_ff.arm.lag import LAG_INJECTION_GAIN
    from adaptive_ff.identification.physical_id import fit_physical

    friction = [replace(f, tau=TAU if j == 1 else 0.0) for j, f in enumerate(FRICTION)]
    t, u, w = _true_records(arm, friction, ArmSimulation(duration=10.0, substeps=1), seed=2)
    shoulder = joint_lag(t, u[:, 0], w[:, 0], friction[0].Vs, friction[0].delta, seed=2)
    elbow = joint_lag(t, u[:, 1], w[:, 1], friction[1].Vs, friction[1].delta, seed=4)
    wrist = joint_lag(t, u[:, 2], w[:, 2], friction[2].Vs, friction[2].delta, seed=6)
    for free in (shoulder, wrist):
        assert np.isnan(free.tau) and np.all(np.isnan(free.interval95)), free
        lo, hi = free.info["interval95"]
        assert 0.0 < lo < hi < 1e-3 and "below 2 samples of the record (2 ms)" in free.reason, free
    assert elbow.reason is None and elbow.interval95[0] <= TAU <= elbow.interval95[1], elbow
    assert elbow.tau == pytest.approx(TAU, rel=0.06)
    assert LAG_INJECTION_GAIN < 1.0
    reset = fit_physical(t, u[:, 2], w[:, 2], Vs=friction[2].Vs, delta=friction[2].delta, n_bootstrap=0,
                         input_delay=0.0, injection_gain=1.0)
    assert reset.info["predictor"] == "one-step" and reset.info["injection_gain"] == 1.0
    assert reset.params["tau"] > 5e-3 > 5.0 * wrist.info["estimate"]


def test_lag_free_sticking_joint_null_by_its_corrected_interval(arm):
    """The planar arm without any lag, its stops integrated finely (``stop_refine=10``, as a continuous arm's; 10 s,
    seed 0), the wrist's record with the true rigid body removed and its true Stribeck shape held: at the record's
    step the output-error fit reads the wrist's sticking at its stops as a lag of about 2.5 ms, with a fit interval
    above the floor (measured 2.46 [2.14, 3.31] ms), which the low-pass correction's wider interval reaches below
    (2.48 [1.69, 3.27] ms): null, as the floor holds for the reported interval too (module docstring of
    adaptive_ff.arm.lag, "Reported")."""
    from dataclasses import replace

    from adaptive_ff.arm.lag import LAG_FLOOR_SAMPLES, LagWorld

    friction = [replace(f, tau=0.0) for f in FRICTION]
    t, u, w = _true_records(arm, friction, ArmSimulation(duration=10.0, substeps=1, stop_refine=10), seed=0)
    wrist = joint_lag(t, u[:, 2], w[:, 2], friction[2].Vs, friction[2].delta, seed=2, world=LagWorld(lowpass=100.0))
    floor = LAG_FLOOR_SAMPLES / wrist.info["rate"]
    lo, hi = wrist.info["interval95"]
    assert floor < lo < wrist.info["estimate"] < hi < 2.0 * floor, wrist.info  # the fit alone would report it
    corrected = wrist.info["lowpass"]["tau"]
    assert floor < corrected < hi, wrist.info  # a positive lag, above the floor itself
    assert np.isnan(wrist.tau) and np.all(np.isnan(wrist.interval95)), wrist
    assert "once corrected for the record's low-pass" in wrist.reason and "below 2 samples of the record (2 ms)" \
        in wrist.reason, wrist.reason
    m = re.search(r"interval \[([0-9.]+), ([0-9.]+)\] ms, which reaches below", wrist.reason)
    assert float(m.group(1)) < 1e3 * floor < 1e3 * corrected < float(m.group(2)), wrist.reason


def test_lag_reason_rules():
    """lag_reason on the numbers of three joints of benchmarks/arm_lag.py --coarse-arms (ms): a lag-free elbow read
    4.05 [1.60, 5.12] whose refits read 0.69 longer on average (17 % of it): null; a lagged shoulder 5.85 [5.67,
    5.81], refits 0.11 longer (1.9 %): reported; a lag-free shoulder 0.91 [0.84, 1.17] at 1 kHz: null (below 2 ms),
    reported from a record at 4 kHz (floor 0.5 ms)."""
    from adaptive_ff.arm.lag import lag_reason

    elbow = lag_reason(4.05e-3, (1.60e-3, 5.12e-3), {"rate": 1000.0, "bias": 0.69e-3})
    assert elbow is not None and "refits read 0.69 ms more on average (more than 7.5 % of it)" in elbow
    assert lag_reason(5.85e-3, (5.67e-3, 5.81e-3), {"rate": 1000.0, "bias": 0.11e-3}) is None
    floor = lag_reason(0.91e-3, (0.84e-3, 1.17e-3), {"rate": 1000.0, "bias": -0.1e-3})
    assert floor is not None and "below 2 samples of the record (2 ms)" in floor
    assert lag_reason(0.91e-3, (0.84e-3, 1.17e-3), {"rate": 4000.0, "bias": -0.1e-3}) is None
    assert "no finite interval" in lag_reason(5e-3, (np.nan, np.nan), {"rate": 1000.0, "bias": 0.0})
    assert "reaches zero" in lag_reason(5e-3, (-1e-3, 9e-3), {"rate": 1000.0, "bias": 0.0})


def test_correction_reason_rules():
    """correction_reason and corrected_interval on the numbers of the finely integrated lag-free wrist of
    test_lag_free_sticking_joint_null_by_its_corrected_interval (ms): the estimate 2.46 corrected to 2.48, 10 valid
    refits with an RMS deviation of 0.35: interval 2.48 ± t(0.975, 10) 0.35 / slope, [1.70, 3.26] at slope 1, below
    the floor of 2 ms at 1 kHz: null; at 4 kHz (floor 0.5 ms) reported; from a fit with refined stops (a stop band)
    reported (the floor on the corrected interval holds for fits at the record's step), there null where the
    interval reaches zero (refits scattering by 1.2 ms) and reported where it does not (1.0 ms); a secant of slope 0.5 doubles
    the half-width; a correction to no positive lag: null, refined or not; no correction (its worlds failed): no
    reason."""
    from scipy import stats

    from adaptive_ff.arm.lag import corrected_interval, correction_reason

    info = {"estimate": 2.46e-3, "rate": 1000.0, "n_valid": 10, "rms": 0.35e-3,
            "lowpass": {"tau": 2.48e-3, "slope": 1.0, "reads": [2.5e-3, 2.3e-3]}}
    half = stats.t.ppf(0.975, 10) * 0.35e-3
    assert corrected_interval(info) == pytest.approx((2.48e-3, 2.48e-3 - half, 2.48e-3 + half), rel=1e-12)
    assert 1.69e-3 < 2.48e-3 - half < 1.71e-3
    reason = correction_reason(info)
    assert reason is not None and "reads 2.48 ms once corrected for the record's low-pass, with the 95 % interval " \
        "[1.7, 3.26] ms, which reaches below 2 samples of the record (2 ms)" in reason, reason
    assert correction_reason(dict(info, rate=4000.0)) is None
    assert correction_reason(dict(info, stop_band=0.11)) is None and correction_reason(dict(info, stop_band=None))
    wide = dict(info, stop_band=0.11, rms=1.2e-3)  # refined: the corrected interval 2.48 -+ 2.67 ms reaches zero
    assert corrected_interval(wide)[1] < 0.0 < corrected_interval(dict(info, rms=1.0e-3))[1]
    assert "which reaches zero" in correction_reason(wide)
    assert correction_reason(dict(wide, rms=1.0e-3)) is None
    flat = dict(info, lowpass=dict(info["lowpass"], slope=0.5))
    assert corrected_interval(flat)[1] == pytest.approx(2.48e-3 - 2.0 * half, rel=1e-12)
    negative = dict(info, lowpass=dict(info["lowpass"], tau=-0.1e-3))
    assert "all the record's low-pass" in correction_reason(negative)
    assert "all the record's low-pass" in correction_reason(dict(negative, stop_band=0.11))
    assert correction_reason(dict(info, lowpass=None)) is None


def test_lag_reason_stick_rule():
    """A joint that sticks hard (its Coulomb friction takes off at least LAG_STICK_MAX = 0.015 rad/s in one sample)
    has no lag reported from a fit at the record's step: the heavy wrist of benchmarks/arm_coverage.py's seed 22
    (--coarse-arms; Fc Ts / J = 0.0410 rad/s; true lag 4.40 ms) read 9.17 [7.16, 12.19] ms, its refits 0.51 ms
    shorter. Refined stops (a stop band) lift the rule, and so does a joint below the bound."""
    from adaptive_ff.arm.lag import LAG_STICK_MAX, lag_reason

    assert LAG_STICK_MAX == 0.015
    info = {"rate": 1000.0, "bias": -0.51e-3, "stop_band": None}
    heavy = lag_reason(9.17e-3, (7.16e-3, 12.19e-3), {**info, "stick": 0.0410})
    assert heavy is not None and "Coulomb friction takes off 0.041 rad/s of its velocity in one sample" in heavy
    assert "--refine-stops" in heavy
    assert lag_reason(9.17e-3, (7.16e-3, 12.19e-3), {**info, "stick": 0.0149}) is None
    assert lag_reason(9.17e-3, (7.16e-3, 12.19e-3), {**info, "stick": 0.0410, "stop_band": 0.113}) is None
    assert lag_reason(9.17e-3, (7.16e-3, 12.19e-3), {**info, "stick": None}) is None


def test_uncorrected_lag_carries_a_warning(arm, log, monkeypatch):
    """A reported lag whose low-pass correction could not run (its worlds not simulated or fitted: ``info["lowpass"]``
    None) is the fit's own reading, and the joint's warnings say so; a corrected one carries no such warning."""
    import adaptive_ff.arm.fit as arm_fit
    from adaptive_ff.arm.lag import JointLag

    def lags(t, u, w, shapes, **kw):
        return [JointLag(0.01, (0.009, 0.011), None, {"lowpass": None if j == 0 else {"tau": 0.01}})
                for j in range(u.shape[1])]

    monkeypatch.setattr(arm_fit, "joint_lags", lags)
    res = identify_arm(log, arm, n_bootstrap=20, seed=1)
    tau_warnings = [[w.message for w in joint.warnings if w.parameter == "tau"] for joint in res.joints]
    assert tau_warnings[0] == [f"the friction lag of joint {arm.names[0]!r} is not corrected for the record's "
                               "low-pass (the correction's worlds could not be simulated or fitted): tau is the "
                               "output-error fit's own reading, read it as an upper bound and its interval as too "
                               "narrow"]
    assert all(not m for m in tau_warnings[1:])
    assert res.joints[0].params["tau"] == 0.01


def test_null_lag_ranges_capped_where_the_residual_rejects_them(arm, log, monkeypatch):
    """A null lag ranges from none to its fit's upper end in the point fits the intervals carry, that end capped
    where, in the joint's friction columns, it raises the joint's residual beyond the likelihood-ratio bound: halved
    until accepted, then bisected (NULL_CAP_BISECTIONS times) between that end and the last rejected one. On the
    planar arm with a 10 ms lag on every joint, every lag made null with a fit interval reaching 200 ms on the
    shoulder and 12 ms on the elbow and the wrist: 12 ms, near the true lag, stands; 200 ms is rejected and capped at
    the largest accepted end tried, within a sixteenth of the halving bracket ``[a, 2a]`` below the smallest rejected
    end tried, above the floor (2 ms); without a range (the fit's interval not finite) none."""
    import adaptive_ff.arm.fit as arm_fit
    from adaptive_ff.arm.lag import JointLag

    def lags(t, u, w, shapes, **kw):
        his = (0.2, 0.012, np.nan)
        return [JointLag(np.nan, (np.nan, np.nan), "made null", {"rate": 1000.0, "interval95": [0.001, hi]})
                for hi in his]

    tried = []  # (joint, end, accepted) of each cap's point fit, read from the columns' lags and the residual test
    point_problem, raises = arm_fit._point_problem, arm_fit._lag_raises_residual

    def spy_problem(setup, *args):
        spy_problem.lags = setup[3]
        return point_problem(setup, *args)

    def spy_raises(stage, rms):
        out = raises(stage, rms)
        if getattr(spy_problem, "lags", None) is not None:
            j = int(np.flatnonzero(np.isfinite(spy_problem.lags))[0])
            tried.append((j, float(spy_problem.lags[j]), not out[j]))
            spy_problem.lags = None
        return out

    monkeypatch.setattr(arm_fit, "joint_lags", lags)
    monkeypatch.setattr(arm_fit, "_point_problem", spy_problem)
    monkeypatch.setattr(arm_fit, "_lag_raises_residual", spy_raises)
    ranges = identify_arm(log, arm, n_bootstrap=20, seed=1).info["lag_ranges"]
    assert ranges[2] is None
    assert ranges[1] == [0.0, 0.012]
    assert [(j, end, ok) for j, end, ok in tried if j == 1] == [(1, 0.012, True)]
    lo, hi = ranges[0]
    shoulder = [(end, ok) for j, end, ok in tried if j == 0]
    accepted = [end for end, ok in shoulder if ok]
    rejected = [end for end, ok in shoulder if not ok]
    assert shoulder[0] == (0.2, False) and len(shoulder) >= 2 + arm_fit.NULL_CAP_BISECTIONS, shoulder
    assert lo == 0.0 and hi == max(accepted) and 0.002 < hi < min(rejected), (ranges, shoulder)
    halved = accepted[0]  # the halving stops at its first accepted end a, the bracket [a, 2a]
    assert 2 * halved in rejected, shoulder
    assert min(rejected) - hi <= halved / 16 * (1 + 1e-12), (halved, shoulder)  # halving alone leaves a gap of a


def test_low_pass_correction_of_a_fit_that_searches_the_stribeck_shape():
    """joint_lag without a Stribeck shape (Vs, delta NaN: the output-error fit searches it) corrects its lag too,
    its worlds holding the shape the fit found: a one-joint record of eqs. 1-3 with a 10 ms lag reads it within
    5 %, as with the true shape given."""
    from adaptive_ff.arm.lag import LagWorld, joint_lag
    from adaptive_ff.identification.simulator import simulate_sampled
    from plant.friction import JointParams

    t = np.arange(0.0, 4.0, 1e-3)
    u = 0.6 * np.sin(2 * np.pi * 0.7 * t) + 0.3 * np.sin(2 * np.pi * 2.3 * t + 1.0)
    p = JointParams(J=0.05, Fc=0.2, Fs=0.3, Vs=0.1, delta=1.0, sigma=0.2, tau=0.01)
    w = simulate_sampled(p, t, u, w0=0.0, f0=0.0, offset=0.0) + 1e-4 * np.random.default_rng(0).standard_normal(t.size)
    for Vs, delta in ((p.Vs, p.delta), (np.nan, np.nan)):
        lag = joint_lag(t, u, w, Vs, delta, n_bootstrap=2, world=LagWorld(lowpass=100.0))
        assert lag.reason is None and lag.info["lowpass"]["tau"] == lag.tau
        assert lag.tau == pytest.approx(p.tau, rel=0.05)


def test_cli_refine_stops(arm, tmp_path, capsys):
    """``identify-arm --refine-stops`` refines each joint's stops in its lag fit (``LagOptions(refine_stops=True)``):
    its record's band is ``LAG_STOP_BAND max(|Fc|, |Fs|) Ts / J`` of the whole-arm fit (``Fs`` where the joint keeps
    a Stribeck term; the reported entry's values are the second pass's, within 4 % of the first's here), recorded as
    ``lag.stop_band``; ``--coarse-stops`` none (null); by default (``"auto"``) the band where the joint's stick speed
    lies in [LAG_REFINE_STICK, LAG_STICK_MAX), none elsewhere. Either way ``lag.stick`` records ``Fc Ts / J`` (the lag
    rule's stick speed, adaptive_ff.arm.lag.stick_speeds)."""
    from adaptive_ff.arm.arm_log import write_arm_log
    from adaptive_ff.arm.lag import LAG_REFINE_STICK, LAG_STICK_MAX, LAG_STOP_BAND

    log = simulate_arm(arm, FRICTION, run=ArmSimulation(duration=4.0, substeps=1), seed=4, armature=ARMATURE)
    path = write_arm_log(log, tmp_path / "arm.csv")
    args = ["identify-arm", str(path), "--urdf", str(URDF), "--json", "--quiet", "--bootstrap", "20",
            "--lag-bootstrap", "2", "--workers", "1"]
    runs = {}
    for flag in ("--refine-stops", "--coarse-stops", None):
        assert main([*args, flag] if flag else args) == 0
        runs[flag] = json.loads(capsys.readouterr().out)["joints"]
    for e, p, d in zip(runs["--refine-stops"], runs["--coarse-stops"], runs[None]):
        static = max(abs(e["Fc"]), abs(e["Fs"])) if e["Vs"] is not None else abs(e["Fc"])
        band = LAG_STOP_BAND * static / e["lag"]["rate"] / e["J"]
        assert e["lag"]["stop_band"] == pytest.approx(band, rel=0.05), (e["name"], e["lag"]["stop_band"], band)
        assert p["lag"]["stop_band"] is None and p["lag"]["samples"] == e["lag"]["samples"]
        assert p["lag"]["stick"] == pytest.approx(abs(e["Fc"]) / e["lag"]["rate"] / e["J"], rel=0.05), p["name"]
        sticks = LAG_REFINE_STICK <= d["lag"]["stick"] < LAG_STICK_MAX
        assert (d["lag"]["stop_band"] is not None) == sticks, (d["name"], d["lag"]["stick"])
        if sticks:
            assert d["lag"]["stop_band"] == e["lag"]["stop_band"], d["name"]
    # by default the wrist (0.5 N·m of Coulomb friction on about 0.057 kg·m²: Fc Ts / J near 0.009 rad/s) alone
    assert [d["lag"]["stop_band"] is not None for d in runs[None]] == [False, False, True]


def test_lag_decision_reports_the_corrected_lag_or_the_reason():
    """lag_decision, which joint_lag and benchmarks/arm_lag.py both decide by, on the wrist of
    test_correction_reason_rules (ms): its fit 2.46 [2.14, 3.31] passes lag_reason, its corrected interval [1.70,
    3.26] reaches below the 2 ms floor at 1 kHz: null with correction_reason's text; at 4 kHz the corrected lag
    and interval; without a correction the fit's own; a fit whose interval reaches zero: lag_reason's text; a
    failed fit (no estimate): null without a reason."""
    from adaptive_ff.arm.lag import corrected_interval, correction_reason, lag_decision, lag_reason

    info = {"estimate": 2.46e-3, "interval95": [2.14e-3, 3.31e-3], "rate": 1000.0, "bias": 0.0, "n_valid": 10,
            "rms": 0.35e-3, "lowpass": {"tau": 2.48e-3, "slope": 1.0, "reads": [2.5e-3, 2.3e-3]}}
    tau, (lo, hi), reason = lag_decision(info)
    assert np.isnan([tau, lo, hi]).all() and reason == correction_reason(info) and "once corrected" in reason
    fast = dict(info, rate=4000.0)
    tau, (lo, hi), reason = lag_decision(fast)
    assert reason is None and (tau, lo, hi) == corrected_interval(fast) and tau == pytest.approx(2.48e-3)
    assert lag_decision(dict(info, lowpass=None)) == (2.46e-3, (2.14e-3, 3.31e-3), None)
    zero = dict(info, interval95=[-1e-3, 5e-3])
    tau, _, reason = lag_decision(zero)
    assert np.isnan(tau) and reason == lag_reason(2.46e-3, (-1e-3, 5e-3), zero) and "reaches zero" in reason
    tau, (lo, hi), reason = lag_decision({"samples": 100})
    assert np.isnan([tau, lo, hi]).all() and reason is None
