"""Tests of adaptive_ff.identification.stribeck_fit: Levenberg-Marquardt fit of the Stribeck map (eq. 3), paper Sec. V-C."""

import json
import warnings

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest
from scipy.stats import t as student_t

from adaptive_ff.identification.stribeck_fit import PARAM_NAMES, StribeckFit, fit_stribeck, plot_stribeck_fit
from plant.errors import ExcitationError, ParameterError, SignalError
from plant.friction import preset, stribeck

PAPER = {k: getattr(preset("paper"), k) for k in PARAM_NAMES}  # Fc=25, Fs=35, Vs=0.02, delta=1, sigma=40
NOISE = 0.3  # N·m, standard deviation of the torque noise in the noisy tests
SEEDS = range(40)


def bidirectional(lo=0.002, hi=0.5, n=20):
    """Velocities (rad/s) of bidirectional quasi-static runs, log-spaced in |w|, shape (2n,)."""
    v = np.geomspace(lo, hi, n)
    return np.concatenate([-v[::-1], v])


def rel_err(fit, true):
    return {k: abs(getattr(fit, k) - true[k]) / abs(true[k]) for k in PARAM_NAMES}


def fd_jacobian(w, p, h=1e-6):
    """dF/d(Fc, Fs, Vs, delta, sigma) by central differences of plant.friction.stribeck (independent)."""
    cols = []
    for k in PARAM_NAMES:
        step = h * max(abs(p[k]), 1e-3)
        up, dn = dict(p), dict(p)
        up[k] += step
        dn[k] -= step
        cols.append((stribeck(w, **up) - stribeck(w, **dn)) / (2 * step))
    return np.column_stack(cols)


# --------------------------------------------------------------------------- noise-free recovery


def test_noise_free_paper_preset_recovered_to_1e_6():
    w = bidirectional()
    fit = fit_stribeck(w, stribeck(w, **PAPER))
    assert isinstance(fit, StribeckFit)
    assert fit.converged
    assert fit.n_points == w.size
    for k, e in rel_err(fit, PAPER).items():
        assert e < 1e-6, (k, getattr(fit, k))
    assert fit.residual_rms < 1e-9 * PAPER["Fc"]
    # the fitted curve is eq. 3 with the fitted parameters
    wq = np.linspace(-0.6, 0.6, 101)
    np.testing.assert_allclose(fit.friction(wq), stribeck(wq, **PAPER), rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize("delta", [-1.0, -0.5, -2.0])
def test_negative_delta_plant_recovered_with_default_starts(delta):
    # delta < 0: friction rises from Fc at standstill to Fs at high speed
    true = dict(PAPER, delta=delta)
    w = bidirectional()
    F = stribeck(w, **true)
    level = (F - true["sigma"] * w)[w > 0]
    assert np.all(np.diff(level) >= 0) and true["Fc"] - 1e-9 < level[0] < level[-1] < true["Fs"]  # sanity
    fit = fit_stribeck(w, F)  # default delta_starts are all positive
    assert fit.delta < 0
    for k, e in rel_err(fit, true).items():
        assert e < 1e-6, (k, getattr(fit, k))


@pytest.mark.parametrize("delta", [0.5, 2.0])
def test_other_positive_shapes_recovered(delta):
    true = dict(PAPER, delta=delta)
    w = bidirectional()
    fit = fit_stribeck(w, stribeck(w, **true))
    for k, e in rel_err(fit, true).items():
        assert e < 1e-6, (k, getattr(fit, k))


def test_one_direction_only_is_enough_for_symmetric_model():
    w = np.geomspace(0.002, 0.5, 20)
    fit = fit_stribeck(w, stribeck(w, **PAPER))
    for k, e in rel_err(fit, PAPER).items():
        assert e < 1e-6, k


def test_user_p0_far_away_still_converges_and_vs_positive():
    w = bidirectional()
    F = stribeck(w, **PAPER)
    p0 = {"Fc": 10.0, "Fs": 50.0, "Vs": 0.2, "delta": 1.5, "sigma": 10.0}
    fit = fit_stribeck(w, F, p0=p0)
    assert fit.Vs > 0
    for k, e in rel_err(fit, PAPER).items():
        assert e < 1e-6, k
    # sequence form, same order as PARAM_NAMES, gives the same answer
    fit2 = fit_stribeck(w, F, p0=[p0[k] for k in PARAM_NAMES])
    np.testing.assert_allclose([getattr(fit2, k) for k in PARAM_NAMES],
                               [getattr(fit, k) for k in PARAM_NAMES], rtol=1e-9)


# --------------------------------------------------------------------------- noisy recovery, uncertainty


@pytest.fixture(scope="module")
def noisy_fits():
    w = bidirectional()
    F0 = stribeck(w, **PAPER)
    fits = [fit_stribeck(w, F0 + np.random.default_rng(seed).normal(0.0, NOISE, w.size)) for seed in SEEDS]
    # Independent prediction of the parameter standard deviations: Gauss-Newton linearisation
    # at the true parameters with a finite-difference Jacobian of plant.friction.stribeck.
    Jt = fd_jacobian(w, PAPER)
    sd_pred = NOISE * np.sqrt(np.diag(np.linalg.inv(Jt.T @ Jt)))
    return w, fits, dict(zip(PARAM_NAMES, sd_pred))


def test_noisy_estimates_within_five_predicted_standard_deviations(noisy_fits):
    _, fits, sd = noisy_fits
    for fit in fits:
        assert fit.converged
        assert fit.Vs > 0
        for k in PARAM_NAMES:
            # tolerance: 5 linearised standard deviations (Vs: ~5 %, delta: ~7.5 % relative per sd)
            assert abs(getattr(fit, k) - PAPER[k]) < 5.0 * sd[k], (k, getattr(fit, k), sd[k])


def test_reported_stderr_matches_prediction_and_monte_carlo(noisy_fits):
    _, fits, sd = noisy_fits
    est = np.array([[getattr(f, k) for k in PARAM_NAMES] for f in fits])
    se = np.array([[f.stderr[k] for k in PARAM_NAMES] for f in fits])
    pred = np.array([sd[k] for k in PARAM_NAMES])
    # reported standard errors scatter with s (chi-distributed, dof = 35) around the prediction
    np.testing.assert_allclose(se.mean(axis=0), pred, rtol=0.15)
    # Monte-Carlo spread of the estimates (40 seeds: ~11 % sampling error of a std) agrees too
    np.testing.assert_allclose(est.std(axis=0, ddof=1), pred, rtol=0.4)


def test_true_values_inside_99_percent_intervals_for_most_seeds(noisy_fits):
    _, fits, _ = noisy_fits
    inside = np.array([[lo <= PAPER[k] <= hi for k, (lo, hi) in f.confidence_intervals(0.99).items()]
                       for f in fits])
    # expected coverage 0.99 -> ~39.6 of 40; allow 4 misses per parameter
    assert inside.sum(axis=0).min() >= len(SEEDS) - 4, inside.sum(axis=0)


def test_covariance_equals_s2_inverse_normal_matrix_in_natural_parameters():
    w = bidirectional()
    F = stribeck(w, **PAPER) + np.random.default_rng(7).normal(0.0, NOISE, w.size)
    fit = fit_stribeck(w, F)
    p = fit.params()
    r = stribeck(w, **p) - F
    s2 = r @ r / (w.size - 5)
    J = fd_jacobian(w, p)  # directly in Vs: equals the delta-method map from log Vs
    np.testing.assert_allclose(fit.cov, s2 * np.linalg.inv(J.T @ J), rtol=1e-4, atol=1e-14)
    np.testing.assert_allclose([fit.stderr[k] for k in PARAM_NAMES], np.sqrt(np.diag(fit.cov)), rtol=1e-12)
    np.testing.assert_allclose(fit.residual_rms, np.sqrt(np.mean(r**2)), rtol=1e-12)
    assert fit.dof == w.size - 5
    with pytest.raises(ValueError):
        fit.cov[0, 0] = 1.0  # read-only


def test_confidence_interval_widths_use_student_t():
    w = bidirectional()
    F = stribeck(w, **PAPER) + np.random.default_rng(3).normal(0.0, NOISE, w.size)
    fit = fit_stribeck(w, F)
    for level in (0.9, 0.99):
        tq = student_t.ppf(0.5 + level / 2, w.size - 5)
        ci = fit.confidence_intervals(level)
        for k in ("Fc", "Fs", "delta", "sigma"):
            np.testing.assert_allclose(ci[k][1] - ci[k][0], 2 * tq * fit.stderr[k], rtol=1e-12)
            np.testing.assert_allclose(0.5 * (ci[k][0] + ci[k][1]), getattr(fit, k), rtol=1e-12)
        # Vs: symmetric on log scale, positive
        lo, hi = ci["Vs"]
        assert 0 < lo < fit.Vs < hi
        np.testing.assert_allclose(np.log(hi / fit.Vs), tq * fit.stderr["Vs"] / fit.Vs, rtol=1e-12)
        np.testing.assert_allclose(np.log(fit.Vs / lo), tq * fit.stderr["Vs"] / fit.Vs, rtol=1e-12)
    for bad in (0.0, 1.0, 1.5):
        with pytest.raises(ParameterError, match="level"):
            fit.confidence_intervals(bad)


def test_weights_downweight_an_outlier_and_uniform_scaling_changes_nothing():
    w = bidirectional()
    F = stribeck(w, **PAPER)
    Fbad = F.copy()
    Fbad[5] += 100.0
    std = np.ones_like(w)
    std[5] = 1e9
    fit = fit_stribeck(w, Fbad, F_std=std)
    for k, e in rel_err(fit, PAPER).items():
        assert e < 1e-6, k
    # relative weights: multiplying all F_std by a constant leaves estimates and covariance unchanged
    Fn = F + np.random.default_rng(11).normal(0.0, NOISE, w.size)
    a = fit_stribeck(w, Fn)
    b = fit_stribeck(w, Fn, F_std=np.full(w.size, 7.0))
    np.testing.assert_allclose([getattr(b, k) for k in PARAM_NAMES], [getattr(a, k) for k in PARAM_NAMES],
                               rtol=1e-6)  # optimiser tolerance; stderr/value is ~1e-2 here
    np.testing.assert_allclose(b.cov, a.cov, rtol=1e-6, atol=1e-16)


def test_to_dict_is_json_serialisable_and_complete():
    w = bidirectional()
    fit = fit_stribeck(w, stribeck(w, **PAPER) + np.random.default_rng(2).normal(0.0, NOISE, w.size))
    d = json.loads(json.dumps(fit.to_dict()))
    for k in PARAM_NAMES:
        assert d[k] == getattr(fit, k)
        assert d["stderr"][k] == fit.stderr[k]
    assert np.array_equal(np.array(d["cov"]), fit.cov)
    assert d["n_points"] == w.size and d["converged"] is True
    assert d["residual_rms"] == fit.residual_rms


# --------------------------------------------------------------------------- model and Jacobian (C)


def eq3_numpy(w, Fc, Fs, Vs, delta, sigma):
    """Eq. 3 written out in numpy (independent of the C core)."""
    return np.sign(w) * (Fc + (Fs - Fc) * np.exp(-(np.abs(w) / Vs) ** delta)) + sigma * w


@pytest.mark.parametrize("delta", [1.0, 0.6, 2.5, -0.8])
def test_c_model_and_jacobian_equal_eq3_and_its_central_differences(delta):
    from adaptive_ff.identification.stribeck_fit import _jacobian, _model

    rng = np.random.default_rng(7)
    w = np.concatenate([-1.0, 1.0] * np.geomspace(1e-3, 2.0, 40)[:, None]).ravel()
    w = w * (1.0 + 0.1 * rng.random(w.size))
    x = np.array([25.0, 35.0, np.log(0.02), delta, 40.0])
    Fc, Fs, logVs, d, sigma = x
    np.testing.assert_allclose(_model(x, w), eq3_numpy(w, Fc, Fs, np.exp(logVs), d, sigma), rtol=1e-14, atol=0)
    J = _jacobian(x, np.sign(w), w, np.log(np.abs(w)))
    assert J.shape == (w.size, 5)
    for j in range(5):
        h = 1e-6 * max(abs(x[j]), 1.0)
        up, dn = x.copy(), x.copy()
        up[j] += h
        dn[j] -= h
        fd = (eq3_numpy(w, up[0], up[1], np.exp(up[2]), up[3], up[4])
              - eq3_numpy(w, dn[0], dn[1], np.exp(dn[2]), dn[3], dn[4])) / (2 * h)
        np.testing.assert_allclose(J[:, j], fd, rtol=1e-6, atol=1e-6 * np.max(np.abs(fd)), err_msg=str(j))


def test_c_jacobian_is_finite_where_the_power_overflows():
    from adaptive_ff.identification.stribeck_fit import _jacobian, _model

    w = np.array([-1e-300, 1e-300, 1e3])
    x = np.array([1.0, 2.0, np.log(0.01), -2.0, 0.5])  # delta < 0: (|w|/Vs)**delta overflows at tiny |w|
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        J = _jacobian(x, np.sign(w), w, np.log(np.abs(w)))
        F = _model(x, w)
    # s -> 0 at standstill for delta < 0: |F| -> Fc, dF/dFc = sgn(w), the Stribeck columns vanish
    np.testing.assert_array_equal(J[:2], [[-1.0, -0.0, -0.0, 0.0, -1e-300], [1.0, 0.0, 0.0, -0.0, 1e-300]])
    assert F[1] == 1.0 and F[0] == -1.0
    assert np.all(np.isfinite(J))


# --------------------------------------------------------------------------- w == 0


def test_zero_velocity_samples_give_no_nan_no_warning_and_are_ignored():
    w = np.concatenate([[0.0, 0.0, 0.0], bidirectional()])
    F = stribeck(w, **PAPER)
    F[:3] = [30.0, -12.0, 34.0]  # stiction at standstill: anywhere in [-Fs, Fs]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fit = fit_stribeck(w, F, F_std=np.ones_like(w))
        curve = fit.friction(w)
        ax = plot_stribeck_fit(fit, w, F)
    assert np.all(np.isfinite(curve)) and curve[0] == 0.0
    assert all(np.isfinite(v) for v in fit.params().values())
    assert all(np.isfinite(v) for v in fit.stderr.values())
    assert fit.n_points == w.size - 3
    ref = fit_stribeck(w[3:], F[3:])
    np.testing.assert_allclose([getattr(fit, k) for k in PARAM_NAMES], [getattr(ref, k) for k in PARAM_NAMES],
                               rtol=1e-12)
    assert ax.get_xlabel()


def test_negative_delta_fit_without_warnings():
    w = np.concatenate([[0.0], bidirectional()])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fit = fit_stribeck(w, stribeck(w, **dict(PAPER, delta=-1.0)))
        assert fit.friction(0.0) == 0.0
    assert fit.delta == pytest.approx(-1.0, rel=1e-6)


# --------------------------------------------------------------------------- bad inputs


@pytest.mark.parametrize(
    "kwargs, exc, name",
    [
        (dict(w=np.r_[bidirectional()[:-1], np.nan]), SignalError, "w"),
        (dict(F=np.r_[stribeck(bidirectional()[:-1], **PAPER), np.inf]), SignalError, "F"),
        (dict(F=np.zeros(7)), SignalError, "F"),
        (dict(w=np.zeros((4, 10)), F=np.zeros(40)), SignalError, "w"),
        (dict(w=np.geomspace(0.01, 0.1, 5), F=np.ones(5)), SignalError, "w"),
        (dict(F_std=np.zeros(40)), SignalError, "F_std"),
        (dict(F_std=np.ones(39)), SignalError, "F_std"),
        (dict(F_std=np.r_[np.ones(39), np.nan]), SignalError, "F_std"),
        (dict(delta_starts=(1.0, 0.0)), ParameterError, "delta_starts"),
        (dict(delta_starts=()), ParameterError, "delta_starts"),
        (dict(p0={"Fc": 25, "Fs": 35, "Vs": -0.02, "delta": 1, "sigma": 40}), ParameterError, "Vs"),
        (dict(p0={"Fc": 25, "Fs": 35, "Vs": 0.02, "delta": 0, "sigma": 40}), ParameterError, "delta"),
        (dict(p0={"Fc": 25, "Fs": 35, "Vs": 0.02}), ParameterError, "p0"),
        (dict(p0=[25, 35, 0.02, 1]), ParameterError, "p0"),
    ],
)
def test_bad_inputs_raise_naming_the_argument(kwargs, exc, name):
    args = dict(w=bidirectional(), F=stribeck(bidirectional(), **PAPER))
    args.update(kwargs)
    w, F = args.pop("w"), args.pop("F")
    with pytest.raises(exc, match=name):
        fit_stribeck(w, F, **args)


def test_too_few_nonzero_points_raise_excitation_error():
    w = np.r_[np.zeros(10), 0.01, -0.01, 0.02, 0.05, 0.1]
    with pytest.raises(ExcitationError, match=r"w has only 5 samples"):
        fit_stribeck(w, stribeck(w, **PAPER))
    w = np.r_[0.01, -0.01, 0.02, -0.02, 0.05, -0.05, 0.1, -0.1]  # 8 points, 4 distinct speeds
    with pytest.raises(ExcitationError, match="distinct speeds"):
        fit_stribeck(w, stribeck(w, **PAPER))


@pytest.mark.parametrize("noise", [0.0, NOISE])
def test_no_low_speed_points_cannot_identify_vs(noise):
    w = bidirectional(0.1, 0.5, 10)  # all |w| >= 5*Vs: the Stribeck hump is not sampled
    F = stribeck(w, **PAPER) + np.random.default_rng(5).normal(0.0, noise, w.size)
    with pytest.raises(ExcitationError, match="Fs/Vs"):
        fit_stribeck(w, F)


@pytest.mark.parametrize("noise", [0.0, NOISE])
def test_no_stribeck_effect_cannot_identify_vs(noise):
    w = bidirectional()
    F = stribeck(w, **dict(PAPER, Fs=PAPER["Fc"])) + np.random.default_rng(5).normal(0.0, noise, w.size)
    with pytest.raises(ExcitationError, match="Fs/Vs"):
        fit_stribeck(w, F)


# --------------------------------------------------------------------------- figure


def test_plot_draws_curve_and_measurements_with_labelled_axes():
    w = bidirectional()
    F = stribeck(w, **PAPER) + np.random.default_rng(4).normal(0.0, NOISE, w.size)
    std = np.full(w.size, 2 * NOISE)
    fit = fit_stribeck(w, F, F_std=std)
    ax = plot_stribeck_fit(fit, w, F, F_std=std)
    assert "rad/s" in ax.get_xlabel()
    assert "N·m" in ax.get_ylabel()
    curves = [ln for ln in ax.get_lines() if ln.get_linestyle() == "-" and len(ln.get_xdata()) > 100]
    assert len(curves) == 2  # one branch per direction
    for ln in curves:
        x, y = np.asarray(ln.get_xdata()), np.asarray(ln.get_ydata())
        np.testing.assert_allclose(y, stribeck(x, **fit.params()), rtol=1e-12)
    assert len(ax.containers) == 1  # the errorbar container
    # drawing into a given Axes returns the same Axes
    from matplotlib.figure import Figure

    ax2 = Figure().add_subplot()
    assert plot_stribeck_fit(fit, w, F, ax=ax2) is ax2
    with pytest.raises(TypeError, match="StribeckFit"):
        plot_stribeck_fit(fit.to_dict(), w, F)


# --------------------------------------------------------------------------- simulated quasi-static runs,
# both signs of delta, interval width vs noise, intervals on exact data


@pytest.mark.parametrize("delta", [1.0, -1.0])
def test_simulated_quasi_static_runs_recover_vs_and_delta_within_5_percent(delta):
    # Sec. V-C experiment on the RK4 plant: bidirectional constant-velocity runs in a PI loop, velocity noise
    # 1e-3 rad/s, mean torque of each run as the support point. delta = -1: friction rising from Fc to Fs.
    from controllers.experiments.quasi_static import bidirectional_velocities, quasi_static_runs
    from plant.friction import JointParams

    p = JointParams(**dict(preset("paper").to_dict(), delta=delta))
    qs = quasi_static_runs(p, bidirectional_velocities(0.002, 0.35, 10), noise_std=1e-3,
                           rng=np.random.default_rng(1))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fit = fit_stribeck(qs.w_mean, qs.u_mean)
    assert np.sign(fit.delta) == np.sign(delta)
    assert abs(fit.Vs / p.Vs - 1) < 0.05, fit.Vs
    assert abs(fit.delta / delta - 1) < 0.05, fit.delta
    for k in ("Fc", "Fs", "sigma"):
        assert abs(getattr(fit, k) / getattr(p, k) - 1) < 0.05, (k, getattr(fit, k))
    # the reported standard errors are non-zero and finite
    assert all(0 < fit.stderr[k] < np.inf for k in PARAM_NAMES)


@pytest.mark.parametrize("delta", [1.0, -1.0, 0.5, -2.0])
def test_intervals_on_noise_free_data_contain_the_truth(delta):
    true = dict(PAPER, delta=delta)
    w = np.concatenate([[0.0], bidirectional()])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fit = fit_stribeck(w, stribeck(w, **true))
        ci = fit.confidence_intervals(0.95)
    for k in PARAM_NAMES:
        lo, hi = ci[k]
        assert lo <= true[k] <= hi, (k, lo, true[k], hi)
        assert hi - lo < 1e-8 * max(abs(true[k]), 1.0), (k, hi - lo)  # exact data: tiny intervals


@pytest.mark.parametrize("delta", [1.0, -1.0])
def test_interval_width_scales_linearly_with_noise_and_matches_linearisation(delta):
    true = dict(PAPER, delta=delta)
    w = bidirectional()
    F0 = stribeck(w, **true)
    z = np.random.default_rng(21).standard_normal(w.size)
    tq = student_t.ppf(0.975, w.size - 5)
    widths = {}
    for s in (0.05, 0.1, 0.2):
        fit = fit_stribeck(w, F0 + s * z)
        ci = fit.confidence_intervals(0.95)
        s_hat = np.sqrt(np.sum((fit.friction(w) - F0 - s * z) ** 2) / (w.size - 5))
        Jf = fd_jacobian(w, fit.params())  # independent: finite differences of plant.friction.stribeck
        g = np.sqrt(np.diag(np.linalg.inv(Jf.T @ Jf)))
        for i, k in enumerate(PARAM_NAMES):
            width = ci[k][1] - ci[k][0]
            widths[(s, k)] = width
            if k != "Vs":  # Vs: log-scale interval, checked below
                # half-width = t * s_hat * sqrt(diag(inv(J^T J))) (Wald interval; FD Jacobian error ~1e-6)
                np.testing.assert_allclose(width / 2, tq * s_hat * g[i], rtol=1e-4)
        lo, hi = ci["Vs"]
        np.testing.assert_allclose(np.log(hi / lo) / 2, tq * s_hat * g[2] / fit.Vs, rtol=1e-4)
    for k in PARAM_NAMES:  # same noise shape, amplitude doubled -> interval width doubled (to linearisation error)
        np.testing.assert_allclose(widths[(0.1, k)] / widths[(0.05, k)], 2.0, rtol=0.05)
        np.testing.assert_allclose(widths[(0.2, k)] / widths[(0.1, k)], 2.0, rtol=0.05)
