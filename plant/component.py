"""Runtime components: a thin Python object over a parameter array and a state array that compiled steps advance.

Every piece of the closed loop that runs at the controller rate (friction
model, PI, gate, estimator, RLS, feedforward, peers, metrics) keeps its
configuration in one float64 array ``params`` and everything that changes in
one float64 array ``state``. One compiled (numba) step function over
``(params, state, ...)`` is the only implementation of the component's
equations: the Python methods call it, and so does the closed-loop engine,
which composes components by handing their arrays to their steps (a composite
component lays its parts out as slices of its own arrays, see :meth:`Component.attach`).
The pattern is :class:`adaptive_ff.identification.rls.RecursiveLeastSquares`
(state buffer with public views) and filterpy's small stateful filters
(public ``x``, ``P``).
"""

from __future__ import annotations

import numpy as np

from plant.errors import ParameterError

__all__ = ["Component"]


class Component:
    """Base class: owns ``params`` and ``state`` (1-D, C-contiguous float64 arrays).

    Attributes
    ----------
    params : ndarray, shape (n_params,)
        Configuration read by the compiled step (never written by it).
    state : ndarray, shape (n_state,)
        Mutable state advanced in place by the compiled step.

    Notes
    -----
    Subclasses allocate both arrays with :meth:`_init_arrays` and expose named
    properties that read and write entries of them. A composite component
    (e.g. an estimator with its own gate and RLS) calls :meth:`attach` on each
    part with slices of its own arrays, so the part's Python attributes keep
    showing the live values while the compiled code advances the composite.
    """

    params: np.ndarray
    state: np.ndarray

    def _init_arrays(self, n_params: int, n_state: int) -> None:
        self.params = np.zeros(int(n_params))
        self.state = np.zeros(int(n_state))

    def attach(self, params: np.ndarray, state: np.ndarray) -> None:
        """Copy the current parameters and state into ``params`` and ``state`` and use those arrays from now on.

        Parameters
        ----------
        params, state : ndarray
            1-D C-contiguous float64 arrays (typically slices of a composite's
            arrays) of the same lengths as :attr:`params` and :attr:`state`.

        Raises
        ------
        ParameterError
            Wrong shape, dtype or memory layout.
        """
        for name, new, old in (("params", params, self.params), ("state", state, self.state)):
            if (not isinstance(new, np.ndarray) or new.dtype != np.float64 or new.shape != old.shape
                    or not new.flags.c_contiguous):
                raise ParameterError(f"{name} must be a C-contiguous float64 array of shape {old.shape}")
        params[:] = self.params
        state[:] = self.state
        self.params = params
        self.state = state
        self._attached()

    def _attached(self) -> None:
        """Hook: re-attach parts after :meth:`attach` (composites override it)."""

    def __getstate__(self) -> dict:
        d = dict(self.__dict__)
        d["params"] = np.array(self.params)
        d["state"] = np.array(self.state)
        return d

    def __setstate__(self, d: dict) -> None:
        self.__dict__.update(d)
        self._attached()
