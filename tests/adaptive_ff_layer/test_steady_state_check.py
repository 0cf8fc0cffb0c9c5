"""The model-form check of an answer against the log's steady state (adaptive_ff.identification.steady_state_check).

References derived differently: the static line's values and standard errors by scipy.optimize.curve_fit (a
nonlinear least-squares solver with its own covariance), the support points' torque at constant velocity by the
closed form F(w) of eq. 3.
"""

import json
import math

import numpy as np
import pytest
from scipy.optimize import curve_fit

from adaptive_ff.identification.identify import identify
from adaptive_ff.identification.steady_state_check import MISS_LIMIT, steady_state_check, with_steady_state_check
from adaptive_ff.io.data import MeasuredData
from plant.errors import ParameterError
from plant.friction import stribeck

# a friction-only log: the torque is F(w) of eq. 3 plus noise, as in a log whose rigid-body dynamics were removed
FC, FS, VS, DELTA, SIGMA, OFFSET = 4.7, 5.6, 0.002, 1.0, 200.0, 0.6


def _friction_only_log(seed: int = 0) -> MeasuredData:
    """40 s at 100 Hz: plateaus of 1.5 s at 10 speeds, each run in one direction then the other, 0.5 s ramps; and
    u = F(w) + offset + 0.3 N·m white noise."""
    rng = np.random.default_rng(seed)
    levels = np.ravel(np.column_stack([np.linspace(0.0008, 0.006, 10), -np.linspace(0.0008, 0.006, 10)]))
    t_knots, w_knots, t = [0.0], [0.0], 0.0
    for v in levels:
        t_knots += [t + 0.5, t + 2.0]
        w_knots += [v, v]
        t += 2.0
    tt = np.arange(0.0, t, 0.01)
    w = np.interp(tt, t_knots, w_knots)
    u = stribeck(w, Fc=FC, Fs=FS, Vs=VS, delta=DELTA, sigma=SIGMA) + OFFSET + 0.3 * rng.standard_normal(tt.size)
    return MeasuredData(tt, u, w + 1e-6 * rng.standard_normal(tt.size), source="friction-only log")


TRUTH = {"Fc": FC, "Fs": FS, "sigma": SIGMA, "offset": OFFSET}


def test_truth_passes_and_the_points_are_on_the_curve():
    c = steady_state_check(_friction_only_log(), TRUTH, Vs=VS, delta=DELTA)
    assert c is not None and c.point_method == "segments" and c.n_points == 20
    # each plateau's mean torque is F(w) of eq. 3 plus the offset, to the noise of its mean (0.3/sqrt(n))
    F = stribeck(c.w, Fc=FC, Fs=FS, Vs=VS, delta=DELTA, sigma=SIGMA) + OFFSET
    np.testing.assert_allclose(c.u, F, atol=0.15)
    assert not c.flagged
    assert c.relative_miss < 0.02


def test_an_answer_that_trades_friction_for_inertia_is_flagged_and_the_line_says_what_the_points_support():
    # the output-error fit on a real friction-only log: Fc a fifth, sigma five times (docs, "Real logs beyond EMPS")
    d = _friction_only_log()
    c = steady_state_check(d, {"Fc": FC / 5, "sigma": 5 * SIGMA, "offset": OFFSET})
    assert c.flagged and c.relative_miss > MISS_LIMIT and c.answer_miss > 2 * c.static["miss"]
    # the line's 95 % intervals hold the line through the noise-free curve at the same speeds (the Stribeck hump
    # lifts its Fc above FC), and the Coulomb level is off by the answer's factor of five
    F = stribeck(c.w, Fc=FC, Fs=FS, Vs=VS, delta=DELTA, sigma=SIGMA) + OFFSET
    exact = np.linalg.lstsq(np.column_stack([np.sign(c.w), c.w, np.ones_like(c.w)]), F, rcond=None)[0]
    for k, v in zip(("Fc", "sigma", "offset"), exact):
        lo, hi = c.static["interval95"][k]
        assert lo <= v <= hi, (k, v, lo, hi)
    assert c.static["interval95"]["Fc"][0] > 3 * FC / 5
    assert "does not reproduce the log's steady state" in c.message


def test_static_line_equals_an_independent_weighted_fit():
    c = steady_state_check(_friction_only_log(1), TRUTH, Vs=VS, delta=DELTA)
    d = _friction_only_log(1)
    from adaptive_ff.identification.steady_state import support_points

    pts = support_points(d, method="auto")
    se = pts.u_std / np.sqrt(pts.n_samples)
    popt, pcov = curve_fit(lambda w, Fc, sigma, off: Fc * np.sign(w) + sigma * w + off, pts.w_mean, pts.u_mean,
                           p0=[1.0, 1.0, 0.0], sigma=se, absolute_sigma=False)
    np.testing.assert_allclose([c.static["Fc"], c.static["sigma"], c.static["offset"]], popt, rtol=1e-6)
    np.testing.assert_allclose([c.static["std"][k] for k in ("Fc", "sigma", "offset")], np.sqrt(np.diag(pcov)),
                               rtol=1e-5)
    assert c.static["miss"] == pytest.approx(math.sqrt(np.mean((popt[0] * np.sign(pts.w_mean) + popt[1] * pts.w_mean
                                                                 + popt[2] - pts.u_mean) ** 2)), rel=1e-6)


def test_points_at_one_speed_do_not_determine_the_line():
    d = _friction_only_log()
    keep = np.abs(np.abs(d.w) - 0.006) < 2e-4  # the top plateau of each direction only
    d1 = MeasuredData(d.t[keep], d.u[keep], d.w[keep])
    c = steady_state_check(d1, TRUTH, Vs=VS, delta=DELTA)
    if c is not None:  # too few points is also an answer
        assert c.static is None


def test_identify_attaches_the_check_and_its_json_is_strict():
    d = _friction_only_log()
    # eq. 4 LS with the Stribeck structure: its curve passes the points
    rep = identify(d, Vs=VS, delta=DELTA, method="paper")
    c = rep.steady_state
    assert c is not None and not c.flagged
    assert c.message in rep.notes
    out = json.loads(json.dumps(rep.to_dict(), allow_nan=False))
    assert out["steady_state"]["n_points"] == 20 and out["steady_state"]["flagged"] is False
    # a flagged answer: the warning is "model_form"; a second check replaces the first one's note and warning
    from dataclasses import replace

    from adaptive_ff.identification.physical_id import PhysicalFit

    bad = PhysicalFit(method="output_error", params={"J": 480.0, "Fc": FC / 5, "Fs": FC / 5, "sigma": 5 * SIGMA,
                                                     "tau": 0.0, "offset": OFFSET},
                      stderr={}, cond=float("nan"), nrmse=50.0, n_samples=d.t.size, nrmse_kind="free-run", info={})
    flagged = with_steady_state_check(replace(rep, physical=bad), d)
    assert flagged.steady_state.flagged
    ss = [w for w in flagged.warnings if w.code == "model_form" and w.parameter == "all"]  # the check's own
    assert len(ss) == 1
    assert c.message not in flagged.notes and flagged.steady_state.message in flagged.notes
    again = with_steady_state_check(replace(flagged, physical=None), d)
    assert not again.steady_state.flagged and "all" not in [w.parameter for w in again.warnings
                                                            if w.code == "model_form"]


def test_a_log_without_steady_state_has_no_check():
    t = np.arange(0.0, 5.0, 1e-3)
    w = np.r_[-1.0 + 0.36 * t[:2500], 0.1 + 0.36 * t[:2500]]  # two ramps: the acceleration is never small
    assert steady_state_check(MeasuredData(t, 3.0 * np.sign(w), w), TRUTH) is None
    rep = identify(MeasuredData(t, 3.0 * np.sign(w) + 0.5 * np.gradient(w, t), w), method="paper")
    assert rep.to_dict()["steady_state"] is None


def test_bad_arguments_are_named():
    d = _friction_only_log()
    with pytest.raises(TypeError, match="MeasuredData"):
        steady_state_check((d.t, d.u, d.w), TRUTH)
    with pytest.raises(ParameterError, match="sigma"):
        steady_state_check(d, {"Fc": 1.0})
    with pytest.raises(ParameterError, match="Fc"):
        steady_state_check(d, {"Fc": math.nan, "sigma": 1.0})


def test_attach_physical_checks_the_new_answer_or_drops_the_old_check():
    from adaptive_ff.identification.identify import attach_physical
    from adaptive_ff.identification.physical_id import PhysicalFit

    d = _friction_only_log()
    rep = identify(d, Vs=VS, delta=DELTA, method="paper")
    bad = PhysicalFit(method="output_error", params={"J": 480.0, "Fc": FC / 5, "Fs": FC / 5, "sigma": 5 * SIGMA,
                                                     "tau": 0.0, "offset": OFFSET},
                      stderr={}, cond=float("nan"), nrmse=50.0, n_samples=d.t.size, nrmse_kind="free-run", info={})
    checked = attach_physical(rep, bad, note="a fit made elsewhere", data=d)
    assert checked.steady_state.flagged and rep.steady_state.message not in checked.notes
    assert [w.code for w in checked.warnings].count("model_form") == 1
    dropped = attach_physical(checked, bad, note="again, without the log")
    assert dropped.steady_state is None and "model_form" not in [w.code for w in dropped.warnings]
    assert checked.steady_state.message not in dropped.notes
