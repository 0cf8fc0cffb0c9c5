"""Output error without the Stribeck pre-fit: where the quasi-static pre-fit (Sec. V-C) is refused, fit_physical
fits Vs and delta with the other parameters, and says which parameters were fitted and which fixed."""

import math

import numpy as np
import pytest

from adaptive_ff.identification.physical_id import fit_physical
from adaptive_ff.identification.steady_state import constant_velocity_segments
from adaptive_ff.identification.stribeck_fit import fit_stribeck
from plant import bandlimited_noise, preset, sample, simulate
from plant.errors import ExcitationError, ParameterError, SignalError

P = preset("paper")
DT = 1e-3


@pytest.fixture(scope="module")
def log():
    """20 s of the Sec. IV-A experiment (band-limited torque) at 1 kHz with 1 % velocity noise, seed 0."""
    rng = np.random.default_rng(0)
    _, u = bandlimited_noise(20.0, dt=DT, cutoff=1.0, std=1.2 * (P.Fs + P.sigma * math.radians(20.0)), rng=rng)
    resp = simulate(P, u, dt=DT)
    return sample(resp, Ts=DT, noise_std=0.01 * float(np.max(np.abs(resp.w))), rng=rng)


def test_prefit_is_refused_and_output_error_fits_vs_and_delta(log):
    # the log has no constant-velocity runs: the pre-fit has no steady-state points and is refused
    sp = constant_velocity_segments(log.t, log.u, log.w)
    assert sp.w_mean.size == 0
    with pytest.raises((ExcitationError, SignalError)):
        fit_stribeck(sp.w_mean, sp.u_mean)
    fit = fit_physical(log.t, log.u, log.w, Vs=None, delta=None, input_delay=0.5 * DT, n_bootstrap=0)
    assert fit.info["fitted"] == ["J", "Fc", "Fs", "sigma", "tau", "offset", "Vs", "delta"]
    assert fit.info["fixed"] == {}
    e = {k: 100.0 * (fit.params[k] / getattr(P, k) - 1.0) for k in ("J", "Fc", "Fs", "sigma", "tau", "Vs", "delta")}
    # measured on this seed: J +0.06, Fc +0.42, Fs -3.8, sigma -0.21, tau -0.33, Vs +33, delta +2.6 %; on seeds 1
    # and 2 of the same log: Fs -11.6 and -13.8 %, Vs +73 and +91 %, delta +24 and -22 %, the others within 3 %
    # (the Stribeck hump is the weakest direction of this experiment: Fs, Vs and delta trade against each other
    # at breakaway, and the search stops above the cost at the truth). The tolerances are those of the three.
    for k, tol in (("J", 2.0), ("Fc", 2.0), ("Fs", 15.0), ("sigma", 2.0), ("tau", 5.0), ("Vs", 100.0),
                   ("delta", 25.0)):
        assert abs(e[k]) < tol, (k, e[k])


def test_given_vs_delta_are_reported_fixed(log):
    n = 3000
    fit = fit_physical(log.t[:n], log.u[:n], log.w[:n], Vs=P.Vs, delta=P.delta, method="paper")
    assert "Vs" not in fit.params
    oe = fit_physical(log.t[:n], log.u[:n], log.w[:n], Vs=P.Vs, delta=P.delta, n_bootstrap=0, lag_profile=False)
    assert oe.info["fixed"] == {"Vs": P.Vs, "delta": P.delta}
    assert "Vs" not in oe.info["fitted"] and "Vs" not in oe.params


def test_vs_and_delta_both_or_neither_and_paper_needs_them(log):
    t, u, w = log.t[:500], log.u[:500], log.w[:500]
    with pytest.raises(ParameterError, match="both Vs and delta"):
        fit_physical(t, u, w, Vs=None, delta=1.0)
    with pytest.raises(ParameterError, match="needs Vs and delta"):
        fit_physical(t, u, w, Vs=None, delta=None, method="paper")


def test_identify_output_error_without_prefit_reports_vs_delta_fitted(log):
    from adaptive_ff.identification.identify import identify
    from adaptive_ff.io.data import MeasuredData

    n = 6001  # 6 s: the form's report, not the accuracy (the test above)
    data = MeasuredData(t=log.t[:n], u=log.u[:n], w=log.w[:n])
    rep = identify(data, Vs=None, delta=None, method="output_error", lag=True,
                   method_options={"n_bootstrap": 0, "lag_profile": False, "input_delay": 0.5 * DT})
    form = rep.form
    assert "Vs" in form["fitted"] and "delta" in form["fitted"]
    assert form["fixed"] == {}
    assert rep.Vs == rep.physical.params["Vs"] and rep.delta == rep.physical.params["delta"]


def test_cli_output_error_without_vs_prints_and_reports_them_fitted(log, tmp_path, capsys):
    import json

    from controllers.cli.main import main

    n = 4001
    csv = tmp_path / "log.csv"
    np.savetxt(csv, np.column_stack([log.t[:n], log.u[:n], log.w[:n]]), delimiter=",", header="t,u,w", comments="")
    assert main(["identify", str(csv), "--method", "output_error", "--lag", "--bootstrap", "0", "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "fitted J, Fc, Fs, sigma, tau, offset, Vs, delta" in text
    assert main(["identify", str(csv), "--method", "output_error", "--lag", "--bootstrap", "0", "--quiet",
                 "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert {"Vs", "delta"} <= set(d["form"]["fitted"]) and d["form"]["fixed"] == {}
