"""The plant zoo (controllers.experiments.zoo, benchmarks/zoo.py) and the random-plant spec of the sweep."""

import json
import math

import numpy as np
import pytest

from controllers.experiments.compare import CompareOptions, compare, comparison_reference
from controllers.experiments.sweep import expand_cases, load_spec
from controllers.experiments.zoo import ZOO_MODELS, ZooBox, ZooOptions, draw_plants, run_zoo, zoo_box
from plant.errors import ParameterError
from plant.models import plant_from_dict

REF = comparison_reference(CompareOptions(duration=4.0, seed=0))


def test_draw_plants_fills_the_box_and_scales_friction_to_the_torque_demand():
    specs = draw_plants(400, REF, seed=3)
    assert specs == draw_plants(400, REF, seed=3)  # seeded
    peak_w, peak_a = float(np.max(np.abs(REF.w))), float(np.max(np.abs(REF.dw)))
    box = ZooBox()
    assert {s["model"] for s in specs} == set(ZOO_MODELS)
    assert 0.3 < np.mean(["drift" in s for s in specs]) < 0.7
    deltas = np.array([s["delta"] for s in specs])
    assert np.all((deltas >= -1.0) & (deltas <= 2.5) & (np.abs(deltas) >= 0.05)) and np.any(deltas < 0)
    for s in specs:
        p = plant_from_dict(s)
        p0 = p.at(0.0) if hasattr(p, "at") else p
        assert box.J[0] <= p0.J <= box.J[1] and box.Vs[0] <= p0.Vs <= box.Vs[1]
        Fc = s.get("Fc", s.get("Fc_pos"))
        Fs = s.get("Fs", s.get("Fs_pos"))
        assert 1.0 <= Fs / Fc <= 4.0
        # friction at the peak speed (the plant's own steady-state map) over the peak torque demand
        F = float(p0.friction(peak_w))
        share = F / (p0.J * peak_a + F)
        assert box.friction_share[0] - 1e-9 <= share <= box.friction_share[1] + 1e-9
        if s["model"] != "lugre":
            tau = s["tau"]
            assert tau == 0.0 or box.tau[0] <= tau <= box.tau[1]


def test_box_and_spec_validation():
    with pytest.raises(ParameterError, match="unknown zoo box key"):
        zoo_box({"Jmax": 3})
    with pytest.raises(ParameterError, match="friction_share"):
        ZooBox(friction_share=(0.5, 1.5))
    with pytest.raises(ParameterError, match="models"):
        ZooBox(models=("coulomb",))
    with pytest.raises(ParameterError, match="n must be"):
        draw_plants(0, REF)
    with pytest.raises(ParameterError, match="unknown mode"):
        ZooOptions(modes=("none", "magic"))


def test_sweep_random_plants_spec_draws_every_model_with_all_its_keys():
    spec = load_spec({"random_plants": {"n": 12, "seed": 4, "box": {"p_drift": 1.0}}, "duration": 4.0,
                      "modes": ["none", "dob"]})
    cases = expand_cases(spec)
    assert len(cases) == 12 and len({c["id"] for c in cases}) == 12
    ref = comparison_reference(CompareOptions(duration=4.0, seed=0))
    drawn = draw_plants(12, ref, seed=4, box=zoo_box({"p_drift": 1.0}))  # the same drawing code
    assert [c["plant"] for c in cases] == drawn
    assert {c["plant"]["model"] for c in cases} == set(ZOO_MODELS) and all("drift" in c["plant"] for c in cases)
    lugre = next(c["plant"] for c in cases if c["plant"]["model"] == "lugre")
    assert {"sigma0", "sigma1", "sigma2"} <= set(lugre)
    for bad, msg in (({"n": 0}, "random_plants.n"), ({"n": 2, "box": {"J": [1, 0.5]}}, "box"),
                     ({"n": 2, "colour": 1}, "random_plants must be")):
        with pytest.raises(ParameterError, match=msg):
            load_spec({"random_plants": bad})
    with pytest.raises(ParameterError, match="cannot be combined"):
        load_spec({"random_plants": {"n": 2}, "grid": {"Fc": [1.0, 2.0]}})


def test_small_zoo_runs_and_its_table_is_consistent():
    modes = ("none", "fixed", "adaptive", "dob", "oracle", "frictionless")
    r = run_zoo(ZooOptions(n=5, duration=6.0, seed=1, modes=modes, group=3, workers=1))
    assert r.modes == tuple(m for m in r.modes if m in modes) and set(r.modes) == set(modes)
    ran = np.isfinite(r.eta["none"])
    # eta is undefined (NaN) where friction does not degrade the PI loop in this short run, or a run diverged;
    # on this draw 2 of the 5 six-second runs give a finite eta (the N = 1000 x 120 s zoo is a benchmark)
    assert ran.sum() >= 2
    for i in np.flatnonzero(ran):
        assert r.eta["none"][i] == 0.0 and r.eta["frictionless"][i] == 1.0
    q = r.quantiles()
    for m in modes:
        v = [x for x in q[m] if math.isfinite(x)]
        assert v == sorted(v)
    best = r.best_adaptive()
    np.testing.assert_array_equal(np.isfinite(best), np.isfinite(r.eta["adaptive"]))
    both = np.isfinite(r.eta["adaptive"]) & np.isfinite(r.eta["dob"])
    assert r.win_rates()["adaptive"]["dob"] == pytest.approx(np.mean(r.eta["adaptive"][both] >= r.eta["dob"][both]))
    d = r.to_dict()
    json.dumps(d, allow_nan=False)
    text = r.summary()
    assert all(m in text for m in modes) and "refused" in text.splitlines()[0]
    # a zoo joint's eta per mode equals compare() on that joint (same preparation, batch engine == single runs)
    i = int(np.flatnonzero(ran)[0])
    c = compare(plant_from_dict(r.plants[i]), duration=6.0, seed=1, modes=modes, progress=False)
    for m in modes:
        assert r.eta[m][i] == pytest.approx(c.eta[m], rel=1e-12, abs=1e-12)
