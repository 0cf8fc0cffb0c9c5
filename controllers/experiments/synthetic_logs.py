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
from controllers.experiments.quasi_static import QS_CROSSOVER
from plant.errors import ParameterError, SignalError, check_nonnegative, check_positive, check_signal, check_time
from plant.excitation import Reference
from plant.friction import JointParams
from plant.joint import PlantResponse, make_rk4_step

__all__ = ["closed_loop_response", "closed_loop_run", "ClosedLoopRun", "write_controller_log", "quasi_static_log", "encoder_counts",
           "write_log_csv"]


def _pi_loop(p: JointParams, w_ref, design: PIDesign, u_max: float, noise: np.ndarray):
    """PI loop on the RK4 plant; returns true velocity, applied torque and friction state per period."""
    Tc = design.Tc
    ctrl = PIController.from_design(design, u_max=u_max)
    step = make_rk4_step(p, Tc)
    wr = np.asarray(w_ref, dtype=float).tolist()
    nz = noise.tolist()
    n = len(wr)
    W, U, F = np.empty(n), np.empty(n), np.empty(n)
    w = wr[0]
    f = float(p.friction(w)) if p.tau == 0 else 0.0
    for k in range(n):
        u = ctrl.step(wr[k] - (w + nz[k]))
        W[k], U[k], F[k] = w, u, f
        w, f = step(w, f, u)
    return W, U, F


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
    anti-windup), then one RK4 step of eqs. 1-3 with ``u`` held (Ruderman, Sec. V-B).
    """
    Tc = design.Tc
    t = np.asarray(reference.t, dtype=float)
    if t.shape[0] > 1 and not math.isclose(t[1] - t[0], Tc, rel_tol=1e-9):
        raise ParameterError(f"reference step {t[1] - t[0]!r} s differs from design.Tc = {Tc!r} s")
    noise_std = check_nonnegative("noise_std", noise_std)
    if noise_std > 0 and rng is None:
        raise ParameterError("noise_std > 0 needs rng=np.random.default_rng(seed)")
    n = t.shape[0]
    noise = rng.normal(0.0, noise_std, size=n) if noise_std > 0 else np.zeros(n)
    W, U, F = _pi_loop(p, reference.w, design, u_max, noise)
    return ClosedLoopRun(response=PlantResponse(t=t.copy(), u=U, w=W, f=F, dt=Tc), w_meas=W + noise,
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


def quasi_static_log(p: JointParams, velocities, *, hold: float = 2.0, settle: float = 1.0, Tc: float = 1e-3,
                     decimate: int = 10, noise_std: float = 0.0, rng: np.random.Generator | None = None,
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
    Tc : float, keyword-only
        Controller period and integration step (s).
    decimate : int, keyword-only
        Log every ``decimate``-th controller sample (>= 1): the log's sample
        time is ``decimate*Tc``.
    noise_std : float, keyword-only
        Velocity measurement noise (rad/s), seen by the controller and logged.
    rng : numpy.random.Generator, keyword-only
        Needed when ``noise_std > 0``.
    design : PIDesign, keyword-only
        Velocity loop; default ``design_pi(p.J, crossover=QS_CROSSOVER, phase_margin=60, Tc=Tc)``
        (the stiff loop of :func:`controllers.experiments.quasi_static.quasi_static_runs`).

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
    """
    v = check_signal("velocities", velocities)
    if np.any(v == 0.0):
        raise ParameterError(f"velocities must be non-zero, got 0 at index {int(np.flatnonzero(v == 0)[0])}")
    hold = check_positive("hold", hold)
    settle = check_positive("settle", settle)
    Tc = check_positive("Tc", Tc)
    if isinstance(decimate, bool) or not isinstance(decimate, (int, np.integer)) or decimate < 1:
        raise ParameterError(f"decimate must be an integer >= 1, got {decimate!r}")
    if design is None:
        design = design_pi(p.J, crossover=QS_CROSSOVER, phase_margin=60.0, Tc=Tc)
    n_each = int(round((hold + settle) / Tc))
    wr = np.repeat(v, n_each)
    if noise_std > 0 and rng is None:
        raise ParameterError("noise_std > 0 needs rng=np.random.default_rng(seed)")
    noise = rng.normal(0.0, check_nonnegative("noise_std", noise_std), size=wr.shape[0]) if noise_std > 0 \
        else np.zeros(wr.shape[0])
    W, U, _ = _pi_loop(p, wr, design, math.inf, noise)
    t = np.arange(wr.shape[0]) * Tc
    # sample k: the measurement the controller saw, and the torque that drove the joint to it
    idx = np.arange(decimate, wr.shape[0], decimate)
    return MeasuredData(t[idx], U[idx - 1], W[idx] + noise[idx], source="simulated quasi-static runs",
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
