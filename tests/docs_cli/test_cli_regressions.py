"""Defects found by fuzzing the command line (tests/docs_cli/test_fuzz_cli.py, benchmarks/fuzz_cli.py), one test each: the
command now exits 2 with a message naming the file, key or option instead of running out of memory, hanging or
failing with an internal error (exit 1).
"""

from pathlib import Path

from controllers.cli.main import main
from plant.errors import ParameterError

ROOT = Path(__file__).resolve().parents[2]


def _never(*args, **kwargs):
    raise ParameterError("the reference was made")


def test_a_scenario_reference_beyond_the_memory_is_refused_before_it_is_made(tmp_path, monkeypatch, capsys):
    """``n_reversals = 1e6`` made the reference of 1.7e9 samples at load (the process was killed for its memory);
    ``1e300`` looped without end."""
    text = (ROOT / "examples" / "scenarios" / "linear_axis.toml").read_text()
    huge = tmp_path / "huge.toml"
    huge.write_text(text.replace("n_reversals = 16", "n_reversals = 1e300"))
    monkeypatch.setattr("plant.motion.reversing_reference", _never)
    assert main(["compare", "--scenario", str(huge), "--no-figures", "--quiet", "--yes"]) == 2
    err = capsys.readouterr().err
    assert f"{huge}: [reference]: its length = 1.7e+300 s is 1.7e303 samples" in err and "was made" not in err


def test_a_point_to_point_reference_of_too_many_moves_is_refused(tmp_path, capsys):
    """``repeat = 1e9`` built a list of 2e9 targets before anything was checked."""
    f = tmp_path / "p2p.toml"
    f.write_text('[plant]\npreset = "paper"\n[reference]\nkind = "point-to-point"\ntargets = [0.0, 1.0]\n'
                 'repeat = 1000000000\nv_max = 1.0\na_max = 10.0\n')
    assert main(["compare", "--scenario", str(f), "--no-figures", "--quiet"]) == 2
    assert f"{f}: [reference] repeat = 1000000000: 2 targets times it are more than 1,000,000 moves" in \
        capsys.readouterr().err


def test_a_reference_file_spanning_too_long_is_refused_before_resampling(tmp_path, capsys):
    """Two rows 1e9 s apart were resampled onto 1e12 samples."""
    csv = tmp_path / "ref.csv"
    csv.write_text("t,w\n0,0\n1e9,1\n")
    f = tmp_path / "file.toml"
    f.write_text(f'[plant]\npreset = "paper"\n[reference]\nkind = "file"\npath = "{csv.name}"\nvelocity = "w"\n')
    assert main(["compare", "--scenario", str(f), "--no-figures", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert f"{csv}: the file spans 1e+09 s, 1e+12 samples at dt = 0.001 s: more than the" in err


def test_design_refuses_a_crossover_too_low_for_its_margins(capsys):
    """A crossover of 1e-4 rad/s at 1 kHz made python-control's margin search fail (an internal error, exit 1)."""
    assert main(["design", "--J", "4", "--crossover", "1e-4", "--no-figures"]) == 2
    assert "crossover must be at least 1e-06/Tc = 0.001 rad/s" in capsys.readouterr().err


def test_design_of_a_few_degrees_of_phase_margin_reports_its_margins(capsys):
    """At 20 rad/s and 1 to 3 deg python-control found no gain crossover (an internal error, exit 1)."""
    import json

    assert main(["design", "--J", "1", "--phase-margin", "1", "--no-figures", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert abs(d["phase_margin"] - 1.0) < 1e-6 and abs(d["crossover"] - 20.0) < 1e-6
    assert abs(d["stability_margin"] - 1.0 / d["sensitivity_peak"]) < 1e-3


def test_a_velocity_noise_whose_square_underflows_designs_no_observer_cutoff_from_it(capsys):
    """``--noise 2.2e-311``: its square is 0 and the residual observer's cut-off divided by it (an internal error,
    ZeroDivisionError); it is the noise-free cut-off now, as for ``--noise 0``."""
    from controllers.experiments.observer_design import residual_cutoff

    assert residual_cutoff(4.0, 2.2e-311, 1e-3, 25.0) == residual_cutoff(4.0, 0.0, 1e-3, 25.0)
    assert main(["compare", "--variant", "lugre", "--duration", "2", "--modes", "none,dob", "--noise", "2.2e-311",
                 "--no-figures", "--quiet"]) == 0


def _stribeck_log(tmp_path):
    import numpy as np

    from plant import preset, simulate

    t = np.arange(0.0, 1.5, 1e-3)
    u = 45.0 * np.sin(2 * np.pi * t) + 10.0 * np.sin(2 * np.pi * 7.1 * t)
    w = simulate(preset("paper"), u, dt=1e-3).w[:-1]
    path = tmp_path / "log.csv"
    np.savetxt(path, np.column_stack([t, u, w]), delimiter=",", header="t,u,w", comments="")
    return path


def test_stribeck_options_of_the_other_method_are_refused_naming_them(tmp_path, capsys):
    """``--method segments --J 1`` and ``--method bins --settle 0.1`` reached the other method's function (an
    internal error, TypeError)."""
    log = _stribeck_log(tmp_path)
    assert main(["stribeck", str(log), "--method", "segments", "--J", "1", "--no-figures"]) == 2
    assert "--J applies to --method bins or auto, not segments" in capsys.readouterr().err
    assert main(["stribeck", str(log), "--method", "bins", "--settle", "0.1", "--no-figures"]) == 2
    assert "--settle applies to --method segments or auto, not bins" in capsys.readouterr().err


def test_stribeck_huge_bins_and_durations_are_refused_naming_the_file(tmp_path, capsys):
    """``--bins 1e22`` asked numpy for an array beyond its size, ``--min-duration 1e300`` for an integer beyond
    C's (internal errors); the data's own errors did not name the file."""
    log = _stribeck_log(tmp_path)
    assert main(["stribeck", str(log), "--bins", "10000000000000000000000", "--no-figures"]) == 2
    assert f"{log}: n_bins = 10000000000000000000000 is more than the log's 1500 samples" in capsys.readouterr().err
    assert main(["stribeck", str(log), "--method", "segments", "--min-duration", "1e300", "--no-figures"]) == 2
    assert f"{log}: only 0 support point(s) found by 'segments'" in capsys.readouterr().err
    points = tmp_path / "points.csv"
    points.write_text("w,F\n0.1,30\n0.2,32\n0.3,35\n")
    assert main(["stribeck", str(points), "--points", "--no-figures"]) == 2
    assert capsys.readouterr().err.startswith(f"adaptive-ff: error: {points}: ")


def test_paper_figures_errors_name_the_options(tmp_path, capsys, monkeypatch):
    """``--sim-duration 1e300 --yes`` asked numpy for an array beyond its size (an internal error); a setting's
    error named the field (``n_speeds``), not the option; ``--quantization 100`` failed naming nothing."""
    out = str(tmp_path / "out")
    assert main(["paper-figures", "--sim-duration", "1e300", "--yes", "--out", out, "--quiet"]) == 2
    assert "--sim-duration = 1e+300 s is 1e303 samples at 1 kHz" in capsys.readouterr().err
    assert main(["paper-figures", "--speeds", "2", "--out", out, "--quiet"]) == 2
    assert "adaptive-ff: error: --speeds must be an integer in 3..10000, got 2" in capsys.readouterr().err

    from plant.errors import ExcitationError

    def unexcited(*args, **kwargs):
        raise ExcitationError("regressor column of 'b0' is identically zero: the data do not excite it")

    monkeypatch.setattr("controllers.experiments.paper_figures.paper_figures", unexcited)
    assert main(["paper-figures", "--quantization", "100", "--out", out, "--quiet"]) == 2
    assert ("the simulated experiments (--sim-duration 30, --exp-duration 60, --noise 0.001, --quantization 100) "
            "cannot be identified: regressor column of 'b0'") in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_design_step_duration_not_positive_names_the_option(capsys):
    """``--step-duration -0`` was refused as ``t_end must be > 0``, a name the command line does not have."""
    assert main(["design", "--J", "1", "--step-duration", "-0", "--no-figures"]) == 2
    assert "--step-duration must be a finite time > 0 s, got -0.0" in capsys.readouterr().err


def test_design_errors_name_the_options_and_where_j_comes_from(capsys):
    """The targets' errors named ``phase_margin=`` and ``crossover=``, not the options; a crossover at the lower
    bound with a high phase margin made python-control's margin search fail (an internal error)."""
    assert main(["design", "--J", "0.1", "--sigma", "40", "--no-figures"]) == 2
    assert ("--phase-margin 60.0 deg cannot be reached by a PI (Kp > 0, Ki > 0) at --crossover 20.0 rad/s"
            in capsys.readouterr().err)
    assert main(["design", "--J", "0.001", "--phase-margin", "77.4311", "--crossover", "0.001", "--no-figures"]) == 2
    err = capsys.readouterr().err
    assert "the margins of the designed loop cannot be computed" in err and "Warning" not in err


def test_identify_errors_of_the_data_name_the_file(tmp_path, capsys):
    """A log that never reverses failed with ``regressor column of 'a1' is identically zero``, naming no file."""
    import numpy as np

    t = np.arange(0.0, 0.5, 1e-3)
    log = tmp_path / "still.csv"
    np.savetxt(log, np.column_stack([t, 10.0 * t, 0.0 * t]), delimiter=",", header="t,u,w", comments="")
    assert main(["identify", str(log), "--quiet"]) == 2
    assert capsys.readouterr().err.startswith(f"adaptive-ff: error: {log}: ")


def test_paper_figures_speeds_are_bounded(tmp_path, capsys):
    """``--speeds 1e22 --yes`` asked numpy for an array beyond its size (an internal error)."""
    assert main(["paper-figures", "--speeds", "10000000000000000000000", "--yes", "--out", str(tmp_path / "o")]) == 2
    assert "--speeds must be an integer in 3..10000, got 10000000000000000000000" in capsys.readouterr().err


def test_export_c_names_the_options_of_the_example_loops_design(tmp_path, capsys):
    """An identification whose J the default targets cannot serve failed with ``phase_margin=60.0 deg cannot be
    reached``, naming neither an option nor the file."""
    import json
    import sys

    sys.path.insert(0, str(ROOT / "tests"))
    from export_c_helpers import ID_JSON

    f = tmp_path / "id.json"
    f.write_text(json.dumps({**ID_JSON, "J": 0.001}))
    assert main(["export-c", "--from", str(f), "--u-max", "10", "--out", str(tmp_path / "c")]) == 2
    err = capsys.readouterr().err
    assert "--phase-margin 60.0 deg cannot be reached" in err and f"the J and sigma of {f}; --Kp and --Ki" in err
    assert main(["export-c", "--from", str(f), "--u-max", "10", "--out", str(tmp_path / "c"), "--Kp", "1", "--Ki",
                 "10", "--quiet"]) == 0


def test_identify_asymmetric_on_a_short_log_names_the_file(tmp_path, capsys):
    """``--asymmetric`` on the first 30 rows of a log failed with ``fit_idim: tail = 49 leaves no sample``, naming no
    file."""
    import numpy as np

    from plant import preset, simulate

    t = np.arange(0.0, 1.5, 1e-3)
    u = 45.0 * np.sin(2 * np.pi * 1.0 * t) + 10.0 * np.sin(2 * np.pi * 7.1 * t)
    w = simulate(preset("paper"), u, dt=1e-3).w[:-1]
    log = tmp_path / "short.csv"
    np.savetxt(log, np.column_stack([t, u, w])[:30], delimiter=",", header="t,u,w", comments="")
    assert main(["identify", str(log), "--quiet"]) == 0
    capsys.readouterr()
    assert main(["identify", str(log), "--asymmetric", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"adaptive-ff: error: {log}: fit_idim: tail = 49 leaves no sample"), err
