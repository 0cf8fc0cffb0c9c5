"""Compiled kernels: numba's ``njit`` with an on-disk cache that follows the whole package.

Every compiled function of the package is declared with :func:`kernel` instead of
``numba.njit(cache=True)``. Two things differ from numba's own cache:

1. **Staleness.** numba keys a cached function on its own source file only, but a
   kernel that calls (and inlines) kernels of other modules — the closed-loop
   engine composes the plant, the PI, the gate, the estimator, the RLS and the
   feedforward, each in the module of its concept — would silently keep the old
   machine code after an edit of a callee (https://github.com/numba/numba/issues/6845). Here the cache
   stamp of every kernel is one digest of all source files of ``plant``,
   ``adaptive_ff`` and ``controllers``: any edit recompiles everything once.
2. **Where it is written.** The first writable of: ``$NUMBA_CACHE_DIR``, the
   ``__pycache__`` folder beside the packages (an editable or user install), the
   user cache folder (``$XDG_CACHE_HOME`` or ``~/.cache``), the system temporary
   folder. A read-only install with a non-writable HOME therefore still caches
   (in the temporary folder, with one line on stderr saying where); where nothing
   is writable the kernels are compiled in memory, with one line saying so,
   instead of failing at import (``tests/test_runs_anywhere.py``).

Inlining: ``@kernel(inline="always")`` (numba IR inlining) is kept for small
scalar helpers and the engine's glue; a component with a large body (the plant
step with its model dispatch, the sliding estimator, the peers) is a compiled
call, which LLVM may still inline. IR-inlining every component into the
closed-loop engine made it take ~6 minutes to compile for the same run time.
"""

from __future__ import annotations

import hashlib
import os
import sys
import tempfile
from pathlib import Path

import numba
from numba.core.caching import CompileResultCacheImpl, FunctionCache, _CacheLocator

__all__ = ["kernel", "cache_dir", "source_digest"]

_ROOT = Path(__file__).resolve().parent.parent
_PACKAGES = ("plant", "adaptive_ff", "controllers")


def _digest() -> str:
    h = hashlib.sha256()
    for pkg in _PACKAGES:
        for f in sorted((_ROOT / pkg).rglob("*.py")):
            h.update(str(f.relative_to(_ROOT)).encode())
            try:
                h.update(f.read_bytes())
            except OSError:
                h.update(b"?")
    return h.hexdigest()[:16]


def _writable(d: Path) -> bool:
    try:
        d.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=d).close()
        return True
    except OSError:
        return False


def _find_cache_dir() -> tuple[Path | None, bool]:
    """The first writable candidate folder (module docstring) and whether it is the temporary-folder fallback."""
    cands = []
    if os.environ.get("NUMBA_CACHE_DIR"):
        cands.append(Path(os.environ["NUMBA_CACHE_DIR"]) / "adaptive_ff")
    cands.append(_ROOT / "__pycache__" / "adaptive_ff_kernels")
    xdg = os.environ.get("XDG_CACHE_HOME")
    try:
        home_cache = Path(xdg) if xdg else Path.home() / ".cache"
        cands.append(home_cache / "adaptive_ff" / "kernels")
    except RuntimeError:  # no home directory
        pass
    uid = os.getuid() if hasattr(os, "getuid") else "user"
    cands.append(Path(tempfile.gettempdir()) / f"adaptive_ff-kernels-{uid}")
    for i, d in enumerate(cands):
        if _writable(d):
            return d, i == len(cands) - 1
    return None, False


def _prune(base: Path | None, keep: str, age: float = 3600.0) -> None:
    """Remove kernel folders of other source digests not used for ``age`` seconds (best effort)."""
    import shutil
    import time

    if base is None:
        return
    now = time.time()
    try:
        for d in base.iterdir():
            if d.is_dir() and d.name != keep and now - d.stat().st_mtime > age:
                shutil.rmtree(d, ignore_errors=True)
    except OSError:
        pass


def _say(msg: str) -> None:
    """One line on stderr (not a warning: it must not turn into an error under ``-W error``)."""
    try:
        print(f"adaptive_ff: {msg}", file=sys.stderr)
    except (OSError, ValueError):  # no usable stderr
        pass


_DIGEST = _digest()
_CACHE_DIR, _fallback = _find_cache_dir()
_prune(_CACHE_DIR, _DIGEST)
if _fallback and not os.environ.get("NUMBA_CACHE_DIR"):
    _say(f"package folder and user cache not writable; compiled kernels are cached in {_CACHE_DIR}")
_warned = False


def source_digest() -> str:
    """Digest of the package sources that stamps every cached kernel (16 hex digits)."""
    return _DIGEST


def cache_dir() -> Path | None:
    """Folder the compiled kernels are cached in, or None (compiled in memory at every start)."""
    return _CACHE_DIR


class _PackageLocator(_CacheLocator):
    """numba cache locator: one folder per package digest, stamped with that digest (see module docstring)."""

    def __init__(self, py_func, py_file):
        self._lineno = py_func.__code__.co_firstlineno
        rel = Path(py_file).resolve()
        try:
            rel = rel.relative_to(_ROOT)
        except ValueError:
            rel = Path(rel.name)
        self._path = str(_CACHE_DIR / _DIGEST / rel.parent)

    def get_cache_path(self):
        return self._path

    def get_source_stamp(self):
        return _DIGEST

    def get_disambiguator(self):
        return str(self._lineno)

    @classmethod
    def from_function(cls, py_func, py_file):
        if _CACHE_DIR is None:
            return None
        self = cls(py_func, py_file)
        try:
            self.ensure_cache_path()
        except OSError:
            return None
        return self


class _KernelCacheImpl(CompileResultCacheImpl):
    _locator_classes = [_PackageLocator]


class _KernelCache(FunctionCache):
    _impl_class = _KernelCacheImpl


def kernel(*args, **options):
    """Declare a compiled kernel: ``numba.njit`` with the package cache (see the module docstring).

    Use as ``@kernel``, ``@kernel(inline="always")`` or ``@kernel("float64(float64)")``
    (explicit signatures are compiled at declaration, as with ``njit``). ``cache``
    must not be given; every other option is passed to :func:`numba.njit`.

    Returns
    -------
    numba.core.registry.CPUDispatcher
        The compiled function.

    Raises
    ------
    TypeError
        ``cache=`` given (the cache is always the package cache).
    """
    if "cache" in options:
        raise TypeError("kernel() manages the cache itself; do not pass cache=")
    sigs = None
    if args and not callable(args[0]):
        sigs, args = args[0], args[1:]

    def wrap(fn):
        global _warned
        disp = numba.njit(**options)(fn)
        try:
            disp._cache = _KernelCache(fn)  # what numba's enable_caching() does, with the package locator
        except RuntimeError:
            if not _warned:
                _say("no writable folder for the compiled-kernel cache; kernels are compiled at every start "
                     "(set NUMBA_CACHE_DIR to a writable folder)")
                _warned = True
        if sigs is not None:
            for s in (sigs if isinstance(sigs, (list, tuple)) else [sigs]):
                disp.compile(s)
            disp.disable_compile()  # as njit with signatures: other argument types raise TypeError
        return disp

    if args:
        return wrap(args[0])
    return wrap
