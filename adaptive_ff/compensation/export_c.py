"""Mode ``adaptive`` as a drop-in C library for a drive: :func:`export_c` (``adaptive-ff export-c``).

The exported folder holds the package's own C code of the compensator, the struct ``aff_adaptive`` that the
package's closed-loop engine runs for mode ``adaptive`` (the feedforward, the residual observer it switches in and
the supervisor; or, exported from a compensator without them, the feedforward alone), and its settings, so a drive
runs the compensator that was simulated:

==================  ===================================================================================
file                content
==================  ===================================================================================
``aff.h``           the API: ``aff_real.h``, ``plant_stribeck.h``, the ``aff_*.h`` headers the compensator
                    needs and ``aff_drive.h`` (``aff_init``, ``aff_step``, ``aff_observe``), concatenated
                    (an amalgamation, as SQLite ships; local ``#include`` lines removed, guards kept)
``aff.c``           the matching ``.c`` files, in dependency order
``aff_config.h``    the settings of this export as documented macros (``AFF_TC``, ``AFF_VS``, ...) and
                    ``extern const aff_config AFF_CONFIG``
``aff_config.c``    ``AFF_CONFIG``: the drive's settings (``aff_config`` of ``aff_drive.h``: mode ``adaptive``'s
                    and the input guard's), a C99 designated initializer of its fields, each with its comment
``example_loop.c``  a 1 kHz velocity loop: read the velocity, ``aff_step``, ``aff_transfer`` into a PI, write
                    the torque, ``aff_observe``, ``aff_status`` (stub I/O to replace)
``Makefile``        ``make``: ``libaff.a`` and the example (``$(CC) -std=c99``, ``-lm``); ``make FLOAT=1``:
                    the single-precision build (``-DAFF_FLOAT``, ``plant/csrc/aff_real.h``)
==================  ===================================================================================

The library uses ``<math.h>`` (and ``<string.h>``: the compiler's ``memmove`` for struct copies; the
freestanding ``<stdint.h>``, ``<stddef.h>``) and nothing else: no ``malloc``, no I/O, no global state, bounded
work per call. A ``static`` helper that two sources
both define (``min2``) is prefixed by its file's stem in ``aff.c``, the one scope they share there. ``aff_config.c``
holds the settings only (SI units); ``aff_init`` checks each and computes the derived fields (filter coefficients,
forgetting factors, counts) in C, the functions the package's Python classes call with the same settings, so a
drive engineer edits a value (or a macro of ``aff_config.h``: the fields equal to it are written with it) and
rebuilds, without Python. The export refuses a compensator whose struct its settings would not rebuild (one that
has observed samples). The files to ship are found by following the ``#include`` lines from
``adaptive_ff/csrc/aff_drive.h`` (:func:`c_closure`), not from a list.
"""

from __future__ import annotations

import math
import re
import struct
from dataclasses import dataclass, field
from pathlib import Path

from adaptive_ff.io.output import staged_folder
from plant.errors import ParameterError

__all__ = ["export_c", "export_settings", "ExportSettings", "JointExport", "CExport", "c_closure", "amalgamate", "struct_initializer",
           "field_comments", "c_literal", "c_comment", "macro_lines", "banner", "prepare_out", "EXPORT_FILES", "CSRC_DIRS", "ROOT_HEADER", "MACRO_DOC",
           "MACRO_FIELDS", "MAKEFILE", "W_MAX_DEFAULT", "HOLD_TIME_DEFAULT"]

#: The folders the compensator's C sources live in, searched in this order for a quoted ``#include``.
CSRC_DIRS = (Path(__file__).resolve().parents[1] / "csrc", Path(__file__).resolve().parents[2] / "plant" / "csrc")

#: The header the exported API starts from.
ROOT_HEADER = "aff_drive.h"

#: The files an export writes, in the order :attr:`CExport.files` lists them.
EXPORT_FILES = ("aff.h", "aff.c", "aff_config.h", "aff_config.c", "example_loop.c", "Makefile")

_LOCAL_INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"\s*$', re.MULTILINE)

#: Macros of aff_config.h and the fields of AFF_CONFIG that take their value: a field whose dotted path ends with
#: one of the names (``Tc``, ``guard.u_max``) and whose value equals the macro's is written as the macro in
#: aff_config.c.
MACRO_FIELDS = {
    "AFF_TC": ("dt", "Tc"),
    "AFF_TS": ("Ts",),
    "AFF_VS": ("Vs", "est.w_range.floor"),
    "AFF_DELTA": ("delta",),
    "AFF_J_DESIGN": ("J", "J_n", "initial_J"),
    "AFF_FF_MAX": ("ff_max", "d_max", "res.u_max"),
    "AFF_KP": ("Kp",),
    "AFF_KI": ("Ki",),
    "AFF_START_FC": ("start.Fc",),
    "AFF_START_FS": ("start.Fs",),
    "AFF_START_SIGMA": ("start.sigma",),
    "AFF_START_TAU": ("start.tau",),
    "AFF_W_MAX": ("guard.w_max",),
    "AFF_U_GUARD": ("guard.u_max",),
    "AFF_HOLD_TIME": ("guard.hold_time",),
    "AFF_OBSERVER": ("mode.use_residual",),
    "AFF_SUPERVISOR": ("mode.use_supervisor",),
}

_STRUCT_BLOCK = re.compile(r"typedef struct (\w+) \{(.*?)\n\} \1;", re.DOTALL)
_FIELD = re.compile(r"^\s+[\w ]+?\b(\w+)(?:\[[^\]]*\])?;\s*/\*(.*)$")


def field_comments(headers) -> dict:
    """The comments of the struct fields in ``headers`` (paths): ``{struct name: {field: comment}}``, a comment
    joined from its lines (the text of each ``/* ... */`` after a field, as the header states unit, range and
    default)."""
    out: dict = {}
    for h in headers:
        for m in _STRUCT_BLOCK.finditer(Path(h).read_text()):
            fields, name, text = {}, None, None
            for line in m.group(2).splitlines():
                f = _FIELD.match(line)
                if f:
                    name, text = f.group(1), f.group(2).strip()
                elif name is not None and text is not None and not text.endswith("*/"):
                    text += " " + line.strip()
                else:
                    continue
                if text.endswith("*/"):
                    fields[name] = " ".join(text[:-2].split())
                    name = text = None
            out[m.group(1)] = fields
    return out


def _find_header(name: str, dirs) -> Path:
    for d in dirs:
        if (d / name).is_file():
            return d / name
    raise FileNotFoundError(f"C header {name!r} not found in {', '.join(str(d) for d in dirs)}")


def c_closure(root: str = ROOT_HEADER, dirs=CSRC_DIRS) -> tuple[list[Path], list[Path]]:
    """The headers and sources a C API needs, found by following its quoted ``#include`` lines.

    Starting from the header ``root``, every ``#include "x.h"`` of a header, and of the ``.c`` file beside a
    header (same stem, same folder), is followed; system includes (``<math.h>``) are not.

    Parameters
    ----------
    root : str
        File name of the API's header (default ``aff_drive.h``).
    dirs : sequence of Path
        Folders searched for a quoted include, in order (default: ``adaptive_ff/csrc``, ``plant/csrc``).

    Returns
    -------
    headers : list of Path
        Every header reached, each after the headers it includes (dependency order).
    sources : list of Path
        The ``.c`` files beside those headers, in the same order.

    Raises
    ------
    FileNotFoundError
        A quoted include names no file of ``dirs``.
    ParameterError
        The includes form a cycle.
    """
    dirs = [Path(d) for d in dirs]
    order: list[Path] = []
    state: dict[Path, int] = {}  # 1 visiting, 2 done

    def visit(h: Path, chain: tuple) -> None:
        if state.get(h) == 2:
            return
        if state.get(h) == 1:
            raise ParameterError("C include cycle: " + " -> ".join(p.name for p in chain + (h,)))
        state[h] = 1
        texts = [h.read_text()]
        c = h.with_suffix(".c")
        if c.is_file():
            texts.append(c.read_text())
        for text in texts:
            for name in _LOCAL_INCLUDE.findall(text):
                dep = _find_header(name, [h.parent] + dirs)
                if dep != h:
                    visit(dep, chain + (h,))
        state[h] = 2
        order.append(h)

    visit(_find_header(root, dirs), ())
    return order, [h.with_suffix(".c") for h in order if h.with_suffix(".c").is_file()]


def _strip_local_includes(text: str) -> str:
    return _LOCAL_INCLUDE.sub("", text).strip("\n") + "\n"


def banner(name: str, what: str, source: str, edit: str = "do not edit: export again") -> str:
    """The comment that opens an exported file: its ``name``, ``what`` it holds, where the settings come from
    (``source``, e.g. ``" for id.json"``) and whether to ``edit`` it."""
    return (f"/* {name} -- {what}\n *\n * Written by `adaptive-ff export-c` (adaptive_ff.compensation.export_c) "
            f"from the\n * C sources of the adaptive-ff package{source}; {edit}.\n */\n")


_STATIC = re.compile(r"^static\b([^;=(\[{]*?)\b([A-Za-z_]\w*)\s*[(=\[;]", re.MULTILINE)


def _static_names(text: str) -> set:
    """The file-scope ``static`` functions and variables defined or declared in a C source."""
    return {m.group(2) for m in _STATIC.finditer(text)}


def _unique_statics(texts: dict) -> dict:
    """The sources with every ``static`` name that more than one of them defines prefixed by its file's stem.

    A ``static`` name is private to its file; in one amalgamated file two files' ``min2`` would collide.
    ``texts``: file name -> text. Only whole identifiers are renamed (comments included, harmlessly).
    """
    seen: dict = {}
    for name, text in texts.items():
        for ident in _static_names(text):
            seen.setdefault(ident, []).append(name)
    out = {}
    for name, text in texts.items():
        stem = Path(name).stem
        for ident in sorted(_static_names(text)):
            if len(seen[ident]) > 1:
                text = re.sub(rf"\b{ident}\b", f"{stem}_{ident}", text)
        out[name] = text
    return out


def amalgamate(headers, sources, origin: str = "") -> tuple[str, str]:
    """The text of ``aff.h`` and ``aff.c``: the files concatenated, their quoted includes removed.

    A ``static`` name defined by more than one source is prefixed by its file's stem in that file
    (``min2`` of ``aff_feedforward.c`` becomes ``aff_feedforward_min2``): one file has one scope.

    Parameters
    ----------
    headers, sources : list of Path
        From :func:`c_closure`.
    origin : str
        Appended to the banner (e.g. ``" (version 0.1.0)"``).

    Returns
    -------
    (str, str)
        The header and the source text.
    """
    h = [banner("aff.h", "the adaptive friction feedforward's C API (one header).", origin)]
    for p in headers:
        h.append(f"\n/* ==== {p.name} ==== */\n" + _strip_local_includes(p.read_text()))
    c = [banner("aff.c", "the adaptive friction feedforward's C implementation (one file).", origin),
         '#include "aff.h"\n']
    texts = _unique_statics({p.name: _strip_local_includes(p.read_text()) for p in sources})
    for p in sources:
        c.append(f"\n/* ==== {p.name} ==== */\n" + texts[p.name])
    return "".join(h), "".join(c)


def macro_lines(macro: str, value, field: str | None = None, scope: str = "") -> list:
    """The two lines of one setting's macro in ``aff_config.h``: the comment of :data:`MACRO_DOC` for ``field``
    (default ``macro``; what it is and its unit, then ``scope``, e.g. ``"; every joint"``) and ``#define macro
    value`` (:func:`c_literal`)."""
    unit, what = MACRO_DOC[macro if field is None else field]
    return [f"/* {what[0].upper() + what[1:]} ({unit}){scope}. */", f"#define {macro} {c_literal(value)}"]


def c_literal(x) -> str:
    """A C99 literal of the Python number ``x``: ints as they are, floats with the shortest round-trip digits
    (``repr``, at most 17 significant digits, so the C ``double`` is the same number), ``INFINITY``/``NAN``."""
    if isinstance(x, bool):
        return str(int(x))
    if isinstance(x, int):
        return str(x)
    x = float(x)
    if math.isnan(x):
        return "NAN"
    if math.isinf(x):
        return "INFINITY" if x > 0 else "-INFINITY"
    s = repr(x)
    return s if ("." in s or "e" in s or "n" in s) else s + ".0"


_FLT_MAX = struct.unpack("<f", b"\xff\xff\x7f\x7f")[0]


def struct_initializer(ffi, value, ctype, *, macros=None, indent: str = "    ", path: str = "",
                       too_large_for_float: list | None = None, comments: dict | None = None) -> str:
    """A C99 designated initializer of every field of the struct ``value`` (a cffi struct object).

    Parameters
    ----------
    ffi : cffi.FFI
        The FFI that declares the struct.
    value : cffi cdata
        The struct (``ptr[0]``).
    ctype : cffi CType
        Its type (``ffi.typeof(ptr).item``).
    macros : dict, keyword-only
        ``{macro name: (value, field names)}``: a scalar field whose dotted path ends with one of the field names
        (``"Tc"``, ``"guard.u_max"``) and whose value equals the macro's is written as the macro. Every floating
        field (``aff_real`` in the C core) is written with a cast, ``(aff_real)0.001``: a constant that the float
        build converts at compile time. An array of zeros is written ``{0}``.
    indent : str, keyword-only
        Indentation of the fields.
    path : str, keyword-only
        Dotted field path of ``value`` (for messages).
    too_large_for_float : list, keyword-only
        Receives the dotted names of finite fields beyond the float range (a float build would overflow them).
    comments : dict, keyword-only
        ``{struct name: {field: comment}}`` (:func:`field_comments`): each field with a comment is preceded by it.

    Returns
    -------
    str
        ``{\\n    .a = (aff_real)1.0,\\n    .b = {...},\\n}`` (no trailing semicolon).

    Raises
    ------
    ParameterError
        A field is a pointer (a struct of the C core holds values only).
    """
    macros = macros or {}
    notes = (comments or {}).get(ctype.cname.replace("struct ", ""), {})
    lines = ["{"]
    for name, f in ctype.fields:
        here = f"{path}.{name}" if path else name
        if name in notes:
            lines += _comment_lines(notes[name], indent)
        lines.append(f"{indent}.{name} = " + _initializer(ffi, getattr(value, name), f.type, here, macros,
                                                          indent, too_large_for_float, comments) + ",")
    lines.append(indent[:-4] + "}")
    return "\n".join(lines)


def c_comment(text: str, indent: str = "") -> str:
    """``text`` as a C comment of lines at most 116 characters wide, each starting with ``indent``, ending in a
    newline (``·`` written ``*``, ``*/`` ``* /``: the comment stays ASCII-safe and closed once).

    Parameters
    ----------
    text : str
        The comment's words (wrapped at spaces).
    indent : str
        Prefix of every line.

    Returns
    -------
    str
    """
    text = str(text).replace("·", "*").replace("*/", "* /")
    return "\n".join(_comment_lines(text, indent)) + "\n"


def _comment_lines(text: str, indent: str, width: int = 116) -> list:
    """``text`` as a C comment of lines at most ``width`` wide."""
    out, cur = [], ""
    for w in text.split():
        if cur and len(indent) + 3 + len(cur) + 1 + len(w) + 3 > width:
            out.append(cur)
            cur = w
        else:
            cur = f"{cur} {w}" if cur else w
    out.append(cur)
    return [f"{indent}{'/* ' if i == 0 else '   '}{s}{' */' if i == len(out) - 1 else ''}" for i, s in enumerate(out)]


def _macro_for(here: str, x: float, macros: dict) -> str | None:
    """The macro whose value ``x`` is and one of whose field names ends the path ``here``, or None."""
    for macro, (mv, names) in macros.items():
        if any(here == n or here.endswith("." + n) for n in names) and isinstance(mv, (int, float)) and (
                x == mv or (math.isnan(x) and math.isnan(mv))):
            return macro
    return None


def _initializer(ffi, v, t, here, macros, indent, big, comments=None) -> str:
    if t.kind == "struct":
        return struct_initializer(ffi, v, t, macros=macros, indent=indent + "    ", path=here,
                                  too_large_for_float=big, comments=comments)
    if t.kind == "array":
        items = [_initializer(ffi, v[i], t.item, f"{here}[{i}]", {}, indent + "    ", big)
                 for i in range(t.length)]
        if t.item.kind == "primitive" and all(float(v[i]) == 0.0 for i in range(t.length)):
            return "{0}"
        rows = [", ".join(items[i:i + 6]) for i in range(0, len(items), 6)]
        if len(rows) <= 1:
            return "{" + (rows[0] if rows else "") + "}"
        inner = indent + "    "
        return "{\n" + ",\n".join(inner + r for r in rows) + "\n" + indent + "}"
    if t.kind in ("primitive", "enum"):
        if t.kind == "primitive" and t.cname in ("float", "double", "long double"):
            x = float(v)
            if big is not None and math.isfinite(x) and abs(x) > _FLT_MAX:
                big.append(here)
            macro = _macro_for(here, x, macros)
            if macro is not None:
                return f"(aff_real){macro}"
            return f"(aff_real){c_literal(x)}"  # a constant converted at compile time (float build: no warning)
        macro = _macro_for(here, int(v), {k: m for k, m in macros.items() if isinstance(m[0], int)})
        return macro if macro is not None else str(int(v))
    raise ParameterError(f"field {here} of type {t.cname} cannot be exported (a C-core struct holds values only)")


@dataclass(frozen=True)
class CExport:
    """What :func:`export_c` wrote.

    Attributes
    ----------
    out : Path
        The folder.
    files : tuple of Path
        The files written (:data:`EXPORT_FILES`, in that order).
    config : dict
        The macros of ``aff_config.h``: name -> value (SI units, see the header's comments).
    headers, sources : tuple of str
        The package's C files in ``aff.h`` and ``aff.c``, in their order there.
    float_default : bool
        Whether ``make`` builds the single-precision variant by default.
    notes : tuple of str
        Caveats (e.g. values that a float build cannot represent).
    joints : tuple of str
        The joints of an arm's export (:func:`adaptive_ff.compensation.export_c_arm.export_c_arm`), one
        compensator each, in the order of ``AFF_CONFIGS``; empty for one compensator.
    """

    out: Path
    files: tuple
    config: dict
    headers: tuple
    sources: tuple
    float_default: bool = False
    notes: tuple = field(default_factory=tuple)
    joints: tuple = ()

    def to_dict(self) -> dict:
        """Strict-JSON dict: ``out, files, config, headers, sources, float_default, notes`` (inf as None), and
        ``joints`` for an arm's export."""
        from plant.results import json_safe

        d = {"out": str(self.out), "files": [str(p) for p in self.files], "config": dict(self.config),
             "headers": list(self.headers), "sources": list(self.sources), "float_default": self.float_default,
             "notes": list(self.notes)}
        if self.joints:
            d["joints"] = list(self.joints)
        return json_safe(d)

    def summary(self) -> str:
        """A few lines: the folder, the files, the configuration and how to build."""
        parts = ["the feedforward"] + (["the residual observer"] if self.config.get("AFF_OBSERVER") else []) \
            + (["the supervisor"] if self.config.get("AFF_SUPERVISOR") else [])
        each = f", one per joint ({', '.join(self.joints)})," if self.joints else ""
        lines = [f"C library of mode adaptive's compensator ({', '.join(parts)}){each} written to {self.out}"]
        lines += [f"  {p.name}" for p in self.files]
        lines.append("configuration (aff_config.h):")
        width = max([16] + [len(k) + 2 for k in self.config]) if self.joints else 16
        lines += [f"  {k:<{width}}{v:.6g}" for k, v in self.config.items()]
        lines.append(f"from {len(self.headers)} headers and {len(self.sources)} sources of the package: "
                     + ", ".join(self.sources))
        lines.append(f"build: make -C {self.out}" + (" (single precision: AFF_FLOAT)" if self.float_default else
                                                    f"; single precision: make -C {self.out} FLOAT=1"))
        lines += [f"note: {n}" for n in self.notes]
        return "\n".join(lines)


# ------------------------------------------------------------------------------------------------------- the files
#: Documentation of each macro of aff_config.h: (unit, meaning).
MACRO_DOC = {
    "AFF_TC": ("s", "controller period: call aff_step and aff_observe once per AFF_TC"),
    "AFF_TS": ("s", "update period of the estimator's RLS, a multiple of AFF_TC"),
    "AFF_VS": ("rad/s", "Stribeck velocity Vs of eq. 3 (the identification's; the estimator does not adapt it)"),
    "AFF_DELTA": ("1", "Stribeck shape factor delta of eq. 3 (the identification's; not adapted)"),
    "AFF_J_DESIGN": ("kg*m^2", "design inertia: the estimator's start, the loop model's, sign observer's, "
                               "residual observer's, switch-in's and supervisor's inertia, the example's stub joint"),
    "AFF_U_MAX": ("N*m", "the drive's torque limit (the example's saturation; the estimator's velocity gate bound "
                         "2*AFF_U_MAX*AFF_TC/AFF_J_DESIGN is a number in aff_config.c)"),
    "AFF_FF_MAX": ("N*m", "bound on |feedforward|; estimates with Fc or Fs above it are not used"),
    "AFF_KP": ("N*m*s/rad", "proportional gain of the loop's PI (the loop model's, the switch-in's, the example's)"),
    "AFF_KI": ("N*m/rad", "integral gain of the loop's PI (the loop model's, the switch-in's, the example's)"),
    "AFF_START_FC": ("N*m", "Coulomb level Fc of the provisional start map (acts until the first trusted estimate)"),
    "AFF_START_FS": ("N*m", "static level Fs of the provisional start map"),
    "AFF_START_SIGMA": ("N*m*s/rad", "viscous coefficient sigma of the provisional start map"),
    "AFF_START_TAU": ("s", "lag tau of the provisional start map (eq. 1)"),
    "AFF_W_MAX": ("rad/s", "the input guard's largest plausible |w| and |w_ref|: beyond it a sample is refused"),
    "AFF_U_GUARD": ("N*m", "the input guard's largest plausible |u| (twice AFF_U_MAX): beyond it a sample is refused"),
    "AFF_HOLD_TIME": ("s", "a held output (refused inputs) older than this fades to 0 over the same time"),
    "AFF_OBSERVER": ("1", "1: the residual observer and its switch-in are part of the compensator (mode adaptive)"),
    "AFF_SUPERVISOR": ("1", "1: the supervisor and its rest rule are part of the compensator (mode adaptive)"),
}


def _config_header(config: dict, source: str) -> str:
    lines = [banner("aff_config.h", "the settings of this export: macros and the drive's AFF_CONFIG.", source,
                     "yours to edit (a value, then rebuild)"),
             "#ifndef AFF_CONFIG_H", "#define AFF_CONFIG_H", '#include "aff.h"', "",
             "/* SI units; the values this export was configured with. The fields of AFF_CONFIG (aff_config.c) equal",
             " * to a macro are written with it: change the macro (or any value in aff_config.c) and rebuild, and",
             " * aff_init checks the settings and computes the compensator's derived fields from them. */"]
    for k, v in config.items():
        lines += ["", *macro_lines(k, v)]
    lines += ["",
              "/* The drive's settings (aff_config.c): aff_init(&c, &AFF_CONFIG). */",
              "extern const aff_config AFF_CONFIG;", "", "#endif", ""]
    return "\n".join(lines)


def _config_source(init: str, source: str, big: list, notes=()) -> str:
    no_float = ""
    if big:
        no_float = ("#ifdef AFF_FLOAT\n#error \"fields beyond the float range (" + ", ".join(big[:4])
                    + "): this export cannot be built with AFF_FLOAT\"\n#endif\n\n")
    return (banner("aff_config.c", "AFF_CONFIG, the drive's settings as the package configured them.", source,
                    "yours to edit (a value, then rebuild)")
            + '#include "aff_config.h"\n\n' + no_float
            + "/* The settings of mode adaptive (mode) and of the input guard (guard), SI units, each field with its\n"
              " * header's comment (unit, range, default). aff_init checks them (a field out of its range: an\n"
              " * aff_error naming it, aff_error_message) and computes the derived fields (filter coefficients,\n"
              " * forgetting factors, counts). Edit a value and rebuild; the fields written with a macro take it from\n"
              " * aff_config.h. Numbers have 17 significant digits at most (the shortest that give back the same\n"
              " * double). */\n"
            + "".join(c_comment(f"Note: {n}") for n in notes)
            + f"const aff_config AFF_CONFIG = {init};\n")


_EXAMPLE = r"""/* example_loop.c -- the adaptive friction compensator in a 1 kHz velocity loop.
 *
 * Written by `adaptive-ff export-c`; yours to change. Per period AFF_TC, in this order:
 *   w    = read_velocity();               the measured velocity (rad/s), raw: NaN or a spike is refused
 *   u_ff = aff_step(&comp, w, w_ref);     the compensation torque of this period (N*m), 0 until switch-on
 *   I   += aff_transfer(&comp);           the supervisor's bumpless transfer into the PI's integrator
 *   u    = your PI on w_ref - w, plus u_ff, saturated to the drive's limit
 *   write_torque(u);                      the torque applied in this period (N*m)
 *   aff_observe(&comp, u, w);             learn from the applied torque and the measured velocity
 * read_velocity, write_torque and reference below are stubs: a rigid joint of the design inertia with the
 * friction map of eq. 3 (EXAMPLE_* below) integrated by explicit Euler, for a dry run on a PC
 * (`make run`). Replace them by your drive's I/O and trajectory; keep the order of the calls.
 */
#include <stdio.h>

#include "aff_config.h"

/* The stub joint's friction (eq. 3; N*m, N*m*s/rad). */
#define EXAMPLE_FC @FC@
#define EXAMPLE_FS @FS@
#define EXAMPLE_SIGMA @SIGMA@
/* Length of the dry run (s) and amplitude (rad/s) and frequency (Hz) of its sine reference. */
#define EXAMPLE_SECONDS 60.0
#define EXAMPLE_AMPLITUDE @AMP@
#define EXAMPLE_HZ 0.2

static double joint_w; /* the stub joint's velocity (rad/s) */

static aff_real read_velocity(void)
{
    return (aff_real)joint_w;
}

static void write_torque(aff_real u)
{
    static const plant_stribeck friction = {
        (aff_real)EXAMPLE_FC, (aff_real)(EXAMPLE_FS - EXAMPLE_FC), (aff_real)AFF_VS, (aff_real)AFF_DELTA,
        (aff_real)EXAMPLE_SIGMA, (aff_real)INFINITY};
    double ud = (double)u;
    if (joint_w == 0.0) { /* at rest: static friction holds the joint up to EXAMPLE_FS */
        if (fabs(ud) > EXAMPLE_FS)
            joint_w = AFF_TC * (ud - (ud > 0.0 ? EXAMPLE_FS : -EXAMPLE_FS)) / AFF_J_DESIGN;
        return;
    }
    double f = (double)plant_stribeck_eval(&friction, (aff_real)joint_w);
    double w_next = joint_w + AFF_TC * (ud - f) / AFF_J_DESIGN;
    joint_w = w_next * joint_w < 0.0 ? 0.0 : w_next; /* friction stops the joint; it does not reverse it */
}

static aff_real reference(long k)
{
    return (aff_real)(EXAMPLE_AMPLITUDE * sin(2.0 * 3.14159265358979323846 * EXAMPLE_HZ * AFF_TC * (double)k));
}

/* A discrete PI C(z) = Kp + Ki*Tc*z/(z-1) with the feedforward added, saturated to +-AFF_U_MAX, and
 * conditional integration (no integration past the limit: Astrom & Hagglund, Advanced PID Control, 2006). */
typedef struct pi { aff_real I; } pi;

static aff_real pi_step(pi *p, aff_real e, aff_real u_ff)
{
    const aff_real umax = (aff_real)AFF_U_MAX;
    aff_real In = p->I + (aff_real)(AFF_KI * AFF_TC) * e;
    aff_real v = (aff_real)AFF_KP * e + In + u_ff;
    if (v > umax || v < -umax) /* saturated: hold the integrator */
        return v > umax ? umax : -umax;
    p->I = In;
    return v;
}

int main(void)
{
    static aff comp; /* the compensator's state (a few kB): static, not on a small stack */
    static const char *const state[] = {"learning", "feedforward", "observer", "backed off", "fault"};
    pi ctl = {0};
    long n = (long)(EXAMPLE_SECONDS / AFF_TC + 0.5);
    aff_error err = aff_init(&comp, &AFF_CONFIG);
    if (err != AFF_OK) {
        printf("aff_init: %s\n", aff_error_message(err));
        return 1;
    }
    for (long k = 0; k < n; k++) { /* in a drive: the body of the AFF_TC task */
        aff_real w_ref = reference(k);
        aff_real w = read_velocity();
        aff_real u_ff = aff_step(&comp, w, w_ref);
        ctl.I += aff_transfer(&comp); /* 0 except where the supervisor switches: no torque step */
        aff_real u = pi_step(&ctl, w_ref - w, u_ff);
        write_torque(u);
        aff_observe(&comp, u, w);
    }
    {
        aff_status_report s = aff_status(&comp);
        printf("after %g s: %s, feedforward %s, %lld estimator updates, %lld samples rejected by its gates, "
               "%lu refused by the input guard\n", EXAMPLE_SECONDS, state[s.state], aff_active(&comp) ? "on" : "off",
               (long long)aff_n_updates(&comp), (long long)aff_n_rejected(&comp),
               (unsigned long)s.n_refused_w_meas + s.n_refused_w_ref + s.n_refused_u);
    }
    {
        aff_real Fc, Fs, sigma, tau;
        if (aff_estimate(&comp, &Fc, &Fs, &sigma, &tau))
            printf("estimate in use: Fc %.4g N*m, Fs %.4g N*m, sigma %.4g N*m*s/rad, tau %.3g s "
                   "(stub joint: %g, %g, %g, no lag)\n", (double)Fc, (double)Fs, (double)sigma, (double)tau,
                   EXAMPLE_FC, EXAMPLE_FS, EXAMPLE_SIGMA);
    }
    return 0;
}
"""

#: The exported Makefile (``@FLOAT@``: 1 where ``make`` builds single precision by default).
MAKEFILE = """\
# Makefile -- libaff.a and example_loop, the adaptive friction compensator (written by adaptive-ff export-c).
#
#   make            double precision: build/double/libaff.a, build/double/example_loop
#   make FLOAT=1    single precision (-DAFF_FLOAT: float and the f-functions of <math.h>), for an MCU with a
#                   single-precision FPU: build/float/...
#   make run        build and run the example loop (a dry run on a stub joint)
#
# Needs a C99 compiler and <math.h> (-lm); nothing else. In your own build: compile aff.c and aff_config.c
# with your flags (add -DAFF_FLOAT for single precision) and include aff_config.h.
FLOAT ?= @FLOAT@
CFLAGS ?= -std=c99 -O2 -Wall -Wextra -pedantic
# no contraction of a*b + c into one fused multiply-add: the double build computes what the package computes
CFLAGS += -ffp-contract=off
LDLIBS = -lm
AR ?= ar
ifeq ($(FLOAT),1)
CPPFLAGS += -DAFF_FLOAT
BUILD = build/float
else
BUILD = build/double
endif

all: $(BUILD)/libaff.a $(BUILD)/example_loop

$(BUILD):
\tmkdir -p $@

$(BUILD)/%.o: %.c aff.h aff_config.h | $(BUILD)
\t$(CC) $(CPPFLAGS) $(CFLAGS) -c $< -o $@

$(BUILD)/libaff.a: $(BUILD)/aff.o $(BUILD)/aff_config.o
\t$(AR) rcs $@ $^

$(BUILD)/example_loop: $(BUILD)/example_loop.o $(BUILD)/libaff.a
\t$(CC) $(CFLAGS) $(LDFLAGS) -o $@ $^ $(LDLIBS)

run: all
\t./$(BUILD)/example_loop

clean:
\trm -rf build

.PHONY: all run clean
"""


def _check_number(name: str, x, *, positive: bool = True) -> float:
    """``x`` as a finite float, > 0 (``positive``) or >= 0; ParameterError naming ``name`` otherwise."""
    try:
        v = math.nan if isinstance(x, bool) else float(x)
    except (TypeError, ValueError, OverflowError):
        v = math.nan
    if not (math.isfinite(v) and (v > 0.0 if positive else v >= 0.0)):
        raise ParameterError(f"{name} must be a finite number {'> 0' if positive else '>= 0'}, got {x!r}")
    return v


def prepare_out(out, force: bool) -> Path:
    """``out`` as a Path, checked: not an existing file, not a non-empty folder unless ``force``
    (ParameterError)."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ParameterError(f"out {out}: an existing file, not a directory; give a directory name")
    if out.is_dir() and any(out.iterdir()) and not force:
        raise ParameterError(f"out {out}: the folder exists and is not empty; give a new folder, or force=True "
                             "(--force) to overwrite the exported files in it")
    return out


#: Defaults of the input guard (aff_drive.h, aff_guard_default_config): the largest plausible velocity (rad/s) and the
#: time after which a held output fades (s).
W_MAX_DEFAULT = 1e4
HOLD_TIME_DEFAULT = 0.1


def _mode_struct(compensator):
    """The ``aff_adaptive`` struct of ``compensator`` (its ``cdata``), or ParameterError naming what it is."""
    from adaptive_ff._caff import ffi

    c = getattr(compensator, "cdata", None)
    try:
        ok = c is not None and ffi.typeof(c).item.cname.replace("struct ", "") == "aff_adaptive"
    except (TypeError, ffi.error):
        ok = False
    if not ok:
        raise ParameterError("compensator must be mode adaptive's compensator (a struct aff_adaptive: "
                             "controllers.peers.adaptive_dob.AdaptiveCompensator, e.g. from "
                             f"controllers.simulation.compensators.build_mode), got {type(compensator).__name__}")
    return c


def _drive_config(compensator, **guard):
    """The drive's settings of ``compensator`` with the guard's fields ``guard`` (``aff_config *``), checked: the
    struct ``aff_init`` builds from them is the compensator's, byte for byte; ParameterError otherwise."""
    from adaptive_ff._caff import ffi, lib

    cfg = compensator.drive_config(**guard)
    c = ffi.new("aff *")
    code = lib.aff_init(c, cfg)
    if code != lib.AFF_OK:
        raise ParameterError(f"aff_init refuses the settings: {ffi.string(lib.aff_error_message(code)).decode()}")
    if bytes(ffi.buffer(ffi.addressof(c, "mode"))) != compensator.struct_bytes():
        raise ParameterError("the compensator is not what its settings configure (it has observed samples, or a part "
                             "was changed after it was configured): export a fresh compensator")
    return cfg


@dataclass(frozen=True)
class ExportSettings:
    """The settings of one compensator's export (:func:`export_settings`).

    Attributes
    ----------
    config : dict
        The macros of ``aff_config.h``: name -> value (SI units; :data:`MACRO_DOC`).
    macros : dict
        ``{macro: (value, field names)}`` for :func:`struct_initializer` (the fields written with a macro).
    drive : cffi cdata
        The drive's settings (``aff_config *``), checked: ``aff_init`` builds the compensator from them.
    stub : dict
        ``Fc``, ``Fs``, ``sigma`` of the example's stub joint (``Fs >= Fc``).
    """

    config: dict
    macros: dict
    drive: object
    stub: dict


@dataclass(frozen=True, kw_only=True)
class JointExport:
    """One joint of an export: its compensator and the settings of its drive and example loop (keyword-only).

    :func:`export_c` writes one, :func:`adaptive_ff.compensation.export_c_arm.export_c_arm` several; the numbers
    are checked by :func:`export_settings` (the message names the field).

    Attributes
    ----------
    compensator : AdaptiveCompensator
        The configured compensator of mode ``adaptive`` (C struct ``aff_adaptive``: the feedforward, with or
        without the residual observer and the supervisor; from
        :func:`controllers.simulation.compensators.build_mode`), before it observes anything: its settings
        (:attr:`~controllers.peers.adaptive_dob.AdaptiveCompensator.config`) become ``AFF_CONFIG.mode``.
    J_design : float
        Design inertia (kg·m²) the compensator was built with (documented as ``AFF_J_DESIGN``; the example's
        stub joint).
    u_max : float
        The drive's torque limit (N·m), the example loop's saturation (``AFF_U_MAX``); the input guard refuses a
        torque beyond twice it (``AFF_U_GUARD``). Within the float range.
    Kp, Ki : float
        Gains of the example loop's PI (N·m·s/rad, N·m/rad; ``AFF_KP``, ``AFF_KI``), >= 0.
    friction : mapping
        ``Fc``, ``Fs`` (N·m) and ``sigma`` (N·m·s/rad) of the example's stub joint (e.g. the identified ones);
        default empty: a joint without friction.
    name : str
        The joint's name (the identification's, e.g. the URDF's; an arm's export names its joints by it);
        default ``"joint"``.
    notes : tuple of str
        What the configuration assumed (e.g. the placeholders ``Vs``, ``delta`` of a joint without a Stribeck
        term, :func:`controllers.experiments.compensator_file.compensator_from_file`'s ``notes``): written in the
        comment above the joint's settings in ``aff_config.c`` and in the export's ``notes``; default none.
    """

    compensator: object
    J_design: float
    u_max: float
    Kp: float
    Ki: float
    friction: dict = field(default_factory=dict)
    name: str = "joint"
    notes: tuple = ()


def export_settings(joint: JointExport, *, w_max: float = W_MAX_DEFAULT,
                    hold_time: float = HOLD_TIME_DEFAULT) -> ExportSettings:
    """The checked settings of an export of ``joint``: what :func:`export_c` writes for it
    (:mod:`adaptive_ff.compensation.export_c_arm` writes several).

    Parameters
    ----------
    joint : JointExport
        The compensator (mode ``adaptive``'s, before it observes anything) and its drive's settings.
    w_max, hold_time : keyword-only
        As :func:`export_c` takes them (SI units).

    Returns
    -------
    ExportSettings

    Raises
    ------
    ParameterError
        ``joint`` not a :class:`JointExport`, not mode adaptive's compensator or not what its settings configure,
        a bad number, ``u_max`` beyond the float range, ``hold_time`` below the controller period.
    """
    if not isinstance(joint, JointExport):
        raise ParameterError(f"joint must be a JointExport, got {type(joint).__name__}")
    compensator = joint.compensator
    ptr = _mode_struct(compensator)
    J_design = _check_number("J_design", joint.J_design)
    u_max = _check_number("u_max", joint.u_max)
    if 2.0 * u_max > _FLT_MAX:
        raise ParameterError(f"u_max = {u_max!r} N·m: twice it (the input guard's bound) is beyond the float range "
                             f"({_FLT_MAX:.4g}); give the drive's real torque limit")
    Kp = _check_number("Kp", joint.Kp, positive=False)
    Ki = _check_number("Ki", joint.Ki, positive=False)
    w_max = _check_number("w_max", w_max)
    hold_time = _check_number("hold_time", hold_time)
    jd = {"Fc": 0.0, "Fs": 0.0, "sigma": 0.0}
    for k, v in dict(joint.friction or {}).items():
        if k not in jd:
            raise ParameterError(f"friction: unknown key {k!r}; allowed {sorted(jd)}")
        jd[k] = _check_number(f"friction {k}", v, positive=False)
    jd["Fs"] = max(jd["Fs"], jd["Fc"])
    ff = compensator.feedforward
    est = ff.estimator
    if hold_time < float(est.Tc):
        raise ParameterError(f"hold_time = {hold_time!r} s is below the controller period Tc = {est.Tc!r} s")
    config = {"AFF_TC": float(est.Tc), "AFF_TS": float(est.Ts), "AFF_VS": float(est.Vs),
              "AFF_DELTA": float(est.delta), "AFF_J_DESIGN": J_design, "AFF_U_MAX": u_max,
              "AFF_FF_MAX": float(ff.ff_max), "AFF_KP": Kp, "AFF_KI": Ki}
    if ff.start is not None:
        e = ff.start.estimate
        config.update({"AFF_START_FC": float(e.Fc), "AFF_START_FS": float(e.Fs), "AFF_START_SIGMA": float(e.sigma),
                       "AFF_START_TAU": float(e.tau)})
    config.update({"AFF_W_MAX": w_max, "AFF_U_GUARD": 2.0 * u_max, "AFF_HOLD_TIME": hold_time,
                   "AFF_OBSERVER": int(ptr.use_residual), "AFF_SUPERVISOR": int(ptr.use_supervisor)})
    macros = {k: (config[k], names) for k, names in MACRO_FIELDS.items() if k in config}
    drive = _drive_config(compensator, w_max=w_max, u_max=2.0 * u_max, hold_time=hold_time)
    return ExportSettings(config=config, macros=macros, drive=drive, stub=jd)


def export_c(joint: JointExport, out, *, w_max: float = W_MAX_DEFAULT, hold_time: float = HOLD_TIME_DEFAULT,
             float_default: bool = False, force: bool = False, origin: str = "") -> CExport:
    """Write the compensator as a C library for a drive: sources, one header, its configuration, an example loop
    and a Makefile (the files: module docstring of :mod:`adaptive_ff.compensation.export_c`).

    Parameters
    ----------
    joint : JointExport
        The compensator of mode ``adaptive`` (before it observes anything: its settings become
        ``AFF_CONFIG.mode``), the design inertia ``J_design`` (kg·m², ``AFF_J_DESIGN``), the drive's torque
        limit ``u_max`` (N·m, ``AFF_U_MAX``; the input guard refuses twice it, ``AFF_U_GUARD``), the example
        loop's PI gains ``Kp``, ``Ki`` (``AFF_KP``, ``AFF_KI``) and the ``friction`` of its stub joint.
    out : str or os.PathLike
        Folder to write into (created; must be empty unless ``force``). The files are written beside it first and
        moved into it together at the end (:func:`adaptive_ff.io.output.staged_folder`): a failure leaves the
        folder as it was, and a second export into the same folder while one runs is refused.
    w_max : float, keyword-only
        The input guard's largest plausible velocity (rad/s, ``AFF_W_MAX``), default 1e4.
    hold_time : float, keyword-only
        A held output older than this fades to 0 (s, ``AFF_HOLD_TIME``), default 0.1, at least the period.
    float_default : bool, keyword-only
        ``make`` builds the single-precision variant unless ``FLOAT=0`` (default False: double).
    force : bool, keyword-only
        Write into a non-empty folder (the exported files are overwritten, others left alone).
    origin : str, keyword-only
        Where the settings came from (e.g. ``" from id.json"``), for the files' banners.

    Returns
    -------
    CExport
        The folder, the files and the configuration (``to_dict()``, ``summary()``).

    Raises
    ------
    ParameterError
        ``joint`` not a :class:`JointExport`, not mode adaptive's compensator or not what its settings configure
        (it has observed samples), a bad number, ``u_max`` beyond the float range, or ``out`` an existing file or a non-empty folder without
        ``force``; ``out`` in use by another export (:class:`adaptive_ff.io.output.OutputInUseError`).
    FileNotFoundError
        The package's C sources are missing (an installation without ``csrc``).
    """
    st = export_settings(joint, w_max=w_max, hold_time=hold_time)
    config, jd, est = st.config, st.stub, joint.compensator.feedforward.estimator
    headers, sources = c_closure()
    out = prepare_out(out, force)
    from adaptive_ff._caff import ffi

    big: list = []
    init = struct_initializer(ffi, st.drive[0], ffi.typeof(st.drive).item, macros=st.macros, too_large_for_float=big,
                              comments=field_comments(headers))
    h_text, c_text = amalgamate(headers, sources, origin)
    notes = [str(n) for n in joint.notes]
    if big:
        notes.append(f"fields beyond the float range ({', '.join(big)}): the export builds in double only")
        if float_default:
            raise ParameterError(f"float_default: fields beyond the float range ({', '.join(big)})")
    example = _EXAMPLE
    for key, v in (("@FC@", jd["Fc"]), ("@FS@", jd["Fs"]), ("@SIGMA@", jd["sigma"]),
                   ("@AMP@", 50.0 * float(est.Vs))):
        example = example.replace(key, c_literal(v))
    texts = {"aff.h": h_text, "aff.c": c_text,
             "aff_config.h": _config_header(config, origin),
             "aff_config.c": _config_source(init, origin, big, joint.notes),
             "example_loop.c": example, "Makefile": MAKEFILE.replace("@FLOAT@", "1" if float_default else "0")}
    with staged_folder(out, "out") as staged:  # all files appear at once, or the previous ones stay
        for name in EXPORT_FILES:
            (staged / name).write_text(texts[name])
    files = [out / name for name in EXPORT_FILES]
    return CExport(out=out, files=tuple(files), config=config, headers=tuple(p.name for p in headers),
                   sources=tuple(p.name for p in sources), float_default=bool(float_default), notes=tuple(notes))
