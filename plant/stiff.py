"""Implicit, error-controlled steps of stiff plants: the lagged models (eqs. 1-3) and LuGre.

:func:`plant.dynamics.plant_step` hands a step to :func:`lagged_stiff_step` where the lagged model's own velocity
range (:func:`lagged_local_rate`) would need more than :data:`LAGGED_RK4_MAX` RK4 sub-steps, and to
:func:`lugre_stiff_step` where a LuGre bristle would need more than :data:`LUGRE_RK4_MAX`. Both are extrapolated
backward Euler with step doubling (Hairer & Wanner, *Solving ODEs I*, Sec. II.4; *Solving ODEs II*, Sec. IV.2).
Parameters and state (C structs ``plant_params``, ``plant_state``): :mod:`plant.rows`. The steps are C
(``plant/csrc/plant_stiff.c``); the functions here are their Python entries.
"""

from __future__ import annotations

import math

from plant._cplant import ffi, lib
from plant.errors import ParameterError
from plant.rows import MODEL_CODES, steepest_rise

__all__ = ["LAGGED_RK4_MAX", "LAGGED_RTOL", "LAGGED_FTOL", "LAGGED_MAX_SUBSTEPS", "lagged_local_rate",
           "lagged_level_max", "static_jump_in_reach",
           "lagged_oscillation", "check_oscillation",
           "lagged_implicit_step", "lagged_stiff_step", "LUGRE_RK4_MAX", "LUGRE_RTOL", "LUGRE_ZTOL",
           "LUGRE_MAX_SUBSTEPS", "lugre_jacobian", "lugre_implicit_step", "lugre_stiff_step"]


#: Lagged-model steps whose RK4 sub-step count (``int(rate*dt) + 1``, :func:`~plant.rows.lagged_rate`) would
#: exceed this use :func:`lagged_stiff_step`; at or below it the RK4 sub-steps (and their results, bit for bit)
#: are kept.
LAGGED_RK4_MAX = int(lib.PLANT_LAGGED_RK4_MAX)  # 64, C plant_stiff.h (as the next ones)
#: Relative tolerance (to ``|w| + Vs``) of the sub-step error control of :func:`lagged_stiff_step` on the velocity.
LAGGED_RTOL = lib.plant_lagged_rtol  # 1e-5
#: Tolerance of the same error control on the friction state (``tau > 0``), relative to the largest friction level.
LAGGED_FTOL = lib.plant_lagged_ftol  # 1e-4
#: Most sub-steps :func:`lagged_stiff_step` takes in one step before it gives up (NaN state: diverged).
LAGGED_MAX_SUBSTEPS = int(lib.PLANT_LAGGED_MAX_SUBSTEPS)  # 200000


def lagged_local_rate(par, w: float, f: float, u: float, dt: float) -> float:
    """Fastest stable mode (1/s) of a lagged model over the velocities it can reach within ``dt`` from ``(w, f)``.

    Parameters
    ----------
    par : cffi ``plant_params *``
        Parameters of a lagged model.
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
    that point clipped into the interval (one maximum; for ``0 < delta < 1`` it falls with ``x``). C
    (``plant/csrc/plant_stiff.c``, ``plant_lagged_local_rate``).
    """
    return lib.plant_lagged_local_rate(par, w, f, u, dt)


def lagged_oscillation(par) -> float:
    """Angular frequency (rad/s) of the lag-inertia oscillation of a lagged model where its static map rises most.

    Parameters
    ----------
    par : cffi ``plant_params *`` (or ``plant_params``)
        Parameters of a lagged model (:func:`plant.rows.plant_params`).

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
    J, Vs, delta, tau = par.J, par.pos.Vs, par.pos.delta, par.tau
    if par.model == MODEL_CODES["lugre"] or not (tau > 0.0 and J > 0.0):  # LuGre, or no lag
        return 0.0
    s = max(steepest_rise(par.pos.dF, Vs, delta, par.pos.sigma), steepest_rise(par.neg.dF, Vs, delta, par.neg.sigma))
    disc = s / (J * tau) - 0.25 / (tau * tau)
    return math.sqrt(disc) if disc > 0.0 else 0.0


def check_oscillation(par, dt: float) -> None:
    """Refuse a lagged model whose lag-inertia oscillation is too fast for the step ``dt`` to resolve cheaply.

    Parameters
    ----------
    par : cffi ``plant_params *`` (or ``plant_params``)
        Parameters (:func:`plant.rows.plant_params`); LuGre plants and plants without a lag pass.
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
    a map with ``delta < 0`` is steep only near standstill, where such joints run well (tests/plant_layer/test_stiff_lagged.py);
    a fit that proposes candidate plants (``controllers.experiments.closed_loop_id``) uses it to keep
    its candidates where the engine integrates them in bounded time.
    """
    om = lagged_oscillation(par)
    if om * dt > LAGGED_RK4_MAX:
        J, tau = par.J, par.tau
        raise ParameterError(
            f"lagged plant: the lag-inertia oscillation {om:.3g} rad/s (J = {J:.3g} kg·m², tau = {tau:.3g} s, "
            f"under-damped) is more than LAGGED_RK4_MAX/dt = {LAGGED_RK4_MAX / dt:.3g} rad/s: resolving it would "
            "take tens of implicit sub-steps per radian at every step")


def lagged_level_max(par) -> float:
    """Largest friction level (N·m) of a lagged row: ``max(Fc, Fs)`` over both directions and the Karnopp stick level.

    Parameters
    ----------
    par : cffi ``plant_params *``
        Parameters of a lagged model (:func:`plant.rows.plant_params`).

    Returns
    -------
    float
        The bound of ``|F(w)| - sigma*|w|`` over all ``w`` (eq. 3: ``Fc + (Fs - Fc)*exp(...)`` lies between ``Fc``
        and ``Fs``). C (``plant/csrc/plant_stiff.c``, ``plant_lagged_level_max``).
    """
    return lib.plant_lagged_level_max(par)


def static_jump_in_reach(par, w: float, u: float, dt: float) -> bool:
    """True where a step of a static lagged row (``tau = 0``, no Karnopp band) may reach the jump of its map at 0.

    Parameters
    ----------
    par : cffi ``plant_params *``
        Parameters of a lagged model with ``tau = 0`` and ``dv = 0``.
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
        non-finite ``w`` or ``u``. C (``plant/csrc/plant_stiff.c``, ``plant_static_jump_in_reach``).
    """
    return bool(lib.plant_static_jump_in_reach(par, w, u, dt))


def lagged_implicit_step(par, w0: float, f0: float, u: float, h: float, sgn: float, q0: float = 0.0) -> tuple:
    """One backward-Euler step of a lagged model (lagged Stribeck, asymmetric, Karnopp) over ``h`` (s).

    Parameters
    ----------
    par : cffi ``plant_params *``
        Parameters of a lagged model (:func:`~plant.rows.plant_params`).
    w0, f0 : float
        Velocity (rad/s) and friction state (N·m) at the start (``f0`` unused for ``tau == 0``).
    u : float
        Torque (N·m), held.
    h : float
        Step (s), > 0.
    sgn : float
        Karnopp breakaway direction (:func:`plant.rows.plant_target`).
    q0 : float
        Joint position (rad) at the start: with a friction ripple the map is evaluated at the end position
        ``q0 + h*w`` (backward Euler on ``dq/dt = w``).

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
    The root is an Illinois regula falsi with a bisection after three iterations that did not halve the bracket
    (Dahlquist & Björck, *Numerical Methods*, Sec. 6.2), to ``1e-13*(|lo| + |hi| + Vs)``. C
    (``plant/csrc/plant_stiff.c``, ``plant_lagged_implicit_step``).
    """
    out = ffi.new("double[3]")
    lib.plant_lagged_implicit_step(par, w0, f0, q0, u, h, sgn, out, out + 1, out + 2)
    return out[0], out[1], out[2]


def lagged_stiff_step(par, st, u: float, dt: float, sgn: float) -> None:
    """Advance a stiff lagged model by ``dt`` (s) with ``u`` (N·m) held: error-controlled implicit sub-steps.

    Parameters
    ----------
    par : cffi ``plant_params *``
        Parameters of a lagged model (lagged Stribeck, asymmetric, Karnopp).
    st : cffi ``plant_state *``
        ``{w, s, aux}``: velocity (rad/s), friction state (N·m), the last sub-step (s; any value outside
        ``(0, dt]``: none yet, then ``dt``); updated in place. NaN state for a non-finite state or input or after
        :data:`LAGGED_MAX_SUBSTEPS` sub-steps (treated as diverged).
    u : float
        Torque (N·m).
    dt : float
        Step (s), > 0.
    sgn : float
        Karnopp breakaway direction (:func:`plant.rows.plant_target`), fixed over the step as in the RK4 path.

    Notes
    -----
    The scheme of :func:`lugre_stiff_step` on eqs. 1-3: a sub-step ``h`` of :func:`lagged_implicit_step` and two
    of ``h/2`` give the error estimate (step doubling, Hairer, Nørsett & Wanner, *Solving ODEs I*, Sec. II.4),
    accepted when ``|w_(h/2) - w_h| <= LAGGED_RTOL*(|w| + Vs)`` and (``tau > 0``)
    ``|f_(h/2) - f_h| <= LAGGED_FTOL*max level``. Where all three solutions stay on one smooth piece of the map
    (``region`` in ``plant/csrc/plant_stiff.c``) the result is the extrapolation ``2*y_(h/2) - y_h`` (second order, A-stable, *Solving ODEs
    II*, Sec. IV.9); across a jump of the map (a reversal, a stick) it is ``y_(h/2)`` itself, which the
    set-valued solve keeps on the jump. The next ``h`` scales with ``0.9/sqrt(err)``, clipped to [0.2, 2]. C
    (``plant/csrc/plant_stiff.c``, ``plant_lagged_stiff_step``).
    """
    lib.plant_lagged_stiff_step(par, st, u, dt, sgn)


#: LuGre steps whose RK4 sub-step count (stiffness bound of :func:`~plant.dynamics.plant_step`) exceeds this use
#: :func:`lugre_stiff_step`; at or below it the RK4 sub-steps (and their results) are kept.
LUGRE_RK4_MAX = int(lib.PLANT_LUGRE_RK4_MAX)  # 64
#: Relative tolerance of the sub-step error control of :func:`lugre_stiff_step`.
LUGRE_RTOL = lib.plant_lugre_rtol  # 1e-5
#: Tolerance of the same error control on the bristle deflection, relative to the largest one ``max(Fc, Fs)/sigma0``
#: (the deflection relaxes at the rate ``sigma0*|w|/g(w)``: its error does not accumulate while sliding).
LUGRE_ZTOL = lib.plant_lugre_ztol  # 1e-3
#: Most sub-steps :func:`lugre_stiff_step` takes in one step before it gives up (NaN state: diverged).
LUGRE_MAX_SUBSTEPS = int(lib.PLANT_LUGRE_MAX_SUBSTEPS)  # 200000


def lugre_jacobian(par, w: float, z: float, u: float, q: float = 0.0) -> tuple:
    """Right-hand side of the LuGre joint and its Jacobian at ``(w, z)`` with the torque ``u`` (N·m).

    Parameters
    ----------
    par : cffi ``plant_params *``
        LuGre parameters (:func:`~plant.rows.plant_params`).
    w, z : float
        Velocity (rad/s), bristle deflection (rad).
    u : float
        Torque (N·m).
    q : float
        Joint position (rad): with a friction ripple ``g`` and ``sigma2`` are times ``R(q)`` (the Jacobian in
        ``(w, z)`` at fixed ``q``).

    Returns
    -------
    (float, float, float, float, float, float)
        ``dw/dt, dz/dt`` and the Jacobian entries ``d(dw/dt)/dw, d(dw/dt)/dz, d(dz/dt)/dw, d(dz/dt)/dz``.

    Notes
    -----
    Canudas de Wit et al. (1995) (module docstring): with ``a(w) = sigma0*|w|/g(w)``,
    ``a'(w) = sgn(w)*sigma0*(g - |w|*dg/d|w|)/g**2``, ``dg/d|w|`` the slope of eq. 3's Stribeck term
    (:func:`plant.stribeck_map.stribeck_slope_scalar`; ``g`` from :func:`plant.rows.plant_target`); ``a'(0) = 0``
    (the kink of ``|w|``). C (``plant/csrc/plant_stiff.c``, ``plant_lugre_jacobian``).
    """
    out = ffi.new("double[6]")
    lib.plant_lugre_jacobian(par, w, z, q, u, out)
    return tuple(out)


def lugre_implicit_step(par, w0: float, z0: float, u: float, h: float, q0: float = 0.0) -> tuple:
    """One backward-Euler step of the LuGre joint over ``h`` (s), solved by Newton's method.

    Parameters
    ----------
    par : cffi ``plant_params *``
        LuGre parameters.
    w0, z0 : float
        Velocity (rad/s) and deflection (rad) at the start.
    u : float
        Torque (N·m), held.
    h : float
        Step (s), > 0.
    q0 : float
        Joint position (rad) at the start (a friction ripple's map at ``q0 + h*w``; the Newton matrix leaves that
        dependence out, a term of order ``h**2``).

    Returns
    -------
    (float, float, bool)
        ``(w, z)`` after ``h`` and whether Newton's iteration converged (at most 30 iterations, to ``1e-12``
        relative to ``|w| + Vs`` and to ``max(Fc, Fs)/sigma0``).

    Notes
    -----
    ``y1 = y0 + h f(y1)`` (Hairer & Wanner, *Solving ODEs II*, Sec. IV.3: L-stable, so the stiff bristle modes
    are damped for every ``h``), Jacobian of :func:`lugre_jacobian`. C (``plant/csrc/plant_stiff.c``,
    ``plant_lugre_implicit_step``).
    """
    out = ffi.new("double[2]")
    ok = lib.plant_lugre_implicit_step(par, w0, z0, q0, u, h, out, out + 1)
    return out[0], out[1], bool(ok)


def lugre_stiff_step(par, st, u: float, dt: float) -> None:
    """Advance a stiff LuGre joint by ``dt`` (s) with ``u`` (N·m) held: error-controlled implicit sub-steps.

    Parameters
    ----------
    par : cffi ``plant_params *``
        LuGre parameters.
    st : cffi ``plant_state *``
        ``{w, s, aux}``: velocity (rad/s), deflection ``z`` (rad), the last sub-step (s; NaN: none yet, then ``dt``);
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
    scales with ``0.9/sqrt(err)``, clipped to [0.2, 2]. No sub-step crosses the end of ``dt``. C
    (``plant/csrc/plant_stiff.c``, ``plant_lugre_stiff_step``).
    """
    lib.plant_lugre_stiff_step(par, st, u, dt)
