"""Recursive least squares with forgetting (eqs. 10-13), windup protection and projection onto parameter bounds.

The arithmetic of one update is one compiled (numba) kernel, :func:`rls_step`, used by
both :meth:`RecursiveLeastSquares.update` (one sample per call) and
:meth:`RecursiveLeastSquares.update_many` (a whole stream in one call). The
estimator state (``theta``, ``P``, counters, configuration) lives in one private
float64 buffer; ``theta`` and ``P`` are views into it and are updated in place.
"""

from __future__ import annotations

import math

import numpy as np
from plant.jit import kernel

from plant.errors import ParameterError, SignalError, check_finite_scalar

__all__ = ["RecursiveLeastSquares", "FORGETTING", "rls_buffer_size", "rls_step", "rls_update", "rls_theta", "rls_P",
           "rls_n_updates", "rls_n_rejected", "rls_prior_variance"]

#: Forgetting schemes of :class:`RecursiveLeastSquares`.
FORGETTING = ("exponential", "directional")

# Layout of the state buffer: a header, then theta (p), P (p*p, row-major), lower (p), upper (p),
# D (p*p, vector-forgetting inflation factors) and a scratch vector (p) for P @ phi.
_NP, _SCHEME, _LAM, _PMAX, _HASB, _NUPD, _NPROJ, _NREJ = 0, 1, 2, 3, 4, 5, 6, 7
_HDR = 8
_EXPONENTIAL, _DIRECTIONAL, _VECTOR = 0, 1, 2
_NDARRAY = np.ndarray
_F8 = np.dtype(np.float64)


def rls_buffer_size(p: int) -> int:
    """Length of the state buffer of a :class:`RecursiveLeastSquares` with ``p`` parameters."""
    return _HDR + 4 * p + 2 * p * p


@kernel(inline="always")
def rls_theta(buf, i):
    """Entry ``i`` of ``theta`` in the state buffer ``buf`` (for kernels that compose the RLS)."""
    return buf[_HDR + i]


@kernel(inline="always")
def rls_P(buf, i, j):
    """Entry ``(i, j)`` of ``P`` in the state buffer ``buf``."""
    return buf[_HDR + np.int64(buf[_NP]) * (1 + i) + j]


@kernel(inline="always")
def rls_prior_variance(buf):
    """Prior variance per parameter of the RLS in ``buf``: the trace bound ``P_max`` over ``p`` (``P0`` for a
    scalar ``P0`` and the default ``P_max``; ``inf`` for the paper's unbounded eqs. 10-13). The scale against
    which the data's reduction of a diagonal entry of ``P`` is judged (no information along a direction
    leaves its ``P`` entry at that order)."""
    return buf[_PMAX] / buf[_NP]


@kernel(inline="always")
def rls_n_updates(buf):
    """Number of accepted updates recorded in the state buffer ``buf`` (float)."""
    return buf[_NUPD]


@kernel(inline="always")
def rls_n_rejected(buf):
    """Number of rejected samples (non-finite, or an update that would overflow) in the state buffer (float)."""
    return buf[_NREJ]


@kernel
def _violation(buf, p, th, lo, hi, i):
    t = buf[th + i]
    a = buf[lo + i] - t
    b = t - buf[hi + i]
    return (a if a > 0.0 else 0.0) + (b if b > 0.0 else 0.0)


@kernel
def _project(buf, p, th, P0, lo, hi):
    """Project theta onto the box in the metric of P^-1 (class Notes); count the projection."""
    any_viol = False
    for i in range(p):
        if _violation(buf, p, th, lo, hi, i) != 0.0:
            any_viol = True
            break
    if not any_viol:
        return
    buf[_NPROJ] += 1.0
    for _ in range(p):
        best = -1.0
        ib = -1
        for i in range(p):
            vi = _violation(buf, p, th, lo, hi, i)
            if vi != 0.0:
                q = vi / math.sqrt(buf[P0 + i * p + i])
                if ib < 0 or q > best:
                    best = q
                    ib = i
        if ib < 0:
            break
        t = buf[th + ib]
        b = buf[lo + ib] if t < buf[lo + ib] else buf[hi + ib]
        c = (t - b) / buf[P0 + ib * p + ib]
        for j in range(p):
            buf[th + j] = buf[th + j] - buf[P0 + j * p + ib] * c
        buf[th + ib] = b
    for i in range(p):
        t = buf[th + i]
        if t < buf[lo + i]:
            buf[th + i] = buf[lo + i]
        elif t > buf[hi + i]:
            buf[th + i] = buf[hi + i]


@kernel("float64(float64[::1], float64[:], float64)")
def rls_step(buf, phi, y):
    """One RLS update of the state in ``buf`` (see the class Notes); return the a-priori error.

    The sample must be finite (:func:`rls_update` checks that). An update that would overflow (the a-priori
    error, ``phi @ P @ phi`` or ``|P @ phi|**2`` not finite: entries of ``phi`` or ``y`` beyond about
    ``1e150/sqrt(trace P)``) is refused before the state is touched: NaN is returned and the sample is
    counted in the rejected-sample counter (``rls_n_rejected``).
    """
    p = np.int64(buf[_NP])
    th = _HDR
    P0 = th + p
    lo = P0 + p * p
    hi = lo + p
    D = hi + p
    v = D + p * p
    scheme = np.int64(buf[_SCHEME])
    lam = buf[_LAM]
    P_max = buf[_PMAX]
    e = y
    for i in range(p):
        e -= phi[i] * buf[th + i]
    # P @ phi into the scratch vector (inflated by D for vector forgetting), then the overflow guard: the
    # state is not touched before it
    r = 0.0
    vv = 0.0
    tr = 0.0
    for i in range(p):
        acc = 0.0
        for j in range(p):
            if scheme == _VECTOR:
                acc += (buf[P0 + i * p + j] * buf[D + i * p + j]) * phi[j]
            else:
                acc += buf[P0 + i * p + j] * phi[j]
        buf[v + i] = acc
        r += phi[i] * acc
        vv += acc * acc
        tr += buf[P0 + i * p + i]
    if not (math.isfinite(e * e) and math.isfinite(r) and math.isfinite(vv)):
        buf[_NREJ] += 1.0
        return np.nan
    if scheme == _VECTOR:
        # inflate P <- D P D (unless that exceeds the trace bound), then a unit-weight update
        tr = 0.0
        for i in range(p):
            tr += buf[P0 + i * p + i] * buf[D + i * p + i]
        inflate = tr <= P_max
        if inflate:
            for k in range(p * p):
                buf[P0 + k] = buf[P0 + k] * buf[D + k]
        r = 0.0
        for i in range(p):
            acc = 0.0
            for j in range(p):
                acc += buf[P0 + i * p + j] * phi[j]
            buf[v + i] = acc
            r += phi[i] * acc
        s = 1.0 + r
        for i in range(p):
            vi = buf[v + i]
            for j in range(i, p):
                x = buf[P0 + i * p + j] - (vi * buf[v + j]) / s
                buf[P0 + i * p + j] = x
                buf[P0 + j * p + i] = x
        g = e / s
    else:
        if scheme == _EXPONENTIAL:
            s = lam + r
            div = 1.0
            if lam < 1.0:
                tr1 = 0.0
                for i in range(p):
                    tr1 += buf[P0 + i * p + i] - (buf[v + i] * buf[v + i]) / s
                if tr1 / lam <= P_max:
                    div = lam
                else:  # covariance bound reached: this update forgets nothing (ordinary RLS step)
                    s = 1.0 + r
            for i in range(p):
                vi = buf[v + i]
                for j in range(i, p):
                    x = buf[P0 + i * p + j] - (vi * buf[v + j]) / s
                    if div != 1.0:
                        x = x / div
                    buf[P0 + i * p + j] = x
                    buf[P0 + j * p + i] = x
            g = e / s
        else:  # directional forgetting
            beta = lam - (1.0 - lam) / r if r > 0.0 else 1.0
            den = 1.0 + beta * r
            if beta < 0.0:
                # trace after the update: trace(P) - beta*|P phi|^2/den; over the bound -> no forgetting
                if tr - beta * vv / den > P_max:
                    beta = 1.0
                    den = 1.0 + r
            c = beta / den
            for i in range(p):
                vi = buf[v + i]
                for j in range(i, p):
                    x = buf[P0 + i * p + j] - (vi * buf[v + j]) * c
                    buf[P0 + i * p + j] = x
                    buf[P0 + j * p + i] = x
            g = e / den  # theta += P_new @ phi * e
    for i in range(p):
        buf[th + i] += buf[v + i] * g
    if buf[_HASB] != 0.0:
        _project(buf, p, th, P0, lo, hi)
    buf[_NUPD] += 1.0
    return e


@kernel("float64(float64[::1], float64[:], float64)")
def rls_update(buf, phi, y):
    """Checked single update: NaN (state untouched but the rejected-sample counter) for a wrong length, a
    non-finite sample or an update that would overflow (:func:`rls_step`), else the a-priori error."""
    p = np.int64(buf[_NP])
    if phi.shape[0] != p:
        buf[_NREJ] += 1.0
        return np.nan
    chk = y * 0.0  # NaN iff y or any phi[i] is NaN/inf
    for i in range(p):
        chk += phi[i] * 0.0
    if chk != 0.0:
        buf[_NREJ] += 1.0
        return np.nan
    return rls_step(buf, phi, y)


@kernel("int64(float64[::1], float64[:, :], float64[:], float64[:, ::1])")
def _update_many(buf, Phi, Y, hist):
    """Validate the whole stream (return the first bad row, state untouched), then update row by row."""
    n, p = Phi.shape
    for k in range(n):
        chk = Y[k] * 0.0
        for i in range(p):
            chk += Phi[k, i] * 0.0
        if chk != 0.0:
            return k
    for k in range(n):
        rls_step(buf, Phi[k], Y[k])
        for i in range(p):
            hist[k, i] = buf[_HDR + i]
    return -1


class RecursiveLeastSquares:
    """Recursive least-squares estimator with forgetting factor ``lam``, eqs. 10-13.

    Parameters
    ----------
    n_params : int
        Number of parameters ``p`` (>= 1).
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
        Current covariance (exactly symmetric; a view, updated in place).
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
        ``lam`` outside (0, 1], bad ``n_params``, ``P0``/``theta0`` of the wrong
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
    symmetric in floating point and drifts over long runs. The form above,
    algebraically identical, subtracts a symmetric rank-one term and so keeps
    ``P`` exactly symmetric (Ljung & Söderström, *Theory and Practice of
    Recursive Identification*, 1983, Sec. 2.2; Haykin, *Adaptive Filter
    Theory*, Ch. 10). With ``lam = 1``, ``P0 = I/r`` and ``theta0 = 0`` the
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
    the compiled :func:`rls_update` (used by the compiled components) returns NaN.

    **Implementation.** One compiled (numba) kernel performs an update in place
    on a private float64 buffer that holds ``theta``, ``P``, the counters and the
    configuration; :meth:`update` calls it once per sample (timings:
    ``benchmarks/rls.py`` and the documentation's benchmark pages), :meth:`update_many` runs
    a whole stream in one call. ``P`` is updated on its upper triangle and
    mirrored, so it is exactly symmetric.
    """


    def __init__(self, n_params: int, *, lam: float = 1.0, P0=1e4, theta0=None, forgetting: str = "exponential",
                 P_max: float | None = None, bounds=None):
        if isinstance(n_params, bool) or not isinstance(n_params, (int, np.integer)) or n_params < 1:
            raise ParameterError(f"n_params must be an integer >= 1, got {n_params!r}")
        p = int(n_params)
        buf = np.zeros(rls_buffer_size(p))
        if forgetting not in FORGETTING:
            raise ParameterError(f"forgetting must be one of {FORGETTING}, got {forgetting!r}")
        if np.ndim(lam) == 0:
            lam = check_finite_scalar("lam", lam)
            if not 0.0 < lam <= 1.0:
                raise ParameterError(f"lam must be in (0, 1], got {lam!r}")
            scheme = _EXPONENTIAL if forgetting == "exponential" else _DIRECTIONAL
        else:
            lam = np.array(lam, dtype=float).reshape(-1)
            if lam.shape != (p,) or not np.all((lam > 0.0) & (lam <= 1.0)):
                raise ParameterError(f"lam must be a number or {p} numbers in (0, 1], got {lam!r}")
            if forgetting != "exponential":
                raise ParameterError("a vector lam needs forgetting='exponential'")
            d = lam ** -0.5
            scheme = _VECTOR
            D = np.outer(d, d)  # exactly symmetric inflation factors
        if np.ndim(P0) == 0:
            p0 = check_finite_scalar("P0", P0)
            if p0 <= 0:
                raise ParameterError(f"P0 must be > 0, got {P0!r}")
            P = p0 * np.eye(p)
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
        if P_max is None:
            P_max = float(np.trace(P))
        elif not (isinstance(P_max, (int, float, np.integer, np.floating)) and not isinstance(P_max, bool)
                  and P_max > 0):
            raise ParameterError(f"P_max must be a number > 0, got {P_max!r}")
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
        buf[_NP] = p
        buf[_SCHEME] = scheme
        buf[_LAM] = lam if scheme != _VECTOR else 1.0
        buf[_PMAX] = float(P_max)
        buf[_HASB] = 1.0 if has_bounds else 0.0
        self.n_params = p
        self._lam = lam
        self._forgetting = forgetting
        self._bind(buf)
        self.theta = theta
        self.P = P
        self._lower[:] = lower
        self._upper[:] = upper
        if scheme == _VECTOR:
            self._D[:] = D

    def _bind(self, buf: np.ndarray) -> None:
        """Attach the state buffer and the views into it (see :func:`rls_buffer_size` for the layout)."""
        p = self.n_params
        self._buf = buf
        o = _HDR
        self._theta = buf[o:o + p]
        o += p
        self._P = buf[o:o + p * p].reshape(p, p)
        o += p * p
        self._lower = buf[o:o + p]
        self._upper = buf[o + p:o + 2 * p]
        o += 2 * p
        self._D = buf[o:o + p * p].reshape(p, p)

    @property
    def buffer(self) -> np.ndarray:
        """The whole state buffer (configuration, ``theta``, ``P``, counters), 1-D float64.

        Compiled components that own an RLS pass this array (or the slice of their own state it was
        attached to, see :meth:`attach`) to :func:`rls_update`.
        """
        return self._buf

    def attach(self, buffer: np.ndarray) -> None:
        """Move the state into ``buffer`` (a 1-D float64 C-contiguous array of :func:`rls_buffer_size` entries,
        e.g. a slice of a compensator's state) and use it from now on.

        Raises
        ------
        ParameterError
            Wrong size, dtype or layout.
        """
        n = rls_buffer_size(self.n_params)
        if (not isinstance(buffer, np.ndarray) or buffer.dtype != np.float64 or buffer.shape != (n,)
                or not buffer.flags.c_contiguous):
            raise ParameterError(f"buffer must be a C-contiguous float64 array of shape ({n},)")
        buffer[:] = self._buf
        self._bind(buffer)

    def __getstate__(self) -> dict:
        return {"n_params": self.n_params, "lam": self._lam, "forgetting": self._forgetting,
                "buf": self._buf.copy()}

    def __setstate__(self, state: dict) -> None:
        self.n_params = state["n_params"]
        self._lam = state["lam"]
        self._forgetting = state["forgetting"]
        self._bind(np.array(state["buf"], dtype=float))

    def __repr__(self) -> str:
        return (f"RecursiveLeastSquares(n_params={self.n_params}, lam={self.lam!r}, forgetting={self.forgetting!r}, "
                f"n_updates={self.n_updates})")

    # ---- state (views into the buffer; assignment copies into it) ----
    @property
    def theta(self) -> np.ndarray:
        """Current estimate, shape (p,) (a view, updated in place by each update; copy it to keep a value)."""
        return self._theta

    @theta.setter
    def theta(self, value) -> None:
        value = np.asarray(value, dtype=float)
        if value.shape != (self.n_params,):
            raise ParameterError(f"theta must have shape ({self.n_params},), got {value.shape}")
        self._theta[:] = value

    @property
    def P(self) -> np.ndarray:
        """Current covariance, shape (p, p), exactly symmetric (a view, updated in place)."""
        return self._P

    @P.setter
    def P(self, value) -> None:
        value = np.asarray(value, dtype=float)
        if value.shape != (self.n_params, self.n_params):
            raise ParameterError(f"P must have shape ({self.n_params}, {self.n_params}), got {value.shape}")
        self._P[:] = value

    @property
    def lam(self):
        """Forgetting factor(s): float, or ndarray of shape (p,) (vector forgetting)."""
        return self._lam

    @property
    def forgetting(self) -> str:
        """Forgetting scheme, one of :data:`FORGETTING`."""
        return self._forgetting

    @property
    def P_max(self) -> float:
        """Bound on ``trace(P)`` (inf = none)."""
        return float(self._buf[_PMAX])

    @property
    def n_updates(self) -> int:
        """Number of accepted updates."""
        return int(self._buf[_NUPD])

    @property
    def n_projected(self) -> int:
        """Number of updates after which ``theta`` was projected onto ``bounds``."""
        return int(self._buf[_NPROJ])

    @property
    def n_rejected(self) -> int:
        """Number of refused samples (non-finite, or an update that would overflow); the state was left unchanged."""
        return int(self._buf[_NREJ])

    @property
    def bounds(self) -> tuple | None:
        """``(lower, upper)`` arrays of the projection box, or None."""
        return None if self._buf[_HASB] == 0.0 else (self._lower.copy(), self._upper.copy())

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
        return phi, y

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
            Regressor (a float64 ndarray takes the fast path; anything else is converted).
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
        The compiled kernel checks the sample (one multiply-add per entry: ``x*0`` is
        NaN exactly for NaN/inf, then the overflow guard) before it touches the state
        and returns NaN for a rejected sample; only then is the sample inspected in
        Python to raise the error.
        """
        try:
            if type(phi) is not _NDARRAY or phi.dtype is not _F8:  # list, int array, ...: convert and check first
                phi, y = self._check(phi, y)
            try:
                e = rls_update(self._buf, phi, y)
            except TypeError:  # phi not a vector, read-only, or y not a number (no matching compiled signature)
                phi, y = self._check(phi, y)
                e = rls_update(self._buf, np.array(phi), y)
        except SignalError:
            self._buf[_NREJ] += 1.0  # refused in Python before the kernel: counted as the kernel would
            raise
        if e != e:
            self._check(phi, y)  # raises SignalError if the kernel rejected a non-finite sample
            raise SignalError(f"sample refused: its update would overflow (phi = {np.asarray(phi).tolist()!r}, "
                              f"y = {float(y)!r}); the state is unchanged")
        return e

    def update_many(self, Phi, Y) -> np.ndarray:
        """Process a stream of N samples in one compiled call; return the estimate after each.

        Equal to ``N`` calls of :meth:`update` (the same kernel, bit for bit).

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
        Phi = np.asarray(Phi, dtype=float)
        Y = np.asarray(Y, dtype=float)
        if not Phi.flags.writeable:  # the compiled signature takes writable arrays (e.g. np.broadcast_to views)
            Phi = Phi.copy()
        if not Y.flags.writeable:
            Y = Y.copy()
        p = self.n_params
        if Phi.ndim != 2 or Phi.shape[1] != p:
            raise SignalError(f"Phi must have shape (N, {p}), got {Phi.shape}")
        if Y.shape != (Phi.shape[0],):
            raise SignalError(f"Y must have shape ({Phi.shape[0]},), got {Y.shape}")
        hist = np.empty((Phi.shape[0], p))
        bad = _update_many(self._buf, Phi, Y, hist)
        if bad >= 0:
            raise SignalError(f"sample {bad} is not finite: Phi[{bad}] = {Phi[bad].tolist()!r}, "
                              f"Y[{bad}] = {float(Y[bad])!r}; no sample of the stream was used")
        return hist
