"""Recursive instrumental variables (IV) with forgetting: the estimator of the eq. 4 feedforward in closed loop.

A thin wrapper of the C struct ``aff_ivrls`` (``adaptive_ff/csrc/aff_ivrls.h``): ``theta`` and ``P`` are numpy views
into it, updated in place. The derivation (why least squares on eq. 4 is biased in the velocity loop, why the
delayed regressors are valid instruments) is in ``docs/theory.md``, section "Instrumental variables for eq. 4 in
the closed loop".
"""

from __future__ import annotations

import math

import numpy as np

from adaptive_ff._caff import ffi, lib
from plant.component import Component, struct_field, struct_fields
from plant.errors import ParameterError, SignalError, check_finite_scalar

__all__ = ["RecursiveIV", "IVRLS_NMAX"]

#: Most parameters a :class:`RecursiveIV` holds (``AFF_IVRLS_NMAX`` of ``adaptive_ff/csrc/aff_ivrls.h``).
IVRLS_NMAX = len(ffi.new("aff_ivrls *").theta)


def _row(name: str, x, p: int) -> np.ndarray:
    a = np.ascontiguousarray(x, dtype=float).reshape(-1) if np.ndim(x) else None
    if a is None or a.shape != (p,):
        raise ParameterError(f"{name} must have shape ({p},), got {np.shape(x)}")
    return a


@struct_fields("p", "lam", "P_max", "guard", "n_updates", "n_rejected")
class RecursiveIV(Component):
    """Recursive instrumental-variable estimator with forgetting factor ``lam`` and a covariance bound.

    Parameters
    ----------
    n_params : int
        Number of parameters ``p``, 1 to :data:`IVRLS_NMAX`.
    lam : float, keyword-only
        Forgetting factor in (0, 1]; default 1 (no forgetting).
    P0 : float, keyword-only
        Initial ``P = P0*I`` (> 0); default 1e4, as the RLS.
    P_max : float or None, keyword-only
        Bound on ``trace(P)`` (windup protection, as :class:`adaptive_ff.identification.rls.RecursiveLeastSquares`):
        an update that would exceed it forgets nothing. Default ``p*P0``; ``math.inf``: none.
    guard : bool, keyword-only
        Also refuse an update with ``phi @ P @ z < 0`` (see Notes); default False (the plain recursion).

    Attributes
    ----------
    theta : ndarray, shape (p,)
        Current estimate (a view of the C struct, updated in place: copy it to keep a value).
    P : ndarray, shape (p, p)
        Inverse of the weighted instrument-regressor moment matrix (a view; not symmetric).
    lam, P_max : float
    guard : bool
    n_updates, n_rejected : int
        Accepted updates; refused samples (non-finite, ``s <= 0``, with ``guard`` ``phi @ P @ z < 0``, or an update
        that would overflow), which leave ``theta`` and ``P`` unchanged.

    Raises
    ------
    ParameterError
        ``n_params`` not an integer in 1..:data:`IVRLS_NMAX`, ``lam`` outside (0, 1], ``P0`` or ``P_max`` not > 0,
        ``guard`` not a bool (the message names the argument and its value).

    Notes
    -----
    With regressor ``phi``, instruments ``z`` and output ``y``, per sample (C ``aff_ivrls_step``; Söderström &
    Stoica, *System Identification*, 1989, Ch. 9, recursive IV; Ljung, *System Identification*, 2nd ed., 1999,
    Ch. 11)::

        e = y - phi @ theta,  v = P @ z,  q = P.T @ phi,  s = lam + phi @ P @ z
        theta += v*e/s,       P = (P - outer(v, q)/s)/lam

    which gives, while no update hits ``P_max``, the weighted batch IV estimate ``theta_N = P_N (lam**N
    theta_0/P0 + sum_k lam**(N-k) z_k y_k)`` with ``P_N^-1 = lam**N I/P0 + sum_k lam**(N-k) z_k phi_k^T``.
    ``z = phi`` is the RLS of Ruderman's eqs. 10-13. ``P`` is not symmetric and ``phi @ P @ z`` may be negative
    (never ``phi @ P @ phi`` in the RLS): ``s`` then falls below ``lam`` and the gain ``v/s`` grows without bound as
    ``s -> 0``. An update with ``s <= 0`` is always refused; with ``guard`` every update with ``phi @ P @ z < 0``, so
    that the estimate is the batch IV estimate of the accepted samples (the eq. 4 feedforward uses it: without it
    its estimate made rare excursions, tau 0.37 s or sigma -385, that cost eta; docs/theory.md).
    """

    _ffi = ffi
    _ctype = "aff_ivrls"

    def __init__(self, n_params: int, *, lam: float = 1.0, P0: float = 1e4, P_max: float | None = None,
                 guard: bool = False):
        if isinstance(n_params, bool) or not isinstance(n_params, (int, np.integer)) or not 1 <= n_params <= IVRLS_NMAX:
            raise ParameterError(f"n_params must be an integer in 1..{IVRLS_NMAX}, got {n_params!r}")
        p = int(n_params)
        lam = check_finite_scalar("lam", lam)
        if not 0.0 < lam <= 1.0:
            raise ParameterError(f"lam must be in (0, 1], got {lam!r}")
        P0 = check_finite_scalar("P0", P0)
        if P0 <= 0.0:
            raise ParameterError(f"P0 must be > 0, got {P0!r}")
        P_max = p * P0 if P_max is None else float(P_max)
        if not P_max > 0.0:
            raise ParameterError(f"P_max must be > 0, got {P_max!r}")
        if not isinstance(guard, (bool, np.bool_)):
            raise ParameterError(f"guard must be True or False, got {guard!r}")
        self._new_struct()
        lib.aff_ivrls_init(self._c, p, lam, P_max, P0, int(bool(guard)))

    theta = struct_field("theta", doc="Current estimate, shape (p,) (a view of the C struct).", size="p", view=True)

    P = struct_field("P", doc="``P``, shape (p, p) (a view of the C struct).", size="p", view=True, square=True)

    def __repr__(self) -> str:
        return f"RecursiveIV({self.p}, lam={self.lam!r}, n_updates={self.n_updates})"

    def update(self, phi, z, y: float) -> float:
        """One sample (C ``aff_ivrls_update``).

        Parameters
        ----------
        phi, z : array_like, shape (p,)
            Regressor and instruments.
        y : float
            Output.

        Returns
        -------
        float
            The a-priori error ``y - phi @ theta``.

        Raises
        ------
        ParameterError
            ``phi`` or ``z`` of the wrong shape.
        SignalError
            The sample was refused (non-finite entry, ``s <= 0``, with :attr:`guard` ``phi @ P @ z < 0``, or an
            update that would overflow); the state is unchanged but :attr:`n_rejected`.
        """
        p = self.p
        a, b = _row("phi", phi, p), _row("z", z, p)
        e = lib.aff_ivrls_update(self._c, ffi.from_buffer("double[]", a), ffi.from_buffer("double[]", b), float(y))
        if math.isnan(e):
            raise SignalError(f"RecursiveIV.update refused the sample (phi={a!r}, z={b!r}, y={y!r}): non-finite, "
                              f"s <= 0, phi'P z < 0 with guard, or an update that would overflow")
        return float(e)

    def update_many(self, Phi, Z, Y) -> np.ndarray:
        """A stream of samples in one call (C ``aff_ivrls_update_many``).

        Parameters
        ----------
        Phi, Z : array_like, shape (n, p)
            Regressors and instruments, one row per sample.
        Y : array_like, shape (n,)
            Outputs.

        Returns
        -------
        ndarray, shape (n, p)
            ``theta`` after each sample (a refused row, ``s <= 0``, the guard or overflow, repeats the previous one
            and counts in :attr:`n_rejected`).

        Raises
        ------
        ParameterError
            Shapes that do not match.
        SignalError
            A non-finite entry (its row is named); the state is then unchanged.
        """
        p = self.p
        Phi = np.ascontiguousarray(Phi, dtype=float)
        Z = np.ascontiguousarray(Z, dtype=float)
        Y = np.ascontiguousarray(Y, dtype=float).reshape(-1)
        n = Y.shape[0]
        if Phi.shape != (n, p) or Z.shape != (n, p):
            raise ParameterError(f"Phi and Z must have shape ({n}, {p}), got {Phi.shape} and {Z.shape}")
        hist = np.empty((n, p))
        bad = lib.aff_ivrls_update_many(self._c, ffi.from_buffer("double[]", Phi), ffi.from_buffer("double[]", Z),
                                        ffi.from_buffer("double[]", Y), n,
                                        ffi.from_buffer("double[]", hist, require_writable=True))
        if bad >= 0:
            raise SignalError(f"RecursiveIV.update_many: row {bad} is not finite; nothing was updated")
        return hist
