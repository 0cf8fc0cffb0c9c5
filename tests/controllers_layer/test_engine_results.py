"""Result protocol of the engine's results: strict JSON, summary text, figures with labelled axes."""

import json
import math

import numpy as np
import pytest

from controllers.design.pi import PIController, design_pi
from controllers.experiments.compare import compare
from controllers.simulation.batch import run_batch
from controllers.simulation.closed_loop import MeasurementSettings, LoopConfig, RunSettings, run_closed_loop
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
    unstable = LoopConfig.from_flat(Kp=5.0 * P.J / 1e-3, Ki=1.0, sensor_gate=False)  # Kp*Tc/J = 5 > 2
    res = run_batch([P, P], ref, "none", [unstable, LoopConfig.from_flat(Kp=1.0, Ki=1.0, sensor_gate=False)])
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


def test_friction0_starts_the_lag_unloaded():
    """``friction0`` sets the lag state F of eq. 3 at the start; the default is steady motion (F = F(w0))."""
    from plant.errors import ParameterError
    from plant.excitation import Reference

    n, w0 = 200, 0.1
    ref = Reference(t=np.arange(n) * 1e-3, w=np.full(n, w0), dw=np.zeros(n))
    pi = lambda: PIController(Kp=D.Kp, Ki=D.Ki, Tc=1e-3)  # noqa: E731
    steady = run_closed_loop(P, pi(), None, ref, measurement=MeasurementSettings(sensor_gate=False))
    cold = run_closed_loop(P, pi(), None, ref, measurement=MeasurementSettings(sensor_gate=False),
                           settings=RunSettings(friction0=0.0))
    F0 = float(P.friction(w0))
    assert steady.f[0] == F0 and cold.f[0] == 0.0
    # first step of tau dF/dt = F(w) - F from F = 0 with w ~ w0: F = (1 - exp(-Tc/tau)) F(w0) = 1.418 N·m
    assert cold.f[1] == pytest.approx((1.0 - math.exp(-1e-3 / P.tau)) * F0, rel=0.01)
    assert steady.f[1] == pytest.approx(F0, rel=0.01)
    with pytest.raises(ParameterError, match="friction0"):
        run_closed_loop(P, pi(), None, ref, settings=RunSettings(friction0=math.nan))
