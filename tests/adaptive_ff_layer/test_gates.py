"""The input gates against their rules as the oracles write them, on streams that straddle the bounds.

:class:`adaptive_ff.compensation.gate.OutlierGate` against tests/compensation_oracle.py ``OutlierGate`` (the jump
bound ``(max_step + n_sigma*scale)*(1 + n_held)``, the running scale, the release after ``max_consecutive``) and
:class:`adaptive_ff.compensation.gate.RangeGate` against tests/peers_oracle.py ``Range`` (the bound ``factor``
times the decaying envelope or the floor, ``x_max``, the release). In the closed-loop tests the faults are far
beyond every bound, so a bound off by a factor would pass there; here the jumps and magnitudes are drawn across
the bounds (a factor of 10 either way), so every decision depends on them. Decisions and counters must agree
exactly, the running scale and envelope to rounding.
"""

import math

import numpy as np
import pytest

from adaptive_ff.compensation.gate import OutlierGate, RangeGate
from compensation_oracle import OutlierGate as OracleGate
from peers_oracle import Range


def _jumps(seed, n=20000):
    """A slow random walk with spikes whose size spans 0.1x to 10x ``max_step``, bursts and non-finite samples."""
    rng = np.random.default_rng(seed)
    x = np.cumsum(rng.normal(0.0, 1e-3, n))
    spike = rng.random(n) < 0.05
    x[spike] += rng.choice([-1.0, 1.0], spike.sum()) * 10.0 ** rng.uniform(-1.0, 1.0, spike.sum()) * 0.01
    for s in rng.integers(0, n - 40, 5):  # bursts: a level shift held for up to 30 samples
        x[s:s + int(rng.integers(5, 30))] += 1.0
    bad = rng.random(n) < 0.002
    x[bad] = rng.choice([math.nan, math.inf, -math.inf], bad.sum())
    return x


@pytest.mark.parametrize("kw", [dict(max_step=0.01), dict(max_step=0.005, n_sigma=3.0, alpha=0.05),
                                dict(max_step=0.002, n_sigma=20.0, max_consecutive=5), dict()])
def test_outlier_gate_decisions_equal_the_rule(kw):
    x = _jumps(1)
    g, o = OutlierGate(**kw), OracleGate(**kw)
    got = np.array([g.check(v) for v in x.tolist()])
    want = np.array([o.check(v) for v in x.tolist()])
    np.testing.assert_array_equal(got, want)
    assert g.n_rejected == o.n_rejected and g.n_nonfinite == int(np.count_nonzero(~np.isfinite(x)))
    assert g.scale == pytest.approx(o.scale, rel=1e-12) and g.last == o.last
    if kw.get("max_step", math.inf) < math.inf:
        assert 200 < g.n_outliers < 0.2 * x.size  # the bound decided often, both ways


def _magnitudes(seed, n=20000):
    """A noisy level of 1 with excursions of 10x to 500x on 3 % of the samples (across the relative bounds once
    the short-memory envelope has decayed after the last one) and non-finite samples."""
    rng = np.random.default_rng(seed)
    x = rng.normal(1.0, 0.3, n)
    far = rng.random(n) < 0.03
    x[far] *= 10.0 ** rng.uniform(1.0, 2.7, far.sum())
    x[rng.random(n) < 0.002] = math.nan
    return x


@pytest.mark.parametrize("kw", [dict(memory=5.0), dict(factor=20.0, memory=3.0),
                                dict(floor=2.0, factor=50.0, max_consecutive=3, memory=5.0),
                                dict(x_max=50.0, factor=1e3, memory=5.0)])
def test_range_gate_decisions_equal_the_rule(kw):
    x = _magnitudes(2)
    g = RangeGate(**kw)
    o = Range(**kw)
    got = np.array([g.check(v) for v in x.tolist()])
    want = []
    for v in x.tolist():
        ok = o.ok(v)
        o.commit(v, ok)
        want.append(ok)
    np.testing.assert_array_equal(got, np.array(want))
    assert g.n_rejected == o.n_rejected and g.envelope == pytest.approx(o.env, rel=1e-12)
    assert 100 < g.n_rejected < 0.2 * x.size  # the bound decided often, both ways
