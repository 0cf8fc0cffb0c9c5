"""Bidirectional constant-velocity ("quasi-static") drive experiments, the paper's Sec. V-C / Fig. 8.

For each velocity setpoint the joint is driven by the discrete PI velocity
loop from rest; after a settling time the velocity and the torque are averaged.
At constant velocity the lag state has settled, ``f = F(w)``, and ``J dw/dt = 0``
gives ``u = f = F(w)`` (eqs. 1-3): the mean torques are support points of the
Stribeck curve, to which the paper fits ``Vs`` and ``delta``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from controllers.design.pi import PIController, PIDesign, design_pi
from plant.errors import ParameterError, check_nonnegative, check_positive, check_signal
from plant.friction import JointParams
from plant.joint import make_rk4_step
from plant.results import axes_or_new, json_safe

__all__ = ["QuasiStaticData", "quasi_static_runs", "bidirectional_velocities", "QS_CROSSOVER"]

#: Default crossover (rad/s) of the velocity loop used for the runs: stiff enough that
#: the PI dominates the negative slope of the Stribeck curve (see quasi_static_runs).
QS_CROSSOVER = 150.0


@dataclass(frozen=True)
class QuasiStaticData:
    """Per-setpoint statistics of constant-velocity runs, see :func:`quasi_static_runs`.

    Attributes
    ----------
    setpoints : ndarray, shape (n,)
        Velocity references (rad/s), in the order given.
    w_mean : ndarray, shape (n,)
        Mean measured velocity over the hold window (rad/s).
    w_std : ndarray, shape (n,)
        Standard deviation of the measured velocity over the window (rad/s).
    u_mean : ndarray, shape (n,)
        Mean torque command over the window (N·m); ``F(w_mean)`` in steady state.
    u_std : ndarray, shape (n,)
        Standard deviation of the torque over the window (N·m): the spread of Fig. 8.
    hold : float
        Length of the averaging window (s).
    settle : float
        Discarded settling time at the start of each run (s).
    Tc : float
        Controller period = integration step (s).
    noise_std : float
        Velocity measurement noise standard deviation (rad/s).
    design : PIDesign
        The velocity-loop design used.
    """

    setpoints: np.ndarray
    w_mean: np.ndarray
    w_std: np.ndarray
    u_mean: np.ndarray
    u_std: np.ndarray
    hold: float
    settle: float
    Tc: float
    noise_std: float
    design: PIDesign

    def to_dict(self) -> dict:
        """Arrays as lists (rad/s, N·m), window settings (s, rad/s) and the loop design, strict JSON."""
        return json_safe({
            "setpoints": self.setpoints, "w_mean": self.w_mean, "w_std": self.w_std, "u_mean": self.u_mean,
            "u_std": self.u_std, "hold": self.hold, "settle": self.settle, "Tc": self.Tc,
            "noise_std": self.noise_std, "design": self.design.to_dict(),
        })

    def summary(self) -> str:
        """Two lines: the runs and the range of the measured support points."""
        n = int(self.setpoints.shape[0])
        return (f"{n} constant-velocity runs, |w_ref| {float(np.min(np.abs(self.setpoints))):.4g} to "
                f"{float(np.max(np.abs(self.setpoints))):.4g} rad/s; settle {self.settle:g} s, hold {self.hold:g} s, "
                f"Tc {self.Tc:g} s, noise {self.noise_std:g} rad/s\n"
                f"mean torque {float(np.min(self.u_mean)):.4g} to {float(np.max(self.u_mean)):.4g} N·m, "
                f"largest spread {float(np.max(self.u_std)):.3g} N·m")

    def plot(self, ax=None):
        """Mean torque over mean velocity with the torque spread as error bars (the points of paper Fig. 8).

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on; default a new figure.

        Returns
        -------
        matplotlib.axes.Axes
            Velocity (rad/s) on a symmetric-log axis, torque (N·m).
        """
        ax = axes_or_new(ax)
        ax.errorbar(self.w_mean, self.u_mean, yerr=self.u_std, fmt="o", ms=3, color="C0", lw=0.8,
                    label="mean ± std over the hold window")
        ax.set_xscale("symlog", linthresh=max(float(np.min(np.abs(self.w_mean))), 1e-12))
        ax.set_xlabel("velocity w (rad/s)")
        ax.set_ylabel("torque u (N·m)")
        ax.legend(fontsize=8)
        ax.grid(True, alpha=0.3)
        return ax


def bidirectional_velocities(w_min: float, w_max: float, n: int) -> np.ndarray:
    """Log-spaced velocity setpoints in both directions.

    Parameters
    ----------
    w_min, w_max : float
        Smallest and largest speed (rad/s), ``0 < w_min < w_max``.
    n : int
        Number of speeds per direction, >= 2.

    Returns
    -------
    ndarray, shape (2*n,)
        ``[-w_max, ..., -w_min, w_min, ..., w_max]`` (ascending), speeds
        ``numpy.geomspace(w_min, w_max, n)``.

    Raises
    ------
    ParameterError
        ``w_min``/``w_max`` not positive or not ordered, or ``n < 2``.
    TypeError
        ``n`` not an integer.

    Notes
    -----
    Log spacing puts half of the points below ``sqrt(w_min*w_max)``, where the
    Stribeck decay (eq. 3) happens; the paper's Fig. 8 samples both directions.
    """
    w_min = check_positive("w_min", w_min)
    w_max = check_positive("w_max", w_max)
    if not w_max > w_min:
        raise ParameterError(f"w_max must be > w_min = {w_min!r}, got {w_max!r}")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)):
        raise TypeError(f"n must be an integer, got {n!r} ({type(n).__name__})")
    if n < 2:
        raise ParameterError(f"n must be >= 2, got {n!r}")
    s = np.geomspace(w_min, w_max, int(n))
    return np.concatenate([-s[::-1], s])


def _one_run(ctrl: PIController, step, wr: float, noise: list, n_settle: int, W: np.ndarray, U: np.ndarray) -> None:
    """One run from rest to ``wr``: settle, then record measured velocity ``W`` and torque ``U`` (filled in place)."""
    ctrl.reset()
    w, f = 0.0, 0.0
    ctl = ctrl.step
    for k in range(n_settle):
        u = ctl(wr - (w + noise[k]))
        w, f = step(w, f, u)
    for k in range(W.shape[0]):
        wm = w + noise[n_settle + k]
        u = ctl(wr - wm)
        W[k] = wm
        U[k] = u
        w, f = step(w, f, u)


def quasi_static_runs(
    p: JointParams,
    velocities,
    *,
    hold: float = 2.0,
    settle: float = 2.0,
    Tc: float = 1e-3,
    noise_std: float = 0.0,
    rng: np.random.Generator | None = None,
    design: PIDesign | None = None,
    u_max: float = math.inf,
) -> QuasiStaticData:
    """Simulate the bidirectional constant-velocity experiments and average each run.

    Parameters
    ----------
    p : JointParams
        True plant parameters.
    velocities : array_like, shape (n,)
        Velocity setpoints (rad/s), non-zero; pass both signs for a
        bidirectional curve (see :func:`bidirectional_velocities`).
    hold : float, keyword-only
        Averaging window (s) after the settling time, >= ``Tc``.
    settle : float, keyword-only
        Discarded settling time (s), >= 0.
    Tc : float, keyword-only
        Controller period and RK4 step (s), > 0 (paper: 1 ms).
    noise_std : float, keyword-only
        Standard deviation (rad/s) of white Gaussian noise on the measured
        velocity, >= 0. The controller sees it and ``w_mean``/``w_std`` are of
        the measured velocity, as in the experiment.
    rng : numpy.random.Generator, keyword-only
        Noise source; required for reproducibility when ``noise_std > 0``
        (a fresh unseeded generator otherwise).
    design : PIDesign, keyword-only
        Velocity-loop design with ``design.Tc == Tc``. Default
        ``design_pi(p.J, sigma=0, crossover=QS_CROSSOVER, phase_margin=60, Tc=Tc)``:
        the designer knows the inertia only.
    u_max : float, keyword-only
        Torque limit (N·m) of the controller, default none.

    Returns
    -------
    QuasiStaticData
        Arrays of shape (n,) in the order of ``velocities``.

    Raises
    ------
    SignalError
        ``velocities`` not a finite 1-D array.
    ParameterError
        A setpoint is 0, ``hold``/``settle``/``Tc``/``noise_std``/``u_max`` out
        of range, or ``design.Tc != Tc``.

    Notes
    -----
    Each run starts at rest (``w = f = 0``, integrator 0) with a step to its
    setpoint. At sample ``k`` the controller reads ``w_k`` (+ noise) and its
    command is held over ``[t_k, t_k + Tc)`` for the RK4 plant
    (:func:`plant.joint.make_rk4_step`). Noise-free and settled, ``u = F(w)``
    of eq. 3 to rounding.

    Breakaway: from rest the joint creeps and chatters around ``w = 0`` until
    the integrator has built up about ``Fs``; with the error about ``|w_ref|``
    that takes ``t_b ~ Fs/(Ki |w_ref|)`` (0.45 s at 0.002 rad/s for the
    ``paper`` preset and the default loop, 0.9 s at 0.001 rad/s). ``settle``
    must exceed ``t_b`` plus a few closed-loop time constants; the default 2 s
    covers the preset down to about 0.001 rad/s (``Vs/20``).

    Below ``Vs`` the Stribeck curve (``delta > 0``) has a negative slope, down
    to ``sigma - (Fs - Fc)/Vs`` (-460 N·m·s/rad for the ``paper`` preset), which
    acts as negative damping. With the lag of eq. 1 linearised around the
    setpoint (slope ``-k``) the loop polynomial is
    ``J tau s^3 + (J + Kp tau) s^2 + (Kp + Ki tau - k) s + Ki``, so the run holds
    its setpoint when ``Kp + Ki*tau > k`` (and the Routh condition
    ``(J + Kp tau)(Kp + Ki tau - k) > J tau Ki``). A soft loop (e.g. 20 rad/s
    crossover for the preset) fails that at the lowest speeds and ends in a
    stick-slip-like limit cycle (the velocity collapses towards 0, the mean
    torque falls off the curve and ``u_std`` grows to several N·m). A 100 rad/s
    loop satisfies it for the preset but is lightly damped at 0.002 rad/s
    (closed-loop pair decaying as ``exp(-7.7 t)``, seconds to settle); the
    default 150 rad/s loop decays as ``exp(-29 t)`` there. Source of the
    experiment: Ruderman, Sec. V-C, Fig. 8.
    """
    v = check_signal("velocities", velocities)
    if np.any(v == 0.0):
        i = int(np.flatnonzero(v == 0.0)[0])
        raise ParameterError(
            f"velocities must be non-zero (sliding regime, F(0) is not a sliding friction), "
            f"got 0 at index {i}"
        )
    Tc = check_positive("Tc", Tc)
    hold = check_positive("hold", hold)
    settle = check_nonnegative("settle", settle)
    noise_std = check_nonnegative("noise_std", noise_std)
    n_hold = int(round(hold / Tc))
    if n_hold < 1:
        raise ParameterError(f"hold must be >= Tc = {Tc!r} s, got {hold!r}")
    n_settle = int(round(settle / Tc))
    if design is None:
        design = design_pi(p.J, sigma=0.0, crossover=QS_CROSSOVER, phase_margin=60.0, Tc=Tc)
    elif not isinstance(design, PIDesign):
        raise TypeError(f"design must be a PIDesign, got {type(design).__name__}")
    elif not math.isclose(design.Tc, Tc, rel_tol=1e-12):
        raise ParameterError(f"design.Tc = {design.Tc!r} s must equal Tc = {Tc!r} s")
    ctrl = PIController.from_design(design, u_max=u_max)
    if noise_std > 0.0 and rng is None:
        rng = np.random.default_rng()
    step = make_rk4_step(p, Tc)
    n_tot = n_settle + n_hold

    n = v.shape[0]
    w_mean, w_std, u_mean, u_std = (np.empty(n) for _ in range(4))
    W = np.empty(n_hold)
    U = np.empty(n_hold)
    for j, wr in enumerate(v.tolist()):
        if noise_std > 0.0:
            noise = (noise_std * rng.standard_normal(n_tot)).tolist()
        else:
            noise = [0.0] * n_tot
        _one_run(ctrl, step, wr, noise, n_settle, W, U)
        w_mean[j], w_std[j] = W.mean(), W.std()
        u_mean[j], u_std[j] = U.mean(), U.std()
    return QuasiStaticData(setpoints=v.copy(), w_mean=w_mean, w_std=w_std, u_mean=u_mean,
                           u_std=u_std, hold=n_hold * Tc, settle=n_settle * Tc, Tc=Tc,
                           noise_std=noise_std, design=design)
