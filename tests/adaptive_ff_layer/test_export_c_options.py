"""``export-c`` refuses, naming the option, a setting its float build cannot represent or that is physically
absurd (exit 2, before anything is read or written); the float build would otherwise stop at an ``#error``."""

import json

import pytest

from controllers.cli.main import main
from export_c_helpers import ID_JSON

BAD = [(["--Tc", "1e-300"], "--Tc 1e-300 s: must be a finite number in the plausible range"),
       (["--Tc", "2"], "--Tc 2.0 s: a drive's controller period is at most 1 s"),
       (["--Ts", "1e300"], "--Ts 1e+300 s: must be a finite number"), (["--Ts", "100"], "--Ts 100.0 s: at most 1000"),
       (["--J-design", "1e300"], "--J-design 1e+300 kg·m²"), (["--ff-max", "1e300"], "--ff-max 1e+300 N·m"),
       (["--stick-band", "1e300"], "--stick-band 1e+300 rad/s"), (["--Vs", "1e-300"], "--Vs 1e-300 rad/s"),
       (["--Vs", "1e300"], "--Vs 1e+300 rad/s"), (["--delta", "1e300"], "--delta 1e+300: the Stribeck shape factor"),
       (["--Kp", "1e300", "--Ki", "1"], "--Kp 1e+300 N·m·s/rad"), (["--Kp", "1", "--Ki", "inf"], "--Ki inf N·m/rad"),
       (["--crossover", "1e300"], "--crossover 1e+300 rad/s"), (["--phase-margin", "500"], "--phase-margin 500.0"),
       (["--hold-time", "1e30"], "--hold-time 1e+30 s"), (["--w-max", "1e38"], "--w-max 1e+38 rad/s"),
       (["--u-max", "1e10"], "--u-max 10000000000.0 N·m: must be a finite number in the plausible range")]


@pytest.mark.parametrize("extra,message", BAD)
def test_absurd_or_unrepresentable_settings_are_refused_naming_the_option(tmp_path, capsys, extra, message):
    f = tmp_path / "id.json"
    f.write_text(json.dumps(ID_JSON))
    out = tmp_path / "drive"
    argv = ["export-c", "--from", str(f), "--out", str(out)] + (["--u-max", "150"] if "--u-max" not in extra else [])
    assert main(argv + extra) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not out.exists() or not any(out.iterdir())

