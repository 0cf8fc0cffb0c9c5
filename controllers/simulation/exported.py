"""Run a compiled ``export-c`` folder in the package's closed loop: what a drive runs is what the tables measure.

:class:`ExportedLibrary` compiles the C sources of an export folder (``aff.c``, ``aff_config.c``: the files
``adaptive-ff export-c`` writes for a drive) with the system's C compiler into a shared library of its own, in a
temporary folder removed when the object goes, and loads it (:mod:`ctypes`). :meth:`ExportedLibrary.compensator`
configures the library's drive struct (``aff``, ``adaptive_ff/csrc/aff_drive.h``) with the settings of a
compensator of mode ``adaptive`` built by the package (:class:`controllers.peers.adaptive_dob.AdaptiveCompensator`),
by the library's own ``aff_init``, and hands the engine the library's ops table ``aff_drive_ops``: every period the
engine calls the library's ``aff_step_gated`` and the guard's check of ``aff_observe`` and the library's
``aff_adaptive_observe``, the compiled code of the export, input guard included, not the package's module. The
package's compensator object then reads its state from the library's struct (its estimate, supervisor and
counters in results and reports).

Only a double build can run in the package's engine (its ``aff_real`` is ``double``); the float build of an export
is checked against the package by replay (``tests/adaptive_ff_layer/test_export_c.py``).
"""

from __future__ import annotations

import ctypes
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

from controllers._cctl import ffi, lib
from controllers.peers.adaptive_dob import AdaptiveCompensator
from plant.errors import ParameterError

__all__ = ["ExportedLibrary", "ExportedCompensator", "COMPILE_FLAGS"]

#: Flags of the shared library: C99, every floating-point operation as written (no contraction into fused
#: multiply-adds, as the package's own build, ``plant/_cbuild.py``), position-independent, double precision.
COMPILE_FLAGS = ("-std=c99", "-O2", "-ffp-contract=off", "-fno-fast-math", "-fPIC", "-shared", "-UAFF_FLOAT")


def _compiler(cc: str | None) -> str:
    name = cc or os.environ.get("CC") or "cc"
    path = shutil.which(name)
    if path is None:
        raise ParameterError(f"cc: no C compiler {name!r} on PATH (set CC or pass cc=) to build the export")
    return path


class ExportedLibrary:
    """An export folder compiled into a shared library and loaded, ready to run in the package's engine.

    Parameters
    ----------
    folder : str or os.PathLike
        An ``adaptive-ff export-c`` folder (``aff.h``, ``aff.c``, ``aff_config.h``, ``aff_config.c``).
    cc : str or None, keyword-only
        The C compiler; default ``$CC``, else ``cc``.

    Attributes
    ----------
    folder : Path
        The export folder. The library is built in a temporary folder that is removed once it is loaded.

    Raises
    ------
    ParameterError
        The folder lacks a file of the export, no compiler is found, or the sources do not compile (the
        compiler's message). The library is built in double precision (``AFF_FLOAT`` undefined), as the package's
        engine runs.
    """

    SOURCES = ("aff.c", "aff_config.c")

    def __init__(self, folder, *, cc: str | None = None):
        self.folder = Path(folder)
        missing = [f for f in ("aff.h", "aff_config.h") + self.SOURCES if not (self.folder / f).is_file()]
        if missing:
            raise ParameterError(f"{self.folder}: not an export-c folder (missing {', '.join(missing)})")
        compiler = _compiler(cc)
        tmp = tempfile.mkdtemp(prefix="adaptive-ff-export-")
        try:
            path = Path(tmp) / "libaff_export.so"
            cmd = [compiler, *COMPILE_FLAGS, f"-I{self.folder}", *(str(self.folder / f) for f in self.SOURCES),
                   "-o", str(path), "-lm"]
            r = subprocess.run(cmd, capture_output=True, text=True)
            if r.returncode != 0:
                raise ParameterError(f"{self.folder}: the export does not compile ({' '.join(cmd)}):\n{r.stderr.strip()}")
            self._dll = ctypes.CDLL(str(path))
        finally:
            # the loaded library stays mapped: the folder goes now, also in a worker process that ends without
            # running finalizers (a pool's os._exit)
            shutil.rmtree(tmp, ignore_errors=True)
        self._init = ffi.cast("aff_error (*)(aff *, const aff_config *)",
                              ctypes.cast(self._dll.aff_init, ctypes.c_void_p).value)
        self._ops = ffi.cast("aff_compensator_ops *", ctypes.addressof(ctypes.c_char.in_dll(self._dll, "aff_drive_ops")))

    def compensator(self, comp: AdaptiveCompensator, **guard) -> ExportedCompensator:
        """The compensator ``comp`` (mode ``adaptive``, before it observes anything) run by this library.

        Parameters
        ----------
        comp : AdaptiveCompensator
            Built by the package (:func:`controllers.simulation.compensators.build_mode`); its settings
            (:meth:`~controllers.peers.adaptive_dob.AdaptiveCompensator.drive_config`) configure the library's
            struct, which ``comp`` reads from then on.
        **guard
            The input guard's settings (``w_max`` rad/s, ``u_max`` N·m, ``hold_time`` s); default the guard's
            defaults at the compensator's period.

        Returns
        -------
        ExportedCompensator

        Raises
        ------
        ParameterError
            ``comp`` is not an :class:`AdaptiveCompensator`, the library's ``aff_init`` refuses its settings (the
            library's message), or the struct it builds differs from the package's (another version of the C core).
        """
        return ExportedCompensator(self, comp, **guard)

    def __repr__(self) -> str:
        return f"ExportedLibrary({str(self.folder)!r})"


class ExportedCompensator:
    """A compensator of mode ``adaptive`` run by an :class:`ExportedLibrary` (made by
    :meth:`ExportedLibrary.compensator`): the engine calls the library through :attr:`ops` with :attr:`handle`.

    Attributes
    ----------
    compensator : AdaptiveCompensator
        The package's object, reading the library's struct (``estimate``, ``supervisor``, ``info()``, ...: every
        other attribute is its).
    ops, handle : cffi pointers
        The library's ``aff_drive_ops`` and the drive struct ``aff`` (owned here).
    """

    C_OPS = None
    MODE = "adaptive"

    def __init__(self, library: ExportedLibrary, comp, **guard):
        if not isinstance(comp, AdaptiveCompensator):
            raise ParameterError(f"comp must be an AdaptiveCompensator (mode adaptive), got {type(comp).__name__}")
        self.library = library
        self._aff = ffi.new("aff *")
        cfg = comp.drive_config(**guard)
        e = library._init(self._aff, cfg)
        if e != lib.AFF_OK:
            raise ParameterError(f"the exported library's aff_init refused the settings: "
                                 f"{ffi.string(lib.aff_error_message(e)).decode()}")
        mode = ffi.addressof(self._aff, "mode")
        if bytes(ffi.buffer(mode)) != comp.struct_bytes():
            raise ParameterError(f"{library.folder}: the library's aff_init builds another struct than the package "
                                 f"for the same settings (an export of another version?)")
        comp._use(mode, self)
        self.compensator = comp
        self.ops = library._ops
        self.handle = ffi.cast("void *", self._aff)

    @property
    def cdata(self):
        """The library's drive struct (cffi ``aff *``)."""
        return self._aff

    def __getattr__(self, name):
        if name.startswith("__") or name in ("compensator", "_aff", "library"):
            raise AttributeError(name)
        return getattr(self.compensator, name)

    def __repr__(self) -> str:
        return f"ExportedCompensator({self.library!r}, {self.compensator!r})"
