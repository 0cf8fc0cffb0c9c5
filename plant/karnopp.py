"""Lagged Stribeck joint with a Karnopp stick band at zero velocity (true sticking, not creeping).

The paper's model (eqs. 1-3) has ``F(0) = 0`` and so lets the joint creep
through zero velocity; a real joint sticks until the applied torque exceeds
the breakaway level. Karnopp's model (D. Karnopp, "Computer simulation of
stick-slip friction in mechanical dynamic systems", ASME J. Dyn. Sys. Meas.
Control 107(1), 1985, pp. 100-103) treats every velocity inside a small band
``|w| < dv`` as "stuck": the friction then balances the applied torque up to
``Fs``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from plant.errors import check_positive
from plant.friction import JointParams, stribeck
from plant.mapping import LaggedPlantModel

__all__ = ["KarnoppParams"]


@dataclass(frozen=True)
class KarnoppParams(LaggedPlantModel):
    """Joint of :class:`plant.friction.JointParams` plus a Karnopp stick band of half-width ``dv``.

    Parameters
    ----------
    J, Fc, Fs, Vs, delta, sigma, tau : float
        As in :class:`plant.friction.JointParams` (SI units).
    dv : float
        Half-width of the stick band (rad/s), > 0.

    Raises
    ------
    ParameterError
        A value out of range (the message quotes it).

    Notes
    -----
    At each integration step of length ``dt`` with input ``u`` held:

    - ``|w| < dv`` and ``|u| <= Fs``: the friction balances the drive torque
      up to ``Fs`` and opposes the motion with at most ``Fs`` (``|f| <= Fs``).
      Where the friction that stops the joint within the step,
      ``u + J*w/dt``, lies in ``[-Fs, Fs]`` it sticks: the velocity is set to
      0 and the friction state to ``f = u``. Else it slides the whole step,
      decelerated by ``f = Fs*sgn(w)``: ``w += dt*(u - f)/J`` (exact; with
      ``u = 0`` it sticks after ``ceil(J*|w|/(Fs*dt))`` steps).
    - ``|w| < dv`` and ``|u| > Fs``: breakaway. RK4 of eqs. 1-2 with the lag
      target ``Fs*sgn(u)`` while the velocity is in the band, ``F(w)`` (eq. 3)
      outside it.
    - ``|w| >= dv``: the lagged Stribeck joint of eqs. 1-3 (RK4).

    A stiff joint (:func:`plant.dynamics.lagged_rate` beyond ``LAGGED_RK4_MAX`` RK4 sub-steps per step) is
    advanced by the implicit :func:`plant.dynamics.lagged_stiff_step` under the same rules.

    Karnopp (1985) fixes the acceleration to 0 in the band; zeroing the
    velocity as well removes the slow drift of that scheme (a common
    refinement, e.g. Olsson et al., "Friction models and friction
    compensation", Eur. J. Control 4(3), 1998, Sec. 3.3), within the bound
    ``|f| <= Fs`` of the static friction: a heavy joint entering the band
    decelerates for several steps before it sticks.
    """

    MODEL: ClassVar[str] = "karnopp"

    J: float
    Fc: float
    Fs: float
    Vs: float
    delta: float
    sigma: float
    tau: float
    dv: float

    def __post_init__(self):
        base = self.lagged()  # validates the shared fields
        for k in ("J", "Fc", "Fs", "Vs", "delta", "sigma", "tau"):
            object.__setattr__(self, k, getattr(base, k))
        object.__setattr__(self, "dv", check_positive("dv", self.dv))

    def lagged(self) -> JointParams:
        """The same joint without the stick band (the paper's model)."""
        return JointParams(J=self.J, Fc=self.Fc, Fs=self.Fs, Vs=self.Vs, delta=self.delta, sigma=self.sigma,
                           tau=self.tau)

    def friction(self, w):
        """Steady-sliding friction map ``F(w)`` (eq. 3), N·m (``F(0) = 0``)."""
        return stribeck(w, Fc=self.Fc, Fs=self.Fs, Vs=self.Vs, delta=self.delta, sigma=self.sigma)

    def frictionless(self) -> JointParams:
        """The same inertia without friction (the compensation limit)."""
        return self.lagged().frictionless()
