"""The ``adaptive-dob`` composite (adaptive friction feedforward + disturbance observer on the residual): the
compiled engine equals an independent oracle (tests/compensation_oracle.py, tests/loop_oracle.py), the batch
engine equals the single run, the parts compose as specified, and the mode holds its targets on one plant of
each friction model (the margin target of docs/benchmarks/variants.md)."""

import math

import numpy as np
import pytest

from adaptive_ff.compensation.adaptive_feedforward import RobustAdaptiveFeedforward, RobustAdaptiveFeedforwardConfig
from adaptive_ff.compensation.sliding_estimator import SlidingFrictionEstimator, SlidingFrictionEstimatorConfig
from controllers.design.pi import design_pi
from controllers.peers.adaptive_dob import AdaptiveDOBCompensator
from controllers.peers.dob import DisturbanceObserver
from controllers.simulation.batch import run_batch
from controllers.simulation.closed_loop import LoopConfig
from loop_helpers import run_named
from plant.errors import ParameterError
from plant.excitation import multisine_reference
from plant.friction import preset
from plant.variant_plants import variant
from test_kernel_adaptive import _assert_same, _both, _initial

P = preset("paper")
DESIGN = design_pi(P.J, crossover=20.0, phase_margin=60.0, Tc=1e-3)


@pytest.fixture(scope="module")
def ref():
    return multisine_reference(6.0, f_min=0.3, rng=np.random.default_rng(0))


@pytest.mark.parametrize("name", ["paper", "lugre", "karnopp", "asymmetric"])
@pytest.mark.parametrize("ff_input", ["measured", "reference"])
def test_engine_equals_oracle_on_every_plant_model(ref, name, ff_input):
    p = P if name == "paper" else variant(name)
    faults = {500: float("nan"), 1200: 5.0, 3000: -3.0}
    a, b = _both(p, ref, mode="adaptive-dob", Kp=DESIGN.Kp, Ki=DESIGN.Ki, u_max=150.0, ff_max=75.0, noise_std=1e-3,
                 Vs=p.Vs, delta=p.delta, initial=_initial(P), warmup=50, stick_band=3e-3, stick_samples=5,
                 faults=faults, ff_input=ff_input, J_n=0.9 * p.J, omega_q=300.0, omega_r=700.0)
    _assert_same(a, b)
    assert b.info["n_updates"] > 100 and b.theta.shape[0] == b.info["n_updates"]
    assert b.estimate is not None and b.info["dob_J_n"] == pytest.approx(0.9 * p.J)
    assert b.info["dob_omega_q"] == 700.0


def test_before_switch_on_it_is_the_observer_and_after_it_the_observer_sees_the_residual(ref):
    """With the feedforward never switched on the composite is the plain DOB (bit for bit); after switch-on
    the observer's recorded torque is ``u - u_ff``."""
    kw = dict(Kp=DESIGN.Kp, Ki=DESIGN.Ki, u_max=150.0, noise_std=1e-3, Vs=P.Vs, delta=P.delta)
    off = run_named(P, ref, mode="adaptive-dob", rng=np.random.default_rng(5), warmup=10**6, omega_r=500.0, **kw)
    dob = run_named(P, ref, mode="dob", rng=np.random.default_rng(5), **kw)
    for name in ("w", "u", "u_ff"):
        np.testing.assert_array_equal(getattr(off, name), getattr(dob, name))
    est = SlidingFrictionEstimator(P.Vs, P.delta, Tc=1e-3, initial=_initial(P, 1.0),
                                   config=SlidingFrictionEstimatorConfig(initial_J=P.J))
    # one direction of motion only: no determinacy test (max_rel_stderr inf), or Fc would never be determined
    ff = RobustAdaptiveFeedforward(est, dt=1e-3,
                                   config=RobustAdaptiveFeedforwardConfig(warmup=0, fade_in=0.0,
                                                                          max_rel_stderr=math.inf))
    comp = AdaptiveDOBCompensator(ff, DisturbanceObserver(J_n=P.J, Tc=1e-3))
    rng = np.random.default_rng(2)
    for k in range(400):  # a sliding ramp: the estimator updates and the feedforward switches on
        w = 0.05 + 1e-4 * k + 1e-4 * rng.normal()
        out = comp.compensate(w, w)
        # the torque of the joint on that ramp (eq. 3's static map at w, plus J*dw/dt with dw/dt = 0.1 rad/s²):
        # data a friction model explains, so the unconstrained estimator's estimate is plausible (a constant
        # torque is explained by no positive J, sigma: the RLS state, which is not projected, is refused)
        u = P.Fc + (P.Fs - P.Fc) * math.exp(-((w / P.Vs) ** P.delta)) + P.sigma * w + P.J * 0.1
        comp.observe(u, w)
    assert comp.active and comp.feedforward.u_ff != 0.0
    assert comp.observer.u_last == pytest.approx(u - comp.u_ff, rel=1e-15)
    assert out == pytest.approx(comp.u_ff + comp.observer.d_hat, rel=1e-15)


def test_batch_equals_single_runs(ref):
    plants = [P, variant("karnopp"), variant("lugre")]
    opts = [LoopConfig.from_flat(Kp=DESIGN.Kp, Ki=DESIGN.Ki, u_max=150.0, noise_std=1e-3, Vs=p.Vs, delta=p.delta, warmup=50,
                        initial=_initial(P)) for p in plants]
    batch = run_batch(plants, ref, "adaptive-dob", opts, seeds=[1, 2, 3])
    for b, (p, o, s) in enumerate(zip(plants, opts, [1, 2, 3])):
        single = run_named(p, ref, mode="adaptive-dob", rng=np.random.default_rng(s), **o.to_flat())
        assert batch.rms[b] == pytest.approx(single.metrics.rms, rel=1e-12)
        assert batch.max_second_half[b] == pytest.approx(single.metrics.max_second_half, rel=1e-12)
        np.testing.assert_array_equal(batch.compensators[b].estimator.theta, single_theta(single))


def single_theta(res):
    return res.theta[-1]


def test_validation():
    est = SlidingFrictionEstimator(P.Vs, P.delta, Tc=1e-3)
    ff = RobustAdaptiveFeedforward(est, dt=1e-3)
    dob = DisturbanceObserver(J_n=P.J, Tc=1e-3)
    with pytest.raises(ParameterError, match="feedforward"):
        AdaptiveDOBCompensator(dob, dob)
    with pytest.raises(ParameterError, match="observer"):
        AdaptiveDOBCompensator(ff, ff)
    with pytest.raises(ParameterError, match="u_max"):
        AdaptiveDOBCompensator(ff, dob, u_max=-1.0)
    with pytest.raises(ParameterError, match="AdaptiveFrictionFeedforward"):  # the kinds it takes, named
        AdaptiveDOBCompensator(est, dob)
    assert math.isinf(AdaptiveDOBCompensator(ff, dob).u_max)


@pytest.mark.parametrize("mode,estimator", [("adaptive-dob", "eq4-rls"), ("adaptive", "eq4"), ("adaptive", "sliding")])
def test_every_estimator_builds_the_composite(mode, estimator):
    """``adaptive-dob``, and ``adaptive`` with its switch-in, compose the observer with the feedforward of any
    estimator: the eq. 4 ones in ``ctl_eq4_dob``, the sliding one in ``ctl_adob`` (``adaptive-dob``) or in the mode's
    one struct ``aff_adaptive`` with its supervisor (``adaptive``); ``switch_in=False`` leaves ``adaptive`` the
    feedforward alone (in ``aff_adaptive`` without the observer over the sliding estimator)."""
    from adaptive_ff.compensation.eq4_feedforward import AdaptiveFrictionFeedforward
    from adaptive_ff.identification.regression import RegressionModel
    from controllers.simulation.compensators import build_mode

    o = LoopConfig.from_flat(Kp=20.0, Ki=200.0, J_design=P.J, Vs=P.Vs, delta=P.delta, estimator=estimator,
                    model=RegressionModel(P.Vs, P.delta))
    _, _, comp = build_mode(P, mode, o)
    assert isinstance(comp, AdaptiveDOBCompensator) and comp.MODE == mode
    eq4 = estimator != "sliding"
    whole = mode == "adaptive" and not eq4
    assert comp.C_OPS == ("ctl_eq4_dob_ops" if eq4 else "aff_adaptive_ops" if whole else "ctl_adob_ops")
    assert isinstance(comp.feedforward, AdaptiveFrictionFeedforward if eq4 else RobustAdaptiveFeedforward)
    assert (comp.switch_in is not None) == (mode == "adaptive")
    assert (getattr(comp, "supervisor", None) is not None) == whole  # the engine supervises the others
    _, _, alone = build_mode(P, "adaptive", o.replace(switch_in=False))
    if eq4:
        assert isinstance(alone, AdaptiveFrictionFeedforward)
    else:
        assert alone.C_OPS == "aff_adaptive_ops" and alone.observer is None
        assert isinstance(alone.feedforward, RobustAdaptiveFeedforward)


def test_at_rest_by_hand_arms_the_hold_and_the_hold_ends_when_the_joint_follows():
    """Stepped by hand: after ``at_rest()`` the output is the observer's part alone (``u_ff`` left out, the observer
    told 0) until the velocity has the reference's sign, then ``u_ff + d_hat`` again; a twin observer fed the
    torques without what was applied of the feedforward agrees to rounding."""
    from adaptive_ff.compensation.adaptive_feedforward import FeedforwardStart
    from adaptive_ff.identification.regression import FrictionEstimate

    init = FrictionEstimate(J=P.J, tau=0.0, sigma=P.sigma, Fc=P.Fc, Fs=P.Fs, offset=0.0, Vs=P.Vs, delta=P.delta,
                            J_alt=math.nan)
    est = SlidingFrictionEstimator(P.Vs, P.delta, Tc=1e-3, initial=init,
                                   config=SlidingFrictionEstimatorConfig(initial_J=P.J))
    ff = RobustAdaptiveFeedforward(est, dt=1e-3, start=FeedforwardStart(init))
    c = AdaptiveDOBCompensator(ff, DisturbanceObserver(J_n=P.J, Tc=1e-3, omega_q=300.0))
    twin = DisturbanceObserver(J_n=P.J, Tc=1e-3, omega_q=300.0)
    rng = np.random.default_rng(3)
    w_seq = [0.0] * 5 + [-1e-4, -2e-4, 0.0, 2e-4, 5e-3, 1e-2]  # at rest, creeps back, then follows w_ref > 0
    held_seen, ff_held = [], []
    for k, w in enumerate(w_seq):
        w_ref = 0.0 if k < 5 else 0.05
        out = c.compensate(w, w_ref)
        d = twin.compensate(w, w_ref)
        if k < 5:
            c.at_rest()
            applied_ff = 0.0
        else:
            applied_ff = 0.0 if c.held else c.u_ff
            assert out == pytest.approx(applied_ff + d, rel=1e-12, abs=1e-12), k
            if c.held:
                ff_held.append(c.feedforward.u_ff)
        held_seen.append(c.held)
        u = 2.0 + rng.normal(0.0, 0.1)
        c.observe(u, w)
        twin.observe(u - applied_ff, w)
    assert held_seen[:8] == [True] * 8 and held_seen[8] is False and c.n_held == 3
    assert min(abs(x) for x in ff_held) > 1.0  # the feedforward had a torque to apply, and it was left out
