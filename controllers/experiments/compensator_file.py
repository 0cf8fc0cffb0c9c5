"""Mode ``adaptive``'s compensator configured from an identification file, as ``compare`` configures it: what
``adaptive-ff export-c --from`` writes for a drive and ``compare-arm`` runs per joint."""

from __future__ import annotations

import math

from controllers.design.pi import PITuning

__all__ = ["compensator_from_file", "read_identified"]


def _number(d: dict, key: str, path, *, required: bool = True):
    """``d[key]`` as a finite float; ParameterError naming the file and the key otherwise (None if absent and not
    ``required``)."""
    from plant.errors import ParameterError

    v = d.get(key)
    if v is None:
        if required:
            raise ParameterError(f"{path}: no {key!r} (a number) in the identification")
        return None
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ParameterError(f"{path}: {key!r} must be a finite number, got {v!r}")
    return float(v)


def read_identified(path, arm_joint=None):
    """The :class:`adaptive_ff.identification.result_file.IdentifiedJoint` of an ``identify --json`` output (the
    parameters of the method that gave the answer, in either file layout), or of the joint ``arm_joint`` of an
    ``identify-arm --json`` output.

    Raises
    ------
    ParameterError
        The file is not an identification (named), or has no joint ``arm_joint``.
    FileNotFoundError
        No such file.
    """
    from adaptive_ff.arm.result import read_arm_joint
    from adaptive_ff.identification.result_file import identification_from_dict, read_identification

    if arm_joint is None:
        return read_identification(path)
    return identification_from_dict(read_arm_joint(path, arm_joint), where=f"{path} joint {arm_joint!r}")


def _stribeck_shape(ident, params: dict, Vs, delta) -> tuple:
    """``(Vs, delta, notes)`` of the compensator of ``ident``: the given ``Vs``, ``delta`` (None: the file's);
    without a Stribeck term in the file (``Vs`` null or absent, ``Fs`` null, absent or equal to ``Fc``) ``Fs = Fc``
    (set in ``params``) and the placeholders of :func:`adaptive_ff.identification.stribeck_fit.placeholder_shape`
    at the file's lowest measured speed (``excitation.min_speed``) for what is not given, with a note."""
    from adaptive_ff.identification.stribeck_fit import placeholder_shape
    from plant.errors import ParameterError

    path = ident.source
    top = {k: v for k, v in (("Vs", ident.Vs), ("delta", ident.delta)) if v is not None and math.isfinite(v)}
    Fc, Fs = params.get("Fc"), params.get("Fs")
    if "Vs" in top or (Fs is not None and Fc is not None and Fs != Fc) or Fc is None:
        Vs = _number(top, "Vs", path) if Vs is None else Vs
        return Vs, (_number(top, "delta", path) if delta is None else delta), ()
    params["Fs"] = Fc  # no Stribeck term: Fs = Fc
    if Vs is None:
        slowest = ident.min_speed
        if slowest is None or not (math.isfinite(slowest) and slowest > 0.0):
            raise ParameterError(f"{path}: no Stribeck term ('Vs' null) and no lowest measured speed "
                                 "('excitation.min_speed') for its placeholder Vs: give Vs (--Vs)")
        Vs, d0 = placeholder_shape([slowest])
        how = f"placeholder Vs = {Vs:.4g} rad/s (the lowest measured speed)"
    else:
        d0, how = placeholder_shape([Vs])[1], f"Vs = {Vs:.4g} rad/s (given)"
    delta = top.get("delta", d0) if delta is None else delta
    note = (f"{path}: no Stribeck term identified: Fs = Fc = {Fc:.4g} N·m, {how}, delta = {delta:.4g} (the rule of "
            "compare's pre-fit without a Stribeck effect); the adaptive estimator learns any Fs - Fc with that shape")
    return Vs, delta, (note,)


def compensator_from_file(path, *, u_max: float, pi: PITuning = PITuning(), start: bool = False, initial: bool = True,
                          feedforward_only: bool = False, arm_joint: str | None = None, **options):
    """The ``adaptive`` mode's compensator configured from an ``identify --json`` file, as ``compare`` configures it.

    Parameters
    ----------
    path : str or os.PathLike
        The identification (``adaptive-ff identify ... --Vs --delta --json``): ``Vs``, ``delta`` at its top level
        (null or absent with ``Fs`` null, absent or equal to ``Fc``: no Stribeck term, see Notes),
        ``J``, ``sigma``, ``Fc``, ``Fs``, ``tau`` of the chosen method at its top level (a file written before
        that layout: in ``physical.params``; read by
        :func:`adaptive_ff.identification.result_file.read_identification`), the velocity noise in
        ``excitation.noise_std`` (optional).
    u_max : float, keyword-only
        The drive's torque limit (N·m): the velocity gate's bound; the feedforward's bound is half of it (as in
        ``compare``) unless ``ff_max`` is given.
    pi : PITuning, keyword-only
        The PI (the nominal loop model of the stick fallback and the example loop,
        :class:`controllers.design.pi.PITuning`): its gains ``Kp``, ``Ki``, or (default) the
        :func:`controllers.design.pi.design_pi` of the identified ``J`` and ``sigma`` at its ``crossover`` (rad/s,
        default 20) and ``phase_margin`` (deg, default 60), as ``design --from`` does.
    start : bool, keyword-only
        Use the identified map (``Fc``, ``Fs``, ``sigma``, ``tau``) as the provisional start
        (:class:`adaptive_ff.compensation.adaptive_feedforward.FeedforwardStart`, at the measured velocity).
    initial : bool, keyword-only
        Start the estimator's RLS from the identified ``Fc``, ``Fs``, ``sigma`` and ``J_design`` (default, as
        ``compare`` starts it from its pre-fit) instead of zero friction.
    feedforward_only : bool, keyword-only
        The feedforward alone: no residual observer, no supervisor (default False: the whole mode).
    arm_joint : str, keyword-only
        ``path`` is an ``identify-arm --json`` output: the compensator of this joint's entry (the layout of
        ``identify --json``; :func:`adaptive_ff.arm.result.read_arm_joint`).
    **options
        Flat settings of :meth:`controllers.simulation.loop_config.LoopConfig.from_flat` that override the defaults: ``Tc``
        (1 ms), ``Ts`` (10 ms), ``J_design`` (the identified ``J``), ``Vs``, ``delta`` (the file's), ``ff_max``
        (``u_max/2``), ``stick_band`` (three times the identification's noise estimate,
        :func:`controllers.simulation.loop_config.stick_band_for`; 0 without one),
        ``stick_samples`` (50), ``warmup`` (50), ``omega_r`` (the residual observer's cut-off,
        :func:`controllers.experiments.observer_design.residual_cutoff` of the design inertia, the noise estimate
        and the identified friction level ``max(Fc, Fs)``), ...

    Returns
    -------
    compensator : AdaptiveCompensator
        Mode ``adaptive``'s compensator (:class:`controllers.peers.adaptive_dob.AdaptiveCompensator`), not yet
        stepped.
    settings : dict
        ``J_design, u_max, Kp, Ki`` and ``joint`` (the identified ``Fc``, ``Fs``, ``sigma`` that are finite and
        >= 0) for :func:`adaptive_ff.compensation.export_c.export_c`, ``options`` (the LoopConfig used) and
        ``notes`` (tuple of str: what was assumed, e.g. the placeholders of a joint without a Stribeck term).

    Raises
    ------
    ParameterError
        Unreadable or invalid file (the file and the key named), a bad setting, ``pi`` not a :class:`PITuning`,
        a joint without a Stribeck term whose file gives no ``excitation.min_speed`` and no ``Vs`` option.
    FileNotFoundError
        No such file.

    Notes
    -----
    A joint without a Stribeck term (``Fs = Fc``; ``identify-arm`` drops it where it does not lower the residual
    beyond its likelihood-ratio bound) gets ``Fs = Fc`` and the placeholders of ``compare``'s pre-fit without a
    Stribeck effect (:func:`adaptive_ff.identification.stribeck_fit.placeholder_shape`): ``Vs`` the lowest
    measured speed (``excitation.min_speed``) unless ``Vs`` is given, ``delta`` 1 unless given; ``notes`` says so.
    """
    from adaptive_ff.compensation.adaptive_feedforward import FeedforwardStart
    from adaptive_ff.identification.regression import FrictionEstimate
    from controllers.simulation.compensators import build_mode
    from controllers.simulation.loop_config import FLAT_PATHS, LoopConfig, stick_band_for
    from plant.errors import ParameterError

    from controllers.experiments.observer_design import residual_cutoff

    known = set(FLAT_PATHS) - {"Kp", "Ki", "u_max", "start", "initial"}
    unknown = sorted(set(options) - known)
    if unknown:
        raise ParameterError(f"unknown option(s) {unknown}; allowed: the loop settings of LoopConfig.from_flat {sorted(known)}")
    ident = read_identified(path, arm_joint)
    path = ident.source  # the file, or the file and the joint: what the messages name
    params = {k: v for k, v in ident.params.items() if math.isfinite(v)}  # a null (non-finite) value: absent
    Vs, delta, notes = _stribeck_shape(ident, params, options.pop("Vs", None), options.pop("delta", None))
    J_id, sigma_id = ident.J, ident.sigma
    J_design = options.pop("J_design", None)
    if J_design is None:
        if not (math.isfinite(J_id) and J_id > 0.0):
            raise ParameterError(f"{path}: the identified J = {J_id!r} kg·m² is not > 0; give --J-design")
        J_design = J_id
    if not isinstance(pi, PITuning):
        raise ParameterError(f"pi must be a PITuning, got {type(pi).__name__}")
    Tc = options.get("Tc", 1e-3)
    Kp, Ki = pi.gains(J_design, sigma=max(sigma_id, 0.0), Tc=Tc)
    joint = {}
    for k in ("Fc", "Fs", "sigma"):
        v = _number(params, k, path, required=False)
        if v is not None and v >= 0.0:
            joint[k] = v
    noise = ident.noise_std if ident.noise_std is not None and math.isfinite(ident.noise_std) else None
    first = None
    if start:
        e = {k: _number(params, k, path) for k in ("Fc", "Fs", "sigma", "tau")}
        first = FeedforwardStart(FrictionEstimate(J=J_design, tau=e["tau"], sigma=e["sigma"], Fc=e["Fc"], Fs=e["Fs"],
                                                  offset=0.0, Vs=None, delta=None, J_alt=math.nan),
                                 ff_input="measured")
    init = None
    if initial:
        init = FrictionEstimate(J=J_design, tau=0.0, sigma=joint.get("sigma", 0.0), Fc=joint.get("Fc", 0.0),
                                Fs=joint.get("Fs", 0.0), offset=0.0, Vs=Vs, delta=delta, J_alt=math.nan)
    level = max(joint.get("Fc", 0.0), joint.get("Fs", 0.0))
    settings = {"ff_max": 0.5 * u_max, "stick_band": stick_band_for(noise) if noise is not None and noise >= 0 else 0.0,
                "stick_samples": 50, "warmup": 50,
                "omega_r": residual_cutoff(J_design, noise or 0.0, Tc, level), **options}
    if feedforward_only:  # the feedforward alone: aff_adaptive without the observer and the supervisor
        settings.update(switch_in=False, supervise=False)
    opts = LoopConfig.from_flat(Kp=Kp, Ki=Ki, u_max=u_max, J_design=J_design, Vs=Vs, delta=delta, start=first,
                                initial=init, **settings)
    _, _, comp = build_mode(None, "adaptive", opts)  # None: no plant field is read with J_design given
    return comp, {"J_design": J_design, "u_max": u_max, "Kp": Kp, "Ki": Ki, "joint": joint, "options": opts,
                  "notes": notes}
