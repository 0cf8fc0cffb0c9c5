"""``adaptive-ff compare`` with its helper process: same output and figures, PI designs handed over intact."""

import math
import os
import pickle
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from controllers.design.pi import PIDesign, design_pi, remember_designs
from plant.errors import ParameterError

ROOT = Path(__file__).resolve().parents[1]

# run the CLI in a fresh process and report which heavy modules the main process imported
_SCRIPT = r"""
import sys
from controllers.cli.main import main
code = main(sys.argv[1:])
print("HEAVY", sorted(m for m in ("control", "matplotlib", "matplotlib.pyplot") if m in sys.modules))
sys.exit(code)
"""


def _cli(out, *, helper):
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONPATH=str(ROOT))
    env.pop("ADAPTIVE_FF_NO_HELPER", None)
    if not helper:
        env["ADAPTIVE_FF_NO_HELPER"] = "1"
    r = subprocess.run([sys.executable, "-c", _SCRIPT, "compare", "--duration", "3", "--quiet", "--out", str(out)],
                       capture_output=True, text=True, env=env, timeout=600)
    assert r.returncode == 0, r.stderr
    assert "Traceback" not in r.stderr
    text, heavy = r.stdout.rsplit("HEAVY", 1)
    return text.replace(str(out), "OUT"), heavy.strip()


def _usable_cpus():
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


@pytest.mark.skipif(not sys.platform.startswith("linux") or _usable_cpus() < 2,
                    reason="the helper process needs fork and two CPUs")
def test_helper_process_gives_the_same_table_and_figure_files(tmp_path):
    with_helper, heavy_with = _cli(tmp_path / "a", helper=True)
    alone, heavy_alone = _cli(tmp_path / "b", helper=False)
    assert with_helper == alone  # plant, PI gains and margins, pre-fit, notes, the metrics table, the figure list
    names = ["tracking.png", "error.png", "friction.png", "rls_convergence.png", "eta.png"]
    assert sorted(p.name for p in (tmp_path / "a").iterdir()) == sorted(names)
    for name in names:
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes(), name
    # the point of the helper: python-control and matplotlib are imported there, not on this process's path
    assert heavy_with == "[]"
    assert "'control'" in heavy_alone and "'matplotlib'" in heavy_alone


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


def test_remembered_designs_are_returned_by_design_pi():
    kw = dict(J=2.5, sigma=0.0, crossover=33.0, phase_margin=55.0, Tc=1e-3)
    d = pickle.loads(pickle.dumps(design_pi(kw["J"], crossover=33.0, phase_margin=55.0, Tc=1e-3)))
    remember_designs([(kw, d)])
    assert design_pi(2.5, crossover=33.0, phase_margin=55.0, Tc=1e-3) is d
    assert design_pi(2.5, crossover=33.0, phase_margin=56.0, Tc=1e-3) is not d  # another target: designed anew
    assert math.isclose(d.phase_margin, 55.0, abs_tol=1e-6)
    with pytest.raises(ParameterError, match="remember_designs"):
        remember_designs([(dict(kw, J=3.0), d)])  # J of the arguments is not the design's
    with pytest.raises(ParameterError, match="remember_designs"):
        remember_designs([(kw, "not a design")])


def test_a_design_made_with_transfer_functions_keeps_them():
    d = design_pi(1.0, crossover=100.0, phase_margin=60.0, Tc=5e-3)
    e = PIDesign(Kp=d.Kp, Ki=d.Ki, Tc=d.Tc, crossover=d.crossover, phase_margin=d.phase_margin,
                 gain_margin=d.gain_margin, phase_crossover=d.phase_crossover, stability_margin=d.stability_margin,
                 J=d.J, sigma=d.sigma, C=d.C, plant=d.plant, loop=d.loop)
    assert e.C is d.C and e.plant is d.plant and e.loop is d.loop


def _helper_dies(comp, out_dir, jobs):
    os._exit(3)  # the helper process killed while it should draw


@pytest.mark.skipif(not sys.platform.startswith("linux") or _usable_cpus() < 2,
                    reason="the helper process needs fork and two CPUs")
def test_figures_are_drawn_here_when_the_helper_dies(monkeypatch, tmp_path, capsys):
    from controllers.cli import compare as cli_compare
    from controllers.cli.main import main

    import gc

    monkeypatch.setattr(cli_compare, "_helper_draw", _helper_dies)
    enabled = gc.isenabled()
    assert main(["compare", "--duration", "2", "--modes", "adaptive", "--quiet", "--out", str(tmp_path)]) == 0
    # called in-process (argv given): the collector is as it was and nothing stays frozen (imports_without_gc)
    assert gc.isenabled() == enabled and gc.get_freeze_count() == 0
    text = capsys.readouterr().out
    assert "figures: " in text and "adaptive" in text
    assert sorted(p.name for p in tmp_path.iterdir()) == ["error.png", "eta.png", "friction.png",
                                                          "rls_convergence.png", "tracking.png"]


def test_design_store_keeps_designs_exactly(monkeypatch, tmp_path):
    from controllers.cli import compare as cli_compare

    monkeypatch.setattr(cli_compare, "design_store", lambda: tmp_path / "pi_designs.json")
    keys = [dict(J=4.0, sigma=0.0, crossover=c, phase_margin=60.0, Tc=1e-3) for c in (20.0, 150.0)]
    assert cli_compare._stored_designs(keys) is None  # nothing kept yet
    made = [(kw, design_pi(kw["J"], crossover=kw["crossover"], phase_margin=60.0, Tc=1e-3)) for kw in keys]
    cli_compare._store_designs(made[:1])
    assert cli_compare._stored_designs(keys) is None  # one of them missing: the helper designs all
    cli_compare._store_designs(made[1:])
    back = cli_compare._stored_designs(keys)
    for (kw, d), (kw2, e) in zip(made, back):
        assert kw2 == kw and e == d and e.to_dict() == d.to_dict()  # every number exactly
        np.testing.assert_array_equal(e.loop.den_array[0, 0], d.loop.den_array[0, 0])
    (tmp_path / "pi_designs.json").write_text("{not json")
    assert cli_compare._stored_designs(keys) is None  # a damaged file: designed again, no error
