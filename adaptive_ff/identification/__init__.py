"""Identification of sliding friction: the discrete-time regression (eqs. 4-6), LS (eq. 9), RLS (eqs. 10-13), the Stribeck pre-fit (Sec. V-C), output-error, IDIM and online UKF fits."""
