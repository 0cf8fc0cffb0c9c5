"""Peer 2: disturbance observer with a Q-filter (the industrial default for friction compensation).

K. Ohnishi, M. Shibata, T. Murakami, "Motion control for advanced
mechatronics", IEEE/ASME Trans. Mechatronics 1(1), 1996; the discrete design
with a binomial Q-filter as in Umeno & Hori, "Robust speed control of DC
servomotors using modern two degrees-of-freedom controller design", IEEE
Trans. Ind. Electron. 38(5), 1991. The observer needs no friction model: it
estimates the lumped disturbance torque from the nominal inverse plant and
cancels it within the Q-filter bandwidth.
"""

from __future__ import annotations

import math

from plant.errors import ParameterError, check_nonnegative, check_positive

__all__ = ["DisturbanceObserver"]


class DisturbanceObserver:
    """Velocity-loop disturbance observer ``d_hat = Q*(u - J_n*dw/dt)``, added to the controller output.

    Parameters
    ----------
    J_n : float, keyword-only
        Nominal inertia (kg·m²), > 0 (the same value the PI design uses).
    omega_q : float, keyword-only
        Q-filter cut-off (rad/s), > 0; default 500 (25 times the default
        velocity-loop crossover, 80 Hz at the 1 kHz sampling rate; the
        benchmark shows 300-2000 rad/s: higher tracks better and injects more
        measurement noise into the torque).
    Tc : float, keyword-only
        Controller period (s).
    order : int, keyword-only
        Order of the binomial Q-filter ``1/(1 + s/omega_q)**order``, >= 1
        (``J_n*s*Q`` must be proper); default 2.
    d_max : float, keyword-only
        Bound on |d_hat| (N·m), default inf.

    Attributes
    ----------
    d_hat : float
        Current disturbance estimate (N·m).
    n_rejected : int
        Non-finite velocity samples (the estimate is held).

    Raises
    ------
    ParameterError
        Invalid settings (the message quotes the value).

    Notes
    -----
    Plant ``J*dw/dt = u - d`` (here ``d`` = friction). Discrete form, exact for
    a torque held over each period: the raw disturbance sample is
    ``v(k) = u(k-1) - J_n*(w(k) - w(k-1))/Tc`` (the mean of ``d`` over the last
    period when ``J_n = J``), and ``d_hat = Q[v]`` with ``Q`` realised as
    ``order`` cascaded first-order lags (each ``x += a*(input - x)``,
    ``a = 1 - exp(-Tc*omega_q)``, unit gain at zero frequency). The
    compensated command is ``u = u_PI + d_hat``.
    """

    def __init__(self, *, J_n: float, omega_q: float = 500.0, Tc: float, order: int = 2, d_max: float = math.inf):
        self.J_n = check_positive("J_n", J_n)
        self.omega_q = check_positive("omega_q", omega_q)
        self.Tc = check_positive("Tc", Tc)
        if isinstance(order, bool) or not isinstance(order, int) or order < 1:
            raise ParameterError(f"order must be an integer >= 1, got {order!r}")
        self.order = order
        self.d_max = math.inf if d_max == math.inf else check_nonnegative("d_max", d_max)
        self._a = 1.0 - math.exp(-self.Tc * self.omega_q)
        self._x = [0.0] * order
        self._w_last = None
        self._u_last = 0.0
        self.d_hat = 0.0
        self.n_rejected = 0

    def compensate(self, w_meas: float, w_ref: float) -> float:
        """Advance the observer with the measured velocity of this period; return the bounded ``d_hat`` (N·m)."""
        if not math.isfinite(w_meas):
            self.n_rejected += 1
            return self.d_hat
        if self._w_last is None:
            self._w_last = w_meas
            return self.d_hat
        v = self._u_last - self.J_n * (w_meas - self._w_last) / self.Tc
        self._w_last = w_meas
        a = self._a
        x = self._x
        for i in range(self.order):
            x[i] += a * (v - x[i])
            v = x[i]
        self.d_hat = min(max(v, -self.d_max), self.d_max)
        return self.d_hat

    def observe(self, u: float, w: float) -> None:
        """Record the torque ``u`` applied in this period (it drives the next velocity sample)."""
        if math.isfinite(u):
            self._u_last = u
