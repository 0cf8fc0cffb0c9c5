"""The output-error problem's batched simulations (adaptive_ff.identification.physical_id): the same numbers as the
one-at-a-time search they replace.

The trust-region passes take their finite-difference Jacobians through one batched C call, the grid searches
(profiles, coordinate moves) simulate their points together, and a problem keeps the residual vectors it was last
asked for. Each is checked here against the plain computation, written out independently: scipy's own
finite differences, a loop of single costs, the coordinate moves one at a time.
"""

import math

import numpy as np
import pytest

from adaptive_ff.identification import physical_id as pid
from plant import bandlimited_noise, preset, sample, simulate

P = preset("paper")
KEYS = ("J", "Fc", "Fs", "sigma", "tau")


@pytest.fixture(scope="module")
def problem():
    rng = np.random.default_rng(4)
    _, u = bandlimited_noise(3.0, dt=1e-3, cutoff=1.0, std=1.2 * (P.Fs + P.sigma * math.radians(20.0)), rng=rng)
    resp = simulate(P, u, dt=1e-3)
    m = sample(resp, Ts=2e-3, noise_std=0.01 * float(np.max(np.abs(resp.w))), rng=rng)
    opts = pid.OutputErrorOptions(n_bootstrap=0)
    t, u, w, Vs, delta = pid._check_inputs(m.t, m.u, m.w, P.Vs, P.delta)
    pb = pid._OutputErrorProblem(t, u, w, Vs, delta, True, opts)
    x = pb.start_vector({k: getattr(P, k) * (1.03 if k != "tau" else 0.9) for k in KEYS})
    return pb, x


def _fresh(pb):
    return pb.replicate(pb.w)


def test_batched_jacobians_give_scipys_own_trust_region_pass(problem, monkeypatch):
    pb, x = problem
    for free in (None, [0, 1, 2, 3, 5]):
        a = _fresh(pb).refine(x, pb.opts.diff_step, pb.f_wide, free=free)
        monkeypatch.setattr(pid, "_LSQ_WORKERS", False)  # scipy's finite differences, one simulation at a time
        b = _fresh(pb).refine(x, pb.opts.diff_step, pb.f_wide, free=free)
        monkeypatch.undo()
        assert a.nfev == b.nfev and a.njev == b.njev > 1
        np.testing.assert_array_equal(a.x, b.x)
        np.testing.assert_array_equal(a.fun, b.fun)


def test_profile_is_the_lowest_of_single_costs(problem):
    pb, x = problem
    g = np.linspace(x[1], 2.5 * x[1], 11)
    single = []
    for v in g:
        xx = x.copy()
        xx[2] = v
        single.append(_fresh(pb).cost(xx, pb.f_wide))
    got = _fresh(pb).profile(x, x[1], 2.5 * x[1], 11, fsc=pb.f_wide)
    assert got[2] == g[int(np.argmin(single))]
    np.testing.assert_array_equal(np.delete(got, 2), np.delete(x, 2))


def test_coordinate_moves_are_the_one_at_a_time_moves(problem):
    pb, x = problem
    for j in range(x.shape[0]):
        ref, c_ref, q = x.copy(), _fresh(pb).cost(x), _fresh(pb)
        for k in (-3, -2, -1, 1, 2, 3):
            xx = ref.copy()
            xx[j] += k * q.typical(ref)[j]
            c = q.cost(xx)
            if c < c_ref:
                ref, c_ref = xx, c
        got, c_got = pid._oe_coordinate_moves(_fresh(pb), x.copy(), _fresh(pb).cost(x), j)
        np.testing.assert_array_equal(got, ref)
        assert c_got == c_ref


def test_a_residual_asked_for_again_is_the_same_without_a_simulation(problem):
    pb, x = problem
    q = _fresh(pb)
    r1 = q.res(x)
    r1[:] = 0.0  # a caller's change does not reach the kept copy
    n = q.n_sim
    r2 = q.res(x.copy())
    assert q.n_sim == n == 1
    np.testing.assert_array_equal(r2, _fresh(pb).res(x))
    sol = q.refine(x, pb.opts.diff_step)
    n = q.n_sim
    assert q.cost(sol.x) == _fresh(pb).cost(sol.x) and q.n_sim == n
