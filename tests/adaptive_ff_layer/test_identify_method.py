"""identify(method=...): the physical-parameter fit wired into the report, the CLI and the JSON."""

import json
import math

import numpy as np
import pytest

from adaptive_ff.io.data import MeasuredData
from adaptive_ff.identification.identify import IDENTIFY_METHODS, identify
from adaptive_ff.identification.physical_id import METHODS, fit_physical
from plant import bandlimited_noise, irregular_sample_times, preset, sample, simulate
from plant.errors import ParameterError

P = preset("paper")
DT = 1e-3


@pytest.fixture(scope="module")
def record():
    """Sec. IV-A experiment (band-limited torque), 30 s, Fig. 10-like irregular sampling around 10 ms."""
    rng = np.random.default_rng(3)
    duration = 30.0
    _, u = bandlimited_noise(duration, dt=DT, cutoff=1.0, std=1.2 * (P.Fs + P.sigma * math.radians(20.0)), rng=rng)
    resp = simulate(P, u, dt=DT)
    times = irregular_sample_times(duration - 0.1, base=0.01, outlier=0.02, jitter=DT, dt=DT, rng=rng)
    m = sample(resp, Ts=0.01, times=times, rng=rng)
    return MeasuredData(t=m.t, u=m.u, w=m.w, source="simulated, irregular")


@pytest.fixture(scope="module")
def report(record):
    return identify(record, Vs=P.Vs, delta=P.delta, lag=True, method="output_error",
                    method_options={"input_delay": 0.5 * DT, "n_bootstrap": 4})  # few refits: the time budget


def test_report_carries_the_physical_fit_equal_to_fit_physical(record, report):
    # the same call directly: identify must pass the record's own (irregular) time stamps, not the resampled grid
    ref = fit_physical(record.t, record.u, record.w, Vs=P.Vs, delta=P.delta, method="output_error",
                       input_delay=0.5 * DT, n_bootstrap=0)  # the bootstrap only adds the errors (test_physical_id)
    assert report.physical is not None and report.physical.method == "output_error"
    assert report.physical.n_samples == record.t.shape[0]
    for k, v in ref.params.items():
        assert report.physical.params[k] == pytest.approx(v, rel=1e-12), k
    # and it is right where eq. 4 is not (noise-free, irregular stamps): Fc, Fs, sigma within 2 %, J, tau 5 %
    for k, tol in (("Fc", 0.02), ("Fs", 0.02), ("sigma", 0.02), ("J", 0.05), ("tau", 0.05)):
        assert report.physical.params[k] == pytest.approx(getattr(P, k), rel=tol), k
    assert abs(report.estimate.Fs / P.Fs - 1.0) > 0.10  # the eq. 4 LS on the resampled record is far off


def test_json_and_summary_name_the_method(report):
    out = json.loads(json.dumps(report.to_json_dict()))
    assert out["method"] == "output_error"
    assert out["Fc"] == pytest.approx(report.physical.params["Fc"], rel=1e-12) and "physical" not in out
    assert set(out["std"]) == set(report.physical.params) and out["form"]["fitted"] == list(report.physical.params)
    assert out["baselines"]["eq4_ls"]["Fc"] == pytest.approx(report.estimate.Fc, rel=1e-12)
    text = report.summary()
    assert "method 'output_error': lagged Stribeck (eqs. 1-3; adaptive_ff.identification.physical_id" in text
    assert f"{report.physical.params['J']:.6g}" in text


def test_paper_method_has_no_physical_fit(record):
    rep = identify(record, Vs=P.Vs, delta=P.delta, lag=True, method="paper")
    assert rep.physical is None and rep.to_json_dict()["method"] == "paper"


@pytest.mark.parametrize("kwargs, match", [
    ({"method": "ols"}, "method must be one of"),
    ({"method": "sliding", "Vs": None, "delta": None}, "give Vs and delta"),  # output_error fits them where not given
    ({"method": "output_error", "method_options": [1]}, "method_options must be a dict"),
])
def test_bad_method_arguments_raise_naming_them(record, kwargs, match):
    args = {"Vs": P.Vs, "delta": P.delta, **kwargs}
    with pytest.raises(ParameterError, match=match):
        identify(record, **args)


def test_cli_method_choices_are_the_library_methods():
    from controllers.cli.main import build_parser

    sub = next(a for a in build_parser()._actions if a.dest == "command")
    opt = next(a for a in sub.choices["identify"]._actions if a.dest == "method")
    assert tuple(opt.choices) == IDENTIFY_METHODS and set(METHODS) <= set(IDENTIFY_METHODS)
    assert opt.default == "auto"


def test_cli_json_carries_the_notes_as_strict_json(record, tmp_path, capsys):
    # the notes (preprocessing, method choice, structure, excitation) travel in --json as a list
    # of strings, the same lines the text report prints after "note: "
    from controllers.cli.main import main

    csv = tmp_path / "log.csv"
    np.savetxt(csv, np.column_stack([record.t, record.u, record.w]), delimiter=",", header="t,u,w", comments="")
    assert main(["identify", str(csv), "--lag", "--json"]) == 0
    d = json.loads(capsys.readouterr().out, parse_constant=lambda c: pytest.fail(f"non-strict JSON constant {c}"))
    notes = d["notes"]
    assert isinstance(notes, list) and len(notes) >= 2 and all(isinstance(n, str) and n for n in notes)
    assert any(n.startswith("structure: ") for n in notes) and any(n.startswith("excitation: ") for n in notes)
    assert main(["identify", str(csv), "--lag"]) == 0
    text = capsys.readouterr().out
    assert all(f"note: {n}" in text for n in notes)


def test_report_to_dict_notes_equal_the_report_notes(report):
    d = json.loads(json.dumps(report.to_dict(), allow_nan=False))
    assert d["notes"] == list(report.notes)
    note = next(n for n in d["notes"] if "physical parameters by 'output_error'" in n)
    boot = report.physical.info["bootstrap"]
    assert report.physical.info["stderr_kind"] == "bootstrap" and f"({boot['n_valid']} refits" in note
    assert f"± is the bootstrap standard error ({boot['n_valid']} refits" in report.physical.summary()


def test_cli_bootstrap_refit_reaches_the_output_error_fit_and_is_refused_elsewhere(record, tmp_path, capsys):
    from controllers.cli.main import main

    csv = tmp_path / "log.csv"
    short = record.t < 8.0
    np.savetxt(csv, np.column_stack([record.t[short], record.u[short], record.w[short]]), delimiter=",",
               header="t,u,w", comments="")
    args = ["identify", str(csv), "--Vs", repr(P.Vs), "--delta", repr(P.delta), "--json", "--quiet"]
    assert main(args + ["--method", "output_error", "--bootstrap", "2"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["info"]["bootstrap"]["refit"] == "the fit's own search from the replicate's start"  # the default
    assert main(args + ["--method", "output_error", "--bootstrap", "2", "--bootstrap-refit", "partial"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["info"]["bootstrap"]["refit"] == "wide trust region, local stage, 1 coordinate-search round(s)"
    assert main(args + ["--method", "paper", "--bootstrap-refit", "full"]) == 2
    assert "--bootstrap-refit applies to --method output_error" in capsys.readouterr().err


def test_the_cli_offers_exactly_the_package_bootstrap_refits():
    # the CLI's parser names the choices itself (it is built without importing the compiled core)
    from adaptive_ff.identification.physical_id import BOOTSTRAP_REFITS
    from controllers.cli.main import build_parser

    sub = next(a for a in build_parser()._subparsers._group_actions[0].choices["identify"]._actions
               if a.dest == "bootstrap_refit")
    assert tuple(sub.choices) == BOOTSTRAP_REFITS
