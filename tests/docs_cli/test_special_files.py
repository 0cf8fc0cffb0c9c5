"""A path that exists but is not a regular file is refused for what it is, at once (exit 2, one line).

A loop of symbolic links or a link to nothing is not "no such file"; a named pipe (FIFO) would block the reader
until a writer comes, a link to ``/dev/zero`` would be read for ever, ``/dev/null`` would read as empty.
"""

import os

import pytest

from controllers.cli.main import main


def _special(tmp_path, kind: str):
    path = tmp_path / f"input-{kind}.json"
    if kind == "loop":
        os.symlink(tmp_path / "other.json", path)
        os.symlink(path, tmp_path / "other.json")
    elif kind == "dangling":
        os.symlink(tmp_path / "nowhere.json", path)
    elif kind == "fifo":
        os.mkfifo(path)
    else:
        os.symlink(f"/dev/{kind}", path)
    return path


WHAT = {"loop": "is a loop of symbolic links", "dangling": "is a symbolic link to ", "fifo": "is a named pipe (FIFO)",
        "zero": "is a character device (a symbolic link to '/dev/zero')",
        "null": "is a character device (a symbolic link to '/dev/null')"}
COMMANDS = {"scenario": (["compare", "--scenario", "{}", "--no-figures", "--quiet"], "scenario file"),
            "plant": (["compare", "--plant", "{}", "--duration", "1", "--no-figures", "--quiet"], "plant file"),
            "log": (["identify", "{}"], "data file"),
            "identification": (["export-c", "--from", "{}", "--u-max", "100", "--out", "OUT"], "JSON identification")}


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="POSIX special files")
@pytest.mark.parametrize("kind", list(WHAT))
@pytest.mark.parametrize("command", list(COMMANDS))
def test_a_special_file_is_refused_for_what_it_is(tmp_path, capsys, kind, command):
    path = _special(tmp_path, kind)
    argv, what = COMMANDS[command]
    argv = [str(path) if a == "{}" else str(tmp_path / "out") if a == "OUT" else a for a in argv]
    assert main(argv) == 2
    cap = capsys.readouterr()
    assert cap.out == "" and "Traceback" not in cap.err
    assert f"{path}: {WHAT[kind]}" in cap.err and f"expected a {what}" in cap.err
    assert "no such file" not in cap.err and "not found" not in cap.err
