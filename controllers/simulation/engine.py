"""The closed-loop engine: plant ∘ sensor ∘ PI ∘ compensator, one compiled step for single runs and batches.

At every controller period ``Tc`` (Ruderman's 1 kHz; the notes of
:func:`controllers.simulation.closed_loop.run_closed_loop`): the sensor
measures ``w_meas = w + noise`` (or an injected fault), the sensor gate
(:func:`adaptive_ff.compensation.gate.gate_check`) gives the controller its
measurement, the compensator computes its torque, the PI
(:func:`controllers.design.pi.pi_step`) the saturated command, the compensator
observes ``(u, w_meas)``, the metrics accumulator
(:func:`controllers.simulation.metrics.metrics_add`) takes the tracking
error of the true velocity, and the plant
(:func:`plant.dynamics.plant_step`) advances one step with ``u`` held.

Every equation lives in the component of its concept; this module only
composes them. Compensators are dispatched on their ``KIND`` (the registry of
:mod:`controllers.simulation.compensators`): a new compensator is a component
class with the two compiled protocol functions plus one line in
:func:`_compensate` and :func:`_observe`.

A single run is a batch of one: :func:`run_engine` steps ``B`` scenarios in
chunks, each chunk time-major (every scenario of the chunk advances one period
before the next period), which lets the CPU overlap the independent,
latency-bound RK4 chains of the scenarios. Chunks run in parallel on threads
(the compiled chunk releases the GIL), so one compiled function serves every
case. Each scenario's numbers do not depend on ``B`` or the chunking.
"""

from __future__ import annotations

from collections import namedtuple

from concurrent.futures import ThreadPoolExecutor

import numba
import numpy as np

from adaptive_ff.compensation.eq4_feedforward import eq4_compensate, eq4_observe
from adaptive_ff.compensation.adaptive_feedforward import robust_compensate, robust_observe
from adaptive_ff.compensation.feedforward import ff_compensate, ff_observe
from adaptive_ff.compensation.gate import gate_check
from controllers.design.pi import pi_step
from controllers.peers.adaptive_dob import adob_compensate, adob_observe
from controllers.peers.canudas import canudas_compensate, canudas_observe
from controllers.peers.dob import dob_compensate, dob_observe
from controllers.simulation.metrics import METRICS_NSTATE, metrics_add, metrics_where
from plant.jit import kernel
from plant.dynamics import plant_friction, plant_step

__all__ = ["EngineInputs", "run_engine", "KIND_NONE", "KIND_ORACLE", "ENGINE_NSTATE"]

#: Compensator kinds handled by the engine itself (the others are the components' ``KIND``).
KIND_NONE, KIND_ORACLE = 0, 1

# per-scenario engine state: held sensor value, drift row, end sample, diverged flag, theta records, fault pointer
_HELD, _ROW, _KEND, _DIV, _NTH, _FP = range(6)
#: Length of the engine's own per-scenario state.
ENGINE_NSTATE = 6

#: The arrays of a run (leading axis: scenario ``b`` of ``B``, except the shared ones).
EngineInputs = namedtuple("EngineInputs", [
    "wr", "t", "revs", "window",           # shared: reference (rad/s), time (s), reversal times (s), window (s)
    "dt", "seg", "plant_table", "plant_state",  # plant: step (s); drift period in samples (B,), rows (B, K, NPAR),
                                           # state (B, NSTATE)
    "noise", "noise_rows", "fault_k", "fault_v",  # sensor: noise (R, N) with R in {0, 1, B}; faults (shared)
    "use_gate", "gate_par", "gate_state",  # sensor gate (B,), (B, 4), (B, 7)
    "pi_par", "pi_state",                  # PI (B, 3), (B, 2)
    "kind", "comp_par", "comp_state",      # compensator kind (shared), arrays (B, ·)
    "w_limit", "eng_state", "met_state",   # divergence bound (B,), engine state (B, 6), metrics (B, 14)
    "decimate", "rec", "theta", "theta_k",  # records: every decimate-th sample (B, 5, R); theta (B, M, p), (B, M)
    "theta_buf",                           # scratch (B, p)
])


@kernel(inline="always")
def _compensate(kind, cp, cs, w_ctrl, w_meas, w_ref, f_true):
    """The compensator's torque for this period (dispatch on ``kind``)."""
    if kind == 2:
        return ff_compensate(cp, cs, w_ctrl, w_meas, w_ref)
    if kind == 3:
        return robust_compensate(cp, cs, w_ctrl, w_meas, w_ref)
    if kind == 4:
        return canudas_compensate(cp, cs, w_ctrl, w_meas, w_ref)
    if kind == 5:
        return dob_compensate(cp, cs, w_ctrl, w_meas, w_ref)
    if kind == 6:
        return eq4_compensate(cp, cs, w_ctrl, w_meas, w_ref)
    if kind == 7:
        return adob_compensate(cp, cs, w_ctrl, w_meas, w_ref)
    if kind == KIND_ORACLE:
        return f_true
    return 0.0


@kernel(inline="always")
def _observe(kind, cp, cs, u, w_meas, theta_out):
    """The compensator observes the applied torque and the measurement; True after an estimate update."""
    if kind == 2:
        return ff_observe(cp, cs, u, w_meas, theta_out)
    if kind == 3:
        return robust_observe(cp, cs, u, w_meas, theta_out)
    if kind == 4:
        return canudas_observe(cp, cs, u, w_meas, theta_out)
    if kind == 5:
        return dob_observe(cp, cs, u, w_meas, theta_out)
    if kind == 6:
        return eq4_observe(cp, cs, u, w_meas, theta_out)
    if kind == 7:
        return adob_observe(cp, cs, u, w_meas, theta_out)
    return False


@kernel(inline="always")
def _sense(x, b, k, es, w):
    """``(w_meas, w_ctrl)``: the sensor value of scenario ``b`` at period ``k`` (noise or an injected fault) and
    what the gate passes to the controller (the held value after a rejected sample)."""
    if x.noise_rows > 1:
        wm = w + x.noise[b, k]
    elif x.noise_rows == 1:
        wm = w + x.noise[0, k]
    else:
        wm = w + 0.0
    nf = x.fault_k.shape[0]
    if nf > 0:  # faults sorted by sample index
        fp = np.int64(es[_FP])
        while fp < nf and x.fault_k[fp] < k:
            fp += 1
        es[_FP] = fp
        if fp < nf and x.fault_k[fp] == k:
            wm = x.fault_v[fp]
    if x.use_gate[b]:
        if gate_check(x.gate_par[b], x.gate_state[b], wm):
            es[_HELD] = wm
        return wm, es[_HELD]
    return wm, wm


@kernel(inline="always")
def _advance(x, b, k, es, par, u):
    """Step the plant of scenario ``b`` with ``u`` held over period ``k``; False (and flagged) once it diverged."""
    ps = x.plant_state[b]
    plant_step(par, ps, u, x.dt)
    w = ps[0]
    if not (-x.w_limit[b] < w < x.w_limit[b]):
        es[_DIV] = 1.0
        es[_KEND] = k + 1
        return False
    return True


@kernel(inline="always")
def _row(x, b, k, es):
    """The plant parameter row of scenario ``b`` at period ``k`` (a drifting plant moves to its next row)."""
    seg = x.seg[b]
    if seg > 0 and k > 0 and k % seg == 0 and es[_ROW] + 1 < x.plant_table.shape[1]:
        es[_ROW] += 1.0
    return x.plant_table[b, np.int64(es[_ROW])]


@kernel(inline="always")
def _period(x, b, k, where):
    """Advance scenario ``b`` by period ``k`` (``where``: its metrics class); False once it has diverged (it then
    stays where it stopped)."""
    es = x.eng_state[b]
    ps = x.plant_state[b]
    par = _row(x, b, k, es)
    w = ps[0]
    wm, wc = _sense(x, b, k, es, w)
    wrk = x.wr[k]
    rec = x.decimate > 0 and k % x.decimate == 0
    f = plant_friction(par, ps) if rec or x.kind == KIND_ORACLE else 0.0  # LuGre: eq. 3 only where it is used
    cp = x.comp_par[b]
    cs = x.comp_state[b]
    uff = _compensate(x.kind, cp, cs, wc, wm, wrk, f)
    u = pi_step(x.pi_par[b], x.pi_state[b], wrk - wc, uff)
    if _observe(x.kind, cp, cs, u, wm, x.theta_buf[b]) and x.theta.shape[1] > 0:
        j = np.int64(es[_NTH])
        if j < x.theta.shape[1]:
            for i in range(x.theta.shape[2]):
                x.theta[b, j, i] = x.theta_buf[b, i]
            x.theta_k[b, j] = k
            es[_NTH] += 1.0
    if rec:
        r = k // x.decimate
        x.rec[b, 0, r] = w
        x.rec[b, 1, r] = wm
        x.rec[b, 2, r] = u
        x.rec[b, 3, r] = uff
        x.rec[b, 4, r] = f
    metrics_add(x.met_state[b], where, wrk - w, u)
    return _advance(x, b, k, es, par, u)


@kernel(inline="always")
def _period_plain(x, b, k, where):
    """:func:`_period` for the engine's own kinds (none, oracle) without records: no compensator dispatch, the
    friction torque only for the oracle. The same operations on the same values, so the same numbers."""
    es = x.eng_state[b]
    ps = x.plant_state[b]
    par = _row(x, b, k, es)
    w = ps[0]
    wm, wc = _sense(x, b, k, es, w)
    wrk = x.wr[k]
    uff = plant_friction(par, ps) if x.kind == KIND_ORACLE else 0.0
    u = pi_step(x.pi_par[b], x.pi_state[b], wrk - wc, uff)
    metrics_add(x.met_state[b], where, wrk - w, u)
    return _advance(x, b, k, es, par, u)


@kernel(inline="always")
def _alive(x, b0, b1):
    n_alive = 0
    for b in range(b0, b1):
        if x.eng_state[b, _DIV] == 0.0:
            n_alive += 1
    return n_alive


@kernel(nogil=True, _nrt=False, error_model="numpy")
def _run_chunk(x, b0, b1, full):
    """Scenarios ``b0..b1-1`` over all periods, time-major; the period function is :func:`_period_plain` (kinds
    none and oracle, nothing recorded) if ``full`` is None, else :func:`_period` (``full`` = True).

    The choice is made by the type of ``full``: numba compiles one specialisation for None and one for a bool,
    and its dead-branch pruning removes the other period function from each (``is None`` on an argument is
    known at compile time), so the plain path keeps its speed and the loop exists once.
    Allocates nothing: compiled without numba's reference counting, which would otherwise wrap every inlined
    component call taking arrays. The metrics class of a period (second half, reversal window) depends on the
    time alone: computed once per period. IEEE division (``error_model="numpy"``): no zero-divisor test before
    each of the ~12 divisions of a step (the same quotients; a zero divisor gives inf/NaN, caught by the
    divergence test, instead of raising)."""
    n = x.wr.shape[0]
    n_alive = _alive(x, b0, b1)
    tmid = 0.5 * (x.t[0] + x.t[-1])
    ip = 0
    for k in range(n):
        if n_alive == 0:
            break
        where, ip = metrics_where(x.t[k], tmid, x.revs, x.window, ip)
        for b in range(b0, b1):
            if x.eng_state[b, _DIV] == 0.0:
                if full is None:
                    alive = _period_plain(x, b, k, where)
                else:
                    alive = _period(x, b, k, where)
                if not alive:
                    n_alive -= 1


#: Scenarios per chunk: at most this many, at least _CHUNK_MIN (else B / threads).
_CHUNK = 64
_CHUNK_MIN = 8


def run_engine(x: EngineInputs) -> None:
    """Run every scenario of ``x`` to the end (or divergence); all outputs are written into ``x``'s arrays.

    Parameters
    ----------
    x : EngineInputs
        Prepared by :func:`controllers.simulation.closed_loop.run_closed_loop` or
        :func:`controllers.simulation.batch.run_batch` (the shapes are listed in the field comments of
        :data:`EngineInputs`). The end sample (``k_end``) is set to ``N`` for runs that did not diverge.
    """
    B = x.eng_state.shape[0]
    threads = numba.get_num_threads()  # NUMBA_NUM_THREADS, default: the cores
    chunk = max(_CHUNK_MIN, min(_CHUNK, -(-B // threads)))
    bounds = [(b0, min(B, b0 + chunk)) for b0 in range(0, B, chunk)]
    full = None if x.kind in (KIND_NONE, KIND_ORACLE) and x.decimate == 0 else True  # selects the period function
    if threads == 1 or len(bounds) == 1:
        for b0, b1 in bounds:
            _run_chunk(x, b0, b1, full)
    else:
        with ThreadPoolExecutor(max_workers=min(threads, len(bounds))) as pool:
            list(pool.map(lambda b: _run_chunk(x, b[0], b[1], full), bounds))
    live = x.eng_state[:, _DIV] == 0.0
    x.eng_state[live, _KEND] = x.wr.shape[0]


def engine_state(n_scenarios: int, w0: float) -> np.ndarray:
    """Initial engine state of ``n_scenarios`` scenarios whose sensor gate holds ``w0`` (rad/s) at the start."""
    es = np.zeros((n_scenarios, ENGINE_NSTATE))
    es[:, _HELD] = w0
    return es


def engine_outcome(es: np.ndarray) -> tuple:
    """``(k_end, diverged, n_theta)`` arrays (int, bool, int) from the engine state ``es`` (B, ENGINE_NSTATE)."""
    return es[:, _KEND].astype(np.int64), es[:, _DIV] > 0.0, es[:, _NTH].astype(np.int64)


def metrics_state(n_scenarios: int) -> np.ndarray:
    """Zeroed metric accumulators for ``n_scenarios`` scenarios, shape (B, METRICS_NSTATE)."""
    return np.zeros((n_scenarios, METRICS_NSTATE))
