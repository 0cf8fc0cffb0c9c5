"""The result protocol of adaptive_ff.identification: strict-JSON to_dict(), summary(), plot(ax=None).

Every result object must survive ``json.dumps(obj.to_dict(), allow_nan=False)`` (NaN/inf -> None), carry
the same numbers as its attributes, give a short text, and (where a figure helps) draw on given or new axes.
Also the option dataclasses (OutputErrorOptions, UKFOptions) that replaced long keyword lists.
"""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from adaptive_ff.identification.diagnostics import excitation_report, velocity_noise_std_irregular
from adaptive_ff.identification.emps_validation import EMPSRecord, simulate_emps_loop
from adaptive_ff.identification.identify import cross_validate, identify
from adaptive_ff.identification.idim import RigidAxisModel, fit_idim
from adaptive_ff.identification.ls import fit_ls
from adaptive_ff.identification.online_ukf import OnlineUKF, UKFOptions, run_online_ukf
from adaptive_ff.identification.physical_id import OutputErrorOptions, PhysicalFit, fit_physical
from adaptive_ff.identification.regression import FrictionEstimate, RegressionModel
from adaptive_ff.identification.steady_state import binned_steady_state
from adaptive_ff.identification.stribeck_fit import fit_stribeck
from adaptive_ff.io.data import MeasuredData
from plant.errors import ParameterError
from plant.friction import JointParams, stribeck

TS = 1e-3
P = JointParams(J=0.5, Fc=1.0, Fs=1.4, Vs=0.05, delta=1.5, sigma=0.8, tau=0.0)


def strict(obj) -> dict:
    """``obj.to_dict()`` through strict JSON and back."""
    return json.loads(json.dumps(obj.to_dict(), allow_nan=False))


def _record(n=6000, offset=0.2):
    """Noise-free eq. 4 record under a square-wave torque with a ripple (reversals every second)."""
    t = np.arange(n) * TS
    u = 30.0 * np.sign(np.sin(2 * np.pi * 0.5 * t)) * 0.1 + 0.3 * np.sin(2 * np.pi * 7 * t)
    m = RegressionModel(P.Vs, P.delta, lag=False, stribeck=True, offset=True)
    w = m.simulate(m.theta_from_physical(P, TS, offset=offset), u, [0.0, 0.0])
    return MeasuredData(t, u, w, source="synthetic")


@pytest.fixture(scope="module")
def record():
    return _record()


def _lines(ax):
    return [ln for ln in ax.get_lines() if len(ln.get_xdata()) > 2]


# --------------------------------------------------------------------------- eq. 4 LS and identify


def test_ls_result_protocol_with_nan_standard_errors(record):
    model = RegressionModel(P.Vs, P.delta, lag=False, stribeck=True, offset=True)
    ls = fit_ls(model, record.u, record.w, Ts=TS)
    d = strict(ls)
    assert d["theta"] == ls.theta_dict() and d["model"]["names"] == list(model.names)
    assert d["estimate"]["Fs"] == pytest.approx(1.4, rel=1e-9)
    assert d["estimate"]["J_alt"] is None  # no lag: b1 = 0, the redundant inertia is NaN
    assert d["n_samples"] == record.n_samples and d["fit_one_step"] == ls.fit_one_step
    ridge = fit_ls(model, record.u, record.w, Ts=TS, ridge=1e-6)
    assert all(v is None for v in strict(ridge)["theta_std"].values())  # NaN standard errors of a ridge fit
    assert "c1" in ls.summary() and f"{ls.cond:.3g}" in ls.summary()
    ax = ls.plot()
    assert len(_lines(ax)) == 2 and "s" in ax.get_xlabel()
    np.testing.assert_array_equal(_lines(ax)[1].get_ydata(), ls.w_free_run)


def test_identification_report_and_cross_validation(record):
    rep = identify(record, Vs=P.Vs, delta=P.delta, method="paper")
    d = strict(rep)
    assert d == rep.to_json_dict() and d["method"] == "paper"
    assert d["Fs"] == pytest.approx(1.4, rel=1e-6) and d["offset"] == pytest.approx(0.2, rel=1e-6)
    assert d["tau"] == 0.0 and d["excitation"]["n_reversals"] == rep.excitation.n_reversals
    ax = rep.plot()
    names = [ln.get_label() for ln in _lines(ax)]
    assert names == list(rep.model.names)
    # the last history row is the final RLS estimate; relative to LS it is 1 up to the ridge 1/P0
    for ln, th_rls, th_ls in zip(_lines(ax), rep.rls_theta, rep.ls.theta):
        assert ln.get_ydata()[-1] == pytest.approx(th_rls / th_ls, rel=1e-12)
        assert ln.get_ydata()[-1] == pytest.approx(1.0, abs=1e-3)
    cv = cross_validate(rep, _record(n=4000, offset=0.2))
    c = strict(cv)
    assert c == cv.to_json_dict() and c["fit_percent"] == pytest.approx(100.0, abs=1e-6)
    assert f"{cv.fit_one_step:.3f} %" in cv.summary()


def test_excitation_report_without_vs_has_none_fraction(record):
    rep = excitation_report(record.u, record.w)
    d = strict(rep)
    assert d["low_speed_fraction"] is None and d["n_reversals"] == rep.n_reversals == 5
    assert "5 velocity reversals" in rep.summary() and "every parameter excited" in rep.summary()
    still = excitation_report(np.ones(50), np.zeros(50))
    assert "WARNING: the input u is constant" in still.summary()
    assert strict(still)["warnings"] == [{"code": w.code, "parameter": w.parameter, "message": str(w)}
                                         for w in still.warnings]
    assert still.warnings[0].code == "identifiability" and still.warnings[0].parameter == "all"


# --------------------------------------------------------------------------- Stribeck pre-fit


def test_stribeck_fit_plot_method_with_and_without_points():
    w = np.r_[-np.geomspace(5e-3, 1.0, 15), np.geomspace(5e-3, 1.0, 15)]
    F = P.friction(w) + np.random.default_rng(3).normal(0.0, 1e-3, w.size)
    fit = fit_stribeck(w, F)
    assert strict(fit)["Vs"] == fit.Vs
    assert f"{fit.Vs:.6g}" in fit.summary() and "30 points" in fit.summary()
    ax = fit.plot()
    curves = _lines(ax)
    assert len(curves) == 2 and len(ax.containers) == 0  # both branches, no measurements
    x = np.asarray(curves[1].get_xdata())
    assert x.max() == pytest.approx(20 * fit.Vs)
    np.testing.assert_allclose(curves[1].get_ydata(), stribeck(x, **fit.params()), rtol=1e-12)
    ax = fit.plot(w=w, F=F)
    assert len(ax.containers) == 1
    with pytest.raises(ParameterError, match="both w and F"):
        fit.plot(w=w)


def test_support_points_protocol():
    t = np.arange(40000) * TS
    w = np.repeat(np.array([-0.4, -0.1, -0.02, 0.02, 0.1, 0.4]), 40000 // 6 + 1)[:40000]
    u = P.friction(w)
    pts = binned_steady_state(MeasuredData(t, u, w), n_bins=4, max_accel=1e9)
    d = strict(pts)
    assert d["w_mean"] == pts.w_mean.tolist() and d["n_samples"] == pts.n_samples.tolist()
    assert f"{pts.n_points} support points" in pts.summary()
    ax = pts.plot()
    assert len(ax.containers) == 1 and "rad/s" in ax.get_xlabel()


# --------------------------------------------------------------------------- physical parameters


def test_physical_fit_to_dict_maps_nan_to_none():
    fit = PhysicalFit(method="output_error", params={"J": 1.0, "Fc": 2.0}, stderr={"J": math.nan, "Fc": 0.1},
                      cond=math.inf, nrmse=99.0, n_samples=10, info={"start": {"J": 1.0}, "x": (1, 2)})
    d = strict(fit)
    assert d["stderr"] == {"J": None, "Fc": 0.1} and d["cond"] is None and d["info"]["x"] == [1, 2]
    assert fit.to_json_dict() == d
    assert "Fc" in fit.summary() and "99.000 %" in fit.summary()


def test_output_error_options_validate_and_name_unknown_keys():
    o = OutputErrorOptions()
    assert (o.h_max, o.burn, o.fs_grid, o.loss, o.start) == (1e-3, 0.5, 31, "soft_l1", None)
    assert OutputErrorOptions(fs_grid=np.int64(5)).fs_grid == 5
    with pytest.raises(ParameterError, match="unknown option.*bogus"):
        OutputErrorOptions.from_options({"bogus": 1})
    with pytest.raises(ParameterError, match="fs_max_ratio"):
        OutputErrorOptions(fs_max_ratio=1.0)
    with pytest.raises(ParameterError, match="start is missing"):
        OutputErrorOptions(start={"J": 1.0})
    with pytest.raises(ParameterError, match="start\\['tau'\\]"):
        OutputErrorOptions(start={"J": 1.0, "Fc": 1.0, "Fs": 1.0, "sigma": 0.0, "tau": 0.0})
    with pytest.raises(ParameterError, match="loss"):
        fit_physical(np.arange(30.0), np.sin(np.arange(30.0)), np.sin(np.arange(30.0)), Vs=0.1, delta=1.0,
                     loss="huber")


def test_irregular_noise_estimate_is_exact_on_a_quadratic():
    # a quadratic is reproduced by every local quadratic fit: the residuals and the estimate are 0 up to rounding
    t = np.cumsum(np.random.default_rng(2).uniform(0.5, 1.5, 200))
    assert velocity_noise_std_irregular(t, 3.0 - 0.2 * t + 1e-3 * t**2) < 1e-10


# --------------------------------------------------------------------------- IDIM and EMPS


def test_idim_fit_and_rigid_axis_summary():
    true = RigidAxisModel.symmetric(95.0, 200.0, 20.0, -3.0)
    t = np.arange(8000) * TS
    w = 0.1 * np.sin(2 * np.pi * 0.5 * t) + 0.04 * np.sin(2 * np.pi * 1.7 * t + 0.3)
    fit = fit_idim(MeasuredData(t, true.force(np.gradient(w, t), w), w), decimate=10)
    d = strict(fit)
    assert d == fit.to_json_dict() and d["J"] == pytest.approx(95.0, rel=1e-8)
    assert "symmetric" in fit.summary() and "force error" in fit.summary()
    assert "Fc = 20" in true.summary()
    assert "Fc- = 21" in RigidAxisModel(J=1.0, Fc_pos=20.0, Fc_neg=21.0, sigma_pos=1.0, sigma_neg=2.0).summary()


def test_emps_simulation_protocol():
    n = 500
    t = np.arange(n) * TS
    rec = EMPSRecord(t=t, qm=np.zeros(n), qg=0.01 * np.sin(2 * np.pi * t), vir=np.zeros(n), pulses=np.zeros(n),
                     gtau=35.0, kp=160.0, kv=240.0, source="synthetic")
    sim = simulate_emps_loop(RigidAxisModel.symmetric(95.0, 200.0, 20.0), rec)
    d = strict(sim)
    assert d["w"] == sim.w.tolist() and len(d["t"]) == n
    assert "500 samples" in sim.summary() and "500 samples" in rec.summary()
    assert strict(rec)["gtau"] == 35.0
    ax = sim.plot()
    np.testing.assert_array_equal(_lines(ax)[0].get_ydata(), sim.w)


# --------------------------------------------------------------------------- online UKF


def test_online_ukf_result_protocol_and_options():
    p = JointParams(J=4.0, Fc=20.0, Fs=30.0, Vs=0.02, delta=1.0, sigma=10.0, tau=0.02)
    th0 = {"Fc": p.Fc, "Fs": p.Fs, "Vs": p.Vs, "delta": p.delta, "sigma": p.sigma, "tau": p.tau}
    t = np.arange(30) * 0.01
    u = 40.0 * np.sin(2 * np.pi * t)
    res = run_online_ukf(t, u, np.zeros(30), J=p.J, theta0=th0, noise_std=1e-3, options={"n_substeps": 2})
    d = strict(res)
    assert d["final"] == res.final and d["n_samples"] == 30 and len(d["P"]) == 8
    assert d["innovation_rms"] == pytest.approx(float(np.sqrt(np.mean(res.innovation[1:] ** 2))), rel=1e-15)
    assert "after 30 samples" in res.summary()
    ax = res.plot()
    assert [ln.get_label() for ln in _lines(ax)] == ["Fc", "Fs", "Vs", "delta", "sigma", "tau"]
    assert all(ln.get_ydata()[-1] == 1.0 for ln in _lines(ax))
    est = OnlineUKF(J=p.J, theta0=th0, noise_std=1e-3, options=UKFOptions(tau_max=1.0, crossing_gate=False))
    assert est.tau_max == 1.0 and est.crossing_gate is False and est.options.n_substeps == 10
    with pytest.raises(ParameterError, match="unknown UKF option"):
        UKFOptions.coerce({"n_steps": 3})
    with pytest.raises(TypeError, match="UKFOptions"):
        UKFOptions.coerce([1, 2])
    with pytest.raises(ParameterError, match="tau_max"):
        OnlineUKF(J=p.J, theta0=th0, noise_std=1e-3, options=UKFOptions(tau_max=0.01))


# --------------------------------------------------------------------------- regression model and estimate


def test_friction_estimate_round_trip_summary_and_plot(record):
    model = RegressionModel(P.Vs, P.delta, lag=False, stribeck=True, offset=True)
    est = fit_ls(model, record.u, record.w, Ts=TS).estimate
    d = strict(est)
    assert d["J_alt"] is None and d["Vs"] == P.Vs
    back = FrictionEstimate.from_dict(d)
    assert math.isnan(back.J_alt) and back.Fs == est.Fs and back.Vs == est.Vs
    with pytest.raises(ParameterError, match="keys"):
        FrictionEstimate.from_dict({"J": 1.0})
    # eq. 3 plus the offset, against the formula written out
    w = np.array([-0.3, -0.01, 0.0, 0.02, 0.4])
    ref = (np.sign(w) * (est.Fc + (est.Fs - est.Fc) * np.exp(-np.abs(w / P.Vs) ** P.delta)) + est.sigma * w
           + est.offset)
    np.testing.assert_allclose(est.friction(w), ref, rtol=1e-14, atol=1e-14)
    assert est.friction(0.0) == est.offset
    coulomb = FrictionEstimate(J=1.0, tau=0.0, sigma=2.0, Fc=3.0, Fs=3.0, offset=0.5, Vs=None, delta=None,
                               J_alt=math.nan)
    assert coulomb.friction(-0.5) == -3.0 - 1.0 + 0.5 and strict(coulomb)["delta"] is None
    assert "Fs = 1.4" in est.summary() and "fixed" in est.summary()
    assert "NOT physically plausible" in FrictionEstimate(**{**est.to_dict(), "J": -1.0, "J_alt": 0.0}).summary()
    ax = est.plot()
    x, y = (np.asarray(a) for a in (_lines(ax)[0].get_xdata(), _lines(ax)[0].get_ydata()))
    assert x.max() == pytest.approx(20 * P.Vs) and y[-1] == pytest.approx(est.friction(x[-1]), rel=1e-15)
    assert strict(model) == {"Vs": P.Vs, "delta": P.delta, "lag": False, "stribeck": True, "offset": True,
                             "names": ["a1", "b0", "c1", "d1", "o1"]}
