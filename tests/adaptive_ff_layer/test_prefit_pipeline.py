"""Sec. V-C end to end: simulated bidirectional constant-velocity runs -> Levenberg-Marquardt Stribeck pre-fit."""

import numpy as np
import pytest

from adaptive_ff.identification.stribeck_fit import fit_stribeck
from controllers.experiments.quasi_static import bidirectional_velocities, quasi_static_runs
from plant import preset

P = preset("paper")


@pytest.mark.parametrize("noise_std", [0.0, 1e-3])
def test_quasi_static_runs_then_lm_fit_recover_the_stribeck_curve(noise_std):
    vel = bidirectional_velocities(0.2 * P.Vs, 0.4, 10)
    qs = quasi_static_runs(P, vel, noise_std=noise_std, rng=np.random.default_rng(4))
    fit = fit_stribeck(qs.w_mean, qs.u_mean)
    tol = 1e-3 if noise_std == 0 else 0.05  # noise-free: steady state is exact; noisy: 5 %
    for name in ("Fc", "Fs", "Vs", "delta", "sigma"):
        assert getattr(fit, name) == pytest.approx(getattr(P, name), rel=tol), name
    assert fit.Vs > 0
    lo, hi = fit.confidence_intervals(0.99)["Vs"]
    assert lo > 0 and lo < hi


# ---------------------------------------------------------------- the design adapts to the joint

from controllers.experiments.compare import compare  # noqa: E402
from controllers.experiments.quasi_static import StribeckDesign, stribeck_experiment  # noqa: E402
from plant.errors import ParameterError  # noqa: E402
from plant.friction import JointParams  # noqa: E402
from plant.lugre import LuGreParams  # noqa: E402

#: stiction 5x the Coulomb level, Vs 7x smaller than the preset's: the negative slope (Fs - Fc)/Vs = 6700
#: N·m·s/rad beats the default 150 rad/s loop (Kp 520), the pre-fit used to reject its own data
DIP = JointParams(J=4.0, Fc=5.0, Fs=25.0, Vs=0.003, delta=1.0, sigma=40.0, tau=0.02)
#: no Stribeck effect at all
COULOMB = JointParams(J=4.0, Fc=25.0, Fs=25.0, Vs=0.02, delta=1.0, sigma=40.0, tau=0.02)
#: stiff LuGre on a small inertia (sigma0 the integrator handles; mechanical mode sqrt(sigma0/J) = 4500 rad/s):
#: the loops of J = 0.05 cannot hold speeds on the negative slope (Kp <= 13 vs (Fs-Fc)/Vs = 500)
STIFF_LUGRE = LuGreParams(J=0.05, Fc=25.0, Fs=35.0, Vs=0.02, delta=2.0, sigma0=1e6, sigma1=224.0, sigma2=40.0)


def test_deep_narrow_dip_is_measured_with_the_stiffer_loop_and_fitted_through_compare():
    comp = compare(DIP, duration=3.0, seed=0, modes=("adaptive",), progress=False)
    f = comp.prefit
    assert f.fallback is None
    # stated tolerances (noise 1e-3 rad/s; the slowest held run is at 1.4 Vs, Fs is extrapolated): Vs 12 %,
    # delta 15 %, Fs 15 %; the fitted map matches the true one within 2 % over the speeds it was measured on
    assert f.Vs == pytest.approx(DIP.Vs, rel=0.12)
    assert f.delta == pytest.approx(DIP.delta, rel=0.15)
    assert f.Fs == pytest.approx(DIP.Fs, rel=0.15)
    wg = np.geomspace(1.4 * DIP.Vs, 0.5, 50)
    np.testing.assert_allclose(f.friction(wg), DIP.friction(wg), rtol=0.02)
    assert f.Fc == pytest.approx(DIP.Fc, rel=0.02)
    ex = comp.experiment
    assert np.any(ex.crossover[ex.held] > 150.0)  # runs only the stiffer loop could hold were used
    assert any("repeated at 300" in n for n in comp.notes)
    # every held run is on the true curve (1 % of the level): the held/not-held test keeps only support points
    F = DIP.friction(ex.setpoints[ex.held])
    np.testing.assert_allclose(ex.u_mean[ex.held], F, rtol=0.03, atol=0.05 * DIP.Fc)


def test_no_stribeck_effect_falls_back_to_coulomb_viscous_with_a_note():
    comp = compare(COULOMB, duration=3.0, seed=0, modes=("adaptive",), progress=False)
    f = comp.prefit
    assert f.fallback == "coulomb-viscous"
    assert f.Fs == f.Fc == pytest.approx(COULOMB.Fc, rel=0.005)
    assert f.sigma == pytest.approx(COULOMB.sigma, rel=0.005)
    assert any("Coulomb + viscous" in n for n in comp.notes)
    assert "note:" in comp.summary()
    assert comp.to_dict()["prefit"]["fallback"] == "coulomb-viscous"


def test_stiff_lugre_degrades_to_coulomb_viscous_instead_of_a_singular_failure():
    comp = compare(STIFF_LUGRE, duration=2.0, seed=0, modes=("adaptive",), progress=False)
    f = comp.prefit
    assert f.fallback == "coulomb-viscous"
    # the sliding branch it measured: Fc + sigma2*w above the transition
    assert f.Fc == pytest.approx(STIFF_LUGRE.Fc, rel=0.01)
    assert f.sigma == pytest.approx(STIFF_LUGRE.sigma2, rel=0.02)
    assert any("did not hold" in n for n in comp.notes)
    assert np.isfinite(comp.eta["adaptive"])


def test_modes_without_prefit_never_run_it_and_given_factors_replace_it():
    comp = compare(DIP, duration=2.0, seed=0, modes=("none", "dob", "oracle"), progress=False)
    assert comp.prefit is None and comp.experiment.fit is None and comp.notes == ()
    comp = compare(DIP, duration=2.0, seed=0, modes=("adaptive",), Vs=0.003, delta=1.0, progress=False)
    assert comp.prefit is None and comp.model.Vs == 0.003
    with pytest.raises(ParameterError, match="need Vs and delta"):
        compare(DIP, duration=2.0, modes=("adaptive",), prefit=False, progress=False)
    with pytest.raises(ParameterError, match="both Vs and delta"):
        compare(DIP, duration=2.0, modes=("adaptive",), Vs=0.003, progress=False)


def test_stribeck_design_validates():
    with pytest.raises(ParameterError, match="w_max"):
        StribeckDesign(w_min=1.0, w_max=0.5)
    with pytest.raises(ParameterError, match="per_decade"):
        StribeckDesign(per_decade=0)
    with pytest.raises(ParameterError, match="J_design"):
        stribeck_experiment(P, J_design=0.0)
    with pytest.raises(ParameterError, match="rng"):
        stribeck_experiment(P, J_design=4.0, noise_std=1e-3)


def test_stribeck_experiment_noise_free_preset_and_result_protocol():
    import json

    ex = stribeck_experiment(P, J_design=P.J, options=StribeckDesign(w_min=1e-3, w_max=0.5, per_decade=2))
    for name in ("Fc", "Fs", "Vs", "delta", "sigma"):
        assert getattr(ex.fit, name) == pytest.approx(getattr(P, name), rel=2e-3), name
    json.dumps(ex.to_dict(), allow_nan=False)
    assert "held" in ex.summary()
    assert ex.torque_scale == pytest.approx(float(np.max(np.abs(P.friction(ex.setpoints)))), rel=1e-3)
