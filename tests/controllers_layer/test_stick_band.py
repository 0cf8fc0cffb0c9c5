"""One stick-band rule: ``feedforward.stick_band`` None sizes the band from the sensor the loop is configured with
(three times its velocity noise: white noise, an encoder's quantisation, a Kalman filter's own variance), a number
is used as given; run_mode, compare and the compensator file all take it from there."""

from __future__ import annotations

import math

import numpy as np
import pytest

from adaptive_ff.identification.regression import FrictionEstimate
from controllers.design.pi import design_pi
from controllers.experiments.compare import CompareOptions, measurement_noise
from controllers.simulation.closed_loop import LoopConfig, run_mode
from controllers.simulation.compensators import build_mode
from controllers.simulation.loop_config import STICK_BAND_NOISE, stick_band_for
from plant import preset
from plant.errors import ParameterError
from plant.excitation import multisine_reference


def test_the_band_is_three_times_the_configured_sensors_velocity_noise():
    assert STICK_BAND_NOISE == 3.0 and LoopConfig().sized_stick_band() == 0.0  # noiseless: the C default
    assert LoopConfig.from_flat(noise_std=2e-3).sized_stick_band() == pytest.approx(6e-3, rel=1e-15)
    # backward difference of a 2^17-count encoder at 1 kHz: two independent quantisation errors of res^2/12
    res = 2.0 * math.pi / 2 ** 17
    o = LoopConfig.from_flat(encoder_counts=2 ** 17, noise_std=1e-3)
    assert o.velocity_noise() == pytest.approx(math.sqrt(1e-6 + 2.0 * res ** 2 / 12.0 / 1e-3 ** 2), rel=1e-12)
    assert o.sized_stick_band() == 3.0 * o.velocity_noise() == pytest.approx(0.0588, abs=1e-4)
    assert o.replace(stick_band=0.01).sized_stick_band() == 0.01  # a number: as given
    assert o.replace(stick_band=0.0).sized_stick_band() == 0.0
    # the comparison's noise is the loop's (the same configured sensor), with the Kalman velocity too
    for kw in (dict(encoder_counts=2 ** 16), dict(encoder_counts=2 ** 17, velocity="kalman"), dict(noise_std=3e-3)):
        c = CompareOptions.from_flat(duration=1.0, **kw)
        assert measurement_noise(c) == c.loop.velocity_noise()
        assert c.loop.sized_stick_band() == 3.0 * measurement_noise(c)
    with pytest.raises(ParameterError, match="noise"):
        stick_band_for(-1e-3)
    with pytest.raises(ParameterError, match="noise"):
        stick_band_for(math.inf)


def test_run_mode_at_the_library_default_sizes_the_band_for_an_encoder():
    # fixed with the true friction model behind a 17-bit encoder's backward difference (noise 0.0196 rad/s, as
    # large as Vs): with a band of 0 the friction map's sign flips with the noise at every slow passage
    p = preset("paper")
    d = design_pi(p.J, crossover=20.0, phase_margin=60.0, Tc=1e-3)
    est = FrictionEstimate(J=p.J, tau=p.tau, sigma=p.sigma, Fc=p.Fc, Fs=p.Fs, offset=0.0, Vs=p.Vs, delta=p.delta,
                           J_alt=math.nan)
    ref = multisine_reference(20.0, rng=np.random.default_rng(0))
    o = LoopConfig.from_flat(Kp=d.Kp, Ki=d.Ki, u_max=150.0, encoder_counts=2 ** 17, estimate=est)
    assert build_mode(p, "fixed", o)[2].stick_band == pytest.approx(o.sized_stick_band(), rel=1e-15)
    eta = {}
    for band, opts in (("sized", o), ("zero", o.replace(stick_band=0.0))):
        r = {m: run_mode(p, ref, m, opts, rng=np.random.default_rng(1)).metrics.rms_second_half
             for m in ("none", "fixed", "frictionless")}
        eta[band] = (r["none"] - r["fixed"]) / (r["none"] - r["frictionless"])
    assert eta["sized"] > 0.95 and eta["zero"] < -1.0, eta
