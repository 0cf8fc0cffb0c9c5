"""adaptive_ff.io.output: staged outputs appear together or not at all; a target in use is refused.

Each case checks the bytes of the target before and after: a failure (an exception, Ctrl-C) leaves the previous
content byte for byte, a success replaces exactly the files written and keeps the others.
"""

import os
import signal
import subprocess
import sys

import pytest

from adaptive_ff.io.output import (OutputInUseError, StagedOutputs, atomic_file, lock_path, output_lock,
                                   staged_folder)
from plant.errors import ParameterError


def _tree(root):
    """``{relative path: bytes}`` of every file under ``root`` (hidden ones included)."""
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.fixture
def previous(tmp_path):
    """An output folder of an earlier run beside a file of the user's."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "a.txt").write_bytes(b"old a")
    (out / "b.txt").write_bytes(b"old b")
    (out / "mine.txt").write_bytes(b"the user's")
    return out


def test_success_replaces_the_files_written_and_keeps_the_others(previous):
    with staged_folder(previous, "--out") as tmp:
        assert tmp.parent == previous.parent and tmp != previous and tmp.name.startswith(".out.adaptive-ff-")
        (tmp / "a.txt").write_bytes(b"new a")
        (tmp / "c.txt").write_bytes(b"new c")
        assert _tree(previous)["a.txt"] == b"old a"  # nothing in place before the end
    assert _tree(previous) == {"a.txt": b"new a", "b.txt": b"old b", "c.txt": b"new c", "mine.txt": b"the user's"}
    assert sorted(p.name for p in previous.parent.iterdir()) == ["out"]  # no staging folder, no lock left


@pytest.mark.parametrize("error", [RuntimeError("a figure failed"), KeyboardInterrupt()])
def test_failure_part_way_leaves_the_previous_bytes(previous, error):
    before = _tree(previous)
    with pytest.raises(type(error)):
        with staged_folder(previous) as tmp:
            (tmp / "a.txt").write_bytes(b"new a")
            raise error
    assert _tree(previous) == before
    assert sorted(p.name for p in previous.parent.iterdir()) == ["out"]


def test_a_failed_new_folder_leaves_nothing_behind(tmp_path):
    with pytest.raises(RuntimeError):
        with staged_folder(tmp_path / "a" / "b" / "out") as tmp:
            (tmp / "x.png").write_bytes(b"png")
            raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []  # the parents made for it are gone too


def test_a_new_folder_appears_whole_with_the_usual_permissions(tmp_path):
    with staged_folder(tmp_path / "new") as tmp:
        (tmp / "x.txt").write_text("x")
        (tmp / "sub").mkdir()
        (tmp / "sub" / "y.txt").write_text("y")
    assert _tree(tmp_path / "new") == {"sub/y.txt": b"y", "x.txt": b"x"}
    mask = os.umask(0)
    os.umask(mask)
    assert (tmp_path / "new").stat().st_mode & 0o777 == 0o777 & ~mask


def test_a_name_of_the_other_kind_is_refused_before_anything_moves(previous):
    (previous / "sub").mkdir()
    before = _tree(previous)
    with pytest.raises(ParameterError, match="sub: a folder, where this run writes a file of that name"):
        with staged_folder(previous) as tmp:
            (tmp / "a.txt").write_bytes(b"new a")
            (tmp / "sub").write_bytes(b"a file named like the folder")
    assert _tree(previous) == before


def test_ctrl_c_during_the_moves_is_held_until_all_moved(previous, monkeypatch):
    real = os.replace
    calls = []

    def replace(src, dst):
        if not calls:
            signal.raise_signal(signal.SIGINT)  # Ctrl-C after the first staged file is on its way
        calls.append(dst)
        real(src, dst)

    monkeypatch.setattr(os, "replace", replace)
    # Python's own Ctrl-C handler (a worker of pytest-xdist may run with SIGINT ignored)
    old_handler = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt):
            with staged_folder(previous) as tmp:
                for name in ("a.txt", "b.txt", "c.txt"):
                    (tmp / name).write_bytes(b"new " + name[0].encode())
    finally:
        signal.signal(signal.SIGINT, old_handler)
    assert len(calls) == 3  # every file moved, then the interrupt
    assert {k: v for k, v in _tree(previous).items() if k != "mine.txt"} == {"a.txt": b"new a", "b.txt": b"new b",
                                                                             "c.txt": b"new c"}


def test_atomic_file_keeps_the_old_bytes_on_failure_and_its_mode(tmp_path):
    f = tmp_path / "summary.json"
    f.write_text("{}")
    f.chmod(0o640)
    with pytest.raises(ValueError):
        with atomic_file(f) as tmp, open(tmp, "w") as fh:
            fh.write('{"half": ')
            raise ValueError("json.dump failed half-way")
    assert f.read_text() == "{}" and sorted(p.name for p in tmp_path.iterdir()) == ["summary.json"]
    with atomic_file(f) as tmp:
        tmp.write_text('{"n": 1}')
    assert f.read_text() == '{"n": 1}' and f.stat().st_mode & 0o777 == 0o640


def test_a_folder_in_use_is_refused_naming_it(tmp_path):
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        out = tmp_path / "out"
        lock = lock_path(out)
        lock.write_text(f"{sleeper.pid}\n")
        with pytest.raises(OutputInUseError) as err:
            with staged_folder(out, "--out"):
                pass
        assert f"--out {out}: in use by another adaptive-ff run (process {sleeper.pid}" in str(err.value)
        assert not out.exists() and lock.read_text() == f"{sleeper.pid}\n"  # the other run's lock stays
    finally:
        sleeper.kill()
        sleeper.wait()


def test_a_stale_lock_is_taken_over_and_its_staging_removed(tmp_path):
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    out = tmp_path / "out"
    lock_path(out).write_text(f"{dead.pid}\n")
    left = tmp_path / f".out.adaptive-ff-{dead.pid}.abc123"  # what the crashed run was writing
    left.mkdir()
    (left / "half.png").write_bytes(b"half")
    with staged_folder(out) as tmp:
        (tmp / "x.txt").write_text("x")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"] and _tree(out) == {"x.txt": b"x"}


def test_the_lock_is_reentrant_within_one_process_and_released(tmp_path):
    out = tmp_path / "out"
    with output_lock(out, "--out") as lock:
        assert lock.read_text().strip() == str(os.getpid())
        with staged_folder(out) as tmp:  # e.g. the CLI holds it while export_c writes
            (tmp / "x.txt").write_text("x")
        assert lock.exists()
    assert not lock.exists() and _tree(out) == {"x.txt": b"x"}


def test_one_target_named_twice_is_staged_once_and_paths_relocate(tmp_path):
    with StagedOutputs() as staged:
        a = staged.folder(tmp_path / "out", "--out")
        assert staged.folder(tmp_path / "x" / ".." / "out", "--report") == a
        (a / "f.png").write_bytes(b"png")
        d = {"figures": [str(a / "f.png")], "report": a / "report.html", "n": 3}
        assert staged.relocate(d) == {"figures": [str(tmp_path / "out" / "f.png")],
                                      "report": tmp_path / "out" / "report.html", "n": 3}
    assert _tree(tmp_path / "out") == {"f.png": b"png"}
