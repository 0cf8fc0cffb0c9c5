"""An arm's identification into ``compare --joint`` and ``export-c``: one C library with a compensator per joint.

The arm file is in the layout ``adaptive-ff identify-arm --json`` writes (three joints with the values the
simulated planar arm of docs/your_arm.md gave, a lag added where the test needs a plant). The proof of the arm's
library: compiled with the system C compiler alone, it replays for each joint a closed-loop log of that joint
(the package's mode ``adaptive`` on the identified joint) and gives, bit for bit in double, what the one-joint
export of that joint's entry gives, which is also what the package's loop applied. No Pinocchio needed.
"""

from __future__ import annotations

import copy
import json
import re
import shutil
import subprocess

import numpy as np
import pytest

from controllers.cli.main import main
from export_c_helpers import compile_export

CC = shutil.which("cc") or shutil.which("gcc")
needs_cc = pytest.mark.skipif(CC is None, reason="no C compiler (cc or gcc) on PATH")
U_MAX = 50.0
N = 20_000


def _entry(name, J, Fc, Fs, Vs, delta, sigma, offset, tau=None):
    lag_warning = {"code": "method", "parameter": "tau", "message": "tau is not determined by the log: null"}
    return {"name": name, "method": "arm", "J": J, "Fc": Fc, "Fs": Fs, "Vs": Vs, "delta": delta, "sigma": sigma,
            "tau": tau, "offset": offset, "std": {}, "interval95": {},
            "warnings": [] if tau is not None else [lag_warning]}


ARM = {"joints": [_entry("shoulder", 1.0606, 2.0062, 2.5841, 0.092429, 1.0, 0.7942, 0.18885, tau=0.02),
                  _entry("elbow", 0.23119, 1.1993, 1.5693, 0.06926, 1.0, 0.50279, -0.070943, tau=0.01),
                  _entry("wrist-3", 0.057279, 0.50253, 0.66583, 0.13948, 2.0, 0.19679, 0.0065432)],
       "rigid_body": {"mode": "fit", "base_parameters": {}, "interval95": {}, "cond": 164.0}, "info": {},
       "warnings": []}


@pytest.fixture(scope="module")
def arm_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("arm") / "arm.json"
    path.write_text(json.dumps(ARM))
    return path


def _entry_file(folder, k):
    """Joint ``k``'s entry alone, as an ``identify --json`` file (the layout it has)."""
    path = folder / f"joint{k}.json"
    path.write_text(json.dumps(ARM["joints"][k]))
    return path


# ------------------------------------------------------------------------------------------------ export-c

REPLAY_ARM_C = r"""
#include <stdio.h>
#include <stdlib.h>
#include "aff_config.h"

/* replay_arm J LOG OUT: joint J's compensator (AFF_CONFIGS[J]) replays LOG (u, w, w_ref: float64 blocks) */
int main(int argc, char **argv)
{
    static aff c;
    int j = atoi(argv[1]);
    FILE *f = fopen(argv[2], "rb");
    long n, k;
    double *buf, *uff;
    if (argc != 4 || j < 0 || j >= AFF_N_JOINTS || !f || fseek(f, 0, SEEK_END) != 0) return 2;
    n = ftell(f) / (3 * (long)sizeof(double));
    rewind(f);
    buf = malloc(3 * (size_t)n * sizeof(double));
    uff = malloc((size_t)n * sizeof(double));
    if (!buf || !uff || fread(buf, sizeof(double), 3 * (size_t)n, f) != 3 * (size_t)n) return 3;
    fclose(f);
    if (aff_init(&c, &AFF_CONFIGS[j]) != AFF_OK) return 5;
    for (k = 0; k < n; k++) {
        uff[k] = (double)aff_step(&c, (aff_real)buf[n + k], (aff_real)buf[2 * n + k]);
        if (aff_observe(&c, (aff_real)buf[k], (aff_real)buf[n + k]) != 1) return 6;
    }
    f = fopen(argv[3], "wb");
    if (!f || fwrite(uff, sizeof(double), (size_t)n, f) != (size_t)n) return 4;
    fclose(f);
    printf("%s %d %lld\n", AFF_JOINT_NAMES[j], aff_active(&c), (long long)aff_n_updates(&c));
    return 0;
}
"""


def _joint_log(folder, k, path):
    """N periods of mode adaptive on joint ``k`` (its entry with a 10 ms lag as the plant), the compensator
    ``export-c`` configures from ``path`` (the arm file and the joint, or the joint's own file): the log file
    (u, w, w_ref) and the feedforward the loop applied."""

    from adaptive_ff.identification.result_file import identification_from_dict
    from controllers.experiments.compensator_file import compensator_from_file
    from controllers.simulation.closed_loop import run_mode
    from plant.excitation import multisine_reference
    from plant.models import plant_from_dict

    entry = dict(ARM["joints"][k], tau=ARM["joints"][k]["tau"] or 0.01)
    plant = plant_from_dict(identification_from_dict(entry).plant_dict())
    arm_joint = ARM["joints"][k]["name"] if path.name == "arm.json" else None
    _, s = compensator_from_file(path, u_max=U_MAX, arm_joint=arm_joint)
    opts = s["options"].replace(noise_std=1e-3, decimate=1, sensor_gate=False)
    ref = multisine_reference(N * opts.controller.Tc, dt=opts.controller.Tc, rng=np.random.default_rng(10 + k))
    r = run_mode(plant, ref, "adaptive", opts, rng=np.random.default_rng(20 + k))
    log = folder / f"log{k}.bin"
    np.concatenate([np.asarray(x, dtype=np.float64) for x in (r.u, r.w_meas, r.w_ref)]).tofile(log)
    return log, np.asarray(r.u_ff)


@pytest.mark.slow
@needs_cc
def test_the_arm_library_replays_each_joint_as_its_one_joint_export(arm_file, tmp_path):
    """Per joint: the arm library's AFF_CONFIGS[j] and the one-joint export of the joint's entry give the same
    feedforward for that joint's closed-loop log, bit for bit (double), and it is the loop's own; the
    feedforward switches on in every replay."""
    from export_c_helpers import REPLAY_C

    assert main(["export-c", "--from", str(arm_file), "--u-max", str(U_MAX), "--out", str(tmp_path / "arm"),
                 "--quiet"]) == 0
    arm_exe = compile_export(CC, tmp_path / "arm", REPLAY_ARM_C, tmp_path / "replay_arm")
    for k, entry in enumerate(ARM["joints"]):
        one = _entry_file(tmp_path, k)
        assert main(["export-c", "--from", str(one), "--u-max", str(U_MAX), "--out", str(tmp_path / f"one{k}"),
                     "--quiet"]) == 0
        one_exe = compile_export(CC, tmp_path / f"one{k}", REPLAY_C, tmp_path / f"replay{k}")
        log, u_ff = _joint_log(tmp_path, k, arm_file)
        res_arm = subprocess.run([str(arm_exe), str(k), str(log), str(tmp_path / "arm.bin")], capture_output=True,
                                 text=True, timeout=120)
        res_one = subprocess.run([str(one_exe), str(log), str(tmp_path / "one.bin")], capture_output=True,
                                 text=True, timeout=120)
        assert res_arm.returncode == 0 and res_one.returncode == 0, (res_arm.stderr, res_one.stderr)
        name, active, updates = res_arm.stdout.split()
        assert name == entry["name"] and active == "1" and int(updates) > 100, res_arm.stdout
        arm_ff = np.fromfile(tmp_path / "arm.bin", dtype=np.float64)
        np.testing.assert_array_equal(arm_ff, np.fromfile(tmp_path / "one.bin", dtype=np.float64))
        np.testing.assert_array_equal(arm_ff, u_ff)
        assert np.count_nonzero(arm_ff) > N // 2


def test_the_arm_header_names_the_joints(arm_file, tmp_path):
    assert main(["export-c", "--from", str(arm_file), "--u-max", str(U_MAX), "--out", str(tmp_path / "arm"),
                 "--json"]) == 0
    header = (tmp_path / "arm" / "aff_config.h").read_text()
    assert "#define AFF_N_JOINTS 3" in header
    assert re.search(r"AFF_JOINT_SHOULDER = 0,.*\n\s*AFF_JOINT_ELBOW = 1,.*\n\s*AFF_JOINT_WRIST_3 = 2,", header)
    assert '#define AFF_JOINT_NAMES_INIT {"shoulder", "elbow", "wrist-3"}' in header
    assert "extern const aff_config AFF_CONFIGS[AFF_N_JOINTS];" in header
    # a value every joint shares is one macro; the others one per joint, with the joint's value
    assert "#define AFF_TC 0.001" in header and "#define AFF_ELBOW_VS 0.06926" in header
    assert "#define AFF_WRIST_3_DELTA 2.0" in header and "#define AFF_SHOULDER_J_DESIGN 1.0606" in header
    source = (tmp_path / "arm" / "aff_config.c").read_text()
    assert source.count("[AFF_JOINT_") == 3 and ".J = (aff_real)AFF_ELBOW_J_DESIGN" in source


def test_one_joint_of_an_arm_file_is_its_entry_exported(arm_file, tmp_path, capsys):
    """``--joint NAME``: the one-joint layout, the same settings as the export of the entry's own file."""
    assert main(["export-c", "--from", str(arm_file), "--joint", "elbow", "--u-max", str(U_MAX), "--out",
                 str(tmp_path / "a"), "--json"]) == 0
    by_joint = json.loads(capsys.readouterr().out)
    assert main(["export-c", "--from", str(_entry_file(tmp_path, 1)), "--u-max", str(U_MAX), "--out",
                 str(tmp_path / "b"), "--json"]) == 0
    by_entry = json.loads(capsys.readouterr().out)
    assert by_joint["config"] == by_entry["config"] and "joints" not in by_joint
    strip = (lambda text: text.split("*/", 1)[1])  # the banner names where the settings come from
    assert strip((tmp_path / "a" / "aff_config.c").read_text()) == strip((tmp_path / "b" / "aff_config.c").read_text())
    assert "for arm.json joint 'elbow'" in (tmp_path / "a" / "aff_config.c").read_text()


@pytest.mark.parametrize("case", ["unknown_joint", "not_an_arm", "one_joint_option", "refused", "no_stribeck"])
def test_export_errors_name_the_file_and_the_joint(case, arm_file, tmp_path, capsys):
    args = ["export-c", "--from", str(arm_file), "--u-max", str(U_MAX), "--out", str(tmp_path / "x")]
    status = 2
    if case == "unknown_joint":
        args += ["--joint", "knee"]
        want = ["arm.json", "'knee'", "'elbow'"]
    elif case == "not_an_arm":
        args[2] = str(_entry_file(tmp_path, 0))
        args += ["--joint", "shoulder"]
        want = ["joint0.json", "not an identify-arm --json output"]
    elif case == "one_joint_option":
        args += ["--Kp", "3"]
        want = ["--Kp", "arm.json", "--joint NAME"]
    elif case == "refused":
        bad = copy.deepcopy(ARM)
        bad["joints"][1]["warnings"] = [{"code": "identifiability", "parameter": "Fc", "message": "Fc is poorly "
                                         "determined"}]
        args[2] = str(tmp_path / "arm.json")
        (tmp_path / "arm.json").write_text(json.dumps(bad))
        status, want = 3, ["arm.json joint 'elbow'", "identifiability warning on Fc", "--accept-warnings"]
    else:  # no Stribeck term and no lowest speed for its placeholder Vs (a file written without one)
        bad = copy.deepcopy(ARM)
        bad["joints"][2].update(Vs=None, delta=None, Fs=bad["joints"][2]["Fc"])
        args[2] = str(tmp_path / "arm.json")
        (tmp_path / "arm.json").write_text(json.dumps(bad))
        want = ["arm.json joint 'wrist-3'", "no Stribeck term", "'excitation.min_speed'", "--Vs"]
    assert main(args) == status
    err = capsys.readouterr().err
    assert "Traceback" not in err and not (tmp_path / "x").exists()
    for w in want:
        assert w in err, (w, err)


# ------------------------------------------------------------------------------------- no Stribeck term

#: The slowest speed of the wrist's rows (rad/s) in the arm file without its Stribeck term.
MIN_SPEED = 0.0123


def _no_stribeck_arm(folder, **wrist):
    """ARM with the wrist's Stribeck term dropped as identify-arm drops it (``Vs``, ``delta`` null, ``Fs = Fc``),
    its entry's lowest speed ``excitation.min_speed``; ``wrist`` overrides entry keys (None: removed)."""
    d = copy.deepcopy(ARM)
    e = d["joints"][2]
    e.update(Vs=None, delta=None, Fs=e["Fc"], excitation={"noise_std": 2e-3, "min_speed": MIN_SPEED})
    for k, v in wrist.items():
        if v is None:
            e.pop(k, None)
        else:
            e[k] = v
    path = folder / "arm.json"
    path.write_text(json.dumps(d))
    return path


def test_placeholder_shape_is_the_lowest_speed_and_delta_1():
    from adaptive_ff.identification.stribeck_fit import placeholder_shape
    from plant.errors import ParameterError

    assert placeholder_shape([-0.3, 0.05, 0.0, float("nan"), 0.2]) == (0.05, 1.0)
    with pytest.raises(ParameterError, match="no non-zero finite speed"):
        placeholder_shape([0.0, float("nan")])


@pytest.mark.parametrize("Fs", ["equal", "null", "absent"])
def test_a_joint_without_stribeck_gets_a_compensator_with_the_placeholders(Fs, tmp_path):
    """Fs = Fc, delta = 1 and Vs the entry's lowest measured speed: the rule of compare's pre-fit without a
    Stribeck effect; the compensator's estimator starts from that map, and the notes say so."""
    from controllers.experiments.compensator_file import compensator_from_file

    Fc = ARM["joints"][2]["Fc"]
    path = _no_stribeck_arm(tmp_path, **({"Fs": Fc} if Fs == "equal" else {"Fs": None}))
    if Fs == "null":
        d = json.loads(path.read_text())
        d["joints"][2]["Fs"] = None
        path.write_text(json.dumps(d))
    comp, s = compensator_from_file(path, arm_joint="wrist-3", u_max=U_MAX)
    est = s["options"].estimator
    assert (est.Vs, est.delta) == (MIN_SPEED, 1.0)
    assert s["joint"] == {"Fc": Fc, "Fs": Fc, "sigma": ARM["joints"][2]["sigma"]}
    init = s["options"].estimator.initial
    assert (init.Fc, init.Fs, init.Vs, init.delta) == (Fc, Fc, MIN_SPEED, 1.0)
    assert comp.feedforward.estimator.Vs == MIN_SPEED and comp.feedforward.estimator.delta == 1.0
    (note,) = s["notes"]
    assert "joint 'wrist-3'" in note and "no Stribeck term" in note and "placeholder Vs = 0.0123 rad/s" in note
    # a Vs given replaces the placeholder; delta stays the placeholder's 1
    _, s = compensator_from_file(path, arm_joint="wrist-3", u_max=U_MAX, Vs=0.05)
    assert (s["options"].estimator.Vs, s["options"].estimator.delta) == (0.05, 1.0) and "(given)" in s["notes"][0]
    # the joints with a Stribeck term: theirs, no note
    _, s = compensator_from_file(path, arm_joint="elbow", u_max=U_MAX)
    assert (s["options"].estimator.Vs, s["options"].estimator.delta, s["notes"]) == (0.06926, 1.0, ())


def test_export_c_of_an_arm_with_a_joint_without_stribeck(tmp_path, capsys):
    """The whole arm's library and the joint's own export: the placeholders in the settings, the note in the
    joint's comment of aff_config.c and in the export's notes."""
    path = _no_stribeck_arm(tmp_path)
    assert main(["export-c", "--from", str(path), "--u-max", str(U_MAX), "--out", str(tmp_path / "arm"),
                 "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    # delta 1 on every joint now (the wrist's placeholder): one macro
    assert out["config"]["AFF_WRIST_3_VS"] == MIN_SPEED and out["config"]["AFF_DELTA"] == 1.0
    (note,) = out["notes"]
    assert "joint 'wrist-3'" in note and "placeholder Vs = 0.0123 rad/s" in note
    source = (tmp_path / "arm" / "aff_config.c").read_text()
    wrist = source.split('/* joint "wrist-3" */', 1)[1].split("[AFF_JOINT_WRIST_3]", 1)[0]
    words = " ".join(wrist.split())  # the comment is wrapped at 116 characters
    assert words.startswith("/* Note: ") and "no Stribeck term identified: Fs = Fc = 0.5025 N*m" in words
    assert "placeholder Vs = 0.0123 rad/s (the lowest measured speed), delta = 1" in words
    assert "Note:" not in source.split('/* joint "wrist-3" */', 1)[0]  # only the wrist's block
    assert main(["export-c", "--from", str(path), "--joint", "wrist-3", "--u-max", str(U_MAX), "--out",
                 str(tmp_path / "one"), "--json"]) == 0
    one = json.loads(capsys.readouterr().out)
    assert one["config"]["AFF_VS"] == MIN_SPEED and one["notes"] == [note]
    assert "no Stribeck term identified" in " ".join((tmp_path / "one" / "aff_config.c").read_text().split())


# ------------------------------------------------------------------------------------------------ compare


def test_compare_a_joint_of_an_arm_file_is_compare_of_its_entry(arm_file, tmp_path, capsys):
    """``compare --from arm.json --joint elbow`` runs what ``compare --from`` the entry's own file runs: the same
    plant (the identified joint), the same PI and design inertia, the same metrics."""
    common = ["--duration", "6", "--no-figures", "--quiet", "--json", "--modes", "none,adaptive"]
    assert main(["compare", "--from", str(arm_file), "--joint", "elbow", *common]) == 0
    by_joint = json.loads(capsys.readouterr().out)
    assert main(["compare", "--from", str(_entry_file(tmp_path, 1)), *common]) == 0
    by_entry = json.loads(capsys.readouterr().out)
    assert by_joint == by_entry
    assert by_joint["plant"]["J"] == ARM["joints"][1]["J"] and by_joint["plant"]["tau"] == 0.01


@pytest.mark.parametrize("case", ["unknown_joint", "no_from", "no_lag"])
def test_compare_joint_errors(case, arm_file, capsys):
    args = ["compare", "--from", str(arm_file), "--joint", "knee", "--duration", "2", "--no-figures", "--quiet"]
    if case == "unknown_joint":
        want = ["arm.json", "'knee'", "'elbow'"]
    elif case == "no_from":
        args = args[:1] + args[3:]
        want = ["--joint knee", "--from ARM.json"]
    else:
        args[4] = "wrist-3"
        want = ["arm.json joint 'wrist-3'", "tau", "--plant"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    for w in want:
        assert w in err, (w, err)
