"""The engine's loop that calls a known compensator's functions directly gives the numbers of the loop that calls
them through the scenario's ops table, bit for bit (ctl_known_ops, ctl_run_chunk)."""

import math

import numpy as np
import pytest

import controllers.simulation.engine as engine
from adaptive_ff.identification.regression import FrictionEstimate
from controllers._cctl import ffi, lib
from controllers.design.pi import design_pi
from controllers.simulation.closed_loop import LoopConfig, run_mode
from plant.excitation import multisine_reference
from plant.friction import preset

P = preset("paper")
D = design_pi(P.J, crossover=20.0, phase_margin=60.0, Tc=1e-3)
EST = FrictionEstimate(J=P.J, tau=P.tau, sigma=P.sigma, Fc=0.9 * P.Fc, Fs=P.Fs, offset=0.0, Vs=P.Vs, delta=P.delta,
                       J_alt=math.nan)
CONFIGS = {"fixed": dict(estimate=EST, noise_std=1e-3), "adaptive": dict(Vs=P.Vs, delta=P.delta, noise_std=1e-3)}


class _TablesOnly:
    """The engine's C library with no known tables: every compensator through a copy of its ops table."""

    def __getattr__(self, name):
        if name == "ctl_known_ops":
            return lambda _name: ffi.NULL
        return getattr(lib, name)


def test_known_tables_are_the_engines_own():
    for name in ("aff_fixed_ff_ops", "aff_adaptive_ops"):
        ops = lib.ctl_known_ops(name.encode())
        assert ops != ffi.NULL and ffi.string(ops.name) in (b"fixed", b"adaptive")
    for name in ("aff_robust_ff_ops", "aff_dob_ops", "ctl_adob_ops", "none"):
        assert lib.ctl_known_ops(name.encode()) == ffi.NULL


@pytest.mark.parametrize("mode", ["fixed", "adaptive"])
def test_direct_calls_equal_the_table(mode, monkeypatch):
    ref = multisine_reference(3.0, rng=np.random.default_rng(4))
    cfg = LoopConfig.from_flat(Kp=D.Kp, Ki=D.Ki, u_max=150.0, **CONFIGS[mode])
    direct = run_mode(P, ref, mode, cfg, rng=np.random.default_rng(5))
    monkeypatch.setattr(engine, "lib", _TablesOnly())
    table = run_mode(P, ref, mode, cfg, rng=np.random.default_rng(5))
    for name in ("w", "w_meas", "u", "u_ff", "f"):
        np.testing.assert_array_equal(getattr(direct, name), getattr(table, name), err_msg=name)
    np.testing.assert_array_equal(direct.theta, table.theta)
    assert direct.metrics.to_dict() == table.metrics.to_dict()
    # the compensator acted: fixed's map from the start, adaptive's estimator updated its estimate
    assert np.any(direct.u_ff != 0.0) if mode == "fixed" else len(direct.theta) > 10
