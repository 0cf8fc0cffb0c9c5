"""The loop's sensor and drive as they are (controllers/simulation/sensor_drive.py, controllers/csrc/ctl_sensor.c,
ctl_drive.c): an encoder's quantised position, a measurement delay, a torque slew-rate limit.

Checked against independent computations from the recorded true velocity: scipy's cumulative trapezoid for
the position, numpy's floor for the counts and differences for the velocity; the delay as a shift; the slew
limit as a bound on the recorded torque's increments.
"""

import math

import numpy as np
import pytest
from scipy.integrate import cumulative_trapezoid

from controllers import LoopConfig, design_pi, run_batch, run_mode
from controllers.simulation.sensor_drive import DELAY_MAX, Drive, Sensor
from plant import ParameterError, preset
from plant.excitation import multisine_reference

P = preset("paper")
D = design_pi(P.J, crossover=20.0, phase_margin=60.0, Tc=1e-3)
REF = multisine_reference(8.0, rng=np.random.default_rng(0))
TC = 1e-3


def _opts(**kw):
    return LoopConfig.from_flat(Kp=D.Kp, Ki=D.Ki, u_max=150.0, Vs=P.Vs, delta=P.delta, sensor_gate=False, **kw)


def _encoder(w, counts, Tc=TC):
    """The encoder's velocity from the true velocity samples: trapezoid position, whole counts, differences."""
    res = 2 * np.pi / counts
    q = cumulative_trapezoid(w, dx=Tc, initial=0.0)
    qm = res * np.floor(q / res)
    v = np.empty_like(w)
    v[0] = w[0]
    v[1:] = np.diff(qm) / Tc
    return v


def test_sensor_component_against_the_independent_encoder():
    t = np.arange(2000) * TC
    w = 0.3 * np.sin(2 * np.pi * 1.3 * t) + 0.05
    s = Sensor(Tc=TC, counts_per_rev=2 ** 12)
    v = np.array([s.measure(x) for x in w])
    np.testing.assert_allclose(v, _encoder(w, 2 ** 12), rtol=0, atol=1e-9)
    assert set(np.round(v[1:] / (2 * np.pi / 2 ** 12 / TC)).astype(int)) <= {-1, 0, 1, 2, 3, 4, 5}  # whole counts


@pytest.mark.parametrize("counts", [2 ** 17, 2 ** 14])
def test_the_loop_measures_through_the_encoder(counts):
    r = run_mode(P, REF, "none", _opts(encoder_counts=counts), rng=np.random.default_rng(1))
    np.testing.assert_allclose(r.w_meas, _encoder(r.w, counts), rtol=0, atol=1e-6)
    step = 2 * np.pi / counts / TC
    k = np.round(r.w_meas[1:] / step)
    np.testing.assert_allclose(r.w_meas[1:], k * step, rtol=0, atol=1e-6)


@pytest.mark.parametrize("delay", [1, 3, DELAY_MAX])
def test_the_loop_measures_with_a_delay(delay):
    r = run_mode(P, REF, "none", _opts(delay=delay), rng=np.random.default_rng(1))
    np.testing.assert_array_equal(r.w_meas[delay:], r.w[:-delay])
    np.testing.assert_array_equal(r.w_meas[:delay], np.full(delay, r.w[0]))


def test_the_drive_limits_the_torque_slew_rate():
    slew = 60.0
    r = run_mode(P, REF, "adaptive", _opts(slew_rate=slew, noise_std=1e-3), rng=np.random.default_rng(1))
    du = np.diff(r.u)
    assert np.max(np.abs(du)) <= slew * TC * (1 + 1e-12)
    assert np.mean(np.abs(np.abs(du) - slew * TC) < 1e-9) > 0.01  # the limit acts
    free = run_mode(P, REF, "adaptive", _opts(noise_std=1e-3), rng=np.random.default_rng(1))
    huge = run_mode(P, REF, "adaptive", _opts(slew_rate=1e12, noise_std=1e-3), rng=np.random.default_rng(1))
    np.testing.assert_array_equal(huge.u, free.u)  # inside the limit the command is applied exactly


def test_batch_equals_single_runs_with_sensor_and_drive():
    o = _opts(encoder_counts=2 ** 16, delay=2, slew_rate=3000.0, noise_std=1e-3)
    single = run_mode(P, REF, "adaptive", o, rng=np.random.default_rng(4))
    b = run_batch([P, P.replace(J=3.0)], REF, "adaptive", o, seeds=[4, 5])
    assert b.rms_second_half[0] == single.metrics.rms_second_half


@pytest.mark.parametrize("kw,match", [(dict(encoder_counts=0), "counts_per_rev"),
                                      (dict(encoder_counts=2.5), "counts_per_rev"),
                                      (dict(delay=DELAY_MAX + 1), "delay"), (dict(delay=-1), "delay"),
                                      (dict(slew_rate=0.0), "slew_rate"), (dict(slew_rate=math.nan), "slew_rate")])
def test_bad_sensor_and_drive_settings_are_refused(kw, match):
    with pytest.raises(ParameterError, match=match):
        _opts(**kw)


def test_drive_component():
    d = Drive(Tc=TC, slew_rate=1000.0)
    assert [d.apply(u) for u in (5.0, 5.0, -5.0, 0.5)] == [1.0, 2.0, 1.0, 0.5]
