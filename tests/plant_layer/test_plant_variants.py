"""Plant variants: LuGre, Karnopp stick band, asymmetric friction, drift; the model registry and JSON files."""

import json
import math

import numpy as np
import pytest

from controllers.experiments.quasi_static import quasi_static_runs
from plant import JointParams, ParameterError, preset, simulate
from plant.asymmetric import AsymmetricParams
from plant.drift import FrictionDrift
from plant.joint import make_rk4_step
from plant.karnopp import KarnoppParams
from plant.lugre import LuGreParams
from plant.models import MODELS, load_plant, plant_from_dict, plant_to_dict
from plant.variant_plants import VARIANT_NAMES, drift_case, variant

LUGRE = variant("lugre")


def _hold(step, u, n, w=0.0, s=0.0):
    for _ in range(n):
        w, s = step(w, s, u)
    return w, s


def test_lugre_steady_sliding_equals_the_stribeck_map():
    """At constant velocity dz/dt = 0, z = g(w)/sigma0 and f = g(w) + sigma2*w (Canudas de Wit et al. 1995)."""
    for w0 in (0.005, 0.02, 0.3, -0.1):
        z = LUGRE.initial_state(w0)
        assert z == pytest.approx(math.copysign(float(LUGRE.g(w0)), w0) / LUGRE.sigma0)
        assert LUGRE.friction_torque(w0, z) == pytest.approx(float(LUGRE.friction(w0)), rel=1e-12)
    # the joint driven by u = F(w0) from the steady state stays there (RK4 at 1 kHz)
    w0 = 0.1
    u = float(LUGRE.friction(w0))
    w, z = _hold(LUGRE.make_step(1e-3), u, 2000, w0, LUGRE.initial_state(w0))
    assert w == pytest.approx(w0, rel=1e-6)


def test_lugre_presliding_is_a_spring_below_breakaway():
    """A torque well below Fc deflects the bristles like a spring: displacement -> u/sigma0, no sliding."""
    step = LUGRE.make_step(1e-3)
    u = 0.3 * LUGRE.Fc
    w, z, x = 0.0, 0.0, 0.0
    xs = []
    for _ in range(3000):
        w_new, z = step(w, z, u)
        x += 0.5 * (w + w_new) * 1e-3
        w = w_new
        xs.append(x)
    assert abs(w) < 1e-6
    # at rest sigma0*z balances u; the position stays within a few bristle deflections (the transient's
    # micro-slip, a known LuGre effect) and no longer moves: no sliding
    assert z == pytest.approx(u / LUGRE.sigma0, rel=1e-3)
    assert u / LUGRE.sigma0 < x < 2 * u / LUGRE.sigma0
    assert abs(xs[-1] - xs[1500]) < 1e-9


def test_lugre_substeps_keep_fast_motion_stable():
    p = LUGRE.replace(sigma0=1e6, sigma1=2000.0)  # much stiffer bristles
    r = simulate(p, np.full(2000, 100.0))
    assert np.all(np.isfinite(r.w)) and r.w[-1] > 0
    # terminal velocity where F(w) = 100 N·m
    assert float(p.friction(r.w[-1])) == pytest.approx(100.0, rel=1e-3)


def test_karnopp_sticks_below_Fs_and_breaks_away_above():
    p = variant("karnopp")
    step = p.make_step(1e-3)
    w, f = _hold(step, 0.9 * p.Fs, 500)
    assert w == 0.0 and f == 0.9 * p.Fs  # stuck: friction balances the torque exactly
    w, f = _hold(step, 1.1 * p.Fs, 500, w, f)
    assert w > 10 * p.dv  # broke away
    # decelerating through the band under a small torque: it sticks instead of creeping through zero
    w, f = _hold(step, 0.5 * p.Fc, 3000, w, f)
    assert w == 0.0


def test_karnopp_outside_the_band_equals_the_lagged_joint():
    p = variant("karnopp")
    base = make_rk4_step(p.lagged(), 1e-3)
    step = p.make_step(1e-3)
    for w, f, u in ((0.2, 30.0, 40.0), (-0.05, -28.0, -10.0)):
        assert step(w, f, u) == base(w, f, u)


def test_asymmetric_map_and_its_symmetric_limit():
    p = variant("asymmetric")
    assert float(p.friction(0.3)) == pytest.approx(p.Fc_pos + (p.Fs_pos - p.Fc_pos) * math.exp(-0.3 / p.Vs)
                                                  + p.sigma_pos * 0.3)
    assert float(p.friction(-0.3)) == pytest.approx(-(p.Fc_neg + (p.Fs_neg - p.Fc_neg) * math.exp(-0.3 / p.Vs))
                                                   - p.sigma_neg * 0.3)
    q = preset("paper")
    sym = AsymmetricParams(J=q.J, Fc_pos=q.Fc, Fc_neg=q.Fc, Fs_pos=q.Fs, Fs_neg=q.Fs, Vs=q.Vs, delta=q.delta,
                           sigma_pos=q.sigma, sigma_neg=q.sigma, tau=q.tau)
    u = np.sin(np.linspace(0, 20, 3000)) * 60.0
    np.testing.assert_array_equal(simulate(sym, u).w, simulate(q, u).w)


def test_drift_ramps_Fc_and_Fs_and_keeps_the_rest():
    d = drift_case(120.0)
    assert d.at(0.0) == preset("paper")
    mid, end, after = d.at(30.0), d.at(60.0), d.at(100.0)
    assert (mid.Fc, mid.Fs) == pytest.approx((25.0 * 1.25, 35.0 * 1.25))
    assert (end.Fc, end.Fs) == pytest.approx((37.5, 52.5)) and after == end
    assert (end.J, end.tau, end.sigma) == (4.0, 0.02, 40.0)
    a = FrictionDrift(variant("asymmetric"), Fc_change=0.5, Fs_change=0.0, t_end=10.0).at(10.0)
    assert (a.Fc_pos, a.Fc_neg, a.Fs_neg) == pytest.approx((37.5, 27.0, 25.0))
    with pytest.raises(ParameterError, match="t_end"):
        FrictionDrift(preset("paper"), t_start=5.0, t_end=5.0)


@pytest.mark.parametrize("name", VARIANT_NAMES)
def test_every_variant_round_trips_through_json(tmp_path, name):
    p = variant(name)
    d = plant_to_dict(p)
    assert d["model"] == p.MODEL
    f = tmp_path / "p.json"
    f.write_text(json.dumps(d))
    assert load_plant(f) == p
    drifting = plant_from_dict({**d, "drift": {"Fc_change": 0.3}})
    assert isinstance(drifting, FrictionDrift) and drifting.base == p
    assert plant_to_dict(drifting)["drift"]["Fc_change"] == 0.3


def test_model_key_defaults_and_errors():
    q = preset("paper")
    assert plant_from_dict(q.to_dict()) == q  # no "model": the paper's lagged Stribeck joint
    assert JointParams.from_dict({**q.to_dict(), "model": "lagged-stribeck"}) == q
    assert set(MODELS) == {"lagged-stribeck", "lugre", "karnopp", "asymmetric"}
    with pytest.raises(ParameterError, match="unknown friction model 'dahl'"):
        plant_from_dict({"model": "dahl"})
    with pytest.raises(ParameterError, match=r"miss the key\(s\) \['sigma1'\]"):
        plant_from_dict({"model": "lugre", "J": 1, "Fc": 1, "Fs": 2, "Vs": 0.1, "delta": 2, "sigma0": 1e4,
                         "sigma2": 0})
    with pytest.raises(ParameterError, match="sigma0 must be > 0"):
        LuGreParams(J=1, Fc=1, Fs=2, Vs=0.1, delta=2, sigma0=0.0, sigma1=1, sigma2=0)
    with pytest.raises(ParameterError, match="dv must be > 0"):
        KarnoppParams(**{**q.to_dict(), "dv": 0.0})
    with pytest.raises(ParameterError, match="is not 'lugre'"):
        LuGreParams.from_dict({**LUGRE.to_dict(), "model": "karnopp"})
    with pytest.raises(ParameterError, match="plant.models"):
        JointParams.from_dict({**q.to_dict(), "model": "lugre"})


def test_quasi_static_runs_accept_any_plant_model():
    """The Sec. V-C experiment on the LuGre variant lands on its steady-state Stribeck map."""
    v = np.array([-0.2, -0.05, 0.01, 0.05, 0.2])
    qs = quasi_static_runs(LUGRE, v, hold=0.5, settle=1.5)
    np.testing.assert_allclose(qs.u_mean, LUGRE.friction(qs.w_mean), rtol=2e-3)
