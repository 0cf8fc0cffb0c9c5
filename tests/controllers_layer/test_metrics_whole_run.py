"""Whole-run metrics of the comparison: eta over the whole run, the RMS deviation from the
frictionless run and the time the compensation first acts, checked against analytic values and independent
numpy computations on the recorded runs."""

import json
import math

import numpy as np
import pytest

from controllers.experiments.compare import compare, eta
from controllers.simulation.metrics import deviation_rms, first_active_time
from plant.errors import SignalError
from plant.friction import preset


def test_deviation_rms_analytic():
    t = np.arange(100_000) * 1e-4
    assert deviation_rms(np.sin(2 * np.pi * t) + 0.5, np.full_like(t, 0.5)) == pytest.approx(math.sqrt(0.5),
                                                                                           rel=1e-9)
    assert deviation_rms([1.0, 3.0], [1.0, -1.0]) == pytest.approx(math.sqrt(8.0), rel=1e-15)
    assert math.isnan(deviation_rms([1.0, np.nan], [0.0, 0.0])) and math.isnan(deviation_rms([], []))
    with pytest.raises(SignalError, match="same shape"):
        deviation_rms([1.0, 2.0], [1.0])


def test_first_active_time():
    t = np.array([0.0, 0.1, 0.2, 0.3])
    assert first_active_time(t, [0.0, np.nan, 0.0, -2.0]) == 0.3
    assert first_active_time(t, [1e-300, 0.0, 0.0, 0.0]) == 0.0
    assert first_active_time(t, np.zeros(4)) is None and first_active_time(t[:0], t[:0]) is None
    with pytest.raises(SignalError, match="same shape"):
        first_active_time(t, [0.0])


@pytest.fixture(scope="module")
def comp():
    return compare(preset("paper"), duration=8.0, seed=3, modes=("adaptive", "adaptive-dob", "dob", "oracle"),
                   progress=False)


def test_comparison_whole_run_metrics_equal_independent_computation(comp):
    R = comp.results
    wf = R["frictionless"].w
    rn, rf = (float(np.sqrt(np.mean((R[m].w_ref - R[m].w) ** 2))) for m in ("none", "frictionless"))
    for m, r in R.items():
        assert comp.rms_dev[m] == pytest.approx(float(np.sqrt(np.mean((r.w - wf) ** 2))), rel=1e-12)
        assert comp.eta_full[m] == pytest.approx(eta(rn, float(np.sqrt(np.mean((r.w_ref - r.w) ** 2))), rf), rel=1e-9)
    assert comp.eta_full["none"] == 0.0 and comp.eta_full["frictionless"] == 1.0 and comp.rms_dev["frictionless"] == 0.0
    assert comp.t_ff_on["none"] is None and comp.t_ff_on["frictionless"] is None
    assert comp.t_ff_on["dob"] == pytest.approx(1e-3, abs=1e-12)  # the observer acts from its second sample on
    for m in ("adaptive", "adaptive-dob"):
        k = int(np.flatnonzero(R[m].u_ff != 0)[0])
        assert comp.t_ff_on[m] == R[m].t[k] and (k == 0 or R[m].u_ff[k - 1] == 0.0)
        # the provisional start map at the (noisy, non-zero) measurement acts from the first period
        # (tests/adaptive_ff_layer/test_fast_start.py pins what it gains)
        assert comp.t_ff_on[m] <= 1e-3


def test_comparison_json_and_table_carry_the_whole_run_metrics(comp):
    d = json.loads(json.dumps(comp.to_dict(), allow_nan=False))
    for m, row in d["modes"].items():
        assert {"eta_full", "rms_dev", "t_ff_on"} <= set(row)
        assert row["rms_dev"] == pytest.approx(comp.rms_dev[m], rel=1e-15)
    assert d["modes"]["none"]["t_ff_on"] is None and d["modes"]["dob"]["t_ff_on"] == pytest.approx(1e-3)
    text = comp.table()
    assert "eta full" in text and "t_on [s]" in text
    line = next(ln for ln in text.splitlines() if ln.startswith("dob "))
    assert line.split()[-1] == "0.001" and f"{np.rad2deg(comp.rms_dev['dob']):.4f}" in line
