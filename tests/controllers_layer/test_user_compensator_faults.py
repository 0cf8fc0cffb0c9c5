"""A user's compensator that is interrupted or returns no number: the run ends at once and nothing looks complete.

The engine calls a user's Python compensator through cffi callbacks (controllers/simulation/user_compensator.py),
which would otherwise print and drop whatever the user's code raises. A ``KeyboardInterrupt`` (Ctrl-C),
``SystemExit`` or ``GeneratorExit`` ends the run at the period it was raised in and propagates as it is: the CLI
exits 130 (interrupt) or with SystemExit's code, and writes no figures, no report and no table. A ``u_ff`` that is
not a real number is a CompensatorError naming the compensator.
"""

import subprocess
import sys

import numpy as np
import pytest

from controllers import CompensatorError, LoopConfig, design_pi
from controllers.cli.main import main
from controllers.simulation.closed_loop import run_own
from plant import preset
from plant.excitation import multisine_reference

P = preset("paper")
D = design_pi(P.J, crossover=20.0, phase_margin=60.0, Tc=1e-3)
OPTS = LoopConfig.from_flat(Kp=D.Kp, Ki=D.Ki, u_max=150.0, Vs=P.Vs, delta=P.delta, noise_std=1e-3, sensor_gate=False)
REF = multisine_reference(1.0, rng=np.random.default_rng(0))
CLI = "import sys; from controllers.cli import main; sys.exit(main())"

#: A compensator module for scenario files: raises the builtin exception ``exc`` in ``where`` at period ``at``.
RAISER = '''
import builtins


class Raiser:
    def __init__(self, ctx, where="compensate", at=200, exc="KeyboardInterrupt"):
        self.where, self.at, self.exc, self.k = where, at, getattr(builtins, exc), 0

    def compensate(self, w_meas, w_ref):
        if self.where == "compensate" and self.k == self.at:
            raise self.exc(4) if self.exc is SystemExit else self.exc()
        return 0.0

    def observe(self, u, w_meas):
        if self.where == "observe" and self.k == self.at:
            raise self.exc(4) if self.exc is SystemExit else self.exc()
        self.k += 1
'''


def _scenario(tmp_path, where: str, exc: str = "KeyboardInterrupt"):
    (tmp_path / "raiser.py").write_text(RAISER)
    path = tmp_path / "sc.toml"
    path.write_text(f'modes = ["none"]\n[plant]\npreset = "paper"\n[reference]\nduration = 1.0\n[drive]\n'
                    f'u_max = 150.0\n[compensation]\nVs = 0.02\ndelta = 1.0\n[compensators.mine]\n'
                    f'factory = "raiser.py:Raiser"\nwhere = "{where}"\nexc = "{exc}"\n')
    return path


class Interrupted:
    """Raises ``exc`` in ``where`` at period 100 and counts the calls after it."""

    def __init__(self, where, exc):
        self.where, self.exc, self.k, self.after = where, exc, 0, 0

    def compensate(self, w_meas, w_ref):
        self.after += self.k > 100
        if self.where == "compensate" and self.k == 100:
            raise self.exc
        return 0.0

    def observe(self, u, w_meas):
        if self.where == "observe" and self.k == 100:
            raise self.exc
        self.k += 1


@pytest.mark.parametrize("where", ["compensate", "observe"])
@pytest.mark.parametrize("exc", [KeyboardInterrupt, SystemExit, GeneratorExit])
def test_an_interrupt_in_the_compensator_ends_the_run_and_propagates(where, exc):
    comp = Interrupted(where, exc)
    with pytest.raises(exc):
        run_own(P, REF, comp, OPTS, rng=np.random.default_rng(1))
    assert comp.k == 100 and comp.after == 0  # the user's code is not called again: the run ended there


def test_an_interrupt_in_observe_exits_130_and_writes_nothing(tmp_path):
    sc = _scenario(tmp_path, "observe")
    r = subprocess.run([sys.executable, "-c", CLI, "compare", "--scenario", str(sc), "--out", str(tmp_path / "out"),
                        "--report", str(tmp_path / "rep"), "--quiet"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 130, r.stderr
    assert "interrupted" in r.stderr and "Traceback" not in r.stderr and "cffi" not in r.stderr
    assert r.stdout == ""  # no table
    assert not any((tmp_path / d).exists() and any((tmp_path / d).iterdir()) for d in ("out", "rep"))


def test_an_interrupt_in_compensate_exits_130_and_writes_nothing(tmp_path, capsys):
    sc = _scenario(tmp_path, "compensate")
    out, rep = tmp_path / "out", tmp_path / "rep"
    assert main(["compare", "--scenario", str(sc), "--out", str(out), "--report", str(rep), "--quiet"]) == 130
    cap = capsys.readouterr()
    assert cap.out == "" and "interrupted" in cap.err
    assert not any(d.exists() and any(d.iterdir()) for d in (out, rep))


def test_system_exit_in_the_compensator_exits_with_its_code(tmp_path, capsys):
    sc = _scenario(tmp_path, "observe", "SystemExit")
    with pytest.raises(SystemExit) as info:
        main(["compare", "--scenario", str(sc), "--no-figures", "--quiet"])
    assert info.value.code == 4 and capsys.readouterr().out == ""


def test_generator_exit_in_the_compensator_is_one_line_exit_1(tmp_path, capsys):
    sc = _scenario(tmp_path, "compensate", "GeneratorExit")
    assert main(["compare", "--scenario", str(sc), "--no-figures", "--quiet"]) == 1
    cap = capsys.readouterr()
    assert cap.out == "" and "GeneratorExit" in cap.err and "Traceback" not in cap.err


@pytest.mark.parametrize("value", ["1.0", None, [1.0], np.array([1.0]), True, 1j])
def test_a_return_value_that_is_not_a_real_number_is_a_compensator_error(value):
    class Returns:
        name = "stringly"

        def compensate(self, w_meas, w_ref):
            return value

        def observe(self, u, w_meas):
            return None

    with pytest.raises(CompensatorError, match=r"'stringly': compensate failed at period 0.*must be a real number"):
        run_own(P, REF, Returns(), OPTS, rng=np.random.default_rng(1))


@pytest.mark.parametrize("value", [1, 1.0, np.float32(1.0), np.int64(1), np.array(1.0)])
def test_real_numbers_of_any_kind_are_accepted_alike(value):
    class Returns:
        def compensate(self, w_meas, w_ref):
            return value

        def observe(self, u, w_meas):
            return None

    r = run_own(P, REF, Returns(), OPTS, rng=np.random.default_rng(1))
    assert np.all(r.u_ff == 1.0) and not r.info["diverged"]
