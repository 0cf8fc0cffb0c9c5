"""Property tests (hypothesis) of the compiled kernels.

* :func:`controllers.simulation.batch.run_batch` equals single runs of the engine, each checked period by period
  against its replay by the independent oracles (tests/loop_oracle.py), to 1e-9, over random plants (eq. 3 with
  lag), gains, limits, noise seeds and modes.
* :meth:`adaptive_ff.identification.rls.RecursiveLeastSquares.update` equals ``update_many`` (bit for bit)
  and the information form of tests/rls_oracle.py (1e-8 relative to the largest entry, see the test) over
  random streams, forgetting schemes, covariance bounds and parameter boxes.

Deterministic (``derandomize=True``) and small (``max_examples``), ``deadline=None``.
"""

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from adaptive_ff.identification.regression import FrictionEstimate
from adaptive_ff.identification.rls import RecursiveLeastSquares
from controllers.simulation.batch import run_batch
from controllers.simulation.closed_loop import LoopConfig
from loop_oracle import replayed_run
from plant.excitation import multisine_reference
from plant.friction import JointParams
from rls_oracle import InformationRLS

SETTINGS = dict(deadline=None, derandomize=True, database=None, suppress_health_check=[HealthCheck.too_slow])
FIELDS = ("rms", "max", "rms_second_half", "max_second_half", "rms_reversal", "u_rms")


@st.composite
def plants(draw):
    Fc = draw(st.floats(0.5, 40.0))
    return JointParams(J=draw(st.floats(0.05, 10.0)), Fc=Fc, Fs=Fc * draw(st.floats(1.0, 1.8)),
                       Vs=draw(st.floats(0.003, 0.2)),
                       delta=draw(st.one_of(st.sampled_from([1.0, 2.0]), st.floats(0.5, 2.5))),
                       sigma=draw(st.floats(0.0, 60.0)),
                       tau=draw(st.one_of(st.just(0.0), st.floats(0.002, 0.05))))


@st.composite
def batch_cases(draw):
    B = draw(st.integers(1, 3))
    ps = [draw(plants()) for _ in range(B)]
    wc = np.array([draw(st.floats(5.0, 80.0)) for _ in range(B)])  # loop crossover, rad/s
    Kp = np.array([p.J for p in ps]) * wc
    Ki = Kp * np.array([draw(st.floats(1.0, 15.0)) for _ in range(B)])
    u_max = np.array([draw(st.one_of(st.just(math.inf), st.floats(1.5, 4.0))) * (p.Fs + 1.0) for p in ps])
    mode = draw(st.sampled_from(["none", "frictionless", "oracle", "fixed"]))
    noise_std = draw(st.sampled_from([0.0, 1e-3]))
    seeds = [draw(st.integers(0, 2**31 - 1)) for _ in range(B)]
    ref_seed = draw(st.integers(0, 1000))
    amp = draw(st.floats(0.05, 1.0))  # peak reference velocity, rad/s
    err = draw(st.floats(0.7, 1.3))
    ff_input = draw(st.sampled_from(["measured", "reference"]))
    return ps, Kp, Ki, u_max, mode, noise_std, seeds, ref_seed, amp, err, ff_input


@settings(max_examples=40, **SETTINGS)
@given(batch_cases())
def test_batch_kernel_equals_run_closed_loop_one_by_one(case):
    ps, Kp, Ki, u_max, mode, noise_std, seeds, ref_seed, amp, err, ff_input = case
    ref = multisine_reference(1.5, f_min=0.5, peak=amp, rng=np.random.default_rng(ref_seed))
    est = [FrictionEstimate(J=p.J, tau=p.tau, sigma=p.sigma, Fc=p.Fc * err, Fs=p.Fs, offset=0.0, Vs=p.Vs,
                            delta=p.delta, J_alt=p.J) for p in ps]
    opts = [LoopConfig.from_flat(Kp=float(Kp[b]), Ki=float(Ki[b]), u_max=float(u_max[b]), noise_std=noise_std,
                        estimate=est[b], ff_input=ff_input, sensor_gate=False) for b in range(len(ps))]
    res = run_batch(ps, ref, mode, opts, seeds=seeds)
    for b, p in enumerate(ps):
        one = replayed_run(p, ref, mode=mode, Kp=float(Kp[b]), Ki=float(Ki[b]), u_max=float(u_max[b]),
                           noise_std=noise_std, seed=seeds[b], estimate=est[b], ff_input=ff_input,
                           sensor_gate=False)
        assert bool(res.diverged[b]) == bool(one["diverged"])
        for name in FIELDS:
            assert getattr(res, name)[b] == pytest.approx(getattr(one["metrics"], name), rel=1e-9, abs=1e-15,
                                                          nan_ok=True), name


@st.composite
def rls_cases(draw):
    p = draw(st.integers(1, 7))
    n = draw(st.integers(1, 120))
    forgetting = draw(st.sampled_from(["exponential", "directional", "vector"]))
    if forgetting == "vector":
        lam = [draw(st.floats(0.8, 1.0)) for _ in range(p)]
        forgetting = "exponential"
    else:
        lam = draw(st.floats(0.8, 1.0))
    P0 = draw(st.floats(0.1, 1e4))
    P_max = draw(st.one_of(st.none(), st.floats(1.0, 1e5)))
    box = draw(st.booleans())
    seed = draw(st.integers(0, 2**31 - 1))
    return p, n, lam, forgetting, P0, P_max, box, seed


@settings(max_examples=100, **SETTINGS)
@given(rls_cases())
def test_rls_update_equals_update_many_and_the_information_form(case):
    p, n, lam, forgetting, P0, P_max, box, seed = case
    rng = np.random.default_rng(seed)
    scale = 10.0 ** rng.uniform(-1, 1, p)
    Phi = rng.normal(size=(n, p)) * scale
    if n > 4:
        Phi[n // 2:] = Phi[n // 2]  # second half unexcited (constant regressor): windup / P_max paths
    theta_true = rng.normal(size=p) / scale
    Y = Phi @ theta_true + 0.1 * rng.normal(size=n)
    kw = dict(lam=lam, P0=P0, forgetting=forgetting, P_max=P_max)
    if P_max is not None and P_max <= P0 * p and forgetting == "directional":
        kw["P_max"] = None  # directional needs P_max >= trace(P0) to be meaningful; default trace(P0)
    if box:
        half = np.abs(theta_true) * rng.uniform(0.3, 2.0, p)
        kw["bounds"] = (-half, half)
    a = RecursiveLeastSquares(p, **kw)
    b = RecursiveLeastSquares(p, **kw)
    o = InformationRLS(p, **kw)
    hist = b.update_many(Phi, Y)
    for k in range(n):
        e = a.update(Phi[k], Y[k])
        e_o = o.update(Phi[k], Y[k])
        assert np.array_equal(a.theta, hist[k])
        scale_t = max(1.0, float(np.max(np.abs(o.theta))))
        # two roundings meet here: the package's P - (P phi)(P phi)^T / s cancels about log10(phi^T P phi)
        # digits along the excited direction, the oracle's solves with R = P^-1 lose about log10(cond R) digits;
        # measured at most 1e-9 relative to the largest entry over 300 such streams (1e-14 on moderate ones)
        assert e == pytest.approx(e_o, rel=1e-8, abs=1e-8 * max(1.0, abs(float(Y[k]))) * scale_t)
        np.testing.assert_allclose(a.theta, o.theta, rtol=0, atol=1e-8 * scale_t)
        P_o = o.P
        np.testing.assert_allclose(a.P, P_o, rtol=0, atol=1e-8 * float(np.max(np.abs(P_o))))
    assert np.array_equal(a.P, b.P) and np.array_equal(a.P, a.P.T)
    assert a.n_updates == b.n_updates == o.n_updates == n
    assert a.n_projected == b.n_projected == o.n_projected
