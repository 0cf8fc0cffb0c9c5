"""An arm's compensators as one C library: mode ``adaptive``'s compensator per joint (:func:`export_c_arm`,
``adaptive-ff export-c --from arm.json``).

The folder has the files of a one-joint export (:mod:`adaptive_ff.compensation.export_c`; the same ``aff.h`` and
``aff.c``, the same ``Makefile``), with the settings of every joint:

==================  ===================================================================================
file                content
==================  ===================================================================================
``aff_config.h``    ``AFF_N_JOINTS``, the joints' indices ``AFF_JOINT_<NAME>`` (an enum) and names
                    (``AFF_JOINT_NAMES_INIT``, the strings of the identification), the settings as macros:
                    one macro where every joint has the same value (``AFF_TC``), else one per joint
                    (``AFF_ELBOW_VS``); ``extern const aff_config AFF_CONFIGS[AFF_N_JOINTS]``
``aff_config.c``    ``AFF_JOINT_NAMES`` and ``AFF_CONFIGS``: one C99 designated initializer per joint, each what
                    the one-joint export of that joint writes as its ``AFF_CONFIG``
``example_loop.c``  the loop of the one-joint example over an array ``aff comp[AFF_N_JOINTS]``, each joint a stub
                    of its own (no coupling), its own PI
==================  ===================================================================================

A drive runs ``aff_init(&comp[j], &AFF_CONFIGS[j])`` once per joint and then, per period, ``aff_step`` and
``aff_observe`` of each joint with that joint's velocity and torque.
"""

from __future__ import annotations

import re

from plant.errors import ParameterError

from adaptive_ff.compensation.export_c import (EXPORT_FILES, HOLD_TIME_DEFAULT, MACRO_FIELDS, MAKEFILE,
                                               W_MAX_DEFAULT, CExport, amalgamate, banner, c_closure, c_comment, c_literal,
                                               JointExport, export_settings, field_comments, macro_lines,
                                               prepare_out, struct_initializer)

__all__ = ["JointExport", "export_c_arm", "c_identifier"]


def c_identifier(name: str) -> str:
    """The upper-case C identifier part of a joint name: letters, digits and ``_`` kept, anything else ``_``, a
    leading digit prefixed by ``J`` (``"joint-1"`` -> ``"JOINT_1"``)."""
    s = re.sub(r"\W", "_", str(name), flags=re.ASCII).upper() or "J"
    return "J" + s if s[0].isdigit() else s


def _joint_ids(names) -> list:
    """Distinct C identifiers of the joints (a clash gets the joint's index appended)."""
    ids = [c_identifier(n) for n in names]
    return [f"{i}_{k}" if ids.count(i) > 1 else i for k, i in enumerate(ids)]


def _macros(settings, ids) -> tuple:
    """``(common, per_joint)``: the macros whose value every joint shares (``{name: value}``), and per joint
    ``{AFF_<ID>_<REST>: (value, original name)}`` for the others."""
    keys = list(settings[0].config)
    common = {k: settings[0].config[k] for k in keys
              if all(k in s.config and s.config[k] == settings[0].config[k] for s in settings)}
    per_joint = []
    for s, jid in zip(settings, ids):
        per_joint.append({f"AFF_{jid}_{k[4:]}": (v, k) for k, v in s.config.items() if k not in common})
    return common, per_joint


def _string_literal(text: str) -> str:
    """A C string literal of ``text`` (ASCII escapes; other characters as octal bytes of UTF-8)."""
    out = []
    for b in str(text).encode("utf-8"):
        ch = chr(b)
        out.append(f"\\{ch}" if ch in '"\\' else ch if 32 <= b < 127 else f"\\{b:03o}")
    return '"' + "".join(out) + '"'


def _config_header(names, ids, common, per_joint, origin) -> str:
    lines = [banner("aff_config.h", "the settings of this export: the joints, macros and AFF_CONFIGS.", origin,
                    "yours to edit (a value, then rebuild)"),
             "#ifndef AFF_CONFIG_H", "#define AFF_CONFIG_H", '#include "aff.h"', "",
             "/* The joints of this export, in the identification's order: AFF_CONFIGS[AFF_JOINT_ELBOW] is the",
             " * settings of the joint named AFF_JOINT_NAMES[AFF_JOINT_ELBOW]. */",
             f"#define AFF_N_JOINTS {len(names)}",
             "enum aff_joint {"]
    lines += [f"    AFF_JOINT_{i} = {k}, /* {_string_literal(n)} */" for k, (i, n) in enumerate(zip(ids, names))]
    lines += ["};", "#define AFF_JOINT_NAMES_INIT {" + ", ".join(_string_literal(n) for n in names) + "}", "",
              "/* SI units; the values this export was configured with: one macro where every joint has the same",
              " * value, else one per joint (AFF_<JOINT>_...). The fields of AFF_CONFIGS (aff_config.c) equal to a",
              " * macro are written with it: change the macro (or any value in aff_config.c) and rebuild, and",
              " * aff_init checks the settings and computes the compensator's derived fields from them. */"]
    for k, v in common.items():
        lines += ["", *macro_lines(k, v, scope="; every joint")]
    for name, macros in zip(names, per_joint):
        if macros:
            lines += ["", f"/* Joint {_string_literal(name)}. */"]
        for k, (v, orig) in macros.items():
            lines += macro_lines(k, v, field=orig)
    lines += ["", "/* The joints' names and the drive's settings per joint (aff_config.c):",
              " * aff_init(&c[j], &AFF_CONFIGS[j]). */",
              "extern const char *const AFF_JOINT_NAMES[AFF_N_JOINTS];",
              "extern const aff_config AFF_CONFIGS[AFF_N_JOINTS];", "", "#endif", ""]
    return "\n".join(lines)


def _config_source(inits, ids, names, origin, big, notes) -> str:
    no_float = ""
    if big:
        no_float = ("#ifdef AFF_FLOAT\n#error \"fields beyond the float range (" + ", ".join(big[:4])
                    + "): this export cannot be built with AFF_FLOAT\"\n#endif\n\n")
    body = ",\n".join(f"    /* joint {_string_literal(n)} */\n" + "".join(c_comment(f"Note: {x}", "    ") for x in nj)
                      + f"    [AFF_JOINT_{i}] = {init}" for i, n, init, nj in zip(ids, names, inits, notes))
    return (banner("aff_config.c", "AFF_CONFIGS, the drive's settings per joint as the package configured them.",
                   origin, "yours to edit (a value, then rebuild)")
            + '#include "aff_config.h"\n\n' + no_float
            + "const char *const AFF_JOINT_NAMES[AFF_N_JOINTS] = AFF_JOINT_NAMES_INIT;\n\n"
            + "/* The settings of mode adaptive (mode) and of the input guard (guard) of each joint, SI units, each\n"
              " * field with its header's comment (unit, range, default). aff_init checks them (a field out of its\n"
              " * range: an aff_error naming it, aff_error_message) and computes the derived fields. Edit a value and\n"
              " * rebuild; the fields written with a macro take it from aff_config.h. */\n"
            + f"const aff_config AFF_CONFIGS[AFF_N_JOINTS] = {{\n{body}\n}};\n")


def _array(values) -> str:
    return "{" + ", ".join(values) + "}"


def _example(joints, settings, ids, common, per_joint) -> str:
    """``example_loop.c``: the one-joint example's loop over the joints (each a stub of its own, its own PI)."""

    def macro(k, key):
        return key if key in common else f"AFF_{ids[k]}_{key[4:]}"

    rows = {"J": [macro(k, "AFF_J_DESIGN") for k in range(len(joints))],
            "U_MAX": [macro(k, "AFF_U_MAX") for k in range(len(joints))],
            "KP": [macro(k, "AFF_KP") for k in range(len(joints))],
            "KI": [macro(k, "AFF_KI") for k in range(len(joints))],
            "VS": [macro(k, "AFF_VS") for k in range(len(joints))],
            "DELTA": [macro(k, "AFF_DELTA") for k in range(len(joints))],
            "FC": [c_literal(s.stub["Fc"]) for s in settings],
            "FS": [c_literal(s.stub["Fs"]) for s in settings],
            "SIGMA": [c_literal(s.stub["sigma"]) for s in settings],
            "AMP": [c_literal(50.0 * float(j.compensator.feedforward.estimator.Vs)) for j in joints]}
    text = _EXAMPLE
    for key, values in rows.items():
        text = text.replace(f"@{key}@", _array(values))
    return text


def export_c_arm(joints, out, *, w_max: float = W_MAX_DEFAULT, hold_time: float = HOLD_TIME_DEFAULT,
                 float_default: bool = False, force: bool = False, origin: str = "") -> CExport:
    """Write an arm's compensators, one per joint, as one C library (the files: module docstring).

    Parameters
    ----------
    joints : sequence of JointExport
        The joints, in the order of ``AFF_CONFIGS``; distinct names; one controller period for all.
    out : str or os.PathLike
        Folder to write into (as :func:`adaptive_ff.compensation.export_c.export_c` takes it).
    w_max, hold_time, float_default, force, origin : keyword-only
        As :func:`adaptive_ff.compensation.export_c.export_c` takes them; the input guard's ``w_max`` and
        ``hold_time`` for every joint.

    Returns
    -------
    CExport
        ``config``: the macros of ``aff_config.h``; ``joints``: the joints' names.

    Raises
    ------
    ParameterError
        No joint, two joints of one name, joints of different controller periods, or what
        :func:`~adaptive_ff.compensation.export_c.export_settings` refuses of a joint (the joint named).
    """
    from adaptive_ff._caff import ffi
    from adaptive_ff.io.output import staged_folder

    joints = list(joints)
    names = [j.name for j in joints]
    if not joints:
        raise ParameterError("export_c_arm: no joint to export")
    if len(set(names)) != len(names):
        raise ParameterError(f"export_c_arm: joint names must be distinct, got {names}")
    settings = []
    for j in joints:
        try:
            settings.append(export_settings(j, w_max=w_max, hold_time=hold_time))
        except ParameterError as exc:
            raise ParameterError(f"joint {j.name!r}: {exc}") from None
    periods = {s.config["AFF_TC"] for s in settings}
    if len(periods) > 1:
        raise ParameterError(f"export_c_arm: the joints' controller periods differ ({sorted(periods)} s); one "
                             "library runs every joint in one period")
    ids = _joint_ids(names)
    common, per_joint = _macros(settings, ids)
    headers, sources = c_closure()
    out = prepare_out(out, force)
    comments = field_comments(headers)
    big: list = []
    inits = []
    for s, pj in zip(settings, per_joint):
        macros = {k: (v, names_) for k, (v, names_) in s.macros.items() if k in common}
        macros.update({k: (v, MACRO_FIELDS[orig]) for k, (v, orig) in pj.items() if orig in MACRO_FIELDS})
        inits.append(struct_initializer(ffi, s.drive[0], ffi.typeof(s.drive).item, macros=macros,
                                        indent="        ", too_large_for_float=big, comments=comments))
    if big and float_default:
        raise ParameterError(f"float_default: fields beyond the float range ({', '.join(big)})")
    h_text, c_text = amalgamate(headers, sources, origin)
    texts = {"aff.h": h_text, "aff.c": c_text,
             "aff_config.h": _config_header(names, ids, common, per_joint, origin),
             "aff_config.c": _config_source(inits, ids, names, origin, big, [j.notes for j in joints]),
             "example_loop.c": _example(joints, settings, ids, common, per_joint),
             "Makefile": MAKEFILE.replace("@FLOAT@", "1" if float_default else "0")}
    with staged_folder(out, "out") as staged:  # all files appear at once, or the previous ones stay
        for name in EXPORT_FILES:
            (staged / name).write_text(texts[name])
    config = dict(common)
    for pj in per_joint:
        config.update({k: v for k, (v, _) in pj.items()})
    notes = [str(n) for j in joints for n in j.notes]
    if big:
        notes.append(f"fields beyond the float range ({', '.join(big)}): the export builds in double only")
    return CExport(out=out, files=tuple(out / n for n in EXPORT_FILES), config=config,
                   headers=tuple(p.name for p in headers), sources=tuple(p.name for p in sources),
                   float_default=bool(float_default), notes=tuple(notes), joints=tuple(names))


_EXAMPLE = r"""/* example_loop.c -- an arm's adaptive friction compensators in a 1 kHz velocity loop, one per joint.
 *
 * Written by `adaptive-ff export-c`; yours to change. Per period AFF_TC and per joint j, in this order:
 *   w    = read_velocity(j);                    the joint's measured velocity (rad/s), raw
 *   u_ff = aff_step(&comp[j], w, w_ref);        the joint's compensation torque of this period (N*m)
 *   I   += aff_transfer(&comp[j]);              the supervisor's bumpless transfer into the joint's PI
 *   u    = the joint's PI on w_ref - w, plus u_ff, saturated to the joint drive's limit
 *   write_torque(j, u);                         the torque applied in this period (N*m)
 *   aff_observe(&comp[j], u, w);                learn from the applied torque and the measured velocity
 * read_velocity, write_torque and reference below are stubs: per joint a rigid body of the joint's design
 * inertia with the friction map of eq. 3 (the identified one), no coupling between the joints, integrated by
 * explicit Euler, for a dry run on a PC (`make run`). Replace them by your drives' I/O and trajectory.
 */
#include <stdio.h>

#include "aff_config.h"

/* Per joint: the stub's friction (eq. 3; N*m, N*m*s/rad), inertia (kg*m^2), Stribeck factors, the PI and the
 * drive's limit, the sine reference's amplitude (rad/s). */
static const double EXAMPLE_FC[AFF_N_JOINTS] = @FC@;
static const double EXAMPLE_FS[AFF_N_JOINTS] = @FS@;
static const double EXAMPLE_SIGMA[AFF_N_JOINTS] = @SIGMA@;
static const double EXAMPLE_J[AFF_N_JOINTS] = @J@;
static const double EXAMPLE_VS[AFF_N_JOINTS] = @VS@;
static const double EXAMPLE_DELTA[AFF_N_JOINTS] = @DELTA@;
static const double EXAMPLE_KP[AFF_N_JOINTS] = @KP@;
static const double EXAMPLE_KI[AFF_N_JOINTS] = @KI@;
static const double EXAMPLE_U_MAX[AFF_N_JOINTS] = @U_MAX@;
static const double EXAMPLE_AMPLITUDE[AFF_N_JOINTS] = @AMP@;
/* Length of the dry run (s) and frequency (Hz) of the sine references. */
#define EXAMPLE_SECONDS 60.0
#define EXAMPLE_HZ 0.2

static double joint_w[AFF_N_JOINTS]; /* the stub joints' velocities (rad/s) */

static aff_real read_velocity(int j)
{
    return (aff_real)joint_w[j];
}

static void write_torque(int j, aff_real u)
{
    plant_stribeck friction;
    double ud = (double)u, f, w_next;
    friction.Fc = (aff_real)EXAMPLE_FC[j];
    friction.dF = (aff_real)(EXAMPLE_FS[j] - EXAMPLE_FC[j]);
    friction.Vs = (aff_real)EXAMPLE_VS[j];
    friction.delta = (aff_real)EXAMPLE_DELTA[j];
    friction.sigma = (aff_real)EXAMPLE_SIGMA[j];
    friction.wcut = (aff_real)INFINITY;
    if (joint_w[j] == 0.0) { /* at rest: static friction holds the joint up to EXAMPLE_FS */
        if (fabs(ud) > EXAMPLE_FS[j])
            joint_w[j] = AFF_TC * (ud - (ud > 0.0 ? EXAMPLE_FS[j] : -EXAMPLE_FS[j])) / EXAMPLE_J[j];
        return;
    }
    f = (double)plant_stribeck_eval(&friction, (aff_real)joint_w[j]);
    w_next = joint_w[j] + AFF_TC * (ud - f) / EXAMPLE_J[j];
    joint_w[j] = w_next * joint_w[j] < 0.0 ? 0.0 : w_next; /* friction stops the joint; it does not reverse it */
}

static aff_real reference(int j, long k)
{
    return (aff_real)(EXAMPLE_AMPLITUDE[j] * sin(2.0 * 3.14159265358979323846 * EXAMPLE_HZ * AFF_TC * (double)k));
}

/* A discrete PI C(z) = Kp + Ki*Tc*z/(z-1) with the feedforward added, saturated to +-u_max, and conditional
 * integration (no integration past the limit: Astrom & Hagglund, Advanced PID Control, 2006). */
typedef struct pi { aff_real I; } pi;

static aff_real pi_step(pi *p, int j, aff_real e, aff_real u_ff)
{
    const aff_real umax = (aff_real)EXAMPLE_U_MAX[j];
    aff_real In = p->I + (aff_real)(EXAMPLE_KI[j] * AFF_TC) * e;
    aff_real v = (aff_real)EXAMPLE_KP[j] * e + In + u_ff;
    if (v > umax || v < -umax) /* saturated: hold the integrator */
        return v > umax ? umax : -umax;
    p->I = In;
    return v;
}

int main(void)
{
    static aff comp[AFF_N_JOINTS]; /* the compensators' states (a few kB each): static, not on a small stack */
    static const char *const state[] = {"learning", "feedforward", "observer", "backed off", "fault"};
    pi ctl[AFF_N_JOINTS] = {{0}};
    long n = (long)(EXAMPLE_SECONDS / AFF_TC + 0.5);
    int j;
    for (j = 0; j < AFF_N_JOINTS; j++) {
        aff_error err = aff_init(&comp[j], &AFF_CONFIGS[j]);
        if (err != AFF_OK) {
            printf("aff_init of joint %s: %s\n", AFF_JOINT_NAMES[j], aff_error_message(err));
            return 1;
        }
    }
    for (long k = 0; k < n; k++) { /* in a drive: the body of the AFF_TC task */
        for (j = 0; j < AFF_N_JOINTS; j++) {
            aff_real w_ref = reference(j, k);
            aff_real w = read_velocity(j);
            aff_real u_ff = aff_step(&comp[j], w, w_ref);
            ctl[j].I += aff_transfer(&comp[j]); /* 0 except where the supervisor switches: no torque step */
            aff_real u = pi_step(&ctl[j], j, w_ref - w, u_ff);
            write_torque(j, u);
            aff_observe(&comp[j], u, w);
        }
    }
    for (j = 0; j < AFF_N_JOINTS; j++) {
        aff_status_report s = aff_status(&comp[j]);
        aff_real Fc, Fs, sigma, tau;
        printf("joint %s after %g s: %s, feedforward %s, %lld estimator updates\n", AFF_JOINT_NAMES[j],
               EXAMPLE_SECONDS, state[s.state], aff_active(&comp[j]) ? "on" : "off",
               (long long)aff_n_updates(&comp[j]));
        if (aff_estimate(&comp[j], &Fc, &Fs, &sigma, &tau))
            printf("  estimate in use: Fc %.4g N*m, Fs %.4g N*m, sigma %.4g N*m*s/rad (stub joint: %g, %g, %g)\n",
                   (double)Fc, (double)Fs, (double)sigma, EXAMPLE_FC[j], EXAMPLE_FS[j], EXAMPLE_SIGMA[j]);
    }
    return 0;
}
"""
