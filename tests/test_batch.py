"""Tests of controllers.simulation.batch: the compiled batch kernel equals run_closed_loop run one by one."""

import inspect
import math

import numpy as np
import pytest

from adaptive_ff.identification.regression import FrictionEstimate
from controllers.simulation.batch import run_batch
from controllers.simulation.closed_loop import run_closed_loop
from plant.errors import ParameterError
from plant.excitation import multisine_reference
from plant.friction import preset

FIELDS = ("rms", "max", "rms_second_half", "max_second_half", "rms_reversal", "u_rms")
# compare with the plain-Python engine of run_closed_loop (independent of any compiled kernel), where selectable
_PY = {"engine": "python"} if "engine" in inspect.signature(run_closed_loop).parameters else {}


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
        pytest.skip("ff_input only matters for fixed")
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
    res = run_batch(plants, ref, mode=mode, Kp=Kp, Ki=Ki, u_max=u_max, noise_std=1e-3, seeds=seeds,
                    estimate=est, ff_input=ff_input)
    for b, p in enumerate(plants):
        one = run_closed_loop(p, ref, mode=mode, Kp=float(Kp[b]), Ki=float(Ki[b]), u_max=float(u_max[b]),
                              noise_std=1e-3, rng=np.random.default_rng(seeds[b]), estimate=est[b],
                              ff_input=ff_input, sensor_gate=False, **_PY)
        for name in FIELDS:
            assert getattr(res, name)[b] == pytest.approx(getattr(one.metrics, name), rel=1e-9, abs=1e-15, nan_ok=True), name
        assert not res.diverged[b]
    res2 = run_batch(plants, ref, mode=mode, Kp=Kp, Ki=Ki, u_max=u_max, noise=noise, estimate=est,
                     ff_input=ff_input)
    one = run_closed_loop(plants[1], ref, mode=mode, Kp=float(Kp[1]), Ki=float(Ki[1]), u_max=float(u_max[1]),
                          estimate=est[1], ff_input=ff_input, sensor_gate=False, noise_std=0.0, **_PY)
    res0 = run_batch(plants, ref, mode=mode, Kp=Kp, Ki=Ki, u_max=u_max, estimate=est, ff_input=ff_input)
    assert res0.rms[1] == pytest.approx(one.metrics.rms, rel=1e-9)
    assert np.all(np.isfinite(res2.rms))


def test_bad_inputs():
    rng = np.random.default_rng(1)
    ref = multisine_reference(0.5, rng=rng)
    p = [preset("paper")] * 2
    with pytest.raises(ParameterError, match="mode"):
        run_batch(p, ref, mode="adaptive", Kp=1.0, Ki=1.0)
    with pytest.raises(ParameterError, match="Kp"):
        run_batch(p, ref, mode="none", Kp=[1.0, 2.0, 3.0], Ki=1.0)
    with pytest.raises(ParameterError, match="Ki"):
        run_batch(p, ref, mode="none", Kp=1.0, Ki=-1.0)
    with pytest.raises(ParameterError, match="u_max"):
        run_batch(p, ref, mode="none", Kp=1.0, Ki=1.0, u_max=0.0)
    with pytest.raises(ParameterError, match="estimate"):
        run_batch(p, ref, mode="fixed", Kp=1.0, Ki=1.0)
    with pytest.raises(ParameterError, match="seeds"):
        run_batch(p, ref, mode="none", Kp=1.0, Ki=1.0, noise_std=0.1)
    with pytest.raises(ParameterError, match="noise"):
        run_batch(p, ref, mode="none", Kp=1.0, Ki=1.0, noise=np.zeros(3))
    with pytest.raises(ParameterError, match="plants"):
        run_batch([], ref, mode="none", Kp=1.0, Ki=1.0)


def test_divergence_matches_run_closed_loop():
    rng = np.random.default_rng(2)
    ref = multisine_reference(1.0, rng=rng)
    p = preset("paper")
    Kp = 5.0 * p.J / 1e-3  # Kp*Tc/J = 5 > 2: the discrete loop is unstable
    res = run_batch([p, p], ref, mode="none", Kp=[Kp, 1.0], Ki=1.0)
    one = run_closed_loop(p, ref, mode="none", Kp=Kp, Ki=1.0, sensor_gate=False, **_PY)
    assert one.info["diverged"] and res.diverged[0] and not res.diverged[1]
    assert math.isnan(res.rms[0]) and math.isnan(one.metrics.rms)


def test_friction_shortcuts_are_bit_exact():
    """_F skips pow for delta == 1 and pow/exp above _wcut; both must give eq. 3 bit for bit."""
    from controllers.simulation.batch import _F, _wcut
    from plant.joint import _friction_scalar

    rng = np.random.default_rng(9)
    for Fc, Fs, Vs, delta, sigma in ((25.0, 35.0, 0.02, 1.0, 40.0), (3.0, 3.0, 0.1, 1.7, 0.0),
                                     (0.0, 2.0, 0.01, 0.6, 1.0), (0.0, 0.0, 0.05, 2.0, 0.0),
                                     (7.5, 20.0, 0.005, 2.3, 5.0)):
        p = preset("paper").replace(Fc=Fc, Fs=Fs, Vs=Vs, delta=delta, sigma=sigma)
        F = _friction_scalar(p)
        wcut = _wcut(Fc, Fs - Fc, Vs, delta)
        assert wcut < math.inf
        w = np.concatenate([wcut * rng.uniform(0.5, 3.0, 2000), Vs * 10.0 ** rng.uniform(-3, 3, 2000), [0.0]])
        for x in np.concatenate([w, -w]).tolist():
            assert _F(x, Fc, Fs - Fc, Vs, delta, sigma, delta == 1.0, wcut) == F(x)


@pytest.mark.parametrize("mode", ["none", "fixed"])
def test_parallel_chunks_equal_single_runs_bit_for_bit(mode):
    """B = 21 spans several chunks (the prange kernel with >= 2 numba threads); each scenario equals its own run."""
    rng = np.random.default_rng(8)
    ref = multisine_reference(1.0, f_min=0.5, rng=rng)
    plants = _plants(rng, 21)
    plants[5] = plants[5].replace(delta=1.7)
    Kp = rng.uniform(0.5, 1.5, 21) * 2.0
    seeds = list(range(100, 121))
    est = [FrictionEstimate(J=p.J, tau=p.tau, sigma=p.sigma, Fc=p.Fc * 0.9, Fs=p.Fs, offset=0.0, Vs=p.Vs,
                            delta=p.delta, J_alt=p.J) for p in plants]
    res = run_batch(plants, ref, mode=mode, Kp=Kp, Ki=40.0, noise_std=1e-3, seeds=seeds, estimate=est)
    for b in (0, 5, 9, 10, 20):
        one = run_batch([plants[b]], ref, mode=mode, Kp=Kp[b], Ki=40.0, noise_std=1e-3, seeds=[seeds[b]],
                        estimate=est[b])
        for name in FIELDS:
            np.testing.assert_array_equal(getattr(res, name)[b], getattr(one, name)[0], err_msg=name)
