"""Exception types shared by the whole package, and small input validators.

The package's errors subclass the built-in ``ValueError`` / ``TypeError`` so
callers can catch either the precise type or the built-in one. ``plant`` is the
bottom layer of the package (``plant`` <- ``adaptive_ff`` <- ``controllers``),
so the exceptions live here and are re-exported by :mod:`adaptive_ff`.
"""

from __future__ import annotations

import dataclasses
import errno
import functools
import math
import os
import reprlib
import stat
from numbers import Real

import numpy as np

__all__ = [
    "FrictionError",
    "ParameterError",
    "SignalError",
    "ExcitationError",
    "check_positive",
    "check_positive_or_inf",
    "check_nonnegative",
    "check_finite_scalar",
    "check_signal",
    "check_time",
    "check_multiple",
    "check_not_special",
    "check_optional",
    "check_optional_number",
    "known_fields",
    "UnknownFieldError",
]


class FrictionError(Exception):
    """Base class of all errors raised by this package."""


class ParameterError(FrictionError, ValueError):
    """A hyperparameter or physical parameter is out of its valid range."""


class SignalError(FrictionError, ValueError):
    """A signal (time series) has the wrong shape, non-finite values, or bad time stamps."""


class ExcitationError(FrictionError, ValueError):
    """The data do not excite the model enough to identify its parameters."""


def check_finite_scalar(name: str, value) -> float:
    """Return ``value`` as a float, or raise if it is not a finite real scalar.

    Raises
    ------
    TypeError
        If ``value`` is not a real number (bool is rejected too).
    ParameterError
        If ``value`` is NaN or infinite.
    """
    if type(value) is not float:  # a float as it is (the common case; float(value) is its value)
        if isinstance(value, bool) or not isinstance(value, (Real, np.floating, np.integer)):
            raise TypeError(f"{name} must be a real number, got {value!r} ({type(value).__name__})")
        value = float(value)
    if not math.isfinite(value):
        raise ParameterError(f"{name} must be finite, got {value!r}")
    return value


def check_optional(name: str, value, cls, *, what: str | None = None, error: type = None):
    """Return ``value`` if it is None or an instance of ``cls``; else raise naming ``name`` and the value's type.

    The one check of a knob that takes an object or None (``check_optional("start", start, FeedforwardStart)``).

    Parameters
    ----------
    name : str
        The argument's name, as the caller spells it.
    value : object
        The value given.
    cls : type or tuple of types
        The accepted type(s).
    what : str, optional
        How the message names the accepted values (default ``"a <cls name>"``).
    error : type, optional
        The exception class (default :class:`ParameterError`).

    Raises
    ------
    ParameterError
        (or ``error``) ``value`` is neither None nor a ``cls``: "<name> must be <what> or None, got <type> <repr>"
        (the repr shortened by :mod:`reprlib`).
    """
    if value is not None and not isinstance(value, cls):
        if what is None:
            names = [c.__name__ for c in (cls if isinstance(cls, tuple) else (cls,))]
            what = "a " + " or ".join(names)
        raise (error or ParameterError)(f"{name} must be {what} or None, got {type(value).__name__} "
                                        f"{reprlib.repr(value)}")
    return value


def check_optional_number(name: str, value, *, integer: bool = False, low: float | None = None,
                          high: float | None = None, strict: bool = False, unit: str = "", none: str = ""):
    """Return None for None, else ``value`` as a finite number (an int with ``integer``) in its range; else raise
    naming ``name`` and the value.

    The one check of a knob that takes a number in a range or None (``check_optional_number("f_scale", f_scale,
    low=0.0, strict=True)``: a robust scale > 0, None for the default); :func:`check_optional` checks the type of
    an object-or-None knob.

    Parameters
    ----------
    name, value : str, object
        The argument's name (as the caller spells it) and the value given.
    integer : bool, keyword-only
        Take an integer (a Python or numpy integer, not a bool) rather than a real number; default False.
    low, high : float or None, keyword-only
        The range's ends (in the value's unit); None (default): unbounded on that side.
    strict : bool, keyword-only
        Refuse the ends themselves (``low < value < high``); default False (``low <= value <= high``).
    unit : str, keyword-only
        The unit the message gives the ends in (``"s"``); default none.
    none : str, keyword-only
        What None means, for the message (``"profiled"``); default not said.

    Returns
    -------
    float, int or None
        None, or the value as a float (an int with ``integer``).

    Raises
    ------
    TypeError
        A number expected and ``value`` is no real number (a bool, a string): as :func:`check_finite_scalar`.
    ParameterError
        ``value`` is NaN or infinite, out of the range, or (``integer``) no integer: "<name> must be [an integer]
        <range> (or None[: <none>]), got <value>" ("a finite number" for a number without a range).
    """
    if value is None:
        return None
    ops = ("> ", "< ") if strict else (">= ", "<= ")
    ends = [op + f"{end:g}" + (f" {unit}" if unit else "") for op, end in zip(ops, (low, high)) if end is not None]
    kind = "an integer" if integer else "" if ends else "a finite number"
    what = (f"{name} must be {' '.join([kind] * bool(kind) + [' and '.join(ends)] * bool(ends))} "
            f"(or None{f': {none}' if none else ''}), got {value!r}")
    if integer:
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
            raise ParameterError(what)
        x = int(value)
    else:
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (Real, np.floating, np.integer)):
            raise TypeError(f"{what} ({type(value).__name__})")
        x = float(value)
        if not math.isfinite(x):
            raise ParameterError(what)
    below = low is not None and (x <= low if strict else x < low)
    above = high is not None and (x >= high if strict else x > high)
    if below or above:
        raise ParameterError(what)
    return x


class UnknownFieldError(ParameterError, TypeError):
    """A keyword that is no field of a settings class: a :class:`ParameterError` and a TypeError (as Python's own
    unexpected-keyword error), naming the class and the keyword."""


def known_fields(cls: type | None = None, *, hint: str = ""):
    """Class decorator: the dataclass ``cls`` refuses an unknown keyword with :class:`UnknownFieldError` naming it
    (rather than Python's plain TypeError); ``hint`` ends the message (where such a keyword belongs). Returns
    ``cls`` (``known_fields(hint=...)``: the decorator)."""
    if cls is None:
        return functools.partial(known_fields, hint=hint)
    init, own = cls.__init__, None

    @functools.wraps(init)
    def __init__(self, *args, **kwargs):
        nonlocal own
        own = own or {f.name for f in dataclasses.fields(cls) if f.init}
        unknown = sorted(set(kwargs) - own)
        if unknown:
            raise UnknownFieldError(f"{cls.__name__}: {', '.join(map(repr, unknown))} is no field of it (fields: "
                                    f"{', '.join(sorted(own))}){hint}")
        init(self, *args, **kwargs)

    cls.__init__ = __init__
    return cls


def check_positive(name: str, value) -> float:
    """Return ``value`` as a float, or raise :class:`ParameterError` unless it is finite and > 0."""
    value = check_finite_scalar(name, value)
    if value <= 0.0:
        raise ParameterError(f"{name} must be > 0, got {value!r}")
    return value


def check_positive_or_inf(name: str, value) -> float:
    """Return ``value`` as a float, or raise :class:`ParameterError` unless it is > 0 (``inf`` allowed: a bound
    that disables its test); a bool, a string or NaN is refused by name."""
    real = isinstance(value, (Real, np.floating, np.integer)) and not isinstance(value, (bool, np.bool_))
    x = float(value) if real else math.nan
    if not x > 0.0:
        raise ParameterError(f"{name} must be > 0 (inf: no test), got {value!r}")
    return x


def check_nonnegative(name: str, value) -> float:
    """Return ``value`` as a float, or raise :class:`ParameterError` unless it is finite and >= 0."""
    value = check_finite_scalar(name, value)
    if value < 0.0:
        raise ParameterError(f"{name} must be >= 0, got {value!r}")
    return value


def check_signal(name: str, x, *, n: int | None = None, min_len: int = 1) -> np.ndarray:
    """Return ``x`` as a finite 1-D float array, or raise :class:`SignalError`.

    Parameters
    ----------
    name : str
        Argument name quoted in the error message.
    x : array_like, shape (N,) or (N, 1)
        The signal. A column vector is flattened.
    n : int, optional
        Required length.
    min_len : int
        Minimum length.

    Raises
    ------
    SignalError
        Wrong shape or length, or a NaN / infinite value (its index is named).
    """
    try:
        arr = np.asarray(x, dtype=float)
    except (TypeError, ValueError) as exc:
        raise SignalError(f"{name} must be a numeric array: {exc}") from None
    if arr.ndim == 2 and 1 in arr.shape:
        arr = arr.reshape(-1)
    if arr.ndim != 1:
        raise SignalError(f"{name} must be one-dimensional, got shape {np.shape(x)}")
    if n is not None and arr.shape[0] != n:
        raise SignalError(f"{name} must have length {n}, got {arr.shape[0]}")
    if arr.shape[0] < min_len:
        raise SignalError(f"{name} needs at least {min_len} samples, got {arr.shape[0]}")
    bad = ~np.isfinite(arr)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise SignalError(f"{name} has a non-finite value {float(arr[i])!r} at index {i}")
    return arr


def check_time(name: str, t, *, n: int | None = None, min_len: int = 2) -> np.ndarray:
    """Return time stamps ``t`` (s) as a 1-D array, or raise unless strictly increasing.

    Raises
    ------
    SignalError
        Shape/finite problems (see :func:`check_signal`) or a non-increasing
        step; the message names the first offending index and both values.
    """
    arr = check_signal(name, t, n=n, min_len=min_len)
    d = np.diff(arr)
    bad = d <= 0
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise SignalError(
            f"{name} must be strictly increasing; {name}[{i + 1}] = {float(arr[i + 1])!r} "
            f"<= {name}[{i}] = {float(arr[i])!r}"
        )
    return arr


def check_multiple(name: str, value: float, base_name: str, base: float) -> int:
    """Return ``round(value/base)``, or raise unless ``value`` (s) is a positive integer multiple of ``base`` (s).

    Used for sample times that must fall on a controller or integration grid
    (e.g. ``Ts`` on ``Tc``); tolerance 1e-9 relative.

    Raises
    ------
    ParameterError
        ``value`` not > 0, or not a multiple of ``base``; the message quotes both.
    """
    value = check_positive(name, value)
    m = value / base
    if abs(m - round(m)) > 1e-9 * max(1.0, m) or round(m) < 1:
        raise ParameterError(f"{name} = {value!r} s must be a positive multiple of {base_name} = {base!r} s")
    return int(round(m))


def check_not_special(path, what: str, *, error: type = ParameterError) -> None:
    """Refuse a path that exists but is not a regular file, for what it is: a directory, a loop of symbolic
    links, a symbolic link to nothing, a named pipe (FIFO, whose reading would wait for a writer), a device
    (``/dev/zero`` would be read for ever), a socket. A missing path, or one that cannot be examined, is left to
    the caller (its own "not found" or read error).

    Parameters
    ----------
    path : str or os.PathLike
        The path given.
    what : str
        What the file should be, for the message (``"plant file"``, ``"scenario file"``).
    error : type, keyword-only
        The exception raised (default :class:`ParameterError`).

    Raises
    ------
    error
        ``"{path}: is a named pipe (FIFO), not a regular file; expected a {what}"`` and the like.
    """
    try:
        mode = os.stat(path).st_mode
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise error(f"{path}: is a loop of symbolic links, not a regular file; expected a {what}") from None
        if exc.errno == errno.ENOENT and os.path.islink(path):
            raise error(f"{path}: is a symbolic link to {os.readlink(path)!r}, which does not exist; expected a "
                        f"{what}") from None
        return
    if stat.S_ISREG(mode):
        return
    kinds = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a named pipe (FIFO)"),
             (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))
    kind = next((name for test, name in kinds if test(mode)), "not a regular file")
    link = f" (a symbolic link to {os.readlink(path)!r})" if os.path.islink(path) else ""
    raise error(f"{path}: is {kind}{link}, not a regular file; expected a {what}")
