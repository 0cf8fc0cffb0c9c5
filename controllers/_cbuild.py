"""Build script of controllers' C core (cffi, API mode; the scheme: plant/_cbuild.py).

Builds ``controllers._cctl`` from ``controllers/csrc/*.c`` plus the C sources of ``adaptive_ff`` and
``plant`` (the engine composes the plant, the gates and the compensators); their types are shared with
``adaptive_ff._caff`` and ``plant._cplant`` through ``ffi.include``.
"""

from __future__ import annotations

import runpy
from pathlib import Path

CSRC = Path(__file__).resolve().parent / "csrc"

#: Headers read by cffi, in dependency order.
HEADERS = [
    "ctl_pi.h",
    "ctl_metrics.h",
    "ctl_dob.h",
    "ctl_canudas.h",
    "ctl_adob.h",
    "ctl_quasi_static.h",
    "ctl_engine.h",
]


#: The layer below's build script, run by its path (it runs plant's in turn): its globals.
aff_build = runpy.run_path(str(CSRC.parent.parent / "adaptive_ff" / "_cbuild.py"))
LAYERS = aff_build["LAYERS"] + [(CSRC, HEADERS)]
ffibuilder = aff_build["make_ffi"]("controllers._cctl", LAYERS, include=aff_build["ffibuilder"])

if __name__ == "__main__":
    ffibuilder.compile(verbose=True)
