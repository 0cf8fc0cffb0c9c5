"""The result protocol shared by all layers: strict-JSON dicts and axes for ``plot(ax=None)``.

Every result object of the package offers

* ``to_dict()`` -> dict that ``json.dumps(d, allow_nan=False)`` accepts: SI units,
  ``None`` where a number is NaN or infinite, plain Python types only;
* ``summary()`` -> str, a few human-readable lines;
* ``plot(ax=None)`` -> matplotlib ``Axes``, where a figure helps (matplotlib is
  imported inside ``plot``, never when the module is imported).

This module holds the helpers those methods share: :func:`json_safe` (the
conversion to strict JSON), :func:`to_json` and :func:`axes_or_new`. It imports
only the standard library, numpy and :mod:`plant.errors`, so every layer (``plant``, ``adaptive_ff``,
``controllers``) may use it.
"""

from __future__ import annotations

import dataclasses
import enum
import json
import math
from collections.abc import Mapping
from pathlib import PurePath

import numpy as np

from plant.errors import check_optional

__all__ = ["json_safe", "to_json", "axes_or_new"]


def json_safe(obj):
    """Convert ``obj`` recursively into plain, strict-JSON Python values.

    Parameters
    ----------
    obj : object
        ``None``, bool, int, float, str; numpy scalars and arrays (any shape);
        mappings (keys become ``str``); lists, tuples, sets (sets sorted);
        ``pathlib`` paths (``str``); enums (their value); objects with a
        ``to_dict()`` method (its result, converted); dataclass instances
        (``{field: value}``, converted).

    Returns
    -------
    None, bool, int, float, str, list or dict
        The same content with every NaN or infinite float replaced by ``None``,
        numpy types replaced by Python ones and arrays by nested lists, so that
        ``json.dumps(result, allow_nan=False)`` succeeds (RFC 8259 has no NaN
        or infinity).

    Raises
    ------
    TypeError
        ``obj`` (or something inside it) is of none of the types above, e.g. a
        python-control transfer function or a matplotlib figure; the message
        names the type. Complex numbers are rejected too (no JSON form).

    Notes
    -----
    The order of mapping keys is kept. Booleans stay booleans (checked before
    integers). An object's ``to_dict()`` is preferred over its dataclass fields,
    so ``to_dict`` must not call ``json_safe(self)`` (use
    ``json_safe(dataclasses.asdict(self))`` or an explicit dict). Source:
    RFC 8259, Sec. 6 (numbers in JSON are finite).
    """
    t = type(obj)
    if t is float:  # the common cases first, by exact type (a subclass takes the checks below)
        return obj if math.isfinite(obj) else None
    if t is dict:
        return {k if type(k) is str else str(k): json_safe(v) for k, v in obj.items()}
    if obj is None or t is str or t is int or isinstance(obj, (bool, str)):
        return obj
    if isinstance(obj, (int, np.integer)) and not isinstance(obj, np.bool_):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, (float, np.floating)):
        x = float(obj)
        return x if math.isfinite(x) else None
    if isinstance(obj, np.ndarray):
        if obj.dtype.kind not in "biuf":
            raise TypeError(f"json_safe: arrays of dtype {obj.dtype} have no JSON form")
        return [json_safe(x) for x in obj.tolist()] if obj.ndim else json_safe(obj.item())
    if isinstance(obj, Mapping):
        return {str(k): json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(x) for x in obj]
    if isinstance(obj, (set, frozenset)):
        return [json_safe(x) for x in sorted(obj)]
    if isinstance(obj, PurePath):
        return str(obj)
    if isinstance(obj, enum.Enum):
        return json_safe(obj.value)
    to_dict = getattr(obj, "to_dict", None)
    if callable(to_dict):
        return json_safe(to_dict())
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: json_safe(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    raise TypeError(f"json_safe: no JSON form for {type(obj).__module__}.{type(obj).__qualname__}")


def to_json(obj, **kwargs) -> str:
    """``json.dumps(json_safe(obj), allow_nan=False, **kwargs)``: strict JSON text of a result.

    Parameters
    ----------
    obj : object
        Anything :func:`json_safe` accepts.
    **kwargs
        Passed to :func:`json.dumps` (e.g. ``indent=2``); ``allow_nan`` must not be given.

    Returns
    -------
    str

    Raises
    ------
    TypeError
        See :func:`json_safe`; also if ``allow_nan`` is passed.
    """
    if "allow_nan" in kwargs:
        raise TypeError("to_json writes strict JSON; do not pass allow_nan")
    return json.dumps(json_safe(obj), allow_nan=False, **kwargs)


class PhysicalParams:
    """Mixin: the physical parameters J, Fc, Fs, sigma, tau of a result as attributes read from its ``params``.

    The class that mixes it in holds ``params``, a mapping with the keys ``"J"``, ``"Fc"``, ``"Fs"``, ``"sigma"``,
    ``"tau"`` (the field symbols of eqs. 1-3; units kg·m², N·m, N·m, N·m·s/rad, s). A missing key raises KeyError.
    """

    __slots__ = ()

    J = property(lambda self: self.params["J"], doc='Inertia (kg·m²), ``params["J"]``.')
    Fc = property(lambda self: self.params["Fc"], doc='Coulomb level (N·m), ``params["Fc"]``.')
    Fs = property(lambda self: self.params["Fs"], doc='Stiction level (N·m), ``params["Fs"]``.')
    sigma = property(lambda self: self.params["sigma"], doc='Viscous coefficient (N·m·s/rad), ``params["sigma"]``.')
    tau = property(lambda self: self.params["tau"], doc='Friction lag (s), ``params["tau"]``.')


def axes_or_new(ax=None, *, figsize: tuple[float, float] = (7.0, 4.0)):
    """The axes a result's ``plot(ax=None)`` draws on: ``ax`` itself, or the axes of a new figure.

    Parameters
    ----------
    ax : matplotlib.axes.Axes, optional
        Axes to draw on. None: a new ``matplotlib.figure.Figure`` (not managed by
        pyplot, so nothing is shown or kept open) with one axes.
    figsize : (float, float), keyword-only
        Size in inches of the new figure.

    Returns
    -------
    matplotlib.axes.Axes
        ``ax``, or the new axes (its figure is ``ax.figure``).

    Raises
    ------
    TypeError
        ``ax`` is neither None nor a matplotlib Axes.
    """
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    if check_optional("ax", ax, Axes, what="a matplotlib Axes", error=TypeError) is None:
        return Figure(figsize=figsize, layout="constrained").subplots()
    return ax
