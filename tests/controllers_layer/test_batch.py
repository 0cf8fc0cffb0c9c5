"""Tests of controllers.simulation.batch: the batch engine equals single runs, each checked against its replay by the
independent oracles (tests/loop_oracle.py)."""

import math

import numpy as np
import pytest

from adaptive_ff.identification.regression import FrictionEstimate
from controllers.simulation.batch import run_batch
from controllers.simulation.closed_loop import LoopConfig
from loop_oracle import replayed_run
from plant.errors import ParameterError
from plant.excitation import multisine_reference
from plant.friction import preset

FIELDS = ("rms", "max", "rms_second_half", "max_second_half", "rms_reversal", "u_rms")


def _opts(Kp, Ki, u_max=math.inf, estimate=None, **kw):
    """One LoopConfig per scenario (sensor gate off, as the batch runs were first defined)."""
    B = len(np.atleast_1d(Kp))
    per = lambda x, b: float(np.broadcast_to(np.asarray(x, dtype=float), (B,))[b])  # noqa: E731
    ests = estimate if isinstance(estimate, list) else [estimate] * B
    return [LoopConfig.from_flat(Kp=per(Kp, b), Ki=per(Ki, b), u_max=per(u_max, b), estimate=ests[b], sensor_gate=False,
                        **kw) for b in range(B)]


def _plants(rng, n=3):
    base = preset("paper")
    out = [base.replace(tau=0.0)]
    for _ in range(n - 1):
        out.append(base.replace(J=base.J * rng.uniform(0.7, 1.3), Fc=base.Fc * rng.uniform(0.7, 1.3),
                                Fs=base.Fs * rng.uniform(1.0, 1.3), tau=base.tau * rng.uniform(0.5, 2.0)))
    return out


@pytest.mark.parametrize("mode", ["none", "frictionless", "oracle", "fixed"])
@pytest.mark.parametrize("ff_input", ["measured", "reference"])
def test_batch_equals_one_by_one(mode, ff_input):
    if mode != "fixed" and ff_input == "reference":
        pytest.skip("ff_input only matters for fixed")  # (3 skipped cases, by design)
    rng = np.random.default_rng(5)
    ref = multisine_reference(4.0, f_min=0.3, rng=rng)
    plants = _plants(rng)
    B = len(plants)
    Kp = rng.uniform(0.5, 1.5, B) * 2.0
    Ki = rng.uniform(0.5, 1.5, B) * 40.0
    u_max = np.array([math.inf, 5.0, 3.0])
    noise = rng.normal(0.0, 1e-3, size=(B, ref.t.size))
    seeds = [11, 12, 13]
    est = [FrictionEstimate(J=p.J, tau=p.tau, sigma=p.sigma, Fc=p.Fc * 0.9, Fs=p.Fs, offset=0.0, Vs=p.Vs,
                            delta=p.delta, J_alt=p.J) for p in plants]
    res = run_batch(plants, ref, mode, _opts(Kp, Ki, u_max, est, noise_std=1e-3, ff_input=ff_input), seeds=seeds)
    for b, p in enumerate(plants):
        one = replayed_run(p, ref, mode=mode, Kp=float(Kp[b]), Ki=float(Ki[b]), u_max=float(u_max[b]),
                           noise_std=1e-3, seed=seeds[b], estimate=est[b], ff_input=ff_input, sensor_gate=False)
        for name in FIELDS:
            assert getattr(res, name)[b] == pytest.approx(getattr(one["metrics"], name), rel=1e-9, abs=1e-15, nan_ok=True), name
        assert not res.diverged[b]
    res2 = run_batch(plants, ref, mode, _opts(Kp, Ki, u_max, est, ff_input=ff_input), noise=noise)
    one = replayed_run(plants[1], ref, mode=mode, Kp=float(Kp[1]), Ki=float(Ki[1]), u_max=float(u_max[1]),
                       estimate=est[1], ff_input=ff_input, sensor_gate=False, noise_std=0.0)
    res0 = run_batch(plants, ref, mode, _opts(Kp, Ki, u_max, est, ff_input=ff_input))
    assert res0.rms[1] == pytest.approx(one["metrics"].rms, rel=1e-9)
    assert np.all(np.isfinite(res2.rms))


def test_bad_inputs():
    rng = np.random.default_rng(1)
    ref = multisine_reference(0.5, rng=rng)
    p = [preset("paper")] * 2
    o = LoopConfig.from_flat(Kp=1.0, Ki=1.0)
    with pytest.raises(ParameterError, match="mode"):
        run_batch(p, ref, "magic", o)
    with pytest.raises(ParameterError, match="options"):
        run_batch(p, ref, "none", [o, o, o])
    with pytest.raises(ParameterError, match="Ki"):
        run_batch(p, ref, "none", LoopConfig.from_flat(Kp=1.0, Ki=-1.0))
    with pytest.raises(ParameterError, match="u_max"):
        run_batch(p, ref, "none", LoopConfig.from_flat(Kp=1.0, Ki=1.0, u_max=0.0))
    with pytest.raises(ParameterError, match="estimate"):
        run_batch(p, ref, "fixed", o)
    with pytest.raises(ParameterError, match="seeds"):
        run_batch(p, ref, "none", LoopConfig.from_flat(Kp=1.0, Ki=1.0, noise_std=0.1))
    with pytest.raises(ParameterError, match="noise"):
        run_batch(p, ref, "none", o, noise=np.zeros(3))
    with pytest.raises(ParameterError, match="plants"):
        run_batch([], ref, "none", o)


def test_divergence_matches_run_closed_loop():
    rng = np.random.default_rng(2)
    ref = multisine_reference(1.0, rng=rng)
    p = preset("paper")
    Kp = 5.0 * p.J / 1e-3  # Kp*Tc/J = 5 > 2: the discrete loop is unstable
    res = run_batch([p, p], ref, "none", _opts([Kp, 1.0], 1.0))
    one = replayed_run(p, ref, mode="none", Kp=Kp, Ki=1.0, sensor_gate=False)
    assert one["diverged"] and res.diverged[0] and not res.diverged[1]
    assert math.isnan(res.rms[0]) and math.isnan(one["metrics"].rms)


@pytest.mark.parametrize("mode", ["none", "fixed", "adaptive", "dob"])
def test_parallel_chunks_equal_single_runs_bit_for_bit(mode):
    """B = 21 spans several chunks (on >= 2 engine threads where the machine has them); each scenario equals its own
    run."""
    rng = np.random.default_rng(8)
    ref = multisine_reference(1.0, f_min=0.5, rng=rng)
    plants = _plants(rng, 21)
    plants[5] = plants[5].replace(delta=1.7)
    Kp = rng.uniform(0.5, 1.5, 21) * 2.0
    seeds = list(range(100, 121))
    est = [FrictionEstimate(J=p.J, tau=p.tau, sigma=p.sigma, Fc=p.Fc * 0.9, Fs=p.Fs, offset=0.0, Vs=p.Vs,
                            delta=p.delta, J_alt=p.J) for p in plants]
    kw = dict(noise_std=1e-3, Vs=0.02, delta=1.0, warmup=50)
    res = run_batch(plants, ref, mode, _opts(Kp, 40.0, math.inf, est, **kw), seeds=seeds)
    for b in (0, 5, 9, 10, 20):
        one = run_batch([plants[b]], ref, mode, _opts([Kp[b]], 40.0, math.inf, [est[b]], **kw), seeds=[seeds[b]])
        for name in FIELDS:
            np.testing.assert_array_equal(getattr(res, name)[b], getattr(one, name)[0], err_msg=name)


def test_a_plant_given_many_times_equals_equal_copies_bit_for_bit():
    """run_batch packs a plant object given more than once only once; the scenarios equal those of equal but
    distinct plant objects (drifting plants of other table lengths padded by their last row, sensor gates on)."""
    from plant.drift import FrictionDrift

    rng = np.random.default_rng(3)
    ref = multisine_reference(0.6, f_min=0.5, rng=rng)
    p = preset("paper")
    drift = FrictionDrift(p, Fc_change=0.5, Fs_change=0.3, t_start=0.1, t_end=0.5, period=0.05)
    shared = [p, drift, p, p.replace(tau=0.0), drift, p]
    copies = [p.replace(), FrictionDrift(p, Fc_change=0.5, Fs_change=0.3, t_start=0.1, t_end=0.5, period=0.05),
              p.replace(), p.replace(tau=0.0), FrictionDrift(p, Fc_change=0.5, Fs_change=0.3, t_start=0.1, t_end=0.5,
                                                              period=0.05), p.replace()]
    o = LoopConfig.from_flat(Kp=8.0, Ki=40.0, u_max=150.0, noise_std=1e-3, sensor_gate=True)
    a = run_batch(shared, ref, "none", o, seeds=list(range(6)))
    b = run_batch(copies, ref, "none", o, seeds=list(range(6)))
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    assert np.all(np.isfinite(a.rms)) and a.rms[0] != a.rms[2]  # same plant, other noise seed
