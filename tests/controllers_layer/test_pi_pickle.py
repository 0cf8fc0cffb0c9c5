"""A PI design pickles without its transfer functions (a process that unpickles it needs no python-control) and
rebuilds them equal on first read."""

import pickle

import numpy as np

from controllers.design.pi import PIDesign, design_pi


def test_design_pickles_without_transfer_functions_and_rebuilds_them_equal():
    d = design_pi(4.0, crossover=20.0, phase_margin=60.0, Tc=1e-3)
    blob = pickle.dumps(d)
    assert b"xferfcn" not in blob and b"TransferFunction" not in blob  # unpickling needs no python-control
    e = pickle.loads(blob)
    assert e == d and e.__dict__.get("_tf_loop") is None
    for name in ("C", "plant", "loop"):  # rebuilt on first read: the same coefficients, the same sample time
        a, b = getattr(d, name), getattr(e, name)
        assert a.dt == b.dt == 1e-3
        np.testing.assert_array_equal(a.num_array[0, 0], b.num_array[0, 0])
        np.testing.assert_array_equal(a.den_array[0, 0], b.den_array[0, 0])
    assert e.to_dict() == d.to_dict()


def test_a_design_made_with_transfer_functions_keeps_them():
    d = design_pi(1.0, crossover=100.0, phase_margin=60.0, Tc=5e-3)
    e = PIDesign(Kp=d.Kp, Ki=d.Ki, Tc=d.Tc, crossover=d.crossover, phase_margin=d.phase_margin,
                 gain_margin=d.gain_margin, phase_crossover=d.phase_crossover, stability_margin=d.stability_margin,
                 J=d.J, sigma=d.sigma, C=d.C, plant=d.plant, loop=d.loop)
    assert e.C is d.C and e.plant is d.plant and e.loop is d.loop
