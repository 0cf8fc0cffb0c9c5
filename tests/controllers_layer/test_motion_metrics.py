"""Motion metrics (error in motion and at standstill, settling after each stop, error at each reversal) against an
independent numpy computation of their definitions (controllers/csrc/ctl_metrics.h, MotionMetrics) on the recorded
runs, an analytic settling time, and the edge cases: no stops, a stop that never settles, a diverged run."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from controllers.design.pi import PIController, design_pi
from controllers.simulation.batch import run_batch
from controllers.simulation.closed_loop import LoopConfig, RunSettings, run_closed_loop, run_mode
from controllers.simulation.metrics import SETTLE_SHARE, motion_metrics, reversal_times, stop_intervals
from plant.errors import ParameterError
from plant.excitation import Reference, multisine_reference
from plant.friction import preset
from plant.motion import point_to_point_reference, reversing_reference

DT = 1e-3
TARGETS = [0.5, -0.2, 0.4, 0.0, 0.6, -0.3]


def oracle(t, w_ref, w, revs, window, share=SETTLE_SHARE, floor=0.0):
    """The motion metrics written from their definitions with numpy (not from the C)."""
    n = t.size
    e = w_ref - w
    zero = w_ref == 0.0
    neighbour = np.zeros(n, dtype=bool)
    neighbour[1:] |= zero[:-1]
    neighbour[:-1] |= zero[1:]
    neighbour[[0, -1]] = True
    rest = zero & neighbour  # runs of >= 2 zeros, or a zero at either end
    half = t >= 0.5 * (t[0] + t[-1])
    mv, st = e[half & ~rest], e[half & rest]
    out = {"rms_motion": math.sqrt(np.mean(mv ** 2)) if mv.size else math.nan,
           "rms_standstill": math.sqrt(np.mean(st ** 2)) if st.size else math.nan,
           "max_standstill": float(np.max(np.abs(st))) if st.size else math.nan}
    starts = [k for k in range(1, n) if rest[k] and not rest[k - 1]]
    t0, t1, band, settle, smax = [], [], [], [], []
    for k0 in starts:
        after = np.flatnonzero(~rest[k0:])
        k1 = k0 + after[0] if after.size else n  # one past the stop's last sample
        before = np.flatnonzero(rest[:k0])
        peak = float(np.max(np.abs(w_ref[before[-1] + 1 if before.size else 0:k0])))
        b = max(share * peak, floor)
        outside = np.abs(e[k0:k1]) > b
        if outside[-1]:
            s = math.inf
        elif not outside.any():
            s = 0.0
        else:
            s = t[k0 + np.flatnonzero(outside)[-1] + 1] - t[k0]
        t0.append(t[k0]), t1.append(t[k1 - 1]), band.append(b), settle.append(s)
        smax.append(float(np.max(np.abs(e[k0:k1]))))
    out.update(stop_start=np.array(t0), stop_end=np.array(t1), settling_band=np.array(band),
               settling_time=np.array(settle), stop_max=np.array(smax))
    rmax = np.full(revs.size, math.nan)
    if revs.size:
        d = np.abs(t[:, None] - revs[None, :])
        j = np.argmin(d, axis=1)  # the first of equal distances: the earlier reversal
        inside = d[np.arange(n), j] <= window
        for r in range(revs.size):
            sel = inside & (j == r)
            if sel.any():
                rmax[r] = float(np.max(np.abs(e[sel])))
    out["reversal_max"] = rmax
    return out


def assert_matches(m, o, rtol=1e-12):
    for k in ("rms_motion", "rms_standstill"):
        assert getattr(m, k) == pytest.approx(o[k], rel=rtol, nan_ok=True), k
    assert m.max_standstill == o["max_standstill"] or (math.isnan(m.max_standstill) and math.isnan(o["max_standstill"]))
    for k in ("stop_start", "stop_end", "settling_band", "settling_time", "stop_max", "reversal_max"):
        np.testing.assert_array_equal(getattr(m, k), o[k], err_msg=k)


def _loop(noise=1e-3):
    p = preset("paper")
    d = design_pi(p.J, crossover=20.0, phase_margin=60.0, Tc=DT)
    return p, LoopConfig.from_flat(Kp=d.Kp, Ki=d.Ki, u_max=150.0, Vs=p.Vs, delta=p.delta, noise_std=noise)


@pytest.fixture(scope="module")
def p2p_runs():
    p, o = _loop()
    ref = point_to_point_reference(TARGETS, v_max=0.5, a_max=4.0, dwell=0.5)
    return p, o, ref, {m: run_mode(p, ref, m, o, rng=np.random.default_rng(3)) for m in ("none", "adaptive")}


def test_point_to_point_run_equals_the_numpy_definitions(p2p_runs):
    _, _, ref, runs = p2p_runs
    revs = reversal_times(ref.t, ref.w)
    for mode, r in runs.items():
        m = r.motion
        assert m.n_stops == len(TARGETS) and np.array_equal(m.stop_start, ref.stops())
        assert_matches(m, oracle(r.t, r.w_ref, r.w, revs, 0.2))
        again = motion_metrics(r.t, r.w_ref, r.w, reversals=revs, window=0.2)  # the recorded run through the C
        for k in ("rms_motion", "rms_standstill", "max_standstill"):
            assert getattr(again, k) == getattr(m, k)
        np.testing.assert_array_equal(again.settling_time, m.settling_time)
    # the error at rest is what the metrics say it is: the stick of the uncompensated joint holds it; the adaptive
    # feedforward's first stop (before it learned) does not settle into 2 % before the next move
    none, ad = runs["none"].motion, runs["adaptive"].motion
    assert np.all(np.isfinite(none.settling_time)) and np.all(none.settling_band == pytest.approx(0.02 * 0.5, rel=1e-3))
    assert ad.n_unsettled == int(np.count_nonzero(np.isinf(ad.settling_time[ad.stop_start >= ad.t_mid])))
    late = ad.settling_time[ad.stop_start >= ad.t_mid]
    assert ad.settling_max == np.max(late) and ad.settling_median == np.median(late)


def test_reversing_run_errors_at_each_reversal_and_the_stop_at_its_end():
    p, o = _loop()
    ref = reversing_reference(0.3, hold=1.0, accel=3.0, n_reversals=5, end_dwell=0.0)
    r = run_mode(p, ref, "none", o, rng=np.random.default_rng(5))
    revs = ref.reversals()
    m = r.motion
    assert m.n_reversals == 5 and np.array_equal(m.reversal_times, revs)
    o_ = oracle(r.t, r.w_ref, r.w, revs, 0.2)
    assert_matches(m, o_)
    assert np.all(np.isfinite(m.reversal_max)) and np.all(m.reversal_max > 0)
    late = revs >= m.t_mid
    assert m.max_reversal == np.max(o_["reversal_max"][late])
    # the reference reaches rest on its last sample: a stop the run ends in, with the error still outside the band
    assert m.n_stops == 1 and m.stop_start[0] == m.stop_end[0] == ref.t[-1]
    assert m.settling_time[0] == math.inf and m.n_unsettled == 1
    d = json.loads(json.dumps(r.to_dict(), allow_nan=False))
    assert d["motion"]["stops"][0]["settled"] is False and d["motion"]["stops"][0]["settling_time"] is None
    assert d["motion"]["settling_max"] is None and d["motion"]["n_unsettled"] == 1
    assert "did not settle" in r.summary()
    # with the default final dwell (0.5 s) the last stop is one whose settling is measured
    r2 = run_mode(p, reversing_reference(0.3, hold=1.0, accel=3.0, n_reversals=5), "none", o,
                  rng=np.random.default_rng(5))
    m2 = r2.motion
    assert m2.n_stops == 1 and m2.stop_end[0] - m2.stop_start[0] == pytest.approx(0.5, abs=2e-3)
    assert_matches(m2, oracle(r2.t, r2.w_ref, r2.w, revs, 0.2))


def test_batch_scenarios_have_their_own_event_arrays_equal_to_single_runs(p2p_runs):
    p, o, ref, _ = p2p_runs
    plants = [p, preset("paper"), p]
    b = run_batch(plants, ref, "adaptive", o, seeds=[3, 11, 12])
    revs = reversal_times(ref.t, ref.w)
    assert len(b.motion) == 3 and b.has_stops
    for i, seed in enumerate((3, 11, 12)):
        one = run_mode(plants[i], ref, "adaptive", o, rng=np.random.default_rng(seed))
        m = b.motion[i]
        for k in ("rms_motion", "rms_standstill", "max_standstill"):
            assert getattr(m, k) == getattr(one.motion, k)
        for k in ("settling_time", "stop_max", "reversal_max", "settling_band"):
            np.testing.assert_array_equal(getattr(m, k), getattr(one.motion, k))
        assert_matches(m, oracle(one.t, one.w_ref, one.w, revs, 0.2))
    assert not np.array_equal(b.motion[0].stop_max, b.motion[1].stop_max)  # per scenario, not shared
    np.testing.assert_array_equal(b.motion_column("rms_motion"), [m.rms_motion for m in b.motion])
    d = json.loads(json.dumps(b.to_dict(), allow_nan=False))
    assert len(d["motion"]) == 3 and len(d["motion"][1]["stops"]) == len(TARGETS)
    assert "in motion RMS" in b.summary()


def _decay_case(e0, T, V=0.5, dwell=1.0, floor=0.0):
    """A ramp to V and back to rest, then a dwell in which the error decays as e0*exp(-(t - t0)/T)."""
    up = np.linspace(0.0, V, 201)[1:]
    w_ref = np.concatenate([np.zeros(1500), up, up[::-1][1:], np.zeros(int(round(dwell / DT)))])
    t = np.arange(w_ref.size) * DT  # 1.5 s at rest first: the stop is in the second half
    k0 = 1500 + 2 * up.size - 1
    e = np.zeros_like(t)
    e[k0:] = e0 * np.exp(-(t[k0:] - t[k0]) / T)
    return t, w_ref, w_ref - e, t[k0]


@pytest.mark.parametrize("e0, T", [(0.2, 0.05), (0.05, 0.2), (0.011, 0.1)])
def test_settling_of_an_exponential_decay_is_T_ln_e0_over_b(e0, T):
    t, w_ref, w, t0 = _decay_case(e0, T)
    m = motion_metrics(t, w_ref, w, reversals=[])
    b = 0.02 * 0.5
    assert m.n_stops == 1 and m.stop_start[0] == t0 and m.settling_band[0] == pytest.approx(b, rel=1e-12)
    assert abs(m.settling_time[0] - T * math.log(e0 / b)) <= DT
    assert m.stop_max[0] == pytest.approx(e0, rel=1e-12)
    # a floor above 2 % of the peak is the band
    mf = motion_metrics(t, w_ref, w, reversals=[], floor=0.02)
    assert mf.settling_band[0] == 0.02 and abs(mf.settling_time[0] - max(T * math.log(e0 / 0.02), 0.0)) <= DT
    assert mf.settling_time[0] == 0.0 or e0 > 0.02
    # an error inside the band from the start settles at once
    assert motion_metrics(t, w_ref, w_ref - 1e-3 * (w_ref == 0), reversals=[]).settling_time[0] == 0.0


def test_a_stop_that_never_settles_is_reported_as_such():
    t, w_ref, w, _ = _decay_case(0.2, 5.0)  # decays far too slowly for the 1 s dwell
    m = motion_metrics(t, w_ref, w, reversals=[])
    assert m.settling_time[0] == math.inf and m.n_unsettled == 1 and m.settling_max == math.inf
    d = json.loads(json.dumps(m.to_dict(), allow_nan=False))
    assert d["stops"][0] == {"t_start": m.stop_start[0], "t_end": t[-1], "band": m.settling_band[0],
                             "settling_time": None, "settled": False, "max": d["stops"][0]["max"]}
    assert d["settling_max"] is None and d["n_unsettled"] == 1


def test_a_reference_without_stops_gives_empty_arrays_and_keeps_the_json_of_the_multisine():
    p, o = _loop()
    ref = multisine_reference(6.0, rng=np.random.default_rng(0))
    r = run_mode(p, ref, "none", o, rng=np.random.default_rng(0))
    m = r.motion
    assert m.n_stops == 0 and m.stop_start.shape == m.settling_time.shape == (0,)
    assert not r.has_stops and "motion" not in r.to_dict()
    assert m.n_reversals == ref.reversals().size > 0
    assert_matches(m, oracle(r.t, r.w_ref, r.w, ref.reversals(), 0.2))
    d = m.to_dict()
    json.dumps(d, allow_nan=False)
    assert d["stops"] == [] and d["settling_median"] is None and d["settling_max"] is None
    assert d["n_unsettled"] == 0 and d["rms_standstill"] is None and d["rms_motion"] is not None


def test_a_diverged_run_keeps_the_events_it_completed_and_nothing_else():
    p, o = _loop(noise=0.0)
    slow = point_to_point_reference([0.2, 0.0], v_max=0.2, a_max=2.0, dwell=0.5)
    fast = point_to_point_reference([0.6], v_max=0.6, a_max=4.0, dwell=0.5, start_dwell=0.0)
    w = np.concatenate([slow.w, fast.w])
    ref = Reference(t=np.arange(w.size) * DT, w=w, dw=np.gradient(w, DT))
    ctl = PIController(Kp=o.controller.Kp, Ki=o.controller.Ki, Tc=DT, u_max=150.0)
    r = run_closed_loop(p, ctl, None, ref, settings=RunSettings(w_limit=0.4))  # the third move exceeds 0.4 rad/s
    assert r.info["diverged"]
    m = r.motion
    assert m.n_stops == 3 and math.isnan(m.rms_motion) and math.isnan(m.max_standstill)
    done = np.isfinite(r.w)  # the samples the run reached
    k_end = int(np.count_nonzero(done))
    o_ = oracle(r.t[:k_end], r.w_ref[:k_end], r.w[:k_end], np.array([]), 0.2)
    np.testing.assert_array_equal(m.settling_time[:2], o_["settling_time"][:2])
    np.testing.assert_array_equal(m.stop_max[:2], o_["stop_max"][:2])
    assert math.isnan(m.settling_time[2]) and math.isnan(m.stop_max[2])
    d = json.loads(json.dumps(r.to_dict(), allow_nan=False))
    assert d["motion"]["stops"][2]["settled"] is None and d["motion"]["stops"][2]["settling_time"] is None
    assert d["motion"]["rms_motion"] is None and d["motion"]["settling_max"] is None
    # a batch with one diverging scenario: each scenario as its single run

    opts = [o.replace(w_limit=0.4), o]
    b = run_batch([p, p], ref, "none", opts)
    assert list(b.diverged) == [True, False]
    for i in range(2):
        one = run_mode(p, ref, "none", opts[i]).motion
        for k in ("settling_time", "stop_max"):
            np.testing.assert_array_equal(getattr(b.motion[i], k), getattr(one, k))
        np.testing.assert_equal(b.motion[i].rms_motion, one.rms_motion)  # NaN for the diverged one
    assert math.isnan(b.motion[0].settling_time[2]) and np.isfinite(b.motion[1].settling_time).all()


def test_stop_intervals_are_the_reference_stops_and_refuse_bad_bands():
    ref = point_to_point_reference([1.0, 1.0, -0.5], v_max=2.0, a_max=10.0, dwell=0.4, start_dwell=0.25)
    a, b, band = stop_intervals(ref.t, ref.w, share=0.05, floor=0.0)
    assert np.array_equal(a, ref.stops())
    assert np.all(ref.w[(ref.t >= a[0]) & (ref.t <= b[0])] == 0.0) and ref.w[np.searchsorted(ref.t, b[0]) + 1] != 0
    assert band == pytest.approx(0.05 * np.array([2.0, 2.0]), rel=1e-3)
    with pytest.raises(ParameterError, match="share"):
        stop_intervals(ref.t, ref.w, share=-0.1)
    with pytest.raises(ParameterError, match="floor"):
        stop_intervals(ref.t, ref.w, floor=math.inf)


def test_plot_marks_dwells_settling_and_reversals(p2p_runs):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    r = p2p_runs[3]["adaptive"]
    ax = r.plot()
    labels = ax.get_legend_handles_labels()[1]
    assert {"dwell", "settled"} <= set(labels)
    n_inf = int(np.count_nonzero(np.isinf(r.motion.settling_time)))
    assert ("not settled" in labels) == (n_inf > 0)
    plt.close(ax.figure)


# --------------------------------------------------------------------------- comparison table, JSON and figures


def _comparison(ref, modes=("none", "adaptive", "frictionless")):
    from adaptive_ff.identification.regression import RegressionModel
    from controllers.experiments.comparison import Comparison, eta_or_none, whole_run_metrics

    p, o = _loop()
    d = design_pi(p.J, crossover=20.0, phase_margin=60.0, Tc=DT)
    res = {m: run_mode(p, ref, m, o, rng=np.random.default_rng(3)) for m in modes}
    rn, rf = res["none"].metrics.rms_second_half, res["frictionless"].metrics.rms_second_half
    etas = {m: eta_or_none(rn, r.metrics.rms_second_half, rf) for m, r in res.items()}
    return Comparison(plant=p, design=d, results=res, eta=etas, prefit=None, offline=None,
                      model=RegressionModel(p.Vs, p.delta, lag=True), **whole_run_metrics(res))


BASE_KEYS = {"mode", "rms", "max", "rms_reversal", "u_rms", "eta", "eta_full", "rms_dev", "t_ff_on"}


@pytest.fixture(scope="module")
def p2p_comparison():
    return _comparison(point_to_point_reference(TARGETS, v_max=0.5, a_max=4.0, dwell=0.5))


def test_comparison_rows_table_and_json_carry_the_motion_metrics(p2p_comparison):
    import argparse

    from controllers.cli.compare import comparison_table

    c = p2p_comparison
    assert c.has_stops
    for row in c.rows():
        m = c.results[row["mode"]].motion
        assert set(row) == BASE_KEYS | {"rms_motion", "settling_max", "n_unsettled", "max_reversal"}
        assert row["rms_motion"] == m.rms_motion and row["settling_max"] == m.settling_max
        assert row["n_unsettled"] == m.n_unsettled and math.isnan(row["max_reversal"])  # no reversal in these moves
        late = m.settling_time[m.stop_start >= m.t_mid]
        assert row["settling_max"] == np.max(late)
    table = c.table()
    assert "motion RMS" in table and "settle max [s]" in table
    adaptive = next(line for line in table.splitlines() if line.startswith("adaptive"))
    assert f"{c.results['adaptive'].motion.settling_max:.3f}" in adaptive
    assert f"{np.rad2deg(c.results['adaptive'].motion.rms_motion):.4f}" in adaptive
    cli = comparison_table(c, argparse.Namespace(units="rad"))
    assert "motion RMS [rad/s]" in cli and f"{c.results['none'].motion.rms_motion:.4f}" in cli
    d = json.loads(json.dumps(c.to_dict(), allow_nan=False))
    assert d["modes"]["adaptive"]["n_unsettled"] == c.results["adaptive"].motion.n_unsettled
    assert d["modes"]["none"]["max_reversal"] is None
    assert len(d["motion"]["adaptive"]["stops"]) == len(TARGETS)


def test_a_multisine_comparison_keeps_its_rows_and_table():
    c = _comparison(multisine_reference(6.0, rng=np.random.default_rng(2)))
    assert not c.has_stops
    assert all(set(r) == BASE_KEYS for r in c.rows())
    assert "motion" not in c.table() and "motion" not in c.to_dict()


def test_figures_of_a_comparison_with_stops_show_them_and_pass_the_figure_checks(p2p_comparison):
    from test_figures_quality import check_figure

    from controllers.report import figures as F

    c = p2p_comparison
    t0 = F.pick_stop(c)
    a = c.results["none"].motion.stop_start
    assert t0 in a and t0 >= c.results["none"].motion.t_mid
    inputs = F.figure_inputs(c)
    np.testing.assert_array_equal(inputs["tracking"]["stops"][0], a)
    assert inputs["tracking"]["t0"] == t0 and set(inputs["tracking"]["zoom_stop"]["settle"]) <= set(c.results)
    assert set(inputs["error"]["motion"]) == set(c.results)
    for f in F._FIGURES:
        fig = getattr(F, f"plot_{f.name}")(c)
        if fig is not None:
            check_figure(fig, f.name)
    ax = c.results["adaptive"].plot()
    check_figure(ax.figure, "ClosedLoopResult.plot with stops")
    assert F.pick_stop(_comparison(multisine_reference(4.0, rng=np.random.default_rng(1)))) is None
