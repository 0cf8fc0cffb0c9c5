"""Test oracle of the closed-loop engine: every equation of a recorded run checked against the independent oracles.

A closed loop with friction amplifies rounding differences (a wrong-signed sample near standstill kicks the joint),
so two independent implementations run side by side part within a few hundred periods. The oracle therefore does
not simulate a second loop: :func:`oracle_replay` takes the engine's record and recomputes, period by period, what
each element of the loop must have produced from the record's own inputs, with the oracle components of
tests/pi_oracle.py, tests/peers_oracle.py, tests/compensation_oracle.py and tests/plant_oracle.py:

* the measurement: the true velocity plus the seeded noise, with the faults;
* the sensor gate (the last accepted measurement) and the compensator's output from the measurements, the
  reference and the recorded torques (estimators on whole signals);
* the PI command from the reference, the gated measurement and that compensation;
* the plant: one step from the recorded state with the recorded torque gives the next recorded state.

The returned signals are the oracle's (``w`` and ``f`` one step ahead of the record), so a run whose record
satisfies all these equations equals them to rounding; any element computed wrongly shows at the first period
it acts. Metrics are recomputed from the oracle's signals with :func:`oracle_metrics`. Full records only
(``decimate=1``).
"""

import math
from types import SimpleNamespace

import numpy as np

import compensation_oracle as co
import peers_oracle as po
import plant_oracle as pl
from controllers.simulation.metrics import LoopMetrics
from pi_oracle import OracleLoopModel, OraclePI, OracleSignObserver

__all__ = ["oracle_replay", "replayed_run", "oracle_metrics", "oracle_make_step"]


def oracle_make_step(p, dt):
    """The one-step plant of tests/plant_oracle.py (every plant model)."""
    return pl.make_step(p, dt)


def oracle_metrics(t, w_ref, w, u, *, reversals, window=0.2) -> LoopMetrics:
    """RMS and peak tracking errors of a whole record (overall, second half, near the reversals) and RMS torque.

    The second half is ``t >= (t[0] + t[-1])/2``; the reversal windows are the samples of the second half within
    ``window`` seconds of a reversal time.
    """
    t = np.asarray(t, dtype=float)
    e = np.asarray(w_ref, dtype=float) - np.asarray(w, dtype=float)
    half = t >= 0.5 * (t[0] + t[-1])
    revs = np.asarray(reversals, dtype=float)
    near = np.zeros_like(half)
    if revs.size:  # distance to the nearest reversal, in blocks of samples (memory)
        for a in range(0, t.size, 4096):
            near[a:a + 4096] = np.min(np.abs(t[a:a + 4096, None] - revs[None, :]), axis=1) <= window
    rms = lambda x: float(np.sqrt(np.mean(np.square(x)))) if x.size else math.nan  # noqa: E731
    return LoopMetrics(rms=rms(e), max=float(np.max(np.abs(e))), rms_second_half=rms(e[half]),
                       max_second_half=float(np.max(np.abs(e[half]))), rms_reversal=rms(e[near & half]),
                       u_rms=rms(np.asarray(u, dtype=float)))


def _velocity_inputs(kw, mode, J_d, with_ff):
    """The loop model (stick fallback) and sign observer of a measured-velocity feedforward, or None."""
    measured = kw.get("ff_input", "measured") == "measured"
    uses = with_ff and measured and mode in ("fixed", "adaptive", "adaptive-dob")
    lm = OracleLoopModel(kw["Kp"], kw["Ki"], J_d, kw.get("Tc", 1e-3)) if (
        uses and kw.get("stick_input", "model") == "model") else None
    obs = None
    if uses and kw.get("sign_input", "observer") == "observer" and kw["Kp"] > 0:
        obs = OracleSignObserver(J_d, kw.get("observer_bandwidth") or 5.0 * kw["Kp"] / J_d, kw.get("Tc", 1e-3))
    return lm, obs


def _stick_band(kw) -> float:
    """The loop's stick band: ``stick_band`` as given, or (None, the default) three times the velocity noise of the
    sensor the settings describe: the white noise and, with an encoder, its backward difference's quantisation
    (two independent uniform errors of ``res**2/12`` over ``Tc``)."""
    if kw.get("stick_band") is not None:
        return kw["stick_band"]
    var = kw.get("noise_std", 0.0) ** 2
    if kw.get("encoder_counts") is not None:
        if kw.get("velocity", "difference") != "difference":
            raise NotImplementedError("the replay sizes the stick band of the backward difference only")
        res = 2.0 * math.pi / kw["encoder_counts"]
        var += 2.0 * (res * res / 12.0) / kw.get("Tc", 1e-3) ** 2
    return 3.0 * math.sqrt(var)


def _ff_settings(kw, Tc, ff_max):
    return dict(dt=Tc, lag=kw.get("lag", True), ff_max=ff_max, sign_width=kw.get("sign_width", 0.0),
                stick_band=_stick_band(kw), stick_samples=kw.get("stick_samples", 10))


def _robust(kw, U, WM, J, Tc, m, ff_max, u_max):
    """Estimator path, decisions and output stepper of the sliding-regime adaptive feedforward."""
    model = kw.get("model")
    Vs = kw.get("Vs") if kw.get("Vs") is not None else model.Vs
    delta = kw.get("delta") if kw.get("delta") is not None else model.delta
    lam = kw.get("lam")
    gate = co.OutlierGate(max_step=2.0 * u_max * Tc / J if math.isfinite(u_max) else math.inf)
    path = co.sliding_path(U, WM, Vs=Vs, delta=delta, Tc=Tc, Ts=m * Tc, T_filter=kw.get("T_filter", 0.02),
                           lam=0.995 if lam is None else lam, forgetting=kw.get("forgetting", "exponential"),
                           P0=kw.get("P0", 1e4), initial=kw.get("initial"), J_guess=J, lag=kw.get("lag", True),
                           offset=kw.get("offset", True), dwell_max=kw.get("dwell_max", 0.01), gate=gate)
    dec = co.robust_decisions(path, dt=Tc, warmup=kw.get("warmup", 200), ff_max=ff_max, start=kw.get("start"),
                              lag_zero=kw.get("lag_zero", 3.0), project=kw.get("project", True))
    out = co.RobustOutput(dec, start=kw.get("start"), Vs=Vs, delta=delta, **_ff_settings(kw, Tc, ff_max))
    info = SimpleNamespace(n_rejected=path["n_rejected"], n_updates=path["rls"].n_updates, n_gated=path["n_gated"],
                           rls=path["rls"])
    ff = SimpleNamespace(estimator=info, n_implausible=dec["n_implausible"], n_lag_held=dec["n_lag_held"],
                         estimate=dec["estimate"], raw_estimate=co.reported_estimate(path, path["rls"].theta))
    return path, out, ff


def _compensation(mode, kw, *, J, J_d, Tc, m, u_max, ff_max, t, wr, wc, WM, U, F):
    """The compensator's output of every period from the record, and what the run reports about it."""
    n = wr.shape[0]
    uff = np.zeros(n)
    rep = dict(t_theta=np.empty(0), theta=np.empty((0, 0)), ff=None, peer=None, estimate=None)
    measured = kw.get("ff_input", "measured") == "measured"
    lam = kw.get("lam")
    if mode == "oracle":
        return F.copy(), rep
    if mode in ("none", "frictionless"):
        return uff, rep
    if mode == "canudas":
        r = po.canudas_path(U, WM, wc, wr, Tc=Tc, Ts=m * Tc, lam=0.999 if lam is None else lam,
                            forgetting=kw.get("forgetting", "exponential"), P0=kw.get("P0", 1e4), J_guess=J,
                            warmup=kw.get("warmup", 200), ff_max=ff_max, ff_input=kw.get("ff_input", "measured"))
        est = None
        if r["coef"] is not None:
            b = float(r["rls"].theta[0])
            est = dict(zip(("Fc_pos", "Fc_neg", "sigma_pos", "sigma_neg"), r["coef"]), J=m * Tc / b)
        rep["peer"] = SimpleNamespace(n_rejected=r["n_rejected"], estimate=est)
        rep.update(t_theta=t[r["update_at"]], theta=r["theta"])
        if rep["theta"].size == 0:
            rep["theta"] = np.empty((0, 0))
        return r["c"], rep
    if mode == "dob":
        J_n = kw.get("J_n")
        r = po.dob_path(wc, U, J_n=J if J_n is None else J_n, omega_q=kw.get("omega_q", 500.0), Tc=Tc, d_max=ff_max)
        rep["peer"] = SimpleNamespace(n_rejected=r["n_rejected"], estimate=None)
        return r["d_hat"], rep
    if mode == "adaptive" and kw.get("estimator", "sliding") == "eq4-rls":
        u_prev = np.concatenate([[0.0], U[:-1]])
        r = po.eq4_path(u_prev, WM, wc, wr, kw["model"], Ts=m * Tc, dt=Tc, lam=0.995 if lam is None else lam,
                        P0=kw.get("P0", 1e4), warmup=kw.get("warmup", 200), lag=kw.get("lag", True), ff_max=ff_max,
                        measured=measured)
        rep.update(t_theta=t[r["sampled"]], theta=r["theta"], estimate=r["est"].estimate)
        rep["ff"] = SimpleNamespace(estimate=r["est"].estimate)
        return r["u_ff"], rep
    lm, obs = _velocity_inputs(kw, mode, J_d, True)
    band = _stick_band(kw)
    if mode == "fixed":
        ff = po.Feedforward(**_ff_settings(kw, Tc, ff_max))
        ff.use(kw["estimate"])
        step = (lambda k, wf, wst: ff.step(wf, wst)) if measured else (lambda k, wf, wst: ff.step(wr[k]))
        rep.update(ff=SimpleNamespace(estimate=kw["estimate"]), estimate=kw["estimate"])
    else:  # adaptive, adaptive-dob: the robust feedforward (its part of the composite)
        path, out, ff = _robust(kw, U, WM, J, Tc, m, ff_max, u_max)
        step = lambda k, wf, wst: out.step(wf, wst, wr[k], measured)  # noqa: E731
        rep.update(t_theta=t[path["update_at"]], theta=path["theta"], ff=ff, estimate=ff.estimate)
    for k in range(n):
        wst = wr[k] if lm is None else lm.step(wc[k], wr[k])
        wf = wc[k] if obs is None else obs.signed(wc[k], band)
        uff[k] = step(k, wf, wst)
        if obs is not None:
            obs.update(U[k], uff[k])
    if mode == "adaptive-dob":  # the observer on the residual u - u_ff, the sum bounded by ff_max
        J_n = kw.get("J_n")
        omega_r = kw.get("omega_r", 1000.0)
        d = po.dob_path(wc, U - uff, J_n=J if J_n is None else J_n, omega_q=omega_r, Tc=Tc, d_max=ff_max)["d_hat"]
        # the crossover of the loop as run: Kp over the inertia the observers take (J_n where given, else the design's)
        d = _slew_limited(d, uff, slew_time=kw.get("slew_time", 0.4),
                          crossover=max(kw["Kp"], 0.0) / (J_d if J_n is None else J_n), a=-math.expm1(-Tc * omega_r))
        uff = np.clip(uff + d, -ff_max, ff_max)
    if rep["theta"].size == 0:  # no update: the engine's empty history
        rep["theta"] = np.empty((0, 0))
    return uff, rep


def _slew_limited(d, uff, *, slew_time, crossover, a):
    """The residual observer's estimate ``d`` as applied under the slew limit: each period it may differ from the
    last applied value by at most ``slew_time*crossover*a`` times the largest ``|u_ff|`` up to and including that
    period (a running maximum); ``d`` itself while that maximum is 0, and where ``slew_time*crossover`` is 0."""
    width = slew_time * crossover * a * np.maximum.accumulate(np.abs(uff))
    if slew_time * crossover == 0.0 or d.size == 0:
        return d
    out, last = np.empty_like(d), 0.0
    for k in range(d.size):  # the value nearest d[k] inside [last - width, last + width]
        last = float(np.median([last - width[k], d[k], last + width[k]])) if width[k] > 0.0 else float(d[k])
        out[k] = last
    return out


def oracle_replay(run, p, ref, *, mode, rng=None, faults=None, **kw) -> dict:
    """Recompute every period of the engine's run ``run`` (a ClosedLoopResult with full records) with the oracles.

    Parameters
    ----------
    run : ClosedLoopResult
        The engine's run of ``p`` on ``ref`` in ``mode`` with the settings ``kw`` (the LoopConfig fields).
    p, ref, mode, rng, faults, kw
        What the run was made with (``rng`` a fresh generator of the same seed).

    Returns
    -------
    dict
        The oracle's signals ``w``, ``w_meas``, ``u``, ``u_ff``, ``f`` (shape (N,), NaN after a divergence),
        ``t_theta``, ``theta``, ``metrics``, ``diverged``, ``estimate``, and objects with the counters: ``ff``
        (``estimator.n_rejected``, ``n_updates``, ``n_gated``, ``rls.n_projected``; ``n_implausible``,
        ``n_lag_held``; ``raw_estimate``, the estimator's report of its final state), ``peer`` (``n_rejected``, ``estimate``), ``gate`` (``n_rejected``).
    """
    Tc = kw.get("Tc", 1e-3)
    m = int(round(kw.get("Ts", 0.01) / Tc))
    u_max = kw.get("u_max", math.inf)
    ff_max = u_max if kw.get("ff_max") is None else kw["ff_max"]
    noise_std = kw.get("noise_std", 0.0)
    drifting = hasattr(p, "at")
    plant = p.frictionless() if mode == "frictionless" else (p.at(0.0) if drifting else p)
    J = float(plant.J)
    J_d = float(kw["J_design"]) if kw.get("J_design") is not None else J
    t = np.asarray(ref.t, dtype=float)
    wr = np.asarray(ref.w, dtype=float)
    n = t.shape[0]
    W, U, F = (np.asarray(getattr(run, x), dtype=float) for x in ("w", "u", "f"))
    # the record ends where the engine stopped (a divergence): the rest is NaN
    n_ok = int(np.argmax(np.isnan(W))) if np.isnan(W).any() else n
    # the measurement and the sensor gate
    noise = rng.normal(0.0, noise_std, size=n) if noise_std > 0 else np.zeros(n)
    WM = W + noise
    for k, v in (dict(faults) if faults else {}).items():
        if int(k) < n:
            WM[int(k)] = float(v)
    gate = None
    wc = WM.copy()
    if kw.get("sensor_gate", True):
        gate = co.OutlierGate(max_step=2.0 * u_max * Tc / J if math.isfinite(u_max) else math.inf)
        held = wr[0]
        for k in range(n_ok):
            if gate.check(WM[k]):
                held = WM[k]
            wc[k] = held
    sl = slice(0, n_ok)
    uff, rep = _compensation(mode, kw, J=J, J_d=J_d, Tc=Tc, m=m, u_max=u_max, ff_max=ff_max, t=t[sl],
                             wr=wr[sl], wc=wc[sl], WM=WM[sl], U=U[sl], F=F[sl])
    # the PI on the gated measurement with that compensation
    pi = OraclePI(Kp=kw["Kp"], Ki=kw["Ki"], Tc=Tc, u_max=u_max)
    u = np.array([pi.step(wr[k] - wc[k], uff[k]) for k in range(n_ok)])
    # the plant, one step from each recorded state
    drift_m = max(int(round(p.period / Tc)), 1) if (drifting and mode != "frictionless") else 0
    step = oracle_make_step(plant, Tc)
    lagged = not hasattr(plant, "sigma0")
    w_o, f_o = np.full(n, np.nan), np.full(n, np.nan)
    w_o[0] = wr[0]
    z = plant.initial_state(wr[0])
    f_o[0] = z if lagged else float(pl.lugre_friction_torque(plant, wr[0], z))
    diverged = False
    w_limit = kw.get("w_limit") or 100.0 * float(np.max(np.abs(wr))) + 1.0
    for k in range(n_ok):
        if drift_m and k % drift_m == 0 and k > 0:
            step = oracle_make_step(p.at(t[k]), Tc)
        w1, z = step(W[k], F[k] if lagged else z, U[k])
        f1 = z if lagged else float(pl.lugre_friction_torque(plant, w1, z))
        if not -w_limit < w1 < w_limit:
            diverged = True
            break
        if k + 1 < n:
            w_o[k + 1], f_o[k + 1] = w1, f1
    out = {"w": w_o, "w_meas": np.where(np.arange(n) < n_ok, WM, np.nan), "u": np.full(n, np.nan),
           "u_ff": np.full(n, np.nan), "f": f_o, "diverged": diverged, "gate": gate, **rep}
    out["u"][:n_ok], out["u_ff"][:n_ok] = u, uff
    if diverged:
        out["w"][n_ok:] = out["f"][n_ok:] = np.nan
    metrics_w = np.where(np.arange(n) < n_ok, w_o, np.nan)
    out["metrics"] = oracle_metrics(t, wr, metrics_w, out["u"], reversals=ref.reversals(),
                                    window=kw.get("reversal_window", 0.2))
    return out


def replayed_run(p, ref, *, mode, seed=0, faults=None, rel=1e-9, **kw) -> dict:
    """The engine's run of one mode (``run_mode`` with ``LoopConfig.from_flat(**kw)``) checked against its replay.

    Returns
    -------
    dict
        :func:`oracle_replay` of the run.

    Raises
    ------
    AssertionError
        A signal of the run departs from the replay by more than ``rel`` times ``max(1, max|signal|)``, or the
        divergence flags differ; the message names the signal and the first period.
    """
    from loop_helpers import run_named

    run = run_named(p, ref, mode=mode, rng=np.random.default_rng(seed), faults=faults, **kw)
    rep = oracle_replay(run, p, ref, mode=mode, rng=np.random.default_rng(seed), faults=faults, **kw)
    for name in ("w", "w_meas", "u", "u_ff", "f"):
        a, b = rep[name], np.asarray(getattr(run, name), dtype=float)
        fin = np.isfinite(a)
        assert np.array_equal(np.isfinite(b), fin), f"{name}: the record ends elsewhere"
        scale = max(1.0, float(np.max(np.abs(a[fin]))) if fin.any() else 1.0)
        bad = np.flatnonzero(np.abs(a[fin] - b[fin]) > rel * scale)
        assert bad.size == 0, f"{name} departs from the replay at period {np.flatnonzero(fin)[bad[0]]}"
    assert bool(run.info["diverged"]) == rep["diverged"]
    return rep
