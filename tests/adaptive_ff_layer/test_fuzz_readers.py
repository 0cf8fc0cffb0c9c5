"""Fuzz of the file readers (derandomized Hypothesis): a typed error or a result, never another exception.

Readers: drive-log CSV (:func:`adaptive_ff.io.logs.load_log`), plant JSON
(:func:`plant.models.load_plant`) and sweep specs (:func:`controllers.experiments.sweep.load_spec`,
then :func:`~controllers.experiments.sweep.check_case` on every case it expands to).
"""

import atexit
import json
import shutil
import tempfile
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from adaptive_ff.io.data import MeasuredData
from adaptive_ff.io.logs import CsvFormat, load_log
from controllers.experiments.sweep import SweepSpec, check_case, expand_cases, load_spec
from plant.errors import FrictionError
from plant.models import load_plant

SETTINGS = settings(derandomize=True, max_examples=150, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])
_DIR = Path(tempfile.mkdtemp(prefix="fuzz_readers_"))  # one folder for every example, removed at exit
atexit.register(shutil.rmtree, _DIR, ignore_errors=True)

cell = st.one_of(st.floats(allow_nan=True, allow_infinity=True).map(repr), st.integers(-10**30, 10**30).map(str),
                 st.sampled_from(["", "t", "u", "w", "nan", "1e308", "-1e308", "#", " ", "1,5", '"', "x"]))
line = st.lists(cell, min_size=0, max_size=5).map(lambda cs: ",".join(cs))
csv_text = st.one_of(
    st.lists(line, max_size=30).map("\n".join),
    st.tuples(st.sampled_from(["t,u,w", "# t,u,w", "Model,X\nTime,CH1,CH2", ""]),
              st.lists(st.tuples(st.floats(-1e3, 1e3), st.one_of(st.floats(-1e3, 1e3), st.sampled_from([1e308, -1e308, float("nan"), float("inf")])),
                                 st.floats(-1e3, 1e3)), max_size=40))
      .map(lambda h: h[0] + "\n" + "\n".join(f"{i * 1e-3 + a * 0:.6g},{b!r},{c!r}"
                                                for i, (a, b, c) in enumerate(h[1]))),
)

json_value = st.recursive(
    st.one_of(st.none(), st.booleans(), st.integers(-10**400, 10**400), st.floats(allow_nan=False),
              st.text(max_size=8)),
    lambda inner: st.one_of(st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=6), inner, max_size=4)),
    max_leaves=12)
plant_keys = st.sampled_from(["model", "J", "Fc", "Fs", "Vs", "delta", "sigma", "tau", "drift", "sigma0", "x"])
number = st.one_of(st.floats(allow_nan=False), st.integers(-10**30, 10**30), st.sampled_from([4.0, 25.0, 0.02]))
plant_obj = st.dictionaries(plant_keys, st.one_of(number, json_value), max_size=9)

spec_keys = st.sampled_from(["preset", "plant", "grid", "controller", "monte_carlo", "modes", "seeds",
                             "duration", "options", "bogus"])
small_list = st.lists(number, min_size=0, max_size=3)
spec_value = st.one_of(
    json_value, small_list, st.dictionaries(st.sampled_from(["Fc", "J", "sigma", "crossover", "phase_margin", "Q"]),
                                            st.one_of(small_list, number), max_size=3),
    st.fixed_dictionaries({"n": st.integers(-2, 5), "seed": st.integers(-2, 5)},
                          optional={"Fc": st.dictionaries(st.sampled_from(["uniform", "normal", "beta"]),
                                                          small_list, max_size=2)}),
    st.lists(st.sampled_from(["none", "adaptive", "magic", 3]), max_size=3),
    st.dictionaries(st.sampled_from(["prefit", "Ts", "lam", "turbo"]), json_value, max_size=2))
spec_obj = st.dictionaries(spec_keys, spec_value, max_size=6)


def _file(name: str, data: bytes) -> Path:
    p = _DIR / name
    p.write_bytes(data)
    return p


@SETTINGS
@given(text=csv_text, columns=st.sampled_from([None, "t=0,u=1,w=2", "t=Time,u=CH1,w=CH2"]),
       fmt=st.sampled_from([CsvFormat(), CsvFormat(skip_rows=1), CsvFormat(header_line=2),
                            CsvFormat(delimiter="semicolon")]))
def test_csv_reader_fuzz(text, columns, fmt):
    path = _file("log.csv", text.encode("utf-8"))
    try:
        d = load_log(path, columns=columns, csv_format=fmt)
    except FrictionError:
        return
    assert isinstance(d, MeasuredData) and d.n_samples >= 20


@SETTINGS
@given(data=st.binary(max_size=300), suffix=st.sampled_from([".csv", ".mat", ".npz"]))
def test_binary_garbage_fuzz(data, suffix):
    path = _file("garbage" + suffix, data)
    try:
        load_log(path)
    except FrictionError:
        pass


@SETTINGS
@given(obj=st.one_of(plant_obj, json_value), raw=st.one_of(st.none(), st.binary(max_size=40)))
def test_plant_json_fuzz(obj, raw):
    path = _file("plant.json", raw if raw is not None else json.dumps(obj).encode())
    try:
        p = load_plant(path)
    except FrictionError:
        return
    assert p.J > 0


@SETTINGS
@given(obj=st.one_of(spec_obj, json_value))
def test_sweep_spec_fuzz(obj):
    path = _file("spec.json", json.dumps(obj).encode())
    try:
        spec = load_spec(path)
    except FrictionError:
        return
    assert isinstance(spec, SweepSpec)
    cases = expand_cases(spec)
    assert cases
    for case in cases[:50]:
        try:
            check_case(case)
        except FrictionError:
            break
