"""Test oracle: the pure-Python plant steps and the identification simulator that the compiled kernels replaced.

Verbatim (issue 10, with one change: the lagged models' right-hand sides multiply by ``1/J`` and ``1/tau``, as the
package's plant step does since the batch speed-up) the former ``plant.joint._friction_scalar`` and ``plant.joint.lagged_rk4_step`` (eq. 3 and
the RK4 step of eqs. 1-2), ``KarnoppParams.make_step``, ``LuGreParams.make_step`` and ``friction_torque``,
``AsymmetricParams.make_step`` (here functions of the parameter object ``self``), and the former numba kernel of
:mod:`adaptive_ff.identification.simulator` run as plain Python. Used by tests/test_plant_kernels.py to check
:mod:`plant.dynamics` bit for bit. Not part of the package.

One change of the model since then: a static map (``tau = 0``, lagged Stribeck and asymmetric) jumps at ``w = 0``
and the joint sticks there (Filippov). RK4 steps creep and chatter through that jump, so a step that can reach it
(:func:`plant.stiff.static_jump_in_reach`) is the package's set-valued step (:func:`plant.stiff.lagged_stiff_step`),
which tests/test_static_stick.py checks against the independent Radau solution of tests/stiff_oracle.py; every
other step here is the former RK4 step, verbatim.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from plant.dynamics import plant_params
from plant.errors import check_positive
from plant.stiff import lagged_stiff_step, static_jump_in_reach

__all__ = ["friction_scalar", "lagged_rk4_step", "make_rk4_step", "karnopp_make_step", "lugre_make_step",
           "lugre_friction_torque", "asymmetric_make_step", "simulator_rk4"]


def friction_scalar(p) -> Callable[[float], float]:
    """Return a fast scalar F(w) (eq. 3) for parameters ``p`` (plain floats, no numpy)."""
    Fc, dF, Vs, delta, sigma = p.Fc, p.Fs - p.Fc, p.Vs, p.delta, p.sigma

    def F(w: float) -> float:
        if w == 0.0:
            return 0.0
        try:
            s = math.exp(-((abs(w) / Vs) ** delta))
        except OverflowError:  # |w/Vs|**delta beyond the float range (delta < 0, w tiny): shape -> 0
            s = 0.0
        if w > 0.0:
            return Fc + dF * s + sigma * w
        return -(Fc + dF * s) + sigma * w

    return F


def static_jump_step(p, dt: float) -> Callable[[float, float, float], tuple | None]:
    """``(w, f, u) -> (w, f)`` of the package's set-valued step where the jump of a static map is within reach of
    the step, else None (see the module docstring)."""
    par = plant_params(p)

    def jump(w: float, f: float, u: float):
        if not static_jump_in_reach(par, w, u, dt):
            return None
        st = np.array([w, f, math.nan])
        lagged_stiff_step(par, st, u, dt, 0.0)
        return float(st[0]), float(st[1])

    return jump


def lagged_rk4_step(F: Callable[[float], float], *, J: float, tau: float, dt: float,
                    jump: Callable | None = None) -> Callable[[float, float, float], tuple]:
    """RK4 step ``(w, f, u) -> (w, f)`` of ``J*dw/dt = u - f``, ``tau*df/dt + f = F(w)`` for any scalar map ``F``.

    Parameters
    ----------
    F : callable
        Static friction map ``F(w)`` (N·m) on plain floats, e.g. eq. 3 or an asymmetric variant.
    J : float, keyword-only
        Inertia (kg·m²).
    tau : float, keyword-only
        Friction lag (s); 0 makes ``f = F(w)`` algebraic (RK4 on ``w`` alone).
    dt : float, keyword-only
        Step (s).
    jump : callable or None, keyword-only
        With ``tau = 0``: :func:`static_jump_step` of the plant, taking the steps that can reach ``w = 0``.

    Returns
    -------
    callable
        The step function used by :func:`make_rk4_step` (see its Notes).
    """
    h2, h6 = dt / 2.0, dt / 6.0
    iJ = 1.0 / J  # the package multiplies by the reciprocals (plant.dynamics, slots inv_J, inv_tau)
    itau = 1.0 / tau if tau > 0.0 else 0.0

    if tau == 0.0:

        def step_static(w: float, f: float, u: float) -> tuple:
            near = jump(w, f, u) if jump is not None else None
            if near is not None:
                return near
            k1 = (u - F(w)) * iJ
            k2 = (u - F(w + h2 * k1)) * iJ
            k3 = (u - F(w + h2 * k2)) * iJ
            k4 = (u - F(w + dt * k3)) * iJ
            w = w + h6 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
            return w, F(w)

        return step_static

    def step(w: float, f: float, u: float) -> tuple:
        k1w = (u - f) * iJ
        k1f = (F(w) - f) * itau
        w2, f2 = w + h2 * k1w, f + h2 * k1f
        k2w = (u - f2) * iJ
        k2f = (F(w2) - f2) * itau
        w3, f3 = w + h2 * k2w, f + h2 * k2f
        k3w = (u - f3) * iJ
        k3f = (F(w3) - f3) * itau
        w4, f4 = w + dt * k3w, f + dt * k3f
        k4w = (u - f4) * iJ
        k4f = (F(w4) - f4) * itau
        return (w + h6 * (k1w + 2.0 * k2w + 2.0 * k3w + k4w),
                f + h6 * (k1f + 2.0 * k2f + 2.0 * k3f + k4f))

    return step


def make_rk4_step(p, dt: float) -> Callable[[float, float, float], tuple]:
    """The former ``plant.joint.make_rk4_step`` for a ``JointParams`` ``p``."""
    dt = check_positive("dt", dt)
    return lagged_rk4_step(friction_scalar(p), J=p.J, tau=p.tau, dt=dt,
                           jump=static_jump_step(p, dt) if p.tau == 0.0 else None)


def karnopp_make_step(self, dt: float) -> Callable[[float, float, float], tuple]:
    """One step ``(w, f, u) -> (w, f)`` over ``dt`` (s) with ``u`` held; rules in the class Notes.

    Raises
    ------
    ParameterError
        ``dt`` not > 0.
    """
    dt = check_positive("dt", dt)
    J, Fc, dF, Vs, delta, sigma, tau = self.J, self.Fc, self.Fs - self.Fc, self.Vs, self.delta, self.sigma, self.tau
    Fs, dv = self.Fs, self.dv
    h2, h6 = dt / 2.0, dt / 6.0
    iJ, itau = 1.0 / J, (1.0 / tau if tau > 0.0 else 0.0)  # reciprocals, as plant.dynamics (slots inv_J, inv_tau)
    exp = math.exp

    def target(w: float, sgn_u: float) -> float:
        if -dv < w < dv:
            return Fs * sgn_u
        if w > 0.0:
            return Fc + dF * exp(-((w / Vs) ** delta)) + sigma * w
        return -(Fc + dF * exp(-((-w / Vs) ** delta))) + sigma * w

    def step(w: float, f: float, u: float) -> tuple:
        if -dv < w < dv:
            if -Fs <= u <= Fs:
                return 0.0, u
            sgn_u = 1.0 if u > 0.0 else -1.0
        else:
            sgn_u = 0.0
        if tau == 0.0:
            k1 = (u - target(w, sgn_u)) * iJ
            k2 = (u - target(w + h2 * k1, sgn_u)) * iJ
            k3 = (u - target(w + h2 * k2, sgn_u)) * iJ
            k4 = (u - target(w + dt * k3, sgn_u)) * iJ
            w = w + h6 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
            return w, target(w, sgn_u)
        k1w = (u - f) * iJ
        k1f = (target(w, sgn_u) - f) * itau
        w2, f2 = w + h2 * k1w, f + h2 * k1f
        k2w = (u - f2) * iJ
        k2f = (target(w2, sgn_u) - f2) * itau
        w3, f3 = w + h2 * k2w, f + h2 * k2f
        k3w = (u - f3) * iJ
        k3f = (target(w3, sgn_u) - f3) * itau
        w4, f4 = w + dt * k3w, f + dt * k3f
        k4w = (u - f4) * iJ
        k4f = (target(w4, sgn_u) - f4) * itau
        return (w + h6 * (k1w + 2.0 * k2w + 2.0 * k3w + k4w),
                f + h6 * (k1f + 2.0 * k2f + 2.0 * k3f + k4f))

    return step


def lugre_make_step(self, dt: float) -> Callable[[float, float, float], tuple]:
    """One integration step ``(w, z, u) -> (w, z)`` over ``dt`` (s) with ``u`` held.

    Classic RK4 on ``(w, z)`` with ``n`` equal sub-steps, ``n`` chosen at each
    call from the current stiffness ``sigma0*|w|/g(w) + (sigma1 + sigma2)/J +
    sqrt(sigma0/J)`` so that each sub-step stays well inside RK4's stability
    region (rate times sub-step <= 1; the region ends near 2.8).

    Raises
    ------
    ParameterError
        ``dt`` not > 0.
    """
    dt = check_positive("dt", dt)
    J, Fc, dF, Vs, delta = self.J, self.Fc, self.Fs - self.Fc, self.Vs, self.delta
    s0, s1, s2 = self.sigma0, self.sigma1, self.sigma2
    g_min, g_max = min(self.Fc, self.Fs), max(self.Fc, self.Fs)
    base_rate = (s1 + s2) / J + math.sqrt(s0 / J)
    exp = math.exp

    def rhs(w, z, u):
        aw = w if w >= 0.0 else -w
        gw = Fc + dF * exp(-((aw / Vs) ** delta)) if aw > 0.0 else (Fc + dF if delta > 0 else Fc)
        zdot = w - s0 * aw / gw * z
        return (u - s0 * z - s1 * zdot - s2 * w) / J, zdot

    def step(w: float, z: float, u: float) -> tuple:
        aw = w if w >= 0.0 else -w
        # bound |w| over the step by its start value plus the largest acceleration
        rate = s0 * (aw + (abs(u) + g_max + s2 * aw) * dt / J) / g_min + base_rate
        n = int(rate * dt) + 1
        h = dt / n
        h2, h6 = 0.5 * h, h / 6.0
        for _ in range(n):
            k1w, k1z = rhs(w, z, u)
            k2w, k2z = rhs(w + h2 * k1w, z + h2 * k1z, u)
            k3w, k3z = rhs(w + h2 * k2w, z + h2 * k2z, u)
            k4w, k4z = rhs(w + h * k3w, z + h * k3z, u)
            w = w + h6 * (k1w + 2.0 * k2w + 2.0 * k3w + k4w)
            z = z + h6 * (k1z + 2.0 * k2z + 2.0 * k3z + k4z)
        return w, z

    return step


def lugre_friction_torque(self, w: float, z: float) -> float:
    """Friction torque (N·m) in state ``(w, z)``: ``sigma0*z + sigma1*dz/dt + sigma2*w``."""
    aw = abs(w)
    g = self.Fc + (self.Fs - self.Fc) * math.exp(-((aw / self.Vs) ** self.delta)) if aw > 0.0 else (
        self.Fs if self.delta > 0 else self.Fc)
    zdot = w - self.sigma0 * aw / g * z
    return self.sigma0 * z + self.sigma1 * zdot + self.sigma2 * w


def asymmetric_make_step(self, dt: float) -> Callable[[float, float, float], tuple]:
    """One classic RK4 step ``(w, f, u) -> (w, f)`` over ``dt`` (s) with ``u`` held.

    Raises
    ------
    ParameterError
        ``dt`` not > 0.
    """
    dt = check_positive("dt", dt)
    J, Vs, delta, tau = self.J, self.Vs, self.delta, self.tau
    cp, dp, sp = self.Fc_pos, self.Fs_pos - self.Fc_pos, self.sigma_pos
    cn, dn, sn = self.Fc_neg, self.Fs_neg - self.Fc_neg, self.sigma_neg
    exp = math.exp

    def F(w: float) -> float:
        if w > 0.0:
            return cp + dp * exp(-((w / Vs) ** delta)) + sp * w
        if w < 0.0:
            return -(cn + dn * exp(-((-w / Vs) ** delta))) + sn * w
        return 0.0

    return lagged_rk4_step(F, J=J, tau=tau, dt=dt, jump=static_jump_step(self, dt) if tau == 0.0 else None)


def _friction(x, Fc, dF, Vs, delta, sigma, offset):
    if x > 0.0:
        return Fc + dF * math.exp(-((x / Vs) ** delta)) + sigma * x + offset
    if x < 0.0:
        return -(Fc + dF * math.exp(-((-x / Vs) ** delta))) + sigma * x + offset
    return offset


def simulator_rk4(tg, ug, idx, J, Fc, Fs, Vs, delta, sigma, tau, offset, w0, f0, Kw, Kf, w_meas, inject):
    n = idx.shape[0]
    out = np.empty(n)
    out[0] = w0
    iJ = 1.0 / J
    itau = 1.0 / tau
    dF = Fs - Fc
    w = w0
    f = f0
    for s in range(1, n):
        a = idx[s - 1]
        b = idx[s]
        for j in range(a, b):
            h = tg[j + 1] - tg[j]
            u0 = ug[j]
            u2 = ug[j + 1]
            u1 = 0.5 * (u0 + u2)
            hh = 0.5 * h
            k1w = (u0 - f) * iJ
            k1f = (_friction(w, Fc, dF, Vs, delta, sigma, offset) - f) * itau
            w2 = w + hh * k1w
            f2 = f + hh * k1f
            k2w = (u1 - f2) * iJ
            k2f = (_friction(w2, Fc, dF, Vs, delta, sigma, offset) - f2) * itau
            w3 = w + hh * k2w
            f3 = f + hh * k2f
            k3w = (u1 - f3) * iJ
            k3f = (_friction(w3, Fc, dF, Vs, delta, sigma, offset) - f3) * itau
            w4 = w + h * k3w
            f4 = f + h * k3f
            k4w = (u2 - f4) * iJ
            k4f = (_friction(w4, Fc, dF, Vs, delta, sigma, offset) - f4) * itau
            w += h / 6.0 * (k1w + 2.0 * k2w + 2.0 * k3w + k4w)
            f += h / 6.0 * (k1f + 2.0 * k2f + 2.0 * k3f + k4f)
        if not (math.isfinite(w) and math.isfinite(f)):
            for r in range(s, n):
                out[r] = np.nan
            return out
        out[s] = w
        if inject:
            e = w_meas[s] - w
            w += Kw * e
            f -= Kf * J / (tg[b] - tg[a]) * e
    return out
