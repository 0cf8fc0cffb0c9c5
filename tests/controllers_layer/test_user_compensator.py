"""A user's own compensator in the engine's loop (controllers/simulation/user_compensator.py).

The independent check: the package's own adaptive compensator, called through the Python protocol by the
engine's callbacks, gives the same run as the engine calling its C functions directly, bit for bit; a
compensator that returns zero gives the run without compensation, bit for bit.
"""

import math

import numpy as np
import pytest

from controllers import CompareOptions, CompensatorError, LoopConfig, compare, design_pi, run_closed_loop, run_mode
from controllers.simulation.closed_loop import MeasurementSettings, run_own
from controllers.simulation.compensators import build_mode
from plant import ParameterError, preset
from plant.excitation import multisine_reference

P = preset("paper")
D = design_pi(P.J, crossover=20.0, phase_margin=60.0, Tc=1e-3)
OPTS = LoopConfig.from_flat(Kp=D.Kp, Ki=D.Ki, u_max=150.0, Vs=P.Vs, delta=P.delta, noise_std=1e-3, sensor_gate=False)
REF = multisine_reference(6.0, rng=np.random.default_rng(0))


class Through:
    """Calls a package compensator through its Python protocol (as a user's object would be called)."""

    def __init__(self, comp):
        self.comp = comp
        self.calls = []

    def compensate(self, w_meas, w_ref):
        self.calls.append(("c", w_meas, w_ref))
        return self.comp.compensate(w_meas, w_ref)

    def observe(self, u, w_meas):
        self.calls.append(("o", u, w_meas))
        self.comp.observe(u, w_meas)


def test_the_package_compensator_through_python_equals_the_direct_run():
    direct = run_mode(P, REF, "adaptive", OPTS, rng=np.random.default_rng(1))
    plant, ctrl, comp = build_mode(P, "adaptive", OPTS)
    mine = Through(comp)
    r = run_closed_loop(plant, ctrl, mine, REF,
                        measurement=MeasurementSettings(noise_std=1e-3, rng=np.random.default_rng(1),
                                                        sensor_gate=False))
    for k in ("w", "w_meas", "u", "u_ff"):
        np.testing.assert_array_equal(getattr(r, k), getattr(direct, k))
    assert r.mode == "Through" and r.info["n_calls"] == REF.t.size
    # the order and the arguments of the calls: compensate(w_meas, w_ref), then observe(u, w_meas), each period
    kinds = [c[0] for c in mine.calls]
    assert kinds == ["c", "o"] * REF.t.size
    k = 1234
    assert mine.calls[2 * k][1:] == (r.w_meas[k], REF.w[k])
    assert mine.calls[2 * k + 1][1:] == (r.u[k], r.w_meas[k])
    assert r.metrics.rms_second_half == direct.metrics.rms_second_half


def test_a_zero_compensator_is_the_loop_without_compensation():
    class Zero:
        name = "zero"

        def compensate(self, w_meas, w_ref):
            return 0

        def observe(self, u, w_meas):
            return None

    none = run_mode(P, REF, "none", OPTS, rng=np.random.default_rng(4))
    r = run_own(P, REF, Zero(), OPTS, rng=np.random.default_rng(4))
    np.testing.assert_array_equal(r.w, none.w)
    np.testing.assert_array_equal(r.u, none.u)
    assert r.mode == "zero" and np.all(r.u_ff == 0.0)


@pytest.mark.parametrize("fail_at,kind,match", [(500, "raise", r"'boom'.*compensate failed at period 500"),
                                                 (77, "nan", r"compensate failed at period 77.*returned nan"),
                                                 (90, "observe", r"observe failed at period 90")])
def test_a_failing_compensator_ends_the_run_and_is_raised(fail_at, kind, match):
    class Failing:
        name = "boom"

        def __init__(self):
            self.k = 0

        def compensate(self, w_meas, w_ref):
            if self.k == fail_at and kind == "raise":
                raise RuntimeError("broken model")
            return math.nan if self.k == fail_at and kind == "nan" else 1.0

        def observe(self, u, w_meas):
            if self.k == fail_at and kind == "observe":
                raise ValueError("bad state")
            self.k += 1

    with pytest.raises(CompensatorError, match=match) as info:
        run_own(P, REF, Failing(), OPTS, rng=np.random.default_rng(1))
    if kind != "nan":
        assert isinstance(info.value.__cause__, (RuntimeError, ValueError))


def test_objects_without_the_protocol_are_refused():
    plant, ctrl, _ = build_mode(P, "none", OPTS)
    with pytest.raises(ParameterError, match="compensate"):
        run_closed_loop(plant, ctrl, object(), REF)
    with pytest.raises(ParameterError, match="built-in mode"):
        CompareOptions.from_flat(compensators={"adaptive": lambda ctx: None})
    with pytest.raises(ParameterError, match="callable"):
        CompareOptions.from_flat(compensators={"mine": 3})


def test_compare_runs_a_user_compensator_beside_the_modes():
    from controllers.experiments.compare import prepare_comparison

    o = CompareOptions.from_flat(duration=20.0, seed=2, modes=("none", "adaptive"))
    adaptive_opts = prepare_comparison(P, o, progress=False).mode_options["adaptive"]
    seen = {}

    def factory(ctx):  # the package's adaptive compensator with the comparison's own options, through Python
        seen["ctx"] = ctx
        return Through(build_mode(P, "adaptive", adaptive_opts)[2])

    c = compare(P, o, compensators={"mine": factory}, progress=False)
    assert list(c.results) == ["none", "adaptive", "frictionless", "mine"]
    assert c.eta["mine"] == c.eta["adaptive"]
    assert c.eta["adaptive"] == compare(P, o, progress=False).eta["adaptive"]
    assert "mine" in c.table() and c.to_dict()["modes"]["mine"]["eta"] == c.eta["adaptive"]
    ctx = seen["ctx"]
    assert ctx.J == c.J_design and ctx.Kp == c.design.Kp and ctx.prefit is c.prefit and ctx.u_max == 2 * ctx.ff_max
