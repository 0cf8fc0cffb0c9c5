"""``compare`` never prints a table of NaN at exit 0, and its tables keep their columns for any value.

A plant whose friction is above the drive's torque limit is refused before its runs, naming the level, its value
and the limit; a run that diverges is named in the table and in the notes, and the command exits 3.
"""

import json
from dataclasses import replace

import pytest

from controllers.cli.compare import comparison_table
from controllers.cli.main import main
from controllers.experiments.comparison import number_text
from controllers.experiments.scenario import load_scenario

#: A user's compensator that feeds a torque forward far beyond what the joint needs: its loop diverges at once.
PUSH = '''
class Push:
    def __init__(self, ctx, torque=5e5):
        self.torque = torque

    def compensate(self, w_meas, w_ref):
        return self.torque

    def observe(self, u, w_meas):
        pass
'''
PAPER = {"J": 4.0, "Fc": 25.0, "Fs": 35.0, "Vs": 0.02, "delta": 1.0, "sigma": 40.0, "tau": 0.02}


def _scenario(tmp_path, *, u_max=1e6, plant='preset = "paper"', push=True):
    (tmp_path / "push.py").write_text(PUSH)
    path = tmp_path / "sc.toml"
    path.write_text(f'modes = ["none"]\n[plant]\n{plant}\n[reference]\nduration = 1.0\n[drive]\nu_max = {u_max!r}\n'
                    f'[compensation]\nVs = 0.02\ndelta = 1.0\n'
                    + ('[compensators.push]\nfactory = "push.py:Push"\n' if push else ""))
    return path


@pytest.fixture(scope="module")
def diverged(tmp_path_factory):
    return load_scenario(_scenario(tmp_path_factory.mktemp("div"))).compare(progress=False)


def test_a_plant_the_drive_cannot_move_is_refused_before_any_run(tmp_path, capsys):
    plant = tmp_path / "stuck.json"
    plant.write_text(json.dumps({**PAPER, "Fc": 1e9, "Fs": 1e9}))
    # without a design inertia the first experiment already fails on it (refused, exit 2, no traceback)
    assert main(["compare", "--plant", str(plant), "--duration", "1", "--modes", "none", "--no-figures",
                 "--quiet"]) == 2
    cap = capsys.readouterr()
    assert cap.out == "" and "Traceback" not in cap.err and "first inertia" in cap.err
    # with one (a data sheet's), the drive's check refuses it by the limit derived from the quasi-static runs
    assert main(["compare", "--plant", str(plant), "--duration", "1", "--modes", "none", "--no-figures",
                 "--quiet", "--J-design", "4"]) == 2
    cap = capsys.readouterr()
    assert cap.out == "" and "Traceback" not in cap.err
    assert f"--plant {plant}: Fc = 1e+09 N·m is above u_max = " in cap.err
    # the limit it names is the one compare derived from its quasi-static runs: far below the friction
    u_max = float(cap.err.split("u_max = ")[1].split(" N·m")[0])
    assert 0 < u_max < 1e9


def test_a_given_drive_limit_is_checked_against_the_friction_up_front(tmp_path, capsys):
    sc = _scenario(tmp_path, u_max=30.0, push=False)  # the paper joint: Fc 25, Fs 35 N·m
    assert main(["compare", "--scenario", str(sc), "--no-figures", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert f"{sc}: [plant] Fs = 35 N·m is above u_max = 30 N·m" in err


def test_a_diverged_run_is_named_in_the_table_and_the_notes_and_exits_3(tmp_path, capsys):
    sc = _scenario(tmp_path)
    assert main(["compare", "--scenario", str(sc), "--no-figures", "--quiet"]) == 3
    cap = capsys.readouterr()
    row = [line for line in cap.out.splitlines() if line.startswith("push ")]
    assert len(row) == 1 and row[0].split()[1:] == ["diverged", "-", "-", "-", "-"]
    assert "nan" not in cap.out
    assert "note: push: diverged at t = 0.001 s" in cap.out and "push diverged" in cap.err
    assert main(["compare", "--scenario", str(sc), "--no-figures", "--quiet", "--json"]) == 3
    d = json.loads(capsys.readouterr().out)
    assert d["modes"]["push"]["diverged"] is True and d["modes"]["push"]["rms"] is None
    assert any(n.startswith("push: diverged") for n in d["notes"])


def test_the_library_table_and_notes_name_the_diverged_run(diverged):
    line = [x for x in diverged.table().splitlines() if x.startswith("push ")][0]
    assert line.split()[1:] == ["diverged"] + ["-"] * 7 and "nan" not in diverged.table()
    assert [n for n in diverged.notes if "diverged" in n] == [n for n in diverged.notes if n.startswith("push: ")]


def _columns_hold(table: str, widths: list) -> bool:
    """Every line as long as the header, and a blank at the start of every column (no two cells run together)."""
    lines = table.splitlines()
    starts = [len(lines[0]) - sum(widths[i:]) for i in range(len(widths))]
    return all(len(x) == len(lines[0]) and all(x[s] == " " for s in starts) for x in lines[2:])


@pytest.mark.parametrize("eta,rms", [(-100.0, 1.0), (-123456.789, 1e300), (1e-300, 12345678.9), (-1e300, -1e-300)])
def test_columns_keep_their_widths_for_any_value(diverged, eta, rms):
    r = diverged.results["none"]
    extreme = replace(r, metrics=replace(r.metrics, rms_second_half=rms, max_second_half=rms, rms_reversal=rms,
                                         u_rms=rms))
    comp = replace(diverged, results={**diverged.results, "none": extreme}, eta={**diverged.eta, "none": eta},
                   eta_full={**diverged.eta_full, "none": eta})
    assert _columns_hold(comp.table(), [12, 13, 14, 13, 8, 9, 12, 9])

    class Args:
        units = "deg"

    cli = comparison_table(comp, Args())
    assert _columns_hold(cli, [14, 14, 23, 13, 9])
    none = [x for x in cli.splitlines() if x.startswith("none ")][0]
    assert float(none.split()[-1]) == pytest.approx(eta, rel=0.05)  # the value is still there, in fewer digits


@pytest.mark.parametrize("x,width,digits,text", [(1.5, 9, 3, "    1.500"), (-100.0, 9, 3, " -100.000"),
                                                  (-1000.0, 9, 3, "    -1000"), (float("nan"), 6, 2, "   n/a"),
                                                  (None, 4, 2, " n/a"), (1e300, 9, 3, "   1e+300")])
def test_number_text_fits_its_width(x, width, digits, text):
    assert number_text(x, width, digits) == text


def test_a_factory_that_fails_or_returns_no_compensator_is_named():
    from controllers import CompareOptions, CompensatorError, compare
    from plant import ParameterError, preset

    class OnlyCompensate:
        def compensate(self, w_meas, w_ref):
            return 0.0

    def broken(ctx):
        raise KeyError("prefit")

    o = CompareOptions.from_flat(duration=0.5, modes=("none",), Vs=0.02, delta=1.0, u_max=150.0)
    with pytest.raises(ParameterError, match=r"compensators\['half'\]: its factory returned a OnlyCompensate without "
                                             r"observe"):
        compare(preset("paper"), o, compensators={"half": lambda ctx: OnlyCompensate()}, progress=False)
    with pytest.raises(CompensatorError, match=r"compensator 'broken': its factory failed: KeyError: 'prefit'"):
        compare(preset("paper"), o, compensators={"broken": broken}, progress=False)
