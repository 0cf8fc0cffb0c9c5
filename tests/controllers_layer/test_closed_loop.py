"""Closed loop: linear limit against python-control, oracle bound, adaptive safety, metrics, comparison."""

import math

import control
import numpy as np
import pytest

from adaptive_ff.compensation.eq4_feedforward import AdaptiveFrictionFeedforward, AdaptiveFrictionFeedforwardConfig
from adaptive_ff.compensation.feedforward import FrictionFeedforward, project_estimate
from adaptive_ff.identification.regression import FrictionEstimate, RegressionModel
from controllers.simulation.closed_loop import loop_metrics
from loop_helpers import run_named
from controllers.experiments.compare import compare, eta
from controllers.design.pi import design_pi
from plant import ParameterError, multisine_reference, preset

P = preset("paper")
DESIGN = design_pi(P.J, crossover=20.0, phase_margin=60.0, Tc=1e-3)
GAINS = dict(Kp=DESIGN.Kp, Ki=DESIGN.Ki)


@pytest.fixture(scope="module")
def ref():
    return multisine_reference(30.0, rng=np.random.default_rng(0))


def test_frictionless_loop_equals_python_control_linear_simulation(ref):
    r = run_named(P, ref, mode="frictionless", **GAINS)
    Tc = 1e-3
    plant_d = control.sample_system(control.tf([1.0], [P.J, 0.0]), Tc, method="zoh")
    Kp, KiTc = DESIGN.Kp, DESIGN.Ki * Tc
    C = control.tf([Kp + KiTc, -Kp], [1.0, -1.0], Tc)  # Kp + Ki*Tc*z/(z-1)
    T = control.feedback(C * plant_d, 1)
    w_lin = control.forced_response(T, T=ref.t, U=ref.w).outputs
    np.testing.assert_allclose(r.w, w_lin, atol=1e-9 * np.max(np.abs(ref.w)))


def test_oracle_is_close_to_frictionless_and_none_is_far(ref):
    runs = {m: run_named(P, ref, mode=m, **GAINS) for m in ("none", "oracle", "frictionless")}
    rms = {m: r.metrics.rms_second_half for m, r in runs.items()}
    assert rms["none"] > 3 * rms["frictionless"]
    assert eta(rms["none"], rms["oracle"], rms["frictionless"]) > 0.95


def test_fixed_feedforward_with_true_parameters_and_lag_helps(ref):
    true = FrictionEstimate(J=P.J, tau=P.tau, sigma=P.sigma, Fc=P.Fc, Fs=P.Fs, offset=0.0, Vs=P.Vs,
                            delta=P.delta, J_alt=P.J)
    none = run_named(P, ref, mode="none", **GAINS).metrics.rms_second_half
    fixed = run_named(P, ref, mode="fixed", estimate=true, ff_input="reference", **GAINS).metrics.rms_second_half
    meas = run_named(P, ref, mode="fixed", estimate=true, ff_input="measured", **GAINS).metrics.rms_second_half
    free = run_named(P, ref, mode="frictionless", **GAINS).metrics.rms_second_half
    # at the reference velocity the true map is early at reversals (the joint lags the
    # reference), so it helps but cannot cancel; at the measured velocity it nearly cancels
    assert eta(none, fixed, free) > 0.5
    assert eta(none, meas, free) > 0.95


def test_eq4_adaptive_mode_improves_tracking_and_stays_plausible(ref):
    """Judged over five noise realisations, not one: a single run of the eq.-4 feedforward is last-bit sensitive
    (its RMS ratio to ``none`` moves 0.35 -> 0.44 under a 1e-13 change of Kp, docs/benchmarks/perf.md): under noise
    its start-up transient can spike (seeds 1-5 with the reciprocal arithmetic of the plant step: ratios 0.43,
    0.43, 0.76, 0.42, 0.46 and max|u_ff| 39, 81, 500, 69, 58 N·m). The claim is that of a typical run: the median
    ratio is below 0.6 (a working estimator gives 0.35-0.5, one that does not adapt ~1, as ``none``) and at most
    two runs of five miss 0.6; the feedforward stays within 3*(Fs + sigma*0.4) on at least three runs and within
    ten times that on every run (a diverging estimate breaks all of these)."""
    model = RegressionModel(P.Vs, P.delta)
    kw = dict(noise_std=1e-3, **GAINS)
    ratios, peaks = [], []
    for seed in range(1, 6):
        none = run_named(P, ref, mode="none", rng=np.random.default_rng(seed), **kw).metrics.rms_second_half
        r = run_named(P, ref, mode="adaptive", estimator="eq4-rls", ff_input="reference", model=model,
                      rng=np.random.default_rng(seed), **kw)
        ratios.append(r.metrics.rms_second_half / none)
        peaks.append(float(np.max(np.abs(r.u_ff))))
        est = r.estimate
        assert est is not None and est.is_plausible()
        assert r.theta.shape == (r.info["n_updates"] + 1, 6)  # the first sample only primes the regressor
        assert np.all(np.isfinite(r.u))
    bound = 3 * (P.Fs + P.sigma * 0.4)
    assert np.median(ratios) < 0.6 and sum(q >= 0.6 for q in ratios) <= 2, ratios
    assert sum(u > bound for u in peaks) <= 2 and max(peaks) <= 10 * bound, peaks


def test_projection_rejects_nonfinite_and_clips_negative():
    raw = FrictionEstimate(J=2.0, tau=-0.01, sigma=-3.0, Fc=-1.0, Fs=5.0, offset=0.0, Vs=0.02, delta=1.0,
                           J_alt=2.0)
    pr = project_estimate(raw)
    assert (pr.tau, pr.sigma, pr.Fc, pr.Fs) == (0.0, 0.0, 0.0, 5.0)
    assert project_estimate(FrictionEstimate(**{**raw.to_dict(), "Fs": math.nan})) is None
    assert project_estimate(FrictionEstimate(**{**raw.to_dict(), "J": -1.0})) is None


def test_adaptive_feedforward_rejects_bad_samples_without_touching_state():
    ff = AdaptiveFrictionFeedforward(RegressionModel(P.Vs, P.delta), dt=1e-3,
                                     config=AdaptiveFrictionFeedforwardConfig(Ts=0.01, warmup=0))
    rng = np.random.default_rng(0)
    for _ in range(50):
        ff.observe(rng.normal(30.0, 5.0), rng.normal(0.2, 0.05))
    theta, Pm, n = ff.theta.copy(), ff.rls.P.copy(), ff.rls.n_updates
    assert ff.observe(math.nan, 0.1) is False and ff.observe(1.0, math.inf) is False
    assert ff.n_rejected == 2
    assert np.array_equal(ff.theta, theta) and np.array_equal(ff.rls.P, Pm) and ff.rls.n_updates == n


def test_feedforward_lag_discretisation_is_exact_first_order_response():
    est = FrictionEstimate(J=1.0, tau=0.05, sigma=0.0, Fc=10.0, Fs=10.0, offset=0.0, Vs=None, delta=None,
                           J_alt=1.0)
    ff = FrictionFeedforward(est, dt=1e-3)
    out = [ff.step(1.0) for _ in range(100)]
    t = np.arange(1, 101) * 1e-3
    np.testing.assert_allclose(out, 10.0 * (1 - np.exp(-t / 0.05)), rtol=1e-12)


def test_loop_metrics_analytic():
    t = np.linspace(0.0, 10.0, 10001)
    e = np.where(t < 5.0, 0.0, 2.0)
    m = loop_metrics(t, e, np.zeros_like(t), np.full_like(t, 3.0), reversals=np.array([7.0]), window=0.5)
    assert m.rms_second_half == pytest.approx(2.0) and m.max == 2.0 and m.u_rms == pytest.approx(3.0)
    assert m.rms == pytest.approx(math.sqrt(0.5 * 4.0), rel=1e-3) and m.rms_reversal == pytest.approx(2.0)


def test_sliding_adaptive_mode_recovers_the_physical_parameters_in_closed_loop(ref):
    kw = dict(noise_std=1e-3, **GAINS)
    r = run_named(P, ref, mode="adaptive", Vs=P.Vs, delta=P.delta, rng=np.random.default_rng(1), **kw)
    est = r.estimate
    # in closed loop, with noise: the sliding-regime gate removes the noise/feedback bias (module docstring)
    assert est.Fc == pytest.approx(P.Fc, rel=0.01) and est.Fs == pytest.approx(P.Fs, rel=0.02)
    assert est.sigma == pytest.approx(P.sigma, rel=0.02) and est.tau == pytest.approx(P.tau, rel=0.1)
    assert est.J == pytest.approx(P.J, rel=0.1)
    assert r.theta.shape == (r.info["n_updates"], 7) and r.info["names"][0] == "J"
    assert r.info["n_gated"] > 0 and r.info["n_rejected"] == 0 and not r.info["diverged"]


def test_compare_returns_all_modes_with_consistent_eta():
    comp = compare(P, duration=20.0, seed=3, progress=False)
    assert list(comp.results) == ["none", "fixed", "adaptive", "adaptive-dob", "canudas", "dob", "oracle",
                                  "frictionless"]
    assert comp.eta["none"] == 0.0 and comp.eta["frictionless"] == 1.0
    assert comp.eta["oracle"] > 0.9
    d = comp.to_json_dict()
    assert set(d["modes"]) == set(comp.results)
    assert set(d["modes"]["adaptive"]) >= {"rms", "max", "rms_reversal", "eta"}
    assert comp.prefit.Vs > 0


def test_bad_mode_and_missing_inputs_raise(ref):
    with pytest.raises(ParameterError, match="mode must be one of"):
        run_named(P, ref, mode="magic", **GAINS)
    with pytest.raises(ParameterError, match="estimate"):
        run_named(P, ref, mode="fixed", **GAINS)
    with pytest.raises(ParameterError, match="multiple"):
        run_named(P, ref, mode="none", Ts=0.0105, **GAINS)
