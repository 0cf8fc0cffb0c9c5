"""The feedforward supervisor: a compensator's torque is applied only while it makes the loop's disturbance smaller.

:class:`FeedforwardSupervisor` wraps the C struct ``aff_supervisor`` (``adaptive_ff/csrc/aff_supervisor.h``),
configured from its settings ``aff_supervisor_config`` by ``aff_supervisor_init``.
The closed-loop engine composes it like the sensor gate and the drive
(:meth:`controllers.simulation.engine.EngineRun.set_supervisor`): each period it passes the compensator's
candidate torque through :meth:`FeedforwardSupervisor.apply` and, after the PI, hands it the applied torque and the
controller's velocity (:meth:`FeedforwardSupervisor.observe`). The modes ``adaptive`` (either estimator) and
``adaptive-dob`` are supervised by default (``LoopConfig.supervisor.enabled``).
"""

from __future__ import annotations

import math

import numpy as np

from adaptive_ff._caff import ffi, lib
from adaptive_ff.compensation.defaults import c_config_class
from plant.component import Component, struct_field, struct_fields
from plant.errors import ParameterError

__all__ = ["FeedforwardSupervisor", "FeedforwardSupervisorConfig", "DELAY_MAX"]

FeedforwardSupervisorConfig = c_config_class(
    "FeedforwardSupervisorConfig", "aff_supervisor_config", "aff_supervisor.h", module=__name__,
    summary="Settings of a :class:`FeedforwardSupervisor`: the statistic's window and hysteresis, the first "
            "decision's wait, the rest rule, the measurement delay and the tracking test (the loop's PI). Its "
            "sentinels are C's: ``settle`` < 0 is ``window/2``, ``rest_band`` -1 no rest rule, ``Kp`` 0 no "
            "tracking test.",
    exclude=("Tc", "J_n", "omega"))

#: Largest measurement delay (periods) the statistic aligns (``AFF_SUPERVISOR_DELAY_MAX``).
DELAY_MAX = len(ffi.new("aff_supervisor *").u_hist) - 1


def _f8(name: str, x, n: int | None = None) -> np.ndarray:
    a = np.ascontiguousarray(x, dtype=np.float64)
    if a.ndim != 1 or (n is not None and a.shape[0] != n):
        raise ParameterError(f"{name} must be a 1-D array{'' if n is None else f' of length {n}'}, got shape "
                             f"{a.shape}")
    return a


@struct_fields("on", "n_backoff", "n_restore", "n_backoff_tracking")
class FeedforwardSupervisor(Component):
    """Back a feedforward off to none while it makes the torque disturbance the PI sees larger than no compensation.

    Parameters
    ----------
    Tc : float, keyword-only
        Controller period (s), > 0.
    J_n : float, keyword-only
        Design inertia of the disturbance observer (kg·m²), > 0.
    omega : float, keyword-only
        Cut-off of the first-order Q-filter (rad/s), > 0; e.g. the loop's crossover ``Kp/J_n``.
    config : FeedforwardSupervisorConfig, keyword-only
        The settings (default: the C defaults, :class:`FeedforwardSupervisorConfig`):

        ``window``
            Time constant of the exponentially weighted mean squares (s), > 0; default 2. Longer: a lower variance of
            the comparison, a slower reaction.
        ``margin``
            Hysteresis (-), in [0, 1): a backed-off feedforward is applied again once its mean-square residual is below
            ``(1 - margin)`` times the friction's; default 0.1.
        ``settle``
            Evidence (s) the first decision waits for, >= 0, after the Q-filter's start transient ``5/omega``; default
            -1 (any value < 0): ``window/2``.
        ``rest_band``
            The reference is at rest where ``|w_ref| <= rest_band`` (rad/s) for ``max(2, ceil(1/(omega*Tc)))`` periods
            in a row (one time constant of the loop: the joint has stopped behind the reference): nothing is applied
            then, through the lag of :meth:`set_rest_lag` (Notes); default 0 (a reference exactly at rest, e.g. the dwells of
            :func:`plant.motion.point_to_point_reference`); -1: no rest rule.
        ``delay``
            Measurement delay of the velocity (periods), 0..:data:`DELAY_MAX`; default 0. The statistic pairs the
            velocity difference with the torques of ``delay`` periods before.
        ``Kp``, ``Ki``
            The loop's PI gains (N·m·s/rad, >= 0; N·m/rad, >= 0) for the tracking test (Notes); default ``Kp`` 0: no
            tracking test, the torque test alone.
        ``track_margin``
            The tracking test backs off where the loop's mean-square velocity error with the candidate exceeds ``1 +
            track_margin`` times the error without it (-), >= 0; default 1 (twice).

    Attributes
    ----------
    on : bool
        Whether the candidate torque is applied.
    n_backoff, n_restore : int
        Switches off and back on.
    t_off : float
        Time backed off (s), the reference moving.
    t_rest : float
        Time the reference was at rest (s): the compensation withdrawn.
    f_hat, r_hat : float
        Filtered disturbance without and with the candidate (N·m).
    ms_friction, ms_residual : float
        Their exponentially weighted mean squares ``M_f``, ``M_r`` (N²·m²).
    ms_error_none, ms_error_comp : float
        The tracking test's mean squares ``M_e0``, ``M_e1`` of the velocity error the nominal loop makes from the
        disturbance without and with the candidate ((rad/s)²; 0 without the test).
    n_backoff_tracking : int
        Back-offs the tracking test made where the torque test would not have.

    Raises
    ------
    ParameterError
        A setting outside its range (the message names it and quotes the value).

    Notes
    -----
    With the torque ``u(k-1)`` held over a period, the raw disturbance sample of a disturbance observer of
    inertia ``J_n`` is ``v(k) = u(k-1-d) - J_n*(w(k) - w(k-1))/Tc`` (Ohnishi, Shibata, Murakami, "Motion control
    for advanced mechatronics", IEEE/ASME Trans. Mechatronics 1(1), 1996; the form of
    :class:`controllers.DisturbanceObserver`, the same C functions ``aff_dob_raw``, ``aff_lag_step``), with the Q-filter
    ``x += a*(v - x)``, ``a = 1 - exp(-Tc*omega)`` (the zero-order-hold discretisation of ``1/(1 + s/omega)``;
    Franklin, Powell & Workman, *Digital Control of Dynamic Systems*, 3rd ed., 1998, Sec. 6.3). ``f_hat = Q[v]``
    is the friction whatever torque was applied (``J*dw/dt = u - f``), ``r_hat = Q[v - u_c]`` the residual
    the candidate ``u_c`` leaves. With ``M = EWMA(x^2)`` (``m += b*(x^2 - m)``, ``b = 1 - exp(-Tc/window)``, from
    0 at period ``n_start = ceil(5/(omega*Tc))`` on, past the Q-filter's start transient), from period ``n_start +
    round(settle/Tc)`` on: on and ``M_r > M_f``: back off; off and ``M_r < (1 - margin)*M_f``, with the joint moving
    in the reference's direction at half its speed or more (``w*w_ref > 0``, ``|w| >= |w_ref|/2``; any ``w`` where
    ``w_ref`` is not finite): on again (a feedforward switched on at a joint stuck at a reversal takes the sign of
    the sensor's noise). Noise and
    the inertia error enter ``f_hat`` and ``r_hat`` alike. In the period the applied torque switches the loop adds ``+u_c`` (off) or
    ``-u_c`` (on) to its PI integrator (bumpless transfer, Åström & Hägglund, *Advanced PID Control*, ISA 2006,
    Sec. 3.5). With the reference at rest a velocity loop's friction brakes the joint toward its setpoint
    ``w = 0``; a friction feedforward can only lift that brake, so it is withdrawn there (no transfer) and those
    periods do not enter the statistics. It is withdrawn through the compensator's lag in use (:meth:`set_rest_lag`;
    at once without a lag), as a lagged friction decays once the joint stops (eq. 2 with ``F(0) = 0``): a lagged
    friction withdrawn in one period keeps acting for its lag and drives the stopped joint backward (a joint of
    ``J`` 0.5 kg·m², ``tau`` 50 ms, 20 N·m: 33 deg/s where the reference is at rest and no compensation errs by
    1.5 deg/s, docs/benchmarks/export_c.md); the closed-loop engine then tells the compensator (the C ops table's
    ``at_rest``: the residual observer of :class:`controllers.peers.adaptive_dob.AdaptiveDOBCompensator` records the
    torque as applied, without the feedforward it did not get). While on and moving, the applied torque is the
    candidate itself (bit for bit).

    The tracking test (with ``Kp``, ``Ki``) weighs the same residual by what it does to the loop's tracking: the
    nominal loop (the PI on the error, its integrator updated first, and ``J_n`` over ``Tc``) turns a torque ``d``
    into the velocity error ``G[d]`` (``y(k+1) = y(k) + Tc/J_n*(Kp*e + I(k+1) + d(k))``, ``I(k+1) = I(k) + Ki*Tc*e``,
    ``e = -y(k)``); ``e0 = G[v]`` is the error the disturbance makes without compensation, ``e1 = G[v - u_c]`` with
    the candidate. A constant residual the PI's integrator rejects costs no tracking; a ripple at the loop's
    bandwidth costs most. With ``M_e0``, ``M_e1`` their mean squares (as ``M_f``, ``M_r``): on and ``M_e1 > (1 +
    track_margin)*M_e0``: back off; off: on again only where both tests clear ``margin``. The measured error is not
    compared: it holds the reference's own tracking error, which dwarfs the friction's share where the friction
    costs little. Without ``track_margin`` the test backed the ``paper`` joint off during its feedforward's fade-in
    (the models' integrators still held the friction's rejection, ``M_e1`` 1.13 times ``M_e0`` for a second).
    C: ``adaptive_ff/csrc/aff_supervisor.c``.
    """

    _ffi = ffi
    _ctype = "aff_supervisor"

    #: The settings' class.
    Config = FeedforwardSupervisorConfig

    def __init__(self, *, Tc: float, J_n: float, omega: float, config: FeedforwardSupervisorConfig | None = None):
        cfg, _ = self._plan(Tc=Tc, J_n=J_n, omega=omega, config=config)
        self._configure(lib.aff_supervisor_init, cfg, lib.aff_error_message)

    _lib = lib

    def _plan(self, *, Tc, J_n, omega, config=None):
        """The constructor's checks and settings (``(cfg, None)``); nothing more to do once the struct is
        configured."""
        config = FeedforwardSupervisorConfig() if config is None else config
        if not isinstance(config, FeedforwardSupervisorConfig):
            raise ParameterError(f"config must be a FeedforwardSupervisorConfig, got {type(config).__name__}")
        self.settings = config
        return self._settings_from(lib, {**config.c_fields(), "Tc": Tc, "J_n": J_n, "omega": omega},
                                   counts=("delay",)), None

    def __repr__(self) -> str:
        c = self._c
        return f"FeedforwardSupervisor(Tc={c.Tc!r}, J_n={c.J_n!r}, omega={c.omega!r}, config={self.settings!r})"

    t_off = struct_field("n_off", int, "Time the candidate torque has been off (s): steps times ``Tc``.", scale="Tc")
    t_rest = struct_field("n_rest", int, "Time at rest (s): steps times ``Tc``.", scale="Tc")

    f_hat = struct_field("x_f", float, "Filtered disturbance without the candidate (N·m).")
    r_hat = struct_field("x_r", float, "Filtered disturbance with the candidate (N·m).")
    ms_friction = struct_field("m_f", float, "Mean square ``M_f`` of ``f_hat`` (N²·m²).")
    ms_residual = struct_field("m_r", float, "Mean square ``M_r`` of ``r_hat`` (N²·m²).")

    def apply(self, u_c: float, w_ref: float = math.inf) -> float:
        """This period's compensation (N·m): the candidate ``u_c`` (N·m) while on and the reference ``w_ref`` (rad/s;
        default moving) is not at rest, 0 while backed off; at rest the last applied torque decays through the lag
        of :meth:`set_rest_lag` (at once by default)."""
        return float(lib.aff_supervisor_apply(self._c, float(u_c), float(w_ref)))

    def set_rest_lag(self, alpha: float) -> None:
        """The lag through which the compensation is withdrawn at rest, as the gain ``alpha = 1 - exp(-Tc/tau)`` of the
        compensator's lag in use ``tau`` (1: no lag, withdrawn at once; outside [0, 1]: at once): at rest the
        applied torque decays as ``u(k) = (1 - alpha)*u(k-1)``, eq. 2's lag with the model friction ``F(0) = 0``
        (C ``aff_supervisor_set_rest_lag``)."""
        lib.aff_supervisor_set_rest_lag(self._c, float(alpha))

    def observe(self, u: float, w: float) -> None:
        """After the PI: the applied torque ``u`` (N·m) and the controller's velocity ``w`` (rad/s) of this period
        (non-finite: skipped)."""
        lib.aff_supervisor_observe(self._c, float(u), float(w))

    def run(self, u_c, u, w, w_ref=None) -> dict:
        """Replay a log: :meth:`apply` then :meth:`observe` for every period (C ``aff_supervisor_run``).

        Parameters
        ----------
        u_c, u, w : array_like, shape (N,)
            Candidate torque (N·m), applied torque (N·m) and controller's velocity (rad/s) of each period.
        w_ref : array_like, shape (N,), optional
            Velocity reference (rad/s); default moving throughout.

        Returns
        -------
        dict
            ``applied``, ``f_hat``, ``r_hat`` (N·m), ``ms_friction``, ``ms_residual`` (N²·m²), each shape (N,), and
            ``on`` (bool, (N,)): the state after each period.

        Raises
        ------
        ParameterError
            Arrays not 1-D or of different lengths.
        """
        uc = _f8("u_c", u_c)
        n = uc.shape[0]
        uu, ww = _f8("u", u, n), _f8("w", w, n)
        wr = np.full(n, math.inf) if w_ref is None else _f8("w_ref", w_ref, n)
        out = {k: np.empty(n) for k in ("applied", "f_hat", "r_hat", "ms_friction", "ms_residual")}
        on = np.empty(n, dtype=np.intc)
        p = lambda a: ffi.from_buffer("double[]", a)  # noqa: E731
        lib.aff_supervisor_run(self._c, p(uc), p(wr), p(uu), p(ww), n, p(out["applied"]), p(out["f_hat"]),
                               p(out["r_hat"]), p(out["ms_friction"]), p(out["ms_residual"]),
                               ffi.from_buffer("int[]", on))
        out["on"] = on.astype(bool)
        return out

    ms_error_none = struct_field("m_e0", float,
                                 "Mean square ``M_e0`` of the nominal loop's error without the candidate ((rad/s)²).")

    ms_error_comp = struct_field("m_e1", float,
                                 "Mean square ``M_e1`` of the nominal loop's error with the candidate ((rad/s)²).")

    def info(self) -> dict:
        """The counters a closed-loop result reports: ``n_backoff``, ``n_backoff_tracking`` (of them, decided by the
        tracking test alone), ``n_restore``, ``t_off``, ``t_rest`` (s)."""
        return {"n_backoff": self.n_backoff, "n_backoff_tracking": self.n_backoff_tracking,
                "n_restore": self.n_restore, "t_off": self.t_off, "t_rest": self.t_rest}
