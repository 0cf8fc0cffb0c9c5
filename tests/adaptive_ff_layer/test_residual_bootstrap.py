"""Residual block bootstrap (covariance.circular_block_resample, politis_white_block, residual_block_bootstrap),
the friction band and the bootstrap errors of identify (adaptive_ff.identification.uncertainty)."""

import json
import math

import numpy as np
import pytest
from scipy.signal import lfilter

from adaptive_ff.identification.covariance import (BootstrapSettings, circular_block_resample, politis_white_block,
                                                     residual_block_bootstrap)
from adaptive_ff.identification.identify import identify
from adaptive_ff.identification.uncertainty import (FrictionBand, ParameterUncertainty, friction_band,
                                                      friction_curves)
from adaptive_ff.io.data import MeasuredData
from plant import bandlimited_noise, sample, simulate
from plant.errors import ParameterError, SignalError
from plant.friction import JointParams
from plant.stribeck_map import stribeck

# a Coulomb + viscous joint (Fs = Fc, no lag): the structure identify fits without Vs, delta
P = JointParams(J=2.0, Fc=5.0, Fs=5.0, Vs=0.02, delta=1.0, sigma=8.0, tau=0.0)


def _ar1(phi: float, n: int, seed: int) -> np.ndarray:
    return lfilter([1.0], [1.0, -phi], np.random.default_rng(seed).normal(size=n))


def test_circular_blocks_are_consecutive_modulo_n_and_every_sample_equally_likely():
    r = np.arange(10.0)
    s = circular_block_resample(r, 23, block=4, rng=np.random.default_rng(3))
    assert s.shape == (23,)
    for b in range(0, 23, 4):  # each block continues by +1 modulo 10
        blk = s[b:b + 4]
        np.testing.assert_array_equal(np.diff(blk) % 10, np.ones(blk.shape[0] - 1))
    # uniform starts on 0..n-1 with wrap-around: each index has probability 1/n per position
    counts = np.bincount(circular_block_resample(r, 200_000, block=7, rng=np.random.default_rng(1)).astype(int),
                         minlength=10) / 200_000
    np.testing.assert_allclose(counts, 0.1, atol=0.004)
    two = circular_block_resample(np.c_[r, -r], 12, block=5, rng=np.random.default_rng(0))
    np.testing.assert_array_equal(two[:, 1], -two[:, 0])  # channels resampled together


def test_circular_resample_rejects_bad_input():
    with pytest.raises(SignalError, match="residuals"):
        circular_block_resample([np.nan, 1.0], 3, block=1, rng=np.random.default_rng(0))
    with pytest.raises(ParameterError, match="block"):
        circular_block_resample([1.0, 2.0], 3, block=0, rng=np.random.default_rng(0))
    with pytest.raises(ParameterError, match="rng"):
        circular_block_resample([1.0, 2.0], 3, block=1, rng=0)


def test_politis_white_block_of_ar1_matches_the_analytic_optimum():
    # AR(1) with coefficient phi: G/g = 2 phi/(1 - phi^2), D = 4/3 g^2, so b = (1.5 (G/g)^2)^(1/3) n^(1/3)
    # (Politis & White 2004 with the circular constant of Patton, Politis & White 2009); mean of 4 seeds
    n, phi = 20_000, 0.8
    b_true = (1.5 * (2 * phi / (1 - phi**2)) ** 2) ** (1 / 3) * n ** (1 / 3)
    b = np.mean([politis_white_block(_ar1(phi, n, s)) for s in range(4)])
    assert b == pytest.approx(b_true, rel=0.1)
    assert politis_white_block(np.random.default_rng(5).normal(size=n)) <= 3  # white: (almost) no blocks
    with pytest.raises(SignalError):
        politis_white_block([1.0, 2.0, 3.0])


def test_bootstrap_se_of_ols_on_white_residuals_matches_the_analytic_se():
    rng = np.random.default_rng(11)
    m = 400
    X = np.c_[np.ones(m), rng.normal(size=m), rng.uniform(-1, 1, size=m)]
    y = X @ np.array([1.0, -2.0, 0.5]) + 0.3 * rng.normal(size=m)
    beta, *_ = np.linalg.lstsq(X, y, rcond=None)
    res = y - X @ beta
    # OLS standard error with s^2 = RSS/m (the residual bootstrap's variance; Efron & Tibshirani Sec. 9.5)
    se_ols = np.sqrt(np.diag(float(res @ res) / m * np.linalg.inv(X.T @ X)))
    pinv = np.linalg.pinv(X)
    b = residual_block_bootstrap(lambda ys: pinv @ ys, X @ beta, res, beta,
                                 settings=BootstrapSettings(n=4000, block=1, seed=2))
    assert b.n_valid == 4000 and b.block == 1
    np.testing.assert_allclose(b.stderr, se_ols, rtol=0.04)
    np.testing.assert_allclose(b.bias, 0.0, atol=0.1 * se_ols.max())


def test_block_bootstrap_keeps_the_colour_of_ar1_residuals():
    # the mean of AR(1) noise: long-run variance sigma^2/(1 - phi)^2, var(mean) = that / m
    m, phi = 20_000, 0.8
    e = _ar1(phi, m, 9)
    se_true = 1.0 / (1 - phi) / math.sqrt(m)
    b = residual_block_bootstrap(np.mean, np.zeros(m), e, [0.0], settings=BootstrapSettings(n=400, seed=0))
    assert b.stderr[0] == pytest.approx(se_true, rel=0.2)
    white = residual_block_bootstrap(np.mean, np.zeros(m), e, [0.0],
                                     settings=BootstrapSettings(n=400, block=1, seed=0))
    assert white.stderr[0] < 0.5 * se_true  # i.i.d. resampling loses the colour: far too small


def test_friction_band_contains_the_fitted_curve_and_is_the_rms_of_the_replicates():
    est = np.array([5.0, 7.0, 8.0])
    reps = est + np.random.default_rng(0).normal(scale=[0.1, 0.3, 0.2], size=(50, 3))
    band = friction_band(est, reps, w_max=0.5, Vs=0.02, delta=1.0, points=11)
    np.testing.assert_allclose(band.F, stribeck(band.w, Fc=5.0, Fs=7.0, Vs=0.02, delta=1.0, sigma=8.0), rtol=1e-12)
    assert np.all(band.lower <= band.F) and np.all(band.F <= band.upper)
    # independent: the half-width at w = 0.5 from the replicates' curves, t quantile with 50 degrees of freedom
    from scipy.stats import t as student_t

    curves = [stribeck(0.5, Fc=a, Fs=b, Vs=0.02, delta=1.0, sigma=c) for a, b, c in reps]
    half = student_t.ppf(0.975, 50) * math.sqrt(np.mean((np.array(curves) - band.F[-1]) ** 2))
    assert band.upper[-1] - band.F[-1] == pytest.approx(half, rel=1e-9)
    assert band.w[5] == 0.0 and band.width[5] == 0.0  # F(0) = 0 for every replicate
    cv = friction_curves([[5.0, 99.0, 8.0]], [-0.1, 0.1], Vs=None, delta=None)  # Coulomb: Fs ignored
    np.testing.assert_allclose(cv[0], [-5.8, 5.8])
    with pytest.raises(ParameterError, match="w_max"):
        friction_band(est, reps, w_max=0.0, Vs=0.02, delta=1.0)


def _record(duration: float, seed: int = 0) -> MeasuredData:
    rng = np.random.default_rng(seed)
    dt = 1e-3
    _, u = bandlimited_noise(duration, dt=dt, std=8.0, cutoff=1.0, rng=rng)
    m = sample(simulate(P, u, dt=dt), Ts=dt, noise_std=2e-4, rng=np.random.default_rng(seed + 100))
    return MeasuredData(m.t, m.u, m.w, source=f"simulated {duration:g} s")


@pytest.fixture(scope="module")
def reports():
    return {d: identify(_record(d), method="paper") for d in (4.0, 16.0)}


def test_identify_reports_the_bootstrap_and_keeps_the_delta_method(reports):
    rep = reports[16.0]
    u = rep.uncertainty
    assert isinstance(u, ParameterUncertainty) and rep.stderr_kind == "residual block bootstrap"
    assert rep.stderr == u.stderr and set(u.stderr) == {"J", "sigma", "Fc", "offset"}
    from adaptive_ff.identification.covariance import bootstrap_t_quantile

    t = bootstrap_t_quantile(u.n_valid, 0.95)
    for k, (lo, hi) in rep.interval95.items():
        assert lo == pytest.approx(rep.params[k] - t * rep.stderr[k], rel=1e-12)
        assert hi == pytest.approx(rep.params[k] + t * rep.stderr[k], rel=1e-12)
    d = rep.to_dict()
    assert d["std"] == pytest.approx(u.stderr) and d["std_delta"] == pytest.approx(rep.std)
    assert d["std_kind"] == "residual block bootstrap" and d["uncertainty"]["n_valid"] == u.n_valid == 200
    text = rep.summary()
    assert "95 % intervals: J [" in text and f"{rep.stderr['Fc']:>13.3g}" in text and "std_delta" in text
    none = identify(_record(4.0), method_options={"n_bootstrap": 0}, method="paper")
    assert none.uncertainty is None and none.stderr == none.std and none.band is None
    same = identify(_record(16.0), method_options={"bootstrap_seed": 0}, method="paper")
    assert same.stderr == rep.stderr  # seeded: the same errors


def test_identify_bootstrap_options_are_checked():
    data = _record(4.0)
    for bad in (1, -2, 2.5, True):
        with pytest.raises(ParameterError, match="n_bootstrap"):
            identify(data, method_options={"n_bootstrap": bad}, method="paper")
    with pytest.raises(ParameterError, match="bootstrap_seed"):
        identify(data, method_options={"bootstrap_seed": -1}, method="paper")
    with pytest.raises(ParameterError, match="takes the options"):
        identify(data, method_options={"inverse": "printed"}, method="paper")


def test_band_contains_the_fitted_curve_and_shrinks_with_more_data(reports):
    short, long = reports[4.0].band, reports[16.0].band
    assert isinstance(long, FrictionBand) and long.level == 0.95
    e = reports[16.0].estimate
    np.testing.assert_allclose(long.F, e.friction(long.w) - e.offset, rtol=1e-9, atol=1e-12)
    assert np.all(long.lower <= long.F) and np.all(long.F <= long.upper)
    # a 4 times longer record: about half the width (1/sqrt(4)); the same speed range, compared pointwise
    assert np.median(long.width[long.w != 0]) < 0.75 * np.median(short.width[short.w != 0])


def test_report_to_dict_is_strict_json_with_the_band(reports):
    rep = reports[16.0]
    d = rep.to_dict()
    s = json.dumps(d, allow_nan=False)
    back = json.loads(s)
    assert len(back["band"]["w"]) == len(back["band"]["lower"]) == len(back["band"]["upper"]) == 101
    assert back["interval95"]["Fc"] == [pytest.approx(v) for v in rep.interval95["Fc"]]
    nan = ParameterUncertainty(kind="x", stderr={"J": math.nan}, interval={"J": (math.nan, math.inf)}, level=0.95,
                               n=2, n_valid=0, block=1, seed=0)
    assert json.loads(json.dumps(nan.to_dict(), allow_nan=False))["stderr"]["J"] is None


def test_plot_draws_the_band_beside_the_rls_convergence(reports):
    rep = reports[16.0]
    ax = rep.plot()
    assert len(ax.figure.axes) == 2
    bx = ax.figure.axes[1]
    assert len(bx.collections) == 1 and bx.lines[0].get_label() == "F(w) fitted"
    np.testing.assert_allclose(bx.lines[0].get_ydata(), rep.band.F)
    assert [ln.get_label() for ln in ax.lines if not ln.get_label().startswith("_")] == list(rep.model.names)


def test_output_error_fit_reports_interval_and_band_of_its_bootstrap():
    from adaptive_ff.identification.covariance import bootstrap_t_quantile
    from adaptive_ff.identification.physical_id import fit_physical
    from plant import preset

    p = preset("paper")
    rng = np.random.default_rng(4)
    _, u = bandlimited_noise(8.0, dt=1e-3, cutoff=1.0, std=1.2 * (p.Fs + p.sigma * 0.35), rng=rng)
    resp = simulate(p, u, dt=1e-3)
    m = sample(resp, Ts=0.01, noise_std=0.01 * float(np.max(np.abs(resp.w))), rng=np.random.default_rng(5))
    f = fit_physical(m.t, m.u, m.w, Vs=p.Vs, delta=p.delta, n_bootstrap=4, input_delay=5e-4)
    boot = f.info["bootstrap"]
    n, bias, rms = boot["n_valid"], boot["bias"], boot["stderr_refits"]
    for k, (lo, hi) in f.info["interval95"].items():  # centred on the estimate with the refits' RMS deviation where
        # their mean shift is at most a quarter of it (Efron & Tibshirani 1993, Sec. 10.6), t of n refits; else on
        # the estimate less the shift with the refits' sample deviation about their mean times sqrt(1 + 1/n), t of
        # n - 1 (the prediction interval of a normal sample)
        c, se, t = f.params[k], rms[k], bootstrap_t_quantile(n, 0.95)
        if abs(bias[k]) > 0.25 * rms[k]:
            c, se = f.params[k] - bias[k], math.sqrt((rms[k] ** 2 - bias[k] ** 2) * (n + 1) / (n - 1))
            t = bootstrap_t_quantile(n - 1, 0.95)
        assert f.stderr[k] == pytest.approx(se, rel=1e-12)
        assert lo == pytest.approx(c - t * se, rel=1e-12, abs=1e-15)
        assert hi == pytest.approx(c + t * se, rel=1e-12, abs=1e-15)
    band = f.info["band"]
    F = stribeck(np.array(band["w"]), Fc=f.params["Fc"], Fs=f.params["Fs"], Vs=p.Vs, delta=p.delta,
                 sigma=f.params["sigma"])
    np.testing.assert_allclose(band["F"], F, rtol=1e-12)
    assert np.all(np.array(band["lower"]) <= F) and np.all(F <= np.array(band["upper"]))
    assert band["n_replicates"] == n
    json.dumps(f.to_dict(), allow_nan=False)


def test_residual_bootstrap_resamples_by_the_scheme_of_its_settings():
    res, fitted = np.cos(np.arange(40.0)), np.zeros(40)
    # circular (default): the replicates are fitted + circular_block_resample, drawn in turn from default_rng(seed)
    b = residual_block_bootstrap(lambda ys: [ys.mean()], fitted, res, [0.0],
                                 settings=BootstrapSettings(n=5, block=4, seed=1))
    rng = np.random.default_rng(1)
    expected = [circular_block_resample(res, 40, block=4, rng=rng).mean() for _ in range(5)]
    assert b.replicates[:, 0].tolist() == expected and b.block == 4
    # wild: each residual kept in place with one sign per block, so the mean square is the residuals' own
    wild = residual_block_bootstrap(lambda ys: [np.mean(ys**2)], fitted, res, [0.0],
                                    settings=BootstrapSettings(n=5, block=4, seed=1, scheme="wild"))
    np.testing.assert_allclose(wild.replicates[:, 0], np.mean(res**2), rtol=1e-12)
    with pytest.raises(ParameterError, match="settings must be a BootstrapSettings"):
        residual_block_bootstrap(np.mean, fitted, res, [0.0], settings={"n": 5})
