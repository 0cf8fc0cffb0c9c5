"""Bring your own compensator: a Python object with ``compensate`` and ``observe`` runs in the engine's loop.

The protocol (the Python form of ``adaptive_ff/csrc/aff_compensator.h``), called once per controller period
``Tc`` in this order::

    u_ff = comp.compensate(w_meas, w_ref)   # friction torque to add (N·m), a finite float
    u    = PI(w_ref - w_meas) + u_ff, saturated (the engine)
    comp.observe(u, w_meas)                 # learn from the applied torque and the raw sample

``compensate`` receives the controller's measurement (after the loop's sensor gate; rad/s) and the velocity
reference (rad/s); ``observe`` the applied, saturated torque (N·m) and the raw sensor sample (rad/s; may be
NaN or a spike where faults are injected: gate it yourself). Optional: ``estimate`` (an attribute or a
method returning a :class:`adaptive_ff.identification.regression.FrictionEstimate`, reported in the
result) and ``info()`` (a dict merged into the result's ``info``). The package's own compensators
(:class:`adaptive_ff.RobustAdaptiveFeedforward`, ...) follow the same protocol.

:class:`UserCompensator` wraps such an object for the engine
(:meth:`controllers.simulation.engine.EngineRun.set_compensator`): the engine's C loop calls it through an ops
table whose functions call back into Python (cffi ``extern "Python"``; ``controllers/_cbuild.py``), so a
user's compensator runs in the same loop, with the same plant, sensor, PI and metrics, as the built-in
modes; each call costs a Python call (docs/benchmarks/perf.md). An exception in the user's code, a ``u_ff``
that is not a real number (a string, None, an array) or a non-finite one ends the run at that period and is
raised as :class:`CompensatorError` after it. A :class:`BaseException` that is not an :class:`Exception`
(``KeyboardInterrupt`` from Ctrl-C, ``SystemExit``, ``GeneratorExit``) ends the run at once as well and is raised
as it is after it: an interrupted run gives no result.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

from controllers._cctl import ffi, lib
from plant.errors import FrictionError, ParameterError

__all__ = ["UserCompensator", "CompensatorError", "CompensatorContext", "is_user_compensator"]


class CompensatorError(FrictionError, RuntimeError):
    """A user's compensator raised, or returned a non-finite torque; names the compensator and the period."""


def is_user_compensator(obj) -> bool:
    """True for an object with callable ``compensate`` and ``observe`` and no C struct of its own (``C_OPS``)."""
    return (getattr(obj, "C_OPS", None) is None and callable(getattr(obj, "compensate", None))
            and callable(getattr(obj, "observe", None)))


class UserCompensator:
    """A user's Python compensator, ready for the engine.

    Parameters
    ----------
    obj : object
        Has ``compensate(w_meas, w_ref) -> float`` and ``observe(u, w_meas)`` (module docstring).
    name : str, keyword-only, optional
        The name it appears under in results and tables; default ``obj.MODE``, else ``obj.name``, else its
        class name.

    Attributes
    ----------
    obj : object
        The wrapped object (its state advances in place during a run).
    name : str
        Its name.
    n_calls : int
        Periods it was called for (``compensate`` and ``observe`` once each).
    error : CompensatorError, BaseException or None
        The first failure of the run, if any: a CompensatorError, or the interrupt (``KeyboardInterrupt``,
        ``SystemExit``, ``GeneratorExit``) that ended it.

    Raises
    ------
    ParameterError
        ``obj`` lacks the protocol, or the name is empty.
    """

    C_OPS = None  # a Python object: the engine calls it back (set_compensator)
    n_theta = 0

    def __init__(self, obj, *, name: str | None = None):
        if not is_user_compensator(obj):
            raise ParameterError(f"compensator must have callable compensate(w_meas, w_ref) and observe(u, w_meas) "
                                 f"methods, got {type(obj).__name__}")
        if name is None:
            name = getattr(obj, "MODE", None) or getattr(obj, "name", None) or type(obj).__name__
        if not isinstance(name, str) or not name.strip():
            raise ParameterError(f"name must be a non-empty string, got {name!r}")
        self.obj = obj
        self.name = name
        self.n_calls = 0
        self.error: BaseException | None = None
        self._handle = ffi.new_handle(self)
        self._name_c = ffi.new("char[]", name.encode())
        self._ops = ffi.new("aff_compensator_ops *", {"name": self._name_c, "compensate": lib.ctl_py_compensate,
                                                      "observe": lib.ctl_py_observe})

    @property
    def MODE(self) -> str:
        """The name results carry as their mode."""
        return self.name

    @property
    def ops(self):
        """The ops table (``aff_compensator_ops *``) whose functions call this object."""
        return self._ops

    @property
    def handle(self):
        """The ``void *`` the engine passes back to the callbacks (kept alive by this object)."""
        return self._handle

    @property
    def estimate(self):
        """The wrapped object's ``estimate`` (attribute, or the result of calling it), else None."""
        est = getattr(self.obj, "estimate", None)
        return est() if callable(est) else est

    def info(self) -> dict:
        """The wrapped object's ``info()`` (if any) plus ``user_compensator`` (its name) and ``n_calls``."""
        extra = self.obj.info() if callable(getattr(self.obj, "info", None)) else {}
        return {**dict(extra), "user_compensator": self.name, "n_calls": self.n_calls}

    def fail(self, where: str, exc: BaseException | None, detail: str = "") -> None:
        """Record the first failure (later ones are consequences of the first): an interrupt (a BaseException that
        is not an Exception) as it is, anything else as a :class:`CompensatorError` naming ``where``."""
        if self.error is None and exc is not None and not isinstance(exc, Exception):
            self.error = exc
        elif self.error is None:
            self.error = CompensatorError(f"compensator {self.name!r}: {where} failed at period {self.n_calls} "
                                          f"(call {self.n_calls + 1}){': ' + detail if detail else ''}"
                                          f"{': ' + repr(exc) if exc is not None else ''}")
            self.error.__cause__ = exc

    def raise_error(self) -> None:
        """Raise the recorded failure, if any (called by the loop after the engine returns)."""
        if self.error is not None:
            raise self.error


def _real(v) -> bool:
    """Whether ``v`` is a real number (int, float, numpy scalar or 0-d array of a real dtype; not a bool)."""
    if isinstance(v, bool):
        return False
    if isinstance(v, numbers.Real):
        return True
    return getattr(v, "shape", None) == () and getattr(getattr(v, "dtype", None), "kind", "") in "fiu"


def _on_callback_error(exc_type, exc_value, tb):
    """cffi's ``onerror`` of the callbacks: an exception that escaped their own ``try`` (an interrupt that landed
    between two of their statements) is recorded on the compensator, so that it ends the run and is raised after
    it, instead of being printed and dropped by cffi."""
    handle = tb.tb_frame.f_locals.get("handle") if tb is not None else None
    if handle is not None:
        ffi.from_handle(handle).fail("callback", exc_value)


@ffi.def_extern(error=math.nan, onerror=_on_callback_error)
def ctl_py_compensate(handle, w_ctrl, w_meas, w_ref):
    """Engine callback: ``u_ff`` of the user's compensator for this period (NaN after a failure: the run ends)."""
    c = ffi.from_handle(handle)
    if c.error is not None:
        return math.nan
    try:
        raw = c.obj.compensate(w_ctrl, w_ref)
        if not _real(raw):
            c.fail("compensate", None, f"returned {raw!r} of type {type(raw).__name__} (w_meas={w_ctrl!r}, "
                                       f"w_ref={w_ref!r}); u_ff must be a real number (N·m)")
            return math.nan
        v = float(raw)
    except BaseException as exc:  # noqa: BLE001 -- any failure of user code ends the run and is raised after it
        c.fail("compensate", exc)
        return math.nan
    if not math.isfinite(v):
        c.fail("compensate", None, f"returned {v!r} (w_meas={w_ctrl!r}, w_ref={w_ref!r}); u_ff must be finite")
        return math.nan
    return v


@ffi.def_extern(error=0, onerror=_on_callback_error)
def ctl_py_observe(handle, u, w_meas, theta_out):
    """Engine callback: the user's compensator observes ``(u, w_meas)``; reports no parameter vector (0). After a
    failure the next ``compensate`` returns NaN: the run ends there."""
    c = ffi.from_handle(handle)
    try:
        if c.error is None:
            c.obj.observe(u, w_meas)
    except BaseException as exc:  # noqa: BLE001
        c.fail("observe", exc)
    c.n_calls += 1
    return 0


@dataclass(frozen=True)
class CompensatorContext:
    """What a comparison gives a user's compensator factory: the loop's design and the pre-fit, never the true
    plant (:func:`controllers.experiments.compare.compare`, ``compensators={name: factory}``; a factory is called
    as ``factory(context)`` and returns an object of the protocol of this module).

    Attributes
    ----------
    J : float
        Design inertia (kg·m²): ``J_design``, or the joint's data-sheet inertia.
    Tc, Ts : float
        Controller period and the package's estimator update period (s).
    Kp, Ki : float
        The PI's gains (N·m·s/rad, N·m/rad).
    u_max, ff_max : float
        Actuator limit and the feedforward's bound (N·m).
    noise_std : float
        Velocity-measurement noise the comparison simulates (rad/s).
    prefit : StribeckFit or None
        The Stribeck pre-fit of the quasi-static runs (``Fc``, ``Fs``, ``Vs``, ``delta``, ``sigma``; paper
        Sec. V-C), None where the comparison made none.
    """

    J: float
    Tc: float
    Ts: float
    Kp: float
    Ki: float
    u_max: float
    ff_max: float
    noise_std: float
    prefit: object = None
