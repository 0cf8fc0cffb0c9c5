"""The drive's counters at their maximum: they saturate at INT64_MAX, never overflow, and adaptation goes on.

On a 32-bit MCU a ``long`` period counter overflows after 24.9 days at 1 kHz; every counter of the code a drive runs
(``aff_drive.h`` and what it includes) is an ``int64_t`` counted up by ``aff_count_up`` (``plant/csrc/aff_real.h``),
which stops at INT64_MAX. These tests put the counters of a running ``aff`` (mode ``adaptive``: the feedforward with
its estimator, the residual observer and its switch-in, the supervisor; found by walking the struct with cffi: 30
counters, 8 run lengths and 2 period indices, and the copies aff_step keeps) at the maximum, as if the drive had run
for 2^63 periods, and run on through the drive's API (``aff_step``, ``aff_observe``) on a seeded closed-loop log of
the ``paper`` joint with two stops of the reference added (the supervisor's rest rule, the residual observer's hold,
the stick band) and five velocity spikes within the guard's bound (the estimator's outlier gate). What they prove:

* after the switch-in (every start condition passed) the counters at INT64_MAX or INT64_MAX - 1 change nothing but
  themselves: the outputs, transfers, the RLS's theta and the estimate in use are those of an untouched copy bit for
  bit, and every counter ends at min(INT64_MAX, start + its count in the copy) (the residual's ``n_held``, whose rest
  periods are counted and taken back, at least that): the step to the maximum is taken and the maximum kept;
* before the switch-in, with every counter at INT64_MAX (also the run lengths: the gates' held samples, the stick
  band's, the supervisor's still periods, the trial's): none overflows (none is negative, every counter is still
  INT64_MAX, the switch-in happens at period INT64_MAX), the outputs stay finite and within ff_max, the feedforward
  acts, the RLS keeps updating at the same 692 of its 1000 update instants as the untouched copy (the sliding
  estimator's schedule, every Ts/Tc-th sample, is counted apart from its saturating sample count) and the estimate
  in use keeps changing;
* the counters of faults the guard refuses first (non-finite samples, torques beyond the range gates), fed straight
  into the component, stay at INT64_MAX too while an untouched copy counts them;
* the drive's sources built with clang's UndefinedBehaviorSanitizer (``-fsanitize=undefined
  -fno-sanitize-recover=all``) replay the run-ons from the states with every counter at INT64_MAX without a finding
  (no signed overflow anywhere, also in comparisons such as the switch-in's with n_wait).
22 of the 30 counters count in these runs (the switch-in's n_used before the switch-in); the others (the RLS's
projections and refusals, the robust feedforward's refused estimates, the supervisor's restores) count decisions
this joint does not take, and are checked to stay at the maximum.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from adaptive_ff._caff import ffi, lib
from controllers.simulation.closed_loop import run_mode
from controllers.simulation.compensators import LoopConfig, build_mode
from plant import preset
from plant.excitation import multisine_reference

P = preset("paper")
TC = 1e-3
N = 16_000            # 16 s of log: the switch-in of this joint is at period 8369
FF_MAX = 75.0
MAX = 2**63 - 1       # INT64_MAX
INDICES = {"k_in", "k_out"}                       # period indices (-1: none), not counters
RUN_LENGTHS = {"n_still", "n_in_band", "n_trial"}  # counters that go back to 0 (and the gates' n_held)
GATES = {"aff_gate", "aff_range_gate"}


def _options() -> LoopConfig:
    # the loop of tests/adaptive_ff_layer/test_drive_guard.py (the README's main job)
    return LoopConfig.from_flat(Kp=69.28, Ki=786.1, u_max=150.0, ff_max=FF_MAX, J_design=P.J, Vs=P.Vs, delta=P.delta,
                       noise_std=1e-3, decimate=1, sensor_gate=False, stick_band=3e-3)


def _log():
    """(u, w_meas, w_ref) of the clean closed loop with two stops and five velocity spikes added (seeded)."""
    ref = multisine_reference(N * TC, dt=TC, rng=np.random.default_rng(4))
    r = run_mode(P, ref, "adaptive", _options(), rng=np.random.default_rng(5))
    u, w, wr = (np.array(x, dtype=float) for x in (r.u, r.w_meas, r.w_ref))
    assert len(u) == N
    rng = np.random.default_rng(6)
    for start in (10_500, 13_000):  # 0.6 s of reference at rest, the joint still within the stick band
        stop = slice(start, start + 600)
        wr[stop] = 0.0
        w[stop] = 1e-3 * rng.standard_normal(600)
        u[stop] = 0.5 * rng.standard_normal(600)
        w[start + 600:start + 630] = 0.0  # the joint starts late (exactly 0: held back, aff_residual_at_rest)
    for k in (6_500, 9_000, 11_000, 13_500, 15_000):  # spikes of 40 rad/s, within the guard's 1e4
        w[k] += 40.0
    return u, w, wr


@pytest.fixture(scope="module")
def log():
    return _log()


def _fresh():
    _, _, comp = build_mode(P, "adaptive", _options())
    c = ffi.new("aff *")
    assert lib.aff_init(c, comp.drive_config()) == lib.AFF_OK
    return c


def _copy(c):
    d = ffi.new("aff *")
    d[0] = c[0]
    return d


def _counters(s, path=""):
    """Every int64_t field of the struct s, recursively: (dotted path, the struct holding it, its name, kind) with
    kind "index", "run" (a run length, back to 0 when the run ends) or "total"."""
    for name, f in ffi.typeof(s).fields:
        here = f"{path}.{name}" if path else name
        if f.type.kind == "struct":
            yield from _counters(getattr(s, name), here)
        elif f.type.kind == "primitive" and f.type.cname == "int64_t":
            owner = ffi.typeof(s).cname.replace("struct ", "")
            kind = ("index" if name in INDICES else
                    "run" if name in RUN_LENGTHS or (name == "n_held" and owner in GATES) else "total")
            yield here, s, name, kind


def _values(c):
    return {p: int(getattr(s, n)) for p, s, n, _ in _counters(c[0])}


def _run(c, log, a, b):
    """Periods a..b-1 of the log: outputs, transfers, the RLS's theta after each period, the estimate in use."""
    u, w, wr = log
    p = int(c.mode.ff.est.p)
    out = np.empty(b - a)
    tr = np.empty(b - a)
    theta = np.empty((b - a, p))
    used = np.empty((b - a, p))
    for i, k in enumerate(range(a, b)):
        out[i] = lib.aff_step(c, w[k], wr[k])
        tr[i] = lib.aff_transfer(c)
        assert lib.aff_observe(c, u[k], w[k]) == 1  # every input within the guard's bounds
        theta[i] = list(c.mode.ff.est.rls.theta[0:p])
        used[i] = list(c.mode.ff.theta_used[0:p])
    return out, tr, theta, used


def _changes(x):
    return int(np.count_nonzero(np.any(np.diff(x, axis=0) != 0, axis=1)))


def test_the_counters_are_int64_and_the_run_on_counts(log):
    """The struct walk finds the counters (of every component), and the run-on makes them count."""
    c = _fresh()
    found = {p: kind for p, _, _, kind in _counters(c[0])}
    kinds = Counter((p.split(".")[0], kind) for p, kind in found.items())
    # mode: 31 totals, 8 run lengths (5 gates, stick band, still periods, trial), k_in and k_out; saved: the copies
    # of the fixed feedforward's, the residual's and the supervisor's
    assert kinds == {("mode", "total"): 31, ("mode", "run"): 8, ("mode", "index"): 2,
                     ("saved", "total"): 14, ("saved", "run"): 5, ("saved", "index"): 2}
    for p in ("mode.sup.n", "mode.sup.n_rest", "mode.res.sw.n", "mode.res.n_held", "mode.ff.est.rls.n_updates",
              "mode.ff.est.gate.n_outliers", "mode.ff.n_implausible", "mode.res.dob.n_rejected"):
        assert found[p] == "total"
    assert found["mode.res.sw.k_in"] == "index" and found["mode.ff.est.gate.n_held"] == "run"
    _run(c, log, 0, 10_000)
    before = _values(c)
    _run(c, log, 10_000, N)
    after = _values(c)
    moved = {p for p in before if p.startswith("mode.") and found[p] == "total" and after[p] > before[p]}
    for p in ("mode.sup.n", "mode.sup.n_rest", "mode.res.sw.n", "mode.res.n_held", "mode.ff.est.n_samples",
              "mode.ff.est.n_rejected", "mode.ff.est.gate.n_outliers", "mode.ff.est.rls.n_updates"):
        assert p in moved
    assert len(moved) >= 10


@pytest.mark.parametrize("start", [MAX, MAX - 1])
def test_totals_at_the_maximum_change_nothing_but_themselves(log, start):
    """After the switch-in, the counters at the maximum (or one below): the same numbers as an untouched copy, the
    counters stepped to the maximum and kept there."""
    cut = 10_000  # the residual observer switched in (8369) and its trial decided: every start condition passed
    c = _fresh()
    _run(c, log, 0, cut)
    assert c.mode.res.sw.decided == 1 and c.mode.res.sw.k_in == 8369 and c.mode.ff.provisional == 0
    ref = _copy(c)
    before = _values(ref)
    for p, s, n, kind in _counters(c[0]):
        if kind == "total":
            setattr(s, n, start)
    out, tr, theta, used = _run(c, log, cut, N)
    out_r, tr_r, theta_r, used_r = _run(ref, log, cut, N)
    np.testing.assert_array_equal(out, out_r)
    np.testing.assert_array_equal(tr, tr_r)
    np.testing.assert_array_equal(theta, theta_r)
    np.testing.assert_array_equal(used, used_r)
    after_r = _values(ref)
    got = _values(c)
    kinds = {p: kind for p, _, _, kind in _counters(c[0])}
    for p, v in got.items():
        assert 0 <= v <= MAX or (kinds[p] == "index" and v == -1), p
        if not p.startswith("mode.") or kinds[p] != "total":
            continue
        expected = min(MAX, start + after_r[p] - before[p])
        if p == "mode.res.n_held":  # a rest period is counted, then taken back: not at the maximum
            assert expected <= v <= MAX, p
        else:
            assert v == expected, (p, v, expected)
    for p in ("mode.sup.n", "mode.res.sw.n", "mode.ff.est.n_samples", "mode.ff.est.n_acc",
              "mode.ff.est.rls.n_updates", "mode.sup.n_rest", "mode.ff.est.gate.n_outliers"):
        assert got[p] == MAX, p  # counted during the run-on: at (or stepped to) the maximum, no further
    for p, kind in kinds.items():
        if p.startswith("saved.") and kind == "total":
            assert got[p] >= start  # the copy aff_step keeps: the state before this period's step


def test_every_counter_at_the_maximum_before_the_switch_in(log):
    """Before the switch-in, every counter and run length at the maximum: no overflow, bounded outputs, and the
    estimator adapts as the untouched copy does."""
    cut = 6_000  # the feedforward acts, the switch-in has not decided yet (k_in -1), the supervisor decides
    c = _fresh()
    _run(c, log, 0, cut)
    assert c.mode.res.sw.k_in == -1 and c.mode.ff.ff.has == 1 and c.mode.sup.on == 1
    ref = _copy(c)
    for p, s, n, kind in _counters(c[0]):
        if kind != "index":
            setattr(s, n, MAX)
    out, tr, theta, used = _run(c, log, cut, N)
    _, _, theta_r, used_r = _run(ref, log, cut, N)
    got = _values(c)
    kinds = {p: kind for p, _, _, kind in _counters(c[0])}
    for p, v in got.items():
        if kinds[p] == "total":
            assert v == MAX, p  # saturated, not wrapped
        elif kinds[p] == "run":
            assert 0 <= v <= MAX, p
    # the switch-in's evidence counted as complete: it switched in at once, at period INT64_MAX, without overflow
    assert c.mode.res.sw.k_in == MAX and c.mode.res.sw.g > 0
    assert c.mode.res.sw.k_out in (-1, MAX)
    assert np.all(np.isfinite(out)) and np.all(np.isfinite(tr))
    assert np.max(np.abs(out)) <= FF_MAX
    assert lib.aff_active(c) == 1
    moving = np.abs(log[2][cut:N]) > 0
    assert np.mean(np.abs(out[moving]) > 0) > 0.99  # the feedforward keeps acting where the reference moves
    # the RLS keeps updating every Ts/Tc = 10 periods outside its sliding-regime gate, as the untouched copy does
    n_theta, n_theta_r = _changes(theta), _changes(theta_r)
    assert n_theta == n_theta_r and n_theta > 0.6 * (N - cut) / 10  # 692 of the 1000 instants
    # and the estimate in use keeps changing with it
    assert _changes(used) > 0.5 * n_theta and _changes(used_r) > 0.5 * n_theta_r
    assert not np.array_equal(used[0], used[-1])


def test_fault_counters_at_the_maximum_without_the_guard(log):
    """The counters of faults the drive's guard refuses first (non-finite samples, torques beyond the range gates),
    fed straight into the component (aff_adaptive_compensate/observe): from INT64_MAX they stay there, as every
    other counter, while an untouched copy counts them; the outputs stay finite and within ff_max."""
    u, w, wr = (x.copy() for x in log)
    a, b = 10_000, 13_000
    w[a:b:7] = np.nan
    u[a + 3:b:11] = np.nan
    u[a + 5:b:13] = 1e9
    c = _fresh()
    _run(c, log, 0, a)
    ref = _copy(c)
    before = _values(ref)
    for p, s, n, kind in _counters(c[0]):
        if kind != "index":
            setattr(s, n, MAX)
    outs = []
    for d in (c, ref):
        m = ffi.addressof(d[0], "mode")
        out = np.empty(b - a)
        for i, k in enumerate(range(a, b)):
            out[i] = lib.aff_adaptive_compensate(m, w[k], w[k], wr[k])
            lib.aff_adaptive_observe(m, u[k], w[k], ffi.NULL)
        outs.append(out)
    for out in outs:
        assert np.all(np.isfinite(out)) and np.max(np.abs(out)) <= FF_MAX
    after_r = _values(ref)
    counted = {p for p in before if p.startswith("mode.") and after_r[p] > before[p]}
    for p in ("mode.sup.n_skipped", "mode.ff.est.gate.n_nonfinite", "mode.ff.est.u_range.n_rejected",
              "mode.ff.ff.n_rejected", "mode.res.dob.n_rejected", "mode.res.dob.u_range.n_rejected"):
        assert p in counted, p
    kinds = {p: kind for p, _, _, kind in _counters(c[0])}
    got = _values(c)
    for p, v in got.items():
        if p.startswith("mode.") and kinds[p] == "total":
            assert v == MAX, p
        elif kinds[p] == "run":
            assert 0 <= v <= MAX, p


ROOT = Path(__file__).resolve().parents[2]
DRIVE = ["aff_adaptive", "aff_residual", "aff_dob", "aff_supervisor", "aff_robust_ff", "aff_sliding", "aff_feedforward",
         "aff_rls", "aff_gate", "aff_velocity_input", "aff_regression", "aff_error", "aff_drive"]
HARNESS = r"""
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include "aff_drive.h"
/* argv: the bytes of an aff (the cffi module's layout), a log of n periods (u[n], w[n], w_ref[n], doubles) */
int main(int argc, char **argv)
{
    static aff c;
    FILE *f = argc == 3 ? fopen(argv[1], "rb") : NULL;
    if (!f || fread(&c, sizeof c, 1, f) != 1 || fgetc(f) != EOF)
        return 2;
    fclose(f);
    f = fopen(argv[2], "rb");
    if (!f || fseek(f, 0, SEEK_END) != 0)
        return 3;
    long n = ftell(f) / (3 * (long)sizeof(double));
    rewind(f);
    double *log = malloc((size_t)(3 * n) * sizeof(double)), *uff = malloc((size_t)n * sizeof(double));
    if (!log || !uff || fread(log, sizeof(double), (size_t)(3 * n), f) != (size_t)(3 * n))
        return 4;
    fclose(f);
    aff_replay(&c, log, log + n, NULL, log + 2 * n, uff, NULL, n);
    double m = 0;
    for (long k = 0; k < n; k++)
        m = isfinite(uff[k]) && fabs(uff[k]) > m ? fabs(uff[k]) : (isfinite(uff[k]) ? m : INFINITY);
    printf("%.17g %lld %lld %lld\n", m, (long long)aff_n_updates(&c), (long long)c.mode.sup.n,
           (long long)c.mode.res.sw.k_in);
    return 0;
}
"""


def test_no_undefined_behaviour_at_the_maximum_under_ubsan(log, tmp_path):
    """The drive's sources under UBSan (clang) replay the run-ons of the states with every counter at INT64_MAX."""
    clang = shutil.which("clang")
    if clang is None or sys.platform == "win32":
        if os.environ.get("CI"):
            pytest.fail("clang is missing: .ci/run installs it")
        pytest.skip("clang is not installed (apt-get install clang)")
    (tmp_path / "harness.c").write_text(HARNESS)
    exe = tmp_path / "harness"
    src = [str(ROOT / "adaptive_ff" / "csrc" / f"{f}.c") for f in DRIVE] + [str(ROOT / "plant" / "csrc" /
                                                                            "plant_stribeck.c")]
    subprocess.run([clang, "-std=c99", "-O1", "-g", "-fsanitize=undefined", "-fno-sanitize-recover=all",
                    f"-I{ROOT / 'adaptive_ff' / 'csrc'}", f"-I{ROOT / 'plant' / 'csrc'}", *src,
                    str(tmp_path / "harness.c"), "-lm", "-o", str(exe)], check=True, capture_output=True)
    for cut, k_in in ((6_000, MAX), (10_000, 8369)):  # before the switch-in (then at INT64_MAX), after it
        c = _fresh()
        _run(c, log, 0, cut)
        for _, s, n, kind in _counters(c[0]):
            if kind != "index":
                setattr(s, n, MAX)
        (tmp_path / "aff.bin").write_bytes(bytes(ffi.buffer(c)))
        np.stack([x[cut:N] for x in log]).astype(float).tofile(tmp_path / "log.bin")
        r = subprocess.run([str(exe), str(tmp_path / "aff.bin"), str(tmp_path / "log.bin")], capture_output=True,
                           text=True, timeout=120)
        assert r.returncode == 0 and r.stderr == "", r.stderr
        m, n_updates, n_sup, k = r.stdout.split()
        assert float(m) <= FF_MAX and int(n_updates) == MAX and int(n_sup) == MAX and int(k) == k_in
