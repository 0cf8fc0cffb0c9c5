"""Test oracle: a tight-tolerance solution of the lagged plant models (eqs. 1-3, asymmetric, Karnopp) per step.

Independent of :mod:`plant.dynamics` (its own eq. 3 in plain Python, scipy's Radau IIA): used by
tests/plant_layer/test_stiff_lagged.py to check :func:`plant.dynamics.lagged_stiff_step` on stiff plants. Per step of ``dt``
the torque is held, as in the engine; the Karnopp stick rule is applied at the step start (the model's
definition, :class:`plant.karnopp.KarnoppParams`: in the band, with ``|u| <= Fs``, a friction of at most ``Fs``
that stops the joint, :func:`_band_hold`). The static map jumps (at ``w = 0``, or at the Karnopp band
edges ``±dv``); Radau integrates each smooth piece (its formula continued past the jump, so the error control
never sees the jump) up to an event at the jump, then:

- ``tau > 0``: the velocity is continuous and crosses the jump (``dw/dt = (u - f)/J`` does not jump);
- ``tau = 0``: the velocity crosses if the acceleration keeps its sign on the other side, else the joint stays on
  the jump with ``f = u`` for the rest of the step (Filippov's solution: the limit of every fixed-step
  solution as the step goes to 0).

Not part of the package.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

__all__ = ["Lagged", "lagged_reference"]


class Lagged:
    """The lagged map of a plant model, per piece: ``F(w, piece)`` with the piece's formula continued."""

    def __init__(self, p):
        self.J, self.Vs, self.delta, self.tau = p.J, p.Vs, p.delta, p.tau
        if hasattr(p, "Fc_pos"):
            self.pos = (p.Fc_pos, p.Fs_pos, p.sigma_pos)
            self.neg = (p.Fc_neg, p.Fs_neg, p.sigma_neg)
        else:
            self.pos = self.neg = (p.Fc, p.Fs, p.sigma)
        self.dv = getattr(p, "dv", 0.0)
        self.Fs_stick = p.Fs if self.dv > 0.0 else 0.0
        self.points = (-self.dv, self.dv) if self.dv > 0.0 else (0.0,)

    def shape(self, w: float) -> float:
        x = abs(float(w)) / self.Vs
        if x == 0.0:
            return 1.0 if self.delta > 0 else 0.0
        try:
            return math.exp(-(x ** self.delta))
        except OverflowError:
            return 0.0

    def piece(self, w: float, d: float) -> int:
        """The piece ``w`` is on, or (on a jump point) enters moving in direction ``d``."""
        for i, p in enumerate(self.points):
            if w < p or (w == p and d < 0):
                return i
        return len(self.points)

    def F(self, w: float, piece: int, sgn: float) -> float:
        """Eq. 3 of the piece (index of the interval between the jump points), continued to any ``w``."""
        if self.dv > 0.0 and piece == 1:
            return self.Fs_stick * sgn
        Fc, Fs, sigma = self.pos if piece == len(self.points) else self.neg
        s = 1.0 if piece == len(self.points) else -1.0
        return s * (Fc + (Fs - Fc) * self.shape(w)) + sigma * w


def _segment(m: Lagged, y, u, sgn, piece, t0, dt):
    """Integrate one piece from t0 until dt or the first jump point: (t, y, point index or None)."""
    pts = m.points
    tau = m.tau

    def rhs(t, y):
        w = y[0]
        if tau == 0.0:
            return [(u - m.F(w, piece, sgn)) / m.J]
        return [(u - y[1]) / m.J, (m.F(w, piece, sgn) - y[1]) / tau]

    events = []
    for p in pts:
        ev = (lambda t, y, p=p: y[0] - p)
        ev.terminal = True
        events.append(ev)
    sc = abs(y[0]) + m.Vs
    atol = [1e-13 * sc] + ([1e-12 * max(m.pos[1], m.pos[0], 1e-9)] if tau > 0 else [])
    r = solve_ivp(rhs, (t0, dt), y, method="Radau", rtol=1e-11, atol=atol, events=events, dense_output=False)
    for i, te in enumerate(r.t_events):
        if te.size:
            ye = r.y_events[i][0].copy()
            ye[0] = pts[i]
            return float(te[0]), ye, i
    return dt, r.y[:, -1].copy(), None


def _band_hold(m: Lagged, w: float, u: float, dt: float):
    """The Karnopp band with ``|u| <= Fs``: the friction opposes the motion with its static limit ``Fs`` until the
    joint rests, at ``t* = J*|w|/(Fs - u*sgn(w))``; from then on it balances ``u`` (Karnopp 1985, ``|f| <= Fs``).
    (w, f) after ``dt``."""
    if w == 0.0:
        return 0.0, u
    d = 1.0 if w > 0 else -1.0
    decel = (m.Fs_stick - u * d) / m.J  # >= 0
    if decel * dt >= abs(w):  # at rest by the step's end
        return 0.0, u
    return w - d * decel * dt, m.Fs_stick * d


def lagged_step(m: Lagged, w: float, f: float, u: float, dt: float):
    """One step of ``dt`` (s) with ``u`` held: (w, f) after it."""
    sgn = 0.0
    if m.dv > 0.0 and abs(w) < m.dv:
        if abs(u) <= m.Fs_stick:
            return _band_hold(m, w, u, dt)
        sgn = 1.0 if u > 0 else -1.0
    tau = m.tau
    y = np.array([w] if tau == 0.0 else [w, f], dtype=float)
    t = 0.0
    for _ in range(10000):
        if t >= dt:
            break
        if tau == 0.0:
            acc_dir = 1.0 if u - m.F(y[0], m.piece(y[0], 0.0), sgn) > 0 else -1.0
        else:
            acc_dir = 1.0 if u - y[1] > 0 else -1.0
        piece = m.piece(y[0], acc_dir)
        on = [i for i, p in enumerate(m.points) if y[0] == p]
        if on and tau == 0.0:  # on a jump: does the acceleration point into the piece on either side?
            p = m.points[on[0]]
            up, dn = m.piece(p, 1.0), m.piece(p, -1.0)
            if u - m.F(p, up, sgn) > 0:
                piece = up
            elif u - m.F(p, dn, sgn) < 0:
                piece = dn
            else:  # Filippov: stays on the jump
                return p, u
        if on:  # leave the point into the piece (so the event does not fire at the start)
            y[0] = np.nextafter(y[0], math.inf if piece == m.piece(y[0], 1.0) else -math.inf)
        t, y, hit = _segment(m, y, u, sgn, piece, t, dt)
    else:
        raise RuntimeError("oracle: too many jump crossings in one step")
    w = float(y[0])
    if tau == 0.0:
        if any(w == p for p in m.points):
            up, dn = m.piece(w, 1.0), m.piece(w, -1.0)
            Fup, Fdn = m.F(w, up, sgn), m.F(w, dn, sgn)
            return w, (u if min(Fup, Fdn) <= u <= max(Fup, Fdn) else Fup)
        return w, m.F(w, m.piece(w, 0.0), sgn)
    return w, float(y[1])


def lagged_reference(p, u: np.ndarray, dt: float, w0: float = 0.0) -> tuple:
    """Velocity and friction state after every step (initial state at rest or steady at ``w0``).

    Parameters
    ----------
    p : JointParams, AsymmetricParams or KarnoppParams
        The plant.
    u : ndarray, shape (N,)
        Torque (N·m), held over each step.
    dt : float
        Step (s).
    w0 : float
        Initial velocity (rad/s); the friction state starts at the steady value.

    Returns
    -------
    (ndarray, ndarray), shape (N + 1,) each
    """
    m = Lagged(p)
    w = float(w0)
    f = 0.0 if w == 0.0 else m.F(w, m.piece(w, 0.0), 0.0)
    W, S = [w], [f]
    for uk in np.asarray(u, dtype=float).tolist():
        w, f = lagged_step(m, w, f, uk, dt)
        W.append(w)
        S.append(f)
    return np.array(W), np.array(S)
