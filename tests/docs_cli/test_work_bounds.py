"""Work bounded up front: an option that asks for more than 10 minutes or 4 GiB is refused before any work, with
what it would cost, unless ``--yes`` (controllers.cli.budget).

The work itself is replaced by a stand-in that raises ``Reached``: without ``--yes`` it must not be reached (the
refusal comes first, exit status 2, nothing written); with ``--yes`` it must be (the command goes on).
"""

import importlib.util
import json
import sys
from pathlib import Path

import numpy as np
import pytest

from controllers.cli.budget import (MEMORY_LIMIT, TIME_LIMIT, WorkEstimate, WorkLimitError, check_work,
                                    compare_estimate, identify_estimate)
from controllers.cli.main import main
from plant.errors import ParameterError

ROOT = Path(__file__).resolve().parents[2]


class Reached(ParameterError):
    """The stand-in of the work: the command got past its bound."""


def _reached(*args, **kwargs):
    raise Reached("the work started")


@pytest.fixture(scope="module")
def log(tmp_path_factory):
    t = np.arange(0.0, 6.0, 1e-3)
    u = 40.0 * np.sin(2.0 * np.pi * 0.5 * t)
    w = 0.3 * np.sin(2.0 * np.pi * 0.5 * t - 0.3)
    path = tmp_path_factory.mktemp("log") / "log.csv"
    np.savetxt(path, np.column_stack([t, u, w]), delimiter=",", header="t,u,w", comments="")
    return path


def test_the_message_says_what_the_run_would_cost_and_the_way_out():
    with pytest.raises(WorkLimitError) as err:
        check_work(WorkEstimate("--bootstrap 1000000000", 40 * 3600.0, 3 * 2**30), yes=False)
    assert str(err.value) == ("--bootstrap 1000000000: about 40 h and 3 GiB (limit 10 min); pass --yes to run it "
                              "anyway")
    with pytest.raises(WorkLimitError, match=r"about 1 s and 8 GiB \(limit 4 GiB\)"):
        check_work(WorkEstimate("x", 1.0, 8 * 2**30), yes=False)
    with pytest.raises(WorkLimitError, match="a run without end and unbounded memory"):
        check_work(compare_estimate(float("inf"), 2), yes=False)
    check_work(WorkEstimate("x", 1e9, 1e18), yes=True)  # --yes: anything
    check_work(WorkEstimate("x", TIME_LIMIT, MEMORY_LIMIT), yes=False)  # at the limits: allowed


def test_estimates_grow_with_their_options():
    assert identify_estimate(60_000, "sliding", bootstrap=10**9).seconds > 100 * TIME_LIMIT
    assert identify_estimate(60_000, "sliding").seconds < 10.0  # the default 200 refits: seconds
    a, b = identify_estimate(3000, "output_error", bootstrap=20), identify_estimate(3000, "output_error",
                                                                                    bootstrap=20, refit="partial")
    assert b.seconds < a.seconds
    assert compare_estimate(120.0, 8).seconds < 10.0 and compare_estimate(120.0, 8).bytes < 2**27
    assert compare_estimate(1e5, 2).bytes > MEMORY_LIMIT


# (argv, the work's dotted name, the start of the message)
CASES = {
    "identify --bootstrap": (["identify", "{log}", "--bootstrap", "1000000000", "--quiet"],
                             "adaptive_ff.identification.identify.identify",
                             "--bootstrap 1000000000 on 6,000 samples (method paper): about "),
    "identify --folds": (["identify", "{log}", "--form", "auto", "--folds", "100000", "--quiet"],
                         "adaptive_ff.identification.identify.identify", "--folds 100000 on 6,000 samples"),
    "compare --duration": (["compare", "--duration", "1e5", "--modes", "none", "--no-figures", "--quiet"],
                           "controllers.experiments.compare.compare", "--duration 100000 (1e+08 samples, 2 runs)"),
    "design --step-duration": (["design", "--J", "4", "--step-duration", "1e6", "--no-figures"],
                               "controllers.design.loop_analysis.analyse_design", "--step-duration 1e+06"),
    "paper-figures --exp-duration": (["paper-figures", "--exp-duration", "1e6", "--quiet", "--out", "{tmp}/pf"],
                                     "controllers.experiments.paper_figures.paper_figures",
                                     "--sim-duration 30, --exp-duration 1e+06, --speeds 10"),
    "sweep cases": (["sweep", "{spec}", "--out", "{tmp}/r.csv", "--quiet", "--workers", "1"],
                    "controllers.experiments.sweep.run_case", "2,000 cases on 1 worker(s)"),
}


@pytest.mark.parametrize("case", list(CASES))
@pytest.mark.parametrize("yes", [False, True])
def test_a_run_beyond_the_limits_is_refused_unless_yes(case, yes, log, tmp_path, monkeypatch, capsys):
    argv, work, message = CASES[case]
    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps({"preset": "paper", "seeds": list(range(2000)), "modes": ["none", "adaptive"],
                                "duration": 600.0, "options": {"Vs": 0.02, "delta": 1.0}}))
    argv = [a.format(log=log, tmp=tmp_path, spec=spec) for a in argv] + (["--yes"] if yes else [])
    module, name = work.rsplit(".", 1)
    monkeypatch.setattr(f"{module}.{name}", _reached)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    if yes:
        assert "the work started" in err
    else:
        assert err.startswith(f"adaptive-ff: error: {message}") and err.rstrip().endswith(
            "; pass --yes to run it anyway"), err
    if not (yes and case == "sweep cases"):  # (a sweep that starts writes the results' header)
        assert sorted(p.name for p in tmp_path.iterdir()) == ["spec.json"]  # nothing written


def test_a_scenario_too_long_is_refused_unless_yes(tmp_path, monkeypatch, capsys):
    text = (ROOT / "examples" / "scenarios" / "linear_axis.toml").read_text()
    long = tmp_path / "long.toml"
    long.write_text(text.replace("n_reversals = 16", "n_reversals = 12000"))  # 20,400 s: about 7 GiB
    monkeypatch.setattr("controllers.simulation.memory.available_memory", lambda: (2**40, "are available"))
    monkeypatch.setattr("controllers.experiments.scenario.Scenario.compare", _reached)
    assert main(["compare", "--scenario", str(long), "--no-figures", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"adaptive-ff: error: {long}: the reference of 20402.7 s (2.04e+07 samples, 7 runs): about "
                          ) and "GiB (limit 4 GiB); pass --yes to run it anyway" in err
    assert main(["compare", "--scenario", str(long), "--no-figures", "--quiet", "--yes"]) == 2
    assert "the work started" in capsys.readouterr().err


def test_the_zoo_benchmark_is_bounded_too(capsys):
    spec = importlib.util.spec_from_file_location("zoo_benchmark", ROOT / "benchmarks" / "zoo.py")
    zoo = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(zoo)
    with pytest.raises(SystemExit) as exit_:
        zoo.main(["--n", "100000", "--workers", "2"])
    assert exit_.value.code == 2
    assert "--n 100000 --duration 120 (8 modes, 2 worker(s)): about" in capsys.readouterr().err
    sys.modules.pop("zoo_benchmark", None)
