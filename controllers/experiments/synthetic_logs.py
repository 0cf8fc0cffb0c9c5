"""Synthetic drive logs from the simulated joint, shaped like real ones (for figures, examples and trying the CLI).

The paper's experiments (Sec. V) are a velocity loop on a robot joint: the
controller tracks a multi-sine reference while current and velocity are read
out at irregular instants (Fig. 10), and bidirectional constant-velocity runs
for the Stribeck curve (Fig. 8). These functions simulate both on the 1 kHz
RK4 plant and return what a data logger would record, so the ``adaptive-ff``
commands can be tried end to end without a robot.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from adaptive_ff.io.data import MeasuredData
from controllers.design.pi import PIController, PIDesign, design_pi
from controllers.experiments.quasi_static import QS_CROSSOVER, QS_TC
from controllers.simulation.closed_loop import MeasurementSettings, RunSettings, run_closed_loop
from plant.errors import ParameterError, SignalError, check_nonnegative, check_positive, check_signal, check_time
from plant.excitation import Reference, multisine_reference
from plant.friction import JointParams
from plant.joint import PlantResponse
from plant.sampling import Measurement, irregular_sample_times, sample

__all__ = ["closed_loop_response", "closed_loop_run", "ClosedLoopRun", "closed_loop_readout", "ClosedLoopReadout",
           "write_controller_log", "quasi_static_log", "encoder_counts", "write_log_csv"]


def _pi_loop(p: JointParams, ref: Reference, design: PIDesign, u_max: float, noise_std: float, rng):
    """The PI loop (no compensator, no sensor gate) on the closed-loop engine; ``(W, W_meas, U, F)`` per period.

    The joint starts at ``w_ref[0]`` with the friction lag unloaded (``F = 0`` where ``tau > 0``, else ``F(w)``)."""
    res = run_closed_loop(p, PIController.from_design(design, u_max=u_max), None, ref,
                          measurement=MeasurementSettings(noise_std=noise_std, rng=rng, sensor_gate=False),
                          settings=RunSettings(friction0=0.0))
    if res.info["diverged"]:
        raise ParameterError(f"the PI loop (Kp = {design.Kp!r}, Ki = {design.Ki!r}) diverged on {p!r}: "
                             "|w| exceeded 100 max|w_ref| + 1 rad/s")
    return res.w, res.w_meas, res.u, res.f


@dataclass(frozen=True)
class ClosedLoopRun:
    """A simulated PI velocity-loop run: the 1 kHz truth and what the controller itself saw.

    Attributes
    ----------
    response : PlantResponse
        The truth at the controller period: ``t`` (s), ``u`` (N·m, held over
        ``[t[k], t[k+1])``), ``w`` (rad/s, true), ``f`` (N·m), ``dt = Tc``.
    w_meas : ndarray, shape (N,)
        The velocity the controller measured at ``t[k]`` (rad/s): ``w + noise``.
    w_ref : ndarray, shape (N,)
        The reference (rad/s).
    """

    response: PlantResponse
    w_meas: np.ndarray
    w_ref: np.ndarray

    def controller_log(self) -> MeasuredData:
        """The controller's own record at its period (what a drive's trace buffer holds).

        Returns
        -------
        MeasuredData
            ``t`` (s), ``u`` (N·m, the command applied over ``[t[k], t[k+1])``), ``w`` (rad/s, the
            measured velocity at ``t[k]`` that the PI acted on): the rows of the sliding-regime
            regression (:func:`adaptive_ff.compensation.sliding_estimator.fit_sliding`).
        """
        r = self.response
        return MeasuredData(r.t.copy(), r.u.copy(), self.w_meas.copy(), source="simulated controller-rate log",
                            notes=(f"PI velocity loop, torque and measured velocity logged every {r.dt:g} s",))


def closed_loop_run(p: JointParams, reference: Reference, *, design: PIDesign, u_max: float = math.inf,
                    noise_std: float = 0.0, rng: np.random.Generator | None = None) -> ClosedLoopRun:
    """Simulate the PI velocity loop (no feedforward): the truth, the controller's measurements and the reference.

    Parameters
    ----------
    p, reference, design, u_max, noise_std, rng
        As in :func:`closed_loop_response` (which returns ``closed_loop_run(...).response``).

    Returns
    -------
    ClosedLoopRun

    Raises
    ------
    ParameterError
        Reference step differs from ``design.Tc``; noise without ``rng``.

    Notes
    -----
    Per period: ``u = sat(PI(w_ref - w_meas))`` (:class:`controllers.design.pi.PIController`,
    anti-windup), then one RK4 step of eqs. 1-3 with ``u`` held (Ruderman, Sec. V-B): the closed-loop
    engine (:func:`controllers.simulation.closed_loop.run_closed_loop`, no compensator, no sensor gate),
    from ``w = w_ref[0]`` with the friction lag unloaded.
    """
    Tc = design.Tc
    t = np.asarray(reference.t, dtype=float)
    if t.shape[0] > 1 and not math.isclose(t[1] - t[0], Tc, rel_tol=1e-9):
        raise ParameterError(f"reference step {t[1] - t[0]!r} s differs from design.Tc = {Tc!r} s")
    noise_std = check_nonnegative("noise_std", noise_std)
    if noise_std > 0 and rng is None:
        raise ParameterError("noise_std > 0 needs rng=np.random.default_rng(seed)")
    W, W_meas, U, F = _pi_loop(p, reference, design, u_max, noise_std, rng)
    return ClosedLoopRun(response=PlantResponse(t=t.copy(), u=U, w=W, f=F, dt=Tc), w_meas=W_meas,
                         w_ref=np.asarray(reference.w, dtype=float).copy())


def closed_loop_response(p: JointParams, reference: Reference, *, design: PIDesign, u_max: float = math.inf,
                         noise_std: float = 0.0, rng: np.random.Generator | None = None) -> PlantResponse:
    """Simulate the PI velocity loop (no feedforward) and return the 1 kHz truth as a :class:`PlantResponse`.

    Parameters
    ----------
    p : JointParams
        Plant.
    reference : Reference
        Velocity reference (rad/s) at the step ``design.Tc``.
    design : PIDesign, keyword-only
        Controller (:func:`controllers.design.pi.design_pi`).
    u_max : float, keyword-only
        Torque limit (N·m), default none.
    noise_std : float, keyword-only
        Velocity measurement noise seen by the controller (rad/s), >= 0.
    rng : numpy.random.Generator, keyword-only
        Needed when ``noise_std > 0``.

    Returns
    -------
    PlantResponse
        ``t`` (s), ``u`` (N·m, ``u[k]`` held over ``[t[k], t[k+1])``), ``w``
        (rad/s, true), ``f`` (N·m), ``dt = design.Tc``; sample it with
        :func:`plant.sampling.sample` like an open-loop response.

    Raises
    ------
    ParameterError
        Reference step differs from ``design.Tc``; noise without ``rng``.

    Notes
    -----
    Per period: ``u = sat(PI(w_ref - w_meas))`` (:class:`controllers.design.pi.PIController`,
    anti-windup), then one RK4 step of eqs. 1-3 with ``u`` held. This is the
    paper's data collection (Sec. V-B: closed loop, multi-sine reference).
    """
    return closed_loop_run(p, reference, design=design, u_max=u_max, noise_std=noise_std, rng=rng).response


@dataclass(frozen=True)
class ClosedLoopReadout:
    """The robot experiment of :func:`closed_loop_readout`: the 1 kHz loop and its slow, irregular readout.

    Attributes
    ----------
    run : ClosedLoopRun
        The loop at the controller period ``Tc``: truth, the PI's measurements, the reference (rad/s).
    measurement : plant.sampling.Measurement
        The readout: ``t`` (s, irregular, 20-40 ms apart), ``u`` (N·m, quantised), ``w`` (rad/s, noisy),
        shape (M,) each.
    design : PIDesign
        The PI of the loop (``Kp`` N·m·s/rad, ``Ki`` N·m/rad, ``Tc`` s).
    u_max : float
        Its torque limit (N·m).
    """

    run: ClosedLoopRun
    measurement: Measurement
    design: PIDesign
    u_max: float

    @property
    def w_ref(self) -> np.ndarray:
        """The reference at the readout stamps (rad/s), shape (M,): what a drive logs next to the readout."""
        r = self.run.response
        return self.run.w_ref[np.rint((self.measurement.t - r.t[0]) / r.dt).astype(np.int64)]

    def controller(self) -> dict:
        """``{"Kp", "Ki", "Tc", "u_max"}`` (N·m·s/rad, N·m/rad, s, N·m): the fields of
        :class:`controllers.experiments.closed_loop_id.ControllerSpec`, as ``controller.json`` holds them."""
        d = self.design
        return {"Kp": float(d.Kp), "Ki": float(d.Ki), "Tc": float(d.Tc), "u_max": float(self.u_max)}


def closed_loop_readout(p: JointParams, duration: float, *, seeds, crossover: float = 200.0,
                        peak: float = math.radians(20.0), noise_std: float = 1e-3, quantization: float = 0.6,
                        Tc: float = 1e-3) -> ClosedLoopReadout:
    """The paper's robot experiment: a 1 kHz PI velocity loop tracks a multi-sine, read out every 20-40 ms.

    Parameters
    ----------
    p : JointParams
        Plant.
    duration : float
        Length of the reference (s), > 0; the readout covers the simulated span ``[0, duration - Tc]``.
    seeds : int or sequence of 4
        Seeds (anything :func:`numpy.random.default_rng` takes) of the reference phases, the PI's
        measurement noise, the readout instants and the readout noise, in this order; an int ``s`` stands
        for ``(s, s + 1, s + 2, s + 3)``.
    crossover : float, keyword-only
        Crossover of the PI loop (rad/s), > 0; default 200 (a stiff robot loop: the joint rarely sticks).
    peak : float, keyword-only
        Peak of the multi-sine reference (rad/s), > 0; default 20 deg/s.
    noise_std : float, keyword-only
        Velocity noise (rad/s), >= 0, seen by the PI and added to the readout.
    quantization : float, keyword-only
        Torque quantum of the readout (N·m), >= 0 (paper Fig. 7: 0.01 A at 60 N·m/A = 0.6 N·m).
    Tc : float, keyword-only
        Controller period and integration step (s), > 0.

    Returns
    -------
    ClosedLoopReadout

    Raises
    ------
    ParameterError
        A setting out of range, or ``seeds`` neither an int nor four seeds.

    Notes
    -----
    Ruderman, Sec. V-B: :func:`plant.excitation.multisine_reference` at ``Tc``; the PI of
    :func:`controllers.design.pi.design_pi` (phase margin 60 deg) with the torque limit
    ``u_max = 3 (max(Fs, Fc) + sigma max|w_ref| + J max|dw_ref/dt|)``; :func:`closed_loop_run`; the readout
    at :func:`plant.sampling.irregular_sample_times` (Fig. 10) by :func:`plant.sampling.sample`.
    """
    if isinstance(seeds, (int, np.integer)) and not isinstance(seeds, bool):
        seeds = tuple(int(seeds) + i for i in range(4))
    if isinstance(seeds, (str, bytes)) or not hasattr(seeds, "__len__") or len(seeds) != 4:
        raise ParameterError(f"seeds must be an int or a sequence of 4 seeds, got {seeds!r}")
    ref_seed, loop_seed, times_seed, meas_seed = seeds
    Tc = check_positive("Tc", Tc)
    ref = multisine_reference(duration, dt=Tc, peak=peak, rng=np.random.default_rng(ref_seed))
    design = design_pi(p.J, crossover=crossover, phase_margin=60.0, Tc=Tc)
    u_max = 3.0 * (max(p.Fs, p.Fc) + p.sigma * float(np.max(np.abs(ref.w))) + p.J * float(np.max(np.abs(ref.dw))))
    run = closed_loop_run(p, ref, design=design, u_max=u_max, noise_std=noise_std,
                          rng=np.random.default_rng(loop_seed))
    resp = run.response
    times = irregular_sample_times(float(resp.t[-1]), dt=Tc, rng=np.random.default_rng(times_seed))
    meas = sample(resp, times=times, noise_std=noise_std, quantization=quantization,
                  rng=np.random.default_rng(meas_seed))
    return ClosedLoopReadout(run=run, measurement=meas, design=design, u_max=u_max)


def quasi_static_log(p: JointParams, velocities, *, hold: float = 2.0, settle: float = 1.0, decimate: int = 10,
                     noise_std: float = 0.0, rng: np.random.Generator | None = None,
                     design: PIDesign | None = None) -> MeasuredData:
    """A continuous log of bidirectional constant-velocity runs, as recorded on a drive (paper Sec. V-C).

    Parameters
    ----------
    p : JointParams
        Plant.
    velocities : array_like, shape (n,)
        Setpoints (rad/s), non-zero, visited in this order, each for
        ``settle + hold`` seconds without stopping the loop in between.
    hold, settle : float, keyword-only
        Time at each setpoint (s) is ``settle + hold``; both > 0 (the split
        only matters to the reader of the log).
    decimate : int, keyword-only
        Log every ``decimate``-th controller sample (>= 1): the log's sample
        time is ``decimate*design.Tc``.
    noise_std : float, keyword-only
        Velocity measurement noise (rad/s), seen by the controller and logged.
    rng : numpy.random.Generator, keyword-only
        Needed when ``noise_std > 0``.
    design : PIDesign, keyword-only
        Velocity loop; its period ``design.Tc`` (s) is the controller period and the integration step. Default
        ``design_pi(p.J, crossover=QS_CROSSOVER, phase_margin=60, Tc=QS_TC)`` (1 ms; the stiff loop of
        :func:`controllers.experiments.quasi_static.quasi_static_runs`).

    Returns
    -------
    MeasuredData
        ``t`` (s), ``u`` (N·m, the torque that drove the joint to the logged
        sample), ``w`` (rad/s, measured).

    Raises
    ------
    SignalError
        ``velocities`` not finite 1-D.
    ParameterError
        A setpoint is 0, or a setting is out of range.
    TypeError
        ``design`` not a :class:`controllers.design.pi.PIDesign`.
    """
    v = check_signal("velocities", velocities)
    if np.any(v == 0.0):
        raise ParameterError(f"velocities must be non-zero, got 0 at index {int(np.flatnonzero(v == 0)[0])}")
    hold = check_positive("hold", hold)
    settle = check_positive("settle", settle)
    if isinstance(decimate, bool) or not isinstance(decimate, (int, np.integer)) or decimate < 1:
        raise ParameterError(f"decimate must be an integer >= 1, got {decimate!r}")
    if design is None:
        design = design_pi(p.J, crossover=QS_CROSSOVER, phase_margin=60.0, Tc=QS_TC)
    elif not isinstance(design, PIDesign):
        raise TypeError(f"design must be a PIDesign, got {type(design).__name__}")
    Tc = float(design.Tc)
    n_each = int(round((hold + settle) / Tc))
    wr = np.repeat(v, n_each)
    if noise_std > 0 and rng is None:
        raise ParameterError("noise_std > 0 needs rng=np.random.default_rng(seed)")
    t = np.arange(wr.shape[0]) * Tc
    ref = Reference(t=t, w=wr, dw=np.zeros_like(wr))
    W, W_meas, U, _ = _pi_loop(p, ref, design, math.inf, check_nonnegative("noise_std", noise_std), rng)
    # sample k: the measurement the controller saw, and the torque that drove the joint to it
    idx = np.arange(decimate, wr.shape[0], decimate)
    return MeasuredData(t[idx], U[idx - 1], W_meas[idx], source="simulated quasi-static runs",
                        notes=(f"{v.shape[0]} setpoints x {hold + settle:g} s, logged every {decimate * Tc:g} s",))


def encoder_counts(resp: PlantResponse, times, *, counts_per_rev: float) -> np.ndarray:
    """Encoder counts at ``times`` of the joint position integrated from a simulated response.

    Parameters
    ----------
    resp : PlantResponse
        Simulated truth (velocity at the integration rate).
    times : array_like, shape (M,)
        Sample times (s) on the ``resp.dt`` grid.
    counts_per_rev : float, keyword-only
        Encoder resolution (counts per joint revolution), > 0.

    Returns
    -------
    ndarray of float, shape (M,)
        ``floor(q/Δ)`` with ``Δ = 2*pi/counts_per_rev`` and ``q`` the
        trapezoidal integral of ``w`` from ``q(0) = 0`` (rad).

    Raises
    ------
    ParameterError
        ``counts_per_rev`` not > 0.
    SignalError
        ``times`` off the grid or outside the response.
    """
    cpr = check_positive("counts_per_rev", counts_per_rev)
    times = check_time("times", times, min_len=1)
    q = np.concatenate([[0.0], np.cumsum(0.5 * (resp.w[1:] + resp.w[:-1]) * resp.dt)])
    idx = np.rint((times - resp.t[0]) / resp.dt).astype(np.int64)
    if idx[0] < 0 or idx[-1] >= q.shape[0] or np.any(np.abs(resp.t[0] + idx * resp.dt - times) > 1e-6 * resp.dt):
        raise SignalError("times must lie on the response's integration grid within its span")
    return np.floor(q[idx] / (2.0 * math.pi / cpr))


def write_log_csv(path, columns: dict, *, header_comment: str | None = None) -> Path:
    """Write named columns to a CSV file (header row of names, ``repr``-exact floats).

    Parameters
    ----------
    path : str or os.PathLike
        Output file (its directory is created).
    columns : dict
        ``{name: array_like, shape (N,)}``, all of the same length.
    header_comment : str, keyword-only, optional
        A ``# ...`` line written before the header (ignored by :func:`adaptive_ff.io.logs.read_columns`).

    Returns
    -------
    Path

    Raises
    ------
    SignalError
        Columns of different lengths or non-finite values.
    """
    cols = {str(k): check_signal(str(k), v) for k, v in columns.items()}
    lengths = {k: c.shape[0] for k, c in cols.items()}
    if len(set(lengths.values())) != 1:
        raise SignalError(f"columns differ in length: {lengths}")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as fh:
        if header_comment:
            fh.write(f"# {header_comment}\n")
        wr = csv.writer(fh)
        wr.writerow(list(cols))
        for row in zip(*(c.tolist() for c in cols.values())):
            wr.writerow([repr(x) for x in row])
    return path


def write_controller_log(path, run: ClosedLoopRun, *, current_to_torque: float) -> Path:
    """Write the controller's own 1 kHz record of a closed-loop run as a drive-style CSV.

    Parameters
    ----------
    path : str or os.PathLike
        Output file.
    run : ClosedLoopRun
        From :func:`closed_loop_run`.
    current_to_torque : float, keyword-only
        Torque constant (N·m/A), > 0: the torque is written as a motor current.

    Returns
    -------
    Path

    Raises
    ------
    ParameterError
        ``current_to_torque`` not > 0.

    Notes
    -----
    Columns: ``time_ms``, ``current_A`` (the command applied over the period that starts at the
    stamp), ``velocity_deg_s`` (the measurement the PI acted on at the stamp), ``reference_deg_s``.
    These are the rows of the sliding-regime regression that ``adaptive-ff identify`` chooses for a
    uniform controller-rate log (:func:`adaptive_ff.identification.identify.choose_method`).
    """
    k = check_positive("current_to_torque", current_to_torque)
    log = run.controller_log()
    return write_log_csv(
        path, {"time_ms": np.round(log.t * 1e3, 9), "current_A": log.u / k, "velocity_deg_s": np.rad2deg(log.w),
               "reference_deg_s": np.rad2deg(run.w_ref)},
        header_comment=(f"simulated controller-rate log of the PI velocity loop: u = {k:g} N·m/A * current_A, "
                        f"every {run.response.dt * 1e3:g} ms"))
