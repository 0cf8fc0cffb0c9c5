"""Tests of the engine's whole-batch setters behind run_batch (EngineRun.set_plants, set_pi_all, the column reads of
outcome() and metrics()): each leaves the scenarios' structs byte for byte as the per-scenario setters do, and a
batch that mixes a drifting plant (the per-scenario path) with fixed ones gives each scenario its single run's
numbers."""

import math

import numpy as np
import pytest

from controllers._cctl import ffi
from controllers.design.pi import PIController
from controllers.simulation.batch import run_batch
from controllers.simulation.closed_loop import LoopConfig, run_mode
from controllers.simulation.engine import EngineRun
from plant.drift import FrictionDrift
from plant.errors import ParameterError
from plant.excitation import multisine_reference
from plant.friction import preset
from plant.rows import plant_rows, plant_state, plant_states


def _plants():
    p = preset("paper")
    return [p, p.replace(J=1.2 * p.J, tau=0.5 * p.tau), p.replace(Fc=0.8 * p.Fc)]


def _engine(B, ref):
    return EngineRun(t=ref.t, w_ref=ref.w, dt=1e-3, n_scenarios=B)


def _bytes(x):
    return bytes(ffi.buffer(x.scenarios))


def test_set_plants_and_set_pi_all_equal_the_per_scenario_setters_byte_for_byte():
    ref = multisine_reference(0.05, rng=np.random.default_rng(0))
    plants = _plants()
    rows = plant_rows(plants)
    st = plant_states(rows, float(ref.w[0]))
    index = [2, 0, 1, 2]
    limits = [5.0, 6.0, 7.0, math.inf]
    pi = PIController(Kp=3.0, Ki=40.0, Tc=1e-3, u_max=10.0)
    one, many = _engine(4, ref), _engine(4, ref)
    for b, (k, lim) in enumerate(zip(index, limits)):
        one.set_plant(b, rows + k, 1, 0, plant_state(plants[k], float(ref.w[0])), lim)
        one.set_pi(b, pi)
        one.scenarios[b].row_k = ffi.NULL  # set_plant's one start sample (0), which C reads only with two rows or more
    many.set_plants(rows, st, index, limits)
    many.set_pi_all(pi)
    assert _bytes(many) == _bytes(one)


def test_set_plants_refuses_an_index_outside_the_table_and_a_wrong_bound_shape():
    ref = multisine_reference(0.05, rng=np.random.default_rng(0))
    rows = plant_rows(_plants())
    st = plant_states(rows, 0.0)
    x = _engine(2, ref)
    with pytest.raises(ParameterError, match="index must hold 2 rows of the 3"):
        x.set_plants(rows, st, [0, 3], [1.0, 1.0])
    with pytest.raises(ParameterError, match="index must hold 2 rows"):
        x.set_plants(rows, st, [0, -1], [1.0, 1.0])
    with pytest.raises(ParameterError, match=r"w_limit must have shape \(2,\)"):
        x.set_plants(rows, st, [0, 1], [1.0])
    assert x.scenarios[0].rows == ffi.NULL  # refused: nothing set


def test_outcome_and_metrics_read_every_scenarios_fields():
    ref = multisine_reference(0.2, rng=np.random.default_rng(0))
    plants = _plants()
    rows = plant_rows(plants)
    x = _engine(3, ref)
    x.set_plants(rows, plant_states(rows, float(ref.w[0])), [0, 1, 2], [1e9, 1e-6, 1e9])  # the second diverges
    x.set_pi_all(PIController(Kp=3.0, Ki=40.0, Tc=1e-3, u_max=10.0))
    x.keep(rows)
    x.run()
    k_end, div, nth = x.outcome()
    sc = x.scenarios
    assert k_end.dtype == np.int64 and nth.dtype == np.int64 and div.dtype == bool
    assert k_end.tolist() == [sc[b].k_end for b in range(3)] and div.tolist() == [False, True, False]
    assert 0 < k_end[1] < ref.t.size == k_end[0] == k_end[2]
    m = x.metrics()
    for b in range(3):
        assert m[b].tobytes() == bytes(ffi.buffer(ffi.addressof(sc[b], "metrics")))
    assert m["n"].tolist() == k_end.tolist()


@pytest.mark.parametrize("mode", ["none", "adaptive"])
def test_a_batch_with_a_drifting_plant_equals_its_single_runs(mode):
    ref = multisine_reference(0.3, rng=np.random.default_rng(0))
    p = preset("paper")
    plants = [p, FrictionDrift(p, Fc_change=0.5, t_start=0.05, t_end=0.25), p.replace(J=1.3 * p.J)]
    o = LoopConfig.from_flat(Kp=12.0, Ki=150.0, u_max=20.0, Vs=p.Vs, delta=p.delta, sensor_gate=False)
    r = run_batch(plants, ref, mode, o)
    for b, q in enumerate(plants):
        one = run_mode(q, ref, mode, o, rng=np.random.default_rng(0))
        assert r.rms[b] == one.metrics.rms and r.u_rms[b] == one.metrics.u_rms
        assert r.max_second_half[b] == one.metrics.max_second_half
