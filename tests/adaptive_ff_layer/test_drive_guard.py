"""The drive's input guard (``adaptive_ff/csrc/aff_drive.h``): a refused sample drops its period.

A closed-loop log of mode ``adaptive`` (the feedforward, the residual observer it switches in, the supervisor) on
the ``paper`` joint is replayed through the drive's API (``aff_step``, ``aff_observe`` through cffi) three ways:
clean; with bursts of bad samples (NaN, +-inf, 1e308, a subnormal, a spike beyond the plausible bound) in one input
(``w``, ``w_ref`` or ``u``); and clean with the burst's periods removed from the log. The guard's promise, checked
exactly: outside the burst the output of the second replay is the third's, bit for bit (after the last bad sample
the state is what it would be had the bad periods never happened), and in it the output is held. The bursts fall
into each state the compensator passes through on this log (learning, feedforward, observer). Within 1 s after a
burst the output is back within 1 % of the friction level of the clean replay. A long dropout fades the held
output to 0 after ``hold_time``; the counters saturate.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from adaptive_ff._caff import ffi, lib
from controllers.simulation.closed_loop import run_mode
from controllers.simulation.compensators import LoopConfig, build_mode
from plant import preset
from plant.excitation import multisine_reference

P = preset("paper")
TC = 1e-3
N = 16_000  # 16 s: the switch-on (about 0.5 s) and the switch-in (about 5 s) of this joint
BAD = {"nan": math.nan, "+inf": math.inf, "-inf": -math.inf, "huge": 1e308, "subnormal": 5e-324, "spike": 1e5}


def _options() -> LoopConfig:
    # the loop of the README's main job, as compare configures it (the identified values here: the preset's)
    return LoopConfig.from_flat(Kp=69.28, Ki=786.1, u_max=150.0, ff_max=75.0, J_design=P.J, Vs=P.Vs, delta=P.delta,
                       noise_std=1e-3, decimate=1, sensor_gate=False, stick_band=3e-3)


@pytest.fixture(scope="module")
def log():
    """(u, w_meas, w_ref) of N periods of mode adaptive, and the package's compensation u_ff of the loop."""
    ref = multisine_reference(N * TC, dt=TC, rng=np.random.default_rng(4))
    r = run_mode(P, ref, "adaptive", _options(), rng=np.random.default_rng(5))
    return (np.ascontiguousarray(r.u, dtype=float), np.ascontiguousarray(r.w_meas, dtype=float),
            np.ascontiguousarray(r.w_ref, dtype=float), np.asarray(r.u_ff, dtype=float))


def _fresh():
    """A drive's ``aff`` of mode adaptive (built as the loop's), the guard of an export for a 150 N·m drive."""
    _, _, comp = build_mode(P, "adaptive", _options())
    c = ffi.new("aff *")
    assert lib.aff_init(c, comp.drive_config(Tc=TC, w_max=1e4, u_max=300.0, hold_time=0.1)) == lib.AFF_OK
    return c


def _replay(u, w, wr, *, states: bool = False):
    c = _fresh()
    out = np.empty(len(u))
    st = np.empty(len(u), dtype=int)
    for k in range(len(u)):
        out[k] = lib.aff_step(c, w[k], wr[k])
        lib.aff_observe(c, u[k], w[k])
        if states:
            st[k] = lib.aff_status(c).state
    return (out, st, c) if states else (out, c)


@pytest.fixture(scope="module")
def clean(log):
    u, w, wr, uff_loop = log
    out, st, c = _replay(u, w, wr, states=True)
    np.testing.assert_array_equal(out, uff_loop)  # the drive's API is the engine's mode adaptive, bit for bit
    return out, st


def test_the_log_passes_through_learning_feedforward_and_observer(clean):
    _, st = clean
    seen = set(st.tolist())
    assert {lib.AFF_STATE_LEARNING, lib.AFF_STATE_FEEDFORWARD, lib.AFF_STATE_OBSERVER} <= seen, seen


def _first(st, state) -> int:
    return int(np.argmax(st == state))


@pytest.mark.parametrize("which", ["w", "w_ref", "u"])
@pytest.mark.parametrize("bad", sorted(BAD))
def test_a_burst_drops_its_periods_and_nothing_else(log, clean, which, bad):
    u, w, wr, _ = log
    ref, st = clean
    fc = P.Fc
    for state in (lib.AFF_STATE_LEARNING, lib.AFF_STATE_FEEDFORWARD, lib.AFF_STATE_OBSERVER):
        k0 = _first(st, state) + 200
        burst = np.arange(k0, k0 + 20)
        x = {"w": w.copy(), "w_ref": wr.copy(), "u": u.copy()}
        assert st[k0] == state
        x[which][burst] = BAD[bad]
        out, c = _replay(x["u"], x["w"], x["w_ref"])
        keep = np.setdiff1d(np.arange(len(u)), burst)
        dropped, _ = _replay(u[keep], w[keep], wr[keep])
        np.testing.assert_array_equal(out[keep], dropped)  # the state as if the bad periods never happened
        if which != "u":  # the output held; a bad u is refused after aff_step gave the period's output
            assert np.all(out[burst] == out[k0 - 1])
        s = lib.aff_status(c)
        n = {"w": s.n_refused_w_meas, "w_ref": s.n_refused_w_ref, "u": s.n_refused_u}[which]
        assert n == 20 and s.k_fault == k0 + 19 and s.n_held == 0
        assert s.last_fault == {"w": lib.AFF_INPUT_W_MEAS, "w_ref": lib.AFF_INPUT_W_REF, "u": lib.AFF_INPUT_U}[which]
        after = slice(k0 + 20 + 1000, k0 + 20 + 3000)  # from 1 s after the burst
        assert np.max(np.abs(out[after] - ref[after])) <= 0.01 * fc, (state, which, bad)


def test_a_long_dropout_holds_then_fades_to_zero(log, clean):
    u, w, wr, _ = log
    ref, st = clean
    k0 = _first(st, lib.AFF_STATE_OBSERVER) + 500
    w2 = w.copy()
    w2[k0:k0 + 400] = math.nan  # 0.4 s: held 0.1 s, faded over the next 0.1 s, then 0
    c = _fresh()
    out = np.empty(k0 + 400)
    for k in range(k0 + 400):
        out[k] = lib.aff_step(c, w2[k], wr[k])
        lib.aff_observe(c, u[k], w2[k])
        if k == k0 + 50:
            s = lib.aff_status(c)
            assert s.state == lib.AFF_STATE_FAULT and s.n_held == 51 and not s.faded
    held = out[k0 - 1]
    assert abs(held) > 0.1 * P.Fc and np.all(out[k0:k0 + 100] == held)
    fading = out[k0 + 100:k0 + 200]
    assert np.all(np.diff(np.abs(fading)) < 0) and np.all(np.sign(fading[:-1]) == np.sign(held))
    np.testing.assert_allclose(np.abs(fading), np.abs(held) * (1 - np.arange(1, 101) / 100), atol=1e-9 * abs(held))
    assert np.all(out[k0 + 200:] == 0.0)
    s = lib.aff_status(c)
    assert s.faded and s.n_held == 400 and s.n_refused_w_meas == 400
    # the first clean sample ends the fault: the compensator goes on from its state before the dropout
    lib.aff_step(c, w[k0 + 400], wr[k0 + 400])
    assert lib.aff_status(c).state != lib.AFF_STATE_FAULT and lib.aff_transfer(c) == lib.aff_adaptive_transfer(
        ffi.addressof(c, "mode"))


def test_counters_saturate_at_their_maximum(log):
    u, w, wr, _ = log
    c = _fresh()
    c.status.n_refused_w_meas = 2**32 - 2
    c.status.n_refused_w_ref = 2**32 - 1
    c.status.n_refused_u = 2**32 - 1
    c.status.k = 2**64 - 2
    for k in range(5):
        lib.aff_step(c, math.nan, math.nan)
        lib.aff_observe(c, u[k], w[k])
    lib.aff_step(c, w[0], wr[0])
    lib.aff_observe(c, math.inf, w[0])
    s = lib.aff_status(c)
    assert s.n_refused_w_meas == s.n_refused_w_ref == s.n_refused_u == 2**32 - 1 and s.k == 2**64 - 1


def test_init_refuses_bad_settings_with_a_named_error():
    _, _, comp = build_mode(P, "adaptive", _options())
    c = ffi.new("aff *")
    g = lib.aff_guard_default_config()
    assert (g.Tc, g.w_max, g.u_max, g.hold_time) == (1e-3, 1e4, 1e6, 0.1)
    for field, value, code in (("Tc", 0.0, lib.AFF_ERR_GUARD_TC), ("w_max", math.inf, lib.AFF_ERR_GUARD_W_MAX),
                               ("u_max", -1.0, lib.AFF_ERR_GUARD_U_MAX), ("hold_time", 1e-4, lib.AFF_ERR_GUARD_HOLD_TIME),
                               ("Tc", 2e-3, lib.AFF_ERR_DRIVE_TC)):
        assert lib.aff_init(c, comp.drive_config(**{field: value})) == code
        assert field.split("_")[0] in ffi.string(lib.aff_error_message(code)).decode()
    assert lib.aff_init(c, ffi.NULL) == lib.AFF_ERR_NULL
    assert lib.aff_init(ffi.NULL, comp.drive_config()) == lib.AFF_ERR_NULL
    assert ffi.string(lib.aff_error_message(lib.AFF_OK)) == b"configured"


def test_feedforward_only_is_the_feedforward_alone(log):
    """The composite without the observer and the supervisor is the feedforward, bit for bit."""
    u, w, wr, _ = log
    o = _options().replace(switch_in=False, supervise=False)
    _, _, comp = build_mode(P, "adaptive", o)
    assert comp.observer is None and comp.supervisor is None
    _, _, ff_only = build_mode(P, "adaptive", o)
    ff = ff_only.feedforward
    c = ffi.new("aff *")
    assert lib.aff_init(c, comp.drive_config()) == lib.AFF_OK
    for k in range(4000):
        a = lib.aff_step(c, w[k], wr[k])
        lib.aff_observe(c, u[k], w[k])
        b = ff.compensate(w[k], wr[k])
        ff.observe(u[k], w[k])
        assert a == b


def test_aff_step_changes_only_what_the_rollback_restores(log):
    """``aff_saved`` holds every part ``aff_adaptive_compensate`` changes: over the log the estimator (``ff.est``) and
    the rest of the feedforward's struct but its fixed feedforward and fade-in gain are the same bytes before and
    after each ``aff_step`` (so that the rollback of a refused ``aff_observe`` is whole)."""
    u, w, wr, _ = log
    c = _fresh()
    before = ffi.new("aff_robust_ff *")
    ff = ffi.addressof(c.mode, "ff")
    for k in range(N):
        before[0] = ff[0]
        lib.aff_step(c, w[k], wr[k])
        before.ff = ff.ff
        before.gain = ff.gain
        assert bytes(ffi.buffer(before)) == bytes(ffi.buffer(ff)), k
        lib.aff_observe(c, u[k], w[k])
