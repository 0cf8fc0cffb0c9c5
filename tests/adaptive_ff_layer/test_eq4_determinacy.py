"""The eq. 4 feedforward's determinacy test (``map_rel_stderr``, C ``aff_eq4_ff_require_determined``) against an
independent computation.

The reference here is the batch form of the weighted IV estimate (Söderström & Stoica, System Identification,
1989, Ch. 8): ``P_N = (lam^N I/P0 + sum lam^(N-k) z phi')^-1``, ``theta_N = P_N sum lam^(N-k) z y`` by
``numpy.linalg.inv``/``solve``, its covariance ``e2 * P_N (sum lam^(N-k) z z') P_N'`` (Sec. 8.2), ``e2`` the running
mean of the normalised a-priori errors ``e^2/(1 + phi' P z)`` with the gain ``max(1 - lam, 1/n)``, and the
gradient of the static map by central differences of the test oracle's inverse map (tests/peers_oracle.py), not
the C recursion or its closed-form gradient.
"""

import math

import numpy as np
import pytest

import peers_oracle as oracle
from adaptive_ff._caff import ffi, lib
from adaptive_ff.compensation.eq4_feedforward import AdaptiveFrictionFeedforward, AdaptiveFrictionFeedforwardConfig
from adaptive_ff.identification.regression import RegressionModel
from plant.errors import ParameterError
from adaptive_ff.compensation.feedforward import FrictionFeedforwardConfig

TS = 0.01
P0 = 1e4


def _stream(seed, n, noise, sigma=4.0):
    """A joint moving back and forth at 100 Hz: eq. 1-3 stepped by Euler at 1 ms under a PI-like torque, sampled
    every 10 ms, with white noise of ``noise`` rad/s on the sampled velocity."""
    rng = np.random.default_rng(seed)
    J, Fc, Fs, Vs, delta, tau = 0.8, 6.0, 9.0, 0.03, 1.2, 0.004
    dt = 1e-3
    w = f = integ = 0.0
    us, ws = [], []
    u_sum = 0.0
    for k in range(n * 10):
        t = k * dt
        w_ref = 0.4 * math.sin(2 * math.pi * 0.3 * t) + 0.15 * math.sin(2 * math.pi * 1.3 * t)
        e = w_ref - w
        integ += 400.0 * dt * e
        u = 40.0 * e + integ
        F = math.copysign(Fc + (Fs - Fc) * math.exp(-abs(w / Vs) ** delta), w) + sigma * w if w != 0 else 0.0
        f += dt / tau * (F - f)
        w += dt / J * (u - f)
        u_sum += u
        if k % 10 == 9:
            us.append(u_sum / 10.0)
            ws.append(w + rng.normal(0.0, noise))
            u_sum = 0.0
    return us, ws


def _model(lag, stribeck, offset):
    return RegressionModel(0.03 if stribeck else None, 1.2 if stribeck else None, lag=lag, stribeck=stribeck,
                           offset=offset)


def _map(theta, model, w):
    """The static map of theta at w > 0 through the oracle's inverse map: Fc*(1-s) + Fs*s + sigma*w."""
    _, _, sigma, Fc, Fs, _, _ = oracle.eq4_physical(theta, model, TS)
    s = math.exp(-abs(w / model.Vs) ** model.delta) if model.stribeck else 0.0
    return Fc * (1.0 - s) + Fs * s + sigma * w


def _map_gradient(theta, model, w, rel):
    """Central differences of :func:`_map` in each parameter, steps ``rel * max(1, |theta_i|)``."""
    g = np.empty(len(theta))
    for i in range(len(theta)):
        h = rel * max(1.0, abs(theta[i]))
        tp, tm = theta.copy(), theta.copy()
        tp[i] += h
        tm[i] -= h
        g[i] = (_map(tp, model, w) - _map(tm, model, w)) / (2 * h)
    return g


@pytest.mark.parametrize("lag,stribeck,offset", [(True, True, True), (True, True, False), (False, True, False),
                                                 (True, False, True)])
def test_static_gradient_is_the_derivative_of_the_inverse_map(lag, stribeck, offset):
    """aff_eq4_static_gradient: F(w) equals the oracle's map and its gradient the central differences of it."""
    model = _model(lag, stribeck, offset)
    rng = np.random.default_rng(3)
    p = model.n_params
    for _ in range(5):
        theta = rng.normal(0.0, 0.3, p)
        theta[1 if lag else 0] += 0.5
        theta[2 if lag else 1] = 0.02 + 0.01 * rng.random()  # b0: b0 - b1 away from 0
        for w in (0.01, 0.03, 0.2, 1.5):
            s = math.exp(-abs(w / model.Vs) ** model.delta) if stribeck else 0.0
            grad = ffi.new("aff_real[]", 16)
            F = lib.aff_eq4_static_gradient(ffi.new("aff_real[]", theta.tolist()), lag, stribeck, offset, w, s, grad)
            assert F == pytest.approx(_map(theta, model, w), rel=1e-12)
            fd = _map_gradient(theta, model, w, 1e-6)
            np.testing.assert_allclose(np.array(list(grad)[:p]), fd, rtol=1e-5, atol=1e-6 * np.abs(fd).max())


def _reference_decisions(rows, model, r, warmup, tau_max, F_max, lam):
    """For each accepted IV update (phi, z, y) the batch IV estimate with the weights lam^(N-k) (the prior's
    lam^N/P0), its determinacy (the C test's rule on the independent covariance) and the projected estimate;
    returns a list of (determined, margin, estimate, whether the projection's move alone refused it)."""
    p = model.n_params
    Szz = np.zeros((p, p))
    Rzp = np.eye(p) / P0
    zy = np.zeros(p)
    theta = np.zeros(p)
    P = P0 * np.eye(p)
    e2 = 0.0
    w_max = 0.0
    out = []
    for n, (phi, z, y) in enumerate(rows, start=1):
        err = y - phi @ theta
        rr = phi @ P @ z
        e2 += (err * err / (1.0 + max(rr, 0.0)) - e2) * max(1.0 - lam, 1.0 / n)
        Szz = lam * Szz + np.outer(z, z)
        Rzp = lam * Rzp + np.outer(z, phi)
        zy = lam * zy + z * y
        P = np.linalg.inv(Rzp)
        # with forgetting the recursion's covariance bound (trace p*P0) must never bind for the batch form to hold
        assert lam == 1.0 or np.trace(P) < p * P0
        theta = np.linalg.solve(Rzp, zy)
        w_max = max(w_max, abs(y))
        if n < warmup:
            out.append((None, None, None, None))
            continue
        est = oracle.admissible(oracle.eq4_physical(theta, model, TS), tau_max=tau_max, F_max=F_max)
        if est is None:
            out.append((None, None, None, None))
            continue
        bound = r * max(est.Fc, est.Fs)
        if not bound > 0:
            out.append((False, 0.0, est, False))
            continue
        cov = e2 * P @ Szz @ P.T
        sd_margin, moved_margin = math.inf, math.inf
        ws = [w_max] + ([model.Vs] if model.stribeck and model.Vs < w_max else [])
        for w in ws:
            g = _map_gradient(theta, model, w, 1e-7)
            s = math.exp(-abs(w / model.Vs) ** model.delta) if model.stribeck else 0.0
            used = est.Fc * (1 - s) + est.Fs * s + est.sigma * w
            sd = math.sqrt(max(g @ cov @ g, 0.0))
            moved = abs(used - _map(theta, model, w))
            sd_margin = min(sd_margin, bound / sd if sd > 0 else math.inf)
            moved_margin = min(moved_margin, bound / moved if moved > 0 else math.inf)
        margin = min(sd_margin, moved_margin)
        out.append((margin >= 1.0, margin, est, sd_margin >= 1.0 > moved_margin))
    return out


@pytest.mark.parametrize("lag,stribeck,offset,lam,sigma", [
    (True, True, True, 1.0, 4.0), (False, True, False, 1.0, 4.0), (True, False, True, 1.0, 4.0),
    (True, True, True, 0.995, 4.0), (False, True, False, 1.0, 0.0)])
def test_the_first_estimate_waits_until_the_iv_covariance_determines_the_map(lag, stribeck, offset, lam, sigma):
    """Sample by sample (observe), lam 1 and 0.995: an estimate is used exactly where the independent batch IV
    covariance puts the standard error of the map at w_max (and at Vs) within map_rel_stderr of max(Fc, Fs) and the
    projection leaves the map there within the same bound; elsewhere the previous one (or none) stays. On a joint
    without viscous friction (sigma 0) the projection's clip of a negative sigma alone refuses some estimates."""
    model = _model(lag, stribeck, offset)
    r, warmup, tau_max, F_max = 0.05, 20, 1.0, 100.0
    c = AdaptiveFrictionFeedforward(model, dt=TS,
                                    config=AdaptiveFrictionFeedforwardConfig(Ts=TS, lam=lam, P0=P0, warmup=warmup,
                                                                             tau_max=tau_max, iv=True,
                                                                             map_rel_stderr=r,
                                                                             ff=FrictionFeedforwardConfig(ff_max=F_max)))
    p = model.n_params
    rows, used = [], []
    for u, w in zip(*_stream(5, 1500, 0.001, sigma)):
        n0 = c.ivrls.n_updates
        c.observe(u, w)
        if c.ivrls.n_updates == n0:
            continue
        cd = c.cdata
        rows.append((np.array([cd.phi[i] for i in range(p)]), np.array([cd.z[i] for i in range(p)]), w))
        e = c.estimate
        used.append(None if e is None else (e.J, e.tau, e.sigma, e.Fc, e.Fs))
    ref = _reference_decisions(rows, model, r, warmup, tau_max, F_max, lam)
    assert len(ref) == len(used) > 1000
    first = next(k for k, u in enumerate(used) if u is not None)
    n_checked = 0
    for k, ((det, margin, est, _), u) in enumerate(zip(ref, used)):
        if margin is not None and abs(margin - 1.0) < 1e-6:
            continue  # at the bound to rounding: either decision is right
        if det:
            n_checked += 1
            assert u == pytest.approx((est.J, est.tau, est.sigma, est.Fc, est.Fs), rel=1e-6, abs=1e-9), k
        elif k > 0:
            assert u == used[k - 1], k  # not determined (or not admissible): the estimate in use stays
    assert warmup < first < len(used) - 100  # undetermined estimates were held back, then it took over
    assert c.n_undetermined > 0 and n_checked > 100
    if sigma == 0.0:  # a joint without viscous friction: the projection's clip of sigma decides some estimates
        assert sum(1 for x in ref if x[3]) > 50
    assert c.info()["n_undetermined"] == c.n_undetermined and c.info()["map_rel_stderr"] == r


def test_determinacy_validation_and_the_default():
    model = _model(True, True, True)
    iv = AdaptiveFrictionFeedforwardConfig(Ts=TS, iv=True)
    assert math.isinf(AdaptiveFrictionFeedforward(model, dt=TS, config=iv).map_rel_stderr)
    assert "n_undetermined" not in AdaptiveFrictionFeedforward(model, dt=TS, config=iv).info()
    for bad in (0.0, -0.1, math.nan, "x", True):
        with pytest.raises(ParameterError, match="map_rel_stderr"):
            AdaptiveFrictionFeedforward(model, dt=TS, config=iv.replace(map_rel_stderr=bad))
    with pytest.raises(ParameterError, match="needs iv"):
        AdaptiveFrictionFeedforward(model, dt=TS, config=AdaptiveFrictionFeedforwardConfig(Ts=TS, map_rel_stderr=0.2))
    c = AdaptiveFrictionFeedforward(model, dt=TS, config=iv.replace(map_rel_stderr=0.2))
    assert lib.aff_eq4_ff_require_determined(c.cdata, 0.0) == -1 and c.map_rel_stderr == 0.2


def test_mode_options_pass_the_bound_to_adaptive_and_not_to_adaptive_dob():
    """``LoopConfig.estimator.iv_map_stderr`` reaches the eq. 4 feedforward of mode ``adaptive`` (default: no test); the
    composite ``adaptive-dob`` builds its feedforward without the test; a bound that is not > 0 is refused."""
    from controllers.simulation.closed_loop import LoopConfig
    from controllers.simulation.compensators import build_mode
    from plant.friction import preset

    P = preset("paper")
    o = LoopConfig.from_flat(Kp=20.0, Ki=200.0, J_design=P.J, Vs=P.Vs, delta=P.delta, estimator="eq4",
                    model=RegressionModel(P.Vs, P.delta))
    assert math.isinf(o.estimator.iv_map_stderr)
    assert math.isinf(build_mode(P, "adaptive", o)[2].feedforward.map_rel_stderr)
    o = o.replace(iv_map_stderr=0.3)
    assert build_mode(P, "adaptive", o)[2].feedforward.map_rel_stderr == 0.3
    assert math.isinf(build_mode(P, "adaptive-dob", o)[2].feedforward.map_rel_stderr)
    for bad in (0.0, -1.0, math.nan, True, "0.2"):
        with pytest.raises(ParameterError, match="iv_map_stderr"):
            o.replace(iv_map_stderr=bad)


def test_compare_zoo_and_cli_pass_the_bound_to_mode_adaptive(capsys):
    """``CompareOptions.loop.estimator.iv_map_stderr`` (and the zoo's and ``compare --iv-map-stderr``, which set it) reaches mode
    ``adaptive``'s options; ``adaptive-dob`` builds its feedforward without the test; a bound not > 0 is refused by
    name, by the CLI with exit code 2 and no traceback."""
    from controllers.cli import main
    from controllers.experiments.compare import CompareOptions, prepare_comparison
    from controllers.experiments.zoo import ZooOptions
    from controllers.simulation.compensators import build_mode
    from plant.friction import preset

    P = preset("paper")
    s = prepare_comparison(P, CompareOptions.from_flat(duration=2.0, modes=("none", "adaptive", "adaptive-dob"),
                                             estimator="eq4", iv_map_stderr=0.15))
    s.bar.close()
    assert s.mode_options["adaptive"].estimator.iv_map_stderr == 0.15
    assert build_mode(P, "adaptive", s.mode_options["adaptive"])[2].feedforward.map_rel_stderr == 0.15
    assert math.isinf(build_mode(P, "adaptive-dob", s.mode_options["adaptive-dob"])[2].feedforward.map_rel_stderr)
    assert math.isinf(CompareOptions().loop.estimator.iv_map_stderr)
    assert math.isinf(ZooOptions().compare.loop.estimator.iv_map_stderr)
    # the zoo prepares and runs each joint with its CompareOptions: the bound is there
    zoo = ZooOptions.from_flat(iv_map_stderr=0.15, estimator="eq4")
    assert zoo.compare_options().loop.estimator.iv_map_stderr == 0.15
    for bad in (0.0, -1.0, math.nan, "0.2"):
        for options in (CompareOptions.from_flat, ZooOptions.from_flat):
            with pytest.raises(ParameterError, match="iv_map_stderr"):
                options(iv_map_stderr=bad)
    assert main(["compare", "--preset", "paper", "--iv-map-stderr", "0", "--duration", "1", "--no-figures",
                 "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "iv_map_stderr" in err and "Traceback" not in err
