"""adaptive_ff.identification.covariance: Newey-West sandwich, Andrews bandwidth, moving-block resampling."""

import math

import numpy as np
import pytest

from adaptive_ff.identification.covariance import (BootstrapResult, andrews_bandwidth, bootstrap_t_quantile,
                                                     block_wild_resample, hac_covariance, moving_block_resample,
                                                     parametric_block_bootstrap, BootstrapSettings)
from plant.errors import ExcitationError, ParameterError, SignalError


def _sandwich(G, r, L):
    """Independent Newey-West: explicit double loop over lags and samples (Newey & West 1987, eq. 2)."""
    n, p = G.shape
    S = np.zeros((p, p))
    for lag in range(-L, L + 1):
        wgt = 1.0 - abs(lag) / (L + 1.0)
        for t in range(n):
            s = t - lag
            if 0 <= s < n:
                S += wgt * r[t] * r[s] * np.outer(G[t], G[s])
    A = np.linalg.inv(G.T @ G)
    return A @ S @ A * n / (n - p)


@pytest.mark.parametrize("L", [0, 1, 4])
def test_hac_equals_the_explicit_sum(L):
    rng = np.random.default_rng(7)
    G = rng.normal(size=(60, 3))
    r = np.convolve(rng.normal(size=64), [1.0, 0.6, 0.3], mode="valid")[:60]
    cov, lags = hac_covariance(G, r, lags=L)
    assert lags == L
    np.testing.assert_allclose(cov, _sandwich(G, r, L), rtol=1e-12, atol=0)


def test_hac_of_one_column_and_white_residuals_is_whites_formula():
    # p = 1, lags = 0: var = sum(g^2 r^2) / (sum g^2)^2 * n/(n-1) (White 1980)
    g = np.array([1.0, 2.0, -1.0, 0.5])
    r = np.array([0.1, -0.2, 0.3, 0.05])
    cov, _ = hac_covariance(g[:, None], r, lags=0)
    assert cov[0, 0] == pytest.approx(np.sum(g**2 * r**2) / np.sum(g**2) ** 2 * 4 / 3, rel=1e-14)


def test_andrews_bandwidth_follows_the_ar1_rule():
    rng = np.random.default_rng(1)
    e = rng.normal(size=20000)
    r = np.empty_like(e)
    r[0] = e[0]
    for k in range(1, e.size):
        r[k] = 0.8 * r[k - 1] + e[k]
    rc = r - r.mean()
    rho = float(rc[1:] @ rc[:-1] / (rc @ rc))
    assert rho == pytest.approx(0.8, abs=0.02)
    alpha = 4 * rho**2 / (1 - rho) ** 4
    assert andrews_bandwidth(r) == math.ceil(1.1447 * (alpha * r.size) ** (1 / 3))
    assert andrews_bandwidth(-np.ones(5) * np.array([1, -1, 1, -1, 1])) == 0  # negative rho clipped to 0


def test_moving_blocks_are_contiguous_runs_of_the_residuals():
    r = np.arange(100.0)
    out = moving_block_resample(r, 95, block=10, rng=np.random.default_rng(3))
    assert out.shape == (95,)
    full = out[:90].reshape(9, 10)  # 95 = 9.5 blocks of 10
    assert np.all(np.diff(full, axis=1) == 1.0)  # each block is r[s:s+10]
    assert np.all((full[:, 0] >= 0) & (full[:, 0] <= 90))
    assert np.all(out[90:] == np.arange(out[90], out[90] + 5))  # the last block cut to 5
    # same seed, same series; block = n: the record itself; block = 1: values of r only
    again = moving_block_resample(r, 95, block=10, rng=np.random.default_rng(3))
    np.testing.assert_array_equal(out, again)
    np.testing.assert_array_equal(moving_block_resample(r, 100, block=500, rng=np.random.default_rng(0)), r)
    iid = moving_block_resample(r, 1000, block=1, rng=np.random.default_rng(0))
    assert set(iid) <= set(r) and len(set(iid)) > 90


def test_moving_blocks_keep_the_lag_one_correlation():
    # an AR(1) series with rho = 0.9: blocks of 50 keep rho (up to the 1/50 of pairs across block joints)
    rng = np.random.default_rng(5)
    e = rng.normal(size=5000)
    r = np.empty_like(e)
    r[0] = e[0]
    for k in range(1, e.size):
        r[k] = 0.9 * r[k - 1] + e[k]
    out = moving_block_resample(r, 5000, block=50, rng=np.random.default_rng(6))
    oc = out - out.mean()
    assert float(oc[1:] @ oc[:-1] / (oc @ oc)) == pytest.approx(0.9, abs=0.04)
    iid = moving_block_resample(r, 5000, block=1, rng=np.random.default_rng(6))
    ic = iid - iid.mean()
    assert abs(float(ic[1:] @ ic[:-1] / (ic @ ic))) < 0.05


@pytest.mark.parametrize("kwargs, err, match", [
    ({"r": []}, SignalError, "residuals"),
    ({"r": [1.0, np.nan]}, SignalError, "residuals"),
    ({"n_out": 0}, ParameterError, "n_out"),
    ({"block": 0}, ParameterError, "block"),
    ({"block": True}, ParameterError, "block"),
    ({"rng": 3}, ParameterError, "rng"),
])
def test_moving_block_bad_input(kwargs, err, match):
    args = {"r": [1.0, 2.0, 3.0], "n_out": 5, "block": 2, "rng": np.random.default_rng(0), **kwargs}
    r = args.pop("r")
    n_out = args.pop("n_out")
    with pytest.raises(err, match=match):
        moving_block_resample(r, n_out, **args)


def test_moving_blocks_of_two_channels_keep_rows_together():
    r = np.column_stack([np.arange(50.0), -np.arange(50.0)])
    out = moving_block_resample(r, 47, block=5, rng=np.random.default_rng(2))
    assert out.shape == (47, 2)
    np.testing.assert_array_equal(out[:, 1], -out[:, 0])  # the same blocks for both channels
    assert np.all(np.diff(out[:45, 0].reshape(9, 5), axis=1) == 1.0)


def _ar1(n, rho, rng):
    e = rng.normal(size=n)
    r = np.empty(n)
    r[0] = e[0] / math.sqrt(1.0 - rho**2)
    for k in range(1, n):
        r[k] = rho * r[k - 1] + e[k]
    return r


def _moving(**kw) -> BootstrapSettings:
    """Bootstrap settings with moving blocks."""
    return BootstrapSettings(scheme="moving", **kw)


def test_parametric_block_bootstrap_matches_the_spread_over_seeds():
    # a straight line in AR(1) noise (rho 0.5), fitted by OLS: the spread of the OLS estimates over 100 seeded
    # records (computed here) against the bootstrap errors of 6 other records (blocks of 3 Andrews bandwidths);
    # the white-noise OLS formula is sqrt((1 - rho)/(1 + rho)) = 0.58 times too small
    n, rho = 2000, 0.5
    t = np.linspace(0.0, 1.0, n)
    A = np.column_stack([np.ones(n), t])

    def ols(y):
        return np.linalg.lstsq(A, y, rcond=None)[0]

    truth = np.array([1.0, 2.0])
    fits = np.array([ols(A @ truth + _ar1(n, rho, np.random.default_rng(s))) for s in range(100)])
    spread = fits.std(axis=0, ddof=1)
    ratios, white = [], []
    for s in range(6):
        y = A @ truth + _ar1(n, rho, np.random.default_rng(1000 + s))
        x = ols(y)
        res = y - A @ x
        b = parametric_block_bootstrap(lambda ys, rng: ols(ys), A @ x, res, x, settings=_moving(
            n=200, block=3 * (andrews_bandwidth(res) + 1), seed=s))
        assert b.n == 200 and b.n_valid == 200 and b.failures == () and b.replicates.shape == (200, 2)
        ratios.append(b.stderr / spread)
        s2 = res @ res / (n - 2)
        white.append(np.sqrt(np.diag(s2 * np.linalg.inv(A.T @ A))) / spread)
    ratios = np.array(ratios)
    assert np.all(ratios > 0.5) and np.all(ratios < 2.0), ratios  # each record within a factor 2
    assert 0.75 < ratios.mean() < 1.25, ratios  # and right on average (measured 0.64-1.14, mean 0.93)
    assert np.all(np.array(white) < 0.7)  # what the bootstrap is for


def test_parametric_block_bootstrap_counts_failed_refits_and_is_seeded():
    pred, res = np.zeros(30), np.sin(np.arange(30.0))
    calls = []

    def refit(y, rng):
        calls.append(1)
        if len(calls) == 2:
            raise ExcitationError("no reversal in this replicate")
        if len(calls) == 3:
            return np.array([np.nan])
        return np.array([y.mean() + rng.normal()])

    b = parametric_block_bootstrap(refit, pred, res, [0.0], settings=_moving(n=6, block=4, seed=1))
    assert b.n_valid == 4 and len(b.failures) == 2
    assert b.failures[0].startswith("ExcitationError: no reversal") and b.failures[1] == "non-finite"
    assert b.stderr[0] == pytest.approx(math.sqrt(np.mean(b.replicates[:, 0] ** 2)))
    assert b.bias[0] == pytest.approx(np.mean(b.replicates[:, 0]))
    calls.clear()
    again = parametric_block_bootstrap(refit, pred, res, [0.0], settings=_moving(n=6, block=4, seed=1))
    np.testing.assert_array_equal(again.replicates, b.replicates)
    # fewer than two valid refits: NaN errors, not a crash
    few = parametric_block_bootstrap(lambda y, rng: [np.inf], pred, res, [0.0], settings=_moving(n=3, block=4, seed=0))
    assert few.n_valid == 0 and math.isnan(few.stderr[0]) and len(few.failures) == 3


def test_parametric_block_bootstrap_threads_give_the_one_thread_result():
    # each refit gets a generator of its own, seeded after every replicate is drawn: the refits' order of
    # completion cannot change a draw; failures keep the replicates' order
    pred, res = np.zeros(40), np.cos(np.arange(40.0))

    def refit(y, rng):
        if y[0] > 0.9:  # the replicates whose first block keeps its sign
            raise ExcitationError("first sample high")
        return np.array([y.mean() + rng.normal(), np.mean(y**2)])

    wild = BootstrapSettings(n=25, block=3, seed=4, scheme="wild")
    runs = [parametric_block_bootstrap(refit, pred, res, [0.0, 0.0], workers=k, settings=wild) for k in (1, 4)]
    np.testing.assert_array_equal(runs[0].replicates, runs[1].replicates)
    assert runs[0].failures == runs[1].failures and 0 < len(runs[0].failures) < 25
    assert runs[0].stderr.tolist() == runs[1].stderr.tolist()
    # each refit sees a whole replicate: the residuals in place, one sign per block (mean square unchanged)
    assert np.allclose(runs[0].replicates[:, 1], np.mean(res**2), rtol=1e-12)


def test_parametric_block_bootstrap_progress_bar_counts_the_refits_and_changes_nothing(capsys, monkeypatch):
    import tqdm.auto

    pred, res = np.zeros(40), np.cos(np.arange(40.0))

    def refit(y, rng):
        return np.array([y.mean() + rng.normal()])

    quiet = parametric_block_bootstrap(refit, pred, res, [0.0], settings=_moving(n=7, block=3, seed=4))
    assert capsys.readouterr().err == ""  # the default draws no bar
    shown = parametric_block_bootstrap(refit, pred, res, [0.0], settings=_moving(n=7, block=3, seed=4),
                                       workers=2, progress=True)
    assert "bootstrap refits" in capsys.readouterr().err
    np.testing.assert_array_equal(quiet.replicates, shown.replicates)
    bars = []

    class Recorder(tqdm.auto.tqdm):  # the bar's own count after the run: one update per refit
        def __init__(self, *a, **k):
            super().__init__(*a, **k)
            bars.append(self)

    monkeypatch.setattr(tqdm.auto, "tqdm", Recorder)
    parametric_block_bootstrap(refit, pred, res, [0.0], settings=_moving(n=7, block=3, seed=4), workers=3,
                               progress=True)
    assert len(bars) == 1 and bars[0].n == bars[0].total == 7


@pytest.mark.parametrize("kwargs, err, match", [
    ({"prediction": np.zeros(5)}, SignalError, "prediction"),
    ({"estimate": [np.nan]}, SignalError, "estimate"),
    ({"settings": {"n": 0}}, ParameterError, "n must"),
    ({"settings": {"n": 2.0}}, ParameterError, "n must"),
    ({"settings": {"block": 0}}, ParameterError, "block"),
    ({"settings": {"block": None}}, ParameterError, "block length"),
    ({"settings": {"seed": -1}}, ParameterError, "seed must"),
    ({"settings": {"scheme": "stationary"}}, ParameterError, "scheme must"),
    ({"refit": None}, ParameterError, "refit"),
    ({"simulate": 3.0}, ParameterError, "simulate must be callable"),
    ({"workers": 0}, ParameterError, "workers"),
    ({"workers": 2.0}, ParameterError, "workers"),
    ({"progress": 1}, ParameterError, "progress"),
    ({"simulate": lambda rng: np.zeros(9)}, ParameterError, r"simulate must return an array of shape \(10,\)"),
])
def test_parametric_block_bootstrap_bad_input(kwargs, err, match):
    kwargs = dict(kwargs)
    settings = {"n": 2, "block": 2, "seed": 0, **kwargs.pop("settings", {})}
    args = {"refit": lambda y, rng: [0.0], "prediction": np.zeros(10), "residuals": np.ones(10), "estimate": [0.0],
            **kwargs}
    with pytest.raises(err, match=match):
        parametric_block_bootstrap(args.pop("refit"), args.pop("prediction"), args.pop("residuals"),
                                   args.pop("estimate"), settings=BootstrapSettings(**settings), **args)
    with pytest.raises(ParameterError, match="settings must be a BootstrapSettings"):
        parametric_block_bootstrap(lambda y, rng: [0.0], np.zeros(10), np.ones(10), [0.0], settings={"n": 2})


def test_t_quantile_is_students_in_closed_form():
    # t_1 is Cauchy: tan(pi (p - 1/2)); t_2: (2p - 1) / sqrt(2 p (1 - p)); t_inf the normal 1.959964
    assert bootstrap_t_quantile(1) == pytest.approx(math.tan(math.pi * 0.475), rel=1e-10)
    assert bootstrap_t_quantile(2) == pytest.approx(0.95 / math.sqrt(2 * 0.975 * 0.025), rel=1e-10)
    assert bootstrap_t_quantile(2, 0.5) == pytest.approx(0.5 / math.sqrt(2 * 0.75 * 0.25), rel=1e-10)
    assert bootstrap_t_quantile(10**7) == pytest.approx(1.959963984540054, rel=1e-6)
    for bad in ({"n": 0}, {"n": 2.0}, {"n": True}, {"n": 3, "level": 1.0}, {"n": 3, "level": 0.0},
                {"n": 3, "level": "0.9"}, {"n": 3, "level": math.nan}):
        with pytest.raises(ParameterError):
            bootstrap_t_quantile(**bad)


def test_t_interval_of_few_refits_covers_95_percent_and_z_does_not():
    # the estimate's error and each of n refit deviations i.i.d. N(0, 1) (an exact bootstrap): e <= t s holds in
    # 95 % of 40000 seeded trials (Monte-Carlo sd 0.1 %); 1.96 s covers 90.2 % with 6 refits
    rng = np.random.default_rng(11)
    for n, z_cover in ((6, 0.902), (10, 0.922)):
        e = np.abs(rng.standard_normal(40000))
        s = np.sqrt(np.mean(rng.standard_normal((40000, n)) ** 2, axis=1))
        assert np.mean(e <= bootstrap_t_quantile(n) * s) == pytest.approx(0.95, abs=0.005)
        assert np.mean(e <= 1.959964 * s) == pytest.approx(z_cover, abs=0.006)
    b = BootstrapResult(stderr=np.array([2.0, math.nan]), bias=np.zeros(2), replicates=np.zeros((4, 2)), n=5,
                        block=3)
    np.testing.assert_allclose(b.half_width()[0], 2.0 * 2.7764451051977934, rtol=1e-12)
    assert math.isnan(b.half_width()[1])
    none = BootstrapResult(stderr=np.full(1, math.nan), bias=np.zeros(1), replicates=np.zeros((0, 1)), n=2, block=1)
    assert math.isnan(none.half_width()[0])


def test_simulate_sees_process_noise_the_fit_absorbs():
    # y_t = theta + c + e_t with a record-level random offset c ~ N(0, 1) (process noise) and white e_t (sd 1),
    # fitted by the mean: c goes into the estimate, not the residuals. sd of the estimate sqrt(1 + 1/n) = 1.0012;
    # the residual bootstrap sees only 1/sqrt(n) = 0.05, with simulate drawing c afresh it sees the whole
    n, theta = 400, 3.0
    rng = np.random.default_rng(5)
    y = theta + rng.standard_normal() + rng.standard_normal(n)
    est = np.array([y.mean()])
    res, pred = y - est[0], np.full(n, est[0])

    def refit(ys, rng):
        return [ys.mean()]

    plain = parametric_block_bootstrap(refit, pred, res, est, settings=_moving(n=300, block=1, seed=1))
    fresh = parametric_block_bootstrap(refit, pred, res, est, settings=_moving(n=300, block=1, seed=1),
                                       simulate=lambda rng: est[0] + rng.standard_normal() + np.zeros(n))
    assert plain.stderr[0] == pytest.approx(1.0 / math.sqrt(n), rel=0.15)
    assert fresh.stderr[0] == pytest.approx(math.sqrt(1.0 + 1.0 / n), rel=0.15)  # 300 refits: sd of s 4 %
    # a non-finite draw drops its replicate with the reason
    draws = iter([np.full(n, np.nan)] + [pred] * 3)
    b = parametric_block_bootstrap(refit, pred, res, est, settings=_moving(n=4, block=1, seed=2),
                                   simulate=lambda rng: next(draws))
    assert b.n_valid == 3 and b.failures == ("non-finite simulation",)


def test_block_wild_keeps_each_residual_in_place_with_one_sign_per_block():
    r = np.arange(1.0, 24.0) * np.where(np.arange(23) % 3 == 0, -1.0, 1.0)
    e = block_wild_resample(r, 23, block=5, rng=np.random.default_rng(3))
    s = e / r
    assert np.all(np.abs(s) == 1.0)  # every residual at its own instant, its size kept
    # the signs change only at block boundaries: the runs of equal signs, cut at the boundaries of some phase
    # in 0..4, are constant
    ok = []
    for ph in range(5):
        k = (np.arange(23) + ph) // 5
        ok.append(all(np.unique(s[k == j]).size == 1 for j in np.unique(k)))
    assert any(ok)
    # two channels share the sign of their row; n_out cuts the series
    e2 = block_wild_resample(np.column_stack([r, 2 * r]), 20, block=5, rng=np.random.default_rng(3))
    np.testing.assert_array_equal(e2[:, 0], e[:20])
    np.testing.assert_array_equal(e2[:, 1], 2 * e[:20])


def test_block_wild_bad_input():
    with pytest.raises(ParameterError, match="n_out"):
        block_wild_resample(np.ones(5), 6, block=2, rng=np.random.default_rng(0))
    with pytest.raises(ParameterError, match="block"):
        block_wild_resample(np.ones(5), 5, block=0, rng=np.random.default_rng(0))
    with pytest.raises(SignalError):
        block_wild_resample(np.array([1.0, np.nan]), 2, block=1, rng=np.random.default_rng(0))


def test_wild_bootstrap_of_ols_gives_whites_heteroscedastic_errors():
    # white, heteroscedastic residuals (large where |x| is large): the wild bootstrap with block 1 and an OLS refit
    # has the covariance of White (1980) over the signs, exactly (X^T X)^-1 X^T diag(r^2) X (X^T X)^-1; the
    # moving-block (here i.i.d.) bootstrap moves the large residuals to small |x| and gives the homoscedastic
    # s^2 (X^T X)^-1 instead
    rng = np.random.default_rng(11)
    n = 200
    x = np.linspace(-1.0, 1.0, n)
    X = np.column_stack([np.ones(n), x])
    y = 1.0 + 2.0 * x + rng.normal(size=n) * (0.05 + 2.0 * x**2)
    beta = np.linalg.lstsq(X, y, rcond=None)[0]
    r = y - X @ beta
    A = np.linalg.inv(X.T @ X)
    white = np.sqrt(np.diag(A @ (X.T * r**2) @ X @ A))
    homo = np.sqrt(np.diag(A) * (r @ r) / n)

    def refit(ys, _rng):
        return np.linalg.lstsq(X, ys, rcond=None)[0]

    wild = BootstrapSettings(n=4000, block=1, seed=5, scheme="wild")
    b = parametric_block_bootstrap(refit, X @ beta, r, beta, settings=wild)
    np.testing.assert_allclose(b.stderr, white, rtol=0.04)
    m = parametric_block_bootstrap(refit, X @ beta, r, beta, settings=_moving(n=4000, block=1, seed=5))
    np.testing.assert_allclose(m.stderr, homo, rtol=0.04)
    assert b.stderr[1] > 1.3 * m.stderr[1]  # the slope's error is larger under the heteroscedasticity
    with pytest.raises(ParameterError, match="scheme"):
        BootstrapSettings(n=2, block=1, seed=5, scheme="stationary")


def _interval_by_refits(estimate: np.ndarray, refits: np.ndarray, extra: float = 0.0):
    """``bias_corrected_interval`` fed from a draw of refits: their mean shift and RMS deviation from the estimate."""
    from adaptive_ff.identification.covariance import bias_corrected_interval

    d = refits - estimate
    return bias_corrected_interval(float(estimate), float(np.mean(d)), float(np.sqrt(np.mean(d * d))), extra,
                                   refits.shape[0])


def test_bias_corrected_interval_covers_at_its_level_where_the_estimator_is_biased():
    """A biased estimator (shift 1.5 of its standard deviation) whose 20 refits sample its error's distribution: the
    interval less the refits' shift covers the truth 95 % of the time (the normal sample's prediction interval,
    Student-t with n - 1 degrees of freedom), where the refits' RMS deviation as its width over-covers (nearly always)."""
    rng = np.random.default_rng(20)
    n, trials, shift = 20, 4000, 1.5
    hits, hits_rms = 0, 0
    for _ in range(trials):
        est = shift + rng.normal()  # the truth is 0
        refits = est + shift + rng.normal(size=n)  # the bootstrap world: the same error, from the estimate
        c, se, t = _interval_by_refits(np.float64(est), refits)
        hits += abs(c) <= t * se
        d = refits - est
        hits_rms += abs(c) <= bootstrap_t_quantile(n) * math.sqrt(np.mean(d * d))
    assert 0.94 <= hits / trials <= 0.96  # binomial standard error 0.0034
    assert hits_rms / trials > 0.99


def test_bias_corrected_interval_forms():
    from scipy.stats import t as student_t

    from adaptive_ff.identification.covariance import bias_corrected_interval

    # a shift below a quarter of the standard error: centred on the estimate, the RMS with the extra share, t_n
    c, se, t = bias_corrected_interval(10.0, 0.2, 1.0, 0.5, 20)
    assert (c, se) == (10.0, pytest.approx(math.sqrt(1.25), rel=1e-15))
    assert t == pytest.approx(student_t.ppf(0.975, 20), rel=1e-12)
    # a larger shift: centre less the shift, the sample variance about the refits' mean times 1 + 1/n, t_{n-1}
    c, se, t = bias_corrected_interval(10.0, 0.6, 1.0, 0.5, 20)
    s2 = (1.0 - 0.36) * 20 / 19
    assert c == pytest.approx(9.4, rel=1e-15) and se == pytest.approx(math.sqrt(s2 * 21 / 20 + 0.25), rel=1e-14)
    assert t == pytest.approx(student_t.ppf(0.975, 19), rel=1e-12)
    with pytest.raises(ParameterError, match="n must be an integer >= 2"):
        bias_corrected_interval(1.0, 0.0, 1.0, 0.0, 1)
