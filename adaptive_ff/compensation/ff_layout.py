"""Array layout of the fixed friction feedforward: the slots of its ``params`` and ``state``.

:class:`adaptive_ff.compensation.feedforward.FrictionFeedforward` is a :class:`plant.component.Component`: its
configuration and its state are two float64 arrays. The compiled kernels of three modules read and write the same
slots: the feedforward's own (:mod:`adaptive_ff.compensation.feedforward`), those of the loop model and the sign
observer that give it its velocity input near standstill (:mod:`adaptive_ff.compensation.velocity_input`), and
those of the adaptive feedforward, whose arrays begin with the fixed one's
(:mod:`adaptive_ff.compensation.adaptive_feedforward`). This module is the one definition of the layout::

    params: DT (call period, s), LAG (filter through the lag, 1/0), FFMAX (bound on |feedforward|, N·m),
            SW (sign ramp width, rad/s), SBAND (stick band, rad/s), SSAMP (in-band samples that declare
            sticking), REF (1: evaluated at the reference), WMAX (largest plausible speed, rad/s),
            loop model: LM (has one, 1/0), KP (Kp), KITC (Ki*dt), BJ (dt/J), LMA (tracking gain),
            sign observer: OB (has one, 1/0), OBJ (dt/J), OBL (gain l1), OBZ (gain l2)
    state:  estimate in use: HAS (1/0), FC (Fc), DF (Fs - Fc), VS (Vs), DELTA (delta), SIGMA (sigma),
            ALPHA (lag filter gain), HASVS (has Vs, 1/0), TAU (tau),
            UFF (output filter), NIB (in-band count), FNREJ (rejected inputs),
            loop model: WM (velocity), IM (integrator), NM (started, 1/0), DW (tracked deviation),
            sign observer: WH (estimate), OBN (started, 1/0), WCS (the controller's measurement of this
            period), UOUT (the compensator's output of this period), ZH (residual estimate)

The slot names have no leading underscore because these modules share them; :mod:`adaptive_ff` exports none.
"""

from __future__ import annotations

__all__ = ["FF_NPAR", "FF_NSTATE", "DT", "LAG", "FFMAX", "SW", "SBAND", "SSAMP", "REF", "WMAX", "LM", "KP", "KITC",
           "BJ", "LMA", "OB", "OBJ", "OBL", "OBZ", "HAS", "FC", "DF", "VS", "DELTA", "SIGMA", "ALPHA", "HASVS", "TAU",
           "UFF", "NIB", "FNREJ", "WM", "IM", "NM", "DW", "WH", "OBN", "WCS", "UOUT", "ZH"]

DT, LAG, FFMAX, SW, SBAND, SSAMP, REF, WMAX, LM, KP, KITC, BJ, LMA, OB, OBJ, OBL, OBZ = range(17)
(HAS, FC, DF, VS, DELTA, SIGMA, ALPHA, HASVS, TAU, UFF, NIB, FNREJ, WM, IM, NM, DW,
 WH, OBN, WCS, UOUT, ZH) = range(21)
#: Lengths of the fixed feedforward's parameter and state arrays.
FF_NPAR, FF_NSTATE = 17, 21
