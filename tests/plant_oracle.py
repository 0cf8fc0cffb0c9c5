"""Test oracle of the plant step: the models' equations integrated by the classical Runge-Kutta tableau, on arrays.

:func:`plant.dynamics.plant_step` advances one state by unrolled RK4 sub-steps. The oracle writes each model's
right-hand side from its equations (eqs. 1-3 of the lagged Stribeck joint and its asymmetric variant, the Karnopp
stick band, LuGre's bristle model) on numpy arrays, and integrates it with a generic explicit Runge-Kutta step
driven by the classical fourth-order Butcher tableau (Hairer, Nørsett, Wanner, *Solving ODEs I*, Sec. II.1,
Table 1.2), for any number of states at once: :func:`step` takes arrays of velocities, states and torques and
returns the states one period later, so that a test steps every state of a recorded trajectory in one call and
compares with the next recorded state. The package's rules that are not integration are written from their
documentation: the Karnopp stick rule (:class:`plant.karnopp.KarnoppParams`) and the number of LuGre sub-steps
(:meth:`plant.lugre.LuGreParams.make_step`).

One part is the package's own: with ``tau = 0`` the map of eq. 3 jumps at ``w = 0`` and a step that can reach the
jump (:func:`plant.stiff.static_jump_in_reach`) is the package's set-valued step
(:func:`plant.stiff.lagged_stiff_step`), which tests/plant_layer/test_static_stick.py checks against the independent Radau
solution of tests/stiff_oracle.py; every other step here is the tableau's. Each period is one RK4 step (lagged
models) as for the non-stiff plants of the tests; LuGre takes its sub-steps. :func:`simulate_foh` is the
identification simulator (first-order hold of the input, output injection) on the same tableau. Not part of the
package.
"""

from __future__ import annotations

import math

import numpy as np

from plant._cplant import ffi
from plant.dynamics import plant_params
from plant.stiff import lagged_stiff_step, static_jump_in_reach

__all__ = ["RK4_TABLEAU", "rk_step", "friction", "step", "make_step", "lugre_friction_torque", "simulate_foh"]

#: The classical fourth-order Runge-Kutta method: nodes ``c``, matrix ``A`` (lower triangle), weights ``b``.
RK4_TABLEAU = ((0.0, 0.5, 0.5, 1.0),
               ((), (0.5,), (0.0, 0.5), (0.0, 0.0, 1.0)),
               (1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0))


def rk_step(rhs, y, h, tableau=RK4_TABLEAU):
    """One explicit Runge-Kutta step of ``dy/dt = rhs(c, y)`` (``c`` the stage's node, a fraction of ``h``).

    ``y`` is an array of any shape (states along the first axis, independent systems along the others); ``h`` a
    scalar or an array broadcast against ``y[0]``.
    """
    c, A, b = tableau
    ks = []
    for ci, row in zip(c, A):
        yi = y + h * sum((a * k for a, k in zip(row, ks)), np.zeros_like(y))
        ks.append(np.asarray(rhs(ci, yi), dtype=float))
    return y + h * sum(bi * k for bi, k in zip(b, ks))


def _levels(p):
    """(Fc, Fs, sigma) for positive and for negative velocities."""
    if hasattr(p, "Fc_pos"):
        return (p.Fc_pos, p.Fs_pos, p.sigma_pos), (p.Fc_neg, p.Fs_neg, p.sigma_neg)
    return ((p.Fc, p.Fs, p.sigma),) * 2


def friction(p, w, sgn=0.0):
    """The static map of plant ``p`` at ``w`` (N·m), any shape: eq. 3 (per direction for the asymmetric model),
    0 at ``w = 0``; inside a Karnopp band ``|w| < dv`` the breakaway torque ``Fs*sgn``."""
    w = np.asarray(w, dtype=float)
    (cp, sp_, vp), (cn, sn_, vn) = _levels(p)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        shape = np.exp(-((np.abs(w) / p.Vs) ** p.delta))  # |w/Vs|**delta beyond the float range: shape 0
        out = np.where(w > 0.0, cp + (sp_ - cp) * shape + vp * w,
                       np.where(w < 0.0, -(cn + (sn_ - cn) * shape) + vn * w, 0.0))
    dv = getattr(p, "dv", 0.0)
    if dv > 0.0:
        out = np.where(np.abs(w) < dv, p.Fs * np.asarray(sgn, dtype=float), out)
    return out


def lugre_friction_torque(p, w, z):
    """LuGre friction torque ``sigma0*z + sigma1*dz/dt + sigma2*w`` (N·m), any shape."""
    w, z = np.asarray(w, dtype=float), np.asarray(z, dtype=float)
    return p.sigma0 * z + p.sigma1 * _lugre_zdot(p, w, z) + p.sigma2 * w


def _lugre_zdot(p, w, z):
    """``dz/dt = w - sigma0*|w|/g(w)*z`` with ``g(w) = Fc + (Fs - Fc)*exp(-|w/Vs|**delta)``."""
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        g = p.Fc + (p.Fs - p.Fc) * np.exp(-((np.abs(w) / p.Vs) ** p.delta))
        return w - np.where(w == 0.0, 0.0, p.sigma0 * np.abs(w) / g * z)


def _lugre_step(p, w, z, u, dt):
    """LuGre: ``n`` equal RK4 sub-steps per element, ``n = int(rate*dt) + 1`` from the stiffness bound at the
    step start (the rule of :meth:`plant.lugre.LuGreParams.make_step`)."""
    aw = np.abs(w)
    g_min, g_max = min(p.Fc, p.Fs), max(p.Fc, p.Fs)
    base = (p.sigma1 + p.sigma2) / p.J + math.sqrt(p.sigma0 / p.J)  # damping and pre-sliding frequency
    rate = p.sigma0 * (aw + (np.abs(u) + g_max + p.sigma2 * aw) * dt / p.J) / g_min + base
    n = np.floor(rate * dt).astype(np.int64) + 1
    h = dt / n

    def rhs(c, y):
        zd = _lugre_zdot(p, y[0], y[1])
        return np.stack([(u - p.sigma0 * y[1] - p.sigma1 * zd - p.sigma2 * y[0]) / p.J, zd])

    y = np.stack([w, z])
    for i in range(int(n.max(initial=0))):
        y = np.where(i < n, rk_step(rhs, y, h), y)
    return y[0], y[1]


def rk4(p, w, s, u, dt, sgn=0.0):
    """One RK4 step of the lagged models' eqs. 1-2 (``J dw/dt = u - f``, ``tau df/dt + f = F(w)``; ``tau = 0``:
    ``f = F(w)`` algebraic and the returned state is ``F`` at the new velocity), arrays; no stick rules."""
    J, tau = p.J, p.tau
    if tau == 0.0:
        w1 = rk_step(lambda c, y: (u - friction(p, y, sgn)) / J, w, dt)
        return w1, friction(p, w1, sgn)
    y = rk_step(lambda c, y: np.stack([(u - y[1]) / J, (friction(p, y[0], sgn) - y[1]) / tau]), np.stack([w, s]), dt)
    return y[0], y[1]


def _band_hold(p, w, u, dt):
    """Karnopp band with ``|u| <= Fs``: the joint under a friction of magnitude at most ``Fs`` (Karnopp 1985).

    While it moves the friction is ``Fs*sgn(w)``, a constant deceleration ``(Fs - u*sgn(w))/J >= 0`` of the speed;
    the speed after ``dt`` is ``|w|`` less that times ``dt``, clipped at 0 where the joint comes to rest within the
    step (then it stays: the friction balances ``u``). Arrays ``(w, f)`` after the step."""
    sg = np.sign(w)
    speed = np.abs(w) - dt * (p.Fs - u * sg) / p.J
    rest = speed <= 0.0
    return np.where(rest, 0.0, sg * speed), np.where(rest, u, p.Fs * sg)


def step(p, w, s, u, dt):
    """One period ``dt`` (s) of plant ``p`` with the torques ``u`` held, for arrays of states ``(w, s)``.

    Returns
    -------
    (ndarray, ndarray)
        Velocity and state (friction torque, LuGre deflection) one period later.

    Notes
    -----
    Karnopp: inside the band ``|w| < dv`` while ``|u| <= Fs`` the friction is at most ``Fs``: a moving joint
    decelerates under ``Fs*sgn(w)`` and rests with ``f = u`` once stopped (:func:`_band_hold`), else it
    breaks away towards ``sgn(u)`` (the band's target ``Fs*sgn(u)``; a step started outside the band has the
    target 0 inside it). Lagged models with ``tau = 0``: steps that can reach the jump at ``w = 0`` are the
    package's set-valued step (module docstring).
    """
    w, s, u = (np.array(np.broadcast_arrays(w, s, u)[i], dtype=float) for i in range(3))
    if p.MODEL == "lugre":
        return _lugre_step(p, w, s, u, dt)
    dv = getattr(p, "dv", 0.0)
    band = np.abs(w) < dv
    sgn = np.where(band, np.sign(u), 0.0)
    w1, s1 = (np.array(a, dtype=float) for a in rk4(p, w, s, u, dt, sgn))  # arrays the static step writes into
    if dv > 0.0:
        hold = band & (np.abs(u) <= p.Fs)
        wh, sh = _band_hold(p, w, u, dt)
        w1, s1 = np.where(hold, wh, w1), np.where(hold, sh, s1)
    if p.tau == 0.0 and dv == 0.0:
        par = plant_params(p)
        for i in np.flatnonzero([static_jump_in_reach(par, a, b, dt) for a, b in zip(w.ravel(), u.ravel())]):
            st = ffi.new("plant_state *", (w.flat[i], s.flat[i], math.nan))
            lagged_stiff_step(par, st, u.flat[i], dt, 0.0)
            w1.flat[i], s1.flat[i] = st.w, st.s
    return w1, s1


def make_step(p, dt):
    """``(w, s, u) -> (w, s)`` on floats: :func:`step` for one state."""

    def one(w, s, u):
        a, b = step(p, w, s, u, dt)
        return float(a), float(b)

    return one


def simulate_foh(tg, ug, idx, p, *, offset=0.0, w0, f0, gain=(0.0, 0.0), w_meas=None):
    """The identification simulator: eqs. 1-3 (lagged, ``tau > 0``) with the input linear between the grid points
    ``tg`` (values ``ug``), RK4 per grid interval, the velocity at the samples ``tg[idx]``; with ``gain = (Kw,
    Kf)`` the sampled error ``e = w_meas - w`` is injected after each sample (``w += Kw*e``,
    ``f -= Kf*J/Ts*e``, ``Ts`` the sample interval). ``offset`` is a constant torque added to the map. NaN from
    the first non-finite state on."""
    out = np.full(len(idx), np.nan)
    y = np.array([w0, f0], dtype=float)
    out[0] = w0
    J, tau = p.J, p.tau
    for s in range(1, len(idx)):
        for j in range(idx[s - 1], idx[s]):
            h, u0, u1 = tg[j + 1] - tg[j], ug[j], ug[j + 1]
            y = rk_step(lambda c, y: np.array([(u0 + c * (u1 - u0) - y[1]) / J,
                                                (friction(p, y[0]) + offset - y[1]) / tau]), y, h)
        if not np.all(np.isfinite(y)):
            return out
        out[s] = y[0]
        if gain != (0.0, 0.0):
            e = w_meas[s] - y[0]
            y = y + np.array([gain[0] * e, -gain[1] * J / (tg[idx[s]] - tg[idx[s - 1]]) * e])
    return out
