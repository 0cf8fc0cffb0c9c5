"""Plausibility everywhere: typed warnings naming the parameter, and design --from refusing them."""

import argparse
import json

import numpy as np
import pytest

from adaptive_ff.identification.identify import identify
from adaptive_ff.identification.physical_id import fit_physical
from adaptive_ff.identification.plausibility import (IdentificationWarning, REFUSING_CODES, check_physical,
                                                     warning_from_dict)
from adaptive_ff.io.data import MeasuredData
from controllers.cli import design as cli_design
from plant import JointParams
from plant.errors import ParameterError
from plant.excitation import bandlimited_noise
from plant.joint import simulate
from plant.sampling import sample

#: A joint without Coulomb/Stribeck friction: every estimate of Fc, Fs scatters around 0 (seeded).
P0 = JointParams(J=1.0, Fc=0.0, Fs=0.0, Vs=0.05, delta=1.0, sigma=2.0, tau=0.01)


@pytest.fixture(scope="module")
def frictionless_record():
    _, u = bandlimited_noise(6.0, dt=1e-3, cutoff=2.0, std=2.0, rng=np.random.default_rng(0))
    m = sample(simulate(P0, u, dt=1e-3), Ts=0.01, noise_std=0.002, rng=np.random.default_rng(10))
    return MeasuredData(m.t, m.u, m.w, source="frictionless joint")


def run_design(argv):
    ap = argparse.ArgumentParser(prog="adaptive-ff")
    cli_design.register(ap.add_subparsers(dest="command", required=True))
    args = ap.parse_args(["design", *argv])
    return args.func(args)


def test_check_physical_names_each_failing_parameter():
    w = check_physical({"J": 4.0, "Fc": 25.0, "Fs": -0.27, "sigma": 40.0, "tau": 0.02, "offset": -3.0},
                       source="output_error")
    assert [(x.code, x.parameter) for x in w] == [("implausible", "Fs")]
    assert "Fs = -0.27 < 0" in w[0] and "stiction" in w[0] and w[0].startswith("output_error")
    w = check_physical({"J": 0.0, "tau": -1e-3, "sigma": float("nan")}, source="LS")
    assert [x.parameter for x in w] == ["J", "tau", "sigma"]
    assert "J = 0 <= 0" in w[0] and "not finite" in w[2]
    assert check_physical({"J": 1.0, "tau": 0.0, "sigma": 0.0, "Fc": 0.0, "Fs": 0.0}, source="x") == []


def test_warning_json_round_trip_and_validation():
    w = IdentificationWarning("implausible", "Fs", "Fs = -0.27 < 0")
    assert isinstance(w, str) and w == "Fs = -0.27 < 0" and w.refusing and "implausible" in REFUSING_CODES
    d = json.loads(json.dumps(w.to_dict(), allow_nan=False))
    assert d == {"code": "implausible", "parameter": "Fs", "message": "Fs = -0.27 < 0"}
    assert warning_from_dict(d) == w and warning_from_dict(d).parameter == "Fs"
    assert warning_from_dict("old free text").code == "identifiability"  # older files: conservative reading
    assert not IdentificationWarning("method", "all", "note").refusing
    with pytest.raises(ParameterError, match="code"):
        IdentificationWarning("bogus", "J", "x")
    with pytest.raises(ParameterError, match="'code', 'parameter', 'message'"):
        warning_from_dict({"code": "implausible"})


def test_output_error_negative_fs_is_flagged(frictionless_record):
    """Regression: output-error returned Fs = -0.27 N·m with no warning (eq. 4 results did get one)."""
    d = frictionless_record
    fit = fit_physical(d.t, d.u, d.w, Vs=0.05, delta=1.0, method="output_error", burn=0.1,
                       start={"J": 1.0, "Fc": 0.1, "Fs": 0.1, "sigma": 2.0, "tau": 0.01})
    neg = [k for k in ("Fc", "Fs") if fit.params[k] < 0]
    assert neg, fit.params  # the seeded record gives a negative stiction estimate
    assert [w.parameter for w in fit.warnings if w.code == "implausible"] == neg
    js = json.loads(json.dumps(fit.to_dict(), allow_nan=False))
    assert {"code": "implausible", "parameter": neg[0]} == {k: js["warnings"][0][k] for k in ("code", "parameter")}


def test_identify_json_carries_typed_warnings(frictionless_record):
    rep = identify(frictionless_record, Vs=0.05, delta=1.0, lag=True, method="paper")
    ls = rep.estimate
    bad = {k for k in ("J", "sigma", "Fc", "Fs", "tau") if getattr(ls, k) < 0}
    assert bad  # LS of eq. 4 gives tau < 0 here (and Fs or Fc < 0)
    d = json.loads(json.dumps(rep.to_dict(), allow_nan=False))
    flagged = {w["parameter"] for w in d["warnings"] if w["code"] == "implausible" and w["message"].startswith("LS")}
    assert flagged == bad
    assert all(set(w) == {"code", "parameter", "message"} for w in d["warnings"])
    assert "WARNING [implausible: tau]" in rep.summary()


def test_design_from_refuses_warned_identification(tmp_path, capsys):
    """Regression: design --from ignored the identification's warning and printed Ki 6594 instead of 786."""
    src = tmp_path / "id.json"
    warn = {"code": "identifiability", "parameter": "tau", "message": "the data do not support the lag"}
    src.write_text(json.dumps({"J": 12.6, "sigma": 237.0, "warnings": [warn]}))
    assert run_design(["--from", str(src), "--no-figures"]) == cli_design.EXIT_REFUSED == 3
    cap = capsys.readouterr()
    assert "Kp" not in cap.out and "identifiability warning on tau: the data do not support the lag" in cap.err
    assert "--accept-warnings" in cap.err
    assert run_design(["--from", str(src), "--no-figures", "--accept-warnings", "--json"]) == 0
    cap = capsys.readouterr()
    assert json.loads(cap.out)["J"] == 12.6 and "on tau" in cap.err
    # a warning that is only a note on the method does not refuse; nor does a plant file without warnings
    src.write_text(json.dumps({"J": 4.0, "sigma": 40.0, "warnings": [{"code": "method", "parameter": "all",
                                                                      "message": "note"}]}))
    assert run_design(["--from", str(src), "--no-figures"]) == 0
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"J": 4.0, "warnings": [{"code": "implausible"}]}))
    with pytest.raises(ParameterError, match="bad.json"):
        run_design(["--from", str(bad), "--no-figures"])
