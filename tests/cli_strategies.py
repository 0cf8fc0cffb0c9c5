"""Hypothesis strategies of ``adaptive-ff`` command lines and their input files, and the checks every run must pass.

Shared by tests/docs_cli/test_fuzz_cli.py (a bounded, derandomized run in CI) and benchmarks/fuzz_cli.py (longer runs that
print the cases tried). A case (:class:`CliCase`) is an argument vector with ``{dir}`` standing for a fresh working
folder, the input files to write there first (CSV logs, plant JSON, scenario TOML, identification JSON, sweep
specs: valid ones, ones at the boundaries, broken ones) and the outputs it names. :func:`run_case` runs it
in-process (:func:`controllers.cli.main.main`) and :func:`check_outcome` asserts what the command line promises:

* the exit status is 0, 2, 3 or 130 (1 is an internal error, a defect);
* no traceback on stdout or stderr;
* an error (status 2) names a file, an option or a key of the input (or is argparse's usage error);
* no partial output: a failed run leaves the working folder byte for byte (a sweep's results, appended case by
  case, excepted), and no run leaves a staging folder or a lock behind;
* ``--json`` on a run that succeeds prints strict JSON (no NaN or Infinity), whose files exist.

``heavy=True`` (the benchmark) adds the slow paths: figures and reports, output-error and closed-loop fits, model
forms, paper-figures, longer runs.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import re
import shlex
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from hypothesis import strategies as st

__all__ = ["CliCase", "Outcome", "cli_cases", "run_case", "check_outcome", "toml_text"]

#: What a number option may be given: valid values (drawn from a range), boundaries and text that is no number.
BROKEN_NUMBERS = ("0", "-1", "-0", "1e-300", "1e300", "1e309", "inf", "-inf", "nan", "x", "", " ", "1,5", "0x10",
                  "1e", "--")


@dataclass
class CliCase:
    """One command line: ``argv`` (``{dir}`` is the working folder), the input ``files`` ({name: bytes}) and the
    ``outputs`` it names (relative paths); ``appended``: outputs a failed run may extend (a sweep's results)."""

    argv: list
    files: dict = field(default_factory=dict)
    outputs: tuple = ()
    appended: tuple = ()

    def command(self, folder="{dir}") -> list:
        """The argument vector with the working folder filled in."""
        return [a.replace("{dir}", str(folder)) for a in self.argv]

    def describe(self) -> str:
        """The command line and the first bytes of each input file, for a report."""
        lines = ["adaptive-ff " + shlex.join(self.argv)]
        for name, data in self.files.items():
            head = data[:300].decode("utf-8", errors="backslashreplace").replace("\n", "\\n")
            lines.append(f"  {name} ({len(data)} bytes): {head}{'...' if len(data) > 300 else ''}")
        return "\n".join(lines)


@dataclass
class Outcome:
    """What a run did: the exit ``status``, ``stdout``, ``stderr``, ``seconds``, the working folder's files before
    and after (``{relative path: bytes}``)."""

    status: int
    stdout: str
    stderr: str
    seconds: float
    before: dict
    after: dict


# --------------------------------------------------------------------------------------------- values


def number(lo: float, hi: float, *, log: bool = False, broken: bool = True):
    """Text of a number option: mostly in ``[lo, hi]`` (log-uniform with ``log``), sometimes a boundary or
    (one time in ten) broken text."""
    if log:
        valid = st.floats(math.log10(lo), math.log10(hi)).map(lambda e: f"{10.0 ** e:.6g}")
    else:
        valid = st.floats(lo, hi, allow_nan=False, allow_infinity=False).map(lambda x: f"{x:.6g}")
    edges = st.sampled_from([f"{lo:g}", f"{hi:g}"])
    choices = [valid] * 8 + [edges] + ([st.sampled_from(BROKEN_NUMBERS)] if broken else [])
    return st.one_of(*choices)


def integer(lo: int, hi: int):
    """Text of an integer option: mostly in ``[lo, hi]``, sometimes a boundary or broken text."""
    return st.one_of(*[st.integers(lo, hi).map(str)] * 6,
                     st.sampled_from([str(lo - 1), "0", "-1", "10000000000000000000000", "1.5", "x", "", "1e3"]))


def options(table: dict, max_size: int = 4):
    """A list of option tokens: up to ``max_size`` options of ``table`` ({"--name": strategy of its value text, or
    None for a flag}), each once."""
    def tokens(chosen):
        parts = [st.just([n]) if table[n] is None else table[n].map(lambda v, n=n: [n, v]) for n in chosen]
        return st.tuples(*parts).map(lambda ps: [x for p in ps for x in p])

    return st.lists(st.sampled_from(sorted(table)), unique=True, max_size=max_size).flatmap(tokens)


# --------------------------------------------------------------------------------------------- files

_LOGS: dict = {}


def _base_log(kind: str) -> np.ndarray:
    """Columns t, u, w of a simulated log of the paper joint (cached): ``uniform`` 1 kHz, ``irregular``, or
    ``quasi-static`` (constant-velocity runs in both directions, 100 Hz: what ``stribeck`` fits)."""
    if kind == "quasi-static" and kind not in _LOGS:
        from controllers.experiments.quasi_static import bidirectional_velocities
        from controllers.experiments.synthetic_logs import quasi_static_log
        from plant import preset

        d = quasi_static_log(preset("paper"), bidirectional_velocities(0.005, 0.4, 6), hold=0.8, settle=0.5,
                             noise_std=1e-3, rng=np.random.default_rng(0))
        _LOGS[kind] = np.column_stack([d.t, d.u, d.w])
    if kind not in _LOGS:
        from plant import preset, simulate

        t = np.arange(0.0, 1.5, 1e-3)
        u = 45.0 * np.sin(2 * np.pi * 1.0 * t) + 10.0 * np.sin(2 * np.pi * 7.1 * t)
        w = simulate(preset("paper"), u, dt=1e-3).w[:-1]
        rows = np.column_stack([t, u, w])
        if kind == "irregular":
            keep = np.random.default_rng(0).random(t.shape[0]) < 0.4
            rows = rows[keep]
        _LOGS[kind] = rows
    return _LOGS[kind]


@st.composite
def csv_log(draw) -> bytes:
    """A CSV drive log: a simulated one (uniform or irregular time stamps, its columns and units varied), cut to a
    boundary length, a corrupted cell, a constant signal, or text that is no log."""
    kind = draw(st.sampled_from(["uniform", "uniform", "irregular", "quasi-static", "garbage"]))
    if kind == "garbage":
        return draw(st.sampled_from([b"", b"t,u,w\n", b"t,u,w\n0,1,2\n", b"\xff\xfe\x00garbage", b"t;u;w\n0;1;2\n",
                                     b"# only a comment\n", b"t,u,w\n" + b"0,0,0\n" * 50]))
    rows = _base_log(kind).copy()
    n = draw(st.sampled_from([rows.shape[0]] * 4 + [200, 30, 2]))
    rows = rows[:n]
    change = draw(st.sampled_from(["none"] * 5 + ["cell", "constant", "repeat_t", "ms"]))
    cells = [[repr(float(x)) for x in r] for r in rows]
    header = "t,u,w"
    if change == "cell" and n:
        i, j = draw(st.integers(0, n - 1)), draw(st.integers(0, 2))
        cells[i][j] = draw(st.sampled_from(["nan", "inf", "-inf", "x", "", "1e13", "1e308", "0x1"]))
    elif change == "constant":
        for c in cells:
            c[2] = "0.0"
    elif change == "repeat_t" and n > 3:
        cells[2][0] = cells[1][0]
    elif change == "ms":
        header = "time,current,vel"
        for c in cells:
            c[0] = repr(float(c[0]) * 1e3)
    return (header + "\n" + "\n".join(",".join(c) for c in cells) + "\n").encode()


@st.composite
def points_table(draw) -> bytes:
    """Stribeck support points ``w,F``: a Stribeck curve (with noise), too few points, one direction only, or
    broken cells."""
    n = draw(st.sampled_from([16, 16, 6, 3, 1]))
    ws = np.concatenate([-np.geomspace(1.0, 0.002, n // 2), np.geomspace(0.002, 1.0, n - n // 2)])
    if draw(st.booleans()):
        ws = np.abs(ws)
    F = np.sign(ws) * (25.0 + 10.0 * np.exp(-np.abs(ws / 0.02))) + 40.0 * ws
    F = F + draw(st.floats(0.0, 5.0)) * np.cos(np.arange(n))
    cells = [[repr(float(a)), repr(float(b))] for a, b in zip(ws, F)]
    if draw(st.booleans()) and cells:
        cells[draw(st.integers(0, len(cells) - 1))][draw(st.integers(0, 1))] = draw(
            st.sampled_from(["nan", "inf", "x", "", "1e300"]))
    return ("w,F\n" + "\n".join(",".join(c) for c in cells) + "\n").encode()


_PLANT_VALUES = st.one_of(st.floats(1e-3, 1e3), st.sampled_from([0.0, -1.0, 1e-12, 1e12, 1e308]),
                          st.sampled_from(["4", None, True, [], {}]))

PAPER = {"J": 4.0, "Fc": 25.0, "Fs": 35.0, "Vs": 0.02, "delta": 1.0, "sigma": 40.0, "tau": 0.02}


def _json_bytes(obj, *, strict: bool = True) -> bytes:
    return json.dumps(obj, allow_nan=not strict).encode()


@st.composite
def plant_json(draw) -> bytes:
    """A plant file: the paper joint with keys changed, removed or added, another model, a time-varying part, or a
    file that is no plant (not an object, not JSON, NaN, not UTF-8)."""
    kind = draw(st.sampled_from(["valid", "changed", "changed", "model", "broken"]))
    if kind == "broken":
        return draw(st.sampled_from([b"", b"[1, 2]", b"{", b'{"J": NaN}', b"\xff\xfe{}", b"null", b'"paper"',
                                     b'{"J": 4, "J": 5}', b"{}"]))
    d = dict(PAPER)
    if kind == "changed":
        for key in draw(st.lists(st.sampled_from(sorted(PAPER) + ["model", "extra"]), min_size=1, max_size=3)):
            if draw(st.booleans()):
                d[key] = draw(_PLANT_VALUES)
            else:
                d.pop(key, None)
    elif kind == "model":
        model = draw(st.sampled_from(["lugre", "karnopp", "asymmetric", "nonsense"]))
        d["model"] = model
        if model == "lugre":
            d.pop("tau")
            d.update(sigma0=draw(st.sampled_from([1e5, 0.0, -1.0])), sigma1=300.0, sigma2=40.0)
            d.pop("sigma")
        elif model == "karnopp":
            d["dv"] = draw(st.sampled_from([1e-3, 0.0, -1.0]))
        elif model == "asymmetric":
            d = {"model": model, "J": 4.0, "Fc_pos": 25.0, "Fc_neg": 20.0, "Fs_pos": 35.0, "Fs_neg": 30.0,
                 "Vs": 0.02, "delta": 1.0, "sigma_pos": 40.0, "sigma_neg": 35.0, "tau": 0.02}
    if draw(st.booleans()):
        extra = draw(st.sampled_from(["drift", "ripple", "payload"]))
        d[extra] = {"drift": {"Fc_change": 0.5, "Fs_change": 0.5, "t_start": 0.0, "t_end": 1.0},
                    "ripple": {"amplitude": 0.1, "harmonic": 3.0, "phase": 0.0},
                    "payload": {"t_step": 1.0, "J_after": 6.0}}[extra]
        if draw(st.booleans()):
            d[extra] = {k: draw(_PLANT_VALUES) for k in d[extra]}
    return _json_bytes(d)


@st.composite
def identification_json(draw) -> bytes:
    """An ``identify --json`` output: the paper joint's (tests/export_c_helpers.py), with keys changed or removed,
    warnings added, or a broken file."""
    from export_c_helpers import ID_JSON

    kind = draw(st.sampled_from(["valid", "changed", "changed", "warned", "broken"]))
    if kind == "broken":
        return draw(st.sampled_from([b"", b"{}", b'{"method": "sliding"}', b"[]", b"{", b'{"J": Infinity}']))
    d = json.loads(json.dumps(ID_JSON))
    if kind == "changed":
        for key in draw(st.lists(st.sampled_from(["J", "Fc", "Fs", "sigma", "tau", "Vs", "delta", "method",
                                                  "excitation", "offset"]), min_size=1, max_size=3)):
            if draw(st.booleans()):
                d[key] = draw(st.one_of(_PLANT_VALUES, st.sampled_from(["paper", "sliding", "output_error"])))
            else:
                d.pop(key, None)
    elif kind == "warned":
        d["warnings"] = draw(st.sampled_from([
            [{"code": "implausible", "parameter": "J", "message": "J is implausible"}],
            ["an older warning as a string"], [{"code": 3}], "not a list"]))
    return _json_bytes(d)


def toml_text(d: dict) -> str:
    """TOML of a mapping of scalars, lists of scalars and tables of them (what a scenario file holds)."""
    def value(v) -> str:
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, float):
            return "nan" if v != v else ("inf" if v == math.inf else "-inf" if v == -math.inf else repr(v))
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        return str(v)

    lines = [f"{k} = {value(v)}" for k, v in d.items() if not isinstance(v, dict)]
    for k, v in d.items():
        if isinstance(v, dict):
            lines.append(f"[{k}]")
            lines += [f"{kk} = {value(vv)}" for kk, vv in v.items()]
    return "\n".join(lines) + "\n"


_SCENARIO_VALUES = st.one_of(st.floats(-1e3, 1e3), st.sampled_from([0, -1, 1e300, float("nan"), float("inf"),
                                                                    "x", True, [1.0]]))


@st.composite
def scenario_toml(draw) -> bytes:
    """A scenario file: a short valid one (multisine, reversing or point-to-point reference; a preset or a plant
    table), keys changed to boundary or wrong values, unknown keys, or text that is no TOML."""
    kind = draw(st.sampled_from(["valid", "changed", "changed", "broken"]))
    if kind == "broken":
        return draw(st.sampled_from([b"", b"[plant", b"x = \n", b"[plant]\npreset = 3\n", b"\xff\xfe",
                                     b"[reference]\nkind = 'multisine'\n", b"[plant]\npreset = 'paper'\n[plant]\n"]))
    ref = draw(st.sampled_from([
        {"kind": "multisine", "duration": 3.0},
        {"kind": "reversing", "speed": 0.2, "hold": 0.5, "accel": 5.0, "n_reversals": 2},
        {"kind": "point-to-point", "targets": [0.3, 0.0], "v_max": 1.0, "a_max": 10.0, "dwell": 0.3}]))
    plant = draw(st.sampled_from([{"preset": "paper"}, dict(PAPER)]))
    d = {"seed": 0, "modes": draw(st.sampled_from([["none"], ["none", "fixed"], ["none", "dob"]])),
         "plant": plant, "reference": ref}
    if draw(st.booleans()):
        d["sensor"] = {"noise_std": 1e-3}
    if draw(st.booleans()):
        d["drive"] = {"u_max": 150.0}
    if draw(st.booleans()):
        d["controller"] = {"crossover": 20.0}
    if kind == "changed":
        for _ in range(draw(st.integers(1, 3))):
            table = draw(st.sampled_from(["", "plant", "reference", "sensor", "drive", "controller", "compensation",
                                          "bogus"]))
            key = draw(st.sampled_from(["duration", "n_reversals", "hold", "speed", "repeat", "targets", "u_max",
                                        "slew_rate", "crossover", "Tc", "noise_std", "delay", "encoder_counts",
                                        "J", "Fc", "seed", "modes", "kind", "estimator", "lam", "nonsense"]))
            val = draw(st.one_of(_SCENARIO_VALUES, st.sampled_from(["none", "reversing", "file", "sliding"])))
            if table == "":
                d[key] = val
            else:
                d.setdefault(table, {})
                if isinstance(d[table], dict):
                    d[table][key] = val
    return toml_text(d).encode()


@st.composite
def sweep_spec(draw) -> bytes:
    """A sweep spec: one short case (or a few), with keys changed; or a broken file."""
    d = {"preset": "paper", "seeds": [0], "modes": ["none"], "duration": 2.0, "options": {"Vs": 0.02, "delta": 1.0}}
    if draw(st.booleans()):
        key = draw(st.sampled_from(["seeds", "modes", "duration", "grid", "options", "preset", "bogus"]))
        d[key] = draw(st.sampled_from([[], [0, 1], ["none", "magic"], -1, 0.0, 1e300, "x", {"Fc": [20.0]},
                                       {"turbo": 1}, None]))
    if draw(st.integers(0, 9)) == 0:
        return draw(st.sampled_from([b"", b"{", b"[]", b"null"]))
    return json.dumps(d).encode()


# --------------------------------------------------------------------------------------------- commands

_OUT = st.sampled_from(["{dir}/out", "{dir}/out", "{dir}/new/deeper", "{dir}/exists", "{dir}/in.csv"])


def _prepare_outputs(argv: list) -> tuple:
    """The outputs an argument vector names (after ``--out``, ``--report``, ``--plot``)."""
    return tuple(argv[i + 1].replace("{dir}/", "") for i, a in enumerate(argv[:-1])
                 if a in ("--out", "--report", "--plot"))


@st.composite
def compare_case(draw, heavy: bool = False) -> CliCase:
    """``compare``: a short run of a few modes on the preset, a plant file or a scenario file."""
    files, argv = {}, ["compare"]
    source = draw(st.sampled_from(["preset", "preset", "plant", "identification", "scenario", "variant"]))
    if source == "plant":
        files["plant.json"] = draw(plant_json())
        argv += ["--plant", "{dir}/plant.json"]
    elif source == "identification":
        files["id.json"] = draw(identification_json())
        argv += ["--plant", "{dir}/id.json"]
    elif source == "scenario":
        files["s.toml"] = draw(scenario_toml())
        argv += ["--scenario", "{dir}/s.toml"]
    elif source == "variant":
        argv += ["--variant", draw(st.sampled_from(["lugre", "karnopp", "static", "drift", "magic"]))]
    if source != "scenario":
        argv += ["--duration", draw(number(2.0, 20.0 if heavy else 4.0))]
        argv += ["--modes", draw(st.sampled_from(["none", "none,fixed", "adaptive", "dob,canudas", "oracle",
                                                  "none,magic", ",", "frictionless"]))]
        argv += draw(options({"--seed": integer(0, 10), "--noise": number(0.0, 1e-2), "--lam": number(0.9, 1.0),
                              "--crossover": number(5.0, 60.0), "--phase-margin": number(30.0, 80.0),
                              "--Ts": number(1e-3, 0.05), "--estimator": st.sampled_from(["eq4", "sliding", "x"]),
                              "--J-design": number(1.0, 10.0), "--Vs": number(0.005, 0.1),
                              "--delta": number(0.5, 2.0), "--omega-q": number(50.0, 1000.0),
                              "--no-prefit": None, "--no-fast-start": None, "--no-switch-in": None}))
    elif draw(st.integers(0, 4)) == 0:
        argv += ["--duration", "5"]  # refused beside --scenario
    argv += draw(options({"--json": None, "--units": st.sampled_from(["rad", "deg", "grad"]), "--yes": None}))
    if heavy and draw(st.booleans()):
        argv += ["--out", draw(_OUT)] + (["--report", "{dir}/rep"] if draw(st.booleans()) else [])
    else:
        argv += ["--no-figures"]
    argv.append("--quiet")
    return CliCase(argv, files, _prepare_outputs(argv))


@st.composite
def identify_case(draw, heavy: bool = False) -> CliCase:
    """``identify``: a log (valid, at the boundaries, broken) with the options of the fast methods."""
    files = {"log.csv": draw(csv_log())}
    argv = ["identify", "{dir}/log.csv"]
    methods = ["auto", "paper", "sliding", "x"] + (["output_error", "closed_loop"] if heavy else [])
    argv += draw(options({"--method": st.sampled_from(methods), "--Vs": number(0.005, 0.1), "--delta":
                          number(0.5, 2.0), "--lag": None, "--no-offset": None, "--lam": number(0.9, 1.0),
                          "--bootstrap": st.sampled_from(["0", "2", "3", "-1", "x", "1000000000000"]),
                          "--columns": st.sampled_from(["t=time,u=current,w=vel", "t=0,u=1,w=2", "t=t,u=u",
                                                        "q=w", "t=t,u=u,w=w,r=w", "x"]),
                          "--time-unit": st.sampled_from(["ms", "s", "min"]),
                          "--velocity-unit": st.sampled_from(["deg/s", "rpm", "rad/s"]),
                          "--current-to-torque": number(0.1, 100.0), "--asymmetric": None,
                          "--axis": st.sampled_from(["linear", "rotary"]), "--units": st.sampled_from(["rad", "deg"]),
                          "--skip-rows": integer(0, 3), "--header-line": integer(1, 3),
                          "--delimiter": st.sampled_from([",", ";", "tab", "xx"]), "--json": None,
                          "--form": st.sampled_from(["auto", "stribeck", "magic"]) if heavy else
                          st.sampled_from(["magic"]),
                          "--folds": integer(2, 4) if heavy else st.sampled_from(["1", "-3", "x"]),
                          "--Kp": number(10.0, 100.0), "--reference-column": st.sampled_from(["w", "r"]),
                          "--yes": None}))
    if heavy and draw(st.booleans()):
        argv += ["--plot", draw(_OUT), "--report", "{dir}/rep"]
    argv.append("--quiet")
    return CliCase(argv, files, _prepare_outputs(argv))


@st.composite
def stribeck_case(draw, heavy: bool = False) -> CliCase:
    """``stribeck``: a table of support points (``--points``) or a log."""
    if draw(st.booleans()):
        files = {"points.csv": draw(points_table())}
        argv = ["stribeck", "{dir}/points.csv", "--points"]
    else:
        files = {"log.csv": draw(csv_log())}
        argv = ["stribeck", "{dir}/log.csv"]
    argv += draw(options({"--method": st.sampled_from(["auto", "segments", "bins", "x"]), "--bins": integer(2, 20),
                          "--min-duration": number(0.01, 1.0), "--settle": number(0.0, 0.5),
                          "--rel-tol": number(0.01, 0.5), "--J": number(0.1, 10.0), "--max-accel": number(1.0, 100.0),
                          "--weighted": None, "--json": None, "--units": st.sampled_from(["rad", "deg"])}))
    if heavy or draw(st.integers(0, 3)) == 0:
        argv += ["--out", draw(_OUT)]
    else:
        argv += ["--no-figures"]
    return CliCase(argv, files, _prepare_outputs(argv))


@st.composite
def design_case(draw, heavy: bool = False) -> CliCase:
    """``design``: J and sigma on the command line or from a file (identification, plant, broken)."""
    files, argv = {}, ["design"]
    if draw(st.booleans()):
        files["id.json"] = draw(st.one_of(identification_json(), plant_json()))
        argv += ["--from", "{dir}/id.json"] + draw(options({"--accept-warnings": None, "--J": number(0.1, 10.0)}))
    else:
        argv += ["--J", draw(number(1e-3, 1e3, log=True))]
    argv += draw(options({"--sigma": number(0.0, 100.0), "--crossover": number(1e-3, 600.0, log=True),
                          "--phase-margin": number(1.0, 89.0), "--Tc": number(1e-5, 1e-2, log=True),
                          "--step-duration": number(0.01, 5.0), "--json": None,
                          "--units": st.sampled_from(["rad", "deg"]), "--axis": st.sampled_from(["linear", "x"]),
                          "--yes": None}))
    if heavy or draw(st.integers(0, 4)) == 0:
        argv += ["--out", draw(_OUT)] + (["--report", "{dir}/rep"] if draw(st.booleans()) else [])
    else:
        argv += ["--no-figures"]
    return CliCase(argv, files, _prepare_outputs(argv))


@st.composite
def export_case(draw, heavy: bool = False) -> CliCase:
    """``export-c``: an identification (valid, changed, warned, broken) and the export's settings."""
    files = {"id.json": draw(identification_json())}
    argv = ["export-c", "--from", "{dir}/id.json", "--u-max", draw(number(1.0, 1e3, log=True)),
            "--out", draw(_OUT)]
    argv += draw(options({"--Tc": number(1e-4, 1e-2, log=True), "--Ts": number(1e-3, 0.1, log=True),
                          "--J-design": number(0.1, 10.0), "--ff-max": number(1.0, 100.0),
                          "--stick-band": number(0.0, 0.1), "--Vs": number(0.005, 0.1), "--delta": number(-2.0, 2.0),
                          "--Kp": number(0.0, 200.0), "--Ki": number(0.0, 2000.0), "--crossover": number(1.0, 100.0),
                          "--phase-margin": number(1.0, 89.0), "--w-max": number(1.0, 1e5, log=True),
                          "--hold-time": number(1e-3, 1.0), "--start": None, "--feedforward-only": None,
                          "--float": None, "--accept-warnings": None, "--force": None, "--json": None,
                          "--quiet": None}))
    return CliCase(argv, files, _prepare_outputs(argv))


@st.composite
def sweep_case(draw, heavy: bool = False) -> CliCase:
    """``sweep``: a short spec into a results file, serial."""
    files = {"spec.json": draw(sweep_spec())}
    out = draw(st.sampled_from(["{dir}/r.csv", "{dir}/r.csv", "{dir}/sub/r.csv", "{dir}/in.csv", "{dir}/exists"]))
    argv = ["sweep", "{dir}/spec.json", "--out", out, "--workers", draw(st.sampled_from(["1", "1", "0", "x"])),
            "--quiet"] + draw(options({"--json": None, "--units": st.sampled_from(["rad", "deg"])}))
    rel = out.replace("{dir}/", "")
    return CliCase(argv, files, (rel, rel + ".summary.json"), appended=(rel,))


@st.composite
def paper_figures_case(draw, heavy: bool = False) -> CliCase:
    """``paper-figures``: short runs (heavy), or options refused before any run."""
    argv = ["paper-figures", "--out", draw(_OUT), "--quiet"]
    if heavy:
        argv += ["--sim-duration", draw(number(4.0, 10.0)), "--exp-duration", draw(number(6.0, 12.0)),
                 "--speeds", draw(integer(6, 8))]
    else:  # refused before the simulation: a bad value
        argv += [draw(st.sampled_from(["--sim-duration", "--exp-duration", "--noise", "--lam", "--quantization"])),
                 draw(st.sampled_from(["-1", "0", "nan", "inf", "x", "1e300"]))]
    files = {}
    if draw(st.integers(0, 3)) == 0:
        files["plant.json"] = draw(plant_json())
        argv += ["--plant", "{dir}/plant.json"]
    argv += draw(options({"--json": None, "--save-data": None, "--yes": None}))
    return CliCase(argv, files, _prepare_outputs(argv))


_VOCABULARY = ["compare", "identify", "design", "export-c", "sweep", "stribeck", "paper-figures", "--json", "--out",
               "--yes", "--duration", "--J", "--from", "--plant", "--u-max", "-h", "--version", "1", "-1", "nan", "x",
               "{dir}/in.csv", "{dir}/exists", "{dir}", "", "=", "--", "--modes", "--quiet", "--no-figures"]


@st.composite
def garbage_case(draw, heavy: bool = False) -> CliCase:
    """Argument vectors of the commands' words, options and values in any order (mostly usage errors)."""
    argv = draw(st.lists(st.sampled_from(_VOCABULARY), min_size=0, max_size=6))
    if "-h" in argv or "--version" in argv:
        argv = [a for a in argv if a not in ("-h", "--version")]
    return CliCase(argv, {}, _prepare_outputs(argv))


#: The strategies by command.
CASES = {"compare": compare_case, "identify": identify_case, "stribeck": stribeck_case, "design": design_case,
         "export-c": export_case, "sweep": sweep_case, "paper-figures": paper_figures_case, "garbage": garbage_case}


def cli_cases(commands=None, *, heavy: bool = False):
    """A strategy of :class:`CliCase` of the given commands (default all of :data:`CASES`)."""
    return st.one_of(*[CASES[c](heavy=heavy) for c in (commands or CASES)])


# --------------------------------------------------------------------------------------------- running and checks


def _tree(root: Path) -> dict:
    out = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for d in dirnames:
            out[os.path.relpath(os.path.join(dirpath, d), root) + "/"] = b""
        for f in filenames:
            p = os.path.join(dirpath, f)
            with open(p, "rb") as fh:
                out[os.path.relpath(p, root)] = fh.read()
    return out


def run_case(case: CliCase, folder) -> Outcome:
    """Run ``case`` in the empty folder ``folder``: write its files (and an existing output folder ``exists`` with
    a file of a previous run, and an input ``in.csv`` to be refused as an output folder), run
    :func:`controllers.cli.main.main` with stdout and stderr captured."""
    from controllers.cli.main import main

    folder = Path(folder)
    for name, data in case.files.items():
        (folder / name).write_bytes(data)
    (folder / "exists").mkdir()
    (folder / "exists" / "old.png").write_bytes(b"a figure of a previous run")
    (folder / "in.csv").write_bytes(b"t,u,w\n")
    before = _tree(folder)
    out, err = io.StringIO(), io.StringIO()
    t0 = time.perf_counter()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            status = main(case.command(folder))
        except SystemExit as exc:  # argparse's usage errors and --help
            status = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    seconds = time.perf_counter() - t0
    return Outcome(status, out.getvalue(), err.getvalue(), seconds, before, _tree(folder))


def _names_something(case: CliCase, folder, err: str) -> bool:
    """Whether the error names an option, a file or a key of the case (or is argparse's usage message)."""
    if "usage:" in err or "the following arguments are required" in err:
        return True
    words, values = set(), set()
    for a in case.command(folder)[1:]:
        if a.startswith("--"):
            name = a.split("=", 1)[0]
            words |= {name, name[2:], name[2:].replace("-", "_")}
        elif "/" in a:
            words |= {a, Path(a).name}
        elif a.strip():
            values.add(a)
    words |= set(case.files)
    words.discard("")
    if re.search(r"(?<![\w-])--[a-zA-Z]", err):
        return True  # names an option (e.g. the one missing)
    if any(re.search(rf"(?<![\w.]){re.escape(v)}(?![\w.])", err) for v in values):
        return True  # a positional argument (a file name) or the value
    return any(w in err for w in words) or "[" in err  # a scenario's [table] key, a spec's key


def check_outcome(case: CliCase, outcome: Outcome, folder) -> None:
    """Assert the promises of the command line (module docstring); AssertionError naming the broken one."""
    o = outcome
    assert o.status in (0, 2, 3, 130), f"exit status {o.status}:\n{o.stderr[-2000:]}"
    assert "Traceback" not in o.stderr and "Traceback" not in o.stdout, f"a traceback:\n{o.stderr[-3000:]}"
    left = [k for k in o.after if ".adaptive-ff" in k]
    assert not left, f"staging or lock left behind: {left}"
    if o.status == 2:
        err = o.stderr.strip()
        assert err, "exit status 2 without a message"
        assert _names_something(case, folder, err), f"the error names no file, option or key: {err!r}"
    if o.status not in (0, 3):
        changed = {k for k in set(o.before) | set(o.after) if o.before.get(k) != o.after.get(k)}
        allowed = set()
        for a in case.appended:
            allowed |= {k for k in changed if k == a or k.startswith(a.rstrip("/") + "/") or
                        (k.endswith("/") and a.startswith(k))}
        assert changed <= allowed, f"a failed run changed {sorted(changed - allowed)}"
    if o.status == 0 and "--json" in case.argv and not any(a in ("-h", "--help") for a in case.argv):
        def no_constant(name):
            raise AssertionError(f"--json printed {name}")

        d = json.loads(o.stdout, parse_constant=no_constant)
        files = []
        if isinstance(d, dict):
            files = [d.get("report")] + list(d.get("figures") or []) + list((d.get("data_files") or {}).values()) \
                if isinstance(d.get("figures", []), list) else [d.get("report")]
        for f in files:
            if isinstance(f, str):
                assert Path(f).exists(), f"--json names {f}, which does not exist"
