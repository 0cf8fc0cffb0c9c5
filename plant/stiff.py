"""Implicit, error-controlled steps of stiff plants: the lagged models (eqs. 1-3) and LuGre.

:func:`plant.dynamics.plant_step` hands a step to :func:`lagged_stiff_step` where the lagged model's own velocity
range (:func:`lagged_local_rate`) would need more than :data:`LAGGED_RK4_MAX` RK4 sub-steps, and to
:func:`lugre_stiff_step` where a LuGre bristle would need more than :data:`LUGRE_RK4_MAX`. Both are extrapolated
backward Euler with step doubling (Hairer & Wanner, *Solving ODEs I*, Sec. II.4; *Solving ODEs II*, Sec. IV.2).
Parameter row and state: :mod:`plant.rows`.
"""

from __future__ import annotations

import math

import numpy as np

from plant.errors import ParameterError
from plant.jit import kernel
from plant.rows import MODEL_CODES, plant_target, steepest_rise
from plant.stribeck_map import stribeck_slope_scalar

__all__ = ["LAGGED_RK4_MAX", "LAGGED_RTOL", "LAGGED_FTOL", "LAGGED_MAX_SUBSTEPS", "lagged_local_rate",
           "lagged_level_max", "static_jump_in_reach",
           "lagged_oscillation", "check_oscillation",
           "lagged_implicit_step", "lagged_stiff_step", "LUGRE_RK4_MAX", "LUGRE_RTOL", "LUGRE_ZTOL",
           "LUGRE_MAX_SUBSTEPS", "lugre_jacobian", "lugre_implicit_step", "lugre_stiff_step"]


#: Lagged-model steps whose RK4 sub-step count (``int(rate*dt) + 1``, :func:`~plant.rows.lagged_rate`) would
#: exceed this use :func:`lagged_stiff_step`; at or below it the RK4 sub-steps (and their results, bit for bit)
#: are kept.
LAGGED_RK4_MAX = 64
#: Relative tolerance (to ``|w| + Vs``) of the sub-step error control of :func:`lagged_stiff_step` on the velocity.
LAGGED_RTOL = 1e-5
#: Tolerance of the same error control on the friction state (``tau > 0``), relative to the largest friction level.
LAGGED_FTOL = 1e-4
#: Most sub-steps :func:`lagged_stiff_step` takes in one step before it gives up (NaN state: diverged).
LAGGED_MAX_SUBSTEPS = 200000


@kernel
def lagged_local_rate(par, w, f, u, dt):
    """Fastest stable mode (1/s) of a lagged model over the velocities it can reach within ``dt`` from ``(w, f)``.

    Parameters
    ----------
    par : ndarray, shape (PLANT_NPAR,)
        Parameter row of a lagged model.
    w, f : float
        Velocity (rad/s) and friction state (N·m) at the step start.
    u : float
        Torque (N·m), held.
    dt : float
        Step (s).

    Returns
    -------
    float
        :func:`~plant.rows.lagged_rate` with the steepest rise of the map taken over ``|w| +- D`` only,
        ``D = 2*dt*(|u| + max(|f|, Fmax + sigma*|w|))/J`` (twice the largest speed change: the joint cannot leave
        this range within the step); ``inf`` when the range reaches a jump of the map (``w = 0``, the Karnopp band
        ``|w| <= dv``) or the state is not finite.

    Notes
    -----
    The rise of eq. 3, ``-dF*delta*x**(delta-1)*exp(-x**delta)/Vs`` at ``x = |w|/Vs`` where ``dF*delta < 0``, is
    largest at ``x**delta = 1 - 1/delta`` (:func:`~plant.rows.lagged_rate`); over an interval it is largest at
    that point clipped into the interval (one maximum; for ``0 < delta < 1`` it falls with ``x``).
    """
    J = par[1]
    tau = par[4]
    aw = w if w >= 0.0 else -w
    pos = w > 0.0
    dF = par[6] if pos else par[10]
    sig = par[7] if pos else par[11]
    Fmax = max(max(par[5], par[5] + par[6]), max(par[9], par[9] + par[10]), par[13])
    D = 2.0 * dt * (abs(u) + max(abs(f), Fmax + max(par[7], par[11]) * aw)) / J
    lo = aw - D
    if not lo > par[14]:  # reaches the jump at 0 or the Karnopp band (or a NaN state)
        return math.inf
    delta = par[3]
    Vs = par[2]
    rise = 0.0
    if dF * delta < 0.0:
        x = 0.0
        if delta >= 1.0 or delta < 0.0:
            x = (1.0 - 1.0 / delta) ** (1.0 / delta)
        xl = lo / Vs
        xh = (aw + D) / Vs
        x = xl if x < xl else (xh if x > xh else x)
        rise = stribeck_slope_scalar(x, dF, Vs, delta)
    s = (sig if sig > 0.0 else 0.0) + rise
    if tau > 0.0:
        return max(1.0 / tau, math.sqrt(s / (J * tau)))
    return s / J


def lagged_oscillation(par) -> float:
    """Angular frequency (rad/s) of the lag-inertia oscillation of a lagged model where its static map rises most.

    Parameters
    ----------
    par : array_like, shape (PLANT_NPAR,)
        Parameter row of a lagged model (:func:`plant.rows.plant_params`).

    Returns
    -------
    float
        ``sqrt(s/(J*tau) - 1/(4*tau**2))`` where positive (the linearised joint oscillates), else 0 (over-damped,
        ``tau == 0``, a LuGre row); ``s`` the steepest rise of the map, ``sigma`` plus the Stribeck term where it
        rises (``dF*delta < 0``; :func:`plant.rows.steepest_rise`), the larger of the two directions.

    Notes
    -----
    Eqs. 1-2 linearised at a slope ``s`` of eq. 3: ``J dw/dt = u - f``, ``tau df/dt = s*w - f``, eigenvalues
    ``-1/(2 tau) +- i*sqrt(s/(J tau) - 1/(4 tau**2))``. Backward Euler damps such a mode at any step (L-stable),
    but the error control of :func:`lagged_stiff_step` must resolve it: where ``omega*dt`` is large and the mode
    under-damped (``tau >> 1/omega``), every step needs tens of sub-steps per radian of ``omega*dt``
    (Hairer & Wanner, *Solving ODEs II*, Sec. IV.2: stiff solvers pay for oscillatory modes).
    """
    par = [float(v) for v in par[:15]]
    J, Vs, delta, tau = par[1], par[2], par[3], par[4]
    if par[0] == MODEL_CODES["lugre"] or not (tau > 0.0 and J > 0.0):  # LuGre, or no lag
        return 0.0
    s = max(steepest_rise(par[6], Vs, delta, par[7]), steepest_rise(par[10], Vs, delta, par[11]))
    disc = s / (J * tau) - 0.25 / (tau * tau)
    return math.sqrt(disc) if disc > 0.0 else 0.0


def check_oscillation(par, dt: float) -> None:
    """Refuse a lagged model whose lag-inertia oscillation is too fast for the step ``dt`` to resolve cheaply.

    Parameters
    ----------
    par : array_like, shape (PLANT_NPAR,)
        Parameter row (:func:`plant.rows.plant_params`); LuGre rows and rows without a lag pass.
    dt : float
        Step (s) the plant is advanced by, > 0.

    Raises
    ------
    ParameterError
        ``lagged_oscillation(par)*dt > LAGGED_RK4_MAX``: an under-damped mode that :func:`plant.dynamics.plant_step`
        would hand to :func:`lagged_stiff_step`, whose error control then resolves the oscillation at every step
        (measured: ``J = 1e-6``, ``tau = 2 ms``, ``sigma = 28``, ``Fs < Fc``, ``omega*dt = 840``: about 20000
        sub-steps per 1 ms step, hours for a 15 s closed-loop run). The message gives the frequency and the
        parameters that set it.

    Notes
    -----
    :func:`lagged_oscillation` (eqs. 1-3 linearised). Not part of :func:`plant.rows.check_integrable`: the rise of
    a map with ``delta < 0`` is steep only near standstill, where such joints run well (tests/test_stiff_lagged.py,
    zoo joints); a fit that proposes candidate plants (``controllers.experiments.closed_loop_id``) uses it to keep
    its candidates where the engine integrates them in bounded time.
    """
    om = lagged_oscillation(par)
    if om * dt > LAGGED_RK4_MAX:
        J, tau = float(par[1]), float(par[4])
        raise ParameterError(
            f"lagged plant: the lag-inertia oscillation {om:.3g} rad/s (J = {J:.3g} kg·m², tau = {tau:.3g} s, "
            f"under-damped) is more than LAGGED_RK4_MAX/dt = {LAGGED_RK4_MAX / dt:.3g} rad/s: resolving it would "
            "take tens of implicit sub-steps per radian at every step")


@kernel(inline="always")
def lagged_level_max(par):
    """Largest friction level (N·m) of a lagged row: ``max(Fc, Fs)`` over both directions and the Karnopp stick level.

    Parameters
    ----------
    par : ndarray, shape (PLANT_NPAR,)
        Parameter row of a lagged model (:func:`plant.rows.plant_params`).

    Returns
    -------
    float
        The bound of ``|F(w)| - sigma*|w|`` over all ``w`` (eq. 3: ``Fc + (Fs - Fc)*exp(...)`` lies between ``Fc``
        and ``Fs``).
    """
    return max(max(par[5], par[5] + par[6]), max(par[9], par[9] + par[10]), par[13])


@kernel(inline="always")
def static_jump_in_reach(par, w, u, dt):
    """True where a step of a static lagged row (``tau = 0``, no Karnopp band) may reach the jump of its map at 0.

    Parameters
    ----------
    par : ndarray, shape (PLANT_NPAR,)
        Parameter row of a lagged model with ``tau = 0`` and ``dv = 0``.
    w : float
        Velocity (rad/s) at the step start.
    u : float
        Torque (N·m), held over the step.
    dt : float
        Step (s), > 0.

    Returns
    -------
    bool
        ``not |w| > dt*a_max`` with ``a_max = (|u| + F_max + 2*sigma_max*|w|)/J`` (:func:`lagged_level_max`): a
        bound of ``|dw/dt|`` while ``|w|`` does not grow past twice its start. Where it is False no RK4 stage of the
        step can leave the side of 0 that ``w`` is on, so the map is smooth along the step; where it is True the
        step needs the set-valued solve of :func:`lagged_stiff_step` (stick or reversal, Filippov). True for a
        non-finite ``w`` or ``u``.
    """
    aw = abs(w)
    amax = (abs(u) + lagged_level_max(par) + 2.0 * max(par[7], par[11], 0.0) * aw) / par[1]
    return not aw > dt * amax


@kernel(inline="always")
def _be_residual(par, w, sgn, c, k, r, w0, d):
    """``d*(c*(w - w0) + k*F(w) - r)``: the backward-Euler residual of :func:`lagged_implicit_step`, oriented."""
    return d * (c * (w - w0) + k * plant_target(par, w, sgn) - r)


@kernel
def _be_root(par, sgn, c, k, r, w0, d, lo, plo, hi, phi):
    """A root of the oriented residual in the bracket ``(lo, hi)`` (``plo < 0 <= phi``): Illinois regula falsi,
    with a bisection after three iterations that did not halve the bracket (Dahlquist & Björck, *Numerical
    Methods*, Sec. 6.2). Returns ``hi`` once ``|hi - lo| <= 1e-13*(|lo| + |hi| + Vs)``."""
    tol = 1e-13 * (abs(lo) + abs(hi) + par[2])
    side = 0
    stall = 0
    for _ in range(300):
        width = abs(hi - lo)
        if not width > tol:
            break
        x = hi - phi * (hi - lo) / (phi - plo)
        if stall >= 3 or not (abs(x - lo) < width and abs(x - hi) < width):
            x = 0.5 * (lo + hi)
            stall = 0
        px = _be_residual(par, x, sgn, c, k, r, w0, d)
        if px >= 0.0:
            hi = x
            phi = px
            if side == 1:
                plo *= 0.5
            side = 1
            if px == 0.0:
                break
        else:
            lo = x
            plo = px
            if side == -1:
                phi *= 0.5
            side = -1
        stall = stall + 1 if abs(hi - lo) > 0.5 * width else 0
    return hi


@kernel
def lagged_implicit_step(par, w0, f0, u, h, sgn):
    """One backward-Euler step of a lagged model (lagged Stribeck, asymmetric, Karnopp) over ``h`` (s).

    Parameters
    ----------
    par : ndarray, shape (PLANT_NPAR,)
        Parameter row of a lagged model (:func:`~plant.rows.plant_params`).
    w0, f0 : float
        Velocity (rad/s) and friction state (N·m) at the start (``f0`` unused for ``tau == 0``).
    u : float
        Torque (N·m), held.
    h : float
        Step (s), > 0.
    sgn : float
        Karnopp breakaway direction (:func:`plant_target`).

    Returns
    -------
    (float, float, float)
        ``(w, f, Fstar)`` after ``h``: the velocity, the friction state (``tau == 0``: the friction) and the
        value ``Fstar`` of the static map the step used (at a jump of the map, the value inside the jump that
        balances the step: sticking).

    Notes
    -----
    ``J*(w - w0) = h*(u - f)`` and ``tau*(f - f0) = h*(F(w) - f)`` (eqs. 1-2; ``f = F(w)`` for ``tau == 0``)
    reduce to one scalar equation ``c*(w - w0) + k*F(w) = r`` with ``a = h/tau``, ``c = J*(1 + a)``, ``k = h*a``,
    ``r = h*((1 + a)*u - f0)`` (``tau == 0``: ``c = J``, ``k = h``, ``r = h*u``). It is solved in the direction
    ``d = sgn(r - k*F(w0))`` the joint accelerates in, between ``w0`` and a bound where the ``c`` term dominates
    ``F`` (at most the largest level plus ``sigma*|w0|``), walking across the jumps of ``F`` (at ``w = 0``, or at
    the Karnopp band edges ``±dv``): where the residual jumps across zero the map is set-valued there (Filippov;
    Karnopp 1985) and the step ends on the jump (the joint sticks at ``w = 0``, ``|u|`` inside the static band).
    A rising map (``delta < 0`` or a viscous slope) makes the residual increasing, so the root is unique; backward
    Euler is L-stable (Hairer & Wanner, *Solving ODEs II*, Sec. IV.3), so any slope is damped for every ``h``.
    """
    J = par[1]
    tau = par[4]
    dv = par[14]
    if tau > 0.0:
        a = h / tau
        c = J * (1.0 + a)
        k = h * a
        r = h * ((1.0 + a) * u - f0)
    else:
        a = 0.0
        c = J
        k = h
        r = h * u
    start = w0
    if (w0 == 0.0 and dv == 0.0) or (dv > 0.0 and (w0 == dv or w0 == -dv)):  # on a jump of the map
        Flo = plant_target(par, np.nextafter(w0, -math.inf), sgn)
        Fhi = plant_target(par, np.nextafter(w0, math.inf), sgn)
        if k * Flo <= r <= k * Fhi:  # F(w0) is the interval [Flo, Fhi] and holds the joint: it stays
            Fstar = r / k
            return w0, (f0 + a * Fstar) / (1.0 + a) if tau > 0.0 else Fstar, Fstar
        d = 1.0 if r > k * Fhi else -1.0
        start = np.nextafter(w0, d * math.inf)
    else:
        g = r - k * plant_target(par, w0, sgn)
        if g == 0.0 or not g == g:
            Fstar = plant_target(par, w0, sgn) if g == g else math.nan
            return w0 if g == g else math.nan, (f0 + a * Fstar) / (1.0 + a) if tau > 0.0 else Fstar, Fstar
        d = 1.0 if g > 0.0 else -1.0
    Fbar = lagged_level_max(par) + max(par[7], par[11]) * abs(w0)
    hi = w0 + d * (abs(r) + k * Fbar) / c
    hi = hi + d * 1e-15 * (abs(hi) + par[2])  # strictly past the bound
    plo = _be_residual(par, start, sgn, c, k, r, w0, d)
    phi = _be_residual(par, hi, sgn, c, k, r, w0, d)
    for i in range(2):  # the jumps of the map ahead of the start, in the direction of motion
        p = (0.0 if i == 0 else math.nan) if dv == 0.0 else (-d * dv if i == 0 else d * dv)
        if not (d * (p - start) > 0.0 and d * (hi - p) > 0.0):
            continue
        before = np.nextafter(p, -d * math.inf)
        pb = _be_residual(par, before, sgn, c, k, r, w0, d)
        if pb >= 0.0:
            hi = before
            phi = pb
            break
        after = np.nextafter(p, d * math.inf)
        pa = _be_residual(par, after, sgn, c, k, r, w0, d)
        if pa >= 0.0:  # the residual jumps across zero: the step ends on the jump
            Fstar = (r - c * (p - w0)) / k
            return p, (f0 + a * Fstar) / (1.0 + a) if tau > 0.0 else Fstar, Fstar
        start = after
        plo = pa
    if phi <= 0.0:
        w = hi
    elif plo >= 0.0:
        w = start
    else:
        w = _be_root(par, sgn, c, k, r, w0, d, start, plo, hi, phi)
    Fstar = (r - c * (w - w0)) / k
    return w, (f0 + a * Fstar) / (1.0 + a) if tau > 0.0 else Fstar, Fstar


@kernel(inline="always")
def _region(par, w):
    """Which smooth piece of the lagged map ``w`` lies on: -2/2 below/above the jump(s), 0 inside the Karnopp band,
    odd on a jump point (``w = 0``, or ``w = -dv``/``dv``)."""
    dv = par[14]
    if dv == 0.0:
        return -2 if w < 0.0 else (2 if w > 0.0 else 1)
    if w < -dv:
        return -2
    if w > dv:
        return 2
    return -1 if w == -dv else (1 if w == dv else 0)


@kernel(inline="always")
def _next_substep(hh, err):
    """Next sub-step after one of length ``hh`` with scaled error ``err`` (accepted where ``err <= 1``).

    The step-doubling controller of both stiff steps: ``hh*0.9/sqrt(err)`` (the error of backward Euler's step
    difference is O(h**2)), the factor kept in [0.2, 2] (Hairer, Norsett & Wanner, *Solving ODEs I*, Sec. II.4).
    """
    fac = 0.9 / math.sqrt(err) if err > 0.0 else 2.0
    return hh * (2.0 if fac > 2.0 else (0.2 if fac < 0.2 else fac))


@kernel
def lagged_stiff_step(par, st, u, dt, sgn):
    """Advance a stiff lagged model by ``dt`` (s) with ``u`` (N·m) held: error-controlled implicit sub-steps.

    Parameters
    ----------
    par : ndarray, shape (PLANT_NPAR,)
        Parameter row of a lagged model (lagged Stribeck, asymmetric, Karnopp).
    st : ndarray, shape (PLANT_NSTATE,)
        ``[w, f, h]``: velocity (rad/s), friction state (N·m), the last sub-step (s; any value outside
        ``(0, dt]``: none yet, then ``dt``); updated in place. NaN state for a non-finite state or input or after
        :data:`LAGGED_MAX_SUBSTEPS` sub-steps (treated as diverged).
    u : float
        Torque (N·m).
    dt : float
        Step (s), > 0.
    sgn : float
        Karnopp breakaway direction (:func:`plant_target`), fixed over the step as in the RK4 path.

    Notes
    -----
    The scheme of :func:`lugre_stiff_step` on eqs. 1-3: a sub-step ``h`` of :func:`lagged_implicit_step` and two
    of ``h/2`` give the error estimate (step doubling, Hairer, Nørsett & Wanner, *Solving ODEs I*, Sec. II.4),
    accepted when ``|w_(h/2) - w_h| <= LAGGED_RTOL*(|w| + Vs)`` and (``tau > 0``)
    ``|f_(h/2) - f_h| <= LAGGED_FTOL*max level``. Where all three solutions stay on one smooth piece of the map
    (:func:`_region`) the result is the extrapolation ``2*y_(h/2) - y_h`` (second order, A-stable, *Solving ODEs
    II*, Sec. IV.9); across a jump of the map (a reversal, a stick) it is ``y_(h/2)`` itself, which the
    set-valued solve keeps on the jump. The next ``h`` scales with ``0.9/sqrt(err)``, clipped to [0.2, 2].
    """
    w = st[0]
    f = st[1]
    h = st[2]
    if not (h > 0.0 and h <= dt):
        h = dt
    tau = par[4]
    Vs = par[2]
    tol_f = LAGGED_FTOL * max(lagged_level_max(par), 1e-300)
    t = 0.0
    count = 0
    while t < dt:
        if count >= LAGGED_MAX_SUBSTEPS or not (w - w == 0.0 and f - f == 0.0 and u - u == 0.0):
            st[0] = math.nan
            st[1] = math.nan
            st[2] = math.nan
            return
        count += 1
        last = h >= dt - t
        hh = dt - t if last else h
        w1, f1, F1 = lagged_implicit_step(par, w, f, u, hh, sgn)
        wm, fm, Fm = lagged_implicit_step(par, w, f, u, 0.5 * hh, sgn)
        w2, f2, F2 = lagged_implicit_step(par, wm, fm, u, 0.5 * hh, sgn)
        err = abs(w2 - w1) / (LAGGED_RTOL * (abs(w2) + Vs))
        if tau > 0.0:
            ef = abs(f2 - f1) / tol_f
            err = err if err > ef else ef
        if not err == err:
            err = math.inf
        if err <= 1.0:
            t = dt if last else t + hh
            reg = _region(par, w2)
            we = 2.0 * w2 - w1
            smooth = reg % 2 == 0 and _region(par, w) == reg and _region(par, w1) == reg and _region(par, wm) == reg
            if smooth and _region(par, we) == reg:
                w = we
                f = 2.0 * f2 - f1 if tau > 0.0 else plant_target(par, we, sgn)
            else:
                w = w2
                f = f2
        h = _next_substep(hh, err)
    st[0] = w
    st[1] = f
    st[2] = h


#: LuGre steps whose RK4 sub-step count (stiffness bound of :func:`~plant.dynamics.plant_step`) exceeds this use
#: :func:`lugre_stiff_step`; at or below it the RK4 sub-steps (and their results) are kept.
LUGRE_RK4_MAX = 64
#: Relative tolerance of the sub-step error control of :func:`lugre_stiff_step`.
LUGRE_RTOL = 1e-5
#: Tolerance of the same error control on the bristle deflection, relative to the largest one ``max(Fc, Fs)/sigma0``
#: (the deflection relaxes at the rate ``sigma0*|w|/g(w)``: its error does not accumulate while sliding).
LUGRE_ZTOL = 1e-3
#: Most sub-steps :func:`lugre_stiff_step` takes in one step before it gives up (NaN state: diverged).
LUGRE_MAX_SUBSTEPS = 200000


@kernel
def lugre_jacobian(par, w, z, u):
    """Right-hand side of the LuGre joint and its Jacobian at ``(w, z)`` with the torque ``u`` (N·m).

    Parameters
    ----------
    par : ndarray, shape (PLANT_NPAR,)
        LuGre parameter row (:func:`~plant.rows.plant_params`).
    w, z : float
        Velocity (rad/s), bristle deflection (rad).
    u : float
        Torque (N·m).

    Returns
    -------
    (float, float, float, float, float, float)
        ``dw/dt, dz/dt`` and the Jacobian entries ``d(dw/dt)/dw, d(dw/dt)/dz, d(dz/dt)/dw, d(dz/dt)/dz``.

    Notes
    -----
    Canudas de Wit et al. (1995) (module docstring): with ``a(w) = sigma0*|w|/g(w)``,
    ``a'(w) = sgn(w)*sigma0*(g - |w|*dg/d|w|)/g**2``, ``dg/d|w|`` the slope of eq. 3's Stribeck term
    (:func:`plant.stribeck_map.stribeck_slope_scalar`; ``g`` from :func:`plant_target`); ``a'(0) = 0`` (the kink of ``|w|``).
    """
    J = par[1]
    s0 = par[15]
    s1 = par[16]
    s2 = par[7]
    aw = w if w >= 0.0 else -w
    g = plant_target(par, w, 0.0)
    a = s0 * aw / g
    fz = w - a * z
    fw = (u - s0 * z - s1 * fz - s2 * w) / J
    da = 0.0
    if aw > 0.0:
        da = s0 * (g - aw * stribeck_slope_scalar(aw / par[2], par[6], par[2], par[3])) / (g * g)
        if w < 0.0:
            da = -da
    dzw = 1.0 - da * z
    return fw, fz, (-s1 * dzw - s2) / J, (-s0 + s1 * a) / J, dzw, -a


@kernel
def lugre_implicit_step(par, w0, z0, u, h):
    """One backward-Euler step of the LuGre joint over ``h`` (s), solved by Newton's method.

    Parameters
    ----------
    par : ndarray, shape (PLANT_NPAR,)
        LuGre parameter row.
    w0, z0 : float
        Velocity (rad/s) and deflection (rad) at the start.
    u : float
        Torque (N·m), held.
    h : float
        Step (s), > 0.

    Returns
    -------
    (float, float, bool)
        ``(w, z)`` after ``h`` and whether Newton's iteration converged (at most 30 iterations, to ``1e-12``
        relative to ``|w| + Vs`` and to ``max(Fc, Fs)/sigma0``).

    Notes
    -----
    ``y1 = y0 + h f(y1)`` (Hairer & Wanner, *Solving ODEs II*, Sec. IV.3: L-stable, so the stiff bristle modes
    are damped for every ``h``), Jacobian of :func:`lugre_jacobian`.
    """
    w = w0
    z = z0
    zs = par[18] / par[15]
    for _ in range(30):
        fw, fz, jww, jwz, jzw, jzz = lugre_jacobian(par, w, z, u)
        g1 = w - w0 - h * fw
        g2 = z - z0 - h * fz
        m11 = 1.0 - h * jww
        m12 = -h * jwz
        m21 = -h * jzw
        m22 = 1.0 - h * jzz
        det = m11 * m22 - m12 * m21
        dw = (g1 * m22 - m12 * g2) / det
        dz = (m11 * g2 - m21 * g1) / det
        w -= dw
        z -= dz
        if abs(dw) <= 1e-12 * (abs(w) + par[2]) and abs(dz) <= 1e-12 * zs:
            return w, z, True
    return w, z, False


@kernel
def lugre_stiff_step(par, st, u, dt):
    """Advance a stiff LuGre joint by ``dt`` (s) with ``u`` (N·m) held: error-controlled implicit sub-steps.

    Parameters
    ----------
    par : ndarray, shape (PLANT_NPAR,)
        LuGre parameter row.
    st : ndarray, shape (PLANT_NSTATE,)
        ``[w, z, h]``: velocity (rad/s), deflection (rad), the last sub-step (s; NaN: none yet, then ``dt``);
        updated in place. NaN state after :data:`LUGRE_MAX_SUBSTEPS` sub-steps (treated as diverged).
    u : float
        Torque (N·m).
    dt : float
        Step (s), > 0.

    Notes
    -----
    Extrapolated backward Euler (Hairer & Wanner, *Solving ODEs II*, Sec. IV.9): a sub-step ``h`` of
    :func:`lugre_implicit_step` and two of ``h/2`` give ``y = 2*y_(h/2) - y_h`` (second order; its stability
    function ``2/(1 - z/2)**2 - 1/(1 - z)`` is A-stable and vanishes at infinity); accepted when
    ``|w_(h/2) - w_h| <= rtol*(|w| + Vs)`` and ``|z_(h/2) - z_h| <= ztol*max(Fc, Fs)/sigma0``
    (:data:`LUGRE_RTOL`, :data:`LUGRE_ZTOL`; step doubling, *Solving ODEs I*, Sec. II.4); the next ``h``
    scales with ``0.9/sqrt(err)``, clipped to [0.2, 2]. No sub-step crosses the end of ``dt``.
    """
    w = st[0]
    z = st[1]
    h = st[2]
    if not (h > 0.0 and h <= dt):
        h = dt
    tol_z = LUGRE_ZTOL * par[18] / par[15]
    t = 0.0
    count = 0
    while t < dt:
        if count >= LUGRE_MAX_SUBSTEPS or not (w == w and z == z):
            st[0] = math.nan
            st[1] = math.nan
            st[2] = math.nan
            return
        count += 1
        last = h >= dt - t
        hh = dt - t if last else h
        w1, z1, ok1 = lugre_implicit_step(par, w, z, u, hh)
        wm, zm, ok2 = lugre_implicit_step(par, w, z, u, 0.5 * hh)
        w2, z2, ok3 = lugre_implicit_step(par, wm, zm, u, 0.5 * hh)
        err = math.inf
        if ok1 and ok2 and ok3:
            ew = abs(w2 - w1) / (LUGRE_RTOL * (abs(w2) + par[2]))
            ez = abs(z2 - z1) / tol_z
            err = ew if ew > ez else ez
        if err <= 1.0:
            t = dt if last else t + hh
            w = 2.0 * w2 - w1
            z = 2.0 * z2 - z1
        h = _next_substep(hh, err)
    st[0] = w
    st[1] = z
    st[2] = h
