"""The plant zoo (controllers.experiments.zoo, benchmarks/zoo.py) and the random-plant spec of the sweep."""

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from adaptive_ff.compensation.feedforward import project_estimate
from controllers.experiments.compare import CompareOptions, compare, comparison_reference, prepare_comparison
from controllers.experiments.sweep import expand_cases, load_spec
from controllers.experiments.zoo import (ZOO_MODELS, ZooBox, ZooOptions, ZooResult, draw_plants, run_zoo, zoo_box,
                                      zoo_options_dict)
from plant.errors import ParameterError
from plant.models import plant_from_dict

REF = comparison_reference(CompareOptions.from_flat(duration=4.0, seed=0))


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
        ZooOptions.from_flat(modes=("none", "magic"))


def test_sweep_random_plants_spec_draws_every_model_with_all_its_keys():
    spec = load_spec({"random_plants": {"n": 12, "seed": 4, "box": {"p_drift": 1.0}}, "duration": 4.0,
                      "modes": ["none", "dob"]})
    cases = expand_cases(spec)
    assert len(cases) == 12 and len({c["id"] for c in cases}) == 12
    ref = comparison_reference(CompareOptions.from_flat(duration=4.0, seed=0))
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
    r = run_zoo(ZooOptions.from_flat(n=4, duration=6.0, seed=2, modes=modes, group=3, workers=1))
    assert r.modes == tuple(m for m in r.modes if m in modes) and set(r.modes) == set(modes)
    # this short run reverses in its second half: friction degrades every joint's loop, eta is defined everywhere
    assert all(c == {"ok": 4, "refused": 0, "diverged": 0, "undefined": 0, "no reference": 0, "invalid": 0}
               for c in r.counts().values())
    assert np.all(r.degradation() > 0.04)
    np.testing.assert_array_equal(r.eta["none"], 0.0)
    np.testing.assert_array_equal(r.eta["frictionless"], 1.0)
    q = r.quantiles()
    for m in modes:
        assert q[m] == sorted(q[m]) and q[m][0] == np.min(r.eta[m]) and q[m][-1] == np.max(r.eta[m])
    np.testing.assert_array_equal(r.best_adaptive(), r.eta["adaptive"])
    assert r.win_rates()["adaptive"]["dob"] == pytest.approx(np.mean(r.eta["adaptive"] >= r.eta["dob"]))
    t = r.targets()
    assert t["refused"] == t["diverged"] == 0 and t["best_not_positive"] == [i for i in range(4) if r.eta["adaptive"][i] <= 0]
    assert t["best_below_dob"] == [i for i in range(4) if r.eta["adaptive"][i] < r.eta["dob"][i]]
    d = r.to_dict()
    json.dumps(d, allow_nan=False)
    assert d["status"]["adaptive"] == ["ok"] * 4
    text = r.summary()
    assert all(m in text for m in modes) and "refused" in text.splitlines()[0] and "targets:" in text
    # a zoo joint's eta per mode equals compare() on that joint (same preparation, batch engine == single runs)
    c = compare(plant_from_dict(r.plants[1]), duration=6.0, seed=2, modes=modes, progress=False)
    for m in modes:
        assert r.eta[m][1] == pytest.approx(c.eta[m], rel=1e-12, abs=1e-12)
        assert r.rms[m][1] == pytest.approx(c.results[m].metrics.rms_second_half, rel=1e-12)


def test_eta_is_undefined_where_friction_does_not_degrade_the_loop_and_reported_as_such():
    # seed 1, 6 s: the reference does not reverse in the second half (|w_ref| >= 0.06 rad/s there), the PI
    # integrator absorbs the friction and the uncompensated loop tracks within 1 % of the frictionless one: eta,
    # a ratio over that difference, is undefined (it used to come out NaN or as a meaningless 5.1)
    ref = comparison_reference(CompareOptions.from_flat(duration=6.0, seed=1))
    assert np.min(np.abs(ref.w[ref.w.size // 2:])) > 0.06
    modes = ("none", "dob", "frictionless")  # no pre-fit: a second or two
    r = run_zoo(ZooOptions.from_flat(n=3, duration=6.0, seed=1, modes=modes, workers=1))
    assert np.all(np.isfinite(r.rms["none"])) and np.all(np.abs(r.degradation()) < 0.01)
    for m in modes:
        assert list(r.status(m)) == ["undefined"] * 3 and r.counts()[m]["undefined"] == 3
        assert np.all(np.isnan(r.eta[m]))
    d = r.to_dict()
    json.dumps(d, allow_nan=False)
    assert d["eta"]["dob"] == [None] * 3 and d["quantiles"]["dob"] == [None] * 7 and d["targets"]["undefined"] == [0, 1, 2]
    assert "3 with eta undefined" in r.summary()
    # with the threshold at 0 eta is compare's number wherever the denominator is positive
    r0 = run_zoo(ZooOptions.from_flat(n=3, duration=6.0, seed=1, modes=modes, workers=1, min_degradation=0.0))
    for i in range(3):
        den = r0.rms["none"][i] - r0.rms["frictionless"][i]
        want = (r0.rms["none"][i] - r0.rms["dob"][i]) / den if den > 0 else math.nan
        np.testing.assert_equal(r0.eta["dob"][i], want)
        assert r0.status("dob")[i] == ("ok" if den > 0 else "undefined")


def test_status_counts_every_failure_apart():
    n = 5
    nan = math.nan
    rms = {"none": np.array([2.0, 2.0, 2.0, nan, 2.0]), "fixed": np.array([1.5, nan, nan, 1.5, 1.5]),
           "frictionless": np.array([1.0, 1.0, 1.0, 1.0, 1.005])}
    div = {"none": np.array([False, False, False, True, False]), "fixed": np.array([False, True, False, False, False]),
           "frictionless": np.zeros(n, dtype=bool)}
    r = ZooResult(plants=[{"model": "karnopp"}] * n, modes=("none", "fixed", "frictionless"),
                  eta={m: np.full(n, nan) for m in rms}, rms=rms, refused={}, mode_refused={"fixed": {2: "no fit"}},
                  diverged=div, min_degradation=0.01, seconds=0.0)
    r.eta["fixed"][0] = 0.5
    r.eta["none"][[0, 1, 2, 4]] = 0.0
    assert list(r.status("fixed")) == ["ok", "diverged", "refused", "no reference", "invalid"]
    assert list(r.status("none")) == ["ok", "ok", "ok", "diverged", "ok"]
    np.testing.assert_allclose(r.degradation(), [1.0, 1.0, 1.0, nan, 2.0 / 1.005 - 1.0])
    assert r.counts()["fixed"] == {"ok": 1, "refused": 1, "diverged": 1, "undefined": 0, "no reference": 1,
                                   "invalid": 1}
    assert r.targets()["refused"] == 1 and r.targets()["diverged"] == 2
    r.notes[4] = ["a pre-fit note", "fixed: the offline fit of the identification run was rejected (...)"]
    assert r.fixed_fallbacks() == [4] and "offline fit rejected on 1 joint(s)" in r.summary()
    assert r.to_dict()["notes"] == {"4": r.notes[4]}


def test_dask_scheduler_gives_the_numbers_of_the_default_path():
    pytest.importorskip("dask")
    from dask.distributed import Client

    o = ZooOptions.from_flat(n=2, duration=3.0, seed=2, modes=("none", "dob", "frictionless"), workers=1)
    base = run_zoo(o)
    sync = run_zoo(ZooOptions(**{**o.__dict__, "scheduler": "synchronous"}))
    # dashboard_address=":0": a free port (None still binds the default 8787: a port in use makes distributed warn)
    with Client(processes=False, n_workers=1, threads_per_worker=1, dashboard_address=":0") as client:
        dist = run_zoo(ZooOptions(**{**o.__dict__, "scheduler": client}))
    assert np.all(np.isfinite(base.rms["dob"]))
    for r in (sync, dist):
        assert r.plants == base.plants
        for m in base.modes:
            np.testing.assert_array_equal(r.rms[m], base.rms[m])
            np.testing.assert_array_equal(r.eta[m], base.eta[m])


def test_fixed_falls_back_to_the_prefit_map_where_its_offline_fit_is_rejected():
    # a light Karnopp joint of the zoo drawn for a 20 s run (seed 0; J 0.068 kg·m², Fc 0.025 N·m, Fs 0.079 N·m):
    # with its exact inertia as the data sheet's the offline fit of its identification run gives Fs = 0.24 N·m,
    # above half the actuator range (0.20 N·m), so `fixed` takes the pre-fit's map
    co = CompareOptions.from_flat(duration=20.0, seed=0, modes=("none", "fixed", "frictionless"))
    spec = draw_plants(91, comparison_reference(co), seed=0)[90]
    co = co.replace(J_design=spec["J"])
    assert spec["model"] == "karnopp"
    p = plant_from_dict(spec)
    s = prepare_comparison(p, co)
    mo = s.mode_options["fixed"]
    assert project_estimate(s.offline.estimate, F_max=0.5 * mo.drive.u_max) is None
    f, e = s.prefit, mo.feedforward.estimate
    # the pre-fit's static map, no lag (the lag would come from the rejected fit), the design inertia
    assert (e.Fc, e.Fs, e.sigma, e.Vs, e.delta, e.tau, e.J, e.offset) == (f.Fc, f.Fs, f.sigma, f.Vs, f.delta, 0.0,
                                                                          s.J_design, 0.0)
    assert f.Fc == pytest.approx(spec["Fc"], rel=0.02) and f.Fs == pytest.approx(spec["Fs"], rel=0.02)
    assert [n for n in s.notes if n.startswith("fixed:")] == [
        n for n in s.notes if "offline fit of the identification run was rejected" in n and "static map" in n]
    assert len([n for n in s.notes if n.startswith("fixed:")]) == 1
    c = compare(p, co, progress=False)
    assert c.notes[:len(s.notes)] == s.notes  # then the runs' own notes (here: fixed's eta above 1)
    # measured 1.067 with the joint's exact inertia as the design inertia
    assert c.eta["fixed"] > 0.95


def test_groups_partition_the_joints_and_shrink_towards_the_end():
    """Guided self-scheduling of the zoo's tasks: every joint in exactly one task, in order, at most ``group``
    per task, sizes never growing, the last task a single joint (no worker left alone with a long group)."""
    from controllers.experiments import zoo

    for n, group, workers in [(1000, 8, 2), (37, 8, 4), (5, 8, 2), (1, 8, 1), (0, 8, 2)]:
        b = zoo._group_bounds(n, group, workers)
        assert [j for a, c in b for j in range(a, c)] == list(range(n))
        sizes = [c - a for a, c in b]
        assert all(1 <= s <= group for s in sizes) and sizes == sorted(sizes, reverse=True)
        assert n == 0 or sizes[-1] == 1
    assert [c - a for a, c in zoo._group_bounds(1000, 8, 2)][121:] == [8, 6, 5, 4, 3, 2, 1, 1, 1, 1]  # ceil(rest/4)


def test_a_zoo_on_a_point_to_point_reference_with_an_encoder_is_compare_on_each_joint():
    """ZooOptions.from_flat(reference=, encoder_counts=, delay=): every joint's numbers are compare()'s with the same
    settings (batch engine with sensors == single runs), and the joints are drawn for that reference."""
    from plant.motion import point_to_point_reference

    ref = point_to_point_reference([0.4, -0.2, 0.3], v_max=0.5, a_max=4.0, dwell=0.4)
    modes = ("none", "adaptive", "dob", "frictionless")
    o = ZooOptions.from_flat(n=3, seed=4, modes=modes, reference=ref, encoder_counts=2 ** 16, delay=1, workers=1)
    assert o.duration == pytest.approx(ref.t.shape[0] * 1e-3)
    r = run_zoo(o)
    assert r.plants == draw_plants(3, ref, seed=4)
    json.dumps(r.to_dict(), allow_nan=False)
    d = json.loads(json.dumps(zoo_options_dict(o), allow_nan=False))
    assert d["reference"] == {"samples": ref.t.shape[0], "stops": 3, "reversals": 0}
    assert d["compare"]["encoder_counts"] == 65536
    assert not r.refused, r.refused  # a 3.7 s identification run too short to fit: fixed/the start fall back
    for j in (0, 2):
        c = compare(plant_from_dict(r.plants[j]), reference=ref, encoder_counts=2 ** 16, delay=1, seed=4, modes=modes,
                    progress=False)
        for m in modes:
            assert r.rms[m][j] == pytest.approx(c.results[m].metrics.rms_second_half, rel=1e-12), (j, m)


def test_own_compensators_run_on_every_zoo_joint_in_worker_processes(tmp_path, monkeypatch):
    """ZooOptions(compensators=) by file path: resolved in each worker, one run per joint, eta beside the modes,
    equal to compare() on that joint with the same factory."""
    import importlib.util

    (tmp_path / "zero_ff.py").write_text(
        "class Zero:\n"
        "    def __init__(self, ctx):\n"
        "        pass\n"
        "    def compensate(self, w_meas, w_ref):\n"
        "        return 0.0\n"
        "    def observe(self, u, w_meas):\n"
        "        pass\n", encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    modes = ("none", "adaptive", "frictionless")
    r = run_zoo(ZooOptions.from_flat(n=3, duration=6.0, seed=2, modes=modes, workers=2, group=1,
                           compensators={"zero": "zero_ff.py:Zero"}))
    assert r.modes == modes + ("zero",)
    np.testing.assert_array_equal(r.rms["zero"], r.rms["none"])  # no compensation is `none`, bit for bit
    np.testing.assert_array_equal(r.eta["zero"], 0.0)
    with pytest.raises(ParameterError, match=r"\[compensators.x\] factory = 'no_such_file.py:Zero': no such file"):
        ZooOptions.from_flat(n=1, compensators={"x": "no_such_file.py:Zero"})


def test_a_design_inertia_off_by_a_factor_is_compare_with_that_J_design_on_each_joint():
    # ZooOptions(J_design_factor=2): every joint designed with twice its inertia, as compare(J_design=2*J) on it
    modes = ("none", "adaptive", "frictionless")
    r = run_zoo(ZooOptions.from_flat(n=2, duration=6.0, seed=2, modes=modes, workers=1, J_design_factor=2.0))
    plain = run_zoo(ZooOptions.from_flat(n=2, duration=6.0, seed=2, modes=modes, workers=1))
    for j in range(2):
        p = plant_from_dict(r.plants[j])
        c = compare(p, duration=6.0, seed=2, modes=modes, progress=False, J_design=2.0 * p.J)
        for m in modes:
            assert r.rms[m][j] == pytest.approx(c.results[m].metrics.rms_second_half, rel=1e-12)
        assert r.rms["adaptive"][j] != plain.rms["adaptive"][j]  # the design inertia reached the runs
        # the default zoo identifies each joint's design inertia, as compare's default does on it
        c0 = compare(p, duration=6.0, seed=2, modes=modes, progress=False)
        assert c0.inertia is not None
        for m in modes:
            assert plain.rms[m][j] == pytest.approx(c0.results[m].metrics.rms_second_half, rel=1e-12)
    assert ZooOptions().J_design_factor is None
    assert zoo_options_dict(ZooOptions(J_design_factor=2.0))["J_design_factor"] == 2.0  # on the benchmark page
    for bad in (0.0, -1.0, math.inf, math.nan):
        with pytest.raises(ParameterError, match="J_design_factor"):
            ZooOptions.from_flat(J_design_factor=bad)


def test_observers_take_the_identified_inertia_where_the_design_inertia_is_contradicted():
    # paper preset designed for twice its inertia: the identification run finds 4.08 kg·m² (true 4), the observers
    # take it and say so; with the design inertia (8) as their nominal one dob and adaptive-dob track worse
    # (measured 30 s, seed 0: dob 0.931 against 0.788, adaptive-dob 0.996 against 0.833)
    from dataclasses import replace

    from controllers.experiments.compare import J_CONTRADICTED, observer_inertia
    from controllers.simulation.closed_loop import run_mode
    from plant.friction import preset

    p = preset("paper")
    s = prepare_comparison(p, CompareOptions.from_flat(duration=30.0, seed=0, modes=("none", "fixed", "dob", "adaptive-dob"),
                                             J_design=2.0 * p.J))
    s.bar.close()
    J_n = s.mode_options["dob"].observer.J_n
    assert J_n == s.offline.estimate.J and abs(J_n / p.J - 1.0) < 0.05
    assert all(o.observer.J_n == J_n for o in s.mode_options.values())
    (note,) = [n for n in s.notes if n.startswith("the design inertia 8 kg·m² is ")]
    assert f"{J_n:.4g} kg·m² of the identification run" in note

    def eta_of(mode, **kw):
        r = {m: run_mode(p, s.reference, m, s.mode_options[m].replace(**(kw if m == mode else {})),
                         rng=np.random.default_rng(s.noise_seed)).metrics.rms_second_half
             for m in ("none", "frictionless", mode)}
        return (r["none"] - r[mode]) / (r["none"] - r["frictionless"])

    for mode in ("dob", "adaptive-dob"):
        assert eta_of(mode) > eta_of(mode, J_n=None) + 0.1
    # the rule itself: contradicted beyond J_CONTRADICTED either way, never without an accepted estimate
    est = s.offline.estimate
    assert observer_inertia(est.J, est) is None and observer_inertia(est.J * J_CONTRADICTED * 0.99, est) is None
    assert observer_inertia(est.J * J_CONTRADICTED * 1.01, est) == est.J
    assert observer_inertia(est.J / (J_CONTRADICTED * 1.01), est) == est.J
    assert observer_inertia(8.0, None) is None and observer_inertia(8.0, replace(est, J=math.nan)) is None
    # with the right design inertia nothing changes
    s1 = prepare_comparison(p, CompareOptions.from_flat(duration=30.0, seed=0, modes=("none", "fixed", "dob")))
    s1.bar.close()
    assert s1.mode_options["dob"].observer.J_n is None and not [n for n in s1.notes if "design inertia" in n]


def test_a_zoo_without_the_switch_in_is_compare_with_switch_in_false_on_each_joint():
    # ZooOptions switch_in=False: mode adaptive as the feedforward alone (what export-c writes for a drive), as
    # compare(switch_in=False) on each joint; zoo seed 1's joint #0 is one where the residual observer switches in
    # within 10 s, so the option reaches the runs
    modes = ("none", "adaptive", "frictionless")
    # the joint's exact inertia (J_design_factor 1): with the identified one it does not switch in within 10 s
    o = ZooOptions.from_flat(n=1, duration=10.0, seed=1, modes=modes, workers=1, switch_in=False, J_design_factor=1.0)
    assert o.compare_options().loop.observer.switch_in is False
    assert ZooOptions().compare_options().loop.observer.switch_in is True
    r = run_zoo(o)
    p = plant_from_dict(r.plants[0])
    bare = compare(p, duration=10.0, seed=1, modes=modes, progress=False, switch_in=False, J_design=p.J)
    full = compare(p, duration=10.0, seed=1, modes=modes, progress=False, J_design=p.J)
    assert "t_switch_in" not in bare.results["adaptive"].info and "t_switch_in" in full.results["adaptive"].info
    for m in modes:
        assert r.rms[m][0] == pytest.approx(bare.results[m].metrics.rms_second_half, rel=1e-12)
    assert r.rms["adaptive"][0] != full.results["adaptive"].metrics.rms_second_half
    assert zoo_options_dict(o)["compare"]["switch_in"] is False  # on the benchmark page
    for bad in (0, "no", None):
        with pytest.raises(ParameterError, match="switch_in"):
            ZooOptions.from_flat(switch_in=bad)


def test_a_zoo_placed_into_a_scenario_is_compare_on_each_joint_with_the_scenarios_settings():
    """ZooOptions(compare=scenario.options): every joint runs with the scenario's reference, sensor and controller, its
    own torque limit and design inertia (compare() with the scenario's options, u_max and J_design left to the
    joint); the largest errors are compare()'s second-half maxima and tracking_harm compares them as it says."""
    from dataclasses import replace
    from pathlib import Path

    from controllers.experiments.scenario import load_scenario

    sc = load_scenario(Path(__file__).resolve().parents[2] / "examples" / "scenarios" / "linear_axis.toml")
    modes = ("none", "adaptive", "frictionless")
    assert sc.options.loop.drive.u_max == 300.0  # the scenario's own torque limit: each joint has its own
    o = ZooOptions.from_flat(n=2, seed=5, modes=modes, compare=sc.options, workers=1)
    assert o.duration == pytest.approx(sc.options.reference.t.shape[0] * 1e-3)
    co = o.compare_options()
    assert co.reference is sc.options.reference and co.loop.drive.u_max is None and co.crossover == sc.options.crossover
    assert (co.loop.sensor, co.seed) == (sc.options.loop.sensor, 5)
    r = run_zoo(o)
    assert r.plants == draw_plants(2, sc.options.reference, seed=5)
    json.loads(json.dumps(zoo_options_dict(o), allow_nan=False))
    for j in range(2):
        c = compare(plant_from_dict(r.plants[j]), sc.options.replace(seed=5, modes=modes, u_max=None,
                                                          compensators=None), progress=False)
        for m in modes:
            assert r.rms[m][j] == pytest.approx(c.results[m].metrics.rms_second_half, rel=1e-12), (j, m)
            assert r.max_error[m][j] == pytest.approx(c.results[m].metrics.max_second_half, rel=1e-12), (j, m)
    fake = replace(r, max_error={"none": np.array([1.0, 1.0]), "frictionless": np.array([0.4, 0.7]),
                                 "adaptive": np.array([1.01, 1.3])})
    assert fake.tracking_harm() == {"adaptive": [0]}  # bounds 1.0 and 1.4
    assert fake.targets()["tracking_harm"] == {"adaptive": [0]}


def test_a_zoo_through_a_compiled_export_gives_the_packages_numbers(tmp_path):
    # ZooOptions(export=DIR): mode adaptive on every joint runs the export folder's C, compiled in the worker and
    # configured per joint by its own aff_init; the numbers are the package's, bit for bit
    import shutil

    from adaptive_ff.compensation.export_c import JointExport, export_c
    from controllers import LoopConfig, design_pi
    from controllers.simulation.compensators import build_mode
    from plant.friction import preset

    if shutil.which("cc") is None:
        pytest.skip("no C compiler")
    p = preset("paper")
    d = design_pi(p.J, crossover=20.0, phase_margin=60.0, Tc=1e-3)
    _, _, comp = build_mode(p, "adaptive", LoopConfig.from_flat(Kp=d.Kp, Ki=d.Ki, u_max=150.0, Vs=p.Vs, delta=p.delta,
                                                       J_design=p.J))
    export_c(JointExport(compensator=comp, J_design=p.J, u_max=150.0, Kp=d.Kp, Ki=d.Ki), tmp_path / "drive_ff")
    modes = ("none", "adaptive", "frictionless")
    pkg = run_zoo(ZooOptions.from_flat(n=3, duration=10.0, seed=1, modes=modes, workers=1))
    exp = run_zoo(ZooOptions.from_flat(n=3, duration=10.0, seed=1, modes=modes, workers=1,
                                       export=tmp_path / "drive_ff"))
    for m in modes:
        np.testing.assert_array_equal(exp.rms[m], pkg.rms[m])
    assert np.isfinite(exp.rms["adaptive"]).all()
    with pytest.raises(ParameterError, match="not an export-c folder"):
        ZooOptions.from_flat(export=tmp_path)
