"""The main job: run every friction-compensation mode on the same scenario and compare tracking."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from tqdm.auto import tqdm

from adaptive_ff.feedforward import project_estimate
from adaptive_ff.ls import LSResult, fit_ls
from adaptive_ff.regression import FrictionEstimate, RegressionModel
from adaptive_ff.stribeck_fit import StribeckFit, fit_stribeck
from controllers.closed_loop import MODES, run_closed_loop
from controllers.pi import PIDesign, design_pi
from controllers.quasi_static import bidirectional_velocities, quasi_static_runs
from plant.errors import ParameterError, check_positive
from plant.excitation import bandlimited_noise, multisine_reference
from plant.friction import JointParams
from plant.joint import simulate
from plant.sampling import sample

__all__ = ["Comparison", "compare", "eta"]


def eta(rms_none: float, rms_mode: float, rms_frictionless: float) -> float:
    """Compensation efficiency ``(RMS_none - RMS_mode) / (RMS_none - RMS_frictionless)``.

    1 means the mode reaches the frictionless limit, 0 no improvement, < 0 worse
    than no compensation. NaN if friction does not degrade the loop at all.
    """
    den = rms_none - rms_frictionless
    return float((rms_none - rms_mode) / den) if den > 0 else float("nan")


@dataclass(frozen=True)
class Comparison:
    """All modes on one scenario.

    Attributes
    ----------
    plant : JointParams
        True plant.
    design : PIDesign
        The PI design used in every mode.
    results : dict[str, ClosedLoopResult]
        One run per mode, same reference and noise.
    eta : dict[str, float]
        Compensation efficiency per mode (second half of the run).
    prefit : StribeckFit or None
        Stribeck pre-fit (Sec. V-C) that gave Vs, delta to the regression model.
    offline : LSResult or None
        The offline LS identification behind the ``fixed`` mode.
    model : RegressionModel
        Regression structure used by ``fixed`` and ``adaptive``.
    """

    plant: JointParams
    design: PIDesign
    results: dict
    eta: dict
    prefit: StribeckFit | None
    offline: LSResult | None
    model: RegressionModel

    def rows(self) -> list[dict]:
        """One dict per mode: mode, rms, max, rms_reversal (second half, rad/s), u_rms, eta."""
        out = []
        for mode, r in self.results.items():
            m = r.metrics
            out.append({"mode": mode, "rms": m.rms_second_half, "max": m.max_second_half,
                        "rms_reversal": m.rms_reversal, "u_rms": m.u_rms, "eta": self.eta[mode]})
        return out

    def table(self) -> str:
        """The comparison as a fixed-width text table (velocities in deg/s)."""
        head = f"{'mode':<13}{'RMS [deg/s]':>12}{'max [deg/s]':>13}{'reversal RMS':>14}{'u RMS [N·m]':>13}{'eta':>8}"
        lines = [head, "-" * len(head)]
        for row in self.rows():
            d = np.rad2deg
            lines.append(f"{row['mode']:<13}{d(row['rms']):>12.4f}{d(row['max']):>13.4f}"
                         f"{d(row['rms_reversal']):>14.4f}{row['u_rms']:>13.2f}{row['eta']:>8.3f}")
        return "\n".join(lines)

    def to_json_dict(self) -> dict:
        """``{"modes": {mode: {"rms", "max", "rms_reversal", "u_rms", "eta"}}, ...}`` in SI units (rad/s)."""
        modes = {r["mode"]: {k: float(v) for k, v in r.items() if k != "mode"} for r in self.rows()}
        out = {"modes": modes, "plant": self.plant.to_dict(),
               "controller": {"Kp": self.design.Kp, "Ki": self.design.Ki, "Tc": self.design.Tc,
                              "phase_margin_deg": self.design.phase_margin,
                              "gain_margin": self.design.gain_margin}}
        if self.prefit is not None:
            out["prefit"] = {k: float(getattr(self.prefit, k)) for k in ("Fc", "Fs", "Vs", "delta", "sigma")}
        if self.offline is not None:
            e = self.offline.estimate
            out["offline_ls"] = {k: float(getattr(e, k)) for k in ("J", "tau", "sigma", "Fc", "Fs")}
        adaptive = self.results.get("adaptive")
        if adaptive is not None and adaptive.estimate is not None:
            e = adaptive.estimate
            out["adaptive_final"] = {k: float(getattr(e, k)) for k in ("J", "tau", "sigma", "Fc", "Fs")}
        return out


def compare(p: JointParams, *, duration: float = 120.0, seed: int = 0, modes=MODES, crossover: float = 20.0,
            phase_margin: float = 60.0, Tc: float = 1e-3, Ts: float = 0.01, u_max: float | None = None,
            noise_std: float = 1e-3, lam: float = 0.995, prefit: bool = True, lag: bool = True,
            progress: bool | None = None) -> Comparison:
    """Run the closed loop in several friction-compensation modes on one scenario.

    Parameters
    ----------
    p : JointParams
        True plant.
    duration : float, keyword-only
        Length of each run (s), default 120.
    seed : int, keyword-only
        Seed of everything random (reference phases, noise, identification run).
    modes : sequence of str, keyword-only
        Subset of :data:`controllers.closed_loop.MODES`; ``none`` and
        ``frictionless`` are always run (``eta`` needs them).
    crossover, phase_margin : float, keyword-only
        PI design targets (rad/s, deg) for :func:`controllers.pi.design_pi` on ``1/(J s)``.
    Tc, Ts : float, keyword-only
        Controller period and identification sample time (s).
    u_max : float, keyword-only
        Torque saturation (N·m); default ``3*(Fs + sigma*peak + J*accel_peak)`` of the plant.
    noise_std : float, keyword-only
        Velocity measurement noise (rad/s), default 1e-3.
    lam : float, keyword-only
        Forgetting factor of the adaptive RLS.
    prefit : bool, keyword-only
        Estimate Vs, delta by the Stribeck pre-fit from simulated quasi-static
        runs (paper Sec. V-C); False uses the true values.
    lag : bool, keyword-only
        Filter the feedforward through the estimated lag.
    progress : bool, keyword-only
        Show a progress bar; default: when stderr is a terminal.

    Returns
    -------
    Comparison

    Raises
    ------
    ParameterError
        Unknown mode or invalid settings.

    Notes
    -----
    ``fixed`` uses an offline LS fit (eq. 9) of a separate identification run:
    the paper's Sec. IV-A experiment (open loop, 1 Hz low-pass band-limited
    white-noise torque of standard deviation ``1.2*(Fs + sigma*peak|w_ref|)``,
    same length, sampled at ``Ts`` with the same noise); ``adaptive`` runs
    RLS (eqs. 10-13) on the loop's own data. Both use the regression model of
    eq. 4 at ``Ts`` with the pre-fitted Vs, delta. ``eta`` uses the RMS error
    over the second half of the run.
    """
    duration = check_positive("duration", duration)
    unknown = [m for m in modes if m not in MODES]
    if unknown:
        raise ParameterError(f"unknown mode(s) {unknown}; known: {MODES}")
    run_modes = [m for m in MODES if m in set(modes) | {"none", "frictionless"}]
    ss = np.random.SeedSequence(seed)
    ref_ss, id_ss, noise_ss, qs_ss = ss.spawn(4)
    ref = multisine_reference(duration, dt=Tc, rng=np.random.default_rng(ref_ss))
    if u_max is None:
        peak_w, peak_a = float(np.max(np.abs(ref.w))), float(np.max(np.abs(ref.dw)))
        u_max = 3.0 * (max(p.Fs, p.Fc) + p.sigma * peak_w + p.J * peak_a)
    design = design_pi(p.J, crossover=crossover, phase_margin=phase_margin, Tc=Tc)
    show = progress
    steps = len(run_modes) + (1 if "fixed" in run_modes else 0) + (1 if prefit else 0)
    bar = tqdm(total=steps, desc="compare", disable=(None if show is None else not show), leave=False)

    fit = None
    if prefit:
        bar.set_postfix_str("Stribeck pre-fit")
        vel = bidirectional_velocities(0.2 * p.Vs, 1.2 * float(np.max(np.abs(ref.w))), 12)
        qs = quasi_static_runs(p, vel, Tc=Tc, noise_std=noise_std, rng=np.random.default_rng(qs_ss))
        fit = fit_stribeck(qs.w_mean, qs.u_mean, F_std=None)
        Vs, delta = fit.Vs, fit.delta
        bar.update()
    else:
        Vs, delta = p.Vs, p.delta
    model = RegressionModel(Vs, delta, lag=True)
    # the feedforward may use at most half the actuator range; friction levels above it are implausible
    common = dict(Kp=design.Kp, Ki=design.Ki, u_max=u_max, ff_max=0.5 * u_max, Tc=Tc, Ts=Ts, noise_std=noise_std,
                  lag=lag)

    offline = None
    estimate: FrictionEstimate | None = None
    if "fixed" in run_modes:
        # Separate identification experiment as in the paper's Sec. IV-A: open loop, low-pass
        # filtered band-limited white-noise torque, sampled at Ts with the same velocity noise.
        bar.set_postfix_str("identification run")
        id_rng = np.random.default_rng(id_ss)
        peak_w = float(np.max(np.abs(ref.w)))
        _, u_id = bandlimited_noise(duration, dt=Tc, cutoff=1.0, std=1.2 * (max(p.Fs, p.Fc) + p.sigma * peak_w),
                                    rng=id_rng)
        meas = sample(simulate(p, u_id, dt=Tc), Ts=Ts, noise_std=noise_std, rng=id_rng)
        offline = fit_ls(model, meas.u, meas.w, Ts=Ts)
        estimate = project_estimate(offline.estimate, F_max=0.5 * u_max)
        bar.update()

    results = {}
    for mode in run_modes:
        bar.set_postfix_str(mode)
        results[mode] = run_closed_loop(p, ref, mode=mode, rng=np.random.default_rng(noise_ss), model=model,
                                        estimate=estimate, lam=lam, **common)
        bar.update()
    bar.close()
    rn = results["none"].metrics.rms_second_half
    rf = results["frictionless"].metrics.rms_second_half
    etas = {mode: eta(rn, r.metrics.rms_second_half, rf) for mode, r in results.items()}
    return Comparison(plant=p, design=design, results=results, eta=etas, prefit=fit, offline=offline, model=model)


