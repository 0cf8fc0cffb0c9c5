"""Recursive least squares with forgetting (eqs. 10-13), windup protection and projection onto parameter bounds.

The arithmetic of one update is C (``adaptive_ff/csrc/aff_rls.c``, ``aff_rls_step``), used by both
:meth:`RecursiveLeastSquares.update` (one sample per call) and :meth:`RecursiveLeastSquares.update_many` (a whole
stream in one call, ``aff_rls_update_many``) and by the C components that embed an RLS. The estimator
(``theta``, ``P``, counters, configuration) is one C struct, ``aff_rls``; ``theta`` and ``P`` are numpy views into
it and are updated in place.
"""

from __future__ import annotations

import math

import numpy as np

from adaptive_ff._caff import ffi, lib
from plant.component import Component, struct_fields
from plant.errors import ParameterError, SignalError

__all__ = ["RecursiveLeastSquares", "FORGETTING", "RLS_NMAX"]

#: Forgetting schemes of :class:`RecursiveLeastSquares`.
FORGETTING = ("exponential", "directional")

#: Most parameters a :class:`RecursiveLeastSquares` holds (``AFF_RLS_NMAX`` of ``adaptive_ff/csrc/aff_rls.h``).
RLS_NMAX = len(ffi.new("aff_rls *").theta)

_SCHEMES = {"exponential": lib.AFF_RLS_EXPONENTIAL, "directional": lib.AFF_RLS_DIRECTIONAL}
_NDARRAY = np.ndarray
_F8 = np.dtype(np.float64)
_VIEWS = ("_theta", "_lower", "_upper", "_D")


@struct_fields("P_max", "n_updates", "n_projected", "n_rejected")
class RecursiveLeastSquares(Component):
    """Recursive least-squares estimator with forgetting factor ``lam``, eqs. 10-13.

    Parameters
    ----------
    n_params : int
        Number of parameters ``p``, 1 to :data:`RLS_NMAX` (the C struct's capacity, ``AFF_RLS_NMAX``).
    lam : float or array_like, shape (p,), keyword-only
        Forgetting factor in (0, 1]; 1 = no forgetting. The paper uses 0.85 on
        its noisy robot data; 0.98-0.999 is usual for slow drift. An array
        gives each parameter its own factor (vector forgetting, exponential
        scheme only; see Notes).
    P0 : float or array_like, shape (p, p), keyword-only
        Initial covariance; a scalar means ``P0*I``. Default 1e4 ("large", as in
        the paper). Must be symmetric positive definite.
    theta0 : array_like, shape (p,), keyword-only
        Initial estimate, default zeros (as in the paper).
    forgetting : {"exponential", "directional"}, keyword-only
        ``"exponential"`` (default): eqs. 10-13, every direction of ``P`` is
        divided by ``lam`` at every update, so without excitation ``P`` would grow
        like ``lam**-k`` (estimator windup) were it not for ``P_max``. ``"directional"``:
        directional forgetting (see Notes); information is forgotten only along the
        current regressor, so ``P`` stays bounded without excitation.
    P_max : float, keyword-only
        Bound on ``trace(P)`` (covariance upper bound, windup protection). When an
        update would exceed it, that update forgets nothing (``lam = 1`` for that
        step). Default ``trace(P0)`` for both schemes: forgetting never makes the
        estimate less certain than the initial guess, so ``P`` stays bounded over
        any number of updates without excitation. ``math.inf`` gives the paper's
        plain eqs. 10-13 (``RecursiveLeastSquares(p, lam=0.85, P_max=math.inf)``),
        which overflow after a few thousand unexcited updates at ``lam = 0.85``.
    bounds : tuple (lower, upper) of array_like, shape (p,), keyword-only
        Box of admissible parameters (``-inf``/``inf`` allowed). After each
        update ``theta`` is projected onto it (see Notes). Default: none.

    Attributes
    ----------
    theta : ndarray, shape (p,)
        Current estimate (public, read it any time). A view of the internal
        state, updated in place: copy it to keep a value.
    P : ndarray, shape (p, p)
        Current covariance (exactly symmetric; a new array from the factors ``U D U'`` the struct holds;
        assigning the attribute sets them).
    lam : float or ndarray, shape (p,)
        Forgetting factor(s).
    n_updates : int
        Accepted updates.
    n_projected : int
        Updates after which ``theta`` had to be projected onto ``bounds``.
    n_rejected : int
        Samples refused with the state unchanged: non-finite, or an update that
        would overflow (see Notes).

    Raises
    ------
    ParameterError
        ``lam`` outside (0, 1], bad ``n_params`` (also more than :data:`RLS_NMAX`), ``P0``/``theta0`` of the wrong
        shape, non-finite, or (``P0``) not symmetric positive definite; unknown
        ``forgetting``; ``P_max`` not > 0; ``bounds`` of the wrong shape, NaN,
        lower > upper, or ``theta0`` outside them.

    Notes
    -----
    With ``phi`` the regressor and ``y`` the output (paper: X and w)::

        e     = y - phi @ theta                      (a-priori error, eq. 10)
        s     = lam + phi @ P @ phi
        gamma = P @ phi / s                          (eq. 12)
        theta = theta + gamma * e                    (eq. 11)
        P     = (P - (P @ phi)(P @ phi)^T / s) / lam (eq. 13)

    Eq. 13 is written ``(I - gamma phi^T) P / lam``; that product is not
    symmetric in floating point, and even the symmetric rank-one form above
    (Ljung & Söderström, *Theory and Practice of Recursive Identification*,
    1983, Sec. 2.2) loses positive definiteness in single precision at the
    condition numbers of a first learning transient (a large ``P0``). ``P`` is
    therefore held as its factors ``P = U diag(d) U^T`` (``U`` unit upper
    triangular, ``d > 0``) and the update is carried out on them by Bierman's
    algorithm (G. J. Bierman, *Factorization Methods for Discrete Sequential
    Estimation*, 1977, Sec. V.3; Grewal & Andrews, *Kalman Filtering*, 2015,
    Sec. 7.5.2), algebraically identical; :attr:`P` is the product, rebuilt
    after each update and exactly symmetric. With ``lam = 1``, ``P0 = I/r`` and ``theta0 = 0`` the
    estimate after N updates equals the ridge-regularised batch solution
    ``argmin ||X theta - y||**2 + r*||theta||**2`` (see
    :func:`adaptive_ff.fit_ls` with ``ridge=r``).

    **Vector forgetting** (``lam`` an array): before each measurement update
    the covariance is inflated as ``P <- D P D`` with ``D = diag(lam)**-1/2``,
    then updated with unit weight (``s = 1 + phi @ P @ phi``); for equal
    factors this is exactly eqs. 10-13 (the division by ``lam`` moved in front
    of the update). Parameters known to vary slowly (an inertia) can so keep a
    long memory while friction levels follow drift (Sælid & Foss, "Adaptive
    controllers with a vector variable forgetting factor", IEEE CDC 1983;
    Vahidi, Stefanopoulou, Peng, Vehicle System Dynamics 43(1), 2005).

    **Directional forgetting** (windup protection; Kulhavý, "Restricted
    exponential forgetting in real-time identification", Automatica 23(5),
    1987; in the form of Bittanti, Bolzern, Campi, "Convergence and exponential
    convergence of identification algorithms with directional forgetting
    factor", Automatica 26(5), 1990)::

        r     = phi @ P @ phi
        beta  = lam - (1 - lam)/r        (beta = 1 if r == 0)
        P     = P - beta*(P @ phi)(P @ phi)^T / (1 + beta*r)
        theta = theta + (P @ phi) * e    (with the updated P)

    The information matrix ``R = P^-1`` changes by ``beta*phi*phi^T`` only:
    along ``phi`` the quadratic form ``phi @ P @ phi`` converges to
    ``(1 - lam)/lam`` (the same memory as exponential forgetting, about
    ``1/(1 - lam)`` samples), and in every direction ``P``-orthogonal to
    ``phi`` it is left unchanged. With constant ``phi`` (constant velocity) or
    ``phi = 0`` (standstill) ``P`` therefore stays bounded, where exponential
    forgetting multiplies the unexcited part by ``1/lam`` per update. For
    ``lam = 1`` both schemes are the ordinary RLS. ``1 + beta*r`` equals
    ``lam*(1 + r) > 0``, so ``P`` stays positive definite. The trace bound
    ``P_max`` guards the one remaining growth path (a regressor that is
    tiny in some direction lets ``P`` grow like ``1/|phi|**2`` there): an update
    that would exceed it uses ``beta = 1`` (no forgetting).

    **Projection** onto ``bounds`` in the metric of ``P^-1`` (the metric in
    which RLS is a steepest-descent method; Goodwin & Sin, *Adaptive
    Filtering, Prediction and Control*, 1984, Sec. 3.3.7; Ioannou & Sun,
    *Robust Adaptive Control*, 1996, Sec. 4.11.3): for the most violated bound
    ``theta_i -> b_i``, ``theta <- theta - P[:, i]*(theta_i - b_i)/P[i, i]``
    (exact for one active bound), repeated at most ``p`` times, then a final
    clip. ``P`` is not changed.

    **Input rejection.** A sample with a NaN/inf entry, or one whose update
    would overflow (the a-priori error ``e``, ``phi @ P @ phi`` or
    ``|P @ phi|**2`` not finite in float64: entries of ``phi``, ``y`` beyond
    about ``1e150``), is refused before the state is touched and counted in
    :attr:`n_rejected`; :meth:`update` then raises :class:`plant.errors.SignalError`,
    the C ``aff_rls_update`` (used by the C components) returns NaN.

    **Implementation.** C (``adaptive_ff/csrc/aff_rls.c``, ``aff_rls_step``) performs an
    update in place on the struct ``aff_rls`` that holds ``theta``, ``P``, the counters and
    the configuration (:attr:`cdata`; a composite component embeds it in its own struct);
    :meth:`update` calls it once per sample (timings: ``benchmarks/rls.py`` and the
    documentation's benchmark pages), :meth:`update_many` runs a whole stream in one call
    (``aff_rls_update_many``). The struct holds ``P`` as its
    factors ``UD`` (assign :attr:`P` to set them).
    """

    _ffi = ffi
    _ctype = "aff_rls"

    def __init__(self, n_params: int, *, lam: float = 1.0, P0=1e4, theta0=None, forgetting: str = "exponential",
                 P_max: float | None = None, bounds=None):
        # the ranges of n_params, lam, P0 and P_max are aff_rls_init's to check (the one validator: a
        # ParameterError with its sentence naming the field); here only what C does not see: the forgetting's
        # name, a vector lam (its factors: aff_rls_set_lam_each) and a matrix P0
        if forgetting not in FORGETTING:
            raise ParameterError(f"forgetting must be one of {FORGETTING}, got {forgetting!r}")
        vector = np.ndim(lam) > 0
        scheme = lib.AFF_RLS_VECTOR if vector else _SCHEMES[forgetting]
        if vector and forgetting != "exponential":
            raise ParameterError("a vector lam needs forgetting='exponential'")
        cfg = self._settings("aff_rls_config", lib.aff_rls_default_config(),
                             {"n_params": n_params, "forgetting": scheme, "lam": 1.0 if vector else lam,
                              "P0": P0 if np.ndim(P0) == 0 else 1.0,
                              "P_max": 0.0 if P_max is None else P_max}, counts=("n_params",))
        code = lib.aff_rls_check_config(cfg)  # before the arrays of p entries are made
        if code != lib.AFF_OK:
            raise ParameterError(f"{type(self).__name__}: {ffi.string(lib.aff_error_message(code)).decode()}")
        p = int(n_params)
        if vector:
            lam = np.array(lam, dtype=float).reshape(-1)
            if lam.shape != (p,):
                raise ParameterError(f"lam must be a number or {p} numbers in (0, 1], got {lam!r}")
        else:
            lam = float(lam)
        if np.ndim(P0) == 0:
            P = float(P0) * np.eye(p)
        else:
            P = np.array(P0, dtype=float)
            if P.shape != (p, p):
                raise ParameterError(f"P0 must have shape ({p}, {p}), got {P.shape}")
            if not np.all(np.isfinite(P)) or not np.allclose(P, P.T, rtol=1e-12, atol=0.0):
                raise ParameterError("P0 must be finite and symmetric")
            P = 0.5 * (P + P.T)
            if np.linalg.eigvalsh(P)[0] <= 0:
                raise ParameterError("P0 must be positive definite")
        if theta0 is None:
            theta = np.zeros(p)
        else:
            theta = np.array(theta0, dtype=float).reshape(-1)
            if theta.shape != (p,) or not np.all(np.isfinite(theta)):
                raise ParameterError(f"theta0 must be {p} finite values, got {theta0!r}")
        if P_max is None or (np.ndim(P0) > 0 and P_max == 0):  # the trace of the P0 given
            cfg.P_max = float(np.trace(P))
        lower = np.full(p, -math.inf)
        upper = np.full(p, math.inf)
        has_bounds = bounds is not None
        if has_bounds:
            try:
                lower, upper = bounds
            except (TypeError, ValueError):
                raise ParameterError(f"bounds must be a pair (lower, upper), got {bounds!r}") from None
            lower = np.broadcast_to(np.asarray(lower, dtype=float), (p,)).copy()
            upper = np.broadcast_to(np.asarray(upper, dtype=float), (p,)).copy()
            if np.isnan(lower).any() or np.isnan(upper).any() or np.any(lower > upper):
                raise ParameterError(f"bounds need lower <= upper without NaN, got {lower!r}, {upper!r}")
            if np.any(theta < lower) or np.any(theta > upper):
                raise ParameterError(f"theta0 = {theta!r} lies outside the bounds")
        self.n_params = p
        self._lam = lam
        self._forgetting = forgetting
        self._configure(lib.aff_rls_init, cfg, lib.aff_error_message)
        if scheme == lib.AFF_RLS_VECTOR:  # D = d d', d = lam**-0.5 (exactly symmetric inflation factors)
            code = lib.aff_rls_set_lam_each(self._c, ffi.new("double[]", [float(x) for x in lam]))
            if code != lib.AFF_OK:
                raise ParameterError(f"lam: {ffi.string(lib.aff_error_message(code)).decode()}")
        self._bind()
        self.theta = theta
        self.P = P
        self._c.has_bounds = int(has_bounds)
        self._lower[:] = lower
        self._upper[:] = upper

    @classmethod
    def in_place(cls, owner: Component, field: str, *, lam=1.0, P0: float = 1e4, forgetting: str = "exponential",
                 P_max: float | None = None) -> "RecursiveLeastSquares":
        """An RLS over the struct ``field`` of ``owner``'s struct, which ``owner``'s C init configured as
        ``RecursiveLeastSquares(p, lam=lam, P0=P0, forgetting=forgetting, P_max=P_max)`` configures its own (C
        ``aff_rls_init``; a vector ``lam``: ``aff_rls_set_lam_each``) and started at its theta: no struct of its
        own built, checked, set and copied in (the composite's C init checked the settings; the estimator of
        :class:`adaptive_ff.compensation.sliding_estimator.SlidingFrictionEstimator`).

        Parameters
        ----------
        owner : plant.component.Component
            The composite (configured), which embeds an ``aff_rls`` at ``field``.
        field : str
            The C field (a dotted path for a nested one).
        lam, P0, forgetting, P_max : keyword-only
            The settings its init was given (as the constructor's; ``P0`` a number), kept as :attr:`config`,
            :attr:`lam` and :attr:`forgetting`.

        Returns
        -------
        RecursiveLeastSquares
            Points into ``owner``'s struct; ``n_params`` is the struct's.
        """
        rls = cls._in_place(owner, field, None)
        vector = type(lam) is not float and np.ndim(lam) > 0
        p = rls.n_params = int(rls._c.p)
        rls._keep(ffi.new("aff_rls_config *", {  # every field of the settings (the composite's init checked them)
            "n_params": p, "forgetting": lib.AFF_RLS_VECTOR if vector else _SCHEMES[forgetting],
            "lam": 1.0 if vector else float(lam), "P0": float(P0), "P_max": 0.0 if P_max is None else float(P_max)}))
        rls._lam = np.array(lam, dtype=float).reshape(-1) if vector else float(lam)
        rls._forgetting = forgetting
        rls._bind()
        return rls

    def _bind(self) -> None:
        """Make the numpy views of the struct's arrays (again, after the struct moved: :meth:`_use`, unpickling)."""
        p = self.n_params
        c = self._c

        def view(field, n):
            return np.frombuffer(ffi.buffer(field), dtype=np.float64)[:n]

        self._theta = view(c.theta, p)
        self._lower = view(c.lower, p)
        self._upper = view(c.upper, p)
        self._D = view(c.D, p * p).reshape(p, p)

    def _attached(self) -> None:
        self._bind()

    def __getstate__(self) -> dict:
        d = super().__getstate__()
        for k in _VIEWS:
            d.pop(k, None)
        return d

    def __repr__(self) -> str:
        return (f"RecursiveLeastSquares(n_params={self.n_params}, lam={self.lam!r}, forgetting={self.forgetting!r}, "
                f"n_updates={self.n_updates})")

    # ---- state (views into the struct; assignment copies into it) ----
    @property
    def theta(self) -> np.ndarray:
        """Current estimate, shape (p,) (a view of the struct, updated in place by each update; copy it to keep a
        value)."""
        return self._theta

    @theta.setter
    def theta(self, value) -> None:
        value = np.asarray(value, dtype=float)
        if value.shape != (self.n_params,):
            raise ParameterError(f"theta must have shape ({self.n_params},), got {value.shape}")
        self._theta[:] = value

    @property
    def P(self) -> np.ndarray:
        """Current covariance ``U diag(d) U'``, shape (p, p), exactly symmetric: a new array computed from the
        factors the struct holds (``aff_rls_cov``); assign to the attribute to set it."""
        p = self.n_params
        out = np.empty((p, p))
        lib.aff_rls_cov(self._c, ffi.from_buffer("double[]", out))
        return out

    @P.setter
    def P(self, value) -> None:
        """Set the covariance: a finite, symmetric, positive definite (p, p) array (``aff_rls_set_P`` stores it and
        its factors); :class:`~plant.errors.ParameterError` otherwise, the state unchanged."""
        value = np.ascontiguousarray(value, dtype=float)
        if value.shape != (self.n_params, self.n_params):
            raise ParameterError(f"P must have shape ({self.n_params}, {self.n_params}), got {value.shape}")
        code = lib.aff_rls_set_P(self._c, ffi.from_buffer("double[]", value))
        if code != lib.AFF_OK:
            raise ParameterError(f"P: {ffi.string(lib.aff_error_message(code)).decode()}")

    @property
    def lam(self):
        """Forgetting factor(s): float, or ndarray of shape (p,) (vector forgetting)."""
        return self._lam

    @property
    def forgetting(self) -> str:
        """Forgetting scheme, one of :data:`FORGETTING`."""
        return self._forgetting

    @property
    def prior_variance(self) -> float:
        """Prior variance per parameter: ``P_max/p`` (``aff_rls_prior_variance``; inf for the unbounded eqs.
        10-13), the scale against which the data's reduction of a diagonal entry of ``P`` is judged."""
        return float(lib.aff_rls_prior_variance(self._c))

    @property
    def bounds(self) -> tuple | None:
        """``(lower, upper)`` arrays of the projection box, or None."""
        return (self._lower.copy(), self._upper.copy()) if self._c.has_bounds else None

    def _check(self, phi, y) -> tuple[np.ndarray, float]:
        """Convert and validate one sample; raise SignalError naming the argument and value."""
        try:
            phi = np.asarray(phi, dtype=float)
        except (TypeError, ValueError):
            raise SignalError(f"phi must be {self.n_params} numbers, got {phi!r}") from None
        if phi.shape != (self.n_params,):
            raise SignalError(f"phi must have shape ({self.n_params},), got {phi.shape}")
        if not np.all(np.isfinite(phi)):
            raise SignalError(f"phi has a non-finite entry: {phi!r}")
        try:
            y = float(y)
        except (TypeError, ValueError):
            raise SignalError(f"y must be a number, got {y!r}") from None
        if not math.isfinite(y):
            raise SignalError(f"y must be finite, got {y!r}")
        return np.ascontiguousarray(phi), y

    def predict(self, phi) -> float:
        """A-priori prediction ``phi @ theta`` (same unit as y).

        Parameters
        ----------
        phi : array_like, shape (p,)
            Regressor.

        Returns
        -------
        float

        Raises
        ------
        SignalError
            Wrong shape or a non-finite entry.
        """
        phi, _ = self._check(phi, 0.0)
        return float(phi @ self._theta)

    def update(self, phi, y) -> float:
        """Process one sample; return the a-priori error ``y - phi @ theta``.

        Parameters
        ----------
        phi : array_like, shape (p,)
            Regressor (a contiguous float64 vector takes the fast path; anything else is converted).
        y : float
            Measured output.

        Returns
        -------
        float
            A-priori prediction error (eq. 10).

        Raises
        ------
        SignalError
            Wrong shape, a NaN/inf in ``phi`` or ``y``, or an update that would
            overflow (class Notes); the state is left unchanged but :attr:`n_rejected`.

        Notes
        -----
        C (``aff_rls_update``) checks the sample (one multiply-add per entry: ``x*0`` is
        NaN exactly for NaN/inf, then the overflow guard) before it touches the state
        and returns NaN for a rejected sample; only then is the sample inspected in
        Python to raise the error.
        """
        try:
            if (type(phi) is not _NDARRAY or phi.dtype is not _F8 or phi.shape != self._theta.shape
                    or not phi.flags.c_contiguous):  # list, int array, strided, wrong shape: convert and check
                phi, y = self._check(phi, y)
            try:
                e = lib.aff_rls_update(self._c, ffi.from_buffer("double[]", phi), y)
            except TypeError:  # y not a number
                phi, y = self._check(phi, y)
                e = lib.aff_rls_update(self._c, ffi.from_buffer("double[]", phi), y)
        except SignalError:
            self._c.n_rejected += 1  # refused in Python before C: counted as C would
            raise
        if e != e:
            self._check(phi, y)  # raises SignalError if C rejected a non-finite sample
            raise SignalError(f"sample refused: its update would overflow (phi = {np.asarray(phi).tolist()!r}, "
                              f"y = {float(y)!r}); the state is unchanged")
        return e

    def update_many(self, Phi, Y) -> np.ndarray:
        """Process a stream of N samples in one C call (``aff_rls_update_many``); return the estimate after each.

        Equal to ``N`` calls of :meth:`update` (the same C function, bit for bit).

        Parameters
        ----------
        Phi : array_like, shape (N, p)
            Regressors, one row per sample.
        Y : array_like, shape (N,)
            Measured outputs.

        Returns
        -------
        ndarray, shape (N, p)
            ``theta`` after each update (row k: after sample k). The a-priori errors
            are ``Y[k] - Phi[k] @ theta_hist[k-1]`` (``theta`` before the call for k = 0).

        Raises
        ------
        SignalError
            Wrong shapes, or a NaN/inf anywhere in ``Phi`` or ``Y`` (the message names
            the first bad row); the whole stream is then rejected and the state left unchanged.

        Notes
        -----
        A finite row whose update would overflow (class Notes) is skipped and counted in
        :attr:`n_rejected`; its row of the history repeats the previous estimate.
        """
        Phi = np.ascontiguousarray(Phi, dtype=float)
        Y = np.ascontiguousarray(Y, dtype=float)
        p = self.n_params
        if Phi.ndim != 2 or Phi.shape[1] != p:
            raise SignalError(f"Phi must have shape (N, {p}), got {Phi.shape}")
        if Y.shape != (Phi.shape[0],):
            raise SignalError(f"Y must have shape ({Phi.shape[0]},), got {Y.shape}")
        hist = np.empty((Phi.shape[0], p))
        bad = lib.aff_rls_update_many(self._c, ffi.from_buffer("double[]", Phi), ffi.from_buffer("double[]", Y),
                                      Phi.shape[0], ffi.from_buffer("double[]", hist, require_writable=True))
        if bad >= 0:
            raise SignalError(f"sample {bad} is not finite: Phi[{bad}] = {Phi[bad].tolist()!r}, "
                              f"Y[{bad}] = {float(Y[bad])!r}; no sample of the stream was used")
        return hist
