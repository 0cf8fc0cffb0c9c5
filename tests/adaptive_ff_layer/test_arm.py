"""The whole-arm identification (adaptive_ff.arm, adaptive-ff identify-arm) on a simulated three-link planar arm.

The truth is the arm simulated from examples/planar3.urdf (Pinocchio's ABA, armatures added, a Stribeck friction per
joint, a velocity PI per joint, sensor noise; seeded); the rigid body is checked against Pinocchio's own inverse
dynamics (RNEA), an independent computation of what the base parameters must reproduce.
"""

import json
from pathlib import Path

import numpy as np
import pytest

pin = pytest.importorskip("pinocchio", reason="the [arm] extra is not installed: pip install -e '.[arm]'")

from adaptive_ff.arm.arm_log import read_arm_log, write_arm_log  # noqa: E402
from adaptive_ff.arm.fit import identify_arm  # noqa: E402
from adaptive_ff.arm.robot import load_urdf  # noqa: E402
from adaptive_ff.arm.simulate import ArmSimulation, JointFriction, simulate_arm  # noqa: E402
from controllers.cli.main import main  # noqa: E402
from plant.errors import ParameterError, SignalError  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
URDF = ROOT / "examples" / "planar3.urdf"
FRICTION = (JointFriction(Fc=2.0, Fs=2.6, Vs=0.1, delta=1.0, sigma=0.8, offset=0.1),
            JointFriction(Fc=1.2, Fs=1.5, Vs=0.08, delta=1.0, sigma=0.5, offset=-0.05),
            JointFriction(Fc=0.5, Fs=0.7, Vs=0.1, delta=1.0, sigma=0.2, offset=0.0))
ARMATURE = np.array([0.2, 0.1, 0.05])


def _truth(arm):
    theta = arm.theta_urdf.copy()
    theta[-arm.n:] = ARMATURE
    return theta


def _model_with_armature(arm):
    model = arm.model.copy()
    model.armature = ARMATURE.copy()
    return model, model.createData()


@pytest.fixture(scope="module")
def arm():
    return load_urdf(URDF)


@pytest.fixture(scope="module")
def log(arm):
    return simulate_arm(arm, FRICTION, run=ArmSimulation(duration=20.0, substeps=1), seed=1, armature=ARMATURE)


@pytest.fixture(scope="module")
def result(arm, log):
    return identify_arm(log, arm, seed=0, lag=False)  # the lag: test_arm_lag.py


@pytest.fixture(scope="module")
def log_csv(log, tmp_path_factory):
    return write_arm_log(log, tmp_path_factory.mktemp("arm") / "arm_log.csv")


def test_base_parameters_reproduce_pinocchio_inverse_dynamics(arm):
    """The base regressor times the base parameters of the true inertias and armatures equals Pinocchio's RNEA
    of the arm with those armatures, at random states; a planar 3-link arm has 11 base parameters (Iyy, mx, mz
    per link and the armatures of joints 2 and 3; joint 1's armature joins its Iyy)."""
    base = arm.base_parameters()
    assert len(base.names) == 11
    assert any("Ia1" in n and "Iyy1" in n for n in base.names)
    rng = np.random.default_rng(7)
    q, dq, ddq = rng.uniform(-2, 2, (20, 3)), rng.standard_normal((20, 3)), rng.standard_normal((20, 3))
    Yb = arm.regressor(q, dq, ddq)[:, :, base.independent]
    model, data = _model_with_armature(arm)
    rnea = np.array([pin.rnea(model, data, q[k], dq[k], ddq[k]) for k in range(20)])
    np.testing.assert_allclose(Yb @ base.of(_truth(arm)), rnea, rtol=0, atol=1e-10)


def test_base_parameters_inside_their_intervals(arm, result):
    truth = arm.base_parameters().of(_truth(arm))
    lo, hi = result.base_interval.T
    assert np.all((lo <= truth) & (truth <= hi)), list(zip(result.base_names, truth, lo, hi))
    # the identified rigid body reproduces Pinocchio's RNEA of the true arm within 1 % of its RMS torque
    rng = np.random.default_rng(3)
    q, dq, ddq = rng.uniform(-1, 1, (50, 3)), rng.standard_normal((50, 3)), rng.standard_normal((50, 3))
    base = arm.base_parameters()
    model, data = _model_with_armature(arm)
    rnea = np.array([pin.rnea(model, data, q[k], dq[k], ddq[k]) for k in range(50)])
    fit = arm.regressor(q, dq, ddq)[:, :, base.independent] @ result.base_values
    assert np.sqrt(np.mean((fit - rnea) ** 2)) < 0.01 * np.sqrt(np.mean(rnea ** 2))


def test_known_friction_inside_its_intervals(result):
    for joint, f in zip(result.joints, FRICTION):
        for k in ("Fc", "sigma", "Fs", "offset"):
            lo, hi = joint.interval95[k]
            assert lo <= getattr(f, k) <= hi, (joint.name, k, getattr(f, k), joint.params[k], (lo, hi))
        assert abs(joint.params["Fc"] - f.Fc) < 0.02 * f.Fc and abs(joint.params["sigma"] - f.sigma) < 0.03 * f.sigma
        assert np.isnan(joint.params["tau"])


def test_J_is_the_diagonal_inertia_at_the_mean_configuration(arm, log, result):
    """J per joint against Pinocchio's CRBA (armatures included) at the log's mean position: within 1 %."""
    model, data = _model_with_armature(arm)
    M = pin.crba(model, data, log.q.mean(axis=0))
    for j, joint in enumerate(result.joints):
        assert joint.params["J"] == pytest.approx(M[j, j], rel=0.01)


def test_interval_coverage_over_seeds(arm):
    """Coverage of Fc and sigma over 4 other seeded arms (12 joints each): measured 0.94 for both over 6 seeds
    (0-5); at least 9 of 12 here."""
    hits = {"Fc": 0, "sigma": 0}
    for seed in (2, 3, 4, 5):
        res = identify_arm(simulate_arm(arm, FRICTION, run=ArmSimulation(duration=20.0, substeps=1), seed=seed,
                                        armature=ARMATURE),
                           arm, seed=seed, n_bootstrap=100, lag=False)
        for joint, f in zip(res.joints, FRICTION):
            for k in hits:
                lo, hi = joint.interval95[k]
                hits[k] += lo <= getattr(f, k) <= hi
    assert hits["Fc"] >= 9 and hits["sigma"] >= 9, hits


def test_min_speed_is_the_slowest_kept_row(result, log):
    """``excitation.min_speed`` (the placeholder ``Vs`` of a joint without a Stribeck term): the slowest filtered
    speed among the joint's rows, at least the 2 % of its 99th-percentile speed below which rows go, and every row
    at least that fast."""
    from adaptive_ff.arm.arm_log import DEFAULT_CUTOFF, filtered_states

    dq = np.abs(filtered_states(log, DEFAULT_CUTOFF)[2])
    for j, joint in enumerate(result.joints):
        v = joint.min_speed
        assert v >= 0.02 * np.percentile(dq[:, j], 99)
        assert np.min(np.abs(dq[:, j] - v)) == 0.0  # a sample's speed
        assert result.info["rows"][j] <= np.count_nonzero(dq[:, j] >= v)
        assert result.to_dict()["joints"][j]["excitation"]["min_speed"] == v


def test_to_dict_is_strict_json_in_the_issue_layout(result):
    from adaptive_ff.identification.result_file import identification_from_dict

    d = json.loads(json.dumps(result.to_dict(), allow_nan=False))
    assert [j["name"] for j in d["joints"]] == ["shoulder", "elbow", "wrist"]
    for entry, joint in zip(d["joints"], result.joints):
        assert set(entry) >= {"name", "J", "Fc", "Fs", "Vs", "delta", "sigma", "tau", "offset", "interval95",
                              "warnings"}
        assert entry["tau"] is None and entry["interval95"]["tau"] == [None, None]
        assert {"code": "method", "parameter": "tau", "message": f"no friction lag (tau, eq. 1) for joint "
                f"{entry['name']!r}: not asked for (lag=False; identify-arm --no-lag); tau is null"} \
            in entry["warnings"]
        # the simulated 2 mrad/s; the motion's own third differences add a little (measured up to 2.11 mrad/s)
        assert entry["excitation"]["noise_std"] == pytest.approx(2e-3, rel=0.06)
        assert entry["Fc"] == joint.params["Fc"]
        read = identification_from_dict(entry, where="arm.json")  # the reader of identify --json takes an entry
        assert read.J == joint.params["J"] and read.sigma == joint.params["sigma"] and np.isnan(read.tau)
    assert set(d["rigid_body"]) == {"mode", "base_parameters", "interval95", "cond"}
    assert len(d["rigid_body"]["base_parameters"]) == 11 and d["rigid_body"]["cond"] == result.cond
    assert result.cond < 1e3 and d["warnings"] == []  # cond 164 on this log: no conditioning warning


def test_summary_and_plot(result):
    text = result.summary()
    for name in ("joint shoulder", "joint elbow", "joint wrist", "11 base parameters"):
        assert name in text
    axes = result.plot()
    assert len(axes) == 3 and [a.get_title() for a in axes] == ["shoulder", "elbow", "wrist"]


def test_rigid_body_urdf_uses_the_urdf_inertias(arm, log):
    res = identify_arm(log, arm, rigid_body="urdf", n_bootstrap=20, lag=False)
    np.testing.assert_array_equal(res.base_values, arm.base_parameters().of(arm.theta_urdf))
    assert np.all(np.isnan(res.base_interval)) and res.to_dict()["rigid_body"]["interval95"][res.base_names[0]] == [
        None, None]
    M = pin.crba(arm.model, arm.data, log.q.mean(axis=0))  # the URDF's arm: no armatures
    assert res.joints[2].params["J"] == pytest.approx(M[2, 2], rel=0.01)


def test_a_joint_that_barely_moves_is_warned(arm, log):
    import dataclasses

    q = log.q.copy()
    q[:, 2] = 0.01 * np.sin(np.linspace(0, 3, q.shape[0]))
    dq = log.dq.copy()
    dq[:, 2] = np.gradient(q[:, 2], log.t)
    res = identify_arm(dataclasses.replace(log, q=q, dq=dq), arm, n_bootstrap=10, lag=False)
    assert any("barely moves" in w and "'wrist'" in w and w.code == "identifiability" for w in res.joints[2].warnings)
    # its own warning names it; its columns, scaled to unit norm, stay apart from the others' (the zero Fs column of
    # a joint without Stribeck term is no fitted column and counts in no condition number)
    assert np.isfinite(res.cond) and res.cond < 1e3 and res.warnings == ()


# ------------------------------------------------------------------------------------------------ bad input


def _csv(path, header, rows):
    path.write_text(",".join(header) + "\n" + "\n".join(",".join(f"{v:.9g}" for v in r) for r in rows) + "\n")
    return path


def test_library_errors_name_file_and_joint(arm, log, log_csv, tmp_path):
    text = log_csv.read_text().splitlines()
    head = text[0].split(",")
    rows = [list(map(float, line.split(","))) for line in text[1:]]
    # a column missing: the file, the column and the URDF's joint
    drop = head.index("tau3")
    path = _csv(tmp_path / "no_tau3.csv", head[:drop] + head[drop + 1:], [r[:drop] + r[drop + 1:] for r in rows])
    with pytest.raises(SignalError, match=r"no_tau3\.csv.*tau3.*'wrist'"):
        read_arm_log(path, 3, joint_names=arm.names)
    # more joints in the log than in the URDF
    path = _csv(tmp_path / "four.csv", head + ["q4", "tau4"], [r + [0.0, 0.0] for r in rows])
    with pytest.raises(SignalError, match=r"four\.csv.*'q4'.*3 joints"):
        read_arm_log(path, 3)
    # a position beyond the URDF's limits
    import dataclasses

    q = log.q.copy()
    q[100, 1] = 2.9
    with pytest.raises(ParameterError,
                       match=r"simulate_arm: joint 2 \('elbow'\) position 2\.9 at sample 100.*planar3\.urdf"):
        identify_arm(dataclasses.replace(log, q=q), arm)
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot name='x'><link name='a'></robot>")
    with pytest.raises(ParameterError, match=r"bad\.urdf: not a URDF"):
        load_urdf(bad)


def test_cli_identify_arm_json(log_csv, capsys):
    assert main(["identify-arm", str(log_csv), "--urdf", str(URDF), "--json", "--quiet", "--bootstrap", "50",
                 "--no-lag"]) == 0
    d = json.loads(capsys.readouterr().out)
    expected = identify_arm(read_arm_log(log_csv, 3), load_urdf(URDF), n_bootstrap=50, lag=False).to_dict()
    assert d["joints"] == expected["joints"] and d["rigid_body"] == expected["rigid_body"]
    assert abs(d["joints"][0]["Fc"] - 2.0) < 0.04


def test_cli_rows_choice(log_csv, capsys):
    """``--rows`` takes identify_arm's ``ROWS`` (the tuple its keyword is checked against) and passes the choice on:
    ``--rows sliding`` gives identify_arm(rows="sliding")'s result, no flag identify_arm's default (``"moving"``,
    recorded in info.row_selection); a value outside ``ROWS`` exits 2 naming the flag, the value and the choices."""
    from adaptive_ff.arm.fit import DEFAULT_ROWS, ROWS

    assert ROWS == ("moving", "sliding") and DEFAULT_ROWS == "moving"
    args = [str(log_csv), "--urdf", str(URDF), "--json", "--quiet", "--bootstrap", "20", "--no-lag"]
    expected = identify_arm(read_arm_log(log_csv, 3), load_urdf(URDF), n_bootstrap=20, lag=False,
                            rows="sliding").to_dict()
    assert main(["identify-arm", *args, "--rows", "sliding"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["joints"] == expected["joints"] and d["info"]["row_selection"] == "sliding"
    assert main(["identify-arm", *args]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["info"]["row_selection"] == "moving" and d["joints"] != expected["joints"]
    with pytest.raises(SystemExit) as exc:
        main(["identify-arm", *args, "--rows", "fast"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and "--rows" in err and "'fast'" in err
    assert all(repr(r) in err for r in ROWS), err


def test_cli_identify_arm_text(log_csv, capsys):
    assert main(["identify-arm", str(log_csv), "--urdf", str(URDF), "--quiet", "--bootstrap", "20",
                 "--no-lag"]) == 0
    out = capsys.readouterr().out
    assert "joint shoulder" in out and "rigid body (fit)" in out


def _renamed(lines, rename, keep=None):
    """The log's lines with its header renamed (``{old: new}``) and only the columns ``keep`` (old names) kept."""
    head = lines[0].split(",")
    idx = [i for i, h in enumerate(head) if keep is None or h in keep]
    out = [",".join(rename.get(head[i], head[i]) for i in idx)]
    out += [",".join(ln.split(",")[i] for i in idx) for ln in lines[1:]]
    return "\n".join(out) + "\n"


def test_columns_named_after_the_joints_read_as_the_numbered_ones(arm, log_csv, tmp_path):
    """``q_<joint>``, ``dq_<joint>``, ``tau_<joint>`` in any order and case: the same log as ``q1..``, ``tau1..``."""
    lines = log_csv.read_text().splitlines()
    rename = {f"{p}{j + 1}": f"{p}_{n.upper() if j == 1 else n}" for p in ("q", "dq", "tau")
              for j, n in enumerate(arm.names)}
    head = lines[0].split(",")
    order = [head.index("t")] + [head.index(h) for h in reversed(head) if h != "t"]  # columns reversed
    text = [",".join(rename.get(head[i], head[i]) for i in order)]
    text += [",".join(ln.split(",")[i] for i in order) for ln in lines[1:]]
    path = tmp_path / "named.csv"
    path.write_text("\n".join(text) + "\n")
    named = read_arm_log(path, 3, joint_names=arm.names)
    numbered = read_arm_log(log_csv, 3, joint_names=arm.names)
    for k in ("t", "q", "dq", "tau"):
        np.testing.assert_array_equal(getattr(named, k), getattr(numbered, k))


@pytest.mark.parametrize("case", ["urdf_garbage", "urdf_missing", "count", "fewer", "missing_column", "limits",
                                  "cutoff", "unknown_name", "named_missing"])
def test_cli_bad_input_exits_2_naming_file_and_joint(case, log_csv, tmp_path, capsys):
    urdf, log_path, extra = URDF, log_csv, []
    lines = log_csv.read_text().splitlines()
    if case == "urdf_garbage":
        urdf = tmp_path / "robot.urdf"
        urdf.write_text("not xml at all")
        want = ["robot.urdf", "not a URDF"]
    elif case == "urdf_missing":
        urdf = tmp_path / "none.urdf"
        want = ["none.urdf"]
    elif case == "count":
        log_path = tmp_path / "log.csv"
        log_path.write_text("\n".join([lines[0] + ",q4,tau4"] + [ln + ",0,0" for ln in lines[1:]]) + "\n")
        want = ["log.csv", "'q4'", "3 joints"]
    elif case == "fewer":  # the log of a two-joint arm for the three-joint URDF
        log_path = tmp_path / "log.csv"
        log_path.write_text(_renamed(lines, {}, keep={"t", "q1", "q2", "dq1", "dq2", "tau1", "tau2"}))
        want = ["log.csv", "columns of 2 joints", "planar3.urdf", "has 3", "joint count", "joint 3 ('wrist')"]
    elif case in ("unknown_name", "named_missing"):  # columns named after joints the URDF does not have
        names = {"1": "shoulder", "2": "elbow", "3": "knee" if case == "unknown_name" else "wrist"}
        rename = {f"{p}{j}": f"{p}_{n}" for p in ("q", "dq", "tau") for j, n in names.items()}
        keep = None if case == "unknown_name" else {"t", "q1", "q2", "tau1", "tau2"}
        log_path = tmp_path / "log.csv"
        log_path.write_text(_renamed(lines, rename, keep))
        want = (["log.csv", "'q_knee'", "joint 'knee'", "planar3.urdf", "shoulder, elbow, wrist", "joint names"]
                if case == "unknown_name" else ["log.csv", "'q_wrist'", "joint 3 ('wrist')", "planar3.urdf"])
    elif case == "missing_column":
        head = lines[0].split(",")
        k = head.index("q2")
        log_path = tmp_path / "log.csv"
        log_path.write_text("\n".join(",".join(x for i, x in enumerate(ln.split(",")) if i != k) for ln in lines))
        want = ["log.csv", "q2", "'elbow'"]
    elif case == "limits":
        log_path = tmp_path / "log.csv"
        parts = lines[50].split(",")
        parts[3] = "3.5"  # q3
        log_path.write_text("\n".join(lines[:50] + [",".join(parts)] + lines[51:]) + "\n")
        want = ["log.csv", "'wrist'", "3.5", "limits"]
    else:
        extra = ["--cutoff", "900"]
        want = ["--cutoff", "900"]
    assert main(["identify-arm", str(log_path), "--urdf", str(urdf), "--quiet", *extra]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.startswith("adaptive-ff: error:"), err
    for w in want:
        assert w in err, (w, err)


def test_design_from_an_arm_joint(log_csv, tmp_path, capsys):
    """design --from arm.json --joint NAME designs what design --J J --sigma sigma designs with that entry's
    numbers; a joint the file does not have exits 2 naming the file, the joint and the joints it has."""
    assert main(["identify-arm", str(log_csv), "--urdf", str(URDF), "--json", "--quiet", "--bootstrap", "20",
                 "--no-lag"]) == 0
    arm_json = tmp_path / "arm.json"
    arm_json.write_text(capsys.readouterr().out)
    entry = json.loads(arm_json.read_text())["joints"][1]
    common = ["--crossover", "20", "--phase-margin", "60", "--no-figures", "--json"]
    assert main(["design", "--from", str(arm_json), "--joint", "elbow", *common]) == 0
    by_joint = json.loads(capsys.readouterr().out)
    assert main(["design", "--J", repr(entry["J"]), "--sigma", repr(entry["sigma"]), *common]) == 0
    by_numbers = json.loads(capsys.readouterr().out)
    assert by_joint["J"] == entry["J"] and by_joint["sigma"] == entry["sigma"]
    assert (by_joint["Kp"], by_joint["Ki"]) == (by_numbers["Kp"], by_numbers["Ki"])
    assert main(["design", "--from", str(arm_json), "--joint", "knee", *common]) == 2
    err = capsys.readouterr().err
    assert "arm.json" in err and "'knee'" in err and "'elbow'" in err and "Traceback" not in err
    assert main(["design", "--joint", "elbow", *common]) == 2
    assert "--from ARM.json" in capsys.readouterr().err


def test_parallel_filter_is_the_torques_filter():
    """The friction columns' filter (parallel_filter) is the one the torque goes through in filtered_states: the
    same rows, bit for bit, on a seeded random log; a constant passes unchanged (to the Butterworth design's DC gain, 1 - 8e-13, applied twice)."""
    from adaptive_ff.arm.arm_log import ArmLog, filtered_states, parallel_filter

    rng = np.random.default_rng(3)
    t = np.arange(4000) * 1e-3
    q = np.column_stack([np.sin(2 * np.pi * 0.5 * t), np.cos(2 * np.pi * 0.3 * t)])
    log = ArmLog(t=t, q=q, tau=rng.standard_normal((4000, 2)), dq=None, source="synthetic")
    pf = parallel_filter(log, 20.0)
    tt, _, _, _, tau = filtered_states(log, 20.0)
    assert np.array_equal(pf(log.tau), tau) and np.array_equal(t[pf.keep], tt)
    assert pf.keep == slice(50, 3950, 10)  # one cutoff period cut at both ends, decimated to 5 x 20 Hz
    np.testing.assert_allclose(pf(np.ones(4000)), 1.0, rtol=0, atol=1e-11)  # the design's DC gain: 1 - 8e-13


def _profile_row(v, d, shift: float = 0.0):
    """One row ``(Vs, delta, weighted RSS, estimate)`` of the profile of :func:`_stale_profile`."""
    x = np.zeros(8)
    x[4:8] = (1.0, 1.2 + 0.5 * np.log(v / 0.1) if np.isfinite(v) else 0.0, 0.5, 0.01)
    rss = 100.0 + (40.0 * np.log(v / 0.1) ** 2 + (0.0 if d == 1.0 else 30.0) if np.isfinite(v) else 50.0)
    return (v, d, rss + shift, x)


def _stale_profile(shift: float):
    """A joint's profile table as ``_profile`` writes it (the grid of 3 deltas x 8 ``Vs``, the refined best, the
    model without the Stribeck term), each row ``(Vs, delta, weighted RSS, estimate)``, every RSS raised by
    ``shift``: the RSS a quadratic in ``log(Vs / 0.1)`` (curvature 40) at ``delta = 1``, 30 more at the other
    deltas, 50 more without the term, over 100; the estimate (8,) holds ``Fc, Fs, sigma, offset`` at [4:8] with
    ``Fs = 1.2 + 0.5 log(Vs / 0.1)``."""
    from adaptive_ff.arm.fit import DELTA_GRID

    grid = np.geomspace(0.02, 0.3, 8)
    return ([_profile_row(v, d, shift) for d in DELTA_GRID for v in grid]
            + [_profile_row(0.1, 1.0, shift), _profile_row(np.nan, np.nan, shift)]), grid


def test_profile_interval_band_is_the_profile_likelihood_of_each_linear_parameter():
    """With the bootstrap's half-widths ``half`` the range is the profile likelihood's interval over the shape: on the
    quadratic profile of :func:`_stale_profile` (RSS ``100 + 40 l^2``, ``l = log(Vs / 0.1)``, ``Fs = 1.2 + 0.5 l``),
    whose RSS at fixed shape grows by the allowance ``A = 0.768`` at ``Fs ± h``, the set ``{Fs: min over l of
    100 + 40 l^2 + A ((Fs - 1.2 - 0.5 l) / h)^2 <= 100 + A}`` is ``1.2 ± sqrt((0.5 L)^2 + h^2)``, ``L^2 = A / 40``
    (the support function of an ellipse), which a fine grid of ``Vs`` approaches from inside; ``Fc``, the same at
    every shape, keeps ``1.0 ± h``. The union of the whole half-width at every accepted shape would reach
    ``1.2 ± (0.5 L + h)``. Each row's share is ``sqrt(1 - 40 l^2 / A)`` (:func:`band_share`)."""
    from adaptive_ff.arm import intervals

    half = np.array([0.02, 0.1, 0.01, 0.005])
    fine = np.exp(np.linspace(-0.2, 0.2, 801)) * 0.1
    table = [_profile_row(v, 1.0) for v in fine] + [_profile_row(0.1, 1.0), _profile_row(np.nan, np.nan)]
    vs, _, (lo, hi), xs, share = intervals.profile_interval(table, 100.0, 1000, 2.0, slice(4, 8), "wrist", half=half)
    L = np.sqrt(0.768 / 40.0)
    np.testing.assert_allclose([lo[1], hi[1]], 1.2 + np.array([-1, 1]) * np.hypot(0.5 * L, half[1]), rtol=0,
                               atol=1e-6)
    np.testing.assert_allclose([lo[0], hi[0]], [1.0 - half[0], 1.0 + half[0]], rtol=0, atol=1e-12)
    assert hi[1] < 1.2 + 0.5 * L + half[1] - 0.02
    np.testing.assert_allclose(vs, 0.1 * np.exp([-L, L]), rtol=1e-3)
    l_acc = np.log(np.array([r[0] for r in table if r[2] <= 100.768]) / 0.1)
    np.testing.assert_allclose(share, np.sqrt(np.clip(1.0 - 40.0 * l_acc ** 2 / 0.768, 0.0, 1.0)), rtol=0,
                               atol=1e-12)
    np.testing.assert_allclose(intervals.band_share([100.0, 100.384, 101.0], 100.0, 0.768),
                               [1.0, np.sqrt(0.5), 0.0], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(intervals.band_share([99.0, 100.0, 100.1], 100.0, 0.0), [1.0, 1.0, 0.0])


def test_profile_interval_of_a_profile_the_later_joints_lowered():
    """The final fit's RSS (100) below every row of a joint's profile (its rows all 5 higher: the later joints' last
    steps lowered the RSS after the joint's profile was taken): the interval is that of the same profile counted
    from its own minimum, not an IndexError. The bound's half-width 100 * 3.84 * 2 / 1000 = 0.768 accepts the
    ``delta = 1`` rows within |log(Vs / 0.1)| <= sqrt(0.768 / 40) = 0.1386: the refined best 0.1 and the grid's
    0.0940 (RSS 100.15 before the shift); counted from the final fit's RSS alone no row would be inside. Without a
    fit to locate the crossings the Vs range is those accepted values; with one (the same quadratic, unshifted:
    the fit with the other joints' final shapes), it reaches the crossings 0.1 exp(+-0.1386) = 0.0871 and 0.1149
    to within 2**-5 of the grid's step in log Vs (log(15) / 7 / 32 = 0.012) on the inside, and Fs covers its
    estimates there, 1.2 +- 0.5 * 0.1386. A profile or final fit without a finite RSS raises ExcitationError
    naming the joint."""
    from adaptive_ff.arm import intervals
    from plant.errors import ExcitationError

    fresh, grid = _stale_profile(0.0)
    stale, _ = _stale_profile(5.0)
    cols = slice(4, 8)
    got = intervals.profile_interval(stale, 100.0, 1000, 2.0, cols, "wrist")
    want = intervals.profile_interval(fresh, 100.0, 1000, 2.0, cols, "wrist")
    accepted = [v for v in grid if 40.0 * np.log(v / 0.1) ** 2 <= 0.768] + [0.1]
    assert got[0] == want[0] == (min(accepted), max(accepted)) and got[1] == (1.0, 1.0)
    fs = [1.2 + 0.5 * np.log(v / 0.1) for v in accepted]
    np.testing.assert_allclose(got[2][0], [1.0, min(fs), 0.5, 0.01], rtol=0, atol=1e-12)
    np.testing.assert_allclose(got[2][1], [1.0, max(fs), 0.5, 0.01], rtol=0, atol=1e-12)
    assert got[3].shape == (len(accepted), 8)
    calls = []

    def fit_at(v, d):  # the same profile between the grid's values, the later joints' steps taken
        calls.append((v, d))
        _, _, rss, x = _profile_row(v, d)
        return x, rss

    located = intervals.profile_interval(stale, 100.0, 1000, 2.0, cols, "wrist", fit_at)
    edge = np.sqrt(0.768 / 40.0)
    step = np.log(grid[1] / grid[0]) / 2 ** intervals.CROSSING_STEPS
    lo_v, hi_v = np.log(np.array(located[0]) / 0.1)
    assert -edge <= lo_v <= -edge + step and edge - step <= hi_v <= edge, (lo_v, hi_v, edge)
    np.testing.assert_allclose(located[2][0][[0, 2, 3]], [1.0, 0.5, 0.01], rtol=0, atol=1e-12)
    assert 1.2 - 0.5 * edge <= located[2][0][1] <= 1.2 - 0.5 * (edge - step)
    assert 1.2 + 0.5 * (edge - step) <= located[2][1][1] <= 1.2 + 0.5 * edge
    assert {d for _, d in calls} == {1.0} and len(calls) == 1 + 2 * intervals.CROSSING_STEPS  # the best, two sides
    for rss_min, table in ((np.nan, fresh), (100.0, [(v, d, np.nan, x) for v, d, _, x in fresh])):
        with pytest.raises(ExcitationError, match="'wrist'.*no finite weighted residual"):
            intervals.profile_interval(table, rss_min, 1000, 2.0, cols, "wrist")
