"""One closed-loop run of the velocity loop: plant, PI controller and compensator objects in, a result out.

:func:`run_closed_loop` takes the objects themselves (a plant model of
:mod:`plant.models`, a :class:`controllers.design.pi.PIController`, a
compensator component or None) and runs them on the C engine
(:mod:`controllers.simulation.engine`). :func:`run_mode` builds the objects of
one named compensation mode from :class:`LoopConfig` through the registry
:mod:`controllers.simulation.compensators` (what ``compare`` does per mode).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from adaptive_ff.compensation.gate import OutlierGate
from adaptive_ff.identification.regression import FrictionEstimate
from controllers.design.pi import PIController
from controllers.simulation.compensators import (MODES, ESTIMATORS, TrueFriction, build_mode, build_supervisor,
                                                 own_supervisor)
from controllers.simulation.loop_config import LoopConfig, RunSettings
from controllers.simulation.engine import EngineMetrics, EngineRecord, EngineRun
from controllers.simulation.memory import MODE_SIGNALS, check_run_memory
from controllers.simulation.metrics import (LoopMetrics, MotionMetrics, engine_motion, loop_metrics, metrics_result,
                                            reversal_times)
from controllers.simulation.sensor_drive import Drive, Sensor
from controllers.simulation.user_compensator import UserCompensator, is_user_compensator
from plant.errors import ParameterError, check_finite_scalar, check_nonnegative, check_optional, check_positive
from plant.excitation import Reference
from plant.dynamics import check_integrable, plant_params
from plant.rows import params_state, stack_params
from plant.results import axes_or_new, json_safe

__all__ = ["MODES", "ESTIMATORS", "LoopConfig", "LoopMetrics", "ClosedLoopResult", "MeasurementSettings",
           "RunSettings", "run_closed_loop", "run_mode",
           "run_own", "loop_metrics", "plant_table", "mark_motion"]


@dataclass(frozen=True)
class ClosedLoopResult:
    """One closed-loop run.

    Attributes
    ----------
    mode : str
        Compensation mode (one of :data:`MODES`, or the compensator's ``MODE``).
    t : ndarray, shape (N,)
        Time (s) at the controller rate (every ``decimate``-th sample when
        ``decimate > 1``; empty for ``decimate=0``).
    w_ref, w, w_meas : ndarray, shape (N,)
        Reference, true and measured velocity (rad/s).
    u, u_ff : ndarray, shape (N,)
        Total (saturated) control torque and its compensation part (N·m).
    f : ndarray, shape (N,)
        True friction torque of the plant (N·m).
    t_theta : ndarray, shape (M,)
        Times of the estimator updates (s); empty without an estimator.
    theta : ndarray, shape (M, p)
        Parameter history of the compensator's estimator.
    estimate : FrictionEstimate or None
        Friction estimate in use at the end of the run.
    metrics : LoopMetrics
    info : dict
        Counters and settings: ``diverged`` (the velocity left ``±w_limit``; the
        rest of the record is NaN), ``n_sensor_rejected`` (measurements the
        sensor gate replaced by the last valid one), ``Tc``, ``noise_std``,
        ``decimate`` and the compensator's own counters (``n_rejected``,
        ``n_updates``, ``n_gated``, ``n_implausible``, ...); with a feedforward
        supervisor (:func:`run_mode` of a supervised mode, :func:`run_own` with
        ``supervise=True``) its ``n_backoff``, ``n_restore``, ``t_off`` (s backed
        off, the reference moving) and ``t_rest`` (s with the reference at rest,
        nothing applied).
    motion : MotionMetrics or None
        Error in motion and at standstill, settling time and largest error of each stop, largest error at each
        reversal (:class:`controllers.simulation.metrics.MotionMetrics`); every sample, whatever ``decimate``.
    """

    mode: str
    t: np.ndarray
    w_ref: np.ndarray
    w: np.ndarray
    w_meas: np.ndarray
    u: np.ndarray
    u_ff: np.ndarray
    f: np.ndarray
    t_theta: np.ndarray
    theta: np.ndarray
    estimate: FrictionEstimate | None
    metrics: LoopMetrics
    info: dict = field(default_factory=dict)
    motion: MotionMetrics | None = None

    @property
    def has_stops(self) -> bool:
        """Whether the reference comes to rest (a point-to-point move, the end of a reversing run): the motion
        metrics are then part of :meth:`to_dict` and :meth:`summary`."""
        return self.motion is not None and self.motion.n_stops > 0

    def to_dict(self) -> dict:
        """Mode, metrics, final estimate and info as strict JSON (no signals; NaN -> None); with ``"motion"``
        (:meth:`MotionMetrics.to_dict`) when the reference has stops (:attr:`has_stops`; a reference that never
        stops, the multi-sine, keeps the keys it had)."""
        est = None if self.estimate is None else self.estimate.to_dict()
        d = {"mode": self.mode, "metrics": self.metrics.to_dict(), "estimate": est, "info": self.info}
        if self.has_stops:
            d["motion"] = self.motion.to_dict()
        return json_safe(d)

    def summary(self) -> str:
        """The mode and its metrics, and whether it diverged; then, when the reference has stops, the motion
        metrics (:meth:`MotionMetrics.summary`)."""
        tail = " (diverged)" if self.info.get("diverged") else ""
        head = f"{self.mode}: {self.metrics.summary()}{tail}"
        return head + ("\n" + self.motion.summary() if self.has_stops else "")

    def plot(self, ax=None):
        """Reference and velocity (deg/s) over time on ``ax`` (a new figure when None); returns the Axes.

        When the reference has stops (:attr:`has_stops`, a robot's moves): each stop's dwell shaded (grey), the
        time its error settled into the band marked (a green tick at ``t_start + settling_time``; a red one at the
        dwell's end when it did not settle), each reversal a dotted vertical line (:func:`mark_motion`), and the
        legend to the right of the axes (a new figure is made wider for it).
        """
        stops = self.has_stops
        ax = axes_or_new(ax, figsize=(9.5, 3.0) if stops else (8.0, 3.0))
        ax.plot(self.t, np.rad2deg(self.w_ref), "k--", lw=0.8, label="reference")
        ax.plot(self.t, np.rad2deg(self.w), lw=1.0, label=self.mode)
        ax.set_xlabel("time [s]")
        ax.set_ylabel("velocity [deg/s]")
        if stops:
            mark_motion(ax, self.motion)
            ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, fontsize=8, frameon=False)
        else:
            ax.legend(loc="upper right")
        return ax


def mark_motion(ax, motion: MotionMetrics, *, labels: bool = True) -> None:
    """Mark the stops and reversals of ``motion`` on the time axis of ``ax`` (matplotlib Axes).

    Each stop's dwell (``stop_start`` to ``stop_end``) is shaded grey, its settling marked by a green vertical
    tick at ``stop_start + settling_time`` (red at ``stop_end`` when it did not settle, none when incomplete),
    each reversal a dotted grey vertical line. ``labels``: put one legend entry per kind.
    """
    first = {"dwell": labels, "settled": labels, "not settled": labels, "reversal": labels}

    def lab(k):
        on = first[k]
        first[k] = False
        return k if on else None

    for a, b, ts in zip(motion.stop_start, motion.stop_end, motion.settling_time):
        ax.axvspan(a, b, color="0.85", lw=0, zorder=0, label=lab("dwell"))
        if np.isfinite(ts):
            ax.axvline(a + ts, color="#009E73", lw=0.9, ymax=0.12, label=lab("settled"))
        elif np.isinf(ts):
            ax.axvline(b, color="#D55E00", lw=0.9, ymax=0.12, label=lab("not settled"))
    for tr in motion.reversal_times:
        ax.axvline(tr, color="0.5", lw=0.7, ls=":", label=lab("reversal"))


def plant_table(p, t, Tc: float) -> tuple:
    """Parameter rows of a (possibly time-varying) plant for the engine, and the sample each row starts at.

    Parameters
    ----------
    p : plant model, FrictionRipple, FrictionDrift or PayloadStep
        A plant of :mod:`plant.models`; a time-varying plant (one with ``at(t)`` and ``row_starts(t, Tc)``:
        :class:`plant.drift.FrictionDrift`, frozen every ``p.period`` s; :class:`plant.payload.PayloadStep`, its
        inertia switched at ``t_step``; a :class:`plant.ripple.FrictionRipple` around either) has one row per
        start sample, row ``j`` the plant ``p.at(t[row_k[j]])`` (row 0: ``p.at(0.0)``).
    t : ndarray, shape (N,)
        Time of the run (s).
    Tc : float
        Controller period (s).

    Returns
    -------
    table : cffi ``plant_params[K]``
        Row ``j`` is the plant from sample ``row_k[j]`` on.
    row_k : ndarray of int, shape (K,)
        Start samples of the rows, increasing, ``row_k[0] = 0`` (what
        :meth:`controllers.simulation.engine.EngineRun.set_plant` takes).

    Raises
    ------
    ParameterError
        A row the engine cannot integrate over ``Tc`` (:func:`plant.dynamics.check_integrable`, with the reason).
    """
    if not hasattr(p, "at"):
        table, row_k = stack_params([plant_params(p)]), np.zeros(1, dtype=np.int64)
    else:
        t = np.asarray(t, dtype=float)
        row_k = np.asarray(p.row_starts(t, Tc), dtype=np.int64)
        table = stack_params([plant_params(p.at(0.0))] + [plant_params(p.at(tk)) for tk in t[row_k[1:]].tolist()])
    check_integrable(table, Tc)
    return table, row_k


def _check_decimate(decimate) -> int:
    if isinstance(decimate, bool) or not isinstance(decimate, (int, np.integer)) or decimate < 0:
        raise ParameterError(f"decimate must be an integer >= 0, got {decimate!r}")
    return int(decimate)


def _faults(faults, n: int) -> tuple:
    if not faults:
        return np.empty(0, dtype=np.int64), np.empty(0)
    items = sorted((int(k), float(v)) for k, v in dict(faults).items() if 0 <= int(k) < n)
    return np.array([k for k, _ in items], dtype=np.int64), np.array([v for _, v in items], dtype=float)


def _sensor_gate(sensor_gate, controller: PIController, J: float) -> OutlierGate | None:
    if sensor_gate is False or sensor_gate is None:
        return None
    if isinstance(sensor_gate, OutlierGate):
        return sensor_gate
    if sensor_gate is True:
        u_max = controller.u_max
        return OutlierGate(max_step=2.0 * u_max * controller.Tc / J if math.isfinite(u_max) else math.inf)
    raise ParameterError(f"sensor_gate must be True, False or an OutlierGate, got {sensor_gate!r}")


def _update_period(compensator) -> int:
    """Controller periods between two estimator updates of a compensator (sizes the theta history)."""
    est = getattr(compensator, "estimator", None)
    m = getattr(est, "m", None) if est is not None else getattr(compensator, "m", None)
    return max(int(m), 1) if m else 1


@dataclass(frozen=True)
class MeasurementSettings:
    """How the loop of :func:`run_closed_loop` measures the velocity.

    Parameters
    ----------
    noise_std : float
        White velocity-measurement noise (rad/s), >= 0; default 0. Needs ``rng``.
    rng : numpy.random.Generator or None
        Noise source: ``rng.normal(0, noise_std, N)``.
    faults : mapping int -> float or None
        Measurement faults: the measured velocity of sample ``k`` is replaced by ``faults[k]``.
    sensor_gate : bool or OutlierGate
        Give the controller (and the peers) the last valid measurement when a sample is non-finite or a
        physically impossible jump; True (default) builds :class:`adaptive_ff.OutlierGate` with ``max_step =
        2*u_max*Tc/J``; an OutlierGate is used as given. The estimators get the raw sample and gate it themselves.
    """

    noise_std: float = 0.0
    rng: np.random.Generator | None = None
    faults: object = None
    sensor_gate: object = True


def run_closed_loop(plant, controller: PIController, compensator, reference: Reference, *,
                    measurement: MeasurementSettings | None = None,
                    settings: RunSettings | None = None) -> ClosedLoopResult:
    """Simulate the PI velocity loop on the plant at the controller rate with one compensator.

    Parameters
    ----------
    plant : plant model
        True plant: :class:`plant.JointParams` or a variant of :mod:`plant.models` (LuGre, Karnopp,
        asymmetric), possibly wrapped in :class:`plant.drift.FrictionDrift` (re-frozen every ``p.period`` s),
        :class:`plant.ripple.FrictionRipple` or :class:`plant.payload.PayloadStep` (:func:`plant_table`).
    controller : PIController
        The PI (gains, period ``Tc`` = the integration step, saturation); its integrator state is
        advanced in place.
    compensator : compensator component, your own compensator, or None
        A :class:`adaptive_ff.FrictionFeedforward` (fixed), :class:`adaptive_ff.RobustAdaptiveFeedforward`,
        :class:`adaptive_ff.compensation.eq4_feedforward.AdaptiveFrictionFeedforward`,
        :class:`controllers.CanudasCompensator`, :class:`controllers.DisturbanceObserver`,
        :class:`controllers.simulation.compensators.TrueFriction` (the oracle), any object with
        ``compensate(w_meas, w_ref)`` and ``observe(u, w_meas)`` methods (run through
        :class:`controllers.simulation.user_compensator.UserCompensator`; the result's mode is its name), or
        None (no compensation). Its state is advanced in place (read its counters and estimate afterwards).
    reference : Reference
        Velocity reference sampled at ``controller.Tc`` (e.g. :func:`plant.multisine_reference`).
    measurement : MeasurementSettings, keyword-only
        Noise, faults and the sensor gate (default: ``MeasurementSettings()``, noise-free, gated).
    settings : RunSettings, keyword-only
        Divergence bound, records, reversal window, initial friction (default: ``RunSettings()``).

    Returns
    -------
    ClosedLoopResult

    Raises
    ------
    CompensatorError
        Your own compensator raised or returned a non-finite torque (the period is named; the run ended there).
    ParameterError
        Reference step not equal to ``controller.Tc``, noise without ``rng``, bad ``decimate``,
        ``sensor_gate``, ``w_limit`` or ``friction0``, a compensator without the component protocol, or a
        reference too long for the memory available (its noise and records,
        :func:`controllers.simulation.memory.check_run_memory`, checked before they are allocated).

    Notes
    -----
    Per period ``Tc``: measure ``w_meas = w + noise`` (or the injected fault); the gate yields the
    controller's measurement ``w_c``; the compensator gives ``u_c``; ``u = sat(PI(w_ref - w_c) + u_c)`` with
    anti-windup; the compensator observes ``(u, w_meas)``; the plant advances one step with ``u`` held
    (RK4, Ruderman eqs. 1-3). All of it runs in the compiled engine (:mod:`controllers.simulation.engine`).
    The measurement is ``w + noise`` and the command is applied as it is; an encoder, a measurement delay and
    a torque slew-rate limit: :func:`run_mode` / :func:`run_own` with ``LoopConfig.from_flat(encoder_counts=...,
    delay=..., slew_rate=...)`` (:mod:`controllers.simulation.sensor_drive`).
    """
    m = MeasurementSettings() if measurement is None else measurement
    r = RunSettings() if settings is None else settings
    check_optional("measurement", measurement, MeasurementSettings)
    check_optional("settings", settings, RunSettings)
    return _run_loop(plant, controller, compensator, reference, noise_std=m.noise_std, rng=m.rng, faults=m.faults,
                     sensor_gate=m.sensor_gate, w_limit=r.w_limit, decimate=r.decimate,
                     reversal_window=r.reversal_window, friction0=r.friction0, sensor=None, drive=None)


def _run_loop(plant, controller, compensator, reference, *, noise_std, rng, faults, sensor_gate, w_limit, decimate,
              reversal_window, friction0, sensor, drive, supervisor=None, mode=None) -> ClosedLoopResult:
    """:func:`run_closed_loop` with the loop's sensor and drive (:class:`Sensor`, :class:`Drive` or None; copied)
    and a feedforward supervisor (:class:`adaptive_ff.compensation.supervisor.FeedforwardSupervisor` or None; its
    state advanced as the run's, its counters in the result's ``info``); the result's ``mode`` is ``mode`` where
    given, else the compensator's."""
    if not isinstance(controller, PIController):
        raise ParameterError(f"controller must be a PIController, got {type(controller).__name__}")
    oracle = isinstance(compensator, TrueFriction)
    if compensator is not None and not oracle and getattr(compensator, "C_OPS", None) is None:
        if not isinstance(compensator, UserCompensator):
            if not is_user_compensator(compensator):
                raise ParameterError(f"compensator must be a compensator component, an object with compensate("
                                     f"w_meas, w_ref) and observe(u, w_meas) methods, or None, got {compensator!r}")
            compensator = UserCompensator(compensator)
    decimate = _check_decimate(decimate)
    Tc = controller.Tc
    noise_std = check_nonnegative("noise_std", noise_std)
    reversal_window = check_nonnegative("reversal_window", reversal_window)
    t = np.ascontiguousarray(reference.t, dtype=float)
    wr = np.ascontiguousarray(reference.w, dtype=float)
    n = t.shape[0]
    if n > 1 and not math.isclose(t[1] - t[0], Tc, rel_tol=1e-9):
        raise ParameterError(f"reference step {t[1] - t[0]!r} s differs from Tc = {Tc!r} s")
    if noise_std > 0 and rng is None:
        raise ParameterError("noise_std > 0 needs rng=np.random.default_rng(seed)")
    if n > 0:  # the noise, the records (every decimate-th sample) and the parameter history
        check_run_memory(n * Tc, Tc, signals=1 + (-(-(MODE_SIGNALS - 1) // decimate) if decimate else 0),
                         what="the reference's duration", detail="the noise and records of one run")
    w_limit = 100.0 * float(np.max(np.abs(wr))) + 1.0 if w_limit is None else check_positive("w_limit", w_limit)
    table, row_k = plant_table(plant, t, Tc)
    frozen = plant.at(0.0) if hasattr(plant, "at") else plant
    gate = _sensor_gate(sensor_gate, controller, float(frozen.J) if sensor_gate is True else math.nan)
    n_theta = 0 if compensator is None or oracle else int(getattr(compensator, "n_theta", 0))
    state0 = params_state(table, float(wr[0]))  # row 0: the plant at t = 0 (``frozen``), packed once
    if friction0 is not None and getattr(frozen, "tau", 0.0) > 0:  # the lagged models (LuGre has no tau)
        state0.s = check_finite_scalar("friction0", friction0)
    revs = reversal_times(t, wr)
    m_theta = n // _update_period(compensator) + 1 if (decimate and n_theta) else 0
    x = EngineRun(t=t, w_ref=wr, dt=float(Tc), n_scenarios=1, faults=_faults(faults, n), oracle=oracle,
                  metrics=EngineMetrics(revs=revs, window=float(reversal_window)),
                  record=EngineRecord(decimate=decimate, n_theta=n_theta, m_theta=m_theta))
    x.set_plant(0, table, len(table), row_k, state0, w_limit)
    if noise_std > 0:
        x.set_noise_table(rng.normal(0.0, noise_std, size=n)[None, :])
        x.set_noise_row(0, 0)
    x.set_gate(0, gate)
    x.set_sensor(0, check_optional("sensor", sensor, Sensor))
    x.set_drive(0, check_optional("drive", drive, Drive))
    x.set_pi(0, controller)
    x.set_compensator(0, None if oracle else compensator)
    x.set_supervisor(0, supervisor if compensator is not None and not oracle else None)
    x.run()
    if isinstance(compensator, UserCompensator):
        compensator.raise_error()
    controller.cdata[0] = x.scenarios[0].pi  # the controller's and the gate's state advance as in a loop
    if gate is not None:
        gate.cdata[0] = x.scenarios[0].gate
    res = _result(x, plant, compensator, t, wr, revs, gate, decimate, n_theta, noise_std, Tc, float(reversal_window),
                  mode)
    if supervisor is not None and x.scenarios[0].use_supervisor:
        x.supervisor_state(0, supervisor)
        res.info.update(supervisor.info())
    own = own_supervisor(compensator)
    if own is not None:  # the compensator's own (mode adaptive), advanced in its struct
        res.info.update(own.info())
    return res


def sensor_and_drive(options: LoopConfig) -> tuple:
    """The :class:`Sensor` and :class:`Drive` of ``options`` (``encoder_counts``, ``delay``, ``slew_rate``), each
    None where the options ask for none."""
    Tc, s = options.controller.Tc, options.sensor
    sensor = (Sensor(Tc=Tc, counts_per_rev=s.encoder_counts, delay=s.delay, velocity=s.velocity,
                     bandwidth=s.velocity_bandwidth, model=s.velocity_model)
              if s.encoder_counts is not None or s.delay else None)
    drive = Drive(Tc=Tc, slew_rate=options.drive.slew_rate) if math.isfinite(options.drive.slew_rate) else None
    return sensor, drive


def _result(x: EngineRun, plant, compensator, t, wr, revs, gate, decimate, n_theta, noise_std, Tc, window,
            mode=None):
    k_end, diverged, n_th = (a[0] for a in x.outcome())
    n = t.shape[0]
    metrics = metrics_result(x.scenarios[0].metrics)
    motion = engine_motion(x, x.metrics(), t, revs, window=window, diverged=[bool(diverged)])[0]
    if diverged:
        nan = math.nan
        rev = metrics.rms_reversal
        if k_end < n and _window_after(t, revs, window, k_end):
            rev = nan
        metrics = LoopMetrics(rms=nan, max=nan, rms_second_half=nan, max_second_half=nan, rms_reversal=rev,
                              u_rms=nan)
    W, WM, U, UFF, F = (x.rec[0, i] for i in range(5))
    ts, wrs = (t[::decimate], wr[::decimate]) if decimate else (t[:0], wr[:0])
    if n_theta and decimate and n_th:
        th = x.theta[0, :n_th].copy()
        t_th = t[x.theta_k[0, :n_th]]
    else:
        th, t_th = np.empty((0, 0)), np.empty(0)
    info = {"Tc": Tc, "noise_std": noise_std, "diverged": bool(diverged), "decimate": decimate,
            "n_sensor_rejected": gate.n_rejected if gate is not None else 0}
    if compensator is not None and hasattr(compensator, "info"):
        info.update(compensator.info())
    if mode is None:
        mode = getattr(compensator, "MODE", "none") if compensator is not None else "none"
    est = getattr(compensator, "estimate", None)
    est = est if isinstance(est, FrictionEstimate) else None
    return ClosedLoopResult(mode=mode, t=ts, w_ref=wrs, w=W, w_meas=WM, u=U, u_ff=UFF, f=F, t_theta=t_th, theta=th,
                            estimate=est, metrics=metrics, info=info, motion=motion)


def run_own(plant, reference: Reference, compensator, options: LoopConfig, *, name: str | None = None,
            rng: np.random.Generator | None = None, faults=None, supervise: bool = False) -> ClosedLoopResult:
    """Run your own compensator in the loop of :func:`run_mode` (the PI, sensor gate and noise of ``options``).

    Parameters
    ----------
    plant : plant model
        True plant (see :func:`run_closed_loop`).
    reference : Reference
        Velocity reference sampled at ``options.controller.Tc``.
    compensator : object
        Has ``compensate(w_meas, w_ref)`` and ``observe(u, w_meas)``
        (:mod:`controllers.simulation.user_compensator`); its state advances in place.
    options : LoopConfig
        The loop's settings (gains, saturation, noise, sensor gate, ``J_design``); the compensation settings
        are not used.
    name : str, keyword-only, optional
        The result's mode; default the compensator's ``MODE``, ``name`` or class name.
    rng, faults : keyword-only
        As :func:`run_mode`.
    supervise : bool, keyword-only
        Pass the compensator's torque through a feedforward supervisor
        (:func:`controllers.simulation.compensators.build_supervisor` with the ``supervise_*`` settings of
        ``options``), which backs it off to none while it makes the loop's torque disturbance larger; default False
        (your compensator is applied as it is).

    Returns
    -------
    ClosedLoopResult
        Its ``mode`` is the compensator's name; ``info`` carries ``n_calls`` and the object's own ``info()`` (and
        ``n_backoff``, ``n_restore``, ``t_off`` with ``supervise``).

    Raises
    ------
    ParameterError
        The object lacks the protocol, bad settings.
    CompensatorError
        The compensator raised or returned a non-finite torque (the period is named).
    """
    comp = compensator if isinstance(compensator, UserCompensator) else UserCompensator(compensator, name=name)
    run_plant, controller, _ = build_mode(plant, "none", options)
    gate = options.sensor.gate
    if gate is True:
        frozen = plant.at(0.0) if hasattr(plant, "at") else plant
        J_design = options.controller.J_design
        gate = _sensor_gate(True, controller, float(frozen.J) if J_design is None else J_design)
    sensor, drive = sensor_and_drive(options)
    sup = build_supervisor(plant, "own", options.replace(supervise=True), force=True) if supervise else None
    return _run_loop(run_plant, controller, comp, reference, noise_std=options.sensor.noise_std, rng=rng,
                     faults=faults, sensor_gate=gate, w_limit=options.run.w_limit, decimate=options.run.decimate,
                     reversal_window=options.run.reversal_window, friction0=options.run.friction0, sensor=sensor,
                     drive=drive, supervisor=sup, mode=comp.name)


def _window_after(t, revs, window, k_end) -> bool:
    """Whether a second-half reversal-window sample lies at or after ``k_end`` (its metric is then undefined)."""
    if not len(revs):
        return False
    tt = t[k_end:]
    tt = tt[tt >= 0.5 * (t[0] + t[-1])]
    if not tt.size:
        return False
    idx = np.searchsorted(revs, tt)
    lo = np.abs(tt - revs[np.clip(idx - 1, 0, len(revs) - 1)])
    hi = np.abs(revs[np.clip(idx, 0, len(revs) - 1)] - tt)
    return bool(np.any(np.minimum(lo, hi) <= window))


def run_mode(plant, reference: Reference, mode: str, options: LoopConfig, *, rng: np.random.Generator | None = None,
             faults=None) -> ClosedLoopResult:
    """Run one named compensation mode: build its objects (:func:`build_mode`) and :func:`run_closed_loop`.

    Parameters
    ----------
    plant : plant model
        True plant (see :func:`run_closed_loop`).
    reference : Reference
        Velocity reference sampled at ``options.controller.Tc``.
    mode : str
        One of :data:`MODES`.
    options : LoopConfig
        Controller, compensator and simulation settings.
    rng : numpy.random.Generator, keyword-only
        Noise source (needed when ``options.sensor.noise_std > 0``).
    faults : mapping int -> float, keyword-only
        Measurement faults (see :func:`run_closed_loop`).

    Returns
    -------
    ClosedLoopResult
        With ``mode`` set to the name given and ``info`` holding ``Ts`` and ``ff_input`` too, and for a supervised
        mode (``options.supervisor.enabled``, :data:`controllers.simulation.compensators.SUPERVISED_MODES`) the
        supervisor's ``n_backoff``, ``n_restore`` and ``t_off`` (s).

    Raises
    ------
    ParameterError
        Unknown mode, settings missing for it, or invalid settings.
    """
    run_plant, controller, compensator = build_mode(plant, mode, options)
    gate = options.sensor.gate
    if gate is True:  # the gate of the design inertia (default: the plant's J, a data-sheet value)
        frozen = plant.at(0.0) if hasattr(plant, "at") else plant
        J_design = options.controller.J_design
        gate = _sensor_gate(True, controller, float(frozen.J) if J_design is None else J_design)
    sensor, drive = sensor_and_drive(options)
    res = _run_loop(run_plant, controller, compensator, reference, noise_std=options.sensor.noise_std, rng=rng,
                    faults=faults, sensor_gate=gate, w_limit=options.run.w_limit, decimate=options.run.decimate,
                    reversal_window=options.run.reversal_window, friction0=options.run.friction0, sensor=sensor,
                    drive=drive,
                    supervisor=None if own_supervisor(compensator) is not None else
                    build_supervisor(plant, mode, options), mode=mode)
    res.info.update(Ts=options.estimator.Ts, ff_input=options.feedforward.ff_input)  # the run's own dict
    return res
