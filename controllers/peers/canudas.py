"""Peer 1: adaptive Coulomb + viscous friction compensation (Canudas de Wit, Åström, Braun 1987).

C. Canudas de Wit, K. J. Åström, K. Braun, "Adaptive friction compensation in
DC-motor drives", IEEE J. Robotics and Automation 3(6), 1987, pp. 681-685: the
friction is modelled as Coulomb plus viscous friction with separate
coefficients for the two directions of motion, the coefficients are estimated
online by recursive least squares from the motor's input and velocity, and
the compensation adds the estimated friction torque to the controller output
(Ruderman's ref. [1]; Armstrong-Hélouvry, Dupont, Canudas de Wit, "A survey of
models, analysis tools and compensation methods for the control of machines
with friction", Automatica 30(7), 1994, Sec. 5).

Implemented here as the classic explicit scheme on the sampled motor model,
with the same RLS machinery as the package's own estimator (directional
forgetting, projection) so that the comparison is about the friction model and
the regression, not about numerics.

Compensator component: configuration and state in the C struct
``ctl_canudas`` (``controllers/csrc/ctl_canudas.h``), which embeds the RLS
(``aff_rls``) and the two range gates (``aff_range_gate``);
``ctl_canudas_compensate`` and ``ctl_canudas_observe`` (the
``aff_compensator_ops`` table ``ctl_canudas_ops``) are the one implementation,
called by :class:`CanudasCompensator`'s methods and by the closed-loop engine.
"""

from __future__ import annotations

import math
from pathlib import Path

from adaptive_ff.compensation.gate import RangeGate, range_gates
from adaptive_ff.identification.rls import RecursiveLeastSquares
from controllers._cctl import ffi, lib
from plant.component import Component, c_compensate, c_observe, config_class, ops_table, struct_fields
from plant.errors import ParameterError, check_multiple

__all__ = ["CanudasCompensator", "CanudasCompensatorConfig", "CANUDAS_N_THETA"]

CanudasCompensatorConfig = config_class(
    "CanudasCompensatorConfig", (ffi, lib), "ctl_canudas_config", module=__name__,
    summary="Settings of a :class:`CanudasCompensator`: the estimator's period, its RLS, the start's inertia, the "
            "dead zone, the warm-up, the bound and the input velocity.",
    header=Path(__file__).resolve().parent.parent / "csrc" / "ctl_canudas.h", exclude=("Tc",),
    fields={"forgetting": ("forgetting", {lib.AFF_RLS_DIRECTIONAL: "directional",
                                           lib.AFF_RLS_EXPONENTIAL: "exponential"}),
             "ff_measured": ("ff_input", {1: "measured", 0: "reference"})})

#: Length of the reported parameter vector ``theta``.
CANUDAS_N_THETA = 5


@struct_fields("Tc", "Ts", "m", "w_dead", "warmup", "ff_max", "ff_measured", "n_rejected", settable=("n_rejected",))
class CanudasCompensator(Component):
    """Direction-dependent Coulomb + viscous friction, estimated by RLS, compensated at a velocity.

    Parameters
    ----------
    Tc : float, keyword-only
        Controller period (s): :meth:`compensate` and :meth:`observe` are called once per period.
    config : CanudasCompensatorConfig, keyword-only
        The settings (default: the C defaults, :class:`CanudasCompensatorConfig`):

        ``Ts``
            Sample time of the estimator (s), a multiple of ``Tc``; default 10 ms.
        ``lam``
            Forgetting factor per RLS update; default 0.999.
        ``forgetting``
            RLS forgetting scheme, default directional.
        ``P0``
            Initial covariance scale, default 1e4.
        ``J_guess``
            Initial inertia (kg·m²) for ``theta0``; default 1.
        ``w_dead``
            Estimation dead zone (rad/s): a sample interval is used only if the
            velocity stays beyond ``±w_dead`` with one sign (no reversal, no
            sticking); default 5e-3.
        ``warmup``
            RLS updates before the compensation is switched on; default 300.
        ``ff_max``
            Bound on |compensation| (N·m), default inf.
        ``ff_input``
            Velocity the compensation is evaluated at; default measured (the
            velocity feedback of the original).
    u_range, w_range : RangeGate, keyword-only
        Range gates of the torque (N·m) and velocity (rad/s) samples; defaults
        ``RangeGate()`` and ``RangeGate(floor=w_dead)``: a sample above
        100 times the envelope of the accepted ones is refused
        (:class:`adaptive_ff.compensation.gate.RangeGate`).

    Attributes
    ----------
    C_OPS : str
        ``"ctl_canudas_ops"``, the C ops table (``aff_compensator_ops``) the engine calls with :attr:`cdata`.
    cdata : cffi ``ctl_canudas *``
        Configuration and state (:class:`plant.component.Component`), advanced in place by
        ``ctl_canudas_compensate`` and ``ctl_canudas_observe``.
    n_theta : int
        5.
    rls : RecursiveLeastSquares
        ``theta = (b, b*sigma_pos, b*sigma_neg, b*Fc_pos, b*Fc_neg)``, ``b = Ts/J``; its struct is the field
        ``rls`` of :attr:`cdata` (as are the range gates' ``u_range`` and ``w_range``).
    coef : tuple of 4 floats or None
        ``(Fc_pos, Fc_neg, sigma_pos, sigma_neg)`` in use, None before warm-up (read/write).
    n_rejected : int
        Samples ignored: non-finite or out of range (the range gates), or an RLS
        update that would overflow.

    Raises
    ------
    ParameterError
        Invalid settings (the message quotes the value).

    Notes
    -----
    Sampled motor model over one period ``Ts`` (Euler, torque averaged over the
    period ``u_bar``)::

        w(k+1) - w(k) = b*u_bar(k) - b*sigma_d*w(k) - b*Fc_d*sgn(w(k)),   b = Ts/J

    with ``d`` the direction of ``w(k)``. Regressor
    ``(u_bar, -w*1(w>0), -w*1(w<0), -1(w>0), +1(w<0))``. Compensation
    ``u_c = Fc_d*sgn(w) + sigma_d*w`` with the estimated coefficients. The
    model has no friction lag and no Stribeck effect: that is the difference
    to Ruderman's model that the comparison measures.
    """

    MODE = "canudas"
    #: Name of the C ops table (``aff_compensator_ops``) the engine calls with :attr:`cdata`, see :attr:`ops`.
    C_OPS = "ctl_canudas_ops"
    n_theta = CANUDAS_N_THETA
    _ffi = ffi
    _ctype = "ctl_canudas"
    _parts = {"u_range": "u_range", "w_range": "w_range", "rls": "rls"}
    _repr_fields = ("Tc", "Ts", "w_dead", "warmup", "ff_max", "rls.n_updates")

    #: The settings' class.
    Config = CanudasCompensatorConfig

    def __init__(self, *, Tc: float, config: CanudasCompensatorConfig | None = None,
                 u_range: RangeGate | None = None, w_range: RangeGate | None = None):
        config = CanudasCompensatorConfig() if config is None else config
        if not isinstance(config, CanudasCompensatorConfig):
            raise ParameterError(f"config must be a CanudasCompensatorConfig, got {type(config).__name__}")
        cfg = self._settings("ctl_canudas_config", lib.ctl_canudas_default_config(), {**config.c_fields(), "Tc": Tc},
                             counts=("warmup",))
        code = lib.ctl_canudas_check_config(cfg)  # the one validator of the settings' ranges
        if code != lib.AFF_OK:
            raise ParameterError(f"{type(self).__name__}: {ffi.string(lib.aff_error_message(code)).decode()}")
        m = check_multiple("Ts", cfg.Ts, "Tc", cfg.Tc)
        Ts = m * cfg.Tc
        b0 = Ts / cfg.J_guess
        inf = math.inf
        rls = RecursiveLeastSquares(5, lam=cfg.lam, P0=cfg.P0, forgetting=config.forgetting,
                                    theta0=[b0, 0, 0, 0, 0], bounds=([1e-12, 0, 0, 0, 0], [inf, inf, inf, inf, inf]))
        u_range, w_range = range_gates(u_range, w_range, w_floor=cfg.w_dead)
        self._new_struct()
        lib.ctl_canudas_init(self._c, cfg.Tc, m, cfg.w_dead, int(cfg.warmup), cfg.ff_max, cfg.ff_measured,
                             rls.cdata.scheme, rls.cdata.lam, cfg.P0, cfg.J_guess)
        self.settings = config
        self._attach(rls=rls, u_range=u_range, w_range=w_range)

    ops = ops_table(lib)

    # ---- state (read/write fields of the struct)
    @property
    def coef(self) -> tuple | None:
        """``(Fc_pos, Fc_neg, sigma_pos, sigma_neg)`` in use (N·m, N·m·s/rad), or None before warm-up."""
        c = self._c
        if not c.on:
            return None
        return (float(c.Fc_pos), float(c.Fc_neg), float(c.sigma_pos), float(c.sigma_neg))

    @coef.setter
    def coef(self, value) -> None:
        c = self._c
        if value is None:
            c.on = 0
            return
        try:
            Fcp, Fcn, sp, sn = (float(v) for v in value)
        except (TypeError, ValueError):
            raise ParameterError(f"coef must be None or 4 numbers (Fc_pos, Fc_neg, sigma_pos, sigma_neg), "
                                 f"got {value!r}") from None
        c.Fc_pos, c.Fc_neg, c.sigma_pos, c.sigma_neg = Fcp, Fcn, sp, sn
        c.on = 1

    @property
    def estimate(self) -> dict | None:
        """``{"J", "Fc_pos", "Fc_neg", "sigma_pos", "sigma_neg"}`` in use (SI units), or None before warm-up."""
        coef = self.coef
        if coef is None:
            return None
        b = float(self.rls.theta[0])
        Fcp, Fcn, sp, sn = coef
        return {"J": self.Ts / b, "Fc_pos": Fcp, "Fc_neg": Fcn, "sigma_pos": sp, "sigma_neg": sn}

    def info(self) -> dict:
        """Counters and the estimate in use, for run reports (JSON-safe).

        Returns
        -------
        dict
            ``n_rejected``, ``n_updates`` (RLS), ``lam``, ``canudas_estimate`` (:attr:`estimate`).
        """
        return {"n_rejected": self.n_rejected, "n_updates": self.rls.n_updates, "lam": self.rls.lam,
                "canudas_estimate": self.estimate}

    compensate = c_compensate(lib.ctl_canudas_compensate, """Compensation torque (N·m) for this period, bounded by
        ``ff_max`` (C ``ctl_canudas_compensate``).

        Parameters
        ----------
        w_meas : float
            Measured velocity (rad/s).
        w_ref : float
            Reference velocity (rad/s).

        Returns
        -------
        float
        """)

    observe = c_observe(lib.ctl_canudas_observe, """Record the torque applied in this period and the velocity
        measured at its start (C ``ctl_canudas_observe``).

        Parameters
        ----------
        u : float
            Applied torque (N·m).
        w : float
            Measured velocity (rad/s).

        Notes
        -----
        A non-finite or out-of-range value is counted in ``n_rejected`` and spoils the current sample
        interval.
        """)
