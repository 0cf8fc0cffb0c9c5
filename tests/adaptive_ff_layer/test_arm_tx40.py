"""A real arm: the Staubli TX40 log in data/tx40 (motor side, with its transmission) through identify-arm.

The reference values are those of thanhndv212/figaroh-examples, examples/staubli_TX40/config/TX40_config.yaml
(``fv``, ``fs``: viscous and Coulomb friction per joint, joint side). The motor-to-joint conversion is checked
against that repository's own formulas (``red_q`` with ``red_q[5, 4] = N6``, ``red_tau`` with ``red_tau[4, 5] =
N6``), written out here independently of ``Transmission``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pin = pytest.importorskip("pinocchio")

from adaptive_ff.arm.arm_log import read_arm_log  # noqa: E402
from adaptive_ff.arm.fit import identify_arm  # noqa: E402
from adaptive_ff.arm.robot import load_urdf  # noqa: E402
from adaptive_ff.arm.transmission import read_transmission  # noqa: E402
from controllers.cli.main import main  # noqa: E402
from plant.errors import ParameterError  # noqa: E402

DATA = Path(__file__).resolve().parents[2] / "data" / "tx40"
LOG, URDF, TOML = DATA / "tx40_motor.npz", DATA / "tx40.urdf", DATA / "transmission.toml"
RATIO = np.array([32.0, 32.0, 45.0, -48.0, 45.0, 32.0])
FV = np.array([8.05, 5.53, 1.97, 1.11, 1.86, 0.65])  # TX40_config.yaml: viscous, N·m·s/rad
FS = np.array([7.14, 8.26, 6.34, 2.48, 3.03, 0.282])  # TX40_config.yaml: Coulomb, N·m
#: Relative tolerance of the identified sigma and Fc against FV and FS on joints 1-4 with rows="moving", the rows of
#: the reference's own kind of fit (measured: 3.9 % at most).
TOL = 0.06


@pytest.fixture(scope="module")
def arm():
    return load_urdf(URDF)


@pytest.fixture(scope="module")
def motor_log(arm):
    return read_arm_log(LOG, arm.n, joint_names=arm.names)


@pytest.fixture(scope="module")
def result(arm, motor_log):
    gear = read_transmission(TOML, arm.n)
    return gear.with_coupling_warnings(identify_arm(gear.to_joint(motor_log), arm, cutoff=80.0, n_bootstrap=200,
                                                    seed=0, lag=False))  # the lags: benchmarks/arm_tx40.py


@pytest.fixture(scope="module")
def result_sliding(arm, motor_log):
    gear = read_transmission(TOML, arm.n)
    return identify_arm(gear.to_joint(motor_log), arm, cutoff=80.0, n_bootstrap=200, seed=0, lag=False,
                        rows="sliding")


def test_the_data_are_the_whole_log(motor_log):
    assert motor_log.q.shape == (45000, 6) and motor_log.dq is None
    np.testing.assert_allclose(np.diff(motor_log.t), 2e-4, rtol=1e-9)  # 5 kHz


def test_motor_to_joint_as_the_source_repository_writes_it(arm, motor_log):
    log = read_transmission(TOML, arm.n).to_joint(motor_log)
    red_q = np.diag(RATIO)
    red_q[5, 4] = RATIO[5]
    q = np.linalg.solve(red_q, motor_log.q.T).T
    q[:, 1] -= np.pi / 2
    q[:, 2] += np.pi / 2
    red_tau = np.diag(RATIO)
    red_tau[4, 5] = RATIO[5]
    np.testing.assert_allclose(log.q, q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(log.tau, motor_log.tau @ red_tau.T, rtol=1e-13, atol=1e-12)
    arm.check_positions(log.q, "tx40")  # within the URDF's limits


def test_power_is_the_same_on_both_sides(arm, motor_log):
    import dataclasses

    gear = read_transmission(TOML, arm.n)
    rng = np.random.default_rng(3)
    dq_m = rng.standard_normal(motor_log.q.shape)
    log = gear.to_joint(dataclasses.replace(motor_log, dq=dq_m))
    np.testing.assert_allclose(np.sum(log.tau * log.dq, axis=1), np.sum(motor_log.tau * dq_m, axis=1),
                               rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("j", range(4))
def test_joints_1_to_4_agree_with_the_reference(result, j):
    """The default rows ("moving"): every row faster than a speed threshold, Coulomb and viscous columns of the
    filtered velocity, the rows of the reference's own fit (FIGAROH's ordinary least squares on this log, replayed
    by benchmarks/arm_tx40.py within 3 % of the reference)."""
    p, iv = result.joints[j].params, result.joints[j].interval95
    assert p["sigma"] == pytest.approx(FV[j], rel=TOL) and p["Fc"] == pytest.approx(FS[j], rel=TOL)
    assert iv["sigma"][0] <= FV[j] <= iv["sigma"][1] and iv["Fc"][0] <= FS[j] <= iv["Fc"][1]
    assert not np.isfinite(p["Vs"])  # no Stribeck term at 80 Hz
    assert not any("shares motor" in w for w in result.joints[j].warnings)


@pytest.mark.parametrize("j", range(4))
def test_sliding_rows_read_a_higher_coulomb_level(result_sliding, result, j):
    """rows="sliding" (``--rows sliding``) leaves out the rows within 1.5 cutoff periods of where the joint is slower
    than 2 % of its 99th-percentile speed or reverses (7 % of each joint's rows here); the friction in those rows
    lies below the line through the others, so the Coulomb level comes out higher and the viscous slope lower than
    with the default rows ("moving"). Measured: Fc 1.044-1.073 times and sigma 0.964-0.981 times the moving rows'
    on joints 1-4 (Fc 7.9-11.5 % above the reference, sigma 2.7-7.1 % below); no Stribeck term kept."""
    p, q = result_sliding.joints[j].params, result.joints[j].params
    assert 1.03 < p["Fc"] / q["Fc"] < 1.09 and 0.95 < p["sigma"] / q["sigma"] < 0.99
    assert result_sliding.info["row_selection"] == "sliding" and result.info["row_selection"] == "moving"
    assert result_sliding.info["rows"][j] < result.info["rows"][j]
    assert not np.isfinite(p["Vs"])


@pytest.mark.parametrize("j", (4, 5))
def test_the_coupled_wrist_joints_carry_a_warning_naming_them(result, j):
    """Joints 5 and 6 share motor 6, whose friction (the reference's fvm6, fsm6 on sgn(dq5 + dq6)) no per-joint
    column holds: their Fc lies far from the reference's and a model_form warning names each of them."""
    joint = result.joints[j]
    warns = [w for w in joint.warnings if "shares motor 6" in w]
    assert len(warns) == 1 and warns[0].code == "model_form" and f"joint {joint.name!r}" in warns[0]
    assert abs(joint.params["Fc"] / FS[j] - 1) > TOL  # what the warning is about


def test_rigid_body_is_well_conditioned(result):
    assert 1.0 < result.cond < 100.0 and result.warnings == ()  # 37 on this log


def test_cli_on_a_window_of_the_log(tmp_path, capsys):
    z = np.load(LOG)
    cut = {k: z[k][:15000] for k in z.files}  # the first 3 s
    path = tmp_path / "tx40_3s.npz"
    np.savez(path, **cut)
    assert main(["identify-arm", str(path), "--urdf", str(URDF), "--transmission", str(TOML), "--cutoff", "80",
                 "--bootstrap", "20", "--json", "--quiet", "--no-lag"]) == 0
    d = json.loads(capsys.readouterr().out)
    names = [j["name"] for j in d["joints"]]
    assert names == [f"joint_{i}" for i in range(1, 7)]
    for entry in d["joints"]:
        shared = [w for w in entry["warnings"] if "shares motor 6" in w["message"]]
        assert len(shared) == (1 if entry["name"] in ("joint_5", "joint_6") else 0)


# ------------------------------------------------------------------------------------------------ bad input

GOOD = "ratio = [32.0, 32.0, 45.0, -48.0, 45.0, 32.0]\n"


@pytest.mark.parametrize("text, words", [
    ("ratio = [32.0, 32.0, 45.0]\n", ["ratio must be 6 numbers", "shape 3"]),
    (GOOD + "coupling = [[1.0, 0.0], [0.0, 1.0]]\n", ["coupling must be 6 x 6 numbers", "shape 2 x 2"]),
    (GOOD + "coupling = [" + ", ".join(["[1, 1, 0, 0, 0, 0]"] * 6) + "]\n", ["singular"]),
    ("ratio = [32.0, 0.0, 45.0, -48.0, 45.0, 32.0]\n", ["ratio of joint 2 is zero"]),
    (GOOD + "offset = [0, 0, 0]\n", ["offset must be 6 numbers"]),
    (GOOD + "torque_constant = ['a', 1, 1, 1, 1, 1]\n", ["torque_constant", "not a numeric array"]),
    (GOOD + "ratios = 3\n", ["unknown key 'ratios'"]),
    ("coupling = []\n", ["has no 'ratio'"]),
    ("ratio = [32.0, \n", ["not a readable TOML transmission file"]),
])
def test_bad_transmission_exits_2_naming_the_file(tmp_path, capsys, text, words):
    bad = tmp_path / "gear.toml"
    bad.write_text(text)
    assert main(["identify-arm", str(LOG), "--urdf", str(URDF), "--transmission", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("adaptive-ff: error: ") and str(bad) in err and "Traceback" not in err
    for w in words:
        assert w in err, (w, err)


def test_missing_transmission_file_exits_2(tmp_path, capsys):
    missing = tmp_path / "none.toml"
    assert main(["identify-arm", str(LOG), "--urdf", str(URDF), "--transmission", str(missing)]) == 2
    err = capsys.readouterr().err
    assert str(missing) in err and "No such transmission file" in err


def test_a_transmission_for_another_joint_count(arm, motor_log, tmp_path):
    gear = read_transmission(TOML, 6)
    import dataclasses

    short = dataclasses.replace(motor_log, q=motor_log.q[:, :5], tau=motor_log.tau[:, :5])
    with pytest.raises(ParameterError, match="a transmission of 6 joints for a log of 5"):
        gear.to_joint(short)


def test_a_negative_level_is_named(arm, motor_log):
    # at the default 20 Hz cutoff and the default rows the profile gives joint 2 a Stribeck term whose Fs comes out
    # negative (eq. 3 needs Fs >= 0; rows="sliding" gives it Fs 10.2 N·m): its entry carries an `implausible`
    # warning naming Fs, which design/compare/export-c --from refuse
    gear = read_transmission(TOML, arm.n)
    r = identify_arm(gear.to_joint(motor_log), arm, n_bootstrap=20, seed=0, lag=False)
    for joint in r.joints:
        signs = {w.parameter for w in joint.warnings if w.code == "implausible"}
        assert signs == {k for k in ("J", "Fc", "Fs", "sigma") if joint.params[k] < (1e-300 if k == "J" else 0.0)}
    assert r.joints[1].params["Fs"] < 0.0 and "Fs" in {w.parameter for w in r.joints[1].warnings
                                                         if w.code == "implausible"}
