"""EMPS closed-loop re-simulation and cross-validation of an identified rigid-axis model.

The EMPS benchmark (Janot, Gautier, Brunot, "Data Set and Reference Models of
EMPS", 2019) judges a model by simulating it in the drive's known feedback loop,
driven by the measured reference position ``qg`` (and, on the validation record,
the force pulses), and comparing simulated and measured motion and force
(its ``Simulation_EMPS.m`` / ``Simulink_EMPS_Rigide.slx``). This module
rebuilds that loop:

* **controller** (data README, 1 kHz): ``nu(k) = kv*(kp*(qg(k) - q(k)) - qdot(k))``
  with ``qdot(k)`` the backward
  difference of the averaged position ``0.5*q(k) + 0.5*q(k-1)``; the voltage
  applied from ``t(k)`` to ``t(k+1)`` is ``vir = nu(k-1) + pulses_N(k)`` (a unit
  delay, as in the benchmark's Simulink model; the logged ``vir`` satisfies
  ``vir(k) = nu(k) + pulses_N(k)`` to 4e-3 V rms, computed from the logged
  ``qm``, ``qg``), force ``gtau*vir``;
* **plant**: ``J*dw/dt = gtau*vir - F(w) - offset``, ``dq/dt = w`` with the
  piecewise-linear friction of :class:`adaptive_ff.identification.idim.RigidAxisModel`.

Between samples the force is constant, so the plant is a linear ODE in each
direction of motion and is integrated *exactly* (zero-order-hold sampling,
Åström & Wittenmark, *Computer-Controlled Systems*, Ch. 2): the closed-form
solution of ``J*dw/dt = a - b*w``, split at the instant the velocity reaches
zero, where the axis sticks while ``-Fc_neg <= force - offset <= Fc_pos``
(Karnopp's stick condition) and otherwise moves on in the other direction.
No ODE solver is needed; the tests check the step against
``scipy.integrate.solve_ivp`` with events. One sample costs a few exponentials:
a 24 841-sample EMPS record simulates in about 0.1 s.

Measured with the published reference model (M = 95.1089, Fv = 203.5034,
Fc = 20.3935, offset = -3.1648): relative velocity error 0.229 %, force error
5.854 % on ``DATA_EMPS.mat`` (published 0.23 %, 5.85 %); 0.378 % and 8.20 % on
``DATA_EMPS_PULSES.mat`` (published 0.48 %, 8.94 %; the benchmark's pulse block
is not documented in the data README, here the logged ``pulses_N`` is added to
the voltage, which is what the logged ``vir`` shows). Without the unit delay
the estimation-file figures would be 0.125 % and 4.57 %.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from adaptive_ff.io.data import EMPS_CUTOFF, EMPS_SKIP, MeasuredData, load_emps
from adaptive_ff.identification.idim import IDIM_DECIMATE, RigidAxisModel, idim_force_error, relative_error
from plant.errors import ParameterError, SignalError, check_not_special, check_signal, check_time
from plant.results import axes_or_new, json_safe

__all__ = ["EMPSRecord", "read_emps_record", "is_emps_record", "EMPSSimulation", "simulate_emps_loop",
           "exact_step", "EMPSValidation", "validate_emps"]

#: Variables of an EMPS record needed for the closed-loop simulation.
_LOOP_VARS = ("t", "qm", "qg", "vir", "gtau", "kp", "kv")


@dataclass(frozen=True)
class EMPSRecord:
    """Raw EMPS benchmark record (see ``data/emps/README.md``).

    Attributes
    ----------
    t : ndarray, shape (N,)
        Time (s).
    qm : ndarray, shape (N,)
        Measured position (m), load side.
    qg : ndarray, shape (N,)
        Reference position (m).
    vir : ndarray, shape (N,)
        Logged controller output (V), pulses included.
    pulses : ndarray, shape (N,)
        Added pulses ``pulses_N`` in volts of ``vir`` (zeros if the file has none).
    gtau : float
        Drive gain (N/V).
    kp : float
        Position-loop gain (1/s).
    kv : float
        Velocity-loop gain (V/(m/s)).
    source : str
        File path.
    """

    t: np.ndarray
    qm: np.ndarray
    qg: np.ndarray
    vir: np.ndarray
    pulses: np.ndarray
    gtau: float
    kp: float
    kv: float
    source: str = ""

    @property
    def force(self) -> np.ndarray:
        """Logged force ``gtau*vir`` (N), shape (N,)."""
        return self.gtau * self.vir

    def to_dict(self) -> dict:
        """Strict-JSON dict of every field (arrays as lists; NaN/inf as None)."""
        return json_safe({"t": self.t, "qm": self.qm, "qg": self.qg, "vir": self.vir, "pulses": self.pulses,
                          "gtau": self.gtau, "kp": self.kp, "kv": self.kv, "source": self.source})

    def summary(self) -> str:
        """One line: file, samples, duration and the loop gains."""
        return (f"EMPS record {self.source or '(in memory)'}: {self.t.shape[0]} samples over "
                f"{self.t[-1] - self.t[0]:.4g} s, gtau = {self.gtau:.6g} N/V, kp = {self.kp:.6g} 1/s, "
                f"kv = {self.kv:.6g} V/(m/s), pulses {'yes' if np.any(self.pulses) else 'none'}")


def is_emps_record(path) -> bool:
    """True if ``path`` is a .mat file holding every variable of the EMPS closed loop.

    Parameters
    ----------
    path : str or os.PathLike
        Any file.

    Returns
    -------
    bool
        The file is readable by ``scipy.io.whosmat`` and holds ``t, qm, qg, vir, gtau, kp, kv``.
    """
    from scipy.io import whosmat

    path = Path(path)
    if path.suffix.lower() != ".mat" or not path.is_file():
        return False
    try:
        names = {name for name, _, _ in whosmat(str(path))}
    except (ValueError, TypeError, OSError, NotImplementedError):
        return False
    return set(_LOOP_VARS) <= names


def read_emps_record(path) -> EMPSRecord:
    """Read the raw signals and loop gains of an EMPS .mat file.

    Parameters
    ----------
    path : str or os.PathLike
        ``DATA_EMPS.mat`` or ``DATA_EMPS_PULSES.mat``.

    Returns
    -------
    EMPSRecord

    Raises
    ------
    FileNotFoundError
        No such file.
    SignalError
        Not a readable .mat, one of ``t, qm, qg, vir, gtau, kp, kv`` missing,
        of the wrong shape or non-finite, time not strictly increasing, or a
        gain <= 0 (``pulses_N`` is optional).

    Notes
    -----
    Variables and units: Janot, Gautier, Brunot (2019); ``data/emps/README.md``.
    """
    from scipy.io import loadmat

    path = Path(path)
    where = str(path)
    check_not_special(path, "EMPS file (.mat)", error=SignalError)
    if not path.is_file():
        raise FileNotFoundError(f"EMPS file not found: {where}")
    try:
        mat = loadmat(where)
    except (ValueError, TypeError, OSError, NotImplementedError) as exc:
        raise SignalError(f"{where}: not a readable MATLAB .mat file ({exc})") from None
    missing = [v for v in _LOOP_VARS if v not in mat]
    if missing:
        raise SignalError(f"{where}: EMPS closed-loop variables {missing} missing; need {list(_LOOP_VARS)}")
    try:
        t = check_time("t", mat["t"])
        n = t.shape[0]
        sig = {k: check_signal(k, mat[k], n=n) for k in ("qm", "qg", "vir")}
        pulses = check_signal("pulses_N", mat["pulses_N"], n=n) if "pulses_N" in mat else np.zeros(n)
        gains = {k: float(check_signal(k, mat[k], n=1)[0]) for k in ("gtau", "kp", "kv")}
    except SignalError as exc:
        raise SignalError(f"{where}: {exc}") from None
    for k, g in gains.items():
        if not g > 0:
            raise SignalError(f"{where}: gain {k} must be > 0, got {g!r}")
    return EMPSRecord(t=t, qm=sig["qm"], qg=sig["qg"], vir=sig["vir"], pulses=pulses, source=where, **gains)


def exact_step(q: float, w: float, force: float, h: float, model: RigidAxisModel) -> tuple[float, float]:
    """Advance ``J*dw/dt = force - F(w) - offset``, ``dq/dt = w`` exactly over ``h`` at constant ``force``.

    Parameters
    ----------
    q : float
        Position (m or rad) at the start.
    w : float
        Velocity (m/s or rad/s) at the start.
    force : float
        Applied force/torque (N or N·m), constant over the step.
    h : float
        Step (s), > 0.
    model : RigidAxisModel
        Inertia, friction and bias.

    Returns
    -------
    (float, float)
        Position and velocity after ``h``.

    Notes
    -----
    In a direction ``s = sgn(w)`` the equation is ``J*dw/dt = a - b*w`` with
    ``a = force - offset - s*Fc_s``, ``b = sigma_s``:
    ``w(t) = a/b + (w0 - a/b)*exp(-b*t/J)``,
    ``q(t) = q0 + (a/b)*t + (w0 - a/b)*(J/b)*(1 - exp(-b*t/J))``
    (``b = 0``: constant acceleration ``a/J``). If ``w`` reaches zero inside the
    step (at ``t* = (J/b)*ln((a/b - w0)/(a/b))``) the step is split there; at
    ``w = 0`` the axis moves off in the direction of ``force - offset`` if that
    exceeds the Coulomb level of the direction, else it sticks for the rest of
    the step (Karnopp, 1985). Exact for the piecewise-constant input of a
    sampled controller (zero-order hold; Åström & Wittenmark, Ch. 2).
    """
    J = model.J
    e = force - model.offset
    for _ in range(4):  # at most: move, cross zero, move the other way (a stick ends the step)
        if h <= 0.0:
            break
        if w > 0.0:
            s = 1.0
        elif w < 0.0:
            s = -1.0
        elif e > model.Fc_pos:
            s = 1.0
        elif e < -model.Fc_neg:
            s = -1.0
        else:
            return q, 0.0
        Fc, b = (model.Fc_pos, model.sigma_pos) if s > 0 else (model.Fc_neg, model.sigma_neg)
        a = e - s * Fc
        if b > 0.0:
            k = b / J
            wi = a / b
            w_end = wi + (w - wi) * math.exp(-k * h)
            if s * w_end >= 0.0:
                return q + wi * h - (w - wi) * math.expm1(-k * h) / k, w_end
            ts = -math.log(wi / (wi - w)) / k
            q += wi * ts - (w - wi) * math.expm1(-k * ts) / k
        else:
            w_end = w + a * h / J
            if s * w_end >= 0.0:
                return q + w * h + 0.5 * a * h * h / J, w_end
            ts = -J * w / a
            q += w * ts + 0.5 * a * ts * ts / J
        w = 0.0
        h -= ts
    return q, w


@dataclass(frozen=True)
class EMPSSimulation:
    """Closed-loop simulation of a model on an EMPS record (:func:`simulate_emps_loop`).

    Attributes
    ----------
    t : ndarray, shape (N,)
        Time (s), the record's.
    q : ndarray, shape (N,)
        Simulated position (m) at ``t``.
    w : ndarray, shape (N,)
        Simulated velocity (m/s) at ``t``.
    force : ndarray, shape (N,)
        Simulated applied force ``gtau*vir`` (N) from ``t(k)`` to ``t(k+1)``.
    """

    t: np.ndarray
    q: np.ndarray
    w: np.ndarray
    force: np.ndarray

    def to_dict(self) -> dict:
        """Strict-JSON dict: ``t, q, w, force`` as lists (SI units; NaN/inf as None)."""
        return json_safe({"t": self.t, "q": self.q, "w": self.w, "force": self.force})

    def summary(self) -> str:
        """One line: samples, duration, peak velocity and force."""
        return (f"EMPS closed-loop simulation: {self.t.shape[0]} samples over {self.t[-1] - self.t[0]:.4g} s, "
                f"max |w| {np.max(np.abs(self.w)):.4g} m/s, max |force| {np.max(np.abs(self.force)):.4g} N")

    def plot(self, ax=None):
        """Simulated velocity over time.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw into; default a new figure.

        Returns
        -------
        matplotlib.axes.Axes
        """
        ax = axes_or_new(ax)
        ax.plot(self.t, self.w, lw=0.8, label="simulated velocity")
        ax.set_xlabel("time (s)")
        ax.set_ylabel("velocity (m/s)")
        ax.legend(loc="best")
        ax.grid(True, alpha=0.3)
        return ax


def simulate_emps_loop(model: RigidAxisModel, record: EMPSRecord, *, delay: int = 1) -> EMPSSimulation:
    """Simulate a rigid-axis model in the EMPS position loop driven by the measured reference.

    Parameters
    ----------
    model : RigidAxisModel
        Mass (kg), friction (N, N·s/m) and bias (N).
    record : EMPSRecord
        Reference ``qg``, pulses, gains and time stamps; ``qm(0)`` is the initial position.
    delay : int, keyword-only
        Samples between the controller's computation and the voltage it
        applies, 0 or 1. Default 1 (unit delay of the benchmark's Simulink
        model; module docstring).

    Returns
    -------
    EMPSSimulation

    Raises
    ------
    TypeError
        ``model`` or ``record`` of the wrong type.
    ParameterError
        ``delay`` not 0 or 1.

    Notes
    -----
    The loop of module docstring, started at rest at ``qm(0)`` with the
    controller memory at ``qm(0)`` and no voltage before the first sample.
    Plant steps by :func:`exact_step`.
    """
    if not isinstance(model, RigidAxisModel):
        raise TypeError(f"model must be a RigidAxisModel, got {type(model).__name__}")
    if not isinstance(record, EMPSRecord):
        raise TypeError(f"record must be an EMPSRecord, got {type(record).__name__}")
    if delay not in (0, 1) or isinstance(delay, bool):
        raise ParameterError(f"delay must be 0 or 1, got {delay!r}")
    t = record.t.tolist()
    qg = record.qg.tolist()
    pulses = record.pulses.tolist()
    kp, kv, gtau = record.kp, record.kv, record.gtau
    n = len(t)
    q_out, w_out, f_out = np.empty(n), np.empty(n), np.empty(n)
    q = q_prev = qa_prev = float(record.qm[0])
    w = 0.0
    nu_prev = 0.0
    for k in range(n):
        q_out[k], w_out[k] = q, w
        qa = 0.5 * q + 0.5 * q_prev
        qdot = (qa - qa_prev) / (t[k] - t[k - 1]) if k else 0.0
        nu = kv * (kp * (qg[k] - q) - qdot)
        force = gtau * ((nu_prev if delay else nu) + pulses[k])
        f_out[k] = force
        q_prev, qa_prev, nu_prev = q, qa, nu
        if k + 1 < n:
            q, w = exact_step(q, w, force, t[k + 1] - t[k], model)
    return EMPSSimulation(t=record.t.copy(), q=q_out, w=w_out, force=f_out)


@dataclass(frozen=True)
class EMPSValidation:
    """How well a model reproduces an EMPS record (:func:`validate_emps`).

    Attributes
    ----------
    velocity_error : float
        Relative velocity error (%) of the closed-loop simulation against the
        filtered measured velocity (``load_emps`` pipeline), samples from ``skip`` on.
    force_error : float
        Relative force error (%) of the simulated against the logged force ``gtau*vir``.
    position_error : float
        Relative position error (%) of the simulated against the logged ``qm``.
    idim_force_error : float
        Relative force error (%) of the inverse dynamic model on the filtered,
        decimated record (:func:`adaptive_ff.identification.idim.idim_force_error`).
    n_samples : int
        Samples compared in the simulation errors.
    source : str
        File validated on.
    simulation : EMPSSimulation
        The simulated signals.
    """

    velocity_error: float
    force_error: float
    position_error: float
    idim_force_error: float
    n_samples: int
    source: str
    simulation: EMPSSimulation

    def to_dict(self) -> dict:
        """Strict-JSON dict: ``velocity_error_percent, force_error_percent, position_error_percent,
        idim_force_error_percent, n_samples, source`` (the simulated signals are left out)."""
        return json_safe({"velocity_error_percent": self.velocity_error, "force_error_percent": self.force_error,
                          "position_error_percent": self.position_error,
                          "idim_force_error_percent": self.idim_force_error,
                          "n_samples": int(self.n_samples), "source": self.source})

    def to_json_dict(self) -> dict:
        """The same as :meth:`to_dict` (the name the CLI uses)."""
        return self.to_dict()

    def summary(self) -> str:
        """One line: the four relative errors."""
        return (f"EMPS validation on {self.source} ({self.n_samples} samples): velocity {self.velocity_error:.3f} %, "
                f"force {self.force_error:.3f} %, position {self.position_error:.4f} %, inverse dynamics "
                f"{self.idim_force_error:.3f} %")

    def plot(self, ax=None):
        """The simulated velocity (:meth:`EMPSSimulation.plot`)."""
        return self.simulation.plot(ax)


def validate_emps(model: RigidAxisModel, path, *, cutoff: float = EMPS_CUTOFF, skip: int = EMPS_SKIP,
                  decimate: int = IDIM_DECIMATE, record: EMPSRecord | None = None,
                  data: MeasuredData | None = None) -> EMPSValidation:
    """Closed-loop re-simulation and inverse-dynamics errors of a model on an EMPS file.

    Parameters
    ----------
    model : RigidAxisModel
        Identified model (kg, N·s/m, N).
    path : str or os.PathLike
        EMPS .mat file (estimation file for the re-simulation check, the
        pulses file for cross-validation).
    cutoff : float, keyword-only
        Cutoff (Hz) of the zero-phase filter giving the measured velocity
        (:func:`adaptive_ff.io.data.load_emps`; default 100 Hz as the benchmark).
    skip : int, keyword-only
        First samples left out of the comparison (default 49, as the benchmark).
    decimate : int, keyword-only
        Decimation of the inverse-dynamics error (default 10; the last
        :data:`~adaptive_ff.identification.idim.IDIM_TAIL` samples, the zero-phase
        filters' end transient, are left out of it as by
        :func:`~adaptive_ff.identification.idim.idim_force_error`).
    record, data : optional, keyword-only
        Already read :func:`read_emps_record` / :func:`load_emps` results of
        ``path`` (avoid reading the file twice).

    Returns
    -------
    EMPSValidation

    Raises
    ------
    FileNotFoundError, SignalError, ParameterError, TypeError
        From the readers, or bad arguments.

    Notes
    -----
    Errors are the benchmark's ``100*||y - y_sim||/||y||`` (Janot et al.,
    2019; :func:`adaptive_ff.identification.idim.relative_error`). The benchmark publishes for
    its reference model 0.23 % (velocity) and 5.85 % (force) on ``DATA_EMPS.mat``, 0.48 %,
    8.94 % (simulation) and 5.98 % (inverse dynamics) on ``DATA_EMPS_PULSES.mat``; the
    figures of this function are on the EMPS benchmark page of the documentation.
    """
    record = read_emps_record(path) if record is None else record
    data = load_emps(path, cutoff=cutoff, skip=skip) if data is None else data
    n = record.t.shape[0]
    if data.n_samples + skip != n:
        raise SignalError(f"{path}: filtered record has {data.n_samples} samples, expected {n} - {skip}")
    sim = simulate_emps_loop(model, record)
    sl = slice(skip, None)
    return EMPSValidation(
        velocity_error=relative_error(data.w, sim.w[sl]),
        force_error=relative_error(record.force[sl], sim.force[sl]),
        position_error=relative_error(record.qm[sl], sim.q[sl]),
        idim_force_error=idim_force_error(model, data, decimate=decimate),
        n_samples=int(n - skip), source=str(path), simulation=sim)
