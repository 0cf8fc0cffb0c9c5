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
