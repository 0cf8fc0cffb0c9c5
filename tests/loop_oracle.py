"""Test oracle: the former pure-Python closed loop (``run_closed_loop(engine="python")`` before issue 10).

Composes the pure-Python oracle components (tests/compensation_oracle.py, tests/peers_oracle.py,
tests/pi_oracle.py, tests/plant_oracle.py) in the order of the former Python loop, with the former
numpy metrics, so that the compiled engine of the package can be checked against an independent
implementation of the same equations. Full records only (``decimate=1``).
"""

import math

import numpy as np

import compensation_oracle as co
import peers_oracle as po
from pi_oracle import OracleLoopModel, OraclePI, OracleSignObserver
import plant_oracle as pl
from controllers.simulation.metrics import LoopMetrics


def oracle_make_step(p, dt):
    """The former ``make_step(dt)`` of each plant model (tests/plant_oracle.py)."""
    step = {"lagged-stribeck": pl.make_rk4_step, "lugre": pl.lugre_make_step, "karnopp": pl.karnopp_make_step,
            "asymmetric": pl.asymmetric_make_step}[p.MODEL]
    return step(p, dt)


def _metric_masks(t, reversals, window):
    half = t >= 0.5 * (t[0] + t[-1])
    mask = np.zeros_like(half)
    if len(reversals):
        idx = np.searchsorted(reversals, t)
        lo = np.abs(t - reversals[np.clip(idx - 1, 0, len(reversals) - 1)])
        hi = np.abs(reversals[np.clip(idx, 0, len(reversals) - 1)] - t)
        mask = (np.minimum(lo, hi) <= window) & half
    return half, mask


def oracle_metrics(t, w_ref, w, u, *, reversals, window=0.2) -> LoopMetrics:
    """The former numpy ``loop_metrics``."""
    e = np.asarray(w_ref) - np.asarray(w)
    half, mask = _metric_masks(t, reversals, window)
    rms = lambda x: float(np.sqrt(np.mean(x**2))) if x.size else float("nan")  # noqa: E731
    return LoopMetrics(rms=rms(e), max=float(np.max(np.abs(e))), rms_second_half=rms(e[half]),
                       max_second_half=float(np.max(np.abs(e[half]))), rms_reversal=rms(e[mask]),
                       u_rms=rms(np.asarray(u)))


def _objects(p, mode, kw, J, Tc, u_max, ff_max, m):
    lam = kw.get("lam")
    if lam is None:
        lam = 0.999 if mode == "canudas" else 0.995
    ff_input = kw.get("ff_input", "measured")
    lag = kw.get("lag", True)
    common = dict(sign_width=kw.get("sign_width", 0.0), stick_band=kw.get("stick_band", 0.0),
                  stick_samples=kw.get("stick_samples", 10))
    if mode == "fixed":
        return co.FrictionFeedforward(kw["estimate"], dt=Tc, lag=lag, ff_max=ff_max, **common), None
    if mode == "adaptive" and kw.get("estimator", "sliding") == "eq4":
        return po.AdaptiveFrictionFeedforward(kw["model"], Ts=m * Tc, dt=Tc, lam=lam, P0=kw.get("P0", 1e4),
                                              warmup=kw.get("warmup", 200), lag=lag, ff_max=ff_max), None
    if mode == "adaptive-dob":
        ff, _ = _objects(p, "adaptive", kw, J, Tc, u_max, ff_max, m)
        _, dob = _objects(p, "dob", dict(kw, omega_q=kw.get("omega_r", 1000.0)), J, Tc, u_max, ff_max, m)
        return co.AdaptiveDOBCompensator(ff, dob, u_max=ff_max, measured=ff_input == "measured"), None
    if mode == "adaptive":
        model = kw.get("model")
        Vs = kw.get("Vs") if kw.get("Vs") is not None else model.Vs
        delta = kw.get("delta") if kw.get("delta") is not None else model.delta
        gate_step = 2.0 * u_max * Tc / J if math.isfinite(u_max) else math.inf
        est = co.SlidingFrictionEstimator(Vs, delta, Tc=Tc, Ts=m * Tc, T_filter=kw.get("T_filter", 0.02), lam=lam,
                                          forgetting=kw.get("forgetting", "exponential"), P0=kw.get("P0", 1e4),
                                          initial=kw.get("initial"), J_guess=J, lag=lag,
                                          dwell_max=kw.get("dwell_max", 0.01), offset=kw.get("offset", True),
                                          gate=co.OutlierGate(max_step=gate_step))
        start = kw.get("start")
        if start is not None:
            start = (start.estimate, start.gain, start.ff_input == "reference")
        return co.RobustAdaptiveFeedforward(est, dt=Tc, lag=lag, ff_max=ff_max, warmup=kw.get("warmup", 200),
                                            start=start, **common), None
    if mode == "canudas":
        return None, po.CanudasCompensator(Tc=Tc, Ts=m * Tc, lam=lam, forgetting=kw.get("forgetting", "exponential"),
                                           P0=kw.get("P0", 1e4), J_guess=J, warmup=kw.get("warmup", 200),
                                           ff_max=ff_max, ff_input=ff_input)
    if mode == "dob":
        J_n = kw.get("J_n")
        return None, po.DisturbanceObserver(J_n=J if J_n is None else J_n, omega_q=kw.get("omega_q", 500.0), Tc=Tc,
                                            d_max=ff_max)
    return None, None


def oracle_run(p, ref, *, mode, rng=None, faults=None, **kw):
    """The former Python loop; returns a dict of signals (w, w_meas, u, u_ff, f), metrics, theta history."""
    Tc = kw.get("Tc", 1e-3)
    m = int(round(kw.get("Ts", 0.01) / Tc))
    u_max = kw.get("u_max", math.inf)
    ff_max = u_max if kw.get("ff_max") is None else kw["ff_max"]
    noise_std = kw.get("noise_std", 0.0)
    drifting = hasattr(p, "at")
    plant = p.frictionless() if mode == "frictionless" else (p.at(0.0) if drifting else p)
    J = float(plant.J)
    drift_m = max(int(round(p.period / Tc)), 1) if (drifting and mode != "frictionless") else 0
    ctrl = OraclePI(Kp=kw["Kp"], Ki=kw["Ki"], Tc=Tc, u_max=u_max)
    ff, peer = _objects(plant, mode, kw, J, Tc, u_max, ff_max, m)
    eq4 = isinstance(ff, po.AdaptiveFrictionFeedforward)
    adob = isinstance(ff, co.AdaptiveDOBCompensator)
    robust = adob or isinstance(ff, co.RobustAdaptiveFeedforward)
    ff_measured = kw.get("ff_input", "measured") == "measured"
    # the stick-detection fallback of the measured-velocity feedforward: the nominal loop (design inertia)
    J_d = float(kw["J_design"]) if kw.get("J_design") is not None else J
    lm = (OracleLoopModel(kw["Kp"], kw["Ki"], J_d, Tc) if ff is not None and not eq4 and ff_measured
          and kw.get("stick_input", "model") == "model" and mode in ("fixed", "adaptive", "adaptive-dob") else None)
    # the sign observer of the measured-velocity feedforward (design inertia, 5*Kp/J unless given)
    obs = None
    if (ff is not None and not eq4 and ff_measured and kw.get("sign_input", "observer") == "observer"
            and kw["Kp"] > 0 and mode in ("fixed", "adaptive", "adaptive-dob")):
        bw = kw.get("observer_bandwidth") or 5.0 * kw["Kp"] / J_d
        obs = OracleSignObserver(J_d, bw, Tc)
    band = kw.get("stick_band", 0.0)
    t = np.asarray(ref.t)
    wr = np.asarray(ref.w, dtype=float)
    n = t.shape[0]
    revs = ref.reversals()
    w_limit = kw.get("w_limit") or 100.0 * float(np.max(np.abs(wr))) + 1.0
    noise = rng.normal(0.0, noise_std, size=n) if noise_std > 0 else np.zeros(n)
    gate = None
    if kw.get("sensor_gate", True):
        gate = co.OutlierGate(max_step=2.0 * u_max * Tc / J if math.isfinite(u_max) else math.inf)
    fd = {int(k): float(v) for k, v in dict(faults).items()} if faults else {}
    step = oracle_make_step(plant, Tc)
    lagged = not hasattr(plant, "sigma0")
    W, WM, U, UFF, F = (np.full(n, np.nan) for _ in range(5))
    th_t, th = [], []
    w = float(wr[0])
    s = plant.initial_state(w)
    f = s if lagged else plant.friction_torque(w, s)
    u = 0.0
    held = w
    diverged = False
    for k in range(n):
        if drift_m and k % drift_m == 0 and k > 0:
            frozen = p.at(t[k])
            step = oracle_make_step(frozen, Tc)
        wm = w + noise[k]
        if k in fd:
            wm = fd[k]
        if gate is not None:
            if gate.check(wm):
                held = wm
            wc = held
        else:
            wc = wm
        wrk = wr[k]
        if eq4 and k % m == 0 and k > 0:
            ff.observe(u, wm)
            th_t.append(t[k])
            th.append(ff.theta.copy())
        wst = wrk if lm is None else lm.step(wc, wrk)
        wf = wc if obs is None else obs.signed(wc, band)
        if adob:
            uff = ff.step(wc, wrk, wst, w_ff=wf)
        elif robust:
            uff = ff.step(wf, wst, wrk) if ff_measured else ff.step(wrk)
        elif ff is not None:
            uff = ff.step(wf, wst) if ff_measured else ff.step(wrk)
        elif peer is not None:
            uff = peer.compensate(wc, wrk)
        elif mode == "oracle":
            uff = f
        else:
            uff = 0.0
        u = ctrl.step(wrk - wc, uff)
        if obs is not None:
            obs.update(u, ff.u_ff if adob else uff)
        if robust:
            ff.observe(u, wm)
            if ff.estimator.updated:
                th_t.append(t[k])
                th.append(ff.estimator.theta.copy())
        elif peer is not None:
            peer.observe(u, wm)
        W[k], WM[k], U[k], UFF[k], F[k] = w, wm, u, uff, f
        w, s = step(w, s, u)
        f = s if lagged else plant.friction_torque(w, s)
        if not -w_limit < w < w_limit:
            diverged = True
            break
    metrics = oracle_metrics(t, wr, W, U, reversals=revs, window=kw.get("reversal_window", 0.2))
    return {"w": W, "w_meas": WM, "u": U, "u_ff": UFF, "f": F, "t_theta": np.asarray(th_t),
            "theta": np.asarray(th).reshape(len(th), -1) if th else np.empty((0, 0)), "metrics": metrics,
            "diverged": diverged, "estimate": ff.estimate if ff is not None else None, "ff": ff, "peer": peer,
            "gate": gate}
