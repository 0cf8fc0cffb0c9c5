"""The feedforward supervisor (adaptive_ff/csrc/aff_supervisor.c, FeedforwardSupervisor, the engine's composition).

The statistics against an independent numpy/scipy computation; a harmful compensator backed off and the run no
worse than none; a good one never touched (bit for bit); the open bench's case; batch = single run.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.signal import lfilter

from adaptive_ff.compensation.supervisor import DELAY_MAX, FeedforwardSupervisor, FeedforwardSupervisorConfig
from controllers import LoopConfig, design_pi, run_mode
from controllers.simulation.compensators import build_mode, build_supervisor
from controllers.experiments.compare import compare, eta
from controllers.simulation.batch import run_batch
from controllers.simulation.closed_loop import run_own
from plant.errors import ParameterError
from plant.excitation import multisine_reference
from plant.friction import preset
from plant.motion import point_to_point_reference
from plant.variant_plants import variant



def _supervisor(Tc, J_n, omega, **settings):
    """A supervisor with the settings ``settings`` (fields of :class:`FeedforwardSupervisorConfig`)."""
    return FeedforwardSupervisor(Tc=Tc, J_n=J_n, omega=omega, config=FeedforwardSupervisorConfig(**settings))

def _oracle(u_c, u, w, *, Tc, J_n, omega, window, margin, settle, delay):
    """The statistics and decisions of aff_supervisor written independently: the raw DOB sample as an array
    expression, the Q-filter by scipy's lfilter, the EWMA as its closed-form weighted sum."""
    n = u.shape[0]
    a = 1.0 - math.exp(-Tc * omega)
    b = 1.0 - math.exp(-Tc / window)
    ud = np.concatenate([np.zeros(delay + 1), u])[:n]   # u(k-1-d), 0 before the start
    cd = np.concatenate([np.zeros(delay + 1), u_c])[:n]
    v = np.zeros(n)
    v[1:] = ud[1:] - J_n * np.diff(w) / Tc              # period 0 only starts the difference
    f = np.zeros(n)
    r = np.zeros(n)
    f[1:] = lfilter([a], [1.0, -(1.0 - a)], v[1:])
    r[1:] = lfilter([a], [1.0, -(1.0 - a)], v[1:] - cd[1:])
    n0 = max(math.ceil(5.0 / (omega * Tc)), 1)
    nd = n0 + int(math.floor(settle / Tc + 0.5))
    mf, mr = np.zeros(n), np.zeros(n)
    for k in range(n0, n):
        wts = b * (1.0 - b) ** (k - np.arange(n0, k + 1))
        mf[k] = np.dot(wts, f[n0:k + 1] ** 2)
        mr[k] = np.dot(wts, r[n0:k + 1] ** 2)
    on = np.ones(n, dtype=bool)
    state = True
    for k in range(n):
        if k >= nd:
            if state and mr[k] > mf[k]:
                state = False
            elif not state and mr[k] < (1.0 - margin) * mf[k]:
                state = True
        on[k] = state
    return f, r, mf, mr, on


@pytest.mark.parametrize("delay", [0, 2])
def test_statistics_equal_an_independent_computation(delay):
    rng = np.random.default_rng(7)
    Tc, J_n, n = 1e-3, 0.5, 3000
    t = np.arange(n) * Tc
    w = np.cumsum(rng.normal(0.0, 0.02, n)) + 0.3 * np.sin(2 * np.pi * 1.5 * t)
    fr = 2.0 * np.sign(np.sin(2 * np.pi * 2.0 * t)) + rng.normal(0.0, 0.3, n)  # the disturbance
    u = np.empty(n)
    u[:-1] = J_n * np.diff(w) / Tc + fr[1:]                                       # J_n*dw/dt = u - f
    u[-1] = u[-2]
    u = np.roll(u, -delay) if delay else u
    u_c = np.where((t > 1.0) & (t < 2.0), -2.0, 1.0) * np.roll(fr, -1 - delay)   # good, harmful, good
    kw = dict(Tc=Tc, J_n=J_n, omega=40.0, window=0.2, margin=0.1, settle=0.05, delay=delay)
    s = _supervisor(**kw)
    got = s.run(u_c, u, w)
    f, r, mf, mr, on = _oracle(u_c, u, w, **kw)
    for name, want in (("f_hat", f), ("r_hat", r), ("ms_friction", mf), ("ms_residual", mr)):
        scale = np.max(np.abs(want))
        np.testing.assert_allclose(got[name], want, rtol=0, atol=1e-12 * scale, err_msg=name)
    np.testing.assert_array_equal(got["on"], on)
    np.testing.assert_array_equal(got["applied"], np.where(np.concatenate([[True], on[:-1]]), u_c, 0.0))
    # it backed off in the harmful second and came back in the third
    assert not on[(t > 1.3) & (t < 2.0)].any() and on[t > 2.6].all() and on[t < 1.0].all()
    assert s.n_backoff == 1 and s.n_restore == 1
    assert s.t_off == pytest.approx(Tc * np.count_nonzero(~on[:-1]), abs=1e-12)


def test_bumpless_transfer_is_the_candidate_at_a_switch():
    s = FeedforwardSupervisor(Tc=1e-3, J_n=1.0, omega=50.0, config=FeedforwardSupervisorConfig(window=0.1, settle=0.0))
    w = np.zeros(400)
    s.run(np.full(400, 3.0), np.zeros(400), w)  # no disturbance, a feedforward of 3 N*m: harmful
    assert not s.on and s.n_backoff == 1
    assert s.apply(3.0) == 0.0 and s.cdata.transfer == 0.0  # already off in the last apply of run
    s2 = FeedforwardSupervisor(Tc=1e-3, J_n=1.0, omega=50.0, config=FeedforwardSupervisorConfig(window=0.1, settle=0.0))
    for _ in range(400):
        assert s2.apply(3.0) == 3.0 and s2.cdata.transfer == 0.0
        s2.observe(0.0, 0.0)
        if not s2.on:  # decided off: the next apply switches and moves the candidate into the PI's integrator
            assert s2.apply(2.5) == 0.0 and s2.cdata.transfer == 2.5
            assert s2.apply(2.5) == 0.0 and s2.cdata.transfer == 0.0
            break
    else:
        pytest.fail("never backed off")


@pytest.mark.parametrize("kw, name", [(dict(margin=1.0), "margin"), (dict(delay=DELAY_MAX + 1), "delay"),
                                      (dict(window=0.0), "window"), (dict(omega=-1.0), "omega"),
                                      (dict(settle=math.nan), "settle"), (dict(window=math.inf), "finite")])
def test_bad_settings_are_refused(kw, name):
    base = dict(Tc=1e-3, J_n=1.0, omega=20.0)
    with pytest.raises(ParameterError, match=name):
        _supervisor(**{**base, **kw})


def test_mode_options_check_the_supervisor_settings():
    with pytest.raises(ParameterError, match="supervise_margin"):
        LoopConfig.from_flat(Kp=1.0, Ki=1.0, supervise_margin=-0.1)
    with pytest.raises(ParameterError, match="supervise_window"):
        LoopConfig.from_flat(Kp=1.0, Ki=1.0, supervise_window=0.0)
    with pytest.raises(ParameterError, match="supervise must"):
        LoopConfig.from_flat(Kp=1.0, Ki=1.0, supervise=1)


def _paper_loop(duration=20.0):
    p = preset("paper")
    d = design_pi(p.J, crossover=20.0, phase_margin=60.0, Tc=1e-3)
    ref = multisine_reference(duration, rng=np.random.default_rng(1))
    o = LoopConfig.from_flat(Kp=d.Kp, Ki=d.Ki, u_max=150.0, Vs=p.Vs, delta=p.delta, noise_std=1e-3)
    return p, ref, o


def _eta(p, ref, o, res):
    rms = {m: run_mode(p, ref, m, o, rng=np.random.default_rng(0)).metrics.rms_second_half
           for m in ("none", "frictionless")}
    return eta(rms["none"], res.metrics.rms_second_half, rms["frictionless"])


class _Harmful:
    """Feeds forward twice the Coulomb level against the measured motion: -2*Fc*sign(w)."""

    def __init__(self, Fc):
        self.Fc = Fc

    def compensate(self, w_meas, w_ref):
        return -2.0 * self.Fc * math.copysign(1.0, w_meas) if w_meas != 0.0 else 0.0

    def observe(self, u, w_meas):
        pass


def test_a_harmful_compensator_is_backed_off_and_the_loop_is_no_worse_than_none():
    p, ref, o = _paper_loop()
    bare = run_own(p, ref, _Harmful(p.Fc), o, rng=np.random.default_rng(0))
    sup = run_own(p, ref, _Harmful(p.Fc), o, rng=np.random.default_rng(0), supervise=True)
    e_bare, e_sup = _eta(p, ref, o, bare), _eta(p, ref, o, sup)
    assert e_bare < -0.2  # clearly worse than none
    assert e_sup >= -0.02
    assert sup.info["n_backoff"] == 1 and sup.info["n_restore"] == 0
    # backed off within the Q-filter's start, the settling time and one window (defaults: 2 s, settle 1 s)
    omega = o.controller.Kp / p.J
    first_off = sup.t[np.flatnonzero((sup.u_ff == 0.0) & (sup.t > 0.1))[0]]
    assert first_off <= 5.0 / omega + 1.0 + 2.0
    assert sup.info["t_off"] == pytest.approx(ref.t[-1] + 1e-3 - first_off, abs=2e-3)
    assert "n_backoff" not in bare.info


def test_a_good_compensator_is_never_backed_off_and_unchanged():
    p, ref, o = _paper_loop()
    on = run_mode(p, ref, "adaptive", o, rng=np.random.default_rng(0))
    off = run_mode(p, ref, "adaptive", o.replace(supervise=False), rng=np.random.default_rng(0))
    assert on.info["n_backoff"] == 0 and on.info["t_off"] == 0.0
    for k in ("w", "u", "u_ff", "theta"):
        np.testing.assert_array_equal(getattr(on, k), getattr(off, k))
    assert on.metrics == off.metrics


def test_open_bench_case_adaptive_not_worse_than_none():
    ref = point_to_point_reference([0.5, -0.2, 0.4, 0.0, 0.6, -0.3] * 3, v_max=0.5, a_max=4.0, dwell=0.5)
    c = compare(preset("paper"), reference=ref, encoder_counts=2 ** 17, delay=1, noise_std=0.0, u_max=150.0,
                seed=0, modes=("none", "adaptive"), progress=False)
    assert c.eta["adaptive"] >= -0.02


def test_batch_supervises_as_a_single_run():
    p, ref, o = _paper_loop(6.0)
    k = variant("karnopp")
    d = design_pi(k.J, crossover=20.0, phase_margin=60.0, Tc=1e-3)
    from adaptive_ff.identification.regression import RegressionModel
    ok = o.replace(Kp=d.Kp, Ki=d.Ki, estimator="eq4-rls", model=RegressionModel(k.Vs, k.delta), warmup=50)
    b = run_batch([k, p], ref, "adaptive", [ok, ok.replace(model=RegressionModel(p.Vs, p.delta))], seeds=[3, 4])
    for i, (plant, oi) in enumerate(((k, ok), (p, ok.replace(model=RegressionModel(p.Vs, p.delta))))):
        one = run_mode(plant, ref, "adaptive", oi, rng=np.random.default_rng(3 + i))
        assert b.rms_second_half[i] == one.metrics.rms_second_half
        assert b.supervisors[i].n_backoff == one.info["n_backoff"]
        assert b.supervisors[i].t_off == one.info["t_off"]


def test_zoo_table_counts_the_joints_worse_than_none():
    from controllers.experiments.zoo import ZooResult

    nan = math.nan
    eta_ad = np.array([0.5, -0.019, -0.021, nan, -3.0])
    rms = {m: np.ones(5) for m in ("none", "adaptive", "frictionless")}
    r = ZooResult(plants=[{"model": "karnopp"}] * 5, modes=("none", "adaptive", "frictionless"),
                  eta={"none": np.zeros(5), "adaptive": eta_ad, "frictionless": np.ones(5)}, rms=rms, refused={},
                  mode_refused={}, diverged={m: np.zeros(5, dtype=bool) for m in rms}, min_degradation=0.0,
                  seconds=0.0)
    assert r.worse_than_none() == {"none": 0, "adaptive": 2, "frictionless": 0}
    assert r.worse_than_none(-1.0) == {"none": 0, "adaptive": 1, "frictionless": 0}
    assert r.to_dict()["worse_than_none"]["adaptive"] == 2
    lines = r.summary().splitlines()
    assert "<none" in lines[1]
    row = next(ln for ln in lines if ln.startswith("adaptive"))
    assert row.split()[7] == "2"  # mode, ok, refused, diverged, undefined, no reference, invalid, <none


def test_nothing_is_applied_with_the_reference_at_rest_and_the_statistics_hold():
    rng = np.random.default_rng(3)
    n = 600
    w_ref = np.where((np.arange(n) >= 200) & (np.arange(n) < 400), 0.0, 0.5)
    u_c, u, w = rng.normal(size=n), rng.normal(size=n), rng.normal(size=n)
    kw = dict(Tc=1e-3, J_n=0.5, omega=40.0, window=0.2, settle=0.0)
    s = _supervisor(**kw)
    out = s.run(u_c, u, w, w_ref)
    rest = np.zeros(n, dtype=bool)
    rest[224:400] = True  # at rest for 1/(omega*Tc) = 25 periods in a row (the joint stops behind the reference)
    np.testing.assert_array_equal(out["applied"][rest], 0.0)
    plain = _supervisor(**kw, rest_band=-1.0).run(u_c, u, w, w_ref)["applied"]
    np.testing.assert_array_equal(out["applied"][:224], plain[:224])  # not yet at rest in 200..223
    assert s.t_rest == pytest.approx(176 * 1e-3, abs=1e-12)
    # the mean squares do not move at rest (the Q-filters do)
    assert np.all(np.diff(out["ms_friction"][224:400]) == 0.0) and np.all(np.diff(out["ms_residual"][224:400]) == 0.0)
    assert np.any(np.diff(out["ms_friction"][200:225]) != 0.0)
    assert np.any(np.diff(out["f_hat"][224:400]) != 0.0)
    # without the rest rule it is the plain supervisor
    s2 = _supervisor(**kw, rest_band=-1.0)
    np.testing.assert_array_equal(s2.run(u_c, u, w, w_ref)["applied"],
                                  _supervisor(**kw).run(u_c, u, w)["applied"])


def _rest_end_runs(mode, targets=(0.5, -0.2, 0.4), **options):
    """The paper joint on point-to-point moves to ``targets`` (rad) ending in a 0.5 s dwell (noise 1e-3 rad/s, seed
    0; ``options`` replace LoopConfig' fields): the recorded run of ``mode`` and its compensator's final state from
    the same run through ``run_batch``."""
    p = preset("paper")
    d = design_pi(p.J, crossover=20.0, phase_margin=60.0, Tc=1e-3)
    o = LoopConfig.from_flat(Kp=d.Kp, Ki=d.Ki, u_max=150.0, Vs=p.Vs, delta=p.delta, noise_std=1e-3).replace(**options)
    ref = point_to_point_reference(list(targets), v_max=0.5, a_max=4.0, dwell=0.5)
    rec = run_mode(p, ref, mode, o, rng=np.random.default_rng(0))
    b = run_batch([p], ref, mode, o, seeds=[0])
    assert b.rms_second_half[0] == rec.metrics.rms_second_half  # the same run
    return p, ref, o, rec, b.compensators[0]


def test_at_rest_the_compensation_is_withdrawn_through_the_lag_in_use():
    """At rest the last applied torque decays as u(k) = exp(-Tc/tau)*u(k-1) (eq. 2 with F(0) = 0): the closed form
    u_last*exp(-n*Tc/tau) after n rest periods; a tau of 0 (alpha 1) or an alpha outside [0, 1] withdraws at once."""
    n, k0 = 300, 100
    w_ref = np.where(np.arange(n) >= k0, 0.0, 0.5)
    kw = dict(Tc=1e-3, J_n=0.5, omega=40.0, window=0.2, settle=0.0)
    tau = 0.02
    s = _supervisor(**kw)
    s.set_rest_lag(1.0 - math.exp(-1e-3 / tau))
    n_hold = int(s.cdata.n_hold)
    applied = []
    for k in range(n):
        applied.append(s.apply(7.5, w_ref[k]))
        s.observe(0.0, 0.0)
    applied = np.array(applied)
    np.testing.assert_array_equal(applied[:k0 + n_hold - 1], 7.5)  # moving, and the hold before the rest
    rest_n = np.arange(1, n - (k0 + n_hold - 1) + 1)
    np.testing.assert_allclose(applied[k0 + n_hold - 1:], 7.5 * np.exp(-rest_n * 1e-3 / tau), rtol=1e-12)
    for alpha in (1.0, 1.5, math.nan, -0.1):
        s = _supervisor(**kw)
        s.set_rest_lag(alpha)
        out = [s.apply(7.5, w_ref[k]) for k in range(n)]
        np.testing.assert_array_equal(out[k0 + n_hold - 1:], 0.0)


def test_at_rest_the_composites_observer_measures_the_friction_itself():
    """With the reference at rest nothing is applied and the engine tells the compensator (ctl_adob_at_rest): the
    residual observer of ``adaptive-dob`` then takes the torque as applied, u, not u - u_ff. At the end of the final
    dwell (0.5 s) its estimate is that of a plain disturbance observer with its settings run on the recorded torque
    and measurement (the difference of their states before the rest decays as (1 + omega*t)*exp(-omega*t), omega
    1000 rad/s)."""
    p, ref, o, rec, comp = _rest_end_runs("adaptive-dob")
    n_end = rec.w_ref.shape[0] - 1 - np.flatnonzero(rec.w_ref != 0.0)[-1]  # periods of the final dwell
    assert n_end >= 400 and rec.info["t_rest"] > 1.0
    _, _, dob = build_mode(p, "dob", o.replace(omega_q=o.observer.omega_r))  # J_n = J, Q cut-off and bound as the composite's
    for k in range(rec.t.shape[0]):
        dob.compensate(rec.w_meas[k], rec.w_ref[k])
        dob.observe(rec.u[k], rec.w_meas[k])
    assert comp.u_ff == 0.0  # told: the feedforward part of the last period was not applied
    assert abs(dob.d_hat) > 0.1 * p.Fc  # the friction holding the joint at rest, not a trivial zero
    assert comp.observer.d_hat == pytest.approx(dob.d_hat, rel=1e-9, abs=1e-12 * p.Fc)


def test_before_its_switch_in_the_observer_of_adaptive_keeps_the_feedforwards_residual():
    """Plain ``adaptive`` before its residual switch-in applies no observer estimate; its switch-in test wants the
    residual f - u_ff of the feedforward, so at rest its observer still records u - u_ff (ctl_adob_at_rest)."""
    _, _, _, rec, comp = _rest_end_runs("adaptive")
    assert comp.t_switch_in is None and rec.info["t_rest"] > 1.0
    assert comp.u_ff != 0.0 and comp.u_ff == comp.cdata.ff.ff.u_out


def test_after_a_rest_the_feedforward_part_is_held_until_the_joint_moves_in_the_references_direction():
    """After a rest the composite (``adaptive-dob``) leaves its feedforward part out and applies the observer's
    estimate alone, the observer told that nothing of the feedforward was applied (aff_residual_at_rest,
    aff_residual_compensate), until the measured velocity has the reference's sign (w_ctrl*w_ref > 0); then u_ff +
    d_hat again. Checked against an independent replay: the rest periods by the supervisor's rule (|w_ref| = 0 for
    n_hold periods in a row), a separate feedforward and a plain disturbance observer run on the recorded torque and
    measurement, composed by that rule in Python. At rest the last applied torque decays through the feedforward's
    lag in use, ``u(k) = exp(-Tc/tau)*u(k-1)`` (the paper joint's lag, 3.2 ms). The observer's estimate passes its
    slew limit (aff_residual.h): it moves by at most ``slew_time*crossover*a*peak`` per period, ``a = 1 -
    exp(-Tc*omega_r)`` its Q-filter's gain, ``crossover = Kp/J``, ``peak`` the largest feedforward torque so far."""
    targets = [0.5, -0.2, 0.4, 0.0, 0.6, -0.3] * 2  # the open bench's moves (the feedforward on after a few)
    # the measurement's noise (1e-3 rad/s) gives the velocity at a rest's end either sign: some moves begin held
    p, ref, o, rec, comp = _rest_end_runs("adaptive-dob", targets, sensor_gate=False)
    assert rec.info["n_backoff"] == 0 and rec.info["n_sensor_rejected"] == 0  # applied outside rest; w_ctrl = w_meas
    n_hold = int(build_supervisor(p, "adaptive-dob", o).cdata.n_hold)
    zero = rec.w_ref == 0.0
    run = np.zeros(zero.shape[0], dtype=int)  # length of the run of zero reference ending at k
    for k in np.flatnonzero(zero):
        run[k] = (run[k - 1] if k > 0 else 0) + 1
    rest = run >= n_hold
    assert rest.sum() * 1e-3 == pytest.approx(rec.info["t_rest"], abs=1e-9)
    _, _, fresh = build_mode(p, "adaptive-dob", o)
    ff = fresh.feedforward  # the feedforward part alone (its own struct's field; the residual part is not called)
    _, _, dob = build_mode(p, "dob", o.replace(omega_q=o.observer.omega_r))  # the composite's observer settings, J_n = J
    n = rec.t.shape[0]
    expected = np.zeros(n)
    withheld = np.zeros(n)  # the feedforward part left out
    held = np.zeros(n, dtype=bool)
    hold = False
    decays = limited = 0
    slew = 0.4 * (o.controller.Kp / p.J) * (1.0 - math.exp(-1e-3 * o.observer.omega_r))  # slew_time 0.4 s
    peak = d_app = 0.0
    for k in range(n):
        wm, wr = rec.w_meas[k], rec.w_ref[k]
        u_ff = ff.compensate(wm, wr)
        d_raw = dob.compensate(wm, wr)
        peak = max(peak, abs(u_ff))
        step = slew * peak
        d_app = d_raw if step == 0.0 else d_app + min(max(d_raw - d_app, -step), step)
        limited += d_app != d_raw
        d = d_app
        if hold and wm * wr > 0.0:
            hold = False
        if rest[k]:
            e = ff.estimate  # the lag in use: eq. 2's decay with F(0) = 0 from the last applied torque
            keep = math.exp(-1e-3 / e.tau) if e is not None and e.tau > 0 else 0.0
            decays += keep > 0
            expected[k] = keep * expected[k - 1]
            told, hold = 0.0, True      # the feedforward not applied (the supervisor's rest rule)
        elif hold:
            told, expected[k], held[k], withheld[k] = 0.0, d, True, u_ff
        else:
            told, expected[k] = u_ff, u_ff + d
        ff.observe(rec.u[k], wm)
        dob.observe(rec.u[k] - told, wm)
    assert np.max(np.abs(expected)) < o.drive.u_max  # the bound never acts
    assert decays > 1000  # the rests after the feedforward's switch-on withdraw it through its lag
    assert limited >= 10  # the slew limit acts on this run (15 periods)
    starts = np.flatnonzero(held & ~np.roll(held, 1))
    ends = np.flatnonzero(rest[:-1] & ~rest[1:]) + 1  # first period after each rest
    assert starts.shape[0] >= 3 and np.all(np.isin(starts, ends))  # a hold begins only at a rest's end
    assert held.sum() < 20 * starts.shape[0]  # for a few periods, not for the move
    assert comp.cdata.res.n_held == held.sum() and comp.n_held == held.sum()
    np.testing.assert_allclose(rec.u_ff[held], expected[held], rtol=1e-9, atol=1e-12 * p.Fc)  # d_hat alone
    np.testing.assert_allclose(rec.u_ff[~held], expected[~held], rtol=1e-9, atol=1e-12 * p.Fc)  # 0 / u_ff + d_hat
    assert np.max(np.abs(withheld)) > 0.05 * p.Fc  # the hold left out a feedforward part (2.1 N*m here)


def test_before_its_switch_in_adaptive_applies_nothing_while_held():
    """Plain ``adaptive`` before its residual switch-in (g = 0) holds too: after a rest its output is 0 until
    w_ctrl*w_ref > 0, otherwise exactly the feedforward's u_ff (against a separate feedforward replayed on the
    recorded torque and measurement); its observer keeps u - u_ff as at rest (the switch-in test's residual). At rest
    the last applied torque decays through the feedforward's lag in use."""
    targets = [0.5, -0.2, 0.4, 0.0, 0.6, -0.3] * 2
    p, ref, o, rec, comp = _rest_end_runs("adaptive", targets, sensor_gate=False)
    assert rec.info["n_backoff"] == 0 and rec.info["n_sensor_rejected"] == 0
    n = rec.t.shape[0]
    k_in = n if comp.t_switch_in is None else int(round(comp.t_switch_in / 1e-3))
    n_hold = int(build_supervisor(p, "adaptive", o).cdata.n_hold)
    run = np.zeros(n, dtype=int)
    for k in np.flatnonzero(rec.w_ref == 0.0):
        run[k] = (run[k - 1] if k > 0 else 0) + 1
    rest = run >= n_hold
    _, _, fresh = build_mode(p, "adaptive", o)
    ff = fresh.feedforward
    expected = np.zeros(n)
    withheld = np.zeros(n)
    held = np.zeros(n, dtype=bool)
    hold = False
    for k in range(k_in):
        wm, wr = rec.w_meas[k], rec.w_ref[k]
        u_ff = ff.compensate(wm, wr)
        if hold and wm * wr > 0.0:
            hold = False
        if rest[k]:
            e = ff.estimate
            expected[k] = (math.exp(-1e-3 / e.tau) if e is not None and e.tau > 0 else 0.0) * expected[k - 1]
            hold = True
        elif hold:
            held[k], withheld[k] = True, u_ff
        else:
            expected[k] = u_ff
        ff.observe(rec.u[k], wm)
    assert held.sum() >= 1 and k_in > n // 4  # switched in at 9.4 s; one move before begins held
    assert np.max(np.abs(withheld)) > 0.05 * p.Fc  # what the hold left out (4.4 N*m here)
    np.testing.assert_allclose(rec.u_ff[:k_in], expected[:k_in], rtol=1e-9, atol=1e-12 * p.Fc)
    assert np.all(rec.u_ff[:k_in][held[:k_in]] == 0.0)
