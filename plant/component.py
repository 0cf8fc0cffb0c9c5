"""Runtime components: a thin Python object over the C struct that the C core's functions advance.

Every piece of the closed loop that runs at the controller rate (friction
model, PI, gate, estimator, RLS, feedforward, peers, metrics) is a C99 struct
with named fields (configuration and state) and ``*_init`` / ``*_step`` /
``*_observe`` functions in the ``csrc`` folder of its package (``plant/csrc``,
``adaptive_ff/csrc``, ``controllers/csrc``); the components a drive runs are configured from
a config struct of settings (``aff_X_config``, checked and turned into the derived fields by
``aff_X_init``: :meth:`Component._configure`). Those functions are the only
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

import dataclasses
import functools
import operator
import re
import weakref
from numbers import Integral, Real
from pathlib import Path
from typing import Any

import numpy as np

from plant.errors import ParameterError

__all__ = ["Component", "c_compensate", "c_observe", "config_class", "config_defaults", "ops_table", "SettingTypeError",
           "step_time", "struct_field", "struct_fields"]


class SettingTypeError(ParameterError, TypeError):
    """A setting of the wrong type (a string or a bool for a number, a float for a count): a
    :class:`plant.errors.ParameterError` and a TypeError, naming the class and the field."""


def _value(ffi, x):
    """A C value as Python: a struct as a dict of its fields, an array as a list, a number as itself."""
    t = ffi.typeof(x) if isinstance(x, ffi.CData) else None
    if t is None:
        return x
    if t.kind == "struct":
        return {name: _value(ffi, getattr(x, name)) for name, _ in t.fields}
    if t.kind == "array":
        return [_value(ffi, v) for v in x]
    return x


def config_defaults(ffi, lib, ctype: str) -> dict:
    """The defaults of the C settings ``ctype`` (``"aff_X_config"``), as ``aff_X_default_config()`` returns them.

    The one statement of a component's defaults is its C ``aff_X_default_config()``; a Python class that offers
    a field of it as a keyword takes the keyword's default from here (read once, at import).

    Parameters
    ----------
    ffi, lib : cffi FFI and library
        The extension module of the package that owns the struct (e.g. ``adaptive_ff._caff``).
    ctype : str
        The config struct's C name, ending in ``_config`` (``"aff_config"``: the drive's, ``aff_default_config``).

    Returns
    -------
    dict
        Field name -> default: a float or an int (a flag is 0 or 1), a nested struct as a dict, an array as a list.

    Raises
    ------
    ParameterError
        ``ctype`` is no config struct with a ``*_default_config`` function in ``lib``.
    """
    if not ctype.endswith("_config"):
        raise ParameterError(f"ctype must name a config struct (…_config), got {ctype!r}")
    fn = getattr(lib, f"{ctype[:-len('_config')]}_default_config", None)
    if fn is None:
        raise ParameterError(f"{ctype}: the library has no {ctype[:-len('_config')]}_default_config()")
    return _value(ffi, fn())


@functools.lru_cache(maxsize=None)
def _header_text(header: str) -> str:
    """The text of the C header at ``header`` ("" where it cannot be read), read once per process."""
    try:
        return Path(header).read_text()
    except OSError:
        return ""


def _field_comments(header, ctype: str) -> dict:
    """Field -> its comment (whitespace joined, a continuation line's leading ``*`` dropped) in the C declaration of
    ``ctype`` in ``header`` ({} without one)."""
    if header is None:
        return {}
    m = re.search(r"typedef struct " + ctype + r" \{(.*?)\} " + ctype + ";", _header_text(str(header)), re.S)
    if m is None:
        return {}
    rows = re.findall(r"(\w+)(?:\[[^\]]*\])?;\s*/\*(.*?)\*/", m.group(1), re.S)
    return {name: " ".join(re.sub(r"\n\s*\*", " ", c).split()) for name, c in rows}


#: The folder that holds the packages; those built from C (a ``_cbuild.py``) declare the structs in ``csrc/*.h``.
_PACKAGES = Path(__file__).resolve().parent.parent


@functools.lru_cache(maxsize=None)
def _struct_comments(ctype: str, header=None) -> dict:
    """Field -> its comment in the declaration of the C struct ``ctype``: in ``header``, or (None) in the first of
    the C-built packages' ``csrc`` headers that declares it ({} where none does)."""
    headers = [header] if header is not None else sorted(
        h for build in _PACKAGES.glob("*/_cbuild.py") for h in (build.parent / "csrc").glob("*.h"))
    for h in headers:
        notes = _field_comments(h, ctype)
        if notes:
            return notes
    return {}


def config_class(name: str, ffi_lib: tuple, ctype: str, *, module: str, summary: str, header=None, exclude=(),
                 fields: dict | None = None) -> type:
    """A frozen dataclass of the settings ``ctype`` (a C ``aff_X_config``): the one generic way to make the Python
    config classes of the components.

    Its fields are the struct's scalar fields in C order (less ``exclude``: the inputs the component's constructor
    takes itself, and the parts given as objects); each field's default is the C ``aff_X_default_config()``'s
    (:func:`config_defaults`), its docstring row the field's comment in the C header (unit, range, default), its
    range the C ``aff_X_init``'s to check when a component is configured from it. A C ``double`` is a float, a
    ``long`` an int, an ``int`` a flag (bool) or, given in ``fields`` as a choice, a name (str); a struct field
    given in ``fields`` with a config class is a field holding that class (default: its defaults).

    Parameters
    ----------
    name : str
        The class's name (e.g. ``"FrictionFeedforwardConfig"``).
    ffi_lib : tuple
        ``(ffi, lib)`` of the cffi extension module of the package that owns the struct (e.g. ``adaptive_ff._caff``'s).
    ctype : str
        The config struct's C name, ending in ``_config``.
    module : str
        The module the class lives in (``__name__``; the class must be bound to ``name`` there to pickle).
    summary : str
        The docstring's first paragraph.
    header : path-like, optional
        The C header that declares ``ctype`` (its field comments make the parameter docs).
    exclude : iterable of str
        C fields left out.
    fields : dict, optional
        The fields that are not plain numbers: C field -> ``(Python name, {C value: name})``, a C enum or flag
        offered as a name (``"at_ref"`` -> ``("ff_input", {0: "measured", 1: "reference"})``); or C struct field ->
        the config class of its settings (a nested config).

    Returns
    -------
    type
        The frozen dataclass. Besides its fields: ``CTYPE`` (the C name), ``c_fields()`` (C field -> value for
        :meth:`Component._settings`, a nested config as its dict), ``replace(**changes)``; an unknown choice raises a
        ParameterError naming the field.
    """
    (ffi, lib), fields, exclude = ffi_lib, dict(fields or {}), set(exclude)
    choices = {k: v for k, v in fields.items() if isinstance(v, tuple)}
    nested = {k: v for k, v in fields.items() if isinstance(v, type)}
    defaults = config_defaults(ffi, lib, ctype)
    notes = _field_comments(header, ctype)
    specs, rows, to_c = [], [], {}
    for cname, f in ffi.typeof(ctype).fields:
        if cname in exclude:
            continue
        if cname in nested:
            cls = nested[cname]
            specs.append((cname, cls, dataclasses.field(default_factory=cls)))
            rows.append(f"{cname} : {cls.__name__}\n    {notes.get(cname, '')} (C ``{cname}``)")
            to_c[cname] = cname
            continue
        if f.type.kind != "primitive":
            continue  # a part (struct, array): given to the component as an object
        key, kind, default = cname, None, defaults[cname]
        if cname in choices:
            key, names = choices[cname]
            kind, default = str, dict(names)[default]
        elif f.type.cname in ("double", "float"):
            kind, default = float, float(default)
        elif f.type.cname == "int":
            kind, default = bool, bool(default)
        else:
            kind, default = int, int(default)
        specs.append((key, kind, dataclasses.field(default=default)))
        among = f"one of {tuple(dict(choices[cname][1]).values())}; " if cname in choices else ""
        rows.append(f"{key} : {kind.__name__}, default {default!r}\n    {among}{notes.get(cname, '')} (C ``{cname}``)")
        to_c[key] = cname
    by_key = {choices[c][0]: dict(choices[c][1]) for c in choices}

    def __post_init__(self):
        for key, names in by_key.items():
            if getattr(self, key) not in names.values():
                raise ParameterError(f"{name}: {key} must be one of {tuple(names.values())}, "
                                     f"got {getattr(self, key)!r}")
        for key in nested:
            if not isinstance(getattr(self, key), nested[key]):
                raise ParameterError(f"{name}: {key} must be a {nested[key].__name__}, got "
                                     f"{type(getattr(self, key)).__name__}")

    # per field, in C order: (Python name, C name, {choice name: its first C code} or None, a nested config)
    spec = tuple((key, cname, {n: code for code, n in reversed(by_key[key].items())} if key in by_key else None,
                  key in nested) for key, cname in to_c.items())

    # the values in C order in one call, then the few choices and nested configs converted in place
    values = operator.attrgetter(*[key for key, *_ in spec]) if len(spec) > 1 else (
        lambda self: tuple(getattr(self, key) for key, *_ in spec))
    cnames = tuple(cname for _, cname, *_ in spec)
    special = tuple((i, codes, sub) for i, (_, _, codes, sub) in enumerate(spec) if codes is not None or sub)

    def c_fields(self) -> dict:
        """C field -> value: a choice as its C code, a nested config as its ``c_fields()``."""
        v = values(self)
        if special:
            v = list(v)
            for i, codes, sub in special:
                v[i] = codes[v[i]] if codes is not None else v[i].c_fields()
        return dict(zip(cnames, v))

    def replace(self, **changes):
        """A copy with ``changes`` (:func:`dataclasses.replace`)."""
        return dataclasses.replace(self, **changes)

    cls = dataclasses.make_dataclass(name, specs, frozen=True, namespace={
        "__post_init__": __post_init__, "c_fields": c_fields, "replace": replace, "CTYPE": ctype,
        "__module__": module})
    where = "" if header is None else f", ``{'/'.join(Path(header).parts[-3:])}``"
    cls.__doc__ = (f"{summary}\n\nThe fields and their defaults are those of the C settings ``{ctype}``{where} "
                   f"(``{ctype[:-len('_config')]}_default_config()``); the ranges are checked by "
                   f"``{ctype[:-len('_config')]}_init`` when a component is configured from them (a ParameterError "
                   f"naming the field).\n\nParameters\n----------\n" + "\n".join(rows) + "\n")
    return cls


def struct_field(field: str, kind=float, doc: str = "", *, via: str = "_c", settable: bool = False,
                 flag: str | None = None, check=None, size: str | None = None, view: bool = False,
                 square: bool = False, scale: str | None = None, choices: dict | None = None) -> property:
    """A public attribute that reads one field of a component's C struct: the one accessor of the wrappers
    (``n_rejected = struct_field("n_rejected", int, "Samples rejected.")``).

    Parameters
    ----------
    field : str
        The C field, a dotted path for a nested one (``"res.u_max"``).
    kind : callable
        Conversion of the C value (``float``, ``int``, ``bool``), default float.
    doc : str
        The attribute's docstring (with its unit).
    via : str, keyword-only
        The attribute that holds the struct pointer, default ``"_c"`` (:attr:`Component.cdata`; a part's, e.g.
        ``"_f"``, where the struct is a field of a composite's).
    settable : bool, keyword-only
        Writable too (a state a caller preloads or restores): the value converted by ``kind`` (a bool stored as
        0/1); default False (read-only).
    flag : str or None, keyword-only
        A field beside ``field`` that says whether it holds a value (``"has_last"``): the attribute reads None
        while the flag is 0; set, None clears the flag and a value sets it. Default None: always a value.
    check : callable or None, keyword-only
        With ``settable``: ``check(value) -> value`` validates a value set before it is stored (e.g.
        ``functools.partial(plant.errors.check_finite_scalar, "integral")``: a ParameterError naming the
        attribute); default None: ``kind`` alone converts it.
    size : str or None, keyword-only
        For an array field: the field beside ``field`` that holds the number of elements in use (``"p"``); the
        attribute reads a new float64 ndarray of that length (a copy; ``kind`` is not applied) and is read-only.
        Default None: a scalar field.
    view : bool, keyword-only
        With ``size``: read a view of the C array's first entries instead of a copy (its writes go to the struct;
        the C element type's float dtype). Default False.
    square : bool, keyword-only
        With ``size``: the array holds a row-major ``size`` x ``size`` matrix (``P``): the attribute reads it with
        shape (n, n). Default False: shape (n,).
    scale : str or None, keyword-only
        A field beside ``field`` whose value multiplies the read value after ``kind`` (``"Tc"``: a count of steps
        read in seconds); read-only. Default None.
    choices : dict or None, keyword-only
        C value -> the name the attribute reads (``{0: "difference", 1: "kalman"}``); read-only. Default None.

    Returns
    -------
    property
    """
    path = tuple(field.split("."))

    def holder(self):
        v = getattr(self, via)
        for name in path[:-1]:
            v = getattr(v, name)
        return v

    def get(self):
        h = holder(self)
        if flag is not None and not getattr(h, flag):
            return None
        if size is not None:
            a, n = getattr(h, path[-1]), int(getattr(h, size))
            m = n * n if square else n
            if view:
                dtype = np.dtype(f"f{self._ffi.sizeof(self._ffi.typeof(a).item)}")
                out = np.frombuffer(self._ffi.buffer(a), dtype=dtype)[:m]
            else:
                out = np.array(self._ffi.unpack(a, m), dtype=float)
            return out.reshape(n, n) if square else out
        if choices is not None:
            return choices[int(getattr(h, path[-1]))]
        v = kind(getattr(h, path[-1]))
        return v * float(getattr(h, scale)) if scale is not None else v

    def put(self, value) -> None:
        h = holder(self)
        if flag is not None:
            setattr(h, flag, 0 if value is None else 1)
            if value is None:
                return
        if check is not None:
            value = check(value)
        setattr(h, path[-1], int(bool(value)) if kind is bool else kind(value))

    if flag is None and size is None and choices is None and scale is None and len(path) == 1:
        name = path[0]

        def get(self):  # the common case, a plain field of the struct: one read, converted
            return kind(getattr(getattr(self, via), name))

    get.__name__ = put.__name__ = path[-1]
    writable = settable and size is None and scale is None and choices is None
    return property(get, put if writable else None, doc=doc)


def _c_kind(ctype) -> type:
    """The Python kind of a primitive cffi type: a C floating type is a float, an ``int`` a flag (bool), any other
    integer (``long``, ``int64_t``) an int (the convention of the C structs, as :func:`config_class`'s)."""
    if ctype.cname in ("double", "float"):
        return float
    return bool if ctype.cname == "int" else int


def struct_fields(*fields: str, settable=(), via: str = "_c", header=None):
    """A class decorator that gives a component class a public attribute for each of the C ``fields`` of its struct:
    the one declaration of the C-mirrored attributes (``@struct_fields("Tc", "m", "ff.dt", settable=("d_hat",))``).

    Each attribute is a :func:`struct_field` named after the field's last name (``"ff.dt"`` -> ``dt``), its kind
    the C type's (a ``double`` a float, an ``int`` a flag read as a bool, a ``long`` or ``int64_t`` an int) and its
    docstring the field's comment in the C header that declares the struct (the unit, the range): the C header is
    the one statement of the field.

    Parameters
    ----------
    *fields : str
        C fields of the class's struct ``_ctype`` (a dotted path for a field of a nested struct), primitive ones.
    settable : iterable of str, keyword-only
        Those of ``fields`` that are writable too (a state a caller preloads or restores); default none.
    via : str, keyword-only
        The attribute that holds the struct pointer (:func:`struct_field`'s ``via``), default ``"_c"``.
    header : path-like, optional, keyword-only
        The C header that declares the structs; default None: the first of the C-built packages' ``csrc/*.h`` that
        declares each (where none does, e.g. an install without the headers, the docstring only names the field).

    Returns
    -------
    callable
        The decorator: sets the attributes on the class (of ``_ffi``, ``_ctype``) and returns it.

    Raises
    ------
    ParameterError
        At class creation: a field that is not a primitive field of the struct, one without a comment in the
        header that declares the struct, a ``settable`` name not among ``fields``, or an attribute the class
        already defines.
    """
    settable = set(settable)

    def decorate(cls):
        unknown = settable - set(fields)
        if unknown:
            raise ParameterError(f"{cls.__name__}: settable names fields not given: {sorted(unknown)}")
        for field in fields:
            ctype, names = cls._ctype, field.split(".")
            for i, name in enumerate(names):
                f = dict(cls._ffi.typeof(ctype).fields).get(name)
                if f is None or f.type.kind != ("struct" if i < len(names) - 1 else "primitive"):
                    raise ParameterError(f"{cls.__name__}: field must be a primitive field of {cls._ctype}, "
                                         f"got {field!r}")
                owner, ctype = ctype, f.type.cname.replace("struct ", "")
            notes = _struct_comments(owner, header)
            note = notes.get(names[-1]) if notes else f"the C field {names[-1]} of {owner}"  # no header shipped
            if not note:
                raise ParameterError(f"{cls.__name__}: field {field!r} has no comment in the C declaration of {owner}")
            if names[-1] in vars(cls):
                raise ParameterError(f"{cls.__name__}: attribute {names[-1]!r} is already defined")
            kind = _c_kind(f.type)
            if kind is bool:  # a C flag's "1: ...; 0: ..." as the values the attribute reads
                note = re.sub(r"(^|; |, )([01])\b", lambda m: m.group(1) + ("True" if m.group(2) == "1" else "False"),
                              note)
            doc = f"{note[0].upper()}{note[1:]} (C ``{field}``)."
            setattr(cls, names[-1], struct_field(field, kind, doc, via=via, settable=field in settable))
        return cls

    return decorate


def step_time(field: str, period: str, doc: str = "", *, via: str = "_c") -> property:
    """A public read-only attribute that reads a step index of the C struct in seconds, or None: the one accessor
    of a switch time (``t_switch_in = step_time("res.sw.k_in", "switch_in.Tc", "Time of the switch-in (s).")``).

    Parameters
    ----------
    field : str
        The C field holding the step index ``k`` (a dotted path, as :func:`struct_field`); ``k < 0`` means "not
        (yet)".
    period : str
        A dotted attribute path from the component to the step's period (s), e.g. ``"switch_in.Tc"``; a None on
        the path (the part absent) makes the attribute read None.
    doc : str
        The attribute's docstring (with its unit).
    via : str, keyword-only
        The attribute that holds the struct pointer, default ``"_c"``.

    Returns
    -------
    property
        Reads ``k * period`` (s), or None where the part is absent or ``k < 0``.
    """
    path, link = tuple(field.split(".")), tuple(period.split("."))

    def get(self):
        Ts = self
        for name in link:
            Ts = getattr(Ts, name)
            if Ts is None:
                return None
        k = getattr(self, via)
        for name in path:
            k = getattr(k, name)
        return None if k < 0 else float(k) * float(Ts)

    get.__name__ = path[-1]
    return property(get, doc=doc)


def c_compensate(fn, doc: str):
    """The compensator protocol's ``compensate(w_meas, w_ref) -> float`` of a component, calling the C function
    ``fn(struct, w_ctrl, w_meas, w_ref)`` with the measured velocity as the controller's (``w_ctrl = w_meas``).

    Parameters
    ----------
    fn : cffi function
        The C ``*_compensate`` (``double (*)(T *, double, double, double)``).
    doc : str
        The method's docstring (units, what it returns).

    Returns
    -------
    function
        ``compensate(self, w_meas, w_ref)``: the compensation (N·m) as a float.
    """
    def compensate(self, w_meas: float, w_ref: float) -> float:
        w_meas = float(w_meas)
        return float(fn(self._c, w_meas, w_meas, float(w_ref)))

    compensate.__doc__ = doc
    return compensate


def c_observe(fn, doc: str, kind=None):
    """The compensator protocol's ``observe(u, w)`` of a component, calling the C function
    ``fn(struct, u, w, NULL)`` (no trace record).

    Parameters
    ----------
    fn : cffi function
        The C ``*_observe`` (``(T *, double u, double w, trace *)``).
    doc : str
        The method's docstring (units, what it returns).
    kind : callable or None
        Conversion of the C return value (``bool``); default None: the method returns None.

    Returns
    -------
    function
        ``observe(self, u, w)``: ``u`` the applied torque (N·m), ``w`` the measured velocity (rad/s).
    """
    def observe(self, u: float, w: float):
        r = fn(self._c, float(u), float(w), self._ffi.NULL)
        return None if kind is None else kind(r)

    observe.__doc__ = doc
    return observe


def ops_table(lib, doc: str = "Pointer to the C ops table :attr:`C_OPS` (``aff_compensator_ops *``).") -> property:
    """A public attribute ``ops`` of a compensator component: the pointer to the C ops table (``aff_compensator_ops``)
    that its class attribute ``C_OPS`` names: the functions the closed-loop engine calls with
    :attr:`Component.cdata`.

    Parameters
    ----------
    lib : cffi library
        The extension module that holds the table (e.g. ``controllers._cctl.lib``).
    doc : str
        The attribute's docstring.

    Returns
    -------
    property
        Read-only; reads ``_ffi.addressof(getattr(lib, C_OPS))`` (a ``aff_compensator_ops *``).
    """
    return property(lambda self: self._ffi.addressof(getattr(lib, self.C_OPS)), doc=doc)


#: (ffi, C struct name) -> {field: float, int or None}: the kind of each field of a settings struct (a C
#: ``double``/``float``, another primitive, or a struct), read once from the cffi type (constant per process).
_FIELD_KINDS: dict = {}


#: The key of :func:`_field_kinds`' entry that holds the cffi pointer type of the struct (no C field's name).
_POINTER = " pointer"


def _field_kinds(ffi, ctype: str) -> dict:
    """The fields of the C struct ``ctype`` (cffi ``ffi``) -> ``float`` (a C ``double`` or ``float``), ``int``
    (another primitive: an integer or a flag) or None (a struct or an array), and :data:`_POINTER` -> the cffi type
    ``ctype *``; cached in memory per process (types, constant)."""
    key = (ffi, ctype)
    kinds = _FIELD_KINDS.get(key)
    if kinds is None:
        ptr = ffi.typeof(f"{ctype} *")
        kinds = {_POINTER: ptr}
        for name, f in ptr.item.fields:
            kinds[name] = (float if f.type.cname in ("double", "float") else
                           int if f.type.kind == "primitive" else None)
        _FIELD_KINDS[key] = kinds
    return kinds


#: A cffi pointer type -> the C name of the struct it points to (constant per process).
_CNAMES: dict = {}
#: A part's dotted C field -> its names (constant per process).
_PATHS: dict = {}


#: A class with :meth:`Component.unbuilt` -> its C ``aff_X_check_config`` (constant per process).
_CHECKS: dict = {}


def _path(field: str) -> tuple:
    """The names of the dotted C field ``field`` (``"res.sw"`` -> ``("res", "sw")``), cached in :data:`_PATHS`."""
    names = _PATHS[field] = tuple(field.split("."))
    return names


class Component:
    """Base class: owns (or points into) one C struct of the component's type.

    Subclasses set two class attributes, ``_ffi`` (the cffi ``FFI`` of their
    package's extension module) and ``_ctype`` (the struct's C name, e.g.
    ``"aff_gate"``), make their struct in ``__init__`` (:meth:`_configure_from`,
    or :meth:`_new_struct` and their C init) and expose the fields of
    :attr:`cdata` as attributes (:func:`struct_fields`, :func:`struct_field`). A composite names its
    parts in ``_parts`` (:meth:`_attach` points them into its struct), a
    component its repr's fields in ``_repr_fields``.

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
    #: The parts embedded in the struct: attribute -> its C field (a dotted path for a nested one), pointed there by
    #: :meth:`_attached` (an attribute that is None is skipped).
    _parts: dict = {}
    #: The attributes :func:`repr` shows as ``name=value`` (a dotted path shows as its last name); empty: the
    #: default ``object`` repr.
    _repr_fields: tuple = ()
    #: The bytes and the C type name of the configuration struct the component was configured from (None: none).
    _config_bytes: bytes | None = None
    _config_ctype: str = ""
    #: What keeps the memory of the struct alive where it is a part of another's: the cffi struct that owns it, or
    #: an owner that is no component (held as it is); None: the component owns its struct.
    _memory = None
    #: A weak reference to the composite whose struct holds this component's (None: none). Weak, and the memory
    #: held by its cffi owner: a part and its composite form no reference cycle, so they are freed as soon as they
    #: are dropped, not by a later pass of the cyclic garbage collector.
    _holder = None
    #: The checked settings (cffi ``aff_X_config *``) of an object made by :meth:`unbuilt`, whose struct its
    #: composite's C init configures from them; None once the object has its struct (its own or a composite's field).
    _pending = None
    #: The cffi library of the class's C functions (``aff_X_check_config``, ``aff_error_message``): set by a class
    #: that offers :meth:`unbuilt`.
    _lib = None

    @classmethod
    def unbuilt(cls, *args, **kwargs):
        """An object of this class to be given as a part to a composite's constructor, whose C init makes its struct:
        the constructor's arguments checked as the constructor checks them (the same errors), its settings kept, no
        struct of its own made, configured and then copied into the composite's.

        The composite's C init configures the part's field of its struct from the part's settings (:attr:`config`);
        the composite then points the part there and completes it (:meth:`_attached`), the same bytes as a part made
        by the constructor and copied in. Until then the object has no struct: give it to a composite that takes
        its part's settings (``RobustAdaptiveFeedforward`` its estimator, ``AdaptiveCompensator`` its parts), nothing
        else.

        Parameters
        ----------
        *args, **kwargs
            The constructor's.

        Returns
        -------
        Component
            The object without its struct (:attr:`config` the checked settings).

        Raises
        ------
        ParameterError, SettingTypeError
            The constructor's errors, with its messages; TypeError for a class without the two-step constructor.
        """
        check = _CHECKS.get(cls)
        if check is None:
            if cls._lib is None or "_plan" not in vars(cls):
                raise TypeError(f"{cls.__name__} is made by its constructor only (no unbuilt form)")
            check = _CHECKS[cls] = getattr(cls._lib, f"{cls._ctype}_check_config")
        part = cls.__new__(cls)
        cfg, names = part._plan(*args, **kwargs)
        code = check(cfg)  # the checks of the constructor's C init
        if code != 0:
            part._refuse(code, cls._lib.aff_error_message, names)
        part._pending = cfg
        part._keep(cfg)
        return part

    def _place(self, ptr, owner: "Component") -> None:
        """Point an :meth:`unbuilt` object at ``ptr``, the field of ``owner``'s struct that ``owner``'s C init has
        just configured from this object's settings, and complete it (:meth:`_built`)."""
        self._c = ptr
        self._memory = owner._c if owner._memory is None else owner._memory
        self._holder = weakref.ref(owner)
        self._pending = None
        self._built()

    def _built(self) -> None:
        """Complete the object once its struct is configured (the constructor's steps after the C init; a class with
        :meth:`unbuilt` defines it, with its ``_plan``)."""

    def _new_struct(self) -> None:
        """Allocate a zeroed struct of type ``_ctype`` owned by this object."""
        self._c = self._ffi.new(f"{self._ctype} *")
        self._memory = self._holder = None

    def _use(self, ptr, owner, *, moved: bool = False) -> None:
        """Use the struct at ``ptr`` (a field of ``owner``'s struct, its memory kept alive here) from now on, after
        copying the current values into it (unless ``moved``: they are there already, the part of a composite whose
        whole struct was copied); then :meth:`_attached` re-points the parts (a composite's), while the old struct
        is still alive (their old pointers point into it)."""
        old, old_memory = self._c, self._memory  # noqa: F841 - alive until the parts have moved along
        if not moved:
            ptr[0] = old[0]
        self._c = ptr
        if isinstance(owner, Component):
            self._memory = owner._c if owner._memory is None else owner._memory
            self._holder = weakref.ref(owner)
        else:
            self._memory, self._holder = owner, None
        if self._parts or type(self)._attached is not Component._attached:  # a leaf of the base class: nothing
            self._attached()

    @property
    def cdata(self):
        """Pointer to the component's C struct (cffi); a ParameterError for an :meth:`unbuilt` object that no
        composite has made yet."""
        if self._pending is not None:
            raise ParameterError(f"{type(self).__name__}.unbuilt(...) has no struct of its own: give it to a composite "
                                 "that makes it from its settings, or use the constructor")
        return self._c

    @classmethod
    def _in_place(cls, owner: "Component", field: str, cfg):
        """A part over the struct ``field`` (a dotted path) of ``owner``'s struct, which ``owner``'s C init has
        configured from the settings ``cfg`` (cffi ``aff_X_config *`` or struct, kept as its :attr:`config`): no
        struct of its own made, checked and copied in. For a class whose objects hold nothing besides the struct
        (e.g. a gate), or whose caller sets the rest (``cfg`` None: the caller keeps the settings too); the
        composite then :meth:`_attach` es it like any part."""
        part = cls.__new__(cls)
        part._c = owner._ffi.addressof(owner._c, *_PATHS.get(field) or _path(field))
        part._memory = owner._c if owner._memory is None else owner._memory
        part._holder = weakref.ref(owner)
        if cfg is not None:  # None: the caller keeps the settings (:meth:`_keep`)
            part._config_bytes = bytes(part._ffi.buffer(cfg))
            part._config_ctype = f"{cls._ctype}_config"
        return part

    def _settings(self, ctype: str, defaults, fields: dict, *, counts: tuple = ()):
        """New settings ``ctype`` (a C config struct, cffi pointer): the C ``defaults`` (e.g.
        ``lib.aff_gate_default_config()``), then the ``fields`` given (name -> value; a struct field takes a dict or a
        struct).

        Only the type of a value is checked here (a C ``double`` takes a real number, not a bool; an integer field an
        integer or a flag's bool, a field named in ``counts`` an integer and not a bool); its range is the C
        ``aff_X_init``'s to check (:meth:`_configure`), the one validator of each field.

        Raises
        ------
        SettingTypeError
            A value of the wrong type (a ParameterError and a TypeError), naming the class and the field.
        """
        kinds = _field_kinds(self._ffi, ctype)
        cfg = self._ffi.new(kinds[_POINTER], defaults)
        for k, v in fields.items():
            kind = kinds[k]
            t = type(v)
            if t is kind:  # the common cases: a float for a C double, an int for an integer (never a bool)
                pass
            elif kind is float:
                if t is not float:  # a float as it is (float(v) is v's value); then an int
                    if t is not int and (not isinstance(v, (Real, np.floating, np.integer))
                                         or isinstance(v, (bool, np.bool_))):
                        raise SettingTypeError(f"{type(self).__name__}: {k} must be a real number, got {v!r} "
                                               f"({type(v).__name__})")
                    v = float(v)
            elif kind is int and t is not int:  # an int as it is (never a bool: type(True) is bool); a flag's bool
                if t is bool and k not in counts:
                    v = int(v)
                else:
                    if not isinstance(v, (Integral, np.integer, np.bool_)) or (
                            k in counts and isinstance(v, (bool, np.bool_))):
                        raise SettingTypeError(f"{type(self).__name__}: {k} must be an integer, got {v!r}")
                    v = int(v)
            setattr(cfg, k, v)
        return cfg

    def _configure_from(self, lib, fields: dict, *, counts: tuple = ()) -> None:
        """Configure the struct ``_ctype`` (``"aff_X"``) from its C defaults ``aff_X_default_config()`` with
        ``fields`` (:meth:`_settings`), checked by ``aff_X_init`` (:meth:`_configure`, messages
        ``lib.aff_error_message``).

        Parameters
        ----------
        lib : cffi library
            The extension module of the package that owns the struct.
        fields : dict
            C field -> value, the settings given.
        counts : tuple of str, keyword-only
            The fields that take an integer and not a bool.

        Raises
        ------
        SettingTypeError, ParameterError
            As :meth:`_settings` and :meth:`_configure`.
        """
        self._configure(getattr(lib, f"{self._ctype}_init"), self._settings_from(lib, fields, counts=counts),
                        lib.aff_error_message)

    def _settings_from(self, lib, fields: dict, *, counts: tuple = ()):
        """:meth:`_configure_from`'s settings: the C defaults ``aff_X_default_config()`` with ``fields``
        (:meth:`_settings`), not yet checked by C."""
        return self._settings(f"{self._ctype}_config", getattr(lib, f"{self._ctype}_default_config")(), fields,
                              counts=counts)

    def _configure(self, init, cfg, message, *, names: dict | None = None, keep: bool = True) -> None:
        """Allocate the struct and configure it from the settings ``cfg`` by the C ``init``, which checks every field
        and computes the derived ones; keep a copy of ``cfg`` (:attr:`config`) unless ``keep`` is False.

        Parameters
        ----------
        init : callable
            ``init(struct pointer, cfg) -> int``, a C ``aff_error aff_X_init(aff_X *, const aff_X_config *)``.
        cfg : cffi pointer
            The settings, e.g. ``ffi.new("aff_gate_config *", {...})``.
        message : callable
            ``message(code) -> char *``: the C ``aff_error_message`` (a sentence naming the field, its unit and
            range).
        names : dict, keyword-only
            Error code -> the Python argument, where it is not the field the sentence names.
        keep : bool, keyword-only
            Keep ``cfg`` as :attr:`config`.

        Raises
        ------
        ParameterError
            ``init`` refused a field: the class, the sentence and, from ``names``, the argument.
        """
        self._new_struct()
        code = int(init(self._c, cfg))
        if code != 0:
            self._refuse(code, message, names)
        if keep:
            self._keep(cfg)

    def _refuse(self, code: int, message, names: dict | None):
        """Raise the ParameterError of the C error ``code``: the class, the sentence ``message(code)`` and, from
        ``names`` (code -> argument), the argument."""
        arg = (names or {}).get(code)
        raise ParameterError(f"{type(self).__name__}: {self._ffi.string(message(code)).decode()}"
                             + (f" (argument {arg})" if arg else ""))

    def _keep(self, cfg) -> None:
        """Keep a copy of the settings ``cfg`` (cffi pointer) as :attr:`config`."""
        self._config_bytes = bytes(self._ffi.buffer(cfg))
        t = self._ffi.typeof(cfg)
        name = _CNAMES.get(t)
        if name is None:
            name = _CNAMES[t] = t.item.cname.replace("struct ", "")
        self._config_ctype = name

    @property
    def config(self):
        """A copy of the settings the component was configured from (cffi ``aff_X_config *``, the C struct of
        ``aff_X_init``; a composite's holds its parts'), or None for a component without one."""
        if self._config_bytes is None:
            return None
        c = self._ffi.new(_field_kinds(self._ffi, self._config_ctype)[_POINTER])
        self._ffi.buffer(c)[:] = self._config_bytes
        return c

    def struct_bytes(self) -> bytes:
        """The struct's bytes (a snapshot of configuration and state)."""
        return bytes(self._ffi.buffer(self._c))

    def _attach(self, **parts) -> None:
        """Keep ``parts`` (attribute -> part object) as attributes, then point the parts :attr:`_parts` into this
        component's struct (:meth:`_attached`)."""
        for attr, part in parts.items():
            setattr(self, attr, part)
        self._attached()

    def _attached(self) -> None:
        """Re-point the parts :attr:`_parts` into this component's struct (composites with more to do extend it).

        A part that points into this component's struct already (its holder is this component) moved along with the
        whole struct (:meth:`_use` copied it): it is re-pointed without copying its bytes again; a part of its own
        (new, or unpickled) is copied in; an :meth:`unbuilt` part, whose field this component's C init configured
        from its settings, is pointed there and completed (:meth:`_place`)."""
        for attr, field in self._parts.items():
            part = getattr(self, attr)
            if part is not None:
                ptr = self._ffi.addressof(self._c, *_PATHS.get(field) or _path(field))
                if part._pending is not None:
                    part._place(ptr, self)
                elif part._c == ptr:  # made in place in this struct just now (:meth:`_in_place`): there already
                    continue
                else:
                    part._use(ptr, self, moved=part._holder is not None and part._holder() is self)

    def __repr__(self) -> str:
        if not self._repr_fields:
            return object.__repr__(self)
        shown = []
        for name in self._repr_fields:
            v = self
            for step in name.split("."):
                v = getattr(v, step)
            shown.append(f"{name.rpartition('.')[2]}={v!r}")
        return f"{type(self).__name__}({', '.join(shown)})"

    def __getstate__(self) -> dict:
        d = {k: v for k, v in self.__dict__.items() if k not in ("_c", "_memory", "_holder")}
        d["_cbytes"] = self.struct_bytes()
        return d

    def __setstate__(self, d: dict) -> None:
        d = dict(d)
        raw = d.pop("_cbytes")
        self.__dict__.update(d)
        self._new_struct()
        self._ffi.buffer(self._c)[:] = raw
        self._attached()
