"""Tests of controllers.simulation.metrics: the C accumulator ctl_metrics against independent numpy computations.

The oracle classifies every sample by brute force (the nearest reversal of each second-half sample, from the
whole reversal array) and computes each RMS with :func:`math.fsum` (exactly rounded sums), each maximum with numpy;
the accumulator streams the same samples through ``ctl_metrics_update`` (Neumaier-compensated sums, a moving
reversal pointer). Bit-for-bit identities are asserted only where the operations are the same by construction
(metrics_columns against metrics_result, the array loop against single updates).
"""

import math

import numpy as np
import pytest

from controllers._cctl import ffi, lib
from controllers.simulation.metrics import (METRIC_NAMES, METRICS_DTYPE, loop_metrics, metrics_add, metrics_columns,
                                            metrics_result, metrics_update, metrics_where, new_metrics)
from plant.errors import ParameterError


def _bits(x):
    return np.asarray(x, dtype=float).view(np.int64)


def _oracle(t, e, u, revs, window):
    """LoopMetrics fields by brute force: class of each sample, then fsum-based RMS and numpy maxima."""
    tmid = 0.5 * (t[0] + t[-1])
    half = t >= tmid
    if revs.size:
        dist = np.min(np.abs(t[:, None] - revs[None, :]), axis=1)
        rev = half & (dist <= window)
    else:
        rev = np.zeros_like(half)

    def rms(x, sel):
        n = int(np.count_nonzero(sel))
        return math.sqrt(math.fsum((x[sel] ** 2).tolist()) / n) if n else math.nan

    def mx(x, sel):
        return float(np.max(np.abs(x[sel]))) if np.any(sel) else math.nan

    every = np.ones_like(half)
    return {"rms": rms(e, every), "max": mx(e, every), "rms_second_half": rms(e, half),
            "max_second_half": mx(e, half), "rms_reversal": rms(e, rev), "u_rms": rms(u, every)}, half, rev


def _case(seed, n=5000):
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.choice([0.0, 1e-3, 2e-3], n, p=[0.05, 0.9, 0.05]))  # repeated and skipped times
    e = rng.standard_normal(n) * 10.0 ** rng.uniform(-4, 2, n)  # errors over six decades
    u = rng.standard_normal(n) * 10.0 ** rng.uniform(-2, 2, n)
    e[rng.random(n) < 0.02] = 0.0
    revs = np.sort(rng.uniform(t[0] - 0.5, t[-1] + 0.5, int(rng.integers(1, 30))))
    window = float(rng.choice([0.0, 0.01, 0.1, 0.5]))
    return t, e, u, revs, window


@pytest.mark.parametrize("seed", range(8))
def test_loop_metrics_equal_the_brute_force_oracle(seed):
    t, e, u, revs, window = _case(seed)
    w_ref = np.sin(t)
    m = loop_metrics(t, w_ref, w_ref - e, u, reversals=revs[::-1], window=window)  # any order: sorted inside
    ref, half, rev = _oracle(t, w_ref - (w_ref - e), u, revs, window)
    for k in METRIC_NAMES:
        if math.isnan(ref[k]):
            assert math.isnan(getattr(m, k)), k
        else:
            assert getattr(m, k) == pytest.approx(ref[k], rel=4e-16, abs=0.0), k


def test_the_classifier_equals_the_nearest_reversal_rule():
    t, e, u, revs, window = _case(11, n=3000)
    revs = np.concatenate([revs[:3], revs[2:]])  # a repeated reversal time
    window = 0.05
    _, half, rev = _oracle(t, e, u, revs, window)
    ip, where = 0, []
    for tk in t.tolist():
        w, ip2 = metrics_where(tk, 0.5 * (t[0] + t[-1]), revs, window, ip)
        assert ip2 >= ip and (ip2 == 0 or revs[ip2 - 1] < tk or not tk >= 0.5 * (t[0] + t[-1]))
        ip = ip2
        where.append(w)
    where = np.array(where)
    np.testing.assert_array_equal(where, np.where(rev, 2, np.where(half, 1, 0)))
    assert np.count_nonzero(where == 2) > 50 and np.count_nonzero(where == 1) > 50
    # no reversals: second half only
    assert metrics_where(1.0, 0.5, np.empty(0), 1e9, 0) == (1, 0)
    assert metrics_where(0.1, 0.5, np.array([0.1]), 1.0, 0) == (0, 0)


def test_streamed_updates_equal_the_array_loop_and_python_faces():
    t, e, u, revs, window = _case(3, n=2000)
    tmid = 0.5 * (t[0] + t[-1])
    a, b, c = new_metrics(), new_metrics(), new_metrics()
    ip = 0
    for k in range(t.size):
        metrics_update(a, t[k], tmid, revs, window, e[k], u[k])
        w, ip = metrics_where(t[k], tmid, revs, window, ip)
        metrics_add(b, w, e[k], u[k])
    lib.ctl_metrics_accumulate(c, ffi.from_buffer("double[]", t), ffi.from_buffer("double[]", e),
                               ffi.from_buffer("double[]", u), t.size, tmid, ffi.from_buffer("double[]", revs),
                               revs.size, window)
    assert bytes(ffi.buffer(a)) == bytes(ffi.buffer(c))
    b.ip = a.ip  # metrics_add leaves the pointer alone
    assert bytes(ffi.buffer(a)) == bytes(ffi.buffer(b))
    assert a.n == t.size and a.n_half == np.count_nonzero(t >= tmid) and 0 < a.n_rev <= a.n_half
    assert a.e2 + a.e2_c == pytest.approx(math.fsum((e ** 2).tolist()), rel=1e-16)


def test_metrics_columns_equal_metrics_result_per_run_on_a_struct_array():
    rng = np.random.default_rng(7)
    B = 40
    arr = new_metrics(B)
    rec = np.frombuffer(ffi.buffer(arr), dtype=METRICS_DTYPE)  # a view of the C structs
    for name in METRICS_DTYPE.names:
        if METRICS_DTYPE[name].kind == "f":
            rec[name] = rng.uniform(0.0, 3.0, B) * (1e-17 if name.endswith("_c") else 1.0)
        else:
            rec[name] = rng.integers(1, 1000, B)
    rec["n"][::5] = 0  # empty run
    rec["n_half"][1::5] = 0  # no second-half samples
    rec["n_rev"][2::5] = 0  # no reversal window
    rec["e_max"][3::5] = math.nan  # a diverged run's maximum
    assert arr[3].n == rec["n"][3] and arr[4].e2_rev_c == rec["e2_rev_c"][4]
    cols = metrics_columns(arr)
    assert sorted(cols) == sorted(METRIC_NAMES)
    cols_np = metrics_columns(rec.copy())  # a numpy record array of the same layout
    for b in range(B):
        one = metrics_result(arr[b])
        one_p = metrics_result(ffi.addressof(arr, b))
        for k in METRIC_NAMES:
            assert _bits(cols[k][b]) == _bits(getattr(one, k)) == _bits(getattr(one_p, k)) == _bits(cols_np[k][b])
    assert math.isnan(cols["rms"][0]) and math.isnan(cols["rms_second_half"][1])
    assert math.isnan(cols["rms_reversal"][2]) and math.isnan(cols["max"][3])
    # analytic: sum of squares 8 (+ compensation 1) over 4 samples -> RMS 1.5
    s = new_metrics()
    s.e2, s.e2_c, s.n, s.e_max = 8.0, 1.0, 4, 2.5
    c = metrics_columns(s)
    assert c["rms"][0] == 1.5 and c["max"][0] == 2.5 and c["u_rms"][0] == 0.0
    assert math.isnan(c["rms_second_half"][0]) and math.isnan(c["max_second_half"][0])


def test_nan_propagates_and_a_short_run_reports_nan():
    m = new_metrics()
    for x in (1.0, -3.0, math.nan, 2.0):
        metrics_add(m, 1, x, 1.0)
    r = metrics_result(m)
    assert math.isnan(r.rms) and math.isnan(r.max) and math.isnan(r.max_second_half) and r.u_rms == 1.0
    m2 = new_metrics()
    for x in (1.0, -3.0, 2.0):
        metrics_add(m2, 2, x, 0.0)
    r2 = metrics_result(m2)
    assert r2.max == 3.0 and r2.rms_reversal == pytest.approx(math.sqrt(14.0 / 3.0), rel=1e-15)
    assert all(math.isnan(v) for v in metrics_result(m2, n_total=4).__dict__.values())
    assert metrics_result(m2, n_total=3) == r2


def test_bad_accumulator_arguments_are_named():
    with pytest.raises(ParameterError, match="states"):
        metrics_columns(np.zeros((3, 14)))
    with pytest.raises(ParameterError, match="states"):
        metrics_columns(ffi.new("double[3]"))
    with pytest.raises(ParameterError, match="st must be one"):
        metrics_result(new_metrics(2))
    with pytest.raises(ParameterError, match="n"):
        new_metrics(-1)
