"""References a robot runs (plant/motion.py) and a reference read from a file (adaptive_ff/io/references.py).

The profiles are checked against their closed forms (Biagiotti & Melchiorri 2008, Sec. 3.2: a trapezoid of
duration ``D/v_max + v_max/a_max``, a triangle peaking at ``sqrt(D*a_max)``), the positions against the targets,
the jerk of the S-curve against ``j_max``, and the file reader against the analytic signals it was written from.
"""

import math

import numpy as np
import pytest

from adaptive_ff.io.logs import LogUnits
from adaptive_ff.io.references import load_reference
from controllers.simulation.metrics import reversal_times
from plant.errors import ParameterError, SignalError
from plant.motion import point_to_point_reference, reversing_reference, trapezoid_profile

DT = 1e-3


@pytest.mark.parametrize("D,v,a", [(1.0, 2.0, 10.0), (0.3, 2.0, 10.0), (2.5, 0.8, 3.0), (0.05, 1.0, 50.0)])
def test_trapezoid_against_its_closed_form(D, v, a):
    w, dw = trapezoid_profile(D, v, a, DT)
    v_peak = min(v, math.sqrt(D * a))
    T = D / v_peak + v_peak / a  # cruise D/v_peak - v_peak/a plus two ramps of v_peak/a
    assert math.isclose(np.sum(w) * DT, D, rel_tol=1e-12)
    assert w[-1] == 0.0 and np.all(w[:-1] > 0)
    assert abs(w.size * DT - T) <= DT * (1 + 1e-9)
    scale = 1 + (a * DT / v_peak) ** 2
    assert v_peak - a * DT / 2 * scale <= np.max(w) <= v_peak * scale  # a triangle's peak may fall between samples
    t = np.arange(1, w.size + 1) * DT
    exact = np.minimum.reduce([a * t, np.full(t.size, v_peak), np.maximum(a * (T - t), 0.0)])
    np.testing.assert_allclose(w, exact, atol=a * DT ** 2 / D * v_peak + 1e-12)
    assert np.max(np.abs(dw)) == a


def test_s_curve_keeps_jerk_acceleration_and_positions():
    r = point_to_point_reference([1.0, 0.25, 1.5], v_max=2.0, a_max=10.0, j_max=200.0, dwell=0.3, start_dwell=0.2)
    jerk = np.diff(r.dw) / DT
    assert np.max(np.abs(jerk)) <= 200.0 * (1 + 1e-9)
    assert np.max(np.abs(r.dw)) <= 10.0 * (1 + 1e-12)
    q = np.cumsum(r.w) * DT
    stops = np.searchsorted(r.t, r.stops())
    np.testing.assert_allclose(q[stops], [1.0, 0.25, 1.5], atol=1e-12)
    # a trapezoid's acceleration jumps; the S-curve's ramps over a_max/j_max = 50 ms
    t_acc = r.dw > 0
    first = np.flatnonzero(t_acc)[0]
    assert 0.0 < r.dw[first] < 10.0 / 40


def test_point_to_point_dwells_stops_and_reversals():
    r = point_to_point_reference([1.0, 1.0, -0.5], v_max=2.0, a_max=10.0, dwell=0.4, start_dwell=0.25)
    assert np.all(r.w[:250] == 0.0)
    stops = r.stops()
    assert stops.size == 2  # the repeated target adds a dwell, not a stop
    T1 = 1.0 / 2.0 + 2.0 / 10.0
    assert abs(stops[0] - (0.25 + T1)) <= DT * (1 + 1e-9)
    k = np.searchsorted(r.t, stops[0])
    assert np.all(r.w[k:k + 800] == 0.0)  # two dwells of 0.4 s
    assert r.reversals().size == 0  # a stop and a start, not a reversal
    q = np.cumsum(r.w) * DT
    assert math.isclose(q[-1], -0.5, abs_tol=1e-12)
    touch = point_to_point_reference([1.0, -0.5], v_max=2.0, a_max=10.0, dwell=0.0, start_dwell=0.0)
    assert touch.reversals().size == 1 and touch.stops().size == 1  # the end only


def test_reversing_reference_reverses_where_the_ramps_cross_zero():
    speed, hold, accel, n = 0.5, 1.0, 5.0, 5
    r = reversing_reference(speed, hold=hold, accel=accel, n_reversals=n, start_dwell=0.3)
    tr = speed / accel
    crossings = 0.3 + 2 * tr + hold + np.arange(n) * (hold + 2 * tr)
    revs = r.reversals()
    assert revs.size == n
    np.testing.assert_allclose(revs, crossings, atol=DT * (1 + 1e-9))
    assert np.max(np.abs(r.w)) == speed and np.max(np.abs(r.dw)) <= accel * (1 + 1e-12)
    assert r.stops().size == 1 and r.w[-1] == 0.0
    for chunk in (1, 2, 3, 700, 1 << 16):  # the engine's chunked reversal times agree
        np.testing.assert_array_equal(reversal_times(r.t, r.w, chunk=chunk), revs)


def test_a_zero_crossing_on_a_sample_is_a_reversal():
    t = np.arange(7) * DT
    w = np.array([0.0, 1.0, 0.0, -1.0, 0.0, 0.0, 1.0])
    from plant.excitation import Reference
    r = Reference(t=t, w=w, dw=np.zeros(7))
    np.testing.assert_array_equal(r.reversals(), [t[2]])
    np.testing.assert_array_equal(r.stops(), [t[4]])
    for chunk in (1, 2, 3, 10):
        np.testing.assert_array_equal(reversal_times(t, w, chunk=chunk), [t[2]])


@pytest.mark.parametrize("kwargs,match", [
    (dict(targets=[], v_max=1.0, a_max=1.0), "targets"),
    (dict(targets=[1.0, math.nan], v_max=1.0, a_max=1.0), r"targets\[1\]"),
    (dict(targets=[1.0], v_max=0.0, a_max=1.0), "v_max"),
    (dict(targets=[1.0], v_max=1.0, a_max=1.0, j_max=-1.0), "j_max"),
    (dict(targets=[1.0], v_max=1.0, a_max=1.0, dwell=-0.1), "dwell"),
])
def test_point_to_point_refuses_bad_arguments(kwargs, match):
    targets = kwargs.pop("targets")
    with pytest.raises(ParameterError, match=match):
        point_to_point_reference(targets, **kwargs)


def test_reversing_reference_refuses_bad_arguments():
    with pytest.raises(ParameterError, match="n_reversals"):
        reversing_reference(0.5, hold=1.0, accel=5.0, n_reversals=0)
    with pytest.raises(ParameterError, match="accel"):
        reversing_reference(0.5, hold=1.0, accel=0.0, n_reversals=2)


def test_load_reference_velocity_in_other_units(tmp_path):
    ts = np.arange(0, 2001) * 2.0  # ms, a 500 Hz recording
    wd = 30.0 * np.sin(2 * np.pi * 0.5 * ts * 1e-3)  # deg/s
    f = tmp_path / "traj.csv"
    np.savetxt(f, np.column_stack([ts, wd]), delimiter=",", header="time_ms,vel_deg", comments="")
    r = load_reference(f, time="time_ms", velocity="vel_deg", units=LogUnits(time_unit="ms", velocity_unit="deg/s"))
    assert r.t[0] == 0.0 and math.isclose(r.t[-1], 4.0) and r.t.size == 4001
    exact = np.deg2rad(30.0) * np.sin(np.pi * r.t)
    # linear interpolation between 2 ms samples: error <= (2 ms)^2/8 * max|w''|
    assert np.max(np.abs(r.w - exact)) <= (2e-3) ** 2 / 8 * np.deg2rad(30.0) * np.pi ** 2 * 1.01
    np.testing.assert_allclose(r.dw[5:-5], np.deg2rad(30.0) * np.pi * np.cos(np.pi * r.t[5:-5]), atol=1e-4)


def test_load_reference_differentiates_a_position(tmp_path):
    t = np.arange(0, 3001) * 1e-3
    q = 0.4 * (1 - np.cos(2 * np.pi * t))  # rad
    f = tmp_path / "q.csv"
    np.savetxt(f, np.column_stack([t, q]), delimiter=",", header="t,q", comments="")
    r = load_reference(f, position="q")
    exact = 0.4 * 2 * np.pi * np.sin(2 * np.pi * r.t)
    # second-order central differences inside: error (2*pi*dt)^2/6 of the amplitude
    assert np.max(np.abs(r.w[1:-1] - exact[1:-1])) <= 0.8 * np.pi * (2 * np.pi * 1e-3) ** 2 / 6 * 1.01


def test_load_reference_errors_name_file_row_and_value(tmp_path):
    f = tmp_path / "bad.csv"
    f.write_text("t,w\n0,0\n0.001,0.1\n0.001,0.2\n0.003,0.3\n")
    with pytest.raises(SignalError, match=r"bad\.csv.*strictly increasing.*row 3 \(line 4\).*0\.001"):
        load_reference(f, velocity="w")
    with pytest.raises(SignalError, match="vel"):
        load_reference(f, velocity="vel")
    with pytest.raises(ParameterError, match="exactly one"):
        load_reference(f, velocity="w", position="w")
    with pytest.raises(ParameterError, match="velocity_unit"):
        LogUnits(velocity_unit="m/s")
    with pytest.raises(ParameterError, match="no torque column"):
        load_reference(f, velocity="w", units=LogUnits(current_to_torque=0.1))
    f.write_text("t,w\n0,0\n0.001,nan\n")
    with pytest.raises(SignalError, match=r"bad\.csv.*'w'.*row 2"):
        load_reference(f, velocity="w")


def test_a_point_to_point_reference_runs_in_the_closed_loop():
    from controllers.design.pi import design_pi
    from controllers.simulation.closed_loop import LoopConfig, run_mode
    from plant.friction import preset

    p = preset("paper")
    d = design_pi(p.J, crossover=20.0, phase_margin=60.0, Tc=DT)
    ref = point_to_point_reference([0.5, -0.2, 0.4], v_max=0.5, a_max=4.0, j_max=100.0, dwell=0.5)
    o = LoopConfig.from_flat(Kp=d.Kp, Ki=d.Ki, u_max=150.0, Vs=p.Vs, delta=p.delta, noise_std=1e-3)
    res = {m: run_mode(p, ref, m, o, rng=np.random.default_rng(3)) for m in ("none", "adaptive")}
    for m, r in res.items():
        assert np.all(np.isfinite(r.w)), m
    rms = {m: float(np.sqrt(np.mean((r.w_ref - r.w) ** 2))) for m, r in res.items()}
    assert rms["adaptive"] < rms["none"]


def test_load_reference_position_in_encoder_counts(tmp_path):
    t = np.arange(0, 2001) * 1e-3
    counts = 4096.0 * t  # a ramp of 4096 counts/s on a 4096-count encoder: one revolution per second
    f = tmp_path / "enc.csv"
    np.savetxt(f, np.column_stack([t, counts]), delimiter=",", header="t,q", comments="")
    r = load_reference(f, position="q", units=LogUnits(position_unit="counts", counts_per_rev=4096.0))
    np.testing.assert_allclose(r.w, 2.0 * np.pi, rtol=1e-9)
