"""Plausibility gate for a sampled measurement: rejects non-finite samples and physically impossible jumps."""

from __future__ import annotations

import math

from plant.errors import ParameterError, check_nonnegative, check_positive

__all__ = ["OutlierGate"]


class OutlierGate:
    """Reject non-finite samples and outlier spikes of a sampled signal (e.g. the measured velocity).

    Parameters
    ----------
    max_step : float, keyword-only
        Largest physically possible change between two consecutive samples, in
        the signal's unit (for a velocity: peak acceleration times the sample
        period, rad/s), >= 0. Default ``inf``: only non-finite samples are rejected.
    n_sigma : float, keyword-only
        Width of the noise allowance in units of the running mean absolute
        sample-to-sample change, > 0; default 8.
    alpha : float, keyword-only
        Smoothing factor of that running mean, in (0, 1]; default 0.01.
    max_consecutive : int, keyword-only
        After this many consecutive outlier rejections the next finite sample
        is accepted again (the signal really moved, e.g. after a re-start);
        default 20.

    Attributes
    ----------
    last : float or None
        Last accepted value.
    scale : float
        Running mean of ``|x(k) - x(k-1)|`` over accepted samples.
    n_rejected, n_nonfinite, n_outliers : int
        Rejections in total, of them non-finite and outlier spikes.

    Raises
    ------
    ParameterError
        Invalid settings (the message quotes the value).

    Notes
    -----
    A finite sample ``x`` is an outlier if
    ``|x - last| > (max_step + n_sigma*scale) * (1 + n_held)`` with ``n_held``
    the number of samples rejected since ``last`` (the bound grows with the
    time since the last accepted sample). This is a validation gate on the
    innovation (the "gating" of target tracking: Bar-Shalom, Li,
    Kirubarajan, *Estimation with Applications to Tracking and Navigation*,
    Wiley 2001) with the innovation predicted by the last accepted sample, a
    physical bound on its size and a running noise scale (updated only by
    accepted samples, so a burst of spikes cannot widen the gate).
    """

    __slots__ = ("max_step", "n_sigma", "alpha", "max_consecutive", "last", "scale", "n_held",
                 "n_rejected", "n_nonfinite", "n_outliers")

    def __init__(self, *, max_step: float = math.inf, n_sigma: float = 8.0, alpha: float = 0.01,
                 max_consecutive: int = 20):
        if max_step != math.inf:
            max_step = check_nonnegative("max_step", max_step)
        self.max_step = float(max_step)
        self.n_sigma = check_positive("n_sigma", n_sigma)
        alpha = check_positive("alpha", alpha)
        if alpha > 1.0:
            raise ParameterError(f"alpha must be in (0, 1], got {alpha!r}")
        self.alpha = alpha
        if isinstance(max_consecutive, bool) or not isinstance(max_consecutive, int) or max_consecutive < 1:
            raise ParameterError(f"max_consecutive must be an integer >= 1, got {max_consecutive!r}")
        self.max_consecutive = max_consecutive
        self.last: float | None = None
        self.scale = 0.0
        self.n_held = 0
        self.n_rejected = 0
        self.n_nonfinite = 0
        self.n_outliers = 0

    def __repr__(self) -> str:
        return (f"OutlierGate(max_step={self.max_step!r}, n_sigma={self.n_sigma!r}, "
                f"n_rejected={self.n_rejected})")

    def check(self, x: float) -> bool:
        """Return True and accept ``x`` if it is plausible; False (counted) if it is rejected.

        Parameters
        ----------
        x : float
            The new sample.

        Returns
        -------
        bool
            Acceptance. A rejected sample changes only the counters.
        """
        x = float(x)
        if not math.isfinite(x):
            self.n_rejected += 1
            self.n_nonfinite += 1
            self.n_held += 1
            return False
        last = self.last
        if last is None:
            self.last = x
            return True
        d = x - last if x >= last else last - x
        bound = (self.max_step + self.n_sigma * self.scale) * (1 + self.n_held)
        if d > bound:
            if self.n_held < self.max_consecutive:
                self.n_rejected += 1
                self.n_outliers += 1
                self.n_held += 1
                return False
        else:
            self.scale += self.alpha * (d - self.scale)
        self.last = x
        self.n_held = 0
        return True
