"""The compiled closed-loop kernel (controllers.simulation.loop_kernel) equals its Python reference twin, and streams metrics."""

import contextlib
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from adaptive_ff.identification.regression import FrictionEstimate, RegressionModel
from controllers.simulation import closed_loop as cl
from controllers.simulation.closed_loop import _reversals, kernel_supported, loop_metrics, run_closed_loop
from controllers.design.pi import design_pi
from plant.errors import ParameterError
from plant.excitation import multisine_reference
from plant.friction import preset

P = preset("paper")
DESIGN = design_pi(P.J, crossover=20.0, phase_margin=60.0, Tc=1e-3)
METRICS = ("rms", "max", "rms_second_half", "max_second_half", "rms_reversal", "u_rms")
SIGNALS = ("w", "w_meas", "u", "u_ff", "f")


def _close(a, b, rel=1e-9):
    """max |a - b| <= rel * max(1, max |a|) over finite entries; NaN/inf identical."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape
    fin = np.isfinite(a)
    assert np.array_equal(a[~fin], b[~fin], equal_nan=True)
    if fin.any():
        scale = max(1.0, float(np.max(np.abs(a[fin]))))
        assert float(np.max(np.abs(a[fin] - b[fin]))) <= rel * scale


def _both(p, ref, **kw):
    seed = kw.pop("seed", 1)
    a = run_closed_loop(p, ref, engine="python", rng=np.random.default_rng(seed), **kw)
    b = run_closed_loop(p, ref, engine="numba", rng=np.random.default_rng(seed), **kw)
    assert a.info["engine"] == "python" and b.info["engine"] == "numba"
    return a, b


def _assert_same(a, b):
    for name in SIGNALS:
        _close(getattr(a, name), getattr(b, name))
    for name in METRICS:
        assert getattr(b.metrics, name) == pytest.approx(getattr(a.metrics, name), rel=1e-9, abs=1e-15, nan_ok=True)
    _close(a.t_theta, b.t_theta, rel=0.0)
    _close(a.theta, b.theta)
    for key in ("n_sensor_rejected", "diverged", "n_rejected", "n_implausible", "n_lag_held", "n_updates",
                "n_gated", "n_projected"):
        assert a.info.get(key) == b.info.get(key), key
    if a.estimate is None:
        assert b.estimate is None
    else:
        ea, eb = a.estimate.to_dict(), b.estimate.to_dict()
        for k, v in ea.items():
            assert eb[k] == pytest.approx(v, rel=1e-9, abs=1e-12, nan_ok=True), k


@contextlib.contextmanager
def _small_chunks(chunk=1000):
    """Let the Python twin stream in chunks of ``chunk`` samples (default 2**16) so short runs cross chunks."""
    defaults = cl._run_python.__kwdefaults__.copy()
    cl._run_python.__kwdefaults__["chunk"] = chunk
    try:
        yield
    finally:
        cl._run_python.__kwdefaults__.update(defaults)


@pytest.fixture(scope="module")
def ref():
    return multisine_reference(6.0, f_min=0.3, rng=np.random.default_rng(0))


def _initial(p, scale=0.8):
    return FrictionEstimate(J=p.J, tau=0.0, sigma=scale * p.sigma, Fc=scale * p.Fc, Fs=scale * p.Fs, offset=0.0,
                            Vs=p.Vs, delta=p.delta, J_alt=float("nan"))


@pytest.mark.parametrize("mode", ["none", "frictionless", "oracle", "fixed", "adaptive", "canudas", "dob"])
def test_kernel_equals_python_every_mode_with_noise_faults_and_gate(ref, mode):
    est = FrictionEstimate(J=P.J, tau=P.tau, sigma=P.sigma, Fc=0.9 * P.Fc, Fs=P.Fs, offset=0.0, Vs=P.Vs,
                           delta=P.delta, J_alt=P.J)
    faults = {500: float("nan"), 1200: 5.0, 1201: math.inf, 3000: -3.0}
    a, b = _both(P, ref, mode=mode, Kp=DESIGN.Kp, Ki=DESIGN.Ki, u_max=150.0, ff_max=75.0, noise_std=1e-3,
                 estimate=est, Vs=P.Vs, delta=P.delta, initial=_initial(P), warmup=50, stick_band=3e-3,
                 stick_samples=5, faults=faults)
    _assert_same(a, b)
    assert a.info["n_sensor_rejected"] >= 3
    if mode == "adaptive":
        assert a.info["n_updates"] > 100 and a.theta.shape[0] == a.info["n_updates"]
        assert a.info["n_rejected"] >= 3  # the estimator's own gate saw the faults
    if mode == "canudas":
        assert a.info["n_rejected"] >= 2  # the non-finite raw samples
        assert a.info["n_updates"] > 100 and a.info["canudas_estimate"] is not None
        for k, v in a.info["canudas_estimate"].items():
            assert b.info["canudas_estimate"][k] == pytest.approx(v, rel=1e-12), k


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(J=st.floats(0.5, 8.0), Fc=st.floats(1.0, 30.0), ratio=st.floats(1.0, 1.6), Vs=st.floats(0.005, 0.1),
       delta=st.floats(0.5, 2.0), sigma=st.floats(0.0, 60.0), tau=st.sampled_from([0.0, 0.005, 0.02, 0.05]),
       crossover=st.floats(10.0, 40.0), u_max=st.sampled_from([math.inf, 150.0, 60.0]),
       noise=st.sampled_from([0.0, 1e-3, 5e-3]), forgetting=st.sampled_from(["exponential", "directional"]),
       lag=st.booleans(), offset=st.booleans(), ff_input=st.sampled_from(["measured", "reference"]),
       sign_width=st.sampled_from([0.0, 2e-3]), gate=st.booleans(), lam=st.sampled_from([0.99, 0.995, 1.0]),
       seed=st.integers(0, 2**16))
def test_adaptive_kernel_equals_python_over_random_plants(ref, J, Fc, ratio, Vs, delta, sigma, tau, crossover,
                                                          u_max, noise, forgetting, lag, offset, ff_input,
                                                          sign_width, gate, lam, seed):
    p = P.replace(J=J, Fc=Fc, Fs=Fc * ratio, Vs=Vs, delta=delta, sigma=sigma, tau=tau)
    d = design_pi(J, crossover=crossover, phase_margin=60.0, Tc=1e-3)
    a, b = _both(p, ref, mode="adaptive", Kp=d.Kp, Ki=d.Ki, u_max=u_max, noise_std=noise, Vs=Vs, delta=delta,
                 forgetting=forgetting, lag=lag, offset=offset, ff_input=ff_input, sign_width=sign_width,
                 sensor_gate=gate, lam=lam, warmup=30, initial=_initial(p) if seed % 2 else None,
                 stick_band=3 * noise, seed=seed)
    _assert_same(a, b)


@pytest.mark.parametrize("decimate", [0, 7])
def test_streamed_metrics_equal_full_record_metrics(ref, decimate):
    kw = dict(mode="adaptive", Kp=DESIGN.Kp, Ki=DESIGN.Ki, u_max=150.0, noise_std=1e-3, Vs=P.Vs, delta=P.delta,
              warmup=50)
    full = run_closed_loop(P, ref, rng=np.random.default_rng(3), **kw)
    dec = run_closed_loop(P, ref, rng=np.random.default_rng(3), decimate=decimate, **kw)
    assert full.info["engine"] == dec.info["engine"] == "numba"
    # independent computation from the full record
    m = loop_metrics(full.t, full.w_ref, full.w, full.u, reversals=ref.reversals(), window=0.2)
    for name in METRICS:
        assert getattr(dec.metrics, name) == pytest.approx(getattr(m, name), rel=1e-12), name
    if decimate:
        np.testing.assert_array_equal(dec.t, full.t[::decimate])
        for name in SIGNALS:
            np.testing.assert_array_equal(getattr(dec, name), getattr(full, name)[::decimate])
        np.testing.assert_array_equal(dec.theta, full.theta)
    else:
        assert dec.t.size == dec.w.size == 0 and dec.theta.size == 0
    # the Python twin streams and decimates the same way (in chunks of 2**16 samples; here 1000)
    with _small_chunks():
        py = run_closed_loop(P, ref, rng=np.random.default_rng(3), decimate=decimate, engine="python", **kw)
    assert py.info["engine"] == "python"
    for name in METRICS:
        assert getattr(py.metrics, name) == pytest.approx(getattr(m, name), rel=1e-12), name
    for name in SIGNALS:
        np.testing.assert_array_equal(getattr(py, name), getattr(dec, name))
    np.testing.assert_array_equal(py.t, dec.t)
    np.testing.assert_array_equal(py.theta, dec.theta)


def test_divergence_is_detected_identically_and_streamed_metrics_are_nan(ref):
    kw = dict(mode="none", Kp=DESIGN.Kp, Ki=DESIGN.Ki, w_limit=0.05)
    a, b = _both(P, ref, **kw)
    assert a.info["diverged"] and b.info["diverged"]
    _assert_same(a, b)
    k = int(np.flatnonzero(np.isnan(a.w))[0])
    assert 0 < k < ref.t.size
    for engine in ("numba", "python"):
        with _small_chunks():
            s = run_closed_loop(P, ref, decimate=0, engine=engine, **kw)
        assert s.info["diverged"]
        for name in METRICS:
            assert getattr(s.metrics, name) == pytest.approx(getattr(a.metrics, name), rel=1e-12, nan_ok=True), name


def test_engine_selection_and_validation(ref):
    assert kernel_supported(P, mode="adaptive")
    assert not kernel_supported(P, mode="adaptive", estimator="eq4")
    assert kernel_supported(P, mode="canudas") and kernel_supported(P, mode="dob")
    assert kernel_supported(P, mode="none", drift=True)
    assert not kernel_supported(object(), mode="none")
    model = RegressionModel(P.Vs, P.delta)
    r = run_closed_loop(P, ref, mode="adaptive", estimator="eq4", model=model, Kp=DESIGN.Kp, Ki=DESIGN.Ki)
    assert r.info["engine"] == "python"
    with pytest.raises(ParameterError, match="engine='numba'"):
        run_closed_loop(P, ref, mode="adaptive", estimator="eq4", model=model, Kp=DESIGN.Kp, Ki=DESIGN.Ki,
                        engine="numba")
    with pytest.raises(ParameterError, match="engine"):
        run_closed_loop(P, ref, mode="none", Kp=DESIGN.Kp, Ki=DESIGN.Ki, engine="cuda")
    with pytest.raises(ParameterError, match="decimate"):
        run_closed_loop(P, ref, mode="none", Kp=DESIGN.Kp, Ki=DESIGN.Ki, decimate=-1)


def test_chunked_reversals_equal_reference_reversals():
    r = multisine_reference(20.0, f_min=0.5, rng=np.random.default_rng(4))
    assert r.reversals().size > 10
    for chunk in (7, 1000, 1 << 16):
        np.testing.assert_array_equal(_reversals(r.t, r.w, chunk=chunk), r.reversals())


@pytest.mark.parametrize("mode", ["dob", "canudas"])
def test_python_engine_streams_metrics_in_chunks(ref, mode):
    kw = dict(mode=mode, Kp=DESIGN.Kp, Ki=DESIGN.Ki, u_max=150.0, noise_std=1e-3, engine="python")
    full = run_closed_loop(P, ref, rng=np.random.default_rng(2), **kw)
    with _small_chunks(999):
        dec = run_closed_loop(P, ref, rng=np.random.default_rng(2), decimate=10, **kw)
    assert full.info["engine"] == dec.info["engine"] == "python"
    for name in METRICS:
        assert getattr(dec.metrics, name) == pytest.approx(getattr(full.metrics, name), rel=1e-12), name
    for name in SIGNALS:
        np.testing.assert_array_equal(getattr(dec, name), getattr(full, name)[::10])


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(J=st.floats(0.5, 8.0), Fc=st.floats(1.0, 30.0), sigma=st.floats(0.0, 60.0),
       tau=st.sampled_from([0.0, 0.01, 0.03]), mode=st.sampled_from(["canudas", "dob"]),
       forgetting=st.sampled_from(["exponential", "directional"]), ff_input=st.sampled_from(["measured", "reference"]),
       omega_q=st.floats(100.0, 2000.0), u_max=st.sampled_from([math.inf, 100.0]), seed=st.integers(0, 2**16))
def test_peer_kernels_equal_python_over_random_plants(ref, J, Fc, sigma, tau, mode, forgetting, ff_input, omega_q,
                                                      u_max, seed):
    p = P.replace(J=J, Fc=Fc, Fs=1.3 * Fc, sigma=sigma, tau=tau)
    d = design_pi(J, crossover=20.0, phase_margin=60.0, Tc=1e-3)
    a, b = _both(p, ref, mode=mode, Kp=d.Kp, Ki=d.Ki, u_max=u_max, noise_std=1e-3, forgetting=forgetting,
                 ff_input=ff_input, omega_q=omega_q, warmup=50, J_n=0.9 * J, seed=seed)
    _assert_same(a, b)


@pytest.mark.parametrize("mode", ["none", "oracle", "adaptive", "canudas"])
def test_kernel_equals_python_on_a_drifting_plant(ref, mode):
    from plant.drift import FrictionDrift

    p = FrictionDrift(P, Fc_change=0.5, Fs_change=0.3, t_start=1.0, t_end=5.0, period=0.01)
    a, b = _both(p, ref, mode=mode, Kp=DESIGN.Kp, Ki=DESIGN.Ki, u_max=150.0, noise_std=1e-3, Vs=P.Vs,
                 delta=P.delta, warmup=50)
    _assert_same(a, b)
    still = run_closed_loop(P, ref, mode=mode, Kp=DESIGN.Kp, Ki=DESIGN.Ki, u_max=150.0, noise_std=1e-3,
                            rng=np.random.default_rng(1), Vs=P.Vs, delta=P.delta, warmup=50)
    assert np.max(np.abs(still.f - a.f)) > 1.0  # the drift really changed the friction


def test_rls_state_layout_assumed_by_the_kernel():
    # controllers.simulation.loop_kernel reads theta and P of adaptive_ff.identification.rls.RecursiveLeastSquares from its state buffer
    from adaptive_ff.identification.rls import _HDR, _NUPD, RecursiveLeastSquares

    rls = RecursiveLeastSquares(3, lam=0.99, P0=[[2.0, 0.1, 0.0], [0.1, 3.0, 0.2], [0.0, 0.2, 4.0]],
                                theta0=[1.0, 2.0, 3.0])
    rls.update(np.array([0.5, -1.0, 2.0]), 1.5)
    buf = rls._buf
    np.testing.assert_array_equal(buf[_HDR:_HDR + 3], rls.theta)
    np.testing.assert_array_equal(buf[_HDR + 3:_HDR + 12].reshape(3, 3), rls.P)
    assert buf[_NUPD] == rls.n_updates == 1