"""The robustness matrix: plant variants of the ``paper`` preset, each changing one thing.

Each variant is the ``paper`` preset (:data:`plant.friction.PRESETS`) with one
model change, so that a loss of compensation quality points at its cause:

==================  ============================================================================
name                change from the ``paper`` preset
==================  ============================================================================
``lugre``           LuGre friction with pre-sliding instead of the lag (same Fc, Fs, Vs; delta = 2
                    as in Canudas de Wit et al. 1995; sigma0 = 5e4 N·m/rad, i.e. a pre-sliding
                    deflection Fc/sigma0 = 0.5 mrad; sigma1 = sqrt(sigma0*J) = 447 N·m·s/rad;
                    sigma2 = sigma = 40 N·m·s/rad)
``karnopp``         true sticking: Karnopp stick band of half-width dv = 5 mrad/s (Vs/4)
``asymmetric``      negative direction weaker: Fc 18, Fs 25 N·m, sigma 30 N·m·s/rad for w < 0
``small-inertia``   J = 0.4 kg·m² (10x smaller: the motor and gear side without the arm);
                    the PI is redesigned for it (same crossover and phase margin)
``long-lag``        tau = 80 ms (4x)
``negative-delta``  delta = -1: friction rises from Fc at standstill towards Fs at speed
``static``          tau = 0: friction is the static map (no lag)
==================  ============================================================================

:func:`drift_case` is the time-varying case of the benchmark: Fc and Fs of the
preset rise by 50 % over the first half of the run (warming).
"""

from __future__ import annotations

from plant.asymmetric import AsymmetricParams
from plant.drift import FrictionDrift
from plant.errors import ParameterError, check_positive
from plant.friction import preset
from plant.karnopp import KarnoppParams
from plant.lugre import LuGreParams

__all__ = ["VARIANT_NAMES", "variant", "variants", "drift_case"]

#: Names of the variants, in table order.
VARIANT_NAMES = ("lugre", "karnopp", "asymmetric", "small-inertia", "long-lag", "negative-delta", "static")


def variant(name: str):
    """The named plant variant of the ``paper`` preset (see the module docstring).

    Raises
    ------
    ParameterError
        Unknown name (the known names are listed).
    """
    p = preset("paper")
    if name == "lugre":
        sigma0 = 5e4
        return LuGreParams(J=p.J, Fc=p.Fc, Fs=p.Fs, Vs=p.Vs, delta=2.0, sigma0=sigma0,
                           sigma1=round((sigma0 * p.J) ** 0.5), sigma2=p.sigma)
    if name == "karnopp":
        return KarnoppParams(J=p.J, Fc=p.Fc, Fs=p.Fs, Vs=p.Vs, delta=p.delta, sigma=p.sigma, tau=p.tau, dv=0.25 * p.Vs)
    if name == "asymmetric":
        return AsymmetricParams(J=p.J, Fc_pos=p.Fc, Fc_neg=18.0, Fs_pos=p.Fs, Fs_neg=25.0, Vs=p.Vs, delta=p.delta,
                                sigma_pos=p.sigma, sigma_neg=30.0, tau=p.tau)
    if name == "small-inertia":
        return p.replace(J=0.4)
    if name == "long-lag":
        return p.replace(tau=0.08)
    if name == "negative-delta":
        return p.replace(delta=-1.0)
    if name == "static":
        return p.replace(tau=0.0)
    raise ParameterError(f"unknown plant variant {name!r}; known: {list(VARIANT_NAMES)}")


def variants() -> dict:
    """``{name: plant}`` for all of :data:`VARIANT_NAMES`."""
    return {name: variant(name) for name in VARIANT_NAMES}


def drift_case(duration: float = 120.0, *, change: float = 0.5):
    """The ``paper`` preset with Fc and Fs rising by ``change`` (relative) over the first half of ``duration`` (s).

    Raises
    ------
    ParameterError
        ``duration`` not > 0.
    """
    duration = check_positive("duration", duration)
    return FrictionDrift(preset("paper"), Fc_change=change, Fs_change=change, t_start=0.0, t_end=0.5 * duration)
