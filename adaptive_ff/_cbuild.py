"""Build script of adaptive_ff's C core (cffi, API mode; the scheme: plant/_cbuild.py).

Builds ``adaptive_ff._caff`` from ``adaptive_ff/csrc/*.c`` plus plant's C sources (the compensator evaluates
eq. 3 with plant's one implementation); the plant types are shared with ``plant._cplant`` through
``ffi.include``. ``adaptive_ff/csrc`` never includes a header of ``controllers``.
"""

from __future__ import annotations

import runpy
from pathlib import Path

CSRC = Path(__file__).resolve().parent / "csrc"

#: Headers read by cffi, in dependency order.
HEADERS = [
    "aff_error.h",
    "aff_compensator.h",
    "aff_gate.h",
    "aff_rls.h",
    "aff_ivrls.h",
    "aff_regression.h",
    "aff_velocity_input.h",
    "aff_feedforward.h",
    "aff_sliding.h",
    "aff_robust_ff.h",
    "aff_eq4_ff.h",
    "aff_stribeck_fit.h",
    "aff_simulator.h",
    "aff_online_ukf.h",
    "aff_supervisor.h",
    "aff_dob.h",
    "aff_residual.h",
    "aff_adaptive.h",
    "aff_drive.h",
]


#: The layer below's build script, run by its path (the build scripts are files setuptools runs, not a package):
#: its globals (``CSRC``, ``HEADERS``, ``make_ffi``, ``ffibuilder``).
plant_build = runpy.run_path(str(CSRC.parent.parent / "plant" / "_cbuild.py"))
LAYERS = [(plant_build["CSRC"], plant_build["HEADERS"]), (CSRC, HEADERS)]
make_ffi = plant_build["make_ffi"]
ffibuilder = make_ffi("adaptive_ff._caff", LAYERS, include=plant_build["ffibuilder"])

if __name__ == "__main__":
    ffibuilder.compile(verbose=True)
