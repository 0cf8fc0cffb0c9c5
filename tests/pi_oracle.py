"""Test oracle: the pure-Python ``PIController`` that :func:`controllers.design.pi.pi_step` replaced (issue 10).

Verbatim the class as it was before the PI became a compiled step over parameter and
state buffers (only renamed ``OraclePI`` and without ``from_design``); used by
tests/test_pi.py to check ``pi_step`` and ``PIController`` bit for bit. Not part of the package.
"""

from __future__ import annotations

import math

import numpy as np

from plant.errors import ParameterError, check_finite_scalar, check_nonnegative, check_positive

__all__ = ["OraclePI"]


class OraclePI:
    """Discrete PI controller with saturation, feedforward and anti-windup (integrator clamping).

    Parameters
    ----------
    Kp : float, keyword-only
        Proportional gain (N·m·s/rad), >= 0.
    Ki : float, keyword-only
        Integral gain (N·m/rad), >= 0.
    Tc : float, keyword-only
        Controller period (s), > 0.
    u_max : float, keyword-only
        Symmetric torque limit (N·m), > 0; ``math.inf`` (default) = no limit.
    integral0 : float, keyword-only
        Initial integrator state (N·m), default 0.

    Attributes
    ----------
    integral : float
        Integrator state ``I`` (N·m), public (read it, or set it to preload).
    saturated : bool
        Whether the last command was clipped to ``±u_max``.

    Raises
    ------
    ParameterError
        A gain is negative or non-finite, ``Tc`` not > 0, ``u_max`` not > 0 or NaN.
    TypeError
        A value is not a real number.

    Notes
    -----
    One call of :meth:`step` with error ``e = r - w`` and feedforward ``u_ff``::

        I' = I + Ki*Tc*e                       (backward Euler: C(z) = Kp + Ki*Tc*z/(z-1))
        clamp: if I' would drive v = Kp*e + I' + u_ff beyond the limit in the
               direction of the update, I' is cut to where v touches the limit,
               but never moved against the update (then I' = I, integration held)
        u  = sat(Kp*e + I' + u_ff, ±u_max)

    This is anti-windup by conditional integration (Åström & Hägglund,
    *Advanced PID Control*, ISA 2006, Sec. 3.5): the integrator only moves while
    the command is inside the limits, or when the update points back out of
    saturation. Because ``u_ff`` is part of ``v``, the integrator sees the
    headroom the feedforward leaves. Under a constant error with ``|Kp*e + u_ff| <
    u_max`` the integrator settles in finitely many steps at exactly
    ``I = ±u_max - Kp*e - u_ff`` (the command sits at the limit) instead of
    growing without bound; when the error reverses the command leaves the limit
    at once. Without saturation (``u_max = inf``) this is the linear ``C(z)``
    designed by :func:`design_pi`.
    """

    __slots__ = ("_Kp", "_Ki", "_Tc", "_KiTc", "_u_max", "integral", "saturated")

    def __init__(self, *, Kp: float, Ki: float, Tc: float, u_max: float = math.inf,
                 integral0: float = 0.0):
        self._Kp = check_nonnegative("Kp", Kp)
        self._Ki = check_nonnegative("Ki", Ki)
        self._Tc = check_positive("Tc", Tc)
        if isinstance(u_max, bool) or not isinstance(u_max, (int, float, np.integer, np.floating)):
            raise TypeError(f"u_max must be a real number, got {u_max!r} ({type(u_max).__name__})")
        u_max = float(u_max)
        if not u_max > 0.0:  # also rejects NaN
            raise ParameterError(f"u_max must be > 0 (math.inf for no limit), got {u_max!r}")
        self._u_max = u_max
        self._KiTc = self._Ki * self._Tc
        self.integral = check_finite_scalar("integral0", integral0)
        self.saturated = False

    @property
    def Kp(self) -> float:
        """Proportional gain (N·m·s/rad)."""
        return self._Kp

    @property
    def Ki(self) -> float:
        """Integral gain (N·m/rad)."""
        return self._Ki

    @property
    def Tc(self) -> float:
        """Controller period (s)."""
        return self._Tc

    @property
    def u_max(self) -> float:
        """Torque limit (N·m), ``inf`` = none."""
        return self._u_max

    def reset(self, integral: float = 0.0) -> None:
        """Set the integrator to ``integral`` (N·m, default 0) and clear ``saturated``."""
        self.integral = check_finite_scalar("integral", integral)
        self.saturated = False

    def step(self, e: float, u_ff: float = 0.0) -> float:
        """Advance one period and return the saturated command ``sat(Kp*e + I + u_ff)`` (N·m).

        Parameters
        ----------
        e : float
            Velocity error ``r - w`` (rad/s) at this sample.
        u_ff : float
            Feedforward torque (N·m), added before the saturation.

        Returns
        -------
        float
            Command torque in ``[-u_max, u_max]`` (N·m).

        Notes
        -----
        Plain-float arithmetic for speed; inputs are not validated here. See the
        class Notes for the clamping rule.
        """
        Kpe = self._Kp * e
        d = self._KiTc * e
        I = self.integral
        In = I + d
        umax = self._u_max
        if d > 0.0:
            lim = umax - Kpe - u_ff
            if In > lim:
                In = lim if lim > I else I
        elif d < 0.0:
            lim = -umax - Kpe - u_ff
            if In < lim:
                In = lim if lim < I else I
        self.integral = In
        v = Kpe + In + u_ff
        if v >= umax:
            self.saturated = True
            return umax
        if v <= -umax:
            self.saturated = True
            return -umax
        self.saturated = False
        return v


class OracleLoopModel:
    """Oracle of :class:`adaptive_ff.compensation.velocity_input.LoopModel` / ``loop_model_step``: the PI
    ``Kp + Ki*Tc*z/(z-1)`` on the zero-order-hold joint ``1/(J s)``, no friction, no noise, no limit.

    :meth:`step` returns the model velocity of this period plus the deviation ``w0 - w_model`` tracked by a
    first-order low-pass of bandwidth ``track`` (default ``Kp/J``), and advances; the first call starts the
    model at the given measurement (0 if not finite).
    """

    def __init__(self, Kp: float, Ki: float, J: float, Tc: float, track: float | None = None):
        self.Kp, self.Ki, self.J, self.Tc = float(Kp), float(Ki), float(J), float(Tc)
        bw = self.Kp / self.J if track is None else float(track)
        self.a = 1.0 - math.exp(-bw * self.Tc)
        self.w = None
        self.integral = 0.0
        self.dev = 0.0

    def step(self, w0: float, r: float) -> float:
        if self.w is None:
            self.w = float(w0) if math.isfinite(w0) else 0.0
        w = self.w
        e = r - w
        self.integral += (self.Ki * self.Tc) * e
        torque = self.Kp * e + self.integral
        self.w = w + (self.Tc / self.J) * torque
        if self.a > 0.0 and math.isfinite(w0):
            self.dev = self.dev + self.a * ((w0 - w) - self.dev)
        return w + self.dev


class OracleSignObserver:
    """Oracle of :class:`adaptive_ff.compensation.velocity_input.SignObserver` / ``sign_observer_step``, written
    from its equations: the model ``J dw/dt = u - u_c - d`` with a constant residual ``d``, error poles
    ``p1 = exp(-bandwidth*Tc)`` and ``p2 = exp(-residual_bandwidth*Tc)`` (default a tenth of ``bandwidth``).

    :meth:`signed` gives the measurement with the observer's sign inside ``±band`` (starting the observer at the
    first measurement); :meth:`update` corrects with that measurement and predicts with ``u - u_c``.
    """

    def __init__(self, J: float, bandwidth: float, Tc: float, residual_bandwidth: float | None = None):
        rb = 0.1 * bandwidth if residual_bandwidth is None else residual_bandwidth
        p1, p2 = math.exp(-bandwidth * Tc), math.exp(-rb * Tc)
        # characteristic polynomial of the error dynamics: (x - p1)(x - p2) = x**2 - (2 - l1 - l2) x + (1 - l1)
        self.l1 = 1.0 - p1 * p2
        self.l2 = (2.0 - self.l1) - (p1 + p2)
        self.b = Tc / J
        self.w = None
        self.z = 0.0
        self.wc = math.nan

    def signed(self, wc: float, band: float) -> float:
        self.wc = wc
        if self.w is None:
            self.w = wc if math.isfinite(wc) else 0.0
        if math.isfinite(wc) and abs(wc) < band:
            return math.copysign(abs(wc), self.w)
        return wc

    def update(self, u: float, u_c: float) -> None:
        if self.w is None:
            return
        if math.isfinite(self.wc):
            e = self.wc - self.w
            self.w += self.l1 * e
            self.z -= self.l2 * e
        if math.isfinite(u - u_c):
            self.w += self.b * (u - u_c) - self.z
