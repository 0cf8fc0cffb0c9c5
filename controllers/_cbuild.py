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
    "ctl_canudas.h",
    "ctl_adob.h",
    "ctl_quasi_static.h",
    "ctl_sensor.h",
    "ctl_drive.h",
    "ctl_engine.h",
]


#: The layer below's build script, run by its path (it runs plant's in turn): its globals.
aff_build = runpy.run_path(str(CSRC.parent.parent / "adaptive_ff" / "_cbuild.py"))
LAYERS = aff_build["LAYERS"] + [(CSRC, HEADERS)]
ffibuilder = aff_build["make_ffi"]("controllers._cctl", LAYERS, include=aff_build["ffibuilder"])
#: A user's compensator written in Python (controllers/simulation/user_compensator.py) runs in the same engine
#: through an ops table whose two functions call back into Python (cffi ``extern "Python"``, the signatures of
#: ``aff_compensator_ops``). They exist only in the binding, so they are declared here, not in a C header.
ffibuilder.cdef('extern "Python" double ctl_py_compensate(void *, double, double, double);\n'
                'extern "Python" int ctl_py_observe(void *, double, double, double *);')

if __name__ == "__main__":
    ffibuilder.compile(verbose=True)
