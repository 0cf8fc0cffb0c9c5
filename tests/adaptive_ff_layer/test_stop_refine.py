"""The stops of a lagged joint: the sample intervals in which it comes to rest or reverses integrated finely.

Eqs. 1-3 with a lag ring through zero velocity at each stop; one RK4 step per millisecond keeps a light joint ringing
(the reference here: scipy's RK45 at tight tolerances, an integrator the package does not use), and an output-error
fit on that coarse step reads a lag several times too long. ``stop_intervals`` and ``input_grid(refine=...)`` give
those intervals sub-steps of a tenth; ``stop_band`` of the output-error fit uses them.
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from adaptive_ff.identification.physical_id import fit_physical
from adaptive_ff.identification.simulator import input_grid, simulate_on_grid, simulate_sampled, stop_intervals
from plant.dynamics import lagged_params
from plant.errors import ParameterError, SignalError
from plant.friction import JointParams

#: A light lagged joint (a wrist of the planar arm of benchmarks/arm_coverage.py): its stops ring for tens of ms.
WRIST = JointParams(J=0.057, Fc=2.16, Fs=2.55, Vs=0.084, delta=1.0, sigma=0.8, tau=3.4e-3)


def test_stop_intervals_marks_the_band_and_the_reversals():
    w = np.array([0.5, 0.05, -0.2, -0.3, 0.0, 0.4, 0.6])
    np.testing.assert_array_equal(stop_intervals(w, 0.1), [True, True, False, True, True, False])
    np.testing.assert_array_equal(stop_intervals(w, 0.0), [False, True, False, True, True, False])
    np.testing.assert_array_equal(stop_intervals(w, 1.0), [True] * 6)


@pytest.mark.parametrize("w, band, err", [([0.1, np.nan, 0.2], 0.1, SignalError), ([0.1], 0.1, SignalError),
                                          ([0.1, 0.2], -0.01, ParameterError),
                                          ([0.1, 0.2], np.inf, ParameterError)])
def test_stop_intervals_rejects_bad_input(w, band, err):
    with pytest.raises(err, match="w|band"):
        stop_intervals(np.array(w), band)


def test_input_grid_refines_the_marked_intervals_only():
    t = np.arange(6) * 1e-3
    u = np.arange(6.0)
    g = input_grid(t, u, h_max=1e-3, refine=[False, True, False, False, True], h_refine=1e-4)
    np.testing.assert_array_equal(np.diff(g.idx), [1, 10, 1, 1, 10])
    np.testing.assert_allclose(g.tg[g.idx], t, rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.diff(g.tg[1:12]), 1e-4, rtol=1e-9)
    np.testing.assert_allclose(g.ug, g.tg * 1e3, rtol=0, atol=1e-12)  # the first-order hold of u = t/ms
    with pytest.raises(SignalError, match="refine"):
        input_grid(t, u, refine=[True, False])
    with pytest.raises(ParameterError, match="h_refine"):
        input_grid(t, u, refine=[True] * 5, h_refine=0.0)


def _stop_reference(p, w0, u0, t):
    """The joint from ``w0`` at its steady friction under a constant ``u0``, by scipy's RK45 (rtol 1e-8, steps of at
    most 10 us) at the times ``t`` (tens of ms: the continuous joint's ringing gets ever faster as it settles, and
    the adaptive steps with it)."""
    def F(w):
        return np.sign(w) * (p.Fc + (p.Fs - p.Fc) * np.exp(-np.abs(w / p.Vs) ** p.delta)) + p.sigma * w

    sol = solve_ivp(lambda _, x: [(u0 - x[1]) / p.J, (F(x[0]) - x[1]) / p.tau], (t[0], t[-1]), [w0, F(w0)],
                    t_eval=t, method="RK45", rtol=1e-8, atol=1e-12, max_step=1e-5)
    return sol.y[0], F(w0)


def test_a_refined_stop_settles_as_the_continuous_joint_and_a_coarse_one_keeps_ringing():
    p = WRIST
    t = np.arange(41) * 1e-3
    u = np.full(t.shape, 1.0)  # below Fc: the joint stops within a few ms and rings through zero
    ref, f0 = _stop_reference(p, 0.05, 1.0, t)
    par = lagged_params(p.J, p.Fc, p.Fs, p.Vs, p.delta, p.sigma, p.tau)
    coarse = simulate_on_grid(par, input_grid(t, u), w0=0.05, f0=f0)
    fine = simulate_on_grid(par, input_grid(t, u, refine=stop_intervals(ref, 2 * p.Fs * 1e-3 / p.J)), w0=0.05,
                            f0=f0)
    assert np.max(np.abs(ref[30:])) < 3e-4  # the continuous joint has settled after 30 ms
    assert np.max(np.abs(fine - ref)[30:]) < 1e-3
    assert np.max(np.abs(coarse - ref)[30:]) > 4e-3  # the 1 ms step rings on


@pytest.fixture(scope="module")
def stick_slip_record():
    """10 s of the light joint under a two-sine torque (it sticks on 60 % of the samples), simulated at 10 us
    steps, its velocity with 2e-4 rad/s of white noise (seeded)."""
    p = WRIST
    t = np.arange(10000) * 1e-3
    u = 3.0 * np.sin(2 * np.pi * 0.5 * t) + 1.0 * np.sin(2 * np.pi * 1.3 * t + 1.0)
    w = simulate_sampled(p, t, u, w0=0.0, f0=0.0, h_max=1e-5)
    return t, u, w + 2e-4 * np.random.default_rng(0).standard_normal(w.shape)


def test_the_output_error_fit_reads_a_light_joints_lag_with_its_stops_refined(stick_slip_record):
    t, u, w = stick_slip_record
    p = WRIST
    band = 2 * p.Fs * 1e-3 / p.J
    fine = fit_physical(t, u, w, Vs=p.Vs, delta=p.delta, n_bootstrap=0, input_delay=0.0, stop_band=band)
    coarse = fit_physical(t, u, w, Vs=p.Vs, delta=p.delta, n_bootstrap=0, input_delay=0.0)
    assert fine.info["stop_band"] == band and 0 < fine.info["refined_intervals"] < t.shape[0] - 1
    assert coarse.info["stop_band"] is None and coarse.info["refined_intervals"] == 0
    assert fine.params["tau"] == pytest.approx(p.tau, rel=0.05)
    assert fine.params["J"] == pytest.approx(p.J, rel=0.02)
    assert coarse.params["tau"] > 2.0 * p.tau  # the 1 ms step's ringing read as lag


def test_output_error_options_check_the_stop_band():
    from adaptive_ff.identification.oe_options import OutputErrorOptions

    assert OutputErrorOptions(stop_band=0.05).stop_band == 0.05
    for bad in (-0.01, np.nan):
        with pytest.raises(ParameterError, match="stop_band"):
            OutputErrorOptions(stop_band=bad)
    with pytest.raises(ParameterError, match="h_refine"):
        OutputErrorOptions(h_refine=0.0)


def test_the_arm_lag_fits_band_is_twice_what_the_static_friction_takes_off_in_a_sample():
    from adaptive_ff.arm.lag import LAG_STOP_BAND, stop_bands

    assert LAG_STOP_BAND == 2.0
    np.testing.assert_allclose(stop_bands([2.55, -0.8, 1.0, 1.0], [0.057, 0.4, np.nan, 0.0], 1e-3),
                               [2 * 2.55e-3 / 0.057, 2 * 0.8e-3 / 0.4, 0.0, 0.0], rtol=1e-14)


def test_the_stick_speed_is_what_the_coulomb_friction_takes_off_in_a_sample():
    from adaptive_ff.arm.lag import stick_speeds

    np.testing.assert_allclose(stick_speeds([2.55, -0.8, 1.0, 1.0, np.inf], [0.057, 0.4, np.nan, 0.0, 1.0], 1e-3),
                               [2.55e-3 / 0.057, 0.8e-3 / 0.4, np.nan, np.nan, np.nan], rtol=1e-14)


def test_the_arm_plant_steps_its_stops_as_a_finely_stepped_arm():
    """The planar arm of benchmarks/arm_coverage.py (seed 0: lagged shoulder and wrist, lag-free elbow), its wrist
    from 0.05 rad/s under 1 N·m, the others at rest: with each joint's stop band the periods in which a joint is
    inside it take ten steps, and the wrist settles as the arm stepped 100 times per period does; one step per
    period keeps it ringing."""
    pytest.importorskip("pinocchio")
    from adaptive_ff.arm.robot import load_urdf
    from adaptive_ff.arm.simulate import STOP_REFINE, ArmPlant
    from benchmarks.arm_coverage import ARMATURE, URDF, arm_friction

    arm = load_urdf(URDF)
    friction = arm_friction(arm.n, 0, lag=True)

    def run(substeps, banded):
        plant = ArmPlant(arm, friction, armature=ARMATURE)
        plant.set_state(np.zeros(arm.n), [0.0, 0.0, 0.05])
        band = plant.stop_band(1e-3) if banded else None
        out = []
        for _ in range(40):
            plant.step([0.0, 0.0, 1.0], 1e-3, substeps, stop_band=band)
            out.append(plant.dq.copy())
        return np.array(out), band

    ref, _ = run(100, False)
    fine, band = run(1, True)
    coarse, _ = run(1, False)
    M = np.diag(ArmPlant(arm, friction, armature=ARMATURE).mass_matrix(np.zeros(arm.n)))
    np.testing.assert_allclose(band, [max(f.Fs, f.Fc) * 1e-3 / m for f, m in zip(friction, M)], rtol=1e-12)
    assert STOP_REFINE == 10
    assert np.max(np.abs(ref[30:, 2])) < 3e-4  # the wrist has settled after 30 ms
    assert np.max(np.abs(fine - ref)[30:, 2]) < 1e-3
    assert np.max(np.abs(coarse - ref)[30:, 2]) > 2e-3


def test_the_stop_refinement_settings_are_checked():
    pytest.importorskip("pinocchio")
    from adaptive_ff.arm.lag import LagOptions
    from adaptive_ff.arm.simulate import ArmSimulation
    from controllers.experiments.compare_arm import CompareArmOptions

    assert ArmSimulation().stop_refine == 1 and CompareArmOptions().stop_refine == 1
    assert LagOptions().refine_stops == "auto" and LagOptions(refine_stops=True).refine_stops is True
    assert LagOptions(refine_stops=False).refine_stops is False
    for bad in (0, 2.5, True):
        with pytest.raises(ParameterError, match="stop_refine"):
            ArmSimulation(stop_refine=bad)
        with pytest.raises(ParameterError, match="stop_refine"):
            CompareArmOptions(stop_refine=bad)
    for bad in (1, "all", None):
        with pytest.raises(ParameterError, match="refine_stops"):
            LagOptions(refine_stops=bad)


def test_refined_joints_are_those_that_stick_below_the_stick_rule():
    """refine_stops="auto" refines the joints whose stick speed Fc Ts / J lies in [LAG_REFINE_STICK, LAG_STICK_MAX)
    (those above keep the stick rule, those below the record's step); True every joint, False none; an unknown
    stick speed (NaN) is not refined."""
    import numpy as np

    from adaptive_ff.arm.lag import LAG_REFINE_STICK, LAG_STICK_MAX, refined_joints

    assert 0.0 < LAG_REFINE_STICK < LAG_STICK_MAX
    s = np.array([0.0, np.nextafter(LAG_REFINE_STICK, 0.0), LAG_REFINE_STICK, 0.01,
                  np.nextafter(LAG_STICK_MAX, 0.0), LAG_STICK_MAX, 0.25, np.nan])
    assert refined_joints(s, "auto").tolist() == [False, False, True, True, True, False, False, False]
    assert refined_joints(s, True).tolist() == [True] * 8
    assert refined_joints(s, False).tolist() == [False] * 8
