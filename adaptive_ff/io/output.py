"""Atomic outputs and output locks: a command's files appear all at once, or the previous ones stay.

A command that writes files (``adaptive-ff compare --out/--report``, ``export-c``, ...) stages them: it writes
every file into a temporary folder beside its target (:class:`StagedOutputs`, a sibling ``.NAME.adaptive-ff-PID.*``
made by :func:`tempfile.mkdtemp`, on the same file system) and moves them into place only when the whole command
has succeeded, with :func:`os.replace`:

* a target folder that does not exist yet is the staging folder renamed: one atomic step;
* into an existing folder each staged file is moved by ``os.replace`` over its namesake; files of the folder that
  the command does not write (your own files beside the figures, an older figure of another mode) stay as they
  are. Before the first move every staged name is checked against the folder (a file where the folder has a
  directory, or the reverse, is refused with nothing moved), and Ctrl-C (SIGINT) and SIGTERM are held back
  during the moves (delivered right after them), so an interrupt never leaves a mix such as a new
  ``aff_config.h`` beside an old ``aff_config.c``. Only a crash of the machine or ``kill -9`` inside the few
  renames can;
* a single file (a summary JSON) is written beside itself and renamed over it.

An exception on the way (a failed figure, a refused fit, Ctrl-C) removes the staging folders and any parent
folder the command created for them: the outputs hold their previous content byte for byte.

Each target is locked for the whole command (:func:`output_lock`): an exclusive lock file
``.NAME.adaptive-ff.lock`` beside it (inside it, ``.adaptive-ff.lock``, when its parent cannot be written), created
with ``O_CREAT | O_EXCL`` and holding the process id. A second command into the same folder or file refuses at
once with :class:`OutputInUseError` naming the target and the process; a lock whose process no longer runs (a
crash, ``kill -9``) is taken over, and the staging folders that process left beside the target are removed. The
lock is re-entrant within one process (a command and the library function it calls may both take it).
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import tempfile
import threading
import time
from pathlib import Path

from plant.errors import ParameterError

__all__ = ["OutputInUseError", "output_lock", "lock_path", "StagedOutputs", "staged_folder", "atomic_file",
           "STAGING_MARK"]

#: The part of a staging folder's or file's name after the target's name: ``.NAME.adaptive-ff-PID.<random>``.
STAGING_MARK = ".adaptive-ff-"

#: A lock file without a readable process id younger than this (s) is taken for one being written right now.
_YOUNG = 10.0

_HELD: dict = {}  # lock file -> [count, created parent folders] of the locks this process holds
_HELD_GUARD = threading.Lock()


class OutputInUseError(ParameterError):
    """An output folder or file is locked by another running ``adaptive-ff`` (:func:`output_lock`)."""


def _writable(folder: Path) -> bool:
    """Whether ``folder`` (or, where it does not exist yet, its nearest existing ancestor) can be written into."""
    cur = folder
    while not cur.exists():
        if cur.parent == cur:
            return False
        cur = cur.parent
    return cur.is_dir() and os.access(cur, os.W_OK | os.X_OK)


def lock_path(target) -> Path:
    """The lock file of an output folder or file (:func:`output_lock`).

    Parameters
    ----------
    target : str or os.PathLike
        The output folder or file, as given (resolved here: symbolic links and ``..`` followed).

    Returns
    -------
    Path
        ``PARENT/.NAME.adaptive-ff.lock`` beside the target, or ``TARGET/.adaptive-ff.lock`` inside it when the
        target has no name (``/``) or its parent cannot be written.
    """
    target = Path(target).resolve()
    if target.name and _writable(target.parent):
        return target.parent / f".{target.name}.adaptive-ff.lock"
    return target / ".adaptive-ff.lock"


def _make_parents(folder: Path) -> list:
    """Create ``folder`` and its missing parents; the folders created, outermost first."""
    missing = []
    cur = folder
    while not cur.exists():
        missing.append(cur)
        cur = cur.parent
    made = []
    for d in reversed(missing):
        try:
            d.mkdir()
        except FileExistsError:
            continue
        made.append(d)
    return made


def _remove_empty(folders) -> None:
    """Remove the folders of ``folders`` that are empty, innermost first (what a failed command created)."""
    for d in reversed(list(folders)):
        with contextlib.suppress(OSError):
            d.rmdir()


def _pid_alive(pid: int) -> bool:
    """Whether a process ``pid`` runs on this machine (conservatively True where that cannot be told)."""
    if pid <= 0:
        return False
    if pid == os.getpid():
        return True
    if os.name == "nt":  # os.kill(pid, 0) would terminate the process there
        import ctypes

        kernel32 = ctypes.windll.kernel32
        handle = kernel32.OpenProcess(0x1000, False, pid)  # PROCESS_QUERY_LIMITED_INFORMATION
        if not handle:
            return False
        code = ctypes.c_ulong()
        ok = kernel32.GetExitCodeProcess(handle, ctypes.byref(code))
        kernel32.CloseHandle(handle)
        return not ok or code.value == 259  # STILL_ACTIVE
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # PermissionError: it runs under another user
        return True
    return True


def _lock_owner(lock: Path) -> tuple[int | None, bool]:
    """``(pid or None, alive)`` of an existing lock file (alive: its process runs, or it is being written)."""
    try:
        text = lock.read_text(encoding="ascii", errors="replace").strip()
        age = time.time() - lock.stat().st_mtime
    except FileNotFoundError:
        return None, False
    except OSError:
        return None, True
    try:
        pid = int(text.split()[0])
    except (ValueError, IndexError):
        return None, age < _YOUNG
    return pid, _pid_alive(pid)


def _remove_stale_staging(target: Path, pid: int | None) -> None:
    """Remove the staging folders and files that the dead process ``pid`` left beside ``target``."""
    if pid is None or not target.name:
        return
    for p in target.parent.glob(f".{target.name}{STAGING_MARK}{pid}.*"):
        if p.is_dir() and not p.is_symlink():
            shutil.rmtree(p, ignore_errors=True)
        else:
            with contextlib.suppress(OSError):
                p.unlink()


def _in_use(target, lock: Path, pid, option: str | None) -> OutputInUseError:
    who = f"process {pid}" if pid is not None else "a process starting right now"
    name = f"{option} {target}" if option else str(target)
    return OutputInUseError(f"{name}: in use by another adaptive-ff run ({who}; lock file {lock}); wait for it to "
                            f"finish, or choose another output (remove {lock} only if no such run exists)")


def _acquire(target, lock: Path, option: str | None) -> list:
    """Create ``lock`` exclusively (taking over a stale one); the parent folders created for it."""
    made = _make_parents(lock.parent)
    try:
        for _ in range(5):
            try:
                fd = os.open(lock, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
            except FileExistsError:
                pid, alive = _lock_owner(lock)
                if alive:
                    raise _in_use(target, lock, pid, option) from None
                if _lock_owner(lock)[0] != pid:  # replaced in the meantime: look again
                    continue
                with contextlib.suppress(FileNotFoundError):
                    lock.unlink()
                _remove_stale_staging(Path(target).resolve(), pid)
                continue
            with os.fdopen(fd, "w", encoding="ascii") as fh:
                fh.write(f"{os.getpid()}\n")
            return made
        raise _in_use(target, lock, _lock_owner(lock)[0], option)
    except BaseException:
        _remove_empty(made)
        raise


@contextlib.contextmanager
def output_lock(target, option: str | None = None):
    """Hold the lock of an output folder or file for the ``with`` block (module docstring).

    Parameters
    ----------
    target : str or os.PathLike
        The output folder or file.
    option : str, optional
        The option that named it (``--out``), for the message.

    Yields
    ------
    Path
        The lock file (:func:`lock_path`).

    Raises
    ------
    OutputInUseError
        Another running process holds the lock: the message names the target, the process and the lock file.
    OSError
        The lock file cannot be created (e.g. a read-only folder).
    """
    lock = lock_path(target)
    with _HELD_GUARD:
        held = _HELD.get(lock)
        if held is not None:
            held[0] += 1
    if held is None:
        made = _acquire(target, lock, option)
        with _HELD_GUARD:
            _HELD[lock] = [1, made]
    try:
        yield lock
    finally:
        with _HELD_GUARD:
            entry = _HELD[lock]
            entry[0] -= 1
            last = entry[0] == 0
            if last:
                del _HELD[lock]
        if last:
            with contextlib.suppress(FileNotFoundError):
                lock.unlink()
            _remove_empty(entry[1])


@contextlib.contextmanager
def _signals_held():
    """Hold SIGINT and SIGTERM back for the ``with`` block (main thread only) and deliver them after it."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list = []
    sigs = [signal.SIGINT] + ([signal.SIGTERM] if hasattr(signal, "SIGTERM") else [])
    old = {}
    try:
        for s in sigs:
            old[s] = signal.signal(s, lambda signum, frame: caught.append(signum))
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h if h is not None else signal.SIG_DFL)
        for s in dict.fromkeys(caught):
            signal.raise_signal(s)


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _staged_entries(staged: Path, target: Path) -> list:
    """``(source, destination)`` of every file to move from ``staged`` into the existing folder ``target``
    (recursively); ParameterError, before anything moves, where a name is a file on one side and a folder on the
    other."""
    moves = []
    for src in sorted(staged.iterdir()):
        dst = target / src.name
        if src.is_dir() and not src.is_symlink():
            if not dst.exists():
                moves.append((src, dst))
            elif dst.is_dir() and not dst.is_symlink():
                moves.extend(_staged_entries(src, dst))
            else:
                raise ParameterError(f"{dst}: a file, where this run writes a folder of that name; move it away")
        else:
            if dst.is_dir() and not dst.is_symlink():
                raise ParameterError(f"{dst}: a folder, where this run writes a file of that name; move it away")
            moves.append((src, dst))
    return moves


def _fsync(path: Path) -> None:
    """Flush a staged file to the disk before it is renamed into place (a crash then leaves old or new bytes)."""
    if path.is_file() and not path.is_symlink():
        with contextlib.suppress(OSError):
            fd = os.open(path, os.O_RDONLY)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)


class StagedOutputs:
    """The outputs of one command, staged beside their targets and moved into place together (module docstring).

    Use it as a context manager: :meth:`folder` and :meth:`file` lock a target and return where to write instead;
    a ``with`` block that ends normally moves every staged file into place (:meth:`commit`); an exception removes
    them (:meth:`abort`). The locks are released in both cases.

    Examples
    --------
    >>> with StagedOutputs() as staged:                          # doctest: +SKIP
    ...     out = staged.folder("results", "--out")
    ...     (out / "table.csv").write_text("a,b\\n")
    >>> staged.final(out / "table.csv")                          # doctest: +SKIP
    PosixPath('results/table.csv')
    """

    def __init__(self):
        self._stack = contextlib.ExitStack()
        self._targets: dict = {}  # resolved target -> (given target, staging path, is folder)
        self._made: list = []  # parent folders created for staging
        self._done = False

    def __enter__(self) -> StagedOutputs:
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        try:
            if exc_type is None:
                self.commit()
            else:
                self.abort()
        finally:
            self._stack.close()
        return False

    def _stage(self, target, option: str | None, folder: bool) -> Path:
        if self._done:
            raise RuntimeError("StagedOutputs: already committed or aborted")
        given = Path(target)
        real = given.resolve()
        if real in self._targets:
            g, staged, is_folder = self._targets[real]
            if is_folder != folder:
                raise ParameterError(f"{option or 'output'} {given}: named as a folder and as a file")
            return staged
        if folder and real.exists() and not real.is_dir():
            raise ParameterError(f"{option or 'output'} {given}: an existing file, not a directory; give a "
                                 "directory name")
        if not folder and real.is_dir():
            raise ParameterError(f"{option or 'output'} {given}: is a directory; give a file name")
        self._stack.enter_context(output_lock(given, option))
        beside = bool(real.name) and _writable(real.parent)
        home = real.parent if beside else real
        if not beside and not real.is_dir():
            raise ParameterError(f"{option or 'output'} {given}: the folder {real.parent} cannot be written")
        self._made += _make_parents(home)
        prefix = f".{real.name}{STAGING_MARK}{os.getpid()}." if beside else f".adaptive-ff-staging-{os.getpid()}."
        if folder:
            staged = Path(tempfile.mkdtemp(dir=home, prefix=prefix))
        else:
            fd, name = tempfile.mkstemp(dir=home, prefix=prefix, suffix=".tmp")
            os.close(fd)
            staged = Path(name)
        self._targets[real] = (given, staged, folder)
        return staged

    def folder(self, target, option: str | None = None) -> Path:
        """Lock the output folder ``target`` and return the staging folder to write its files into.

        Parameters
        ----------
        target : str or os.PathLike
            The folder the files belong in; it and its parents may not exist yet.
        option : str, optional
            The option that named it (``--out``), for messages.

        Returns
        -------
        Path
            An empty folder beside ``target`` (the same one for the same target given twice).

        Raises
        ------
        OutputInUseError
            Another running process writes into ``target``.
        ParameterError
            ``target`` is an existing file, or neither it nor its parent can be written.
        """
        return self._stage(target, option, True)

    def file(self, target, option: str | None = None) -> Path:
        """Lock the output file ``target`` and return the staging file to write instead (it exists, empty).

        Parameters
        ----------
        target : str or os.PathLike
            The file; its folder may not exist yet.
        option : str, optional
            The option that named it, for messages.

        Returns
        -------
        Path
            An empty file beside ``target``.

        Raises
        ------
        OutputInUseError
            Another running process writes ``target``.
        ParameterError
            ``target`` is a directory, or its folder cannot be written.
        """
        return self._stage(target, option, False)

    def final(self, path) -> Path:
        """Where a staged path ends up after :meth:`commit`, spelled as its target was given.

        Parameters
        ----------
        path : str or os.PathLike
            A path inside a staging folder, a staging file, or any other path (returned unchanged).

        Returns
        -------
        Path
        """
        p = Path(path)
        for given, staged, folder in self._targets.values():
            if p == staged:
                return given
            if folder:
                with contextlib.suppress(ValueError):
                    return given / p.relative_to(staged)
        return p

    def relocate(self, obj):
        """``obj`` (nested dicts, lists, tuples, strings and paths, e.g. a result's ``to_dict()``) with every staged
        path replaced by :meth:`final` of it.

        Parameters
        ----------
        obj : object
            JSON-like data.

        Returns
        -------
        object
            The same structure; strings stay strings, paths stay paths.
        """
        if isinstance(obj, Path):
            return self.final(obj)
        if isinstance(obj, str):
            for given, staged, _ in self._targets.values():
                if obj == str(staged) or obj.startswith(str(staged) + os.sep):
                    return str(self.final(obj))
            return obj
        if isinstance(obj, dict):
            return {k: self.relocate(v) for k, v in obj.items()}
        if isinstance(obj, (list, tuple)):
            return type(obj)(self.relocate(v) for v in obj)
        return obj

    def commit(self) -> None:
        """Move every staged file into place (module docstring); a target nothing was written for stays as it was.

        Raises
        ------
        ParameterError
            A staged name is a file where its target has a folder, or the reverse (nothing moved then).
        OSError
            A rename failed (e.g. the disk went read-only); what had not moved yet is removed.
        """
        if self._done:
            return
        plans = []
        mode = 0o777 & ~_umask()
        try:
            for real, (given, staged, folder) in self._targets.items():
                if not folder:
                    _fsync(staged)
                    staged.chmod(real.stat().st_mode & 0o7777 if real.exists() else mode & 0o666)
                    plans.append([(staged, real)])
                elif any(staged.iterdir()):
                    for f in staged.rglob("*"):
                        _fsync(f)
                    if real.exists():
                        plans.append(_staged_entries(staged, real))
                    else:
                        staged.chmod(mode)
                        plans.append([(staged, real)])
            with _signals_held():
                for plan in plans:
                    for src, dst in plan:
                        os.replace(src, dst)
        finally:
            self._cleanup()

    def abort(self) -> None:
        """Remove every staging folder and file, and the parent folders created for them: the targets keep their
        previous content."""
        self._cleanup()

    def _cleanup(self) -> None:
        self._done = True
        for _, staged, folder in self._targets.values():
            if folder:
                shutil.rmtree(staged, ignore_errors=True)
            else:
                with contextlib.suppress(FileNotFoundError):
                    staged.unlink()
        _remove_empty(self._made)


@contextlib.contextmanager
def staged_folder(target, option: str | None = None):
    """Write the files of one output folder atomically: ``with staged_folder(out) as tmp: <write into tmp>``.

    Parameters
    ----------
    target : str or os.PathLike
        The output folder (created with its parents if missing).
    option : str, optional
        The option or argument that named it, for messages.

    Yields
    ------
    Path
        The staging folder (:meth:`StagedOutputs.folder`); its files move into ``target`` when the block ends
        normally, and are removed if it raises.

    Raises
    ------
    OutputInUseError
        Another running process writes into ``target``.
    """
    with StagedOutputs() as staged:
        yield staged.folder(target, option)


@contextlib.contextmanager
def atomic_file(target, option: str | None = None):
    """Write one file atomically: ``with atomic_file(path) as tmp: <write tmp>`` (renamed over ``path`` at the end).

    Parameters
    ----------
    target : str or os.PathLike
        The file to write (its folder created if missing); an existing file keeps its permissions.
    option : str, optional
        The option that named it, for messages.

    Yields
    ------
    Path
        The staging file beside ``target`` (:meth:`StagedOutputs.file`).

    Raises
    ------
    OutputInUseError
        Another running process writes ``target``.
    """
    with StagedOutputs() as staged:
        yield staged.file(target, option)
