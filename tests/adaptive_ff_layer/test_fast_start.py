"""The fast start of the plain ``adaptive`` mode: the pre-fit map through the lag of the
identification run acts from the first period, the estimator's estimate takes over once trusted; pinned on short
``paper`` runs."""

import math
from dataclasses import replace

import numpy as np
import pytest

from adaptive_ff.compensation.adaptive_feedforward import FeedforwardStart, RobustAdaptiveFeedforward, RobustAdaptiveFeedforwardConfig
from adaptive_ff.compensation.sliding_estimator import SlidingFrictionEstimator
from adaptive_ff.identification.regression import FrictionEstimate
from controllers.experiments.compare import CompareOptions, eta, prepare_comparison
from controllers.simulation.closed_loop import run_mode
from controllers.simulation.metrics import deviation_rms, first_active_time
from plant.errors import ParameterError
from plant.friction import preset

P = preset("paper")
DUR = 15.0
HALF = int(DUR / 2e-3)  # first sample of the second half at Tc = 1 ms


def _est(tau, Fc=25.0, Fs=35.0, sigma=40.0):
    return FrictionEstimate(J=4.0, tau=tau, sigma=sigma, Fc=Fc, Fs=Fs, offset=0.0, Vs=0.02, delta=1.0,
                            J_alt=float("nan"))


@pytest.fixture(scope="module")
def runs():
    s = prepare_comparison(P, CompareOptions.from_flat(duration=DUR, modes=("adaptive", "fixed")))
    run = lambda mode, o: run_mode(P, s.reference, mode, o, rng=np.random.default_rng(s.noise_seed))  # noqa: E731
    out = {m: run(m, s.mode_options[m]) for m in ("none", "frictionless", "adaptive")}
    out["no_start"] = run("adaptive", s.mode_options["adaptive"].replace(start=None))
    f = s.prefit
    for k in (0.9, 1.1):  # the pre-fit levels with the true lag off by 10 %: a defect the pin must see
        e = FrictionEstimate(J=s.J_design, tau=k * P.tau, sigma=f.sigma, Fc=f.Fc, Fs=f.Fs, offset=0.0, Vs=f.Vs,
                             delta=f.delta, J_alt=float("nan"))
        out[f"fixed_{k}"] = run("fixed", s.mode_options["fixed"].replace(estimate=e))
    return s, out


def _eta_full(out, r):
    return eta(out["none"].metrics.rms, r.metrics.rms, out["frictionless"].metrics.rms)


def test_compare_starts_from_the_prefit_map_with_the_identified_lag_at_the_measurement(runs):
    s, _ = runs
    st = s.mode_options["adaptive"].feedforward.start
    assert st is not None and st.ff_input == "measured" and st.gain == 1.0
    # the lag of the identification run's offline fit (Sec. IV-A), projected as fixed uses it: within 2 % of 20 ms
    assert st.estimate.tau == pytest.approx(s.mode_options["fixed"].feedforward.estimate.tau, rel=1e-12)
    assert st.estimate.tau == pytest.approx(P.tau, rel=0.02)
    assert (st.estimate.Fc, st.estimate.Fs, st.estimate.sigma) == pytest.approx((s.prefit.Fc, s.prefit.Fs,
                                                                                   s.prefit.sigma), rel=1e-12)


def test_without_an_accepted_identification_the_start_uses_the_loop_time_constant_at_the_reference():
    # u_max = 40 N·m: levels above 20 N·m (half the range) are implausible, so the offline fit (Fc ~ 25 N·m) is
    # rejected and its lag cannot be used
    s = prepare_comparison(P, CompareOptions.from_flat(duration=3.0, modes=("adaptive",), u_max=40.0))
    assert s.offline is not None and s.offline.estimate.Fc > 20.0
    st = s.mode_options["adaptive"].feedforward.start
    assert st.ff_input == "reference" and st.estimate.tau == pytest.approx(1.0 / s.design.crossover, rel=1e-12)


def test_start_deviation_pins_the_identified_lag_over_seeds():
    # RMS of w - w_frictionless over the first 2 s (the start and the hand-over), mean over seeds 0-2: measured
    # 1.9e-3 rad/s with the identified lag, 5.3e-3 / 3.3e-3 with it 10 % short / long (oracle 1.4e-3; the
    # provisional start at the reference through 1/crossover was 6.8e-3 on seed 0), so a 10 % lag error breaks
    # the bound; one seed alone is not enough (seed 2: 1.9e-3 vs 2.2e-3 with +10 %)
    n2 = 2000
    devs = {k: [] for k in (0.9, 1.0, 1.1)}
    for seed in (0, 1, 2):
        s = prepare_comparison(P, CompareOptions.from_flat(duration=DUR, seed=seed, modes=("adaptive",)))
        run = lambda mode, o: run_mode(P, s.reference, mode, o, rng=np.random.default_rng(s.noise_seed))  # noqa: E731
        wl = run("frictionless", s.mode_options["frictionless"]).w
        mo = s.mode_options["adaptive"]
        for k in devs:
            start = mo.feedforward.start
            st = replace(start, estimate=replace(start.estimate, tau=k * start.estimate.tau))
            devs[k].append(deviation_rms(run("adaptive", mo.replace(start=st)).w[:n2], wl[:n2]))
    mean = {k: float(np.mean(v)) for k, v in devs.items()}
    assert mean[1.0] <= 3.0e-3
    assert mean[0.9] > 3.0e-3 and mean[1.1] > 3.0e-3


def test_fast_start_pins_switch_on_whole_run_eta_and_the_lag_in_use(runs):
    _, out = runs
    a, old = out["adaptive"], out["no_start"]
    # switched on in the first periods (without the start: ~6 s, the joint sticks under the PI alone)
    assert first_active_time(a.t, a.u_ff) <= 0.002
    assert first_active_time(old.t, old.u_ff) > 4.0
    # whole-run eta over 15 s: 0.95 with the start (measured 0.946), 0.23 without
    assert _eta_full(out, a) >= 0.93
    assert _eta_full(out, old) < 0.5
    # the estimator's estimate took over (hand-over) and its lag is within 7 % of the true 20 ms (measured +5.6 %
    # after 15 s with the sign observer of the feedforward; 120 s runs: 0.0198 +- 0.0005 s over ten seeds,
    # docs/benchmarks/compensation.md)
    assert a.estimate is not None and a.estimate.tau == pytest.approx(P.tau, rel=0.07)
    # second-half distance from the frictionless run: 2.47e-3 rad/s measured (with the loop-model stick fallback,
    # h/adaptive; 2.8e-3 with the reference fallback); the pre-fit map with the true lag off by -10 % / +10 %
    # (fixed mode, same scenario) is at 6.77e-3 / 3.61e-3 (with the true lag 2.41e-3; seeds 1, 2: +10 % at
    # 4.53e-3, 4.40e-3), so a 10 % lag error breaks the bound
    wl = out["frictionless"].w
    dev2 = lambda r: deviation_rms(r.w[HALF:], wl[HALF:])  # noqa: E731
    assert dev2(a) <= 3.1e-3
    assert dev2(out["fixed_0.9"]) > 3.1e-3 and dev2(out["fixed_1.1"]) > 3.1e-3


def test_start_map_acts_with_its_gain_until_the_hand_over_then_fades_to_one():
    est = SlidingFrictionEstimator(0.02, 1.0, Tc=1e-3)
    ff = RobustAdaptiveFeedforward(est, dt=1e-3, start=FeedforwardStart(_est(0.0, Fc=10.0, Fs=10.0, sigma=0.0),
                                   gain=0.5),
                                   config=RobustAdaptiveFeedforwardConfig(warmup=0, fade_in=0.1,
                                                                          max_rel_stderr=math.inf))
    assert ff.active and ff.provisional and ff.estimate is None
    # tau 0: no lag filter; at the reference 0.2 rad/s the start map is Fc = 10 N·m, times the gain
    assert ff.compensate(-0.3, 0.2) == pytest.approx(5.0, rel=1e-12)
    assert ff.step(0.2) == pytest.approx(5.0, rel=1e-12)
    assert ff.step(-0.3, 0.2) == pytest.approx(5.0, rel=1e-12)  # the reference, not the measurement
    # the lag of the start map: first-order filter with gain 1 - exp(-dt/tau) on the static map
    ff2 = RobustAdaptiveFeedforward(SlidingFrictionEstimator(0.02, 1.0, Tc=1e-3), dt=1e-3,
                                    start=FeedforwardStart(_est(0.05, Fc=10.0, Fs=10.0, sigma=0.0)))
    assert ff2.compensate(0.0, 0.2) == pytest.approx(10.0 * (1.0 - math.exp(-1e-3 / 0.05)), rel=1e-12)
    # feed a sliding record until the estimator's first estimate is taken: the output then fades from 0.5 to 1
    t = np.arange(20000) * 1e-3
    w = 0.2 + 0.1 * np.sin(2 * np.pi * 0.5 * t)
    u = 4.0 * np.gradient(w, 1e-3) + 10.0
    k_hand = None
    for k in range(t.size):
        ff.observe(float(u[k]), float(w[k]))
        if not ff.provisional:
            k_hand = k
            break
    assert k_hand is not None and ff.estimate is not None
    out = ff.compensate(0.2, 0.2)
    assert 0.5 < out / ff.u_ff < 0.5 + 2e-3 / 0.1 + 1e-12


@pytest.mark.parametrize("bad", [dict(gain=0.0), dict(gain=1.5), dict(ff_input="x"),
                                 dict(estimate=_est(-0.01)), dict(estimate=_est(0.0, Fc=math.nan))])
def test_start_validation(bad):
    kw = dict(estimate=_est(0.0))
    kw.update(bad)
    with pytest.raises(ParameterError):
        FeedforwardStart(**kw)
    with pytest.raises(ParameterError):
        RobustAdaptiveFeedforward(SlidingFrictionEstimator(0.02, 1.0, Tc=1e-3), dt=1e-3, start=_est(0.0))


def test_cli_no_fast_start_switches_the_start_off(capsys):
    """``compare --no-fast-start``: the adaptive feedforward waits for the estimator (the joint sticks under the PI
    alone for seconds); by default it acts from the first periods (as pinned above on 15 s)."""
    import json

    from controllers.cli.main import main

    args = ["compare", "--modes", "adaptive", "--duration", "6", "--no-figures", "--quiet", "--json"]
    t_on = {}
    for flag in ((), ("--no-fast-start",)):
        assert main(args + list(flag)) == 0
        t_on[flag] = json.loads(capsys.readouterr().out)["modes"]["adaptive"]["t_ff_on"]
    assert t_on[()] is not None and t_on[()] <= 0.002
    assert t_on[("--no-fast-start",)] is None or t_on[("--no-fast-start",)] > 1.0  # measured 2.71 s
