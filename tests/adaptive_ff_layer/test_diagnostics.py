"""Data-quality diagnostics: noise level, excitation warnings, and their use in identify()."""

from pathlib import Path

import numpy as np
import pytest

from adaptive_ff.io.data import MeasuredData, load_emps
from adaptive_ff.identification.diagnostics import excitation_report, velocity_noise_std
from adaptive_ff.identification.identify import identify
from adaptive_ff.identification.regression import RegressionModel
from plant.errors import ExcitationError, ParameterError, SignalError
from plant.friction import JointParams

ROOT = Path(__file__).resolve().parents[2]
EMPS = ROOT / "data" / "emps" / "DATA_EMPS.mat"
Ts = 1e-3


def test_noise_std_of_white_noise_on_a_smooth_signal():
    rng = np.random.default_rng(0)
    t = np.arange(20000) * Ts
    for s in (1e-3, 1e-2):
        w = 0.5 * np.sin(2 * np.pi * 0.7 * t) + s * rng.standard_normal(t.size)
        # MAD of 20000 third differences: relative standard error about 1.1/sqrt(N) ~ 1 %; bound 5 %
        assert velocity_noise_std(w) == pytest.approx(s, rel=0.05)
    # a smooth signal alone: its third differences are a sinusoid of amplitude A = (2*pi*0.7)^3 * 0.5 * Ts^3
    # = 4.3e-8, whose scaled MAD is 1.4826 * A / sqrt(2) = 1.05 A; /sqrt(20): 1.0e-8, far below any real noise
    A = (2 * np.pi * 0.7) ** 3 * 0.5 * Ts**3
    assert velocity_noise_std(0.5 * np.sin(2 * np.pi * 0.7 * t)) == pytest.approx(1.4826 * A / np.sqrt(40), rel=0.02)


def _stribeck_record(amplitude, *, n=6000, offset=0.2, mean=0.0, w0=0.0):
    """Noise-free record of the eq. 4 Stribeck model under a square-wave torque (reversals every 1 s)."""
    p = JointParams(J=0.5, Fc=1.0, Fs=1.4, Vs=0.05, delta=1.5, sigma=0.8, tau=0.0)
    t = np.arange(n) * Ts
    u = mean + amplitude * np.sign(np.sin(2 * np.pi * 0.5 * t)) + 0.3 * np.sin(2 * np.pi * 7 * t)
    m = RegressionModel(p.Vs, p.delta, lag=False, stribeck=True, offset=True)
    w = m.simulate(m.theta_from_physical(p, Ts, offset=offset), u, [w0, w0])
    return p, MeasuredData(t, u, w, source="synthetic")


def test_low_speed_warning_names_fs_and_vs():
    # fast reversals (square wave of 30 N·m against Fc = 1): the velocity passes the Stribeck
    # transition |w| < 3*Vs in a few samples only
    p, d = _stribeck_record(30.0)
    rep = excitation_report(d.u, d.w, Vs=p.Vs)
    frac = np.mean((np.abs(d.w) < 3 * p.Vs) & (np.abs(d.w) > 3 * rep.noise_std))
    assert rep.low_speed_fraction == pytest.approx(frac, rel=1e-12) and 0 < frac < 0.01
    assert len(rep.warnings) == 1 and "Fs and Vs are not identifiable" in rep.warnings[0]
    assert f"{100 * frac:.2f} %" in rep.warnings[0]
    # identify() passes the warning on (the noise-free record is still fitted exactly)
    r = identify(d, Vs=p.Vs, delta=p.delta, method="paper")
    assert any("Fs and Vs are not identifiable" in w for w in r.warnings)
    assert r.estimate.Fs == pytest.approx(1.4, rel=1e-6)
    assert "Fs and Vs are not identifiable" in r.summary() and r.to_json_dict()["warnings"] == [w.to_dict() for w in r.warnings]
    # slower reversals: 6 % of the samples in the transition, no warning
    p, d = _stribeck_record(3.0)
    assert excitation_report(d.u, d.w, Vs=p.Vs).warnings == ()


def test_no_low_speed_samples_at_all_names_the_cause_in_the_excitation_error():
    # the torque keeps the joint moving forwards (no reversal, |w| > 1): the Stribeck column exp(-|w/Vs|^1.5)
    # is ~1e-15, fit_ls refuses, and identify() says why
    p, d = _stribeck_record(0.5, mean=3.0, w0=2.0)
    assert np.min(d.w) > 1.0
    with pytest.raises(ExcitationError, match="Fs and Vs are not identifiable") as exc:
        identify(d, Vs=p.Vs, delta=p.delta, method="paper")
    assert "reversal" in str(exc.value)


def test_no_reversal_warning():
    rng = np.random.default_rng(3)
    t = np.arange(5000) * Ts
    w = 1.0 + 0.5 * np.sin(2 * np.pi * 1.3 * t) + 1e-3 * rng.standard_normal(t.size)
    u = 2.0 + 0.8 * w
    rep = excitation_report(u, w)
    assert rep.n_reversals == 0
    assert any("0 velocity reversal" in x and "Fc is not separable" in x for x in rep.warnings)
    # the same warning through identify() (Coulomb structure without offset: the fit itself succeeds)
    p = JointParams(J=0.5, Fc=1.0, Fs=1.0, Vs=0.05, delta=1.5, sigma=0.8, tau=0.0)
    m = RegressionModel(lag=False, stribeck=False, offset=False)
    u = 3.0 + 0.5 * np.sin(2 * np.pi * 0.9 * t)
    wsim = m.simulate(m.theta_from_physical(p, Ts), u, [2.0, 2.0])
    r = identify(MeasuredData(t, u, wsim), offset=False, method="paper")
    assert np.all(wsim > 0)
    assert any("Fc is not separable from a constant torque offset" in x for x in r.warnings)
    # with an offset the Coulomb column is collinear with it: an error that names the cause
    with pytest.raises(ExcitationError, match="drive in both directions"):
        identify(MeasuredData(t, u, wsim), method="paper")


def test_constant_speed_and_acceleration_warnings():
    t = np.arange(4000) * Ts
    w = np.where(np.sin(2 * np.pi * 1.0 * t) >= 0, 1.0, -1.0)  # two speed levels only, symmetric
    u = 2.0 * w
    rep = excitation_report(u, w)
    assert any("sigma is not separable from Fc" in x for x in rep.warnings)
    u = np.ones(100)
    w = np.linspace(-1, 1, 100)
    assert any("constant" in x for x in excitation_report(u, w).warnings)
    # a velocity that changes no more than its noise: J not identifiable
    rng = np.random.default_rng(1)
    w = 1.0 + 0.01 * t + 1e-2 * rng.standard_normal(t.size)
    rep = excitation_report(np.sin(t), w)
    assert any("J (and tau) are not identifiable" in x for x in rep.warnings), rep.warnings


def test_emps_excitation_is_sufficient():
    d = load_emps(EMPS)
    rep = excitation_report(d.u, d.w, Vs=0.005)
    # 7 reversals (the trajectory goes back and forth); 2.2 % of the samples are below 5 mm/s (data README)
    assert rep.n_reversals == 7 and rep.warnings == ()
    assert 0.01 < rep.low_speed_fraction < 0.1
    assert np.mean(np.abs(d.w) < 0.005) == pytest.approx(0.022, abs=0.001)


def test_bad_arguments():
    w = np.linspace(-1, 1, 50)
    with pytest.raises(ParameterError, match="min_reversals"):
        excitation_report(w, w, min_reversals=0)
    with pytest.raises(ParameterError, match="min_low_speed"):
        excitation_report(w, w, min_low_speed=1.0)
    with pytest.raises(ParameterError, match="Vs"):
        excitation_report(w, w, Vs=-1.0)
    with pytest.raises(SignalError, match="w"):
        velocity_noise_std(np.ones(5))
    with pytest.raises(SignalError):
        excitation_report(w, w[:-1])
