"""Result protocol of the engine's results: strict JSON, summary text, figures with labelled axes."""

import json
import math

import numpy as np

from controllers.design.pi import PIController, design_pi
from controllers.experiments.compare import compare
from controllers.simulation.batch import run_batch
from controllers.simulation.closed_loop import ModeOptions, run_closed_loop
from controllers.simulation.compensators import TrueFriction
from plant.excitation import multisine_reference
from plant.friction import preset

P = preset("paper")
D = design_pi(P.J, crossover=20.0, phase_margin=60.0, Tc=1e-3)


def test_closed_loop_result_protocol():
    ref = multisine_reference(2.0, rng=np.random.default_rng(0))
    r = run_closed_loop(P, PIController(Kp=D.Kp, Ki=D.Ki, Tc=1e-3), TrueFriction(), ref)
    d = r.to_dict()
    json.dumps(d, allow_nan=False)
    assert d["mode"] == "oracle" and d["metrics"]["rms"] == r.metrics.rms
    assert r.summary().startswith("oracle: RMS")
    ax = r.plot()
    assert ax.get_xlabel() == "time [s]" and ax.get_ylabel() == "velocity [deg/s]"


def test_batch_result_protocol_with_a_diverged_scenario():
    ref = multisine_reference(1.0, rng=np.random.default_rng(2))
    unstable = ModeOptions(Kp=5.0 * P.J / 1e-3, Ki=1.0, sensor_gate=False)  # Kp*Tc/J = 5 > 2
    res = run_batch([P, P], ref, "none", [unstable, ModeOptions(Kp=1.0, Ki=1.0, sensor_gate=False)])
    d = res.to_dict()
    json.dumps(d, allow_nan=False)
    assert d["diverged"] == [True, False] and d["rms"][0] is None and d["rms"][1] == res.rms[1]
    assert "diverged 1" in res.summary()


def test_comparison_protocol():
    comp = compare(P, duration=3.0, seed=0, modes=("none", "oracle"), prefit=False, progress=False)
    d = comp.to_dict()
    json.dumps(d, allow_nan=False)
    assert set(d["modes"]) == {"none", "oracle", "frictionless"}
    assert math.isclose(d["modes"]["oracle"]["eta"], comp.eta["oracle"])
    assert comp.summary() == comp.table()
    ax = comp.plot()
    assert ax.get_ylabel().startswith("eta") and len(ax.patches) == 3
