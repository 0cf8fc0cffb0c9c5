"""The work ``identify`` estimates before it starts follows what ``--method auto`` runs, counted in simulations.

On a 1 kHz open-loop log with ``--Vs``, ``auto`` starts with the sliding regression and answers by output error
where the regression's own simulation-extrapolation finds J or tau biased (adaptive_ff.identification.identify).
The estimate counts both (:func:`adaptive_ff.identification.identify.auto_methods`); here it is compared with the
simulations the fit and its bootstrap refits report having run (``info["n_simulations"]``,
``info["bootstrap"]["n_simulations"]``), not with a timing.
"""

import math

import numpy as np
import pytest

from adaptive_ff.identification.identify import auto_methods, identify
from adaptive_ff.identification.physical_id import fit_physical
from adaptive_ff.io.data import MeasuredData, load_emps
from controllers.cli.budget import OE_FIT_SIMULATIONS, OE_REFIT_SHARE, TIME_LIMIT, identify_estimate
from controllers.cli.main import main
from emps_reference import EMPS
from plant import bandlimited_noise, preset, sample, simulate
from plant.errors import ParameterError

P = preset("paper")


def _open_loop(duration: float, seed: int = 0) -> MeasuredData:
    """The ``paper`` preset driven open loop by band-limited torque, 1 kHz, velocity noise 1 % of its peak (the log
    of benchmarks/output_error_speed.py)."""
    rng = np.random.default_rng(seed)
    _, u = bandlimited_noise(duration, dt=1e-3, cutoff=1.0, std=1.2 * (P.Fs + P.sigma * math.radians(20.0)), rng=rng)
    resp = simulate(P, u, dt=1e-3)
    m = sample(resp, Ts=1e-3, noise_std=0.01 * float(np.max(np.abs(resp.w))), rng=rng)
    return MeasuredData(m.t, m.u, m.w, source="open loop")


def _closed_loop(duration: float) -> MeasuredData:
    from controllers.experiments.synthetic_logs import closed_loop_readout

    return closed_loop_readout(P, duration, seeds=3).run.controller_log()


def test_auto_methods_names_the_output_error_fit_only_on_an_open_loop_controller_rate_log():
    assert auto_methods(_open_loop(5.0), Vs=P.Vs, lag=True) == ("sliding", "output_error")
    assert auto_methods(_closed_loop(5.0), Vs=P.Vs, lag=True) == ("sliding",)
    assert auto_methods(_open_loop(5.0), Vs=None) == ("paper",)
    assert auto_methods(load_emps(EMPS), Vs=None) == ("idim",)


def test_the_estimate_counts_the_simulations_auto_runs():
    d = _open_loop(10.0)
    est = identify_estimate(d.n_samples, auto_methods(d, Vs=P.Vs, lag=True), bootstrap=2)
    rep = identify(d, Vs=P.Vs, delta=P.delta, lag=True,  # the default method: auto
                   method_options={"n_bootstrap": 2, "bootstrap_workers": 1})
    info = rep.physical.info
    assert rep.physical.method == "output_error" and info["bootstrap"]["n"] == 2
    measured = info["n_simulations"] + info["bootstrap"]["n_simulations"]
    assert est.simulations == pytest.approx(OE_FIT_SIMULATIONS * (1 + 2 * OE_REFIT_SHARE["full"]))
    assert 0.9 < est.simulations / measured < 1.2
    # the refits hold the fit's input delay and screen their profile over tau: a share of the fit, not the fit again
    # (0.47 on the 20 s log)
    share = info["bootstrap"]["n_simulations"] / (2 * info["n_simulations"])
    assert abs(share - OE_REFIT_SHARE["full"]) < 0.1
    sliding_only = identify_estimate(d.n_samples, "sliding", bootstrap=2)
    assert sliding_only.simulations == 0 and est.seconds > 5 * sliding_only.seconds


def test_a_partial_refit_costs_its_share_of_a_fit():
    d = _open_loop(5.0)
    fit = fit_physical(d.t, d.u, d.w, Vs=P.Vs, delta=P.delta, method="output_error", n_bootstrap=3,
                       bootstrap_refit="partial", bootstrap_workers=1)
    share = fit.info["bootstrap"]["n_simulations"] / (3 * fit.info["n_simulations"])  # measured 0.124
    assert abs(share - OE_REFIT_SHARE["partial"]) < 0.04
    assert identify_estimate(d.n_samples, "output_error", bootstrap=3, refit="partial").simulations == \
        pytest.approx(OE_FIT_SIMULATIONS * (1 + 3 * OE_REFIT_SHARE["partial"]))


class Reached(ParameterError):
    """The stand-in of the work: the command got past its bound."""


def _reached(*args, **kwargs):
    raise Reached("the work started")


@pytest.mark.parametrize("loop", ["open", "closed"])
def test_the_cli_refuses_the_output_error_fit_auto_would_start(loop, tmp_path, monkeypatch, capsys):
    d = _open_loop(6.0) if loop == "open" else _closed_loop(6.0)
    path = tmp_path / "log.csv"
    np.savetxt(path, np.column_stack([d.t, d.u, d.w]), delimiter=",", header="t,u,w", comments="", fmt="%.10g")
    monkeypatch.setattr("adaptive_ff.identification.identify.identify", _reached)
    # 2000 refits: seconds for the sliding regression alone, hours with the output-error fit's
    assert identify_estimate(d.n_samples, "sliding", bootstrap=2000).seconds < 0.01 * TIME_LIMIT
    assert main(["identify", str(path), "--Vs", str(P.Vs), "--delta", str(P.delta), "--lag", "--bootstrap", "2000",
                 "--quiet"]) == 2
    err = capsys.readouterr().err
    if loop == "open":
        assert err.startswith(f"adaptive-ff: error: --bootstrap 2000 on {d.n_samples:,} samples (method auto: "
                              "sliding then output_error, the output_error fit where the sliding regression is "
                              "biased on this open-loop log; --method sliding keeps it): about "), err
        assert err.rstrip().endswith("pass --yes to run it anyway")
    else:
        assert "the work started" in err  # the closed loop keeps the sliding regression: within the limits
