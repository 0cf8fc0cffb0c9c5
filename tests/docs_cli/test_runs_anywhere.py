"""Import, a computation and the CLI work from a read-only install with a non-writable HOME and temporary folder.

The C core is built at install time (setup.py, cffi): nothing is compiled or cached at run time. The packages
(with their built extension modules) are copied to a folder that cannot be written, HOME and the temporary
folder point where nothing can be created, and the run must leave no file behind.

The tests may run as root, where ``chmod a-w`` does not stop writes. HOME and the temporary folder are
therefore paths through a regular file (mkdir fails with NotADirectoryError for anyone).
"""

import os
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import pytest

import adaptive_ff
import controllers
import plant

PACKAGES = (plant, adaptive_ff, controllers)


@pytest.fixture(scope="module")
def read_only_install(tmp_path_factory):
    base = tmp_path_factory.mktemp("ro")
    site = base / "site"
    site.mkdir()
    for pkg in PACKAGES:
        src = Path(pkg.__file__).resolve().parent
        shutil.copytree(src, site / src.name, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    blocker = base / "blocker"  # a regular file: no folder can be created below it, not even by root
    blocker.write_text("not a folder\n")
    for p in sorted(site.rglob("*"), reverse=True) + [site]:
        mode = p.stat().st_mode
        p.chmod(mode & ~(stat.S_IWUSR | stat.S_IWGRP | stat.S_IWOTH))
    work = base / "work"
    work.mkdir()
    yield site, blocker, work
    for p in [site] + sorted(site.rglob("*")):
        if p.is_dir():
            p.chmod(p.stat().st_mode | stat.S_IWUSR)


def _env(site, blocker):
    env = {k: v for k, v in os.environ.items() if k not in ("XDG_CACHE_HOME", "PYTHONPATH", "HOME", "TMPDIR")}
    env.update(PYTHONPATH=str(site), HOME=str(blocker / "home"), TMPDIR=str(blocker / "tmp"), MPLBACKEND="Agg",
               PYTHONDONTWRITEBYTECODE="1", MPLCONFIGDIR=str(blocker / "mpl"))
    return env


def _run(code, env, cwd):
    return subprocess.run([sys.executable, "-c", code], env=env, cwd=cwd, capture_output=True, text=True,
                          timeout=300)


def _files(folder: Path) -> list:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def test_read_only_install_without_home_or_temporary_folder(read_only_install):
    site, blocker, work = read_only_install
    env = _env(site, blocker)
    before = _files(site)
    code = ("import adaptive_ff, numpy as np;"
            "from adaptive_ff.identification.rls import RecursiveLeastSquares as R;"
            "r = R(2); r.update(np.array([1.0, 0.0]), 1.0);"
            "print(adaptive_ff.__file__); print(r.theta.tolist())")
    res = _run(code, env, work)
    assert res.returncode == 0, res.stderr
    out = res.stdout.splitlines()
    assert out[0].startswith(str(site))  # the read-only copy was imported
    theta = eval(out[1])  # noqa: S307 - our own print of a list of floats
    assert theta[1] == 0.0 and abs(theta[0] - 1e4 / (1.0 + 1e4)) < 1e-15  # P0/(1 + P0) with P0 = 1e4
    assert res.stderr == ""
    # and a closed-loop command of the console script runs without a traceback, writing only its --out folder
    cli = _run("import sys; from controllers.cli.main import main; "
               "sys.exit(main(['design', '--J', '4', '--sigma', '40', '--no-figures', '--out', 'o']))", env, work)
    assert cli.returncode == 0, cli.stderr
    assert "Kp" in cli.stdout and "Traceback" not in cli.stderr
    assert _files(site) == before  # nothing compiled or cached beside the packages
    assert all(p.startswith("o") for p in _files(work))


def test_the_source_tree_holds_no_symbolic_link():
    """A checkout is plain files: a symbolic link (one that points into a developer's machine, or into its own
    folder) breaks a copy of the tree on any other machine (the docs build copies ``examples/`` recursively)."""
    root = Path(__file__).resolve().parents[2]
    links = [str(p.relative_to(root)) for top in ("plant", "adaptive_ff", "controllers", "tests", "benchmarks",
                                                  "examples", "docs", "data") if (root / top).exists()
             for p in (root / top).rglob("*") if p.is_symlink()]
    assert not links, links
