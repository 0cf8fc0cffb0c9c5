"""Batches of closed-loop scenarios on the C engine: every mode on every plant model, metrics streamed.

:func:`run_batch` runs B scenarios (one plant each, a common reference) in one
call of the engine that also runs single runs
(:mod:`controllers.simulation.engine`), in parallel over chunks of scenarios
on threads (:func:`controllers.simulation.engine.engine_threads`). Memory is O(B) apart from optional noise arrays; no
signals are recorded.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from adaptive_ff.compensation.gate import OutlierGate
from controllers.simulation.closed_loop import plant_table, sensor_and_drive
from controllers.simulation.compensators import (MODES, LoopConfig, TrueFriction, build_modes, build_supervisor,
                                                 own_supervisor)
from controllers.simulation.engine import EngineMetrics, EngineRun
from controllers.simulation.metrics import METRIC_NAMES, metrics_columns, reversal_times, engine_motion
from plant.errors import ParameterError
from plant.excitation import Reference
from plant.rows import check_integrable, integrable_rows, plant_rows, plant_state, plant_states
from plant.results import json_safe

__all__ = ["BATCH_MODES", "BatchResult", "run_batch"]

#: Modes supported by the batch engine: all of them.
BATCH_MODES = MODES


@dataclass(frozen=True)
class BatchResult:
    """Metrics of B closed-loop runs, each array of shape (B,); definitions of
    :class:`controllers.simulation.metrics.LoopMetrics` (velocity error ``e = w_ref - w``, rad/s).

    Attributes
    ----------
    mode : str
    rms, max, rms_second_half, max_second_half, rms_reversal : ndarray, shape (B,)
        Error metrics (rad/s); NaN for diverged runs.
    u_rms : ndarray, shape (B,)
        RMS control torque (N·m); NaN for diverged runs.
    diverged : ndarray of bool, shape (B,)
        |w| left ``w_limit``.
    compensators : tuple
        The compensator object of each scenario (None where the mode has none), with its final state.
    motion : tuple of MotionMetrics
        Per scenario: error in motion and at standstill, settling time and largest error of each stop of the
        reference, largest error at each reversal (:class:`controllers.simulation.metrics.MotionMetrics`; the
        per-event arrays are the scenario's own).
    supervisors : tuple
        The feedforward supervisor of each scenario with its final state (counters ``n_backoff``, ``t_off``), None
        where the mode is not supervised (:func:`controllers.simulation.compensators.build_supervisor`).
    """

    mode: str
    rms: np.ndarray
    max: np.ndarray
    rms_second_half: np.ndarray
    max_second_half: np.ndarray
    rms_reversal: np.ndarray
    u_rms: np.ndarray
    diverged: np.ndarray
    compensators: tuple = ()
    motion: tuple = ()
    supervisors: tuple = ()

    @property
    def has_stops(self) -> bool:
        """Whether the common reference comes to rest: the motion metrics are then part of :meth:`to_dict` and
        :meth:`summary`."""
        return bool(self.motion) and self.motion[0].n_stops > 0

    def motion_column(self, name: str) -> np.ndarray:
        """One aggregate of :class:`controllers.simulation.metrics.MotionMetrics` (``rms_motion``,
        ``settling_max``, ``max_reversal``, ...) over the scenarios, shape (B,)."""
        return np.array([getattr(m, name) for m in self.motion], dtype=float)

    def to_dict(self) -> dict:
        """Mode, metric arrays as lists (NaN -> None) and the diverged flags (strict JSON); ``"motion"``, one
        :meth:`MotionMetrics.to_dict` per scenario, when the reference has stops (:attr:`has_stops`)."""
        d = {"mode": self.mode, "diverged": [bool(x) for x in self.diverged]}
        d.update({k: getattr(self, k).tolist() for k in METRIC_NAMES})
        if self.has_stops:
            d["motion"] = [m.to_dict() for m in self.motion]
        return json_safe(d)

    def summary(self) -> str:
        """One line: B, median and worst second-half RMS error (deg/s), diverged runs; when the reference has
        stops a second: median and worst in-motion RMS (deg/s) and longest settling time (s) over the
        scenarios."""
        r = np.rad2deg(self.rms_second_half)
        fin = r[np.isfinite(r)]
        med = float(np.median(fin)) if fin.size else math.nan
        worst = float(np.max(fin)) if fin.size else math.nan
        line = (f"{self.mode}: B = {self.diverged.size}, second-half RMS median {med:.4f} deg/s, worst "
                f"{worst:.4f} deg/s, diverged {int(np.count_nonzero(self.diverged))}")
        if not self.has_stops:
            return line
        rm = np.rad2deg(self.motion_column("rms_motion"))
        rm = rm[np.isfinite(rm)]
        st = self.motion_column("settling_max")
        st = st[~np.isnan(st)]
        return line + (f"\n  in motion RMS median {float(np.median(rm)) if rm.size else math.nan:.4f} deg/s, worst "
                       f"{float(np.max(rm)) if rm.size else math.nan:.4f} deg/s; settling max over the scenarios "
                       f"{float(np.max(st)) if st.size else math.nan:.3f} s")


def _options_list(options, B: int) -> list:
    if isinstance(options, LoopConfig):
        return [options] * B
    opts = list(options)
    if len(opts) != B or not all(isinstance(o, LoopConfig) for o in opts):
        raise ParameterError(f"options must be one LoopConfig or {B} of them")
    return opts


def _noise(noise, seeds, opts, B: int, n: int) -> tuple:
    if noise is not None:
        nz = np.asarray(noise, dtype=float)
        nz = nz[None, :] if nz.ndim == 1 else nz
        if nz.ndim != 2 or nz.shape[1] != n or nz.shape[0] not in (1, B):
            raise ParameterError(f"noise must have shape ({n},) or ({B}, {n}), got {np.shape(noise)}")
        if not np.all(np.isfinite(nz)):
            raise ParameterError("noise must be finite")
        return np.ascontiguousarray(nz), (B if nz.shape[0] == B and B > 1 else 1)
    stds = [o.sensor.noise_std for o in opts]
    if max(stds) > 0:
        if seeds is None or len(seeds) != B:
            raise ParameterError(f"noise_std > 0 needs seeds (length {B}) or noise=, got seeds={seeds!r}")
        nz = np.stack([np.random.default_rng(s).normal(0.0, sd, size=n) for s, sd in zip(seeds, stds)])
        return nz, (B if B > 1 else 1)
    return np.zeros((1, 1)), 0


def _unique(objs) -> tuple:
    """The distinct objects of ``objs`` (by identity, first-seen order) and the index of each entry among them."""
    first, uniq, idx = {}, [], []
    for x in objs:
        i = first.setdefault(id(x), len(uniq))
        if i == len(uniq):
            uniq.append(x)
        idx.append(i)
    return uniq, np.array(idx, dtype=np.int64)


def _plants_arrays(run_plants, plants, opts, t, wr, Tc) -> tuple:
    """Parameter rows, drift periods and initial states of the scenarios, and their sensor gates.

    Returns ``((rows, st), tables, n_rows, row_ks, states), index, gates``: ``tables[i]`` (a cffi
    ``plant_params`` array), ``row_ks[i]`` (the start samples of its rows, :func:`plant_table`; 0 for one row) and
    ``states[i]`` (``plant_state``) of the distinct plant ``i`` (a plant object given more than once,
    ``[p] * B``, is packed and checked once), ``index[b]`` the distinct plant of scenario ``b``. Plants that do
    not drift are packed in one table (:func:`plant.rows.plant_rows`), checked in one array pass and
    initialised in one C pass; a time-varying plant (drift, payload step) has one row per change. The arrays
    the entries point into (``rows`` of the static plants, their states ``st``) are returned first: the caller
    keeps them alive (an element of a cffi array does not own its memory)."""
    uniq, idx = _unique(run_plants)
    static = [k for k, rp in enumerate(uniq) if not hasattr(rp, "at")]
    rows = plant_rows([uniq[k] for k in static])
    bad = np.flatnonzero(~integrable_rows(rows, Tc))
    if bad.size:
        b = int(np.flatnonzero(idx == static[int(bad[0])])[0])
        try:
            check_integrable(rows + int(bad[0]), Tc)
        except ParameterError as e:
            raise ParameterError(f"plants[{b}]: {e}") from None
    st = plant_states(rows, float(wr[0]))
    tables, row_ks, states = [None] * len(uniq), [0] * len(uniq), [None] * len(uniq)
    for j, k in enumerate(static):
        tables[k], states[k] = rows + j, st[j]
    for k, rp in enumerate(uniq):
        if tables[k] is None:  # a time-varying plant: one row per change
            tables[k], row_ks[k] = plant_table(rp, t, Tc)
            states[k] = plant_state(rp.at(0.0), float(wr[0]))  # owns its struct
    n_rows = [1 if isinstance(row_ks[k], int) else len(tables[k]) for k in range(len(uniq))]
    gates = [_sensor_gate(p, o, Tc) for p, o in zip(plants, opts)]
    return ((rows, st), tables, n_rows, row_ks, states), idx, gates


def _sensor_gate(p, o, Tc: float):
    """The sensor plausibility gate of one scenario (None without ``sensor_gate``), sized by the design inertia."""
    if not o.sensor.gate:
        return None
    J_design = o.controller.J_design
    J = float((p.at(0.0) if hasattr(p, "at") else p).J) if J_design is None else float(J_design)
    return OutlierGate(max_step=2.0 * o.drive.u_max * Tc / J if math.isfinite(o.drive.u_max) else math.inf)


def run_batch(plants, reference: Reference, mode: str, options, *, seeds=None, noise=None,
              through=None) -> BatchResult:
    """Run B closed loops (one per plant) on a common reference with the C engine.

    Parameters
    ----------
    plants : sequence of plant models, length B
        True plants (any model of :mod:`plant.models`, possibly drifting).
    reference : Reference
        Velocity reference sampled at ``Tc``, shared by all scenarios.
    mode : str
        One of :data:`BATCH_MODES` (every mode of :data:`controllers.simulation.compensators.MODES`).
    options : LoopConfig or sequence of B LoopConfig
        Settings, common or per scenario (gains, saturation, estimates, noise level ...); the controller
        period ``Tc`` and ``decimate`` of the first are used for all. No signals are recorded.
    seeds : sequence of int, length B, keyword-only
        Noise seeds (needed when ``noise_std > 0`` and ``noise`` is None): the noise of scenario b is
        ``np.random.default_rng(seeds[b]).normal(0, noise_std, N)``, exactly as ``run_mode(...,
        rng=np.random.default_rng(seeds[b]))`` (memory B*N).
    noise : ndarray, shape (N,) or (B, N), keyword-only
        Explicit measurement noise (rad/s), overrides ``noise_std``/``seeds``.
    through : ExportedLibrary or None, keyword-only
        Run mode ``adaptive``'s compensator of each scenario by this compiled export
        (:class:`controllers.simulation.exported.ExportedLibrary`: the library's code, configured with the
        package's settings) instead of the package's module; default None. Other modes are not affected.

    Returns
    -------
    BatchResult

    Raises
    ------
    ParameterError
        Bad mode, shapes, values, or missing estimate/seeds (the message names the argument).

    Notes
    -----
    Scenario b equals ``run_mode(plants[b], reference, mode, options_b, rng=default_rng(seeds[b]))`` bit for
    bit (the same C engine; each scenario's result does not depend on B or the chunking).
    """
    plants = list(plants)
    B = len(plants)
    if B == 0:
        raise ParameterError("plants must contain at least one plant model, got an empty sequence")
    opts = _options_list(options, B)
    Tc = opts[0].controller.Tc
    if any(not math.isclose(o.controller.Tc, Tc) for o in opts):
        raise ParameterError("all options must share the controller period Tc")
    t = np.ascontiguousarray(reference.t, dtype=float)
    wr = np.ascontiguousarray(reference.w, dtype=float)
    n = t.shape[0]
    if n > 1 and not math.isclose(t[1] - t[0], Tc, rel_tol=1e-9):
        raise ParameterError(f"reference step {t[1] - t[0]!r} s differs from Tc = {Tc!r} s")
    run_plants, ctrls, comps = build_modes(plants, mode, opts)
    if through is not None and mode == "adaptive":
        comps = [through.compensator(c) for c in comps]
    (rows, tables, n_rows, row_ks, states), idx, gates = _plants_arrays(run_plants, plants, opts, t, wr, Tc)
    oracle = isinstance(comps[0], TrueFriction)
    nz, nrows = _noise(noise, seeds, opts, B, n)
    w_default = 100.0 * float(np.max(np.abs(wr))) + 1.0
    revs = reversal_times(t, wr)
    x = EngineRun(t=t, w_ref=wr, dt=float(Tc), n_scenarios=B, oracle=oracle,
                  metrics=EngineMetrics(revs=revs, window=float(opts[0].run.reversal_window)))
    x.set_noise_table(nz if nrows else None)
    w_limit = [w_default if o.run.w_limit is None else float(o.run.w_limit) for o in opts]
    if len(rows[0]) == len(tables):  # every distinct plant fixed in time (one row each): one C pass
        x.set_plants(rows[0], rows[1], idx, w_limit)
    else:
        for b in range(B):
            k = idx[b]
            x.set_plant(b, tables[k], n_rows[k], row_ks[k], states[k], w_limit[b])
    if all(c is ctrls[0] for c in ctrls):  # one options object: its PI copied into every scenario in one C pass
        x.set_pi_all(ctrls[0])
    else:
        for b in range(B):
            x.set_pi(b, ctrls[b])
    parts = {}  # the sensor and drive of each distinct options object (copied by value into its scenarios)
    sups = [None] * B
    for b in range(B):
        o = opts[b]
        if nrows:
            x.set_noise_row(b, b if nrows > 1 else 0)
        if gates[b] is not None:  # a new scenario has none
            x.set_gate(b, gates[b])
        if id(o) not in parts:
            parts[id(o)] = sensor_and_drive(o)
        sensor, drive = parts[id(o)]
        if sensor is not None:  # a new scenario has none, nor a drive
            x.set_sensor(b, sensor)
        if drive is not None:
            x.set_drive(b, drive)
        if comps[b] is not None and not oracle:
            x.set_compensator(b, comps[b])
        own = own_supervisor(comps[b])  # applied by the compensator itself (mode adaptive), advanced in its struct
        if own is not None:
            sups[b] = own
        else:
            sups[b] = None if comps[b] is None or oracle else build_supervisor(plants[b], mode, o)
            if sups[b] is not None:  # a new scenario has none
                x.set_supervisor(b, sups[b])
    x.keep(rows)
    x.run()
    for b in range(B):
        if sups[b] is not None and x.scenarios[b].use_supervisor:  # the engine's copy of it, read back
            x.supervisor_state(b, sups[b])
    _, diverged, _ = x.outcome()
    states = x.metrics()
    cols = metrics_columns(states)
    for k in METRIC_NAMES:
        cols[k][diverged] = np.nan
    motion = engine_motion(x, states, t, revs, window=float(opts[0].run.reversal_window), diverged=diverged)
    return BatchResult(mode=mode, diverged=diverged, compensators=tuple(comps), motion=motion,
                       supervisors=tuple(sups), **cols)
