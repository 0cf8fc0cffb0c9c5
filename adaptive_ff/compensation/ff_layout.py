"""Array layout of the fixed friction feedforward: the slots of its ``params`` and ``state``.

:class:`adaptive_ff.compensation.feedforward.FrictionFeedforward` is a :class:`plant.component.Component`: its
configuration and its state are two float64 arrays. The compiled kernels of three modules read and write the same
slots: the feedforward's own (:mod:`adaptive_ff.compensation.feedforward`), those of the loop model and the sign
observer that give it its velocity input near standstill (:mod:`adaptive_ff.compensation.velocity_input`), and
those of the adaptive feedforward, whose arrays begin with the fixed one's
(:mod:`adaptive_ff.compensation.adaptive_feedforward`). This module is the one definition of the layout::

    params: P_DT (call period, s), P_LAG (filter through the lag, 1/0), P_FFMAX (bound on |feedforward|, N·m),
            P_SW (sign ramp width, rad/s), P_SBAND (stick band, rad/s), P_SSAMP (in-band samples that declare
            sticking), P_REF (1: evaluated at the reference), P_WMAX (largest plausible speed, rad/s),
            loop model: P_LM (has one, 1/0), P_KP (Kp), P_KITC (Ki*dt), P_BJ (dt/J), P_LMA (tracking gain),
            sign observer: P_OB (has one, 1/0), P_OBJ (dt/J), P_OBL (gain l1), P_OBZ (gain l2)
    state:  estimate in use: S_HAS (1/0), S_FC (Fc), S_DF (Fs - Fc), S_VS (Vs), S_DELTA (delta), S_SIGMA (sigma),
            S_ALPHA (lag filter gain), S_HASVS (has Vs, 1/0), S_TAU (tau),
            S_UFF (output filter), S_NIB (in-band count), S_FNREJ (rejected inputs),
            loop model: S_WM (velocity), S_IM (integrator), S_NM (started, 1/0), S_DW (tracked deviation),
            sign observer: S_WH (estimate), S_OBN (started, 1/0), S_WCS (the controller's measurement of this
            period), S_UOUT (the compensator's output of this period), S_ZH (residual estimate)

The slot names (``P_`` a slot of ``params``, ``S_`` one of ``state``) have no leading underscore because these
modules share them; :mod:`adaptive_ff` exports none.
"""

from __future__ import annotations

__all__ = ["FF_NPAR", "FF_NSTATE", "P_DT", "P_LAG", "P_FFMAX", "P_SW", "P_SBAND", "P_SSAMP", "P_REF", "P_WMAX", "P_LM",
           "P_KP", "P_KITC", "P_BJ", "P_LMA", "P_OB", "P_OBJ", "P_OBL", "P_OBZ", "S_HAS", "S_FC", "S_DF", "S_VS",
           "S_DELTA", "S_SIGMA", "S_ALPHA", "S_HASVS", "S_TAU", "S_UFF", "S_NIB", "S_FNREJ", "S_WM", "S_IM", "S_NM",
           "S_DW", "S_WH", "S_OBN", "S_WCS", "S_UOUT", "S_ZH"]

(P_DT, P_LAG, P_FFMAX, P_SW, P_SBAND, P_SSAMP, P_REF, P_WMAX, P_LM, P_KP, P_KITC, P_BJ, P_LMA, P_OB, P_OBJ,
 P_OBL, P_OBZ) = range(17)
(S_HAS, S_FC, S_DF, S_VS, S_DELTA, S_SIGMA, S_ALPHA, S_HASVS, S_TAU, S_UFF, S_NIB, S_FNREJ, S_WM, S_IM, S_NM,
 S_DW, S_WH, S_OBN, S_WCS, S_UOUT, S_ZH) = range(21)
#: Lengths of the fixed feedforward's parameter and state arrays.
FF_NPAR, FF_NSTATE = 17, 21
