"""A compiled export-c folder run in the package's engine (controllers/simulation/exported.py, aff_drive_ops).

The engine calls the library's own code (aff_step_gated, the guard, aff_adaptive_observe) instead of the package's
module: on joints where the residual observer switches in and the supervisor acts, every metric equals the
package's run bit for bit and the struct the library advanced ends byte for byte where the package's ended.
"""

from __future__ import annotations

import math
import shutil

import numpy as np
import pytest

from adaptive_ff.compensation.export_c import JointExport, export_c
from controllers import LoopConfig, design_pi
from controllers._cctl import ffi
from controllers.simulation.batch import run_batch
from controllers.simulation.compensators import build_mode
from controllers.simulation.exported import ExportedLibrary
from plant.errors import ParameterError
from plant.excitation import multisine_reference
from plant.friction import preset
from plant.variant_plants import variant

pytestmark = pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")


def _options(p, d):
    return LoopConfig.from_flat(Kp=d.Kp, Ki=d.Ki, u_max=150.0, Vs=p.Vs, delta=p.delta, noise_std=1e-3, J_design=p.J,
                       ff_max=75.0)


@pytest.fixture(scope="module")
def library(tmp_path_factory):
    p = preset("paper")
    d = design_pi(p.J, crossover=20.0, phase_margin=60.0, Tc=1e-3)
    _, _, comp = build_mode(p, "adaptive", _options(p, d))
    out = tmp_path_factory.mktemp("export") / "drive_ff"
    export_c(JointExport(compensator=comp, J_design=p.J, u_max=150.0, Kp=d.Kp, Ki=d.Ki), out)
    return ExportedLibrary(out)


def test_a_batch_through_the_compiled_export_equals_the_packages_bit_for_bit(library):
    plants = [preset("paper"), variant("karnopp"), variant("lugre"), variant("long-lag"), variant("asymmetric")]
    ref = multisine_reference(20.0, rng=np.random.default_rng(4))
    opts = [_options(p, design_pi(p.J, crossover=20.0, phase_margin=60.0, Tc=1e-3)) for p in plants]
    seeds = list(range(10, 10 + len(plants)))
    pkg = run_batch(plants, ref, "adaptive", opts, seeds=seeds)
    exp = run_batch(plants, ref, "adaptive", opts, seeds=seeds, through=library)
    for k in ("rms", "max", "rms_second_half", "max_second_half", "rms_reversal", "u_rms"):
        np.testing.assert_array_equal(getattr(exp, k), getattr(pkg, k), err_msg=k)
    assert not pkg.diverged.any()
    for a, b in zip(pkg.compensators, exp.compensators):
        assert type(b).__name__ == "ExportedCompensator"
        assert b.compensator.struct_bytes() == a.struct_bytes()  # the library's struct ends where the package's did
    # the runs exercise the parts: the estimator, the observer's switch-in and the supervisor
    assert all(c.compensator.feedforward.estimator.n_updates > 100 for c in exp.compensators)
    assert any(c.compensator.info().get("t_switch_in") is not None for c in exp.compensators)
    assert all(s is not None for s in exp.supervisors)
    assert [s.n_backoff for s in exp.supervisors] == [s.n_backoff for s in pkg.supervisors]


def test_other_modes_are_not_affected_and_another_compensator_is_refused(library):
    p = preset("paper")
    d = design_pi(p.J, crossover=20.0, phase_margin=60.0, Tc=1e-3)
    ref = multisine_reference(3.0, rng=np.random.default_rng(1))
    a = run_batch([p], ref, "dob", _options(p, d), seeds=[1])
    b = run_batch([p], ref, "dob", _options(p, d), seeds=[1], through=library)
    assert a.rms[0] == b.rms[0] and type(b.compensators[0]).__name__ == "DisturbanceObserver"
    _, _, dob = build_mode(p, "dob", _options(p, d))
    with pytest.raises(ParameterError, match="AdaptiveCompensator"):
        library.compensator(dob)


def test_a_folder_that_is_not_an_export_or_does_not_compile_is_refused(tmp_path, library):
    with pytest.raises(ParameterError, match="not an export-c folder"):
        ExportedLibrary(tmp_path)
    broken = tmp_path / "broken"
    shutil.copytree(library.folder, broken)
    (broken / "aff.c").write_text("this is not C\n")
    with pytest.raises(ParameterError, match="does not compile"):
        ExportedLibrary(broken)
    with pytest.raises(ParameterError, match="no C compiler"):
        ExportedLibrary(library.folder, cc="no-such-compiler-here")


def test_the_build_folder_is_gone_once_the_library_is_loaded_or_refused(tmp_path, monkeypatch, library):
    # a pool worker ends without running finalizers: nothing of the build may wait for one
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    import tempfile
    monkeypatch.setattr(tempfile, "tempdir", None)
    again = ExportedLibrary(library.folder)
    assert list(tmp_path.iterdir()) == []
    p = preset("paper")  # the loaded library runs without its file
    o = _options(p, design_pi(p.J, crossover=20.0, phase_margin=60.0, Tc=1e-3))
    ref = multisine_reference(2.0, rng=np.random.default_rng(2))
    a = run_batch([p], ref, "adaptive", o, seeds=[3])
    b = run_batch([p], ref, "adaptive", o, seeds=[3], through=again)
    assert type(b.compensators[0]).__name__ == "ExportedCompensator" and b.rms[0] == a.rms[0]
    broken = tmp_path.parent / (tmp_path.name + "-broken")
    shutil.copytree(library.folder, broken)
    (broken / "aff.c").write_text("this is not C\n")
    with pytest.raises(ParameterError, match="does not compile"):
        ExportedLibrary(broken)
    assert list(tmp_path.iterdir()) == []


def test_the_librarys_guard_refuses_what_the_package_module_passes_on(library):
    # the drive's input guard is part of what runs: a velocity beyond its bound drops the period (the package's
    # module would gate it itself), so a run through the export is the drive's, guard included
    p = preset("paper")
    d = design_pi(p.J, crossover=20.0, phase_margin=60.0, Tc=1e-3)
    _, _, comp = build_mode(p, "adaptive", _options(p, d))
    c = library.compensator(comp, w_max=0.5)
    ops, h = c.ops, c.handle
    assert ops.compensate(h, 0.1, 0.1, 0.2) == 0.0  # learning: no output yet
    assert ops.observe(h, 1.0, 0.1, ffi.NULL) in (0, 1)
    before = bytes(c.compensator.struct_bytes())
    ops.compensate(h, 0.7, 0.7, 0.2)  # beyond w_max: refused, the period dropped
    assert ops.observe(h, 1.0, 0.7, ffi.NULL) == 0
    # counted once (in aff_step; the observe of a dropped period does nothing), the struct as before the period
    assert c.cdata.status.n_refused_w_meas == 1 and bytes(c.compensator.struct_bytes()) == before
    assert math.isfinite(ops.transfer(h))
