"""One answer at the top of an identification file, and one reader of it.

``identify --json`` on the controller-rate log of the paper joint (J 4, Fc 25, Fs 35, sigma 40, tau 0.02; the
README's demo case) leads with the sliding-regime estimate; the paper's eq. 4 LS (J about 32 on this 20 s log,
171.6 on the README's) is nested under ``baselines``. ``design --from`` and ``export-c --from`` read the top
level; files of the former layout (answer under ``physical.params``) still read right; a file of neither
layout is refused naming the file and the key.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from adaptive_ff.identification.result_file import (IdentificationFileError, identification_from_dict,
                                                    read_identification)
from controllers.experiments.compensator_file import compensator_from_file
from controllers.cli.main import main
from controllers.design.pi import design_pi
from controllers.experiments.synthetic_logs import closed_loop_run, write_controller_log
from plant import preset
from plant.errors import ParameterError
from plant.excitation import multisine_reference

P = preset("paper")
VS, DELTA = 0.0197756, 1.01582  # the Stribeck pre-fit of the README's quasi-static log (true 0.02, 1)


@pytest.fixture(scope="module")
def id_json(tmp_path_factory):
    """``identify --json`` of a 20 s, 1 kHz closed-loop log of the paper joint (seeded), written to a file."""
    ref = multisine_reference(20.0, dt=1e-3, peak=math.radians(20.0), rng=np.random.default_rng(1))
    design = design_pi(P.J, crossover=20.0, phase_margin=60.0, Tc=1e-3)
    u_max = 3.0 * (max(P.Fs, P.Fc) + P.sigma * float(np.max(np.abs(ref.w))) + P.J * float(np.max(np.abs(ref.dw))))
    run = closed_loop_run(P, ref, design=design, u_max=u_max, noise_std=1e-3, rng=np.random.default_rng(2))
    folder = tmp_path_factory.mktemp("ident")
    csv = write_controller_log(folder / "controller_log.csv", run, current_to_torque=60.0)
    return folder, csv, run


@pytest.fixture(scope="module")
def out(id_json):
    _, csv, _ = id_json
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main(["identify", str(csv), "--columns", "t=time_ms,u=current_A,w=velocity_deg_s", "--time-unit",
                     "ms", "--current-to-torque", "60", "--velocity-unit", "deg/s", "--Vs", str(VS), "--delta",
                     str(DELTA), "--json"]) == 0
    return json.loads(buf.getvalue())


def test_top_level_is_the_chosen_method_and_eq4_is_a_baseline(out):
    assert out["method"] == "sliding" and "physical" not in out and "rls" not in out
    # the sliding-regime regression recovers the joint (measured J +2.7 %, Fc, Fs, sigma within 0.2 %)
    assert out["J"] == pytest.approx(P.J, rel=0.04)
    for k in ("Fc", "Fs", "sigma"):
        assert out[k] == pytest.approx(getattr(P, k), rel=0.015), k
    assert out["tau"] == pytest.approx(P.tau, rel=0.04)
    assert out["Vs"] == VS and out["delta"] == DELTA
    assert set(out["std"]) == {"J", "Fc", "Fs", "sigma", "tau", "offset"} and all(v > 0 for v in out["std"].values())
    assert out["form"]["name"] == "lagged Stribeck" and out["form"]["fixed"] == {"Vs": VS, "delta": DELTA}
    assert out["form"]["fitted"] == ["J", "Fc", "Fs", "sigma", "tau", "offset"]
    # the paper's eq. 4 LS/RLS, under their names: far off on this closed-loop log (J 8 times too large)
    ls, rls = out["baselines"]["eq4_ls"], out["baselines"]["eq4_rls"]
    assert ls["J"] > 5 * P.J and rls["J"] == pytest.approx(ls["J"], rel=0.01)
    assert {"J", "Fc", "Fs", "sigma", "tau", "offset", "std", "fit_free_run_percent"} <= set(ls)


def test_design_and_export_c_read_the_top_level(out, id_json, capsys):
    folder, _, _ = id_json
    idj = folder / "id.json"
    idj.write_text(json.dumps(out))
    assert main(["design", "--from", str(idj), "--no-figures", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["J"] == out["J"] and d["sigma"] == out["sigma"]
    expect = design_pi(out["J"], sigma=out["sigma"], crossover=20.0, phase_margin=60.0, Tc=1e-3)
    _, s = compensator_from_file(idj, u_max=150.0)
    assert s["J_design"] == out["J"] and s["joint"] == {k: out[k] for k in ("Fc", "Fs", "sigma")}
    assert s["Kp"] == pytest.approx(expect.Kp, rel=1e-12) and s["Ki"] == pytest.approx(expect.Ki, rel=1e-12)
    assert s["options"].estimator.Vs == VS and s["options"].feedforward.stick_band == pytest.approx(3 * out["excitation"]["noise_std"])


def _former_layout(out: dict) -> dict:
    """The same identification as the package wrote it before the baselines layout: eq. 4 LS at the top level,
    the answer under ``physical``."""
    ls = out["baselines"]["eq4_ls"]
    old = {k: ls[k] for k in ("J", "sigma", "Fc", "Fs", "tau", "offset", "fit_percent", "cond", "std")}
    old.update(Vs=out["Vs"], delta=out["delta"], rls=out["baselines"]["eq4_rls"], excitation=out["excitation"],
               warnings=out["warnings"], notes=out["notes"], method=out["method"])
    old["physical"] = {"method": out["method"], "params": {k: out[k] for k in ("J", "Fc", "Fs", "sigma", "tau")},
                       "stderr": out["std"], "warnings": []}
    return old


def test_one_reader_for_both_layouts(out, tmp_path):
    new, old = tmp_path / "new.json", tmp_path / "old.json"
    new.write_text(json.dumps(out))
    old.write_text(json.dumps(_former_layout(out)))
    a, b = read_identification(new), read_identification(old)
    assert (a.layout, b.layout) == ("top", "physical")
    for k in ("J", "Fc", "Fs", "sigma", "tau"):
        assert getattr(a, k) == getattr(b, k) == out[k], k
    assert a.method == b.method == "sliding" and a.Vs == b.Vs == VS and a.noise_std == b.noise_std
    assert b.params["offset"] == 0.0 and a.params["offset"] == out["offset"]  # the former physical table had none
    # the readers give the same answer for either file
    _, sa = compensator_from_file(new, u_max=150.0)
    _, sb = compensator_from_file(old, u_max=150.0)
    assert sa["J_design"] == sb["J_design"] == out["J"] and sa["Kp"] == sb["Kp"] and sa["joint"] == sb["joint"]
    from controllers.cli.design import plant_from_file

    assert plant_from_file(new) == plant_from_file(old) == (out["J"], out["sigma"])


def test_a_former_paper_file_reads_its_top_level():
    d = {"J": 95.1, "sigma": 203.5, "Fc": 20.4, "Fs": 20.4, "tau": 0.0, "offset": -0.2, "method": "paper",
         "rls": {"J": 95.0}}
    j = identification_from_dict(d)
    assert j.layout == "eq4" and j.method == "paper" and j.J == 95.1 and j.params["offset"] == -0.2 and j.Vs is None


def test_neither_layout_names_the_file_and_the_key(out, tmp_path, capsys):
    no_j = tmp_path / "no_j.json"
    no_j.write_text(json.dumps({k: v for k, v in out.items() if k != "J"}))
    with pytest.raises(IdentificationFileError, match=r"no_j\.json: no 'J'") as e:
        read_identification(no_j)
    assert e.value.key == "J" and isinstance(e.value, ParameterError)
    bad = tmp_path / "bad_physical.json"
    bad.write_text(json.dumps({"method": "sliding", "physical": {"method": "sliding", "params": {"J": 4.0}}}))
    with pytest.raises(IdentificationFileError, match=r"bad_physical\.json: no 'physical\.params\.Fc'"):
        read_identification(bad)
    empty = tmp_path / "empty_physical.json"
    empty.write_text(json.dumps({"method": "sliding", "physical": {"method": "sliding"}}))
    with pytest.raises(IdentificationFileError, match=r"empty_physical\.json: 'physical' has no 'params'"):
        read_identification(empty)
    with pytest.raises(IdentificationFileError, match="'sigma' must be a finite number"):
        identification_from_dict({**out, "sigma": "40"})
    # the CLI readers say the same, without a traceback
    for argv in (["design", "--from", str(no_j), "--no-figures"],
                 ["export-c", "--from", str(bad), "--u-max", "150", "--out", str(tmp_path / "c")]):
        assert main(argv) != 0
        err = capsys.readouterr().err
        assert "Traceback" not in err and ("no 'J'" in err or "no 'physical.params.Fc'" in err), err


def test_report_attributes_and_summary_lead_with_the_answer(id_json):
    from adaptive_ff.identification.identify import identify

    rep = identify(id_json[2].controller_log(), Vs=VS, delta=DELTA, method="auto")
    assert rep.method == "sliding" and rep.J == rep.physical.params["J"] == rep.params["J"]
    assert rep.J == pytest.approx(P.J, rel=0.04) and rep.estimate.J > 5 * P.J  # estimate: the eq. 4 baseline
    assert rep.stderr == rep.physical.stderr and (rep.Vs, rep.delta) == (VS, DELTA)
    assert rep.to_dict()["J"] == rep.J and rep.baselines["eq4_ls"]["J"] == rep.estimate.J
    lines = rep.summary().splitlines()
    assert lines[1].startswith("method 'sliding': lagged Stribeck")
    first_j = next(x for x in lines if x.startswith("J "))
    assert float(first_j.split()[1]) == pytest.approx(rep.J, rel=1e-5)  # the answer's J is the first J row
    assert lines.index(first_j) < next(i for i, x in enumerate(lines) if x.startswith("baselines:"))


def test_html_report_leads_with_the_answer(id_json, tmp_path):
    from adaptive_ff.identification.identify import identify
    from controllers.report.html import identify_report

    log = id_json[2].controller_log()
    rep = identify(log, Vs=VS, delta=DELTA, method="sliding")
    html = identify_report(tmp_path / "r", rep, log).read_text(encoding="utf-8")
    answer = html.index("Answer: method <b>sliding</b>")
    assert answer < html.index(f"{rep.J:.6g}") < html.index("Baselines: the paper's eq. 4") < html.index("LS value")
