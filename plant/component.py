"""Runtime components: a thin Python object over the C struct that the C core's functions advance.

Every piece of the closed loop that runs at the controller rate (friction
model, PI, gate, estimator, RLS, feedforward, peers, metrics) is a C99 struct
with named fields (configuration and state) and ``*_init`` / ``*_step`` /
``*_observe`` functions in the ``csrc`` folder of its package (``plant/csrc``,
``adaptive_ff/csrc``, ``controllers/csrc``). Those functions are the only
implementation of the component's equations: the Python methods call them
through cffi, and so does the closed-loop engine (``controllers/csrc/ctl_engine.c``),
which composes components by holding their structs. A composite component
(an estimator with its own gate and RLS) embeds its parts' structs as fields;
the Python part objects then point into the composite's struct
(:meth:`Component._use`), so their attributes show the live values. The
pattern is filterpy's small stateful filters (public ``x``, ``P``) and OSQP's
C workspace behind a thin Python object.
"""

from __future__ import annotations

from typing import Any

__all__ = ["Component"]


class Component:
    """Base class: owns (or points into) one C struct of the component's type.

    Subclasses set two class attributes, ``_ffi`` (the cffi ``FFI`` of their
    package's extension module) and ``_ctype`` (the struct's C name, e.g.
    ``"aff_gate"``), call :meth:`_new_struct` in ``__init__`` and expose named
    properties that read and write fields of :attr:`cdata`.

    Attributes
    ----------
    cdata : cffi pointer
        Pointer to the component's struct (owned, or a field of a composite's struct).

    Notes
    -----
    Copies (:func:`copy.deepcopy`, :mod:`pickle`: a process pool, Dask) carry
    the struct's bytes; a composite re-points its parts in :meth:`_attached`.
    """

    _ffi: Any = None
    _ctype: str = ""

    def _new_struct(self) -> None:
        """Allocate a zeroed struct of type ``_ctype`` owned by this object."""
        self._c = self._ffi.new(f"{self._ctype} *")
        self._owner = None

    def _use(self, ptr, owner) -> None:
        """Use the struct at ``ptr`` (a field of ``owner``'s struct, kept alive here) from now on, after
        copying the current values into it; then :meth:`_attached` re-points the parts (a composite's), while the
        old struct is still alive (their old pointers point into it)."""
        old, old_owner = self._c, self._owner  # noqa: F841 - alive until the parts have moved along
        ptr[0] = old[0]
        self._c = ptr
        self._owner = owner
        self._attached()

    @property
    def cdata(self):
        """Pointer to the component's C struct (cffi)."""
        return self._c

    def struct_bytes(self) -> bytes:
        """The struct's bytes (a snapshot of configuration and state)."""
        return bytes(self._ffi.buffer(self._c))

    def _attached(self) -> None:
        """Hook: re-point parts into this component's struct (composites override it)."""

    def __getstate__(self) -> dict:
        d = {k: v for k, v in self.__dict__.items() if k not in ("_c", "_owner")}
        d["_cbytes"] = self.struct_bytes()
        return d

    def __setstate__(self, d: dict) -> None:
        d = dict(d)
        raw = d.pop("_cbytes")
        self.__dict__.update(d)
        self._new_struct()
        self._ffi.buffer(self._c)[:] = raw
        self._attached()
