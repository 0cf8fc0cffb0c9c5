"""Tests of adaptive_ff.identification.model_forms: model-form selection by blocked cross-validation.

Simulated logs of a known form (seeded): a Coulomb + viscous joint without lag must come out as Coulomb +
viscous, the paper's lagged Stribeck joint as a Stribeck form with lag, with the true parameters inside the
chosen form's reported 95 % intervals. The blocks, the one-standard-error rule and the information criteria
are checked against independent computations; the JSON is strict.
"""

import json
import math

import numpy as np
import pytest

from adaptive_ff.identification import model_forms as mf
from adaptive_ff.identification.identify import identify
from adaptive_ff.identification.model_forms import (FORMS, FormSelection, cv_blocks, one_standard_error_choice,
                                                    select_form)
from adaptive_ff.identification.result_file import identification_from_dict
from adaptive_ff.io.data import MeasuredData, to_uniform
from controllers.cli.main import main
from plant import JointParams, bandlimited_noise, preset, sample, simulate
from plant.errors import ExcitationError, ParameterError

P = preset("paper")  # J 4, Fc 25, Fs 35, Vs 0.02, delta 1, sigma 40, tau 0.02
DT = 1e-3
#: Coulomb + viscous joint without lag: Fs = Fc, tau = 0.
CV = JointParams(J=P.J, Fc=P.Fc, Fs=P.Fc, Vs=P.Vs, delta=P.delta, sigma=P.sigma, tau=0.0)


def _log(p, seed, duration=20.0):
    """Band-limited torque (1 Hz) on the simulated joint, sampled at 10 ms with 1 % velocity noise."""
    rng = np.random.default_rng(seed)
    _, u = bandlimited_noise(duration, dt=DT, cutoff=1.0, std=1.2 * (P.Fs + P.sigma * math.radians(20.0)), rng=rng)
    resp = simulate(p, u, dt=DT)
    m = sample(resp, Ts=0.01, noise_std=0.01 * float(np.max(np.abs(resp.w))), rng=rng)
    return MeasuredData(m.t, m.u, m.w, source=f"simulated seed {seed}")


@pytest.fixture(scope="module")
def cv_report():
    # input_delay: plant.sampling.sample stamps the input held over each 1 ms step at its start
    return identify(_log(CV, 0), Vs=P.Vs, delta=P.delta, form="auto", form_options={"input_delay": 0.5 * DT})


@pytest.fixture(scope="module")
def stribeck_selection():
    return select_form(_log(P, 0), Vs=P.Vs, delta=P.delta, input_delay=0.5 * DT)


def _inside(cand, truth: dict):
    iv = cand.intervals(0.95)
    for k, v in truth.items():
        lo, hi = iv[k]
        assert lo <= v <= hi, (k, v, lo, hi, cand.params[k], cand.stderr[k])


def test_coulomb_viscous_log_chooses_coulomb_viscous(cv_report):
    sel = cv_report.forms
    assert isinstance(sel, FormSelection)
    assert sel.chosen == "coulomb_viscous", sel.summary()
    b = sel.best
    assert b.n_params == 4 and b.fitted == ("J", "Fc", "sigma", "offset")
    assert b.params["Fs"] == b.params["Fc"] and b.params["tau"] == 0.0
    _inside(b, {"J": CV.J, "Fc": CV.Fc, "sigma": CV.sigma, "offset": 0.0})
    # noise 1 % of the peak: the free-run error of the right form is that noise (white, std 0.01*peak)
    assert sel.predictor == "free-run"
    assert b.rms == pytest.approx(sel.noise_std, rel=0.1)
    # the free Stribeck forms: this log has no resolved low-speed data (noise 0.018 rad/s > Vs)
    for name in ("stribeck_free", "stribeck_free_lag"):
        assert sel.candidate(name).status.startswith("not identifiable from this log:")
        assert not sel.candidate(name).ok


def test_stribeck_lag_log_chooses_stribeck_with_lag(stribeck_selection):
    sel = stribeck_selection
    b = sel.best
    assert b.stribeck != "none" and b.lag, sel.summary()
    _inside(b, {"J": P.J, "Fc": P.Fc, "Fs": P.Fs, "sigma": P.sigma, "tau": P.tau, "offset": 0.0})
    # the forms without lag predict clearly worse out of sample (more than 10 standard errors)
    for c in sel.candidates:
        if c.ok and not c.lag:
            assert c.cv_mse > b.cv_mse + 10 * b.cv_se, c.name


def test_identify_answers_with_the_chosen_form(cv_report):
    d = cv_report.to_dict()
    json.dumps(d, allow_nan=False)
    b = cv_report.forms.best
    assert d["method"] == "output_error" and d["form"]["selected"] == "coulomb_viscous"
    assert d["form"]["constrained"] == {"Fs": "Fc", "tau": 0.0} and d["form"]["fitted"] == list(b.fitted)
    for k in ("J", "Fc", "sigma", "offset"):
        assert d[k] == b.params[k]
    assert d["Fs"] == d["Fc"] and d["tau"] == 0.0
    assert [c["name"] for c in d["forms"]["candidates"]] == list(FORMS)
    joint = identification_from_dict(json.loads(json.dumps(d)))  # what design --from and export-c --from read
    assert joint.J == b.params["J"] and joint.Fs == joint.Fc and joint.tau == 0.0 and joint.method == "output_error"
    # the plant file of README step 4 from this JSON: a Coulomb + viscous joint (Fs = Fc)
    plant = JointParams(**{k: d[k] for k in ("J", "Fc", "Fs", "sigma", "tau", "Vs", "delta")})
    w = np.array([-1.0, -0.01, 0.01, 1.0])
    np.testing.assert_allclose(plant.friction(w), np.sign(w) * d["Fc"] + d["sigma"] * w, rtol=1e-12)
    assert "model forms of" in cv_report.summary() and "chosen: Coulomb + viscous" in cv_report.summary()


def test_json_strict_with_null_for_forms_not_fitted(cv_report):
    d = cv_report.forms.to_dict()
    text = json.dumps(d, allow_nan=False)
    assert "NaN" not in text and "Infinity" not in text
    free = next(c for c in d["candidates"] if c["name"] == "stribeck_free")
    assert free["cv_mse"] is None and free["aic"] is None and free["params"] == {} and free["ok"] is False
    assert d["chosen"] == "coulomb_viscous" and d["folds"] == 5


def test_information_criteria_formulas(cv_report):
    for c in cv_report.forms.candidates:
        if not c.ok:
            continue
        rss = c.rms**2 * c.n_scored
        assert c.aic == pytest.approx(c.n_scored * math.log(rss / c.n_scored) + 2 * c.n_params, rel=1e-12)
        assert c.bic == pytest.approx(c.n_scored * math.log(rss / c.n_scored) + c.n_params * math.log(c.n_scored),
                                      rel=1e-12)
        # pooled CV error = the block errors weighted by their scored samples; its SE = std/sqrt(K)
        fm = np.array(c.cv_fold_mse)
        assert c.cv_se == pytest.approx(np.std(fm, ddof=1) / math.sqrt(fm.size), rel=1e-12)
        assert min(fm) <= c.cv_mse <= max(fm)


@pytest.mark.parametrize("n, folds", [(10, 2), (2001, 5), (24792, 7), (13, 13)])
def test_cv_blocks_partition_the_log(n, folds):
    blocks = cv_blocks(n, folds)
    assert len(blocks) == folds and blocks[0][0] == 0 and blocks[-1][1] == n
    held = np.concatenate([np.arange(a, b) for a, b in blocks])
    np.testing.assert_array_equal(held, np.arange(n))  # each sample held out exactly once, in order
    sizes = [b - a for a, b in blocks]
    assert max(sizes) - min(sizes) <= 1 and min(sizes) >= 1


def test_held_out_velocity_never_enters_the_fold_fit():
    data = _log(CV, 1, duration=6.0)
    pb = mf._Problem(data, None, None, True, 1e-3, 0.0)
    n = data.t.shape[0]
    a, b = cv_blocks(n, 5)[2]
    train = np.zeros(n, dtype=bool)
    train[pb.i0:] = True
    train[a:b] = False
    x = pb.pack("coulomb_viscous_lag", {"J": 4.0, "Fc": 25.0, "sigma": 40.0, "tau": 0.01, "offset": 0.1})
    r0 = pb.residuals("coulomb_viscous_lag", x, train)
    s0 = mf._ls_start(to_uniform(data), True, (data.t[a], data.t[b - 1]))
    w2 = data.w.copy()
    w2[a:b] += np.random.default_rng(3).normal(0.0, 5.0, b - a)  # garbage in the held-out block
    data2 = MeasuredData(data.t, data.u, w2)
    pb2 = mf._Problem(data2, None, None, True, 1e-3, 0.0)
    pb2.noise, pb2.predictor, pb2.gain = pb.noise, pb.predictor, pb.gain
    np.testing.assert_array_equal(pb2.residuals("coulomb_viscous_lag", x, train), r0)
    assert mf._ls_start(to_uniform(data2), True, (data.t[a], data.t[b - 1])) == s0


def test_one_standard_error_rule_on_a_hand_made_table():
    rows = [("A", 4, 1.05, 0.02), ("B", 5, 1.00, 0.06), ("C", 6, 0.98, 0.05), ("D", 7, 0.97, 0.01)]
    # smallest 0.97 (D) + its SE 0.01 = 0.98: C and D qualify; C has fewer parameters
    assert one_standard_error_choice(rows)[0] == "C"
    rows[3] = ("D", 7, 0.97, 0.04)  # limit 1.01: B, C, D qualify -> B
    name, rule = one_standard_error_choice(rows)
    assert name == "B" and "1.01" in rule
    # equal parameter counts: the smaller CV error; a form that failed (NaN) is ignored
    assert one_standard_error_choice([("X", 5, 2.0, 1.0), ("Y", 5, 1.5, 0.1), ("Z", 3, math.nan, 0.1)])[0] == "Y"
    with pytest.raises(ExcitationError):
        one_standard_error_choice([("Z", 3, math.nan, 0.1)])


@pytest.mark.parametrize("kw, word", [({"folds": 1}, "folds"), ({"folds": 2.5}, "folds"), ({"folds": True}, "folds"),
                                      ({"criterion": "r2"}, "criterion"), ({"forms": ["lugre"]}, "forms"),
                                      ({"method": "closed_loop"}, "method"), ({"Vs": 0.02}, "delta"),
                                      ({"predictor": "two-step"}, "predictor")])
def test_bad_values_name_the_argument(kw, word):
    data = _log(CV, 2, duration=2.0)
    with pytest.raises(ParameterError, match=word):
        select_form(data, **kw)


def test_identify_form_bad_values():
    data = _log(CV, 2, duration=2.0)
    with pytest.raises(ParameterError, match="form must be 'auto' or one of"):
        identify(data, form="coulomb")
    with pytest.raises(ParameterError, match="folds"):
        identify(data, form="auto", form_options={"folds": 1})
    with pytest.raises(ParameterError, match="form_options"):
        identify(data, form="auto", form_options={"fold": 3})
    with pytest.raises(ParameterError, match="got 'closed_loop'"):
        identify(data, Vs=0.02, delta=1.0, form="auto", method="closed_loop")


@pytest.mark.parametrize("argv, word", [(["--form", "bogus"], "form must be"), (["--form", "auto", "--folds", "1"],
                                                                                 "--folds")])
def test_cli_bad_form_values_no_traceback(tmp_path, capsys, argv, word):
    data = _log(CV, 2, duration=2.0)
    f = tmp_path / "log.csv"
    np.savetxt(f, np.column_stack([data.t, data.u, data.w]), delimiter=",", header="t,u,w", comments="")
    assert main(["identify", str(f), *argv]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and word in err


def test_plot_draws_every_fitted_form(cv_report):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ax = cv_report.forms.plot()
    assert len(ax.lines) == sum(c.ok for c in cv_report.forms.candidates)
    lo, hi = cv_report.forms.w_range
    x = ax.lines[0].get_xdata()
    assert x.min() == pytest.approx(lo) and x.max() == pytest.approx(hi)
    plt.close(ax.figure)


def test_design_from_uses_the_chosen_form(cv_report, tmp_path, capsys):
    # the excitation warning on Fs (too few low-speed samples) does not concern a form without Fs: a note
    codes = {(w.code, w.parameter) for w in cv_report.warnings}
    assert ("identifiability", "Fs") not in codes and ("method", "Fs") in codes
    f = tmp_path / "id.json"
    f.write_text(json.dumps(cv_report.to_json_dict()))
    assert main(["design", "--from", str(f), "--crossover", "10", "--no-figures", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["J"] == cv_report.forms.best.params["J"]
    assert out["sigma"] == cv_report.forms.best.params["sigma"] and "output_error" in out["source"]


def test_cli_form_auto_prints_the_table(tmp_path, capsys):
    data = _log(CV, 5, duration=8.0)
    f = tmp_path / "log.csv"
    np.savetxt(f, np.column_stack([data.t, data.u, data.w]), delimiter=",", header="t,u,w", comments="")
    assert main(["identify", str(f), "--form", "auto", "--folds", "3", "--units", "rad"]) == 0
    out = capsys.readouterr().out
    assert "blocked CV, 3 contiguous blocks" in out
    for c in FORMS.values():
        assert c[0] in out  # every candidate has a row (fitted, or why not)
    assert "not run: needs Vs and delta" in out and "chosen: " in out
    assert out.index("model forms of") < out.index("baselines:")  # the table before the eq. 4 baselines


def _log_1khz(p, seed, duration=20.0):
    """The same torque on the joint, logged at 1 kHz (a controller-rate log) with 1e-3 rad/s velocity noise."""
    rng = np.random.default_rng(seed)
    _, u = bandlimited_noise(duration, dt=DT, cutoff=1.0, std=1.2 * (P.Fs + P.sigma * math.radians(20.0)), rng=rng)
    m = sample(simulate(p, u, dt=DT), Ts=DT, noise_std=1e-3, rng=rng)
    return MeasuredData(m.t, m.u, m.w, source=f"1 kHz seed {seed}")


@pytest.mark.parametrize("p, true_form", [
    pytest.param(CV, "coulomb_viscous", marks=pytest.mark.xfail(strict=True, reason=(
        "known: the sliding regression's half-period regressand gives this lag-free joint a lag of 0.87 +- 0.15 ms "
        "(the derivative columns' exact backward differences removed the filters' +2.5 % from J; the timing of the "
        "friction columns, half a period after the torque's, is not modelled), and the one-standard-error rule "
        "then keeps coulomb_viscous_lag"))),
    (P, "stribeck_lag")])
def test_sliding_regression_selection_chooses_the_true_form(p, true_form):
    four = ["coulomb_viscous", "coulomb_viscous_lag", "stribeck", "stribeck_lag"]
    r = identify(_log_1khz(p, 0), Vs=P.Vs, delta=P.delta, method="sliding", form="auto", form_options={"forms": four})
    sel = r.forms
    assert sel.method == "sliding" and r.method == "sliding" and sel.chosen == true_form, sel.summary()
    assert "N·m (N) (equation error of the filtered torque L[u])" in sel.summary()
    # Fc and sigma within 0.5 % (the sliding regression's J is biased by about +2.5 % at 1 kHz: its module
    # docstring; its intervals are not checked here for that reason)
    assert r.Fc == pytest.approx(p.Fc, rel=5e-3) and r.sigma == pytest.approx(p.sigma, rel=5e-3)
    assert [c.n_params for c in sel.candidates] == [4, 6, 5, 7]  # the lag adds J*tau and tau
    json.dumps(r.to_dict(), allow_nan=False)


def test_compare_plant_reads_the_chosen_form(cv_report, tmp_path, capsys):
    d = cv_report.to_json_dict()
    for k in ("Vs", "delta"):  # as written without a Stribeck pre-fit: nothing to give
        d.pop(k)
    f = tmp_path / "id.json"
    f.write_text(json.dumps(d))
    joint = identification_from_dict(d)
    plant = joint.plant_dict()
    assert plant["Fs"] == plant["Fc"] == d["Fc"] and plant["tau"] == 0.0 and plant["J"] == d["J"]
    assert main(["compare", "--plant", str(f), "--duration", "1", "--modes", "none", "--no-figures", "--quiet"]) == 0
    out = capsys.readouterr().out
    assert f"Fc={d['Fc']:.6g} N·m, Fs={d['Fc']:.6g} N·m" in out and "tau=0 s" in out
    # a Stribeck answer without Vs, delta cannot make a plant file
    with pytest.raises(ParameterError, match="Vs"):
        identification_from_dict(dict(d, Fs=1.2 * d["Fc"])).plant_dict()
