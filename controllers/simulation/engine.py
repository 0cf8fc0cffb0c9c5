"""The closed-loop engine: plant ∘ sensor ∘ PI ∘ compensator, one C step for single runs and batches.

At every controller period ``Tc`` (Ruderman's 1 kHz; the notes of
:func:`controllers.simulation.closed_loop.run_closed_loop`): the sensor
measures ``w_meas = w + noise`` (or an injected fault), the sensor gate
(``aff_gate_check``, :class:`adaptive_ff.OutlierGate`) gives the controller
its measurement, the compensator computes its torque, the PI (``ctl_pi_step``,
:class:`controllers.PIController`) the saturated command, the compensator
observes ``(u, w_meas)``, the metrics (``ctl_metrics_add``) take the tracking
error of the true velocity, and the plant (``plant_step``) advances one step
with ``u`` held. The loop is C (``controllers/csrc/ctl_engine.c``,
``ctl_run_chunk``); every equation lives in the component of its concept, the
engine only composes them. A compensator is any object whose C struct
implements ``adaptive_ff/csrc/aff_compensator.h`` (``compensate`` and
``observe`` through a const ops table named by the class attribute ``C_OPS``).

A single run is a batch of one: :meth:`EngineRun.run` steps ``B`` scenarios in
chunks, each chunk time-major (every scenario of the chunk advances one period
before the next period), which lets the CPU overlap the independent,
latency-bound RK4 chains of the scenarios. Chunks run in parallel on threads
(cffi releases the GIL during the C call). Each scenario's numbers do not depend
on ``B`` or the chunking.
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from controllers._cctl import ffi, lib
from controllers.simulation.metrics import METRICS_DTYPE, SETTLE_SHARE, stop_intervals
from plant.errors import ParameterError

__all__ = ["EngineRun", "EngineMetrics", "EngineRecord", "THETA_NMAX", "engine_threads"]

#: Largest parameter vector a compensator may report (``CTL_THETA_NMAX`` of ctl_engine.h).
THETA_NMAX = len(ffi.new("ctl_scenario *").theta_buf)
#: Scenarios per chunk: at most this many, at least _CHUNK_MIN (else B / threads).
_CHUNK = 64
_CHUNK_MIN = 8
#: Signals recorded per period (rows of :attr:`EngineRun.rec`).
RECORDED = ("w", "w_meas", "u", "u_ff", "f")


#: The fields of a ``ctl_scenario`` read after a run, at their offsets in the struct (numpy's view of the array of B:
#: one pass per field instead of one cffi access per scenario): the metric accumulators (:data:`METRICS_DTYPE`, the
#: bytes of ``ctl_metrics``), ``k_end``, ``diverged`` and ``n_theta_rec``.
_SCENARIO_FIELDS = np.dtype({
    "names": ["metrics", "k_end", "diverged", "n_theta_rec"],
    "formats": [METRICS_DTYPE, f"i{ffi.sizeof('long')}", f"i{ffi.sizeof('int')}", f"i{ffi.sizeof('long')}"],
    "offsets": [ffi.offsetof("ctl_scenario", f) for f in ("metrics", "k_end", "diverged", "n_theta_rec")],
    "itemsize": ffi.sizeof("ctl_scenario")})
if METRICS_DTYPE.itemsize != ffi.sizeof("ctl_metrics"):  # pragma: no cover - the dtype mirrors the C struct
    raise ImportError(f"METRICS_DTYPE has {METRICS_DTYPE.itemsize} bytes, ctl_metrics {ffi.sizeof('ctl_metrics')}")


def engine_threads() -> int:
    """Threads the engine runs chunks on: ``ADAPTIVE_FF_THREADS`` if set (an integer >= 1), else the CPUs this
    process may use."""
    env = os.environ.get("ADAPTIVE_FF_THREADS")
    if env:
        try:
            n = int(env)
        except ValueError:
            n = 0
        if n < 1:
            raise ParameterError(f"ADAPTIVE_FF_THREADS must be an integer >= 1, got {env!r}")
        return n
    try:
        return max(len(os.sched_getaffinity(0)), 1)
    except AttributeError:  # not on Linux
        return max(os.cpu_count() or 1, 1)


def _f8(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


@dataclass(frozen=True)
class EngineMetrics:
    """What the engine's metrics of a run need besides the reference.

    Parameters
    ----------
    revs : array_like, shape (R,)
        Reversal times of the reference (s), increasing; default none.
    window : float
        Half-width (s) of the metrics' reversal windows; default 0.
    settle_share, settle_floor : float
        Settling band of the reference's stops: ``max(settle_share * move peak speed, settle_floor)`` (-, rad/s;
        :class:`controllers.simulation.metrics.MotionMetrics`); default :data:`SETTLE_SHARE`, 0.
    """

    revs: object = ()
    window: float = 0.0
    settle_share: float = SETTLE_SHARE
    settle_floor: float = 0.0


@dataclass(frozen=True)
class EngineRecord:
    """What an engine run records of each scenario.

    Parameters
    ----------
    decimate : int
        Record every ``decimate``-th period (0, default: nothing recorded).
    n_theta, m_theta : int
        Length of the compensator's parameter vector and capacity of the estimate history (0, default: none).
    """

    decimate: int = 0
    n_theta: int = 0
    m_theta: int = 0


class EngineRun:
    """The inputs of one engine call: what all scenarios share (a ``ctl_run``) and ``B`` scenarios
    (``ctl_scenario[B]``), with every array the C structs point to kept alive here.

    Parameters
    ----------
    t, w_ref : ndarray, shape (N,)
        Time (s) and velocity reference (rad/s) sampled at ``dt``.
    dt : float
        Controller period = integration step (s).
    n_scenarios : int
        ``B``.
    faults : (ndarray of int64, ndarray of float), optional
        Sorted sample indices whose measurement is replaced, and the values (rad/s); shared by all scenarios.
    oracle : bool
        Feed the plant's true friction forward (the ``oracle`` mode).
    metrics : EngineMetrics
        The reference's reversal times, the reversal window and the stops' settling band (default: none, 0, the
        default band).
    record : EngineRecord
        What is recorded (default: nothing).

    Attributes
    ----------
    rec : ndarray, shape (B, 5, ceil(N/decimate))
        Records of :data:`RECORDED` (NaN where not reached).
    theta : ndarray, shape (B, m_theta, n_theta); theta_k : ndarray of int64, shape (B, m_theta)
        Estimates after updates and their periods.
    scenarios : cffi ``ctl_scenario[B]``
        The scenarios' structs (plant state, gate, PI, metrics, outcome) after :meth:`run`.
    stops : (ndarray, ndarray, ndarray), each shape (S,)
        The reference's stops: first and last sample time (s) and settling band (rad/s)
        (:func:`controllers.simulation.metrics.stop_intervals`).
    settle, stop_max : ndarray, shape (B, S); rev_max : ndarray, shape (B, R)
        Per scenario: settling time (s) and largest |e| (rad/s) of each stop, largest |e| in each reversal's window
        (rad/s); written by the C engine (``ctl_events``), NaN where the event was not complete.
    """

    def __init__(self, *, t, w_ref, dt: float, n_scenarios: int, faults=None, oracle: bool = False,
                 metrics: EngineMetrics = EngineMetrics(), record: EngineRecord = EngineRecord()):
        revs, window = metrics.revs, metrics.window
        settle_share, settle_floor = metrics.settle_share, metrics.settle_floor
        decimate, n_theta, m_theta = record.decimate, record.n_theta, record.m_theta
        if n_theta > THETA_NMAX:
            raise ParameterError(f"the compensator reports {n_theta} parameters, more than the engine's "
                                 f"{THETA_NMAX} (CTL_THETA_NMAX)")
        B = int(n_scenarios)
        self._t, self._wr, self._revs = _f8(t), _f8(w_ref), _f8(revs)
        n = self._t.shape[0]
        fk, fv = faults if faults is not None else (np.empty(0, dtype=np.int64), np.empty(0))
        self._fk, self._fv = np.ascontiguousarray(fk, dtype=np.int64), _f8(fv)
        n_rec = (n + decimate - 1) // decimate if decimate > 0 else 0
        self.rec = np.full((B, 5, n_rec), math.nan)
        self.theta = np.empty((B, m_theta, max(n_theta, 1)))
        self.theta_k = np.zeros((B, m_theta), dtype=np.int64)
        r = self.c_run = ffi.new("ctl_run *")
        r.t = ffi.from_buffer("double[]", self._t)
        r.w_ref = ffi.from_buffer("double[]", self._wr)
        r.n = n
        r.dt = float(dt)
        r.revs = ffi.from_buffer("double[]", self._revs)
        r.n_revs = self._revs.shape[0]
        r.window = float(window)
        r.fault_k = ffi.from_buffer("int64_t[]", self._fk)
        r.fault_v = ffi.from_buffer("double[]", self._fv)
        r.n_faults = self._fk.shape[0]
        r.oracle = bool(oracle)
        r.decimate = int(decimate)
        r.n_rec = n_rec
        r.n_theta = int(n_theta)
        r.m_theta = int(m_theta)
        r.settle_share, r.settle_floor = float(settle_share), float(settle_floor)
        self.stops = stop_intervals(self._t, self._wr, share=settle_share, floor=settle_floor)
        S, R = self.stops[0].shape[0], self._revs.shape[0]
        self.settle, self.stop_max, self.rev_max = np.empty((B, S)), np.empty((B, S)), np.empty((B, R))
        ev = [ffi.from_buffer("double[]", a) for a in (self.settle, self.stop_max, self.rev_max)]
        self.scenarios = ffi.new("ctl_scenario[]", B)
        self._keep = []
        self._ops = {}
        lib.ctl_scenarios_init(self.scenarios, B, float(self._wr[0]) if n else 0.0, ev[0], ev[1], S, ev[2], R)
        if decimate > 0:  # the records: row b of rec, theta and theta_k
            rec = ffi.from_buffer("double[]", self.rec)
            th = ffi.from_buffer("double[]", self.theta)
            thk = ffi.from_buffer("int64_t[]", self.theta_k)
            for b in range(B):
                sc = self.scenarios[b]
                sc.rec = rec + b * 5 * n_rec
                if m_theta > 0 and n_theta > 0:
                    sc.theta = th + b * m_theta * max(n_theta, 1)
                    sc.theta_k = thk + b * m_theta

    def set_plant(self, b: int, rows, n_rows: int, row_k, state, w_limit: float) -> None:
        """Scenario ``b``'s plant: ``n_rows`` parameter rows (a cffi ``plant_params`` pointer/array, kept
        alive here), the sample each row starts at (``row_k``: increasing integers from 0, length ``n_rows``, e.g.
        of :func:`controllers.simulation.closed_loop.plant_table`; an int ``seg`` means row ``j`` from sample
        ``j*seg`` on, 0 one row), its initial state (``plant_state``) and the divergence bound (rad/s)."""
        sc = self.scenarios[b]
        n_rows = int(n_rows)
        if isinstance(row_k, (int, np.integer)):  # a uniform period: row j from sample j*seg on (0: row 0 only)
            n_rows = n_rows if row_k else 1
            row_k = np.arange(n_rows) * int(row_k)
        starts = np.ascontiguousarray(row_k, dtype=np.dtype("long"))
        if starts.shape != (max(n_rows, 1),) or starts[0] != 0 or (n_rows > 1 and np.any(np.diff(starts) < 0)):
            raise ParameterError(f"row_k must hold {n_rows} increasing start samples from 0, got {row_k!r}")
        self._keep.extend((rows, starts))
        sc.rows = rows
        sc.n_rows = n_rows
        sc.row_k = ffi.from_buffer("long[]", starts)
        sc.plant = state[0] if ffi.typeof(state).kind == "pointer" else state
        sc.w_limit = float(w_limit)

    def set_plants(self, rows, states, index, w_limit) -> None:
        """Every scenario's plant at once, each one that does not vary in time: scenario ``b`` steps the parameter
        row ``rows[index[b]]`` (a cffi ``plant_params[]`` table, :func:`plant.rows.plant_rows`; kept alive here) from
        the state ``states[index[b]]`` (``plant_state[]``, :func:`plant.rows.plant_states`, copied) with the
        divergence bound ``w_limit[b]`` (rad/s): :meth:`set_plant` with one row for each, in one C pass
        (``ctl_scenarios_set_plants``).

        Raises
        ------
        ParameterError
            ``index`` (shape (B,)) outside the table, ``w_limit`` not of shape (B,), or fewer states than rows.
        """
        B = len(self.scenarios)
        idx = np.ascontiguousarray(index, dtype=np.int64)
        lim = _f8(w_limit)
        n_rows = len(rows)
        if idx.shape != (B,) or (B and (idx.min() < 0 or idx.max() >= n_rows)):
            raise ParameterError(f"index must hold {B} rows of the {n_rows} of the table, got {index!r}")
        if lim.shape != (B,):
            raise ParameterError(f"w_limit must have shape ({B},), got {np.shape(w_limit)}")
        if len(states) < n_rows:
            raise ParameterError(f"states must hold a state per row ({n_rows}), got {len(states)}")
        self._keep.extend((rows, states))
        lib.ctl_scenarios_set_plants(self.scenarios, B, rows, states, ffi.from_buffer("int64_t[]", idx),
                                     ffi.from_buffer("double[]", lim))

    def set_noise_table(self, noise) -> None:
        """A table of noise rows, shape (R, N) (rad/s), that :meth:`set_noise_row` hands to scenarios; None: none."""
        self._noise = None if noise is None else np.ascontiguousarray(noise, dtype=np.float64)
        if self._noise is not None:
            self._noise_ptr = ffi.from_buffer("double[]", self._noise)

    def set_noise_row(self, b: int, r: int) -> None:
        """Scenario ``b`` measures with row ``r`` of the noise table."""
        self.scenarios[b].noise = self._noise_ptr + r * self._noise.shape[1]

    def keep(self, obj) -> None:
        """Keep ``obj`` (memory a scenario points into) alive as long as this run."""
        self._keep.append(obj)

    def set_gate(self, b: int, gate) -> None:
        """Scenario ``b``'s sensor gate (an :class:`adaptive_ff.OutlierGate`, copied by value) or None."""
        sc = self.scenarios[b]
        sc.use_gate = gate is not None
        if gate is not None:
            sc.gate = gate.cdata[0]

    def set_sensor(self, b: int, sensor) -> None:
        """Scenario ``b``'s sensor (a :class:`controllers.simulation.sensor_drive.Sensor`, copied by value) or None
        (the measurement is ``w + noise``)."""
        sc = self.scenarios[b]
        sc.use_sensor = sensor is not None
        if sensor is not None:
            sc.sensor = sensor.cdata[0]

    def set_drive(self, b: int, drive) -> None:
        """Scenario ``b``'s drive (a :class:`controllers.simulation.sensor_drive.Drive`, copied by value) or None
        (the command is applied as it is)."""
        sc = self.scenarios[b]
        sc.use_drive = drive is not None
        if drive is not None:
            sc.drive = drive.cdata[0]

    def set_supervisor(self, b: int, supervisor) -> None:
        """Scenario ``b``'s feedforward supervisor (an :class:`adaptive_ff.compensation.supervisor.FeedforwardSupervisor`,
        copied by value; read its state back with :meth:`supervisor_state`) or None (the compensation is applied as
        it is)."""
        sc = self.scenarios[b]
        sc.use_supervisor = supervisor is not None
        if supervisor is not None:
            sc.sup = supervisor.cdata[0]

    def supervisor_state(self, b: int, supervisor) -> None:
        """Copy scenario ``b``'s supervisor struct after :meth:`run` into ``supervisor`` (its counters then read the
        run's)."""
        supervisor.cdata[0] = self.scenarios[b].sup

    def set_pi(self, b: int, controller) -> None:
        """Scenario ``b``'s PI (a :class:`controllers.PIController`, copied by value)."""
        self.scenarios[b].pi = controller.cdata[0]

    def set_pi_all(self, controller) -> None:
        """Every scenario's PI: ``controller`` (a :class:`controllers.PIController`, copied by value into each; C
        ``ctl_scenarios_set_pi``), :meth:`set_pi` of each scenario in one C pass."""
        lib.ctl_scenarios_set_pi(self.scenarios, len(self.scenarios), controller.cdata)

    def set_compensator(self, b: int, comp) -> None:
        """Scenario ``b``'s compensator: its own struct is advanced in place (kept alive here); a
        :class:`controllers.simulation.user_compensator.UserCompensator` is called back through its ops table;
        None: none."""
        if comp is None:
            return
        name = getattr(comp, "C_OPS", None)
        sc = self.scenarios[b]
        if name is None and hasattr(comp, "ops") and hasattr(comp, "handle"):  # a user's Python compensator
            self._keep.append(comp)
            sc.comp = comp.handle
            sc.ops = comp.ops
            return
        if name is None:
            raise ParameterError(f"compensator must be a compensator component (C_OPS), a UserCompensator or None, "
                                 f"got {comp!r}")
        ops = self._ops.get(name)
        if ops is None:  # the engine's own table where it has one (its loop then calls the functions directly)
            ops = lib.ctl_known_ops(name.encode())
            if ops == ffi.NULL:  # cffi reads a const table as a value: one copy per run, kept alive here
                ops = ffi.new("aff_compensator_ops *", getattr(lib, name))
            self._ops[name] = ops
        self._keep.append(comp)
        sc.comp = ffi.cast("void *", comp.cdata)
        sc.ops = ops

    def run(self) -> None:
        """Run every scenario to the end (or divergence) in chunks on :func:`engine_threads` threads."""
        B = len(self.scenarios)
        threads = engine_threads()
        chunk = max(_CHUNK_MIN, min(_CHUNK, -(-B // threads)))
        bounds = [(b0, min(B, b0 + chunk)) for b0 in range(0, B, chunk)]
        one = lambda b: lib.ctl_run_chunk(self.c_run, self.scenarios + b[0], b[1] - b[0])  # noqa: E731
        if threads == 1 or len(bounds) == 1:
            for bd in bounds:
                one(bd)
        else:
            with ThreadPoolExecutor(max_workers=min(threads, len(bounds))) as pool:
                list(pool.map(one, bounds))

    def metrics(self) -> np.ndarray:
        """The scenarios' metric accumulators, a copy as a numpy array of
        :data:`controllers.simulation.metrics.METRICS_DTYPE`, shape (B,)."""
        B = len(self.scenarios)
        out = np.empty(B, dtype=METRICS_DTYPE)
        raw = np.frombuffer(ffi.buffer(self.scenarios), dtype=np.uint8).reshape(B, _SCENARIO_FIELDS.itemsize)
        off = _SCENARIO_FIELDS.fields["metrics"][1]
        out.view(np.uint8).reshape(B, -1)[:] = raw[:, off:off + METRICS_DTYPE.itemsize]  # the bytes, as C has them
        return out

    def _fields(self) -> np.ndarray:
        """The scenarios' structs as a numpy view of :data:`_SCENARIO_FIELDS` (the fields read after a run), shape
        (B,)."""
        return np.frombuffer(ffi.buffer(self.scenarios), dtype=_SCENARIO_FIELDS)

    def outcome(self) -> tuple:
        """``(k_end, diverged, n_theta)`` arrays (int64, bool, int64) of shape (B,)."""
        f = self._fields()
        return f["k_end"].astype(np.int64), f["diverged"] != 0, f["n_theta_rec"].astype(np.int64)
