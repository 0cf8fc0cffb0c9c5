"""Test oracles of the velocity-loop pieces, each derived from its equations rather than from the package's code.

* :func:`pi_linear`: the PI ``C(z) = Kp + Ki*Tc*z/(z - 1)`` without a limit, on a whole signal: the integral
  term is ``Ki/s`` discretised by :func:`scipy.signal.cont2discrete` (backward differences) and run by
  :func:`scipy.signal.lfilter` from the initial integrator state (:func:`scipy.signal.lfiltic`).
* :class:`OraclePI`: the PI with saturation and conditional-integration anti-windup, stepped, written from the
  rule of :class:`controllers.design.pi.PIController` (Notes): the integrator moves by ``Ki*Tc*e`` but stops
  where the command reaches the limit in the direction of the move, and never moves back.
* :class:`OracleLoopModel`: the nominal loop of :class:`adaptive_ff.compensation.velocity_input.LoopModel`, the
  PI in feedback around the zero-order-hold joint ``1/(J s)``, assembled in state space from the two blocks as
  :func:`scipy.signal.cont2discrete` gives them, plus the deviation tracker (tests/lti_oracle.py).
* :class:`OracleSignObserver`: the observer of :class:`adaptive_ff.compensation.velocity_input.SignObserver`
  with its gains from :func:`scipy.signal.place_poles` (the error poles ``exp(-bandwidth*Tc)`` and
  ``exp(-residual_bandwidth*Tc)``), stepped in matrix form.

Not part of the package.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import signal

from lti_oracle import StepLTI, lag

__all__ = ["pi_linear", "OraclePI", "OracleLoopModel", "OracleSignObserver"]


def pi_linear(e, u_ff=0.0, *, Kp: float, Ki: float, Tc: float, integral0: float = 0.0) -> tuple:
    """Command and integrator of the unlimited PI over a whole error signal.

    Parameters
    ----------
    e : array_like, shape (N,)
        Velocity error ``r - w`` (rad/s) per period.
    u_ff : float or array_like, shape (N,)
        Feedforward torque (N·m), added to the command.
    Kp, Ki, Tc, integral0 : float
        Gains, period (s) and the integrator state before the first sample (N·m).

    Returns
    -------
    u, integral : ndarray, shape (N,)
        Command and integrator state after each sample.
    """
    e = np.asarray(e, dtype=float)
    num, den, _ = signal.cont2discrete(([1.0], [1.0, 0.0]), Tc, method="backward_diff")  # 1/s
    b, a = Ki * np.atleast_1d(np.squeeze(num)), np.asarray(den, dtype=float)
    integral, _ = signal.lfilter(b, a, e, zi=signal.lfiltic(b, a, [integral0], [0.0]))
    return Kp * e + integral + u_ff, integral


class OraclePI:
    """The limited PI with conditional integration, one period per :meth:`step` (no input checks)."""

    def __init__(self, *, Kp: float, Ki: float, Tc: float, u_max: float = math.inf, integral0: float = 0.0):
        self.Kp, self.gain_i, self.u_max = float(Kp), float(Ki) * float(Tc), float(u_max)
        self.integral = float(integral0)
        self.saturated = False

    def step(self, e: float, u_ff: float = 0.0) -> float:
        """Command ``sat(Kp*e + I + u_ff)`` (N·m) after moving the integrator ``I`` by the rule."""
        move = self.gain_i * e
        rest = self.Kp * e + u_ff  # the command without the integrator
        I = self.integral  # noqa: E741
        if move != 0.0 and math.isfinite(self.u_max):
            ahead = math.copysign(1.0, move)
            stop = ahead * self.u_max - rest  # the integrator value that puts the command on the limit ahead
            room = ahead * (stop - I)  # how far the integrator may still move that way (negative: past it)
            move = ahead * min(abs(move), max(room, 0.0))
        self.integral = I + move
        v = rest + self.integral
        self.saturated = abs(v) >= self.u_max
        return math.copysign(self.u_max, v) if self.saturated else v


def _loop_matrices(Kp: float, Ki: float, J: float, Tc: float) -> tuple:
    """``(A, B)`` of the closed loop ``x' = A x + B r`` with ``x = (plant state, integrator state)``."""
    # the plant 1/(J s) with a zero-order hold, and the integral term Ki/s by backward differences (its output
    # includes this period's error: C(z) = Kp + Ki*Tc*z/(z - 1))
    Ap, Bp, Cp, _, _ = signal.cont2discrete((np.zeros((1, 1)), np.ones((1, 1)) / J, np.ones((1, 1)),
                                             np.zeros((1, 1))), Tc, method="zoh")
    Ai, Bi, Ci, Di, _ = signal.cont2discrete((np.zeros((1, 1)), np.ones((1, 1)), Ki * np.ones((1, 1)),
                                              np.zeros((1, 1))), Tc, method="backward_diff")
    ap, bp, cp = float(Ap[0, 0]), float(Bp[0, 0]), float(Cp[0, 0])
    ai, bi, ci, di = float(Ai[0, 0]), float(Bi[0, 0]), float(Ci[0, 0]), float(Di[0, 0])
    # e = r - cp*xp;  u = (Kp + di)*e + ci*xi;  xp' = ap*xp + bp*u;  xi' = ai*xi + bi*e
    k = Kp + di
    A = np.array([[ap - bp * k * cp, bp * ci], [-bi * cp, ai]])
    B = np.array([bp * k, bi])
    return A, B, cp


class OracleLoopModel:
    """The nominal loop (no friction, no noise, no limit) driven by the reference, plus the tracked deviation.

    :meth:`step` returns the model velocity of this period plus the deviation ``w0 - w_model`` through the
    first-order lag of bandwidth ``track`` (default ``Kp/J``; a non-finite ``w0`` holds it), then advances; the
    first call starts the model at the given measurement (0 if not finite) with an empty integrator.
    """

    def __init__(self, Kp: float, Ki: float, J: float, Tc: float, track: float | None = None):
        self.A, self.B, self.cp = _loop_matrices(float(Kp), float(Ki), float(J), float(Tc))
        bw = float(Kp) / float(J) if track is None else float(track)
        self.tracker = StepLTI(lag(bw, float(Tc))) if bw > 0.0 else None
        self.x = None
        self.dev = 0.0

    def step(self, w0: float, r: float) -> float:
        if self.x is None:
            self.x = np.array([(w0 if math.isfinite(w0) else 0.0) / self.cp, 0.0])
        w = self.cp * float(self.x[0])
        if self.tracker is not None and math.isfinite(w0):
            self.dev = self.tracker.step(w0 - w)
        self.x = self.A @ self.x + self.B * r
        return w + self.dev


class OracleSignObserver:
    """The sign observer: a current-estimate observer of ``w' = w + Tc/J*(u - u_c) - z``, ``z' = z``.

    :meth:`signed` gives the measurement with the observer's sign inside ``±band`` (starting the observer at the
    first measurement); :meth:`update` corrects with that measurement and predicts with ``u - u_c``.
    """

    def __init__(self, J: float, bandwidth: float, Tc: float, residual_bandwidth: float | None = None):
        rb = 0.1 * bandwidth if residual_bandwidth is None else residual_bandwidth
        self.A = np.array([[1.0, -1.0], [0.0, 1.0]])
        self.Bu = np.array([Tc / J, 0.0])
        C = np.array([[1.0, 0.0]])
        # correct-then-predict: the error obeys e' = A (I - L C) e = (A - M C) e with M = A L; place the poles of
        # A - M C by duality (scipy places those of A^T - C^T K, K = M^T)
        poles = [math.exp(-bandwidth * Tc), math.exp(-rb * Tc)]
        M = signal.place_poles(self.A.T, C.T, poles).gain_matrix.T[:, 0]
        self.L = np.linalg.solve(self.A, M)
        self.x = None
        self.wc = math.nan

    @property
    def w(self) -> float | None:
        """The a-priori velocity estimate (rad/s), None before the first measurement."""
        return None if self.x is None else float(self.x[0])

    def signed(self, wc: float, band: float) -> float:
        self.wc = wc
        if self.x is None:
            self.x = np.array([wc if math.isfinite(wc) else 0.0, 0.0])
        if math.isfinite(wc) and abs(wc) < band:
            return math.copysign(abs(wc), self.x[0])
        return wc

    def update(self, u: float, u_c: float) -> None:
        if self.x is None:
            return
        if math.isfinite(self.wc):
            self.x = self.x + self.L * (self.wc - self.x[0])
        du = u - u_c
        if math.isfinite(du):
            self.x = self.A @ self.x + self.Bu * du
