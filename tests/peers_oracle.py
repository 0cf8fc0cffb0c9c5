"""Test oracle: the Python peers and the eq. 4 adaptive feedforward as they were before they became compiled components.

Verbatim copies (issue 10) of ``controllers.peers.canudas.CanudasCompensator``,
``controllers.peers.dob.DisturbanceObserver`` and, from
``adaptive_ff.compensation.feedforward``, ``project_estimate``,
``FrictionFeedforward`` and ``AdaptiveFrictionFeedforward`` (commit 9d852bd).
Used by tests/test_peer_components.py and tests/test_eq4_component.py to check
the compiled components bit for bit (peers) and to 1e-12 (eq. 4). Not part of
the package. They use the package's ``RecursiveLeastSquares`` (itself checked
against ``tests/rls_oracle.py``) and ``RegressionModel`` (numpy arithmetic).
"""

from __future__ import annotations

import math

import numpy as np

from adaptive_ff.identification.regression import FrictionEstimate, RegressionModel
from adaptive_ff.identification.rls import RecursiveLeastSquares
from plant.errors import ParameterError, SignalError, check_multiple, check_nonnegative, check_positive


class Range:
    """Issue 12: the range rule of adaptive_ff.compensation.gate.RangeGate, written again (independent code).

    Out of range: not finite, |x| > x_max, or |x| > factor*max(env, floor) while that reference is > 0 and fewer
    than max_consecutive samples were rejected in a row. Accepted samples raise the envelope at once
    (env = max(|x|, exp(-1/memory)*env)).
    """

    def __init__(self, x_max=math.inf, factor=100.0, floor=0.0, memory=10000.0, max_consecutive=20):
        self.x_max, self.factor, self.floor = x_max, factor, floor
        self.decay, self.max_consecutive = math.exp(-1.0 / memory), max_consecutive
        self.env, self.held, self.n_rejected = 0.0, 0, 0

    def ok(self, x: float) -> bool:
        if not math.isfinite(x) or abs(x) > self.x_max:
            return False
        ref = max(self.env, self.floor)
        return ref == 0.0 or self.held >= self.max_consecutive or abs(x) <= self.factor * ref

    def commit(self, x: float, ok: bool) -> None:
        if ok:
            self.env = max(abs(x), self.decay * self.env)
            self.held = 0
        else:
            self.held += 1
            self.n_rejected += 1


def rls_try(rls, phi, y):
    """The package RLS update, with a refused sample (issue 12: an update that would overflow) as None."""
    try:
        return rls.update(phi, y)
    except SignalError:
        return None

__all__ = ["CanudasCompensator", "DisturbanceObserver", "FrictionFeedforward", "AdaptiveFrictionFeedforward",
           "project_estimate"]


class CanudasCompensator:
    """Direction-dependent Coulomb + viscous friction, estimated by RLS, compensated at a velocity.

    Parameters
    ----------
    Tc : float, keyword-only
        Controller period (s): :meth:`compensate` and :meth:`observe` are called once per period.
    Ts : float, keyword-only
        Sample time of the estimator (s), a multiple of ``Tc``; default 10 ms.
    lam : float, keyword-only
        Forgetting factor per RLS update; default 0.999.
    forgetting : {"directional", "exponential"}, keyword-only
        RLS forgetting scheme, default directional.
    P0 : float, keyword-only
        Initial covariance scale, default 1e4.
    J_guess : float, keyword-only
        Initial inertia (kg·m²) for ``theta0``; default 1.
    w_dead : float, keyword-only
        Estimation dead zone (rad/s): a sample interval is used only if the
        velocity stays beyond ``±w_dead`` with one sign (no reversal, no
        sticking); default 5e-3.
    warmup : int, keyword-only
        RLS updates before the compensation is switched on; default 300.
    ff_max : float, keyword-only
        Bound on |compensation| (N·m), default inf.
    ff_input : {"measured", "reference"}, keyword-only
        Velocity the compensation is evaluated at; default measured (the
        velocity feedback of the original).

    Attributes
    ----------
    rls : RecursiveLeastSquares
        ``theta = (b, b*sigma_pos, b*sigma_neg, b*Fc_pos, b*Fc_neg)``, ``b = Ts/J``.
    n_rejected : int
        Non-finite samples ignored.

    Raises
    ------
    ParameterError
        Invalid settings (the message quotes the value).

    Notes
    -----
    Sampled motor model over one period ``Ts`` (Euler, torque averaged over the
    period ``u_bar``)::

        w(k+1) - w(k) = b*u_bar(k) - b*sigma_d*w(k) - b*Fc_d*sgn(w(k)),   b = Ts/J

    with ``d`` the direction of ``w(k)``. Regressor
    ``(u_bar, -w*1(w>0), -w*1(w<0), -1(w>0), +1(w<0))``. Compensation
    ``u_c = Fc_d*sgn(w) + sigma_d*w`` with the estimated coefficients. The
    model has no friction lag and no Stribeck effect: that is the difference
    to Ruderman's model that the comparison measures.
    """

    def __init__(self, *, Tc: float, Ts: float = 0.01, lam: float = 0.999, forgetting: str = "directional",
                 P0: float = 1e4, J_guess: float = 1.0, w_dead: float = 5e-3, warmup: int = 300,
                 ff_max: float = math.inf, ff_input: str = "measured"):
        self.Tc = check_positive("Tc", Tc)
        self.m = check_multiple("Ts", Ts, "Tc", self.Tc)
        self.Ts = self.m * self.Tc
        self.w_dead = check_nonnegative("w_dead", w_dead)
        if isinstance(warmup, bool) or not isinstance(warmup, (int, np.integer)) or warmup < 0:
            raise ParameterError(f"warmup must be an integer >= 0, got {warmup!r}")
        self.warmup = int(warmup)
        self.ff_max = math.inf if ff_max == math.inf else check_nonnegative("ff_max", ff_max)
        if ff_input not in ("measured", "reference"):
            raise ParameterError(f"ff_input must be 'measured' or 'reference', got {ff_input!r}")
        self.ff_measured = ff_input == "measured"
        b0 = self.Ts / check_positive("J_guess", J_guess)
        inf = math.inf
        self.rls = RecursiveLeastSquares(5, lam=lam, P0=P0, forgetting=forgetting, theta0=[b0, 0, 0, 0, 0],
                                         bounds=([1e-12, 0, 0, 0, 0], [inf, inf, inf, inf, inf]))
        self.coef = None  # (Fc_pos, Fc_neg, sigma_pos, sigma_neg) in use
        self._k = 0
        self._usum = 0.0
        self._w_prev = None
        self._ok = True
        self.n_rejected = 0
        self.u_range, self.w_range = Range(), Range(floor=self.w_dead)

    @property
    def estimate(self) -> dict | None:
        """``{"J", "Fc_pos", "Fc_neg", "sigma_pos", "sigma_neg"}`` in use (SI units), or None before warm-up."""
        if self.coef is None:
            return None
        b = float(self.rls.theta[0])
        Fcp, Fcn, sp, sn = self.coef
        return {"J": self.Ts / b, "Fc_pos": Fcp, "Fc_neg": Fcn, "sigma_pos": sp, "sigma_neg": sn}

    def compensate(self, w_meas: float, w_ref: float) -> float:
        """Compensation torque (N·m) for this period, bounded by ``ff_max``."""
        if self.coef is None:
            return 0.0
        w = w_meas if self.ff_measured else w_ref
        if not math.isfinite(w):  # issue 12
            return 0.0
        Fcp, Fcn, sp, sn = self.coef
        if w > 0.0:
            c = Fcp + sp * w
        elif w < 0.0:
            c = -Fcn + sn * w
        else:
            c = 0.0
        if not math.isfinite(c):  # issue 12
            return 0.0
        return min(max(c, -self.ff_max), self.ff_max)

    def observe(self, u: float, w: float) -> None:
        """Record the torque ``u`` applied in this period and the velocity ``w`` measured at its start."""
        uok, wok = self.u_range.ok(u), self.w_range.ok(w)
        if not (uok and wok):
            if not uok:
                self.u_range.commit(u, False)
            if not wok:
                self.w_range.commit(w, False)
            self.n_rejected += 1
            self._ok = False  # the current interval is spoiled
            return
        self.u_range.commit(u, True)
        self.w_range.commit(w, True)
        k = self._k
        if k % self.m == 0:
            wp = self._w_prev
            if wp is not None and self._ok:
                self._update(wp, w, self._usum / self.m)
            self._w_prev = w
            self._usum = 0.0
            self._ok = True
        self._usum += u
        self._k = k + 1

    def _update(self, w0: float, w1: float, ubar: float) -> None:
        wd = self.w_dead
        if w0 > wd and w1 > wd:
            phi = [ubar, -w0, 0.0, -1.0, 0.0]
        elif w0 < -wd and w1 < -wd:
            phi = [ubar, 0.0, -w0, 0.0, 1.0]
        else:
            return
        if rls_try(self.rls, np.array(phi), w1 - w0) is None:
            self.n_rejected += 1
            return
        if self.rls.n_updates >= self.warmup:
            b, bsp, bsn, bfp, bfn = self.rls.theta.tolist()
            self.coef = (bfp / b, bfn / b, bsp / b, bsn / b)


class DisturbanceObserver:
    """Velocity-loop disturbance observer ``d_hat = Q*(u - J_n*dw/dt)``, added to the controller output.

    Parameters
    ----------
    J_n : float, keyword-only
        Nominal inertia (kg·m²), > 0 (the same value the PI design uses).
    omega_q : float, keyword-only
        Q-filter cut-off (rad/s), > 0; default 500 (25 times the default
        velocity-loop crossover, 80 Hz at the 1 kHz sampling rate; the
        benchmark shows 300-2000 rad/s: higher tracks better and injects more
        measurement noise into the torque).
    Tc : float, keyword-only
        Controller period (s).
    order : int, keyword-only
        Order of the binomial Q-filter ``1/(1 + s/omega_q)**order``, >= 1
        (``J_n*s*Q`` must be proper); default 2.
    d_max : float, keyword-only
        Bound on |d_hat| (N·m), default inf.

    Attributes
    ----------
    d_hat : float
        Current disturbance estimate (N·m).
    n_rejected : int
        Non-finite velocity samples (the estimate is held).

    Raises
    ------
    ParameterError
        Invalid settings (the message quotes the value).

    Notes
    -----
    Plant ``J*dw/dt = u - d`` (here ``d`` = friction). Discrete form, exact for
    a torque held over each period: the raw disturbance sample is
    ``v(k) = u(k-1) - J_n*(w(k) - w(k-1))/Tc`` (the mean of ``d`` over the last
    period when ``J_n = J``), and ``d_hat = Q[v]`` with ``Q`` realised as
    ``order`` cascaded first-order lags (each ``x += a*(input - x)``,
    ``a = 1 - exp(-Tc*omega_q)``, unit gain at zero frequency). The
    compensated command is ``u = u_PI + d_hat``.
    """

    def __init__(self, *, J_n: float, omega_q: float = 500.0, Tc: float, order: int = 2, d_max: float = math.inf):
        self.J_n = check_positive("J_n", J_n)
        self.omega_q = check_positive("omega_q", omega_q)
        self.Tc = check_positive("Tc", Tc)
        if isinstance(order, bool) or not isinstance(order, int) or order < 1:
            raise ParameterError(f"order must be an integer >= 1, got {order!r}")
        self.order = order
        self.d_max = math.inf if d_max == math.inf else check_nonnegative("d_max", d_max)
        self._a = 1.0 - math.exp(-self.Tc * self.omega_q)
        self._x = [0.0] * order
        self._w_last = None
        self._u_last = 0.0
        self.d_hat = 0.0
        self.n_rejected = 0
        self.u_range, self.w_range = Range(), Range()

    def compensate(self, w_meas: float, w_ref: float) -> float:
        """Advance the observer with the measured velocity of this period; return the bounded ``d_hat`` (N·m)."""
        ok = self.w_range.ok(w_meas)
        self.w_range.commit(w_meas, ok)
        if not ok:
            self.n_rejected += 1
            return self.d_hat
        if self._w_last is None:
            self._w_last = w_meas
            return self.d_hat
        v = self._u_last - self.J_n * (w_meas - self._w_last) / self.Tc
        self._w_last = w_meas
        a = self._a
        x = self._x
        for i in range(self.order):
            x[i] += a * (v - x[i])
            v = x[i]
        self.d_hat = min(max(v, -self.d_max), self.d_max)
        return self.d_hat

    def observe(self, u: float, w: float) -> None:
        """Record the torque ``u`` applied in this period (it drives the next velocity sample)."""
        ok = self.u_range.ok(u)
        self.u_range.commit(u, ok)
        if ok:
            self._u_last = u
        else:
            self.n_rejected += 1


def project_estimate(est: FrictionEstimate, *, tau_max: float = 1.0,
                     F_max: float = math.inf) -> FrictionEstimate | None:
    """Project a raw estimate onto the physically admissible set, or reject it.

    Parameters
    ----------
    est : FrictionEstimate
        Raw estimate from :meth:`RegressionModel.to_physical`.
    tau_max : float, keyword-only
        Largest admissible lag (s).
    F_max : float, keyword-only
        Largest admissible Coulomb or static friction level (N·m), e.g. the
        feedforward bound; default inf.

    Returns
    -------
    FrictionEstimate or None
        ``None`` if a value is non-finite, ``J <= 0`` (the input gain
        ``b0 - b1`` has the wrong sign: nothing physical can be read from it),
        or ``Fc`` or ``Fs`` exceeds ``F_max`` (an unconverged estimate);
        otherwise a copy with ``Fc, Fs, sigma`` clipped to ``>= 0`` and ``tau``
        clipped to ``[0, tau_max]``.

    Notes
    -----
    Projection onto a box of physical bounds, the standard safeguard of
    adaptive control (Ioannou & Sun, *Robust Adaptive Control*, 1996, Sec. 4.11.3),
    applied here to the physical parameters rather than to ``theta``.
    """
    vals = (est.J, est.tau, est.sigma, est.Fc, est.Fs, est.offset)
    if not all(math.isfinite(v) for v in vals) or est.J <= 0 or est.Fc > F_max or est.Fs > F_max:
        return None
    return FrictionEstimate(J=est.J, tau=min(max(est.tau, 0.0), tau_max), sigma=max(est.sigma, 0.0),
                            Fc=max(est.Fc, 0.0), Fs=max(est.Fs, 0.0), offset=est.offset, Vs=est.Vs,
                            delta=est.delta, J_alt=est.J_alt)


class FrictionFeedforward:
    """Friction feedforward torque from a fixed estimate, with the estimated lag.

    Parameters
    ----------
    estimate : FrictionEstimate or None
        Friction parameters; ``None`` gives zero feedforward.
    dt : float, keyword-only
        Call period of :meth:`step` (s), e.g. the controller period.
    lag : bool, keyword-only
        Filter the static map through the estimated lag ``tau`` (eq. 1), default True.
    ff_max : float, keyword-only
        Bound on |feedforward| (N·m), default inf.
    sign_width : float, keyword-only
        Treatment of the sign near zero velocity (rad/s): 0 (default) uses
        ``sgn(w)``; ``> 0`` the linear ramp ``clip(w/sign_width, -1, 1)``, which
        stops measurement noise from flipping the full Coulomb torque.
    stick_band : float, keyword-only
        Velocity band (rad/s) for the stick detection: once the first velocity
        given to :meth:`step` (the measurement) has stayed inside
        ``±stick_band`` for ``stick_samples`` consecutive calls, the joint is
        taken as stuck and the second velocity (the reference: the intended
        direction of motion) is used instead, until the measurement leaves the
        band. A stuck joint's measured velocity is noise; its sign says
        nothing. Default 0 (off).
    stick_samples : int, keyword-only
        Consecutive in-band samples that declare sticking, >= 1; default 10.

    Raises
    ------
    ParameterError
        ``dt <= 0``, ``ff_max < 0``, ``sign_width < 0``, ``stick_band < 0`` or ``stick_samples < 1``.

    Notes
    -----
    ``u_ff`` follows ``tau*du_ff/dt + u_ff = F_hat(w)`` (eq. 1 with the estimate),
    discretised exactly for a held input: ``u_ff += (1 - exp(-dt/tau))*(F_hat(w) - u_ff)``.
    The constant ``offset`` of the estimate is not fed forward (it is a sensor
    or drive bias, not friction; the PI integrator removes it).
    """

    def __init__(self, estimate: FrictionEstimate | None, *, dt: float, lag: bool = True,
                 ff_max: float = math.inf, sign_width: float = 0.0, stick_band: float = 0.0,
                 stick_samples: int = 10):
        self.dt = check_positive("dt", dt)
        self.ff_max = float(ff_max) if ff_max == math.inf else check_nonnegative("ff_max", ff_max)
        self.lag = bool(lag)
        self.sign_width = check_nonnegative("sign_width", sign_width)
        self.stick_band = check_nonnegative("stick_band", stick_band)
        if isinstance(stick_samples, bool) or not isinstance(stick_samples, (int, np.integer)) or stick_samples < 1:
            raise ParameterError(f"stick_samples must be an integer >= 1, got {stick_samples!r}")
        self.stick_samples = int(stick_samples)
        self._n_in_band = 0
        self.u_ff = 0.0
        self.n_step_rejected = 0
        self._set(estimate)

    def _set(self, est: FrictionEstimate | None) -> None:
        self.estimate = est
        if est is None:
            self._alpha = 1.0
            return
        self._alpha = 1.0 - math.exp(-self.dt / est.tau) if (self.lag and est.tau > 0) else 1.0
        self._Fc, self._dF, self._sigma = est.Fc, est.Fs - est.Fc, est.sigma
        self._Vs, self._delta = est.Vs, est.delta

    def static(self, w: float) -> float:
        """Static friction estimate ``F_hat(w)`` (N·m), eq. 3 with the estimate (no offset)."""
        est = self.estimate
        if est is None or w == 0.0:
            return 0.0
        aw = abs(w)
        if self._Vs is None:
            mag = self._Fc
        else:
            mag = self._Fc + self._dF * math.exp(-((aw / self._Vs) ** self._delta))
        sw = self.sign_width
        if sw > 0.0 and aw < sw:
            return mag * (w / sw) + self._sigma * w
        return math.copysign(mag, w) + self._sigma * w

    def step(self, w: float, w_ref: float | None = None) -> float:
        """Advance one period; return the bounded feedforward (N·m).

        Parameters
        ----------
        w : float
            Velocity the friction map is evaluated at (rad/s), e.g. the measurement.
        w_ref : float, optional
            Used instead of ``w`` while the joint is detected as stuck (see
            ``stick_band``), e.g. the reference velocity.
        """
        held = min(max(self.u_ff, -self.ff_max), self.ff_max)
        if not math.isfinite(w) or (w_ref is not None and not math.isfinite(w_ref)):  # issue 12: rejected, held
            self.n_step_rejected += 1
            return held
        n_in_band = self._n_in_band
        if w_ref is not None:
            if -self.stick_band < w < self.stick_band:
                n_in_band += 1
                if n_in_band >= self.stick_samples:
                    w = w_ref
            else:
                n_in_band = 0
        f = self.static(w)
        if not math.isfinite(f):
            self.n_step_rejected += 1
            return held
        self._n_in_band = n_in_band
        self.u_ff += self._alpha * (f - self.u_ff)
        return min(max(self.u_ff, -self.ff_max), self.ff_max)


class AdaptiveFrictionFeedforward(FrictionFeedforward):
    """Adaptive friction feedforward: RLS (eqs. 10-13) on the sampled (u, w) stream drives the feedforward.

    Parameters
    ----------
    model : RegressionModel
        Regression structure, with Vs, delta from the pre-fit (Sec. V-C).
    Ts : float, keyword-only
        Sample time of the (u, w) stream fed to :meth:`observe` (s).
    dt : float, keyword-only
        Call period of :meth:`step` (s).
    lam : float, keyword-only
        RLS forgetting factor in (0, 1]; default 0.995 (memory ``Ts/(1-lam)``,
        2 s at Ts = 10 ms). The paper's 0.85 suits offline replay of noisy data,
        not a loop that must hold its estimate through slow phases.
    P0 : float, keyword-only
        Initial RLS covariance scale, default 1e4.
    warmup : int, keyword-only
        Accepted samples before the feedforward is switched on, default 300
        (the paper's RLS transient lasts about 4 s).
    lag, ff_max : see :class:`FrictionFeedforward`; estimates with ``Fc`` or
        ``Fs`` above ``ff_max`` are treated as implausible.
    tau_max : float, keyword-only
        Upper projection bound of ``tau`` (s), default 1.

    Attributes
    ----------
    rls : RecursiveLeastSquares
        The estimator (public ``theta``, ``P``).
    n_rejected : int
        Samples refused (non-finite ``u`` or ``w``); they leave the state unchanged.
    n_implausible : int
        RLS updates whose estimate could not be projected (held the previous one).

    Raises
    ------
    ParameterError
        Invalid hyperparameters (message quotes the value).

    Notes
    -----
    At each sample ``k``: ``phi(k)`` from eq. 4 with the stored ``u(k-1)``,
    ``w(k-1)``, ``w(k-2)``; RLS update; ``theta`` mapped to physical
    parameters (inverse map in :mod:`adaptive_ff.identification.regression`), projected by
    :func:`project_estimate`; the feedforward uses the last admissible estimate.
    """

    def __init__(self, model: RegressionModel, *, Ts: float, dt: float, lam: float = 0.995, P0: float = 1e4,
                 warmup: int = 300, lag: bool = True, ff_max: float = math.inf, tau_max: float = 1.0):
        super().__init__(None, dt=dt, lag=lag, ff_max=ff_max)
        self.model = model
        self.Ts = check_positive("Ts", Ts)
        if isinstance(warmup, bool) or not isinstance(warmup, (int, np.integer)) or warmup < 0:
            raise ParameterError(f"warmup must be an integer >= 0, got {warmup!r}")
        self.warmup = int(warmup)
        self.tau_max = check_positive("tau_max", tau_max)
        self.rls = RecursiveLeastSquares(model.n_params, lam=lam, P0=P0)
        self._past: list[float] | None = None  # [u(k-1), w(k-1), w(k-2)]
        self.n_rejected = 0
        self.u_range, self.w_range = Range(), Range(floor=model.Vs if model.stribeck else 0.0)
        self.n_implausible = 0

    @property
    def theta(self) -> np.ndarray:
        """Current RLS parameter vector, shape (p,)."""
        return self.rls.theta

    def observe(self, u: float, w: float) -> bool:
        """Feed one sample ``(u(k), w(k))`` taken ``Ts`` after the previous one.

        Parameters
        ----------
        u : float
            Torque applied just before the sample (N·m).
        w : float
            Measured velocity (rad/s).

        Returns
        -------
        bool
            True if the sample was used, False if rejected (non-finite); a
            rejected sample changes no state except ``n_rejected``.
        """
        u = float(u)
        w = float(w)
        uok, wok = self.u_range.ok(u), self.w_range.ok(w)
        if not (uok and wok):
            if not uok:
                self.u_range.commit(u, False)
            if not wok:
                self.w_range.commit(w, False)
            self.n_rejected += 1
            return False
        past = self._past
        if past is None:
            self.u_range.commit(u, True)
            self.w_range.commit(w, True)
            self._past = [u, w, w]
            return True
        u1, w1, w2 = past
        with np.errstate(over="ignore", invalid="ignore"):
            phi = self.model.phi(u, u1, w1, w2)
        if not np.all(np.isfinite(phi)) or rls_try(self.rls, phi, w) is None:
            self.n_rejected += 1
            return False
        self.u_range.commit(u, True)
        self.w_range.commit(w, True)
        self._past = [u, w, w1]
        if self.rls.n_updates >= self.warmup:
            est = project_estimate(self.model.to_physical(self.rls.theta, self.Ts), tau_max=self.tau_max,
                                   F_max=self.ff_max)
            if est is None:
                self.n_implausible += 1
            else:
                self._set(est)
        return True
