"""Import and the CLI work from a read-only install with a non-writable HOME.

The packages are copied to a temporary folder that cannot be written, HOME points where nothing can be created,
NUMBA_CACHE_DIR and XDG_CACHE_HOME are unset. The compiled-kernel cache (plant/jit.py) must then fall back to the
temporary folder, or, where that cannot be written either, compile in memory; either way with one line saying so.

The tests may run as root, where ``chmod a-w`` does not stop writes. The candidate folders are therefore made
impossible to create for anyone: the package's ``__pycache__`` and HOME are paths through a regular file (mkdir
fails with NotADirectoryError), and in the second case the temporary folder too.
"""

import os
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("plant", "adaptive_ff", "controllers")


@pytest.fixture(scope="module")
def read_only_install(tmp_path_factory):
    base = tmp_path_factory.mktemp("ro")
    site = base / "site"
    site.mkdir()
    for pkg in PACKAGES:
        shutil.copytree(ROOT / pkg, site / pkg, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    blocker = base / "blocker"  # a regular file: no folder can be created below it, not even by root
    blocker.write_text("not a folder\n")
    (site / "__pycache__").write_text("not a folder\n")  # the package-side kernel cache cannot be created
    for p in sorted(site.rglob("*"), reverse=True) + [site]:
        mode = p.stat().st_mode
        p.chmod(mode & ~(stat.S_IWUSR | stat.S_IWGRP | stat.S_IWOTH))
    tmp = base / "tmp"
    tmp.mkdir()
    yield site, blocker, tmp
    for p in [site] + sorted(site.rglob("*")):
        if p.is_dir():
            p.chmod(p.stat().st_mode | stat.S_IWUSR)


def _env(site, blocker, tmp):
    env = {k: v for k, v in os.environ.items()
           if k not in ("NUMBA_CACHE_DIR", "XDG_CACHE_HOME", "PYTHONPATH", "HOME", "TMPDIR")}
    env.update(PYTHONPATH=str(site), HOME=str(blocker / "home"), TMPDIR=str(tmp), MPLBACKEND="Agg",
               PYTHONDONTWRITEBYTECODE="1", MPLCONFIGDIR=str(tmp / "mpl"))
    return env


def _run(code, env, cwd):
    return subprocess.run([sys.executable, "-c", code], env=env, cwd=cwd, capture_output=True, text=True,
                          timeout=600)


def test_read_only_install_and_no_home_cache_in_the_temporary_folder(read_only_install):
    site, blocker, tmp = read_only_install
    env = _env(site, blocker, tmp)
    code = ("import adaptive_ff, controllers, plant.jit as j, numpy as np;"
            "from adaptive_ff.identification.rls import RecursiveLeastSquares as R;"
            "r = R(2); r.update(np.array([1.0, 0.0]), 1.0);"
            "print(adaptive_ff.__file__); print(j.cache_dir()); print(r.theta.tolist())")
    res = _run(code, env, tmp)
    assert res.returncode == 0, res.stderr
    out = res.stdout.splitlines()
    assert out[0].startswith(str(site)) and Path(out[1]).parent == tmp  # the copy, cached in the temp folder
    assert out[2].startswith("[0.99990000999900") and out[2].endswith(", 0.0]")  # P0/(1 + P0) with P0 = 1e4
    said = [ln for ln in res.stderr.splitlines() if ln.startswith("adaptive_ff:")]
    assert len(said) == 1 and "cached in" in said[0] and "Traceback" not in res.stderr
    assert any((tmp / Path(out[1]).name).rglob("*.nbi"))  # the kernels were really cached there
    # and a short CLI command runs (the console script's entry point) without a traceback
    cli = _run("import sys; from controllers.cli.main import main; "
               "sys.exit(main(['design', '--J', '4', '--sigma', '40', '--no-figures', '--out', 'o']))", env, tmp)
    assert cli.returncode == 0, cli.stderr
    assert "Kp" in cli.stdout and "Traceback" not in cli.stderr


def test_nothing_writable_compiles_in_memory_with_one_line(read_only_install):
    site, blocker, tmp = read_only_install
    env = _env(site, blocker, tmp)
    # the temporary folder cannot be created either (tempfile.tempdir is what gettempdir() returns)
    code = (f"import tempfile; tempfile.tempdir = {str(blocker / 'tmp')!r};"
            "import adaptive_ff, plant.jit as j, numpy as np;"
            "from adaptive_ff.identification.rls import RecursiveLeastSquares as R;"
            "r = R(2); r.update(np.array([1.0, 0.0]), 1.0); print(j.cache_dir()); print(r.n_updates)")
    res = _run(code, env, tmp)
    assert res.returncode == 0, res.stderr
    assert res.stdout.split() == ["None", "1"]
    said = [ln for ln in res.stderr.splitlines() if ln.startswith("adaptive_ff:")]
    assert len(said) == 1 and "compiled at every start" in said[0] and "Traceback" not in res.stderr
