r"""Simulation of the joint model (eqs. 1-3) on measured, possibly irregular, sample times.

The prediction-error identification of :mod:`adaptive_ff.identification.physical_id`
(``method="output_error"``) compares the model with a sampled record
``(t(i), u(i), w(i))``. This module integrates the continuous-time model::

    J*dw/dt = u - f
    tau*df/dt + f = F(w) + offset          (F: eq. 3)

between the actual sample instants ``t(i-1) .. t(i)`` (whatever their spacing)
by classic fourth-order Runge-Kutta on sub-steps of at most ``h_max``, with the
input reconstructed from its samples by linear interpolation (first-order hold;
the drive applied a much faster, smooth input that was only logged at the
sample instants).

Two predictors (Ljung, *System Identification*, 2nd ed., Secs. 3.2, 5.7):

* **simulation** (``gain = (0, 0)``): the model runs free on the input; the
  output-error (simulation-error) predictor.
* **one-step-ahead with output injection** (``gain = (Kw, Kf)``): after each
  sample the prediction error ``e = w(i) - w_hat(i)`` corrects the state,
  ``w <- w + Kw*e``, ``f <- f - Kf*(J/h_i)*e`` (``h_i`` the interval). With
  ``(1, 1)`` the velocity is reset to the measurement and the friction state
  by the dead-beat estimate of its error (a friction error ``df`` over an
  interval ``h`` moves the velocity by about ``-df*h/J``); the prediction
  error is then a one-step-ahead error along a *simulated* intra-sample path.
  :func:`adaptive_ff.identification.physical_id.fit_physical` uses ``(1, 0)`` on noise-free
  data: velocity reset, friction state simulated (it is continuous and
  forgets its error within ``tau``).

The friction map ``sgn(w)`` is discontinuous; with ``tau > 0`` the lag integrates
it, so ``w`` stays continuously differentiable, and at standstill the RK4 steps
chatter around ``w = 0`` with an amplitude of order ``h**2*Fs/(J*tau)`` exactly as
the plant simulation (:func:`plant.joint.make_rk4_step`) does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline

from adaptive_ff._caff import ffi, lib
from plant.dynamics import lagged_params, stack_params
from plant.errors import ParameterError, SignalError, check_finite_scalar, check_positive, check_signal, check_time
from plant.friction import JointParams

__all__ = ["InputGrid", "input_grid", "stop_intervals", "simulate_on_grid", "simulate_on_grid_batch",
           "simulate_on_grid_sens", "simulate_sampled", "H_MAX_DEFAULT", "H_REFINE_DEFAULT", "SENS_NAMES", "BATCH_MAX"]

#: Parameters of the sensitivities of :func:`simulate_on_grid_sens`, in the order of its columns.
SENS_NAMES = ("J", "Fc", "Fs", "sigma", "tau", "offset", "Vs", "delta")

#: Most simulations of one C call of :func:`simulate_on_grid_batch` (``AFF_SIM_BATCH_MAX`` of ``aff_simulator.h``);
#: more are chunked.
BATCH_MAX = int(lib.aff_sim_batch_max)

#: Default largest RK4 sub-step (s): the paper's 1 kHz integration rate.
H_MAX_DEFAULT = 1e-3
#: Default largest RK4 sub-step (s) of the intervals :func:`input_grid` refines (``refine``): a tenth of
#: :data:`H_MAX_DEFAULT`.
H_REFINE_DEFAULT = 1e-4

_LONG = np.dtype(f"i{ffi.sizeof('long')}")  # C long of aff_simulate_on_grid's idx (8 bytes on LP64, 4 on Windows)


@dataclass(frozen=True)
class InputGrid:
    """Integration grid between the sample instants, with the interpolated input.

    Attributes
    ----------
    tg : ndarray, shape (M,)
        Grid times (s): every sample instant plus equal sub-steps in between.
    ug : ndarray, shape (M,)
        Input (N·m) at ``tg``, linear in between.
    idx : ndarray of int, shape (N,)
        ``tg[idx[i]] == t[i]``: position of sample ``i`` on the grid.
    """

    tg: np.ndarray
    ug: np.ndarray
    idx: np.ndarray


def input_grid(t, u, *, h_max: float = H_MAX_DEFAULT, input_delay: float = 0.0, interp: str = "linear",
               refine=None, h_refine: float = H_REFINE_DEFAULT) -> InputGrid:
    """Sub-divide the sample intervals and interpolate the input onto the sub-steps.

    Parameters
    ----------
    t : array_like, shape (N,)
        Sample times (s), strictly increasing, any spacing.
    u : array_like, shape (N,)
        Input samples (N·m).
    h_max : float, keyword-only
        Largest sub-step (s), > 0. Each interval ``t(i) - t(i-1)`` is split into
        ``ceil(interval/h_max)`` equal sub-steps.
    input_delay : float, keyword-only
        Time (s) by which each logged input sample precedes its time stamp: the
        input value ``u(i)`` is taken to act at ``t(i) - input_delay``. For
        :func:`plant.sampling.sample` (``u(i)`` is the zero-order-hold value over
        the last integration step ``dt`` before ``t(i)``) the centre of that
        step, ``dt/2``, is the unbiased choice. Default 0.
    interp : {"linear", "cubic"}, keyword-only
        Reconstruction of the input between samples: ``"linear"`` (first-order
        hold, default) or ``"cubic"`` (not-a-knot cubic spline through the
        samples, :class:`scipy.interpolate.CubicSpline`; smaller error for a
        smooth input).
    refine : array_like of bool, shape (N-1,), or None, keyword-only
        Intervals split into sub-steps of at most ``h_refine`` instead of
        ``h_max`` (True at interval ``i``, from ``t(i)`` to ``t(i+1)``), e.g.
        :func:`stop_intervals`; None (default): none.
    h_refine : float, keyword-only
        Largest sub-step (s) of the refined intervals, > 0; default
        :data:`H_REFINE_DEFAULT`.

    Returns
    -------
    InputGrid

    Raises
    ------
    SignalError
        ``t`` not strictly increasing or shapes differ; ``refine`` not one
        entry per interval.
    ParameterError
        ``h_max`` or ``h_refine`` not > 0; ``input_delay`` not finite; unknown
        ``interp``.

    Notes
    -----
    Linear interpolation between samples is the first-order hold (Franklin,
    Powell & Workman, *Digital Control of Dynamic Systems*, 3rd ed., Sec. 6.3);
    outside the sampled span the end values are held.
    """
    t = check_time("t", t)
    u = check_signal("u", u, n=t.shape[0])
    h_max = check_positive("h_max", h_max)
    input_delay = check_finite_scalar("input_delay", input_delay)
    if interp not in ("linear", "cubic"):
        raise ParameterError(f"interp must be 'linear' or 'cubic', got {interp!r}")
    dt = np.diff(t)
    n = np.maximum(np.ceil(dt / h_max - 1e-9).astype(np.int64), 1)
    if refine is not None:
        h_refine = check_positive("h_refine", h_refine)
        refine = np.asarray(refine)
        if refine.shape != dt.shape:
            raise SignalError(f"refine must have one entry per interval of t, shape {dt.shape}, got {refine.shape}")
        n = np.where(refine.astype(bool), np.maximum(n, np.ceil(dt / h_refine - 1e-9).astype(np.int64)), n)
    idx = np.concatenate([[0], np.cumsum(n)])
    seg = np.repeat(np.arange(dt.shape[0]), n)
    frac = (np.arange(idx[-1]) - idx[seg]) / n[seg]
    tg = np.concatenate([t[seg] + frac * dt[seg], t[-1:]])
    if interp == "cubic" and t.shape[0] >= 4:
        ts = t - input_delay
        ug = CubicSpline(ts, u)(np.clip(tg, ts[0], ts[-1]))
    else:
        ug = np.interp(tg, t - input_delay, u)
    return InputGrid(tg=np.ascontiguousarray(tg), ug=np.ascontiguousarray(ug), idx=idx.astype(np.int64))


def _grid_args(grid: InputGrid, offset: float, w0: float, f0: float, gain, w_meas, out: np.ndarray) -> tuple:
    """The arguments after ``par`` of the C grid simulations (``aff_simulate_on_grid`` and its ``_sens``), ``out``
    (shape (N,)) the velocity they write; SignalError where a non-zero gain comes without ``w_meas`` of shape
    (N,). Each ``ffi.from_buffer`` keeps its array alive while the returned tuple lives (the call)."""
    Kw, Kf = float(gain[0]), float(gain[1])
    inject = Kw != 0.0 or Kf != 0.0
    n = grid.idx.shape[0]
    if inject:
        wm = np.ascontiguousarray(w_meas, dtype=float)
        if wm.shape != (n,):
            raise SignalError(f"w_meas must have shape ({n},) with a non-zero gain, got {wm.shape}")
    else:
        wm = out  # not read
    tg = np.ascontiguousarray(grid.tg, dtype=float)
    ug = np.ascontiguousarray(grid.ug, dtype=float)
    idx = np.ascontiguousarray(grid.idx, dtype=_LONG)
    return (ffi.from_buffer("double[]", tg), ffi.from_buffer("double[]", ug), ffi.from_buffer("long[]", idx), n,
            float(offset), float(w0), float(f0), Kw, Kf, ffi.from_buffer("double[]", wm), int(inject),
            ffi.from_buffer("double[]", out))


def stop_intervals(w, band: float) -> np.ndarray:
    """The sample intervals in which a velocity record comes to rest or reverses: either end's ``|w|`` below
    ``band`` or the sign of ``w`` changing (``refine`` of :func:`input_grid`).

    Parameters
    ----------
    w : array_like, shape (N,)
        Velocity samples (rad/s), finite.
    band : float
        Half-width (rad/s) of the band around zero, >= 0; 0 marks only the reversals.

    Returns
    -------
    ndarray of bool, shape (N-1,)

    Raises
    ------
    SignalError
        ``w`` not a finite 1-D array of at least 2 samples.
    ParameterError
        ``band`` negative or not finite.

    Notes
    -----
    Why: with a lag (eq. 1) the friction, which jumps with ``sgn(w)`` (eq. 3), drives the joint through zero
    velocity at each stop in a damped ringing, a few milliseconds per period on a light joint. One RK4 step per
    millisecond does not resolve it and keeps it ringing; an output-error fit then reads the lag that mimics its own
    coarse step. Steps of a tenth of that inside the band where the joint stops reproduce a finely integrated joint
    (``docs/your_arm.md``, How, Lag).
    """
    w = check_signal("w", w, min_len=2)
    band = check_finite_scalar("band", band)
    if band < 0.0:
        raise ParameterError(f"band must be >= 0 (rad/s), got {band!r}")
    slow = np.abs(w) < band
    return slow[:-1] | slow[1:] | (np.sign(w[:-1]) != np.sign(w[1:]))


def simulate_on_grid(par: np.ndarray, grid: InputGrid, *, w0: float, f0: float, offset: float = 0.0,
                     gain=(0.0, 0.0), w_meas=None) -> np.ndarray:
    """Fast RK4 simulation of eqs. 1-3 on an :class:`InputGrid` (no validation: inner loop of the fits).

    C (``aff_simulator.c``, ``aff_simulate_on_grid``): the plant's one RK4 step (``plant_rk4`` of
    ``plant/csrc/plant_dynamics.c``) with the input at the start, middle and end of each sub-step. The
    offset enters as ``u - offset`` and ``f - offset``. Releases the GIL (threads may run fits in parallel).

    Parameters
    ----------
    par : cffi ``plant_params *``
        Parameters of the lagged Stribeck joint from
        :func:`plant.dynamics.lagged_params` ``(J, Fc, Fs, Vs, delta, sigma, tau)``
        (SI units); needs ``J > 0``, ``Vs > 0``, ``delta != 0``, ``tau > 0`` (for
        RK4 stability ``tau`` above about 0.4 times the sub-step; ``tau = 0``
        integrates the static map).
    grid : InputGrid
        From :func:`input_grid`.
    w0, f0 : float, keyword-only
        Initial velocity (rad/s) and friction state (N·m) at ``t[0]``.
    offset : float, keyword-only
        Constant torque bias (N·m) added to ``F``; integrated exactly as the
        plain model with input ``u - offset`` and friction state ``f - offset``.
    gain : (float, float), keyword-only
        Output-injection gains ``(Kw, Kf)`` (module docstring); ``(0, 0)`` = free simulation.
    w_meas : ndarray, shape (N,), keyword-only
        Measured velocity, needed when a gain is non-zero.

    Returns
    -------
    ndarray, shape (N,)
        Predicted velocity at the sample instants (before any correction);
        entry 0 is ``w0``. Diverging parameters give NaN from the divergence on, not an error.

    Raises
    ------
    SignalError
        ``w_meas`` missing or not of shape (N,) while a gain is non-zero.
    """
    out = np.empty(grid.idx.shape[0])
    lib.aff_simulate_on_grid(par, *_grid_args(grid, offset, w0, f0, gain, w_meas, out))
    return out


def simulate_on_grid_batch(pars, grid: InputGrid, *, w0: float, f0: float, offsets, gain=(0.0, 0.0),
                           w_meas=None) -> np.ndarray:
    """:func:`simulate_on_grid` of several parameter sets at once (no validation: inner loop of the fits).

    C (``aff_simulator.c``, ``aff_simulate_on_grid_batch``): the simulations advance side by side, sub-step by
    sub-step, up to :data:`BATCH_MAX` per call (more are chunked); each row is the same numbers, bit for bit, as
    :func:`simulate_on_grid` of its parameters, at about 15 % less CPU time per simulation (the CPU overlaps the
    independent simulations). Releases the GIL.

    Parameters
    ----------
    pars : sequence of cffi ``plant_params *``, length K
        Lagged Stribeck joints from :func:`plant.dynamics.lagged_params` (as :func:`simulate_on_grid`).
    grid : InputGrid
        From :func:`input_grid`.
    w0, f0 : float, keyword-only
        Initial velocity (rad/s) and friction state (N·m) at ``t[0]``, the same for every simulation.
    offsets : array_like, shape (K,), keyword-only
        Constant torque bias (N·m) of each simulation.
    gain, w_meas : keyword-only
        As :func:`simulate_on_grid` (the same for every simulation).

    Returns
    -------
    ndarray, shape (K, N)
        Row ``k``: :func:`simulate_on_grid` of ``pars[k]`` with ``offset=offsets[k]``.

    Raises
    ------
    SignalError
        ``w_meas`` missing or not of shape (N,) while a gain is non-zero; ``offsets`` not of length K.
    """
    offsets = np.ascontiguousarray(offsets, dtype=float).reshape(-1)
    if offsets.shape[0] != len(pars):
        raise SignalError(f"offsets must have one entry per parameter set ({len(pars)}), got {offsets.shape[0]}")
    n = grid.idx.shape[0]
    out = np.empty((len(pars), n))
    args = _grid_args(grid, 0.0, w0, f0, gain, w_meas, out[0] if len(pars) else np.empty(n))
    for a in range(0, len(pars), BATCH_MAX):
        b = min(a + BATCH_MAX, len(pars))
        lib.aff_simulate_on_grid_batch(stack_params(pars[a:b]), ffi.from_buffer("double[]", offsets[a:b]), b - a,
                                       *args[:4], *args[5:11], ffi.from_buffer("double[]", out[a:b]))
    return out


def simulate_on_grid_sens(par: np.ndarray, grid: InputGrid, *, w0: float, f0: float, offset: float = 0.0,
                          gain=(0.0, 0.0), w_meas=None) -> tuple[np.ndarray, np.ndarray]:
    """:func:`simulate_on_grid` with the exact Jacobian of its output (no validation: inner loop of the fits).

    C (``aff_simulator.c``, ``aff_simulate_on_grid_sens``): the same RK4 stages as :func:`simulate_on_grid`
    (the same velocity, bit for bit), each with its tangent along the parameters (forward sensitivities of the
    discretised model: the derivative of the numerical solution, which is the RK4 solution of the variational
    equations; Hairer, Norsett & Wanner, *Solving Ordinary Differential Equations I*, Secs. I.14, II.1).
    Eq. 3 is differentiated as the simulation evaluates it: zero slope at ``w == 0`` and no Stribeck term past
    its cut-off speed. Releases the GIL.

    Parameters
    ----------
    par : cffi ``plant_params *``
        A lagged Stribeck joint from :func:`plant.dynamics.lagged_params` with ``tau > 0``.
    grid : InputGrid
        From :func:`input_grid`.
    w0, f0, offset, gain, w_meas : keyword-only
        As :func:`simulate_on_grid`.

    Returns
    -------
    w : ndarray, shape (N,)
        Predicted velocity at the sample instants (rad/s), equal to :func:`simulate_on_grid`'s.
    dw : ndarray, shape (N, 8)
        ``dw[i, j]`` = derivative of ``w[i]`` with respect to parameter ``j`` of :data:`SENS_NAMES`
        (``J, Fc, Fs, sigma, tau, offset, Vs, delta``; SI units); row 0 is zero. NaN where ``w`` is NaN.

    Raises
    ------
    SignalError
        ``w_meas`` missing or not of shape (N,) while a gain is non-zero.
    """
    out = np.empty(grid.idx.shape[0])
    dout = np.empty((out.shape[0], len(SENS_NAMES)))
    lib.aff_simulate_on_grid_sens(par, *_grid_args(grid, offset, w0, f0, gain, w_meas, out),
                                  ffi.from_buffer("double[]", dout))
    return out, dout


def simulate_sampled(p: JointParams, t, u, *, w0: float = 0.0, f0: float | None = None, offset: float = 0.0,
                     h_max: float = H_MAX_DEFAULT, input_delay: float = 0.0) -> np.ndarray:
    """Free-run simulation of the joint (eqs. 1-3) at the given sample times, from sampled input.

    Parameters
    ----------
    p : JointParams
        Physical parameters; ``tau > 0`` required.
    t : array_like, shape (N,)
        Sample times (s), strictly increasing, any spacing.
    u : array_like, shape (N,)
        Input torque samples (N·m), linearly interpolated in between.
    w0 : float, keyword-only
        Velocity at ``t[0]`` (rad/s).
    f0 : float, keyword-only
        Friction state at ``t[0]`` (N·m); default ``F(w0) + offset``.
    offset : float, keyword-only
        Constant torque bias (N·m).
    h_max : float, keyword-only
        Largest RK4 sub-step (s). Default 1 ms.
    input_delay : float, keyword-only
        See :func:`input_grid`.

    Returns
    -------
    ndarray, shape (N,)
        Velocity (rad/s) at ``t``.

    Raises
    ------
    TypeError
        ``p`` is not a :class:`plant.friction.JointParams`.
    ParameterError
        ``p.tau == 0`` (use :func:`plant.joint.simulate` for the static map) or
        bad ``h_max``.
    SignalError
        Bad ``t``/``u``.
    """
    if not isinstance(p, JointParams):
        raise TypeError(f"p must be a JointParams, got {type(p).__name__}")
    if p.tau <= 0.0:
        raise ParameterError(f"simulate_sampled needs tau > 0, got tau = {p.tau!r}")
    w0 = check_finite_scalar("w0", w0)
    offset = check_finite_scalar("offset", offset)
    f0 = p.friction(w0) + offset if f0 is None else check_finite_scalar("f0", f0)
    grid = input_grid(t, u, h_max=h_max, input_delay=input_delay)
    par = lagged_params(p.J, p.Fc, p.Fs, p.Vs, p.delta, p.sigma, p.tau)
    w = simulate_on_grid(par, grid, w0=w0, f0=f0, offset=offset)
    if not np.all(np.isfinite(w)):  # pragma: no cover - physical parameters keep the model stable
        raise SignalError("the simulation diverged; reduce h_max")
    return w
