"""Nothing from the true plant reaches an estimator, compensator or experiment design.

The plant object of these tests raises :class:`TruthLeak` when a friction field (or ``J``) is read anywhere but in the plant step's packing (:func:`plant.dynamics.plant_params`,
:func:`plant.dynamics.plant_state`), the open-loop simulator (:func:`plant.joint.simulate`) or the frictionless
reference. ``compare`` then runs every adaptive-path mode
on it: the pre-fit's experiment, the identification run of ``fixed``, the estimators, the gates and the DOB see
the joint only through its simulated response.
"""

import contextlib
import sys

import numpy as np
import pytest

import plant.dynamics as dyn
import plant.joint as joint
from controllers.experiments.compare import compare
from plant.friction import JointParams, preset

P = preset("paper")
FRICTION = frozenset({"Fc", "Fs", "Vs", "delta", "sigma", "tau", "friction", "friction_torque", "initial_state"})


class TruthLeak(Exception):
    """A true plant field was read outside the plant step (not an AttributeError: hasattr must not hide it)."""


_open = [0]


@contextlib.contextmanager
def _plant_step():
    _open[0] += 1
    try:
        yield
    finally:
        _open[0] -= 1


class GuardedJoint(JointParams):
    """The paper joint whose friction fields (and J if ``guard_J``) raise unless the plant step reads them."""

    guard_J = False

    def __init__(self, *args, **kw):
        with _plant_step():
            super().__init__(*args, **kw)

    def __getattribute__(self, name):
        if not _open[0] and (name in FRICTION or (name == "J" and type(self).guard_J)):
            raise TruthLeak(f"true plant field {name!r} read outside the plant step")
        return object.__getattribute__(self, name)

    def frictionless(self):
        with _plant_step():
            return JointParams.frictionless(self)


def _opened(fn):
    def wrapper(*a, **k):
        with _plant_step():
            return fn(*a, **k)
    return wrapper


@pytest.fixture
def guarded(monkeypatch):
    """Open the guard in the plant step's packing at every module that imported it."""
    for src, name in ((dyn, "plant_params"), (dyn, "plant_state"), (joint, "simulate")):
        orig = getattr(src, name)
        wrapped = _opened(orig)
        for mod in list(sys.modules.values()):
            if getattr(mod, name, None) is orig:
                monkeypatch.setattr(mod, name, wrapped)
    monkeypatch.setattr(GuardedJoint, "guard_J", False)
    return GuardedJoint(**{k: getattr(P, k) for k in ("J", "Fc", "Fs", "Vs", "delta", "sigma", "tau")})


def test_the_guard_catches_a_read():
    g = GuardedJoint(J=4.0, Fc=25.0, Fs=35.0, Vs=0.02, delta=1.0, sigma=40.0, tau=0.02)
    with pytest.raises(TruthLeak):
        _ = g.Vs
    with pytest.raises(TruthLeak):
        g.friction(np.array([0.1]))
    assert g.J == 4.0  # unguarded by default (the guard of J is switched on by the tests that need it)
    GuardedJoint.guard_J = True
    try:
        with pytest.raises(TruthLeak):
            _ = g.J
    finally:
        GuardedJoint.guard_J = False


def test_compare_runs_every_adaptive_path_mode_without_reading_the_true_friction(guarded, monkeypatch):
    monkeypatch.setattr(GuardedJoint, "guard_J", True)  # with J_design given, not even J is read
    comp = compare(guarded, duration=6.0, seed=1, modes=("none", "fixed", "adaptive", "canudas", "dob"),
                   J_design=4.0, progress=False)
    # the pre-fit of the designed runs, from the response only, finds the true Stribeck factors
    assert comp.prefit.Vs == pytest.approx(P.Vs, rel=0.03)
    assert comp.prefit.delta == pytest.approx(P.delta, rel=0.05)
    assert comp.J_design == 4.0
    for mode in ("fixed", "dob"):
        assert comp.eta[mode] > 0.5, mode
    assert all(np.isfinite(comp.eta[m]) for m in ("adaptive", "canudas"))  # 6 s: the adaptive mode is still warming up


def test_compare_identifies_its_design_inertia_without_reading_the_true_one(guarded, monkeypatch):
    monkeypatch.setattr(GuardedJoint, "guard_J", True)  # no J_design: the default never reads J either
    comp = compare(guarded, duration=6.0, seed=1, modes=("none", "adaptive", "dob"), progress=False)
    assert comp.inertia is not None and comp.J_design == comp.inertia.J
    assert comp.J_design == pytest.approx(P.J, rel=0.03)  # identified, not read
    assert all(np.isfinite(comp.eta[m]) for m in ("adaptive", "dob"))
