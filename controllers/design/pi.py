"""Discrete PI velocity controller: loop-shaping design and the runtime controller with anti-windup.

Loop (sampled at ``Tc``, the velocity measured at ``t_k`` and the command held
over ``[t_k, t_k + Tc)``)::

    plant   P(s) = 1 / (J s + sigma)            velocity w (rad/s) per torque u (N·m)
    P(z)    = ZOH discretisation of P(s)        (exact for the held command)
    C(z)    = Kp + Ki*Tc*z/(z - 1)              (backward-Euler integrator)
    L(z)    = C(z) P(z)

:func:`design_pi` places the gain crossover of the *discrete* ``L`` at a
requested frequency with a requested phase margin; :class:`PIController`
implements exactly this ``C(z)`` with a saturation, a feedforward input and
anti-windup by conditional integration (integrator clamping), a thin class
over the C struct ``ctl_pi`` and its step (``controllers/csrc/ctl_pi.c``,
``ctl_pi_step``; the closed-loop engine calls the same function). python-control and scipy are imported by the
design functions when they run, not with this module.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from functools import partial

import numpy as np

from controllers._cctl import ffi, lib
from plant.component import Component, struct_field, struct_fields
from plant.errors import ParameterError, check_finite_scalar, check_nonnegative, check_positive
from plant.results import axes_or_new, json_safe

__all__ = [
    "PIDesign",
    "PITuning",
    "design_pi",
    "analyse_gains",
    "ClosedLoopStep",
    "closed_loop_step",
    "PIController",
    "pi_step",
    "MAX_CROSSOVER_FRACTION",
    "MIN_CROSSOVER_TC",
]

#: Largest allowed crossover as a fraction of the Nyquist frequency ``pi/Tc``.
#: At ``0.2*pi/Tc`` the hold and the sampling already cost about 18 degrees of
#: phase (``wc*Tc/2``); beyond it the continuous-time picture is meaningless.
MAX_CROSSOVER_FRACTION = 0.2

#: Smallest allowed ``crossover*Tc``: below about 8e-7 the loop's poles sit so close to ``z = 1`` that the margins
#: cannot be computed (python-control's frequency grid fails), and a crossover of 1e-3 rad/s at 1 kHz (a loop
#: that settles in hours) is no velocity loop.
MIN_CROSSOVER_TC = 1e-6


_TF_PREFIX = "_tf_"


class _TransferFunctionField:
    """Field ``C``, ``plant`` or ``loop`` of :class:`PIDesign`: given to the constructor, or built on first read.

    A data descriptor (the dataclass stores what the constructor gets through ``__set__``): an unset value
    (None) is built from the design's gains by ``PIDesign._build_transfer_functions``, which imports
    python-control then, not when the design is made or unpickled.
    """

    def __init__(self, name: str):
        self.key = _TF_PREFIX + name

    def __get__(self, obj, objtype=None):
        if obj is None:
            return None  # the dataclass default
        if obj.__dict__.get(self.key) is None:
            obj._build_transfer_functions()
        return obj.__dict__[self.key]

    def __set__(self, obj, value):
        obj.__dict__[self.key] = None if isinstance(value, _TransferFunctionField) else value


@dataclass(frozen=True)
class PIDesign:
    """Result of :func:`design_pi`: gains and the margins achieved by the discrete loop.

    Attributes
    ----------
    Kp : float
        Proportional gain (N·m·s/rad).
    Ki : float
        Integral gain (N·m/rad); the integrator is ``Ki*Tc*z/(z - 1)``.
    Tc : float
        Controller period (s).
    crossover : float
        Achieved gain-crossover frequency of ``loop`` (rad/s), from
        ``control.stability_margins``.
    phase_margin : float
        Achieved phase margin (degrees), from ``control.stability_margins``.
    gain_margin : float
        Upper gain margin (factor, not dB): ``1/|L|`` at the first phase
        crossover above ``crossover``; ``inf`` if there is none. See Notes of
        :func:`design_pi`.
    phase_crossover : float
        Frequency of that phase crossover (rad/s), NaN if ``gain_margin`` is inf.
    stability_margin : float
        Smallest distance of ``L(exp(j w Tc))`` from -1 (``control.stability_margins``).
    J : float
        Design inertia (kg·m²).
    sigma : float
        Design viscous coefficient (N·m·s/rad).
    C : control.TransferFunction
        Discrete controller ``C(z)`` (``dt = Tc``).
    plant : control.TransferFunction
        ZOH-discretised plant ``P(z)`` (``dt = Tc``).
    loop : control.TransferFunction
        Open loop ``L(z) = C(z) P(z)``.
    """

    Kp: float
    Ki: float
    Tc: float
    crossover: float
    phase_margin: float
    gain_margin: float
    phase_crossover: float
    stability_margin: float
    J: float
    sigma: float
    C: control.TransferFunction = field(default=None, repr=False, compare=False)
    plant: control.TransferFunction = field(default=None, repr=False, compare=False)
    loop: control.TransferFunction = field(default=None, repr=False, compare=False)

    def __getstate__(self) -> dict:
        """Pickled without the transfer functions: they are rebuilt on first use, so that a design sent to
        another process does not import python-control where it is unpickled."""
        return {k: v for k, v in self.__dict__.items() if not k.startswith(_TF_PREFIX)}

    def _build_transfer_functions(self) -> None:
        """Set ``C``, ``plant`` and ``loop`` from the gains, ``J``, ``sigma``, ``Tc`` (as :func:`design_pi`)."""
        plant, C, loop = _transfer_functions(self.Kp, self.Ki, self.Tc, self.J, self.sigma)
        self.__dict__.update({_TF_PREFIX + "C": C, _TF_PREFIX + "plant": plant, _TF_PREFIX + "loop": loop})

    def to_dict(self) -> dict:
        """Gains, margins and design plant as strict JSON (SI units; gain margin also in dB; inf/NaN as None).

        The transfer functions are not included (rebuild them with :func:`design_pi`
        from ``J``, ``sigma``, ``crossover``, ``phase_margin``, ``Tc``).
        """
        gm = self.gain_margin
        return json_safe({
            "Kp": self.Kp, "Ki": self.Ki, "Tc": self.Tc, "J": self.J, "sigma": self.sigma,
            "crossover": self.crossover, "phase_margin": self.phase_margin, "gain_margin": gm,
            "gain_margin_db": 20.0 * math.log10(gm) if gm > 0.0 else None,
            "phase_crossover": self.phase_crossover, "stability_margin": self.stability_margin,
        })

    def summary(self) -> str:
        """Two lines: the gains and the margins the discrete loop achieves."""
        gm = self.gain_margin
        gm_txt = (f"{gm:.4g} ({20.0 * math.log10(gm):.1f} dB) at {self.phase_crossover:.5g} rad/s"
                  if math.isfinite(gm) else "inf (no phase crossover below Nyquist)")
        return (f"PI for 1/(J s + sigma), J = {self.J:g} kg·m², sigma = {self.sigma:g} N·m·s/rad, "
                f"Tc = {self.Tc:g} s: Kp = {self.Kp:.6g} N·m·s/rad, Ki = {self.Ki:.6g} N·m/rad\n"
                f"crossover {self.crossover:.5g} rad/s, phase margin {self.phase_margin:.2f} deg, "
                f"gain margin {gm_txt}, stability margin {self.stability_margin:.3f}")

    def plot(self, ax=None):
        """Magnitude (dB) of the open loop ``L``, of ``S = 1/(1+L)`` and ``T = L/(1+L)`` over frequency.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on; default a new figure (:func:`plant.results.axes_or_new`).

        Returns
        -------
        matplotlib.axes.Axes
            Frequency (rad/s, log axis) up to the Nyquist frequency ``pi/Tc``; the
            gain crossover is marked. Responses by ``control.frequency_response``
            on ``z = exp(j w Tc)``.
        """
        import control

        ax = axes_or_new(ax)
        w_nyq = math.pi / self.Tc
        om = np.geomspace(min(self.crossover, self.Ki / max(self.Kp, 1e-300)) / 100.0, w_nyq * (1 - 1e-9), 1000)

        def mag_db(sys):
            return 20.0 * np.log10(np.abs(np.asarray(control.frequency_response(sys, om).complex).reshape(-1)))

        ax.semilogx(om, mag_db(self.loop), color="C0", lw=1.5, label="|L| open loop")
        ax.semilogx(om, mag_db(control.feedback(1, self.loop)), color="C2", lw=0.9, ls="--", label="|S|")
        ax.semilogx(om, mag_db(control.feedback(self.loop, 1)), color="C3", lw=0.9, ls=":", label="|T|")
        ax.axhline(0.0, color="k", lw=0.6)
        ax.axvline(self.crossover, color="C1", lw=0.8,
                   label=f"crossover {self.crossover:.4g} rad/s, PM {self.phase_margin:.1f}°")
        ax.set_xlabel("frequency ω (rad/s)")
        ax.set_ylabel("magnitude (dB)")
        ax.legend(fontsize=8)
        ax.grid(True, which="both", alpha=0.3)
        return ax


for _name in ("C", "plant", "loop"):
    setattr(PIDesign, _name, _TransferFunctionField(_name))
del _name


def _transfer_functions(Kp: float, Ki: float, Tc: float, J: float, sigma: float) -> tuple:
    """``(P(z), C(z), L(z))`` of the module docstring: ZOH plant, PI controller, open loop (python-control)."""
    import control

    plant = control.sample_system(control.tf([1.0], [J, sigma]), Tc, method="zoh")
    C = _pi_tf(Kp, Ki, Tc)
    return plant, C, control.series(C, plant)


def _pi_tf(Kp: float, Ki: float, Tc: float):
    """``C(z) = Kp + Ki*Tc*z/(z-1) = ((Kp + Ki*Tc) z - Kp)/(z - 1)`` as a python-control TF."""
    import control

    return control.tf([Kp + Ki * Tc, -Kp], [1.0, -1.0], Tc)


def _upper_gain_margin(loop, wgc: float, gm_all, wpc_all, Tc: float):
    """Gain margin at the first phase crossover above ``wgc`` (factor, frequency in rad/s).

    ``control.stability_margins`` (0.10.2) reports, for a discrete loop with an
    integrator, a spurious phase crossover at ``w ~ 0`` (where ``|L| -> inf``) and
    misses the crossover at the Nyquist frequency ``z = -1``; both are handled here.
    """
    w_nyq = math.pi / Tc
    cands = [(float(w), float(g)) for g, w in zip(np.atleast_1d(gm_all), np.atleast_1d(wpc_all))
             if np.isfinite(w) and wgc < w < w_nyq * (1.0 - 1e-9)]
    Lnyq = complex(loop(-1.0))
    if Lnyq.real < 0.0 and abs(Lnyq.imag) <= 1e-9 * abs(Lnyq):
        cands.append((w_nyq, 1.0 / abs(Lnyq)))
    if not cands:
        return math.inf, math.nan
    w, g = min(cands)
    return g, w


def _continuous_gains(J: float, sigma: float, wc: float, pm: float) -> tuple[float, float]:
    """Step 1 of :func:`design_pi`: ``(Kp, Ki)`` of the continuous-time loop-shaping solution."""
    pm_rad = math.radians(pm)
    mag_inv = math.hypot(J * wc, sigma)
    phi_p = math.atan2(J * wc, sigma)
    phi_c = math.pi - pm_rad - phi_p
    if not 0.0 < phi_c < math.pi / 2:
        lo = math.degrees(math.pi / 2 - phi_p)
        hi = math.degrees(math.pi - phi_p)
        raise ParameterError(
            f"phase_margin={pm!r} deg cannot be reached by a PI (Kp > 0, Ki > 0) at "
            f"crossover={wc!r} rad/s: the plant lags {math.degrees(phi_p):.4g} deg there, so the "
            f"phase margin must lie in ({lo:.4g}, {hi:.4g}) deg"
        )
    return mag_inv * math.cos(phi_c), wc * mag_inv * math.sin(phi_c)


def _discrete_gains(plant, Kp0: float, Ki0: float, wc: float, pm: float, Tc: float) -> tuple[float, float]:
    """Step 2 of :func:`design_pi`: solve ``L(exp(j wc Tc)) = -exp(j PM)`` for ``(Kp, Ki)``, from ``(Kp0, Ki0)``."""
    from scipy import optimize

    pm_rad = math.radians(pm)
    zc = complex(math.cos(wc * Tc), math.sin(wc * Tc))
    Pz = complex(plant(zc))
    integ = Tc * zc / (zc - 1.0)
    target = -complex(math.cos(pm_rad), math.sin(pm_rad))

    def residual(x):
        r = (x[0] * Kp0 + x[1] * Ki0 * integ) * Pz - target
        return [r.real, r.imag]

    sol = optimize.root(residual, [1.0, 1.0], method="hybr")
    Kp, Ki = float(sol.x[0] * Kp0), float(sol.x[1] * Ki0)
    if max(abs(v) for v in residual(sol.x)) > 1e-9:
        raise ParameterError(
            f"no discrete PI found for crossover={wc!r} rad/s, phase_margin={pm!r} deg, "
            f"Tc={Tc!r} s ({sol.message})"
        )
    if Kp <= 0.0 or Ki <= 0.0:
        raise ParameterError(
            f"crossover={wc!r} rad/s with phase_margin={pm!r} deg needs Kp={Kp:.6g}, Ki={Ki:.6g} "
            f"at Tc={Tc!r} s (sampling lag too large); lower crossover or phase_margin"
        )
    return Kp, Ki


def _margins(loop, wc: float, pm: float, Tc: float) -> tuple[float, float, float, float, float]:
    """Step 3 of :func:`design_pi`: ``(crossover, phase margin, gain margin, phase crossover, stability margin)``.

    Raises ParameterError if the closed loop ``loop/(1 + loop)`` is unstable.
    """
    import control

    poles = control.poles(control.feedback(loop, 1))
    if np.any(np.abs(poles) >= 1.0):
        raise ParameterError(
            f"crossover={wc!r} rad/s, phase_margin={pm!r} deg give an unstable discrete closed loop "
            f"(pole moduli {np.abs(poles).round(6).tolist()}) at Tc={Tc!r} s"
        )
    with warnings.catch_warnings():
        # for poles close to z = 1 (crossover << 1/Tc) python-control switches from its
        # polynomial to its frequency-grid method and says so; both are accurate here
        warnings.filterwarnings("ignore", message="stability_margins: Falling back", category=UserWarning)
        # its frequency-grid search probes points where the response is inf (z = 1) and scipy's
        # finite differences warn about inf - inf; the margins it returns are unaffected
        warnings.filterwarnings("ignore", category=RuntimeWarning, module=r"scipy\.optimize\._numdiff")
        warnings.filterwarnings("ignore", category=RuntimeWarning, module=r"control\.xferfcn")  # the same at z = 1
        try:
            gm_all, pm_all, sm_all, wpc_all, wgc_all, _ = control.stability_margins(loop, returnall=True)
        except (ValueError, ZeroDivisionError, np.linalg.LinAlgError) as exc:  # its frequency-grid search fails
            raise ParameterError(f"crossover={wc!r} rad/s, phase_margin={pm!r} deg at Tc={Tc!r} s: the margins of "
                                 f"the designed loop cannot be computed ({exc}); its poles are too close to z = 1: "
                                 "a higher crossover") from None
    if np.size(wgc_all):
        i = int(np.argmin(np.abs(np.atleast_1d(wgc_all) - wc)))
        wgc = float(np.atleast_1d(wgc_all)[i])
        pm_ach = float(np.atleast_1d(pm_all)[i])
    else:  # python-control finds no gain crossover for some loops of a few degrees of margin: the design point's
        L = complex(loop(np.exp(1j * wc * Tc)))
        if not abs(abs(L) - 1.0) <= 1e-6:
            raise ParameterError(f"crossover={wc!r} rad/s, phase_margin={pm!r} deg at Tc={Tc!r} s: the margins of "
                                 f"the designed loop cannot be computed (|L| = {abs(L):.6g} at the crossover)")
        wgc, pm_ach = wc, math.degrees(math.pi + math.atan2(L.imag, L.real))
    gm, wpc = _upper_gain_margin(loop, wgc, gm_all, wpc_all, Tc)
    if np.size(sm_all):
        sm = float(np.min(sm_all))
    else:  # not reported with the crossover above: min |1 + L| on a frequency grid up to Nyquist
        w = np.geomspace(1e-3 * wc, math.pi / Tc, 4000)
        sm = float(np.min(np.abs(1.0 + np.asarray(loop(np.exp(1j * w * Tc)), dtype=complex).reshape(-1))))
    return wgc, pm_ach, gm, wpc, sm


def design_pi(
    J: float,
    *,
    sigma: float = 0.0,
    crossover: float = 20.0,
    phase_margin: float = 60.0,
    Tc: float = 1e-3,
) -> PIDesign:
    """Design a discrete PI velocity controller for ``1/(J s + sigma)`` by loop shaping.

    Parameters
    ----------
    J : float
        Plant inertia (kg·m²), > 0.
    sigma : float, keyword-only
        Plant viscous coefficient (N·m·s/rad), >= 0. 0 = pure inertia.
    crossover : float, keyword-only
        Target gain-crossover frequency ``wc`` of the discrete loop (rad/s),
        > 0 and <= ``MAX_CROSSOVER_FRACTION*pi/Tc``.
    phase_margin : float, keyword-only
        Target phase margin (degrees), in (0, 90).
    Tc : float, keyword-only
        Controller period (s), > 0.

    Returns
    -------
    PIDesign
        Gains, transfer functions and the margins the discrete loop achieves.

    Raises
    ------
    ParameterError
        An argument is out of range (the message names it and quotes the value; ``crossover`` must lie between
        ``MIN_CROSSOVER_TC/Tc`` and ``MAX_CROSSOVER_FRACTION*pi/Tc``), or the target cannot be met by a PI controller with ``Kp > 0, Ki > 0``
        (``phase_margin`` larger than the plant leaves room for, e.g. when
        ``sigma`` dominates ``J*crossover``), or the resulting closed loop is
        not stable.
    TypeError
        An argument is not a real number.

    Notes
    -----
    Plant discretised with a zero-order hold (``control.sample_system``), which
    is exact for a command held over the period (Franklin, Powell, Workman,
    *Digital Control of Dynamic Systems*, 3rd ed., Sec. 6.2); the controller
    uses the backward-Euler integrator of :class:`PIController`.

    1. Continuous-time start (Åström & Murray, *Feedback Systems*, 2nd ed.,
       Sec. 11.4 (loop shaping)): with ``phi_p = atan2(J wc, sigma)`` the plant
       lag at ``wc``, the PI lag is ``phi_c = 180 deg - PM - phi_p`` and
       ``Kp = |J j wc + sigma| cos(phi_c)``, ``Ki = wc |J j wc + sigma| sin(phi_c)``.
    2. Discrete refinement: ``scipy.optimize.root`` solves
       ``L(exp(j wc Tc)) = -exp(j PM)`` (magnitude 1, phase ``PM - 180 deg``) for
       ``(Kp, Ki)``. ``C`` is linear in the gains, so this converges in a few
       iterations to machine precision. For this plant and controller ``|L|``
       decreases monotonically on ``(0, pi/Tc)``, so ``wc`` is the only crossover.
    3. Margins from ``control.stability_margins`` on the discrete loop. The
       gain margin is the upper one, at the first -180 deg crossing above
       ``wc``. For this loop the phase stays above -180 deg on ``(0, pi/Tc)``
       and reaches it at the Nyquist frequency (``L(-1)`` is real and
       negative), so ``GM = 1/|L(-1)|``. python-control 0.10.2 reports a
       spurious crossover near ``w = 0`` for loops with an integrator (phase
       tends to -180 deg there) and misses ``z = -1``; both are corrected.
    """
    J = check_positive("J", J)
    sigma = check_nonnegative("sigma", sigma)
    Tc = check_positive("Tc", Tc)
    wc = check_positive("crossover", crossover)
    w_max = MAX_CROSSOVER_FRACTION * math.pi / Tc
    if wc > w_max:
        raise ParameterError(
            f"crossover must be well below the Nyquist frequency pi/Tc = {math.pi / Tc:.6g} rad/s "
            f"(<= {MAX_CROSSOVER_FRACTION}*pi/Tc = {w_max:.6g} rad/s), got {wc!r}"
        )
    if wc * Tc < MIN_CROSSOVER_TC:
        raise ParameterError(f"crossover must be at least {MIN_CROSSOVER_TC:g}/Tc = {MIN_CROSSOVER_TC / Tc:.6g} rad/s "
                             f"(a velocity loop that settles within hours), got {wc!r}")
    pm = check_finite_scalar("phase_margin", phase_margin)
    if not 0.0 < pm < 90.0:
        raise ParameterError(f"phase_margin must be in (0, 90) degrees, got {pm!r}")

    import control

    Kp0, Ki0 = _continuous_gains(J, sigma, wc, pm)  # 1. continuous-time analytic solution
    plant = control.sample_system(control.tf([1.0], [J, sigma]), Tc, method="zoh")
    Kp, Ki = _discrete_gains(plant, Kp0, Ki0, wc, pm, Tc)  # 2. discrete refinement
    C = _pi_tf(Kp, Ki, Tc)
    loop = control.series(C, plant)
    wgc, pm_ach, gm, wpc, sm = _margins(loop, wc, pm, Tc)  # 3. stability, margins
    return PIDesign(Kp=Kp, Ki=Ki, Tc=Tc, crossover=wgc, phase_margin=pm_ach, gain_margin=gm,
                    phase_crossover=wpc, stability_margin=sm, J=J, sigma=sigma, C=C,
                    plant=plant, loop=loop)


@dataclass(frozen=True, kw_only=True)
class PITuning:
    """How a loop's PI is chosen (keyword-only): given gains, or designed by :func:`design_pi` for the plant.

    Parameters
    ----------
    Kp, Ki : float or None
        The gains (N·m·s/rad, N·m/rad): both, or neither (default) for a design.
    crossover : float
        Target gain-crossover frequency (rad/s) of the design, default 20.
    phase_margin : float
        Target phase margin (deg) of the design, default 60.

    Raises
    ------
    ParameterError
        One of ``Kp``/``Ki`` alone. The targets are checked by :func:`design_pi` where a design is made.
    """

    Kp: float | None = None
    Ki: float | None = None
    crossover: float = 20.0
    phase_margin: float = 60.0

    def __post_init__(self):
        if (self.Kp is None) != (self.Ki is None):
            raise ParameterError("give both --Kp and --Ki, or neither (then the PI is designed from J and sigma)")

    def gains(self, J: float, *, sigma: float = 0.0, Tc: float = 1e-3) -> tuple[float, float]:
        """``(Kp, Ki)``: the given gains, else those of :func:`design_pi` for ``1/(J s + sigma)`` (kg·m²,
        N·m·s/rad) at the targets and the period ``Tc`` (s)."""
        if self.Kp is not None:
            return self.Kp, self.Ki
        d = design_pi(J, sigma=sigma, crossover=self.crossover, phase_margin=self.phase_margin, Tc=Tc)
        return d.Kp, d.Ki


def analyse_gains(Kp: float, Ki: float, *, J: float, sigma: float = 0.0, Tc: float = 1e-3) -> PIDesign:
    """The margins of a given discrete PI on ``1/(J s + sigma)``: the :class:`PIDesign` of gains a user already has
    (``adaptive-ff design --json``, a drive's parameters), as :func:`design_pi` reports its own.

    Parameters
    ----------
    Kp : float
        Proportional gain (N·m·s/rad), > 0.
    Ki : float
        Integral gain (N·m/rad), >= 0.
    J : float, keyword-only
        Inertia of the loop model (kg·m²), > 0.
    sigma : float, keyword-only
        Viscous coefficient of the loop model (N·m·s/rad), >= 0.
    Tc : float, keyword-only
        Controller period (s), > 0.

    Returns
    -------
    PIDesign
        The gains as given; ``crossover`` where ``|L| = 1`` (rad/s), the phase, gain and stability margins of the
        discrete loop, as :func:`design_pi` computes them (its step 3).

    Raises
    ------
    ParameterError
        A value out of range (named), a closed loop that is unstable (its pole moduli quoted), or a loop gain that
        never falls to 1 below the Nyquist frequency.

    Notes
    -----
    ``|L(exp(j w Tc))|`` decreases monotonically on ``(0, pi/Tc)`` for this plant and controller (:func:`design_pi`,
    Notes), so the crossover is the one root of ``|L| = 1`` there (``scipy.optimize.brentq``).
    """
    Kp = check_positive("Kp", Kp)
    Ki = check_nonnegative("Ki", Ki)
    J = check_positive("J", J)
    sigma = check_nonnegative("sigma", sigma)
    Tc = check_positive("Tc", Tc)

    import control
    from scipy.optimize import brentq

    plant = control.sample_system(control.tf([1.0], [J, sigma]), Tc, method="zoh")
    C = _pi_tf(Kp, Ki, Tc)
    loop = control.series(C, plant)
    poles = control.poles(control.feedback(loop, 1))
    if np.any(np.abs(poles) >= 1.0):
        raise ParameterError(f"Kp = {Kp!r} N·m·s/rad, Ki = {Ki!r} N·m/rad give an unstable discrete closed loop on "
                             f"J = {J!r} kg·m², sigma = {sigma!r} N·m·s/rad at Tc = {Tc!r} s (pole moduli "
                             f"{np.abs(poles).round(6).tolist()})")

    def log_gain(w: float) -> float:
        return math.log(abs(complex(loop(np.exp(1j * w * Tc)))))

    lo, hi = 1e-5 / Tc, 0.999 * math.pi / Tc  # w*Tc >= 1e-5: (z - 1)**2 expanded keeps its digits
    if not (log_gain(lo) > 0.0 > log_gain(hi)):
        raise ParameterError(f"Kp = {Kp!r} N·m·s/rad, Ki = {Ki!r} N·m/rad on J = {J!r} kg·m² at Tc = {Tc!r} s: the "
                             f"loop gain does not cross 1 below the Nyquist frequency")
    wc = brentq(log_gain, lo, hi, xtol=1e-12 / Tc, rtol=1e-12)
    L = complex(loop(np.exp(1j * wc * Tc)))
    pm = math.degrees(math.pi + math.atan2(L.imag, L.real))
    wgc, pm_ach, gm, wpc, sm = _margins(loop, wc, pm, Tc)
    return PIDesign(Kp=Kp, Ki=Ki, Tc=Tc, crossover=wgc, phase_margin=pm_ach, gain_margin=gm,
                    phase_crossover=wpc, stability_margin=sm, J=J, sigma=sigma, C=C, plant=plant, loop=loop)


@dataclass(frozen=True)
class ClosedLoopStep:
    """Linear closed-loop response to a unit velocity-reference step, see :func:`closed_loop_step`.

    Attributes
    ----------
    t : ndarray, shape (N + 1,)
        Time (s), ``t[k] = k*Tc``.
    w : ndarray, shape (N + 1,)
        Velocity (rad/s) per 1 rad/s of reference.
    u : ndarray, shape (N + 1,)
        Controller torque (N·m) per 1 rad/s of reference, held over ``[t[k], t[k+1])``.
    """

    t: np.ndarray
    w: np.ndarray
    u: np.ndarray

    def to_dict(self) -> dict:
        """The three arrays as lists (s, rad/s, N·m per rad/s), strict JSON."""
        return json_safe({"t": self.t, "w": self.w, "u": self.u})

    def summary(self) -> str:
        """One line: duration, final velocity and torque, largest torque."""
        return (f"unit step over {self.t[-1]:.4g} s: w(end) = {self.w[-1]:.6g} rad/s, "
                f"u(end) = {self.u[-1]:.6g} N·m, max |u| = {float(np.max(np.abs(self.u))):.6g} N·m")

    def plot(self, ax=None):
        """Velocity (rad/s) over time (s) as held samples, with the 1 rad/s reference.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on; default a new figure.

        Returns
        -------
        matplotlib.axes.Axes
        """
        ax = axes_or_new(ax)
        ax.step(self.t, self.w, where="post", color="C0", lw=1.2, label="velocity w")
        ax.axhline(1.0, color="k", lw=0.6, ls="--", label="reference (1 rad/s)")
        ax.set_xlabel("time t (s)")
        ax.set_ylabel("velocity w (rad/s)")
        ax.legend(fontsize=8)
        ax.grid(True, alpha=0.3)
        return ax


def closed_loop_step(design: PIDesign, *, t_end: float = 0.5) -> ClosedLoopStep:
    """Step response of the discrete linear closed loop of ``design`` (no friction, no saturation).

    Parameters
    ----------
    design : PIDesign
        From :func:`design_pi`.
    t_end : float, keyword-only
        Duration (s), >= ``design.Tc``.

    Returns
    -------
    ClosedLoopStep
        ``w = L/(1+L) r`` and ``u = C/(1+L) r`` for a unit step ``r`` (1 rad/s);
        in steady state ``w -> 1`` and ``u -> sigma`` (integral action).

    Raises
    ------
    ParameterError
        ``t_end`` not >= ``design.Tc``.

    Notes
    -----
    ``control.step_response`` of ``control.feedback(loop, 1)`` and
    ``control.feedback(C, plant)``.
    """
    import control

    t_end = check_positive("t_end", t_end)
    Tc = design.Tc
    n = int(round(t_end / Tc))
    if n < 1:
        raise ParameterError(f"t_end must be >= Tc = {Tc!r} s, got {t_end!r}")
    t = np.arange(n + 1) * Tc
    w = control.step_response(control.feedback(design.loop, 1), T=t).outputs
    u = control.step_response(control.feedback(design.C, design.plant), T=t).outputs
    return ClosedLoopStep(t=t, w=np.asarray(w, dtype=float).reshape(-1),
                          u=np.asarray(u, dtype=float).reshape(-1))


def pi_step(pi, e: float, u_ff: float = 0.0) -> float:
    """One period of the discrete PI with saturation and clamping anti-windup on a ``ctl_pi`` struct.

    Parameters
    ----------
    pi : PIController or cffi ``ctl_pi *``
        The controller (or a pointer to its C struct, e.g. an element of a ``ctl_pi[]`` array); its
        integrator and saturation flag are advanced in place.
    e : float
        Velocity error ``r - w`` (rad/s) at this sample.
    u_ff : float
        Feedforward torque (N·m), added before the saturation.

    Returns
    -------
    float
        Command torque ``sat(Kp*e + I' + u_ff, ±u_max)`` (N·m).

    Notes
    -----
    C (``controllers/csrc/ctl_pi.c``, ``ctl_pi_step``); inputs are not validated. With ``d = Ki*Tc*e`` the
    backward-Euler integrator ``I' = I + d`` (``C(z) = Kp + Ki*Tc*z/(z-1)``) is clamped: if ``I'`` would
    drive ``v = Kp*e + I' + u_ff`` past the limit in the direction of ``d``, it is cut to where ``v``
    touches the limit, but never moved against ``d`` (then ``I' = I``). Anti-windup by conditional
    integration: Åström & Hägglund, *Advanced PID Control*, ISA 2006, Sec. 3.5. See :class:`PIController`
    for its properties.
    """
    return lib.ctl_pi_step(pi.cdata if isinstance(pi, PIController) else pi, e, u_ff)


@struct_fields("Kp", "u_max", "saturated", settable=("saturated",))
class PIController(Component):
    """Discrete PI controller with saturation, feedforward and anti-windup (integrator clamping).

    A thin class over the C struct ``ctl_pi`` (``controllers/csrc/ctl_pi.h``) and its step ``ctl_pi_step``.

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
    cdata : cffi ``ctl_pi *``
        The C struct: fields ``Kp``, ``KiTc`` (``Ki*Tc``), ``u_max``, ``I``, ``saturated``
        (:class:`plant.component.Component`).
    integral : float
        Integrator state ``I`` (N·m) (read it, or set it to preload).
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

    _ffi = ffi
    _ctype = "ctl_pi"
    _repr_fields = ("Kp", "Ki", "Tc", "u_max", "integral")

    def __init__(self, *, Kp: float, Ki: float, Tc: float, u_max: float = math.inf,
                 integral0: float = 0.0):
        Kp = check_nonnegative("Kp", Kp)
        self._Ki = check_nonnegative("Ki", Ki)
        self._Tc = check_positive("Tc", Tc)
        if isinstance(u_max, bool) or not isinstance(u_max, (int, float, np.integer, np.floating)):
            raise TypeError(f"u_max must be a real number, got {u_max!r} ({type(u_max).__name__})")
        u_max = float(u_max)
        if not u_max > 0.0:  # also rejects NaN
            raise ParameterError(f"u_max must be > 0 (math.inf for no limit), got {u_max!r}")
        integral0 = check_finite_scalar("integral0", integral0)
        self._new_struct()
        lib.ctl_pi_init(self._c, Kp, self._Ki * self._Tc, u_max, integral0)

    @classmethod
    def from_design(cls, design: PIDesign, *, u_max: float = math.inf) -> "PIController":
        """Controller with the gains and period of a :class:`PIDesign` and the limit ``u_max`` (N·m).

        Raises
        ------
        ParameterError
            ``u_max`` not > 0.
        """
        return cls(Kp=design.Kp, Ki=design.Ki, Tc=design.Tc, u_max=u_max)

    @property
    def Ki(self) -> float:
        """Integral gain (N·m/rad)."""
        return self._Ki

    @property
    def Tc(self) -> float:
        """Controller period (s)."""
        return self._Tc

    integral = struct_field("I", float, "Integrator state ``I`` (N·m); settable (finite) to preload it.",
                            settable=True, check=partial(check_finite_scalar, "integral"))

    def reset(self, integral: float = 0.0) -> None:
        """Set the integrator to ``integral`` (N·m, default 0) and clear ``saturated``."""
        self.integral = integral
        self._c.saturated = 0

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
        C (``controllers/csrc/ctl_pi.c``, ``ctl_pi_step``) on :attr:`cdata`; inputs are not
        validated here. See the class Notes for the clamping rule.
        """
        return lib.ctl_pi_step(self._c, e, u_ff)
