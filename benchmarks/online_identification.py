"""Online identification of all friction parameters: unscented Kalman filter vs. the paper's RLS.

The paper's online estimator (RLS on eq. 4, eqs. 10-13) needs the Stribeck
factors ``Vs``, ``delta`` from a quasi-static pre-fit (Sec. V-C; its footnote
leaves their online estimation out). :class:`adaptive_ff.identification.online_ukf.OnlineUKF`
estimates ``(Fc, Fs, Vs, delta, sigma, tau)`` jointly online. Both run on the
same sampled stream:

* plant: the ``paper`` preset (eqs. 1-3, RK4 at 1 kHz);
* excitation: a velocity PI loop running at the sample time ``Ts`` (10 ms,
  paper Sec. IV-A; the torque is held over each interval, the
  :func:`plant.sampling.sample` convention) tracking the paper's multi-sine
  velocity reference (0.01-1 Hz, up to 20 deg/s, frequent reversals and
  low-speed passages); the soft 10 ms loop cannot hold the negative Stribeck
  slope, so the reversals show short stick-slip episodes, as on a real joint;
* measurement: white velocity noise (default 1e-3 rad/s).

RLS: :class:`adaptive_ff.identification.rls.RecursiveLeastSquares` (``lam = 1``,
``P0 = 1e4*I``, ``theta0 = 0``, as in the paper) on the eq. 4
:class:`adaptive_ff.identification.regression.RegressionModel` with ``Vs``, ``delta`` from
:func:`adaptive_ff.identification.stribeck_fit.fit_stribeck` on simulated bidirectional
quasi-static runs (:func:`controllers.experiments.quasi_static.quasi_static_runs`, same
noise). UKF: ``J`` known, initial guess off by 25-100 % (``Vs`` twice the
truth, ``delta = 1.5``).

Printed table: final relative error of each parameter and the convergence
time (the time after which all six stay within 10 % of the truth; "never"
if they do not by the end). Figure: the parameter trajectories vs. truth.

Run: ``python benchmarks/online_identification.py [--duration 60] [--seed 0] [--seeds 5] [--out FILE]``.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from adaptive_ff.identification.online_ukf import PARAM_NAMES, convergence_time, run_online_ukf
from adaptive_ff.identification.regression import RegressionModel
from adaptive_ff.identification.rls import RecursiveLeastSquares
from adaptive_ff.identification.stribeck_fit import fit_stribeck
from controllers.experiments.quasi_static import bidirectional_velocities, quasi_static_runs
from plant.errors import ParameterError, check_positive
from plant.excitation import multisine_reference
from plant.friction import JointParams, preset
from plant.joint import make_rk4_step
from plant.sampling import Measurement

__all__ = ["METHODS", "make_stream", "OnlineComparison", "coarse_theta0", "compare_online", "online_rows",
           "format_table", "seed_summary", "plot_trajectories", "main"]

#: Relative band (of the truth) that defines convergence in the table.
CONV_TOL = 0.10


def make_stream(p: JointParams, *, duration: float = 60.0, Ts: float = 0.01, noise_std: float = 1e-3,
                rng: np.random.Generator, dt: float = 1e-3, crossover: float = 30.0) -> Measurement:
    """Closed-loop identification stream: a velocity PI at ``Ts`` tracking the multi-sine reference.

    Parameters
    ----------
    p : JointParams
        Plant (eqs. 1-3).
    duration : float, keyword-only
        Length (s), > 0.
    Ts : float, keyword-only
        Sample and controller period (s), a multiple of ``dt``.
    noise_std : float, keyword-only
        White velocity noise (rad/s), >= 0; the controller sees the noisy velocity.
    rng : numpy.random.Generator, keyword-only
        Reference phases and noise.
    dt : float, keyword-only
        RK4 step of the plant (s), default 1 ms.
    crossover : float, keyword-only
        PI gains ``Kp = crossover*J``, ``Ki = Kp*crossover/5`` (rad/s, N·m·s/rad, N·m/rad).

    Returns
    -------
    plant.sampling.Measurement
        ``t, u, w`` of shape (N,), ``N = duration/Ts + 1``; ``u[k]`` is the
        torque held over ``(t[k-1], t[k]]`` (``u[0] = 0``).

    Raises
    ------
    ParameterError
        ``Ts`` not a multiple of ``dt`` or a size not > 0.

    Notes
    -----
    Reference: :func:`plant.excitation.multisine_reference` (paper Sec. V-B).
    """
    Ts = check_positive("Ts", Ts)
    dt = check_positive("dt", dt)
    m = int(round(Ts / dt))
    if m < 1 or abs(m * dt - Ts) > 1e-9 * Ts:
        raise ParameterError(f"Ts must be a multiple of dt = {dt!r}, got {Ts!r}")
    ref = multisine_reference(duration, dt=Ts, rng=rng)
    n = ref.t.size
    Kp = crossover * p.J
    Ki = Kp * crossover / 5.0
    step = make_rk4_step(p, dt)
    noise = rng.normal(0.0, noise_std, n) if noise_std > 0 else np.zeros(n)
    W, U, WM = np.zeros(n), np.zeros(n), np.zeros(n)
    WM[0] = noise[0]
    w = f = integ = 0.0
    for k in range(n - 1):
        e = ref.w[k] - WM[k]
        uk = Kp * e + integ
        integ += Ki * Ts * e
        for _ in range(m):
            w, f = step(w, f, uk)
        W[k + 1], U[k + 1], WM[k + 1] = w, uk, w + noise[k + 1]
    return Measurement(t=ref.t.copy(), u=U, w=WM, u_true=U.copy(), w_true=W, Ts=Ts)


#: Methods compared, in table order: UKF from a coarse guess, UKF from the pre-fit, RLS.
METHODS = ("UKF, coarse start", "UKF, pre-fit start", "RLS eq. 4 + pre-fit")


@dataclass(frozen=True)
class OnlineComparison:
    """Histories and final values of the online estimators on one stream.

    Attributes
    ----------
    t : ndarray, shape (N,)
        Sample times (s).
    truth : dict
        True ``{Fc, Fs, Vs, delta, sigma, tau}``.
    hist : dict
        ``{method: {name: ndarray (N,)}}`` parameter histories (SI units) for
        each of :data:`METHODS`; for RLS ``Vs`` and ``delta`` are the pre-fit constants.
    std : dict
        ``{method: {name: ndarray (N,)}}`` UKF 1-sigma (UKF methods only).
    theta0 : dict
        ``{method: initial guess}`` of the UKF methods.
    prefit : adaptive_ff.identification.stribeck_fit.StribeckFit
        The quasi-static pre-fit (Sec. V-C).
    J : float
        The true inertia (kg·m²), given to the UKF.
    rls_J : float
        The RLS inertia estimate (kg·m²).
    wall : dict
        ``{method: wall time (s)}``.
    """

    t: np.ndarray
    truth: dict
    hist: dict
    std: dict
    theta0: dict
    prefit: object
    J: float
    rls_J: float
    wall: dict


def coarse_theta0(p: JointParams) -> dict:
    """The coarse UKF start: the truth scaled by (0.7, 1.3, 2, 1.5, 0.75, 0.5) for (Fc, Fs, Vs, |delta|, sigma, tau)."""
    return {"Fc": 0.7 * p.Fc, "Fs": 1.3 * p.Fs, "Vs": 2.0 * p.Vs, "delta": 1.5 * p.delta, "sigma": 0.75 * p.sigma,
            "tau": 0.5 * p.tau}


def compare_online(p: JointParams | None = None, *, duration: float = 60.0, seed: int = 0, Ts: float = 0.01,
                   noise_std: float = 1e-3, ukf_options: dict | None = None) -> OnlineComparison:
    """Run the quasi-static pre-fit, the RLS and the UKF (two starts) on one simulated stream.

    Parameters
    ----------
    p : JointParams, optional
        Plant; default ``preset("paper")``.
    duration, Ts, noise_std : float, keyword-only
        Stream length (s), sample time (s), velocity noise (rad/s, > 0), see :func:`make_stream`.
    seed : int, keyword-only
        Seed of ``np.random.default_rng`` (reference, noise, quasi-static runs).
    ukf_options : dict, optional, keyword-only
        Further keyword arguments of :class:`adaptive_ff.identification.online_ukf.OnlineUKF`.

    Returns
    -------
    OnlineComparison

    Raises
    ------
    ExcitationError
        The quasi-static pre-fit cannot identify ``Vs``, ``delta``.

    Notes
    -----
    UKF starts: "coarse" is :func:`coarse_theta0` (no pre-fit needed except
    the sign of ``delta``, a structural choice the UKF does not estimate);
    "pre-fit" takes ``Fc, Fs, Vs, delta, sigma`` from the quasi-static pre-fit
    (the same information the RLS gets) and ``tau`` at half the truth.
    """
    p = preset("paper") if p is None else p
    noise_std = check_positive("noise_std", noise_std)
    rng = np.random.default_rng(seed)
    truth = {k: float(getattr(p, k)) for k in PARAM_NAMES}
    qs = quasi_static_runs(p, bidirectional_velocities(0.002, 0.35, 10), noise_std=noise_std, rng=rng)
    prefit = fit_stribeck(qs.w_mean, qs.u_mean)
    meas = make_stream(p, duration=duration, Ts=Ts, noise_std=noise_std, rng=rng)
    t, u, w = meas.t, meas.u, meas.w
    hist, std, wall, starts = {}, {}, {}, {}

    # --- UKF on the stream, two starts
    coarse = coarse_theta0(p)
    coarse["delta"] = math.copysign(abs(coarse["delta"]), prefit.delta)  # the curve branch from the pre-fit
    starts[METHODS[0]] = coarse
    starts[METHODS[1]] = dict(prefit.params(), tau=0.5 * p.tau)
    for name in METHODS[:2]:
        t0 = time.perf_counter()
        res = run_online_ukf(t, u, w, J=p.J, theta0=starts[name], noise_std=noise_std, options=ukf_options)
        wall[name] = time.perf_counter() - t0
        hist[name], std[name] = res.theta, res.theta_std

    # --- RLS on eq. 4 with the pre-fit Vs, delta (paper Sec. IV-B, V-C)
    t0 = time.perf_counter()
    model = RegressionModel(prefit.Vs, prefit.delta)
    rls = RecursiveLeastSquares(model.n_params, lam=1.0, P0=1e4)
    h = np.full((t.size, 6), np.nan)
    J_hat = math.nan
    for k in range(2, t.size):
        rls.update(model.phi(u[k], u[k - 1], w[k - 1], w[k - 2]), w[k])
        est = model.to_physical(rls.theta, Ts)
        h[k] = [est.Fc, est.Fs, prefit.Vs, prefit.delta, est.sigma, est.tau]
        J_hat = est.J
    h[:2] = h[2]
    wall[METHODS[2]] = time.perf_counter() - t0
    hist[METHODS[2]] = {k: h[:, i].copy() for i, k in enumerate(PARAM_NAMES)}
    return OnlineComparison(t=t, truth=truth, hist=hist, std=std, theta0=starts, prefit=prefit, J=float(p.J),
                            rls_J=float(J_hat), wall=wall)


def _conv_time(t, hist: dict, truth: dict, tol: float = CONV_TOL) -> float:
    times = []
    for k in PARAM_NAMES:
        h = np.where(np.isfinite(hist[k]), hist[k], 1e300)
        times.append(convergence_time(t, h, truth[k], rel_tol=tol))
    return max(times)


def online_rows(comp: OnlineComparison | None = None, **kwargs) -> list[dict]:
    """Table rows: method, final relative error of each parameter, convergence time.

    Parameters
    ----------
    comp : OnlineComparison, optional
        A finished comparison; default ``compare_online(**kwargs)``.
    **kwargs
        Passed to :func:`compare_online` when ``comp`` is None.

    Returns
    -------
    list of dict
        One dict per method of :data:`METHODS` with keys ``method``,
        ``Fc, Fs, Vs, delta, sigma, tau`` (signed relative error of the final
        estimate, 1), ``t_conv`` (s; the time after which all six stay within
        10 % of the truth, ``inf`` = never) and ``wall`` (s).
    """
    comp = compare_online(**kwargs) if comp is None else comp
    rows = []
    for name in METHODS:
        hist = comp.hist[name]
        row = {"method": name}
        for k in PARAM_NAMES:
            row[k] = float(hist[k][-1] / comp.truth[k] - 1.0)
        row["t_conv"] = _conv_time(comp.t, hist, comp.truth)
        row["wall"] = float(comp.wall[name])
        rows.append(row)
    return rows


def format_table(rows: list[dict]) -> str:
    """Fixed-width text table of :func:`online_rows` (signed relative errors in %)."""
    head = f"{'method':22s}" + "".join(f"{k:>10s}" for k in PARAM_NAMES) + f"{'t_conv [s]':>12s}{'wall [s]':>10s}"
    lines = [head, "-" * len(head)]
    for r in rows:
        tc = "never" if not math.isfinite(r["t_conv"]) else f"{r['t_conv']:.1f}"
        lines.append(f"{r['method']:22s}" + "".join(f"{100 * r[k]:+9.2f}%" for k in PARAM_NAMES)
                     + f"{tc:>12s}{r['wall']:10.2f}")
    return "\n".join(lines)


def plot_trajectories(comp: OnlineComparison):
    """Figure of the six parameter trajectories (UKF with ±2σ, RLS) against the truth.

    Returns
    -------
    matplotlib.figure.Figure
        Six axes (time in s, each parameter in its SI unit); y limits 0 to 2.2 x truth.
    """
    from matplotlib.figure import Figure

    units = {"Fc": "N·m", "Fs": "N·m", "Vs": "rad/s", "delta": "1", "sigma": "N·m·s/rad", "tau": "s"}
    fig = Figure(figsize=(11.0, 7.5), layout="constrained")
    axes = fig.subplots(3, 2, sharex=True).ravel()
    for ax, k in zip(axes, PARAM_NAMES):
        tr = comp.truth[k]
        for c, name in zip(("C0", "C2"), METHODS[:2]):
            m, s = comp.hist[name][k], comp.std[name][k]
            ax.fill_between(comp.t, m - 2 * s, m + 2 * s, color=c, alpha=0.2, lw=0)
            ax.plot(comp.t, m, color=c, label=f"{name} (±2σ)")
        rl = METHODS[2] + (" (constant)" if k in ("Vs", "delta") else "")
        ax.plot(comp.t, comp.hist[METHODS[2]][k], color="C1", label=rl)
        ax.axhline(tr, color="k", ls="--", lw=1, label="truth")
        ax.set_ylim(*sorted((0.0, 2.2 * tr)))
        ax.set_ylabel(f"{k} [{units[k]}]")
        ax.grid(True, alpha=0.3)
    for ax in axes[-2:]:
        ax.set_xlabel("time t [s]")
    axes[0].legend(loc="upper right", fontsize=7)
    fig.suptitle("Online identification: UKF (all six parameters) vs RLS on eq. 4 (Vs, delta from the pre-fit)")
    return fig


def seed_summary(rows_by_seed: list[list[dict]]) -> str:
    """Median and worst absolute final relative error (%) per method and parameter over seeds, and convergence."""
    head = f"{'method':22s}{'':8s}" + "".join(f"{k:>9s}" for k in PARAM_NAMES) + f"{'converged':>11s}"
    lines = [head, "-" * len(head)]
    for i, name in enumerate(METHODS):
        rs = [rows[i] for rows in rows_by_seed]
        e = np.array([[abs(r[k]) for k in PARAM_NAMES] for r in rs]) * 100
        n_conv = sum(math.isfinite(r["t_conv"]) for r in rs)
        lines.append(f"{name:22s}{'median':8s}" + "".join(f"{v:8.2f}%" for v in np.median(e, axis=0))
                     + f"{n_conv:>7d}/{len(rs)}")
        lines.append(f"{'':22s}{'worst':8s}" + "".join(f"{v:8.2f}%" for v in e.max(axis=0)))
    return "\n".join(lines)


def main(argv=None) -> int:
    """Command line: run the comparison, print the table, save the figure to ``--out``.

    ``--seeds N`` (N > 1) repeats the comparison for seeds ``seed .. seed+N-1`` and
    adds the median and worst absolute final error over them; the table and
    the figure are of the first seed.
    """
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=60.0, help="stream length (s), default 60")
    ap.add_argument("--seed", type=int, default=0, help="random seed, default 0")
    ap.add_argument("--seeds", type=int, default=1, help="number of seeds for the summary, default 1")
    ap.add_argument("--Ts", type=float, default=0.01, help="sample time (s), default 0.01")
    ap.add_argument("--noise", type=float, default=1e-3, help="velocity noise std (rad/s), default 1e-3")
    ap.add_argument("--out", default="online_identification.png", help="figure path")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    comp = compare_online(duration=args.duration, seed=args.seed, Ts=args.Ts, noise_std=args.noise)
    rows = online_rows(comp)
    pf = comp.prefit
    print("plant: preset 'paper' " + ", ".join(f"{k}={v:g}" for k, v in comp.truth.items()) + f", J={comp.J:g}")
    print(f"stream: {args.duration:g} s at Ts = {args.Ts * 1e3:g} ms, velocity noise {args.noise:g} rad/s, seed {args.seed}")
    print(f"pre-fit (Sec. V-C): Vs = {pf.Vs:.5g} ± {pf.stderr['Vs']:.2g} rad/s, delta = {pf.delta:.4g} ± "
          f"{pf.stderr['delta']:.2g}; RLS J = {comp.rls_J:.4g} kg·m² (UKF: J = {comp.J:g} given)")
    print(f"final relative error (signed); t_conv: all six within {100 * CONV_TOL:.0f} % from then on")
    print(format_table(rows))
    if args.seeds > 1:
        all_rows = [rows] + [online_rows(duration=args.duration, seed=args.seed + i, Ts=args.Ts, noise_std=args.noise)
                             for i in range(1, args.seeds)]
        print(f"\nover seeds {args.seed}..{args.seed + args.seeds - 1}: |final relative error|, "
              f"converged = all six within {100 * CONV_TOL:.0f} % at the end and from some time on")
        print(seed_summary(all_rows))
    fig = plot_trajectories(comp)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    print(f"figure: {out}; wall time {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
