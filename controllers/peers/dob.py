"""Peer 2: disturbance observer with a Q-filter (the industrial default for friction compensation).

K. Ohnishi, M. Shibata, T. Murakami, "Motion control for advanced
mechatronics", IEEE/ASME Trans. Mechatronics 1(1), 1996; the discrete design
with a binomial Q-filter as in Umeno & Hori, "Robust speed control of DC
servomotors using modern two degrees-of-freedom controller design", IEEE
Trans. Ind. Electron. 38(5), 1991. The observer needs no friction model: it
estimates the lumped disturbance torque from the nominal inverse plant and
cancels it within the Q-filter bandwidth.

Compensator component: configuration and state in the C struct
``aff_dob`` (``adaptive_ff/csrc/aff_dob.h``, with its two range gates embedded
as ``aff_range_gate`` fields), configured from its settings ``aff_dob_config`` by
``aff_dob_init``; ``aff_dob_compensate`` and ``aff_dob_observe``
(the ``aff_compensator_ops`` table ``aff_dob_ops``) are the one implementation,
called by :class:`DisturbanceObserver`'s methods and by the closed-loop engine.
"""

from __future__ import annotations

from adaptive_ff.compensation.defaults import c_defaults
from adaptive_ff.compensation.gate import RANGE_DEFAULTS, RangeGate, range_gate_in
from controllers._cctl import ffi, lib
from plant.component import Component, c_compensate, c_observe, ops_table, struct_field, struct_fields
from plant.errors import ParameterError

__all__ = ["DisturbanceObserver", "DOB_ORDER_MAX"]

#: Highest order of the Q-filter (``AFF_DOB_ORDER_MAX`` of ``adaptive_ff/csrc/aff_dob.h``).
DOB_ORDER_MAX = len(ffi.new("aff_dob *").x)

#: The C defaults of the observer's settings (``aff_dob_default_config()``): the keywords' defaults.
_DOB = c_defaults("aff_dob_config")


@struct_fields(
    "J_n", "omega_q", "Tc", "order", "d_max", "a", "d_hat", "n_rejected", "u_last",
    settable=("d_hat", "n_rejected", "u_last")
)
class DisturbanceObserver(Component):
    """Velocity-loop disturbance observer ``d_hat = Q*(u - J_n*dw/dt)``, added to the controller output.

    Parameters
    ----------
    J_n : float, keyword-only
        Nominal inertia (kg·m²), > 0 (the same value the PI design uses).
    omega_q : float, keyword-only
        Q-filter cut-off (rad/s), > 0; default 500, the C default (``aff_dob_default_config()``, as those of
        ``order`` and ``d_max``; 25 times the default
        velocity-loop crossover, 80 Hz at the 1 kHz sampling rate; higher
        tracks better and injects more measurement noise into the torque,
        see docs/benchmarks/compensation.md).
    Tc : float, keyword-only
        Controller period (s).
    order : int, keyword-only
        Order of the binomial Q-filter ``1/(1 + s/omega_q)**order``, 1 to
        :data:`DOB_ORDER_MAX` (``J_n*s*Q`` must be proper); default 2.
    d_max : float, keyword-only
        Bound on |d_hat| (N·m), default inf.
    u_range, w_range : RangeGate, keyword-only
        Range gates of the torque (N·m) and velocity (rad/s) samples; default
        ``RangeGate()`` each: a sample above 100 times the envelope of the
        accepted ones is ignored (:class:`adaptive_ff.compensation.gate.RangeGate`).

    Attributes
    ----------
    C_OPS : str
        ``"aff_dob_ops"``, the C ops table (``aff_compensator_ops``) the engine calls with :attr:`cdata`.
    cdata : cffi ``aff_dob *``
        Configuration and state (:class:`plant.component.Component`); the range gates' structs are its
        fields ``u_range`` and ``w_range`` (the :class:`RangeGate` objects point into it).
    n_theta : int
        0 (no parameter vector).
    d_hat : float
        Current disturbance estimate (N·m).
    n_rejected : int
        Non-finite or out-of-range velocity samples (the estimate is held) and
        torque samples (the last torque is kept).
    a : float
        The Q-filter's step gain ``1 - exp(-Tc*omega_q)`` (-).
    u_last, w_last : float
        The last accepted torque (N·m) and velocity (rad/s; None before the first), read/write.

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

    MODE = "dob"
    #: Name of the C ops table (``ffi.addressof(getattr(controllers._cctl.lib, C_OPS))``: the engine's compensator
    #: interface, see :attr:`ops`).
    C_OPS = "aff_dob_ops"
    n_theta = 0
    _ffi = ffi
    _ctype = "aff_dob"
    _parts = {"u_range": "u_range", "w_range": "w_range"}
    _repr_fields = ("J_n", "omega_q", "Tc", "order", "d_max")

    def __init__(self, *, J_n: float, omega_q: float = _DOB["omega_q"], Tc: float, order: int = _DOB["order"],
                 d_max: float = _DOB["d_max"], u_range: RangeGate | None = None, w_range: RangeGate | None = None):
        cfg, _ = self._plan(J_n=J_n, omega_q=omega_q, Tc=Tc, order=order, d_max=d_max, u_range=u_range,
                            w_range=w_range)
        self._configure(lib.aff_dob_init, cfg, lib.aff_error_message)
        self._built()

    _lib = lib

    def _plan(self, *, J_n, omega_q=_DOB["omega_q"], Tc, order=_DOB["order"], d_max=_DOB["d_max"], u_range=None,
              w_range=None):
        """The constructor's checks and settings (``(cfg, None)``); the gates given kept for :meth:`_built`."""
        # the ranges of the settings are aff_dob_init's to check (the one validator: a ParameterError whose
        # sentence names the field); a wrong type is _settings' SettingTypeError
        for name, g in (("u_range", u_range), ("w_range", w_range)):
            if g is not None and not isinstance(g, RangeGate):
                raise ParameterError(f"{name} must be a RangeGate, got {type(g).__name__}")
        self._given = (u_range, w_range)
        return self._settings_from(lib, {"Tc": Tc, "J_n": J_n, "omega_q": omega_q, "order": order, "d_max": d_max,
                                         "u_range": RANGE_DEFAULTS if u_range is None else u_range.config[0],
                                         "w_range": RANGE_DEFAULTS if w_range is None else w_range.config[0]},
                                   counts=("order",)), None

    def _built(self) -> None:
        """The constructor's step once the struct is configured: its gates (a gate not given: ``RangeGate()`` made
        in place in the struct, as aff_dob_init configured it)."""
        u_range, w_range = self._given
        del self._given
        self._attach(u_range=range_gate_in(self, "u_range") if u_range is None else u_range,
                     w_range=range_gate_in(self, "w_range") if w_range is None else w_range)

    ops = ops_table(lib)

    w_last = struct_field("w_last", float, "The last accepted velocity (rad/s), None before the first.",
                          settable=True, flag="has_w_last")

    def info(self) -> dict:
        """Counter and settings for run reports: ``n_rejected``, ``J_n`` (kg·m²), ``omega_q`` (rad/s).

        Returns
        -------
        dict
        """
        return {"n_rejected": self.n_rejected, "J_n": self.J_n, "omega_q": self.omega_q}

    compensate = c_compensate(lib.aff_dob_compensate, """Advance the observer with the measured velocity of this
        period (C ``aff_dob_compensate``).

        Parameters
        ----------
        w_meas : float
            Measured velocity (rad/s); a non-finite value is counted and the estimate held.
        w_ref : float
            Reference velocity (rad/s), unused.

        Returns
        -------
        float
            The bounded disturbance estimate ``d_hat`` (N·m).
        """)

    observe = c_observe(lib.aff_dob_observe, """Record the torque applied in this period (it drives the next
        velocity sample; C ``aff_dob_observe``).

        Parameters
        ----------
        u : float
            Applied torque (N·m); a non-finite value is ignored.
        w : float
            Measured velocity (rad/s), unused.
        """)
