"""The estimator rows of ``compare`` (``CompareOptions.estimator_rows``, ``--estimator-rows``): mode ``adaptive`` with
another estimator beside the others, on the same reference and noise.

Each row is checked against an independent comparison that runs that estimator as the ``adaptive`` mode's own: the
two must agree to the last bit (same preparation, same seed, same noise), and the rows must not disturb the others.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from controllers.cli.main import main
from controllers.experiments.compare import CompareOptions, compare
from plant.errors import ParameterError
from plant.friction import preset
from plant.variant_plants import variant

_BASE = dict(duration=4.0, seed=3, progress=False)


@pytest.fixture(scope="module")
def paper_with_rows():
    return compare(preset("paper"), modes=("none", "adaptive", "dob", "frictionless"),
                   estimator_rows=("eq4", "eq4-rls"), **_BASE)


@pytest.mark.parametrize("estimator", ["eq4", "eq4-rls"])
def test_a_row_is_the_adaptive_mode_of_its_estimator_bit_for_bit(paper_with_rows, estimator):
    alone = compare(preset("paper"), modes=("none", "adaptive", "frictionless"), estimator=estimator, **_BASE)
    row, own = paper_with_rows.results[f"adaptive[{estimator}]"], alone.results["adaptive"]
    np.testing.assert_array_equal(row.w, own.w)
    np.testing.assert_array_equal(row.u_ff, own.u_ff)
    assert paper_with_rows.eta[f"adaptive[{estimator}]"] == alone.eta["adaptive"]
    assert row.info["estimator"] == estimator


def test_the_rows_leave_the_other_modes_as_they_were(paper_with_rows):
    plain = compare(preset("paper"), modes=("none", "adaptive", "dob", "frictionless"), **_BASE)
    for mode in ("none", "adaptive", "dob", "frictionless"):
        np.testing.assert_array_equal(paper_with_rows.results[mode].w, plain.results[mode].w)
    assert paper_with_rows.results["adaptive"].info["estimator"] == "sliding"


def test_rows_stand_right_after_adaptive_in_table_and_json(paper_with_rows):
    order = ["none", "adaptive", "adaptive[eq4]", "adaptive[eq4-rls]", "dob", "frictionless"]
    assert list(paper_with_rows.results) == order
    assert [r["mode"] for r in paper_with_rows.rows()] == order
    d = json.loads(json.dumps(paper_with_rows.to_dict(), allow_nan=False))
    assert list(d["modes"]) == order
    lines = paper_with_rows.table().splitlines()
    # the rows of an estimator export-c does not write are marked, with a footnote: no drive runs them
    marked = [m + "*" if m in ("adaptive[eq4]", "adaptive[eq4-rls]") else m for m in order]
    assert [ln.split()[0] for ln in lines[2:-1]] == marked
    assert lines[-1] == ("* estimator 'eq4' (adaptive[eq4]); estimator 'eq4-rls' (adaptive[eq4-rls]): research "
                         "variants; export-c writes mode adaptive with the sliding estimator")
    assert paper_with_rows.research_rows() == {"adaptive[eq4]": "eq4", "adaptive[eq4-rls]": "eq4-rls"}


def test_without_adaptive_a_row_stands_where_adaptive_would():
    c = compare(preset("paper"), modes=("none", "dob", "frictionless"), estimator_rows=("eq4",), **_BASE)
    assert list(c.results) == ["none", "adaptive[eq4]", "dob", "frictionless"]


@pytest.mark.parametrize("rows, why", [
    (("magic",), "must be one of ('sliding', 'eq4', 'eq4-rls'), got 'magic'"),
    (("eq4-iv",), "'eq4-iv' is now 'eq4'"),  # the former name gets a pointer to the current one
    (("sliding",), "'sliding' is the estimator of the adaptive mode's own row"),
    (("eq4-rls", "eq4-rls"), "given twice"),
    ("eq4-rls", "must be a tuple"),
])
def test_bad_rows_are_refused_by_name(rows, why):
    with pytest.raises(ParameterError, match="estimator_rows") as exc:
        CompareOptions.from_flat(estimator_rows=rows)
    assert why in str(exc.value)


def test_a_compensator_may_not_take_a_row_label():
    with pytest.raises(ParameterError, match="compensators"):
        CompareOptions.from_flat(estimator_rows=("eq4-rls",), compensators={"adaptive[eq4-rls]": lambda ctx: None})


def test_cli_prints_the_row_and_refuses_it_beside_a_scenario(tmp_path, capsys):
    assert main(["compare", "--duration", "4", "--seed", "3", "--modes", "none,adaptive,frictionless",
                 "--estimator-rows", "eq4", "--no-figures", "--quiet", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert list(d["modes"]) == ["none", "adaptive", "adaptive[eq4]", "frictionless"]
    sc = tmp_path / "s.toml"
    sc.write_text('modes = ["none", "adaptive"]\n[plant]\npreset = "paper"\n[reference]\nduration = 4.0\n')
    assert main(["compare", "--scenario", str(sc), "--estimator-rows", "eq4-rls", "--no-figures", "--quiet"]) == 2
    assert "--estimator-rows cannot be combined with --scenario" in capsys.readouterr().err


def test_rows_alone_need_the_prefit_and_the_refusal_names_their_mode():
    with pytest.raises(ParameterError, match=r"modes \['adaptive'\] need Vs and delta"):
        compare(preset("paper"), modes=("none", "dob", "frictionless"), estimator_rows=("eq4-rls",), prefit=False,
                **_BASE)


def test_the_feedforward_alone_that_makes_the_joint_stick_and_slip_is_kept_off_by_the_tracking_test():
    # the paper's RLS as printed, as the feedforward alone, on the Karnopp variant: its biased estimate makes the
    # loop stick and slip (eta -1.96 over 30 s where the torque test alone restores it twice); the supervisor's
    # tracking test refuses to restore it (the velocity error with it stays far above the error without), so the
    # mode ends no worse than none; with the switch-in, the default, the same estimator is at the frictionless loop
    base = dict(modes=("none", "adaptive", "frictionless"), estimator="eq4-rls", duration=30.0, seed=0, progress=False)
    bare = compare(variant("karnopp"), switch_in=False, **base)
    info = bare.results["adaptive"].info
    assert info["n_backoff"] == 1 and info["n_restore"] == 0 and info["t_off"] > 25.0
    assert abs(bare.eta["adaptive"]) < 0.02
    assert not [n for n in bare.notes if "worse than no compensation" in n]
    guarded = compare(variant("karnopp"), **base)
    assert guarded.eta["adaptive"] > 0.9
    assert not [n for n in guarded.notes if "worse than no compensation" in n]



@pytest.mark.xfail(strict=True, raises=AssertionError, reason="known: the supervisor's tracking test backs the eq. 4 "
                   "feedforward off at 1.3 s, while its first estimate is poor, and never restores it (118.7 s off, "
                   "eta 0.000) though the estimate converges: with the tracking test off the same feedforward reaches "
                   "eta 0.975. Measured cause: backed off, the joint moves with the reference (same sign, half its "
                   "speed or more) in 57 % of the moving reference's periods and sticks or lags in the rest, where the "
                   "candidate at the measured velocity takes the noise's sign; the statistics of the off state counted "
                   "in the moving periods alone restore it (18.9 s off, eta 0.987) and keep the Karnopp case's "
                   "feedforward off, but delay the restore of the eq4-rls feedforward at the reference velocity "
                   "(test_closed_loop's eq. 4 test: 7.5-8.8 s off -> 16-21 s, RMS ratios 0.33 -> 0.90-0.95)")
def test_a_feedforward_backed_off_early_comes_back_once_its_estimate_converges():
    base = dict(modes=("none", "adaptive", "frictionless"), estimator="eq4", seed=3, switch_in=False, progress=False)
    free = compare(preset("paper"), supervise_tracking=False, **base)
    info = free.results["adaptive"].info
    assert info["n_backoff"] == 0 and free.eta["adaptive"] > 0.96  # the feedforward never supervised: 0.975
    supervised = compare(preset("paper"), **base)
    assert supervised.results["adaptive"].info["n_restore"] >= 1
    assert supervised.eta["adaptive"] > 0.9


def test_worse_than_none_notes_threshold_and_modes():
    from types import SimpleNamespace

    from controllers.experiments.compare import WORSE_THAN_NONE, worse_than_none_notes

    results = {m: SimpleNamespace(info=info) for m, info in (
        ("fixed", {}), ("adaptive", {"estimator": "sliding", "t_switch_in": None}),
        ("adaptive[eq4-rls]", {"estimator": "eq4-rls"}), ("dob", {}))}
    etas = {"fixed": WORSE_THAN_NONE, "adaptive": -0.5, "adaptive[eq4-rls]": -0.03, "dob": None}
    notes = worse_than_none_notes(etas, results)
    # fixed at the threshold itself is not worse than none; undefined eta gives no note
    assert [n.split(":")[0] for n in notes] == ["adaptive", "adaptive[eq4-rls]"]
    assert "feedforward alone" not in notes[0]  # adaptive ran with its switch-in
    assert notes[1] == ("adaptive[eq4-rls]: worse than no compensation (eta -0.03 over the second half); it ran as "
                        "the feedforward alone (switch_in=False, --no-switch-in), with estimator 'eq4-rls': the "
                        "residual switch-in, the default, hands over to the observer where the feedforward misses")


def test_the_cli_offers_exactly_the_package_estimators():
    # the CLI's parser names the choices itself (it is built without importing the compiled core)
    from controllers.cli.main import build_parser
    from controllers.simulation.compensators import ESTIMATORS

    sub = next(a for a in build_parser()._subparsers._group_actions[0].choices["compare"]._actions
               if a.dest == "estimator")
    assert tuple(sub.choices) == ESTIMATORS
