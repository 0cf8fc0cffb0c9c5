"""Physics of a robot joint with sliding dynamic friction: the bottom layer (imports nothing of the package).

Ruderman's plant (eqs. 1-3): ``J*dw/dt = u - f``, ``tau*df/dt + f = F(w)``, with the
Stribeck map ``F``; a fixed-step RK4 integrator at 1 kHz, a sampler with the
paper's measurement defects, and excitation generators.

The names below are imported lazily (PEP 562): ``import plant`` is cheap, and
``plant.simulate`` or ``from plant import simulate`` imports :mod:`plant.joint`
(and whatever it needs, e.g. scipy or numba) on first use.
"""

from __future__ import annotations

import importlib
import sys
import types

#: module -> the public names this package re-exports from it
_EXPORTS = {
    "plant.errors": ("ExcitationError", "FrictionError", "ParameterError", "SignalError"),
    "plant.excitation": ("Reference", "bandlimited_noise", "multisine_reference"),
    "plant.friction": ("PRESETS", "JointParams", "preset", "stribeck", "stribeck_shape"),
    "plant.asymmetric": ("AsymmetricParams",),
    "plant.drift": ("FrictionDrift",),
    "plant.karnopp": ("KarnoppParams",),
    "plant.lugre": ("LuGreParams",),
    "plant.models": ("MODELS", "load_plant", "plant_from_dict", "plant_to_dict"),
    "plant.variant_plants": ("VARIANT_NAMES", "drift_case", "variant", "variants"),
    "plant.joint": ("DT_DEFAULT", "PlantResponse", "make_rk4_step", "simulate"),
    "plant.sampling": ("Measurement", "irregular_sample_times", "sample"),
    "plant.results": ("json_safe", "to_json", "axes_or_new"),
}
_WHERE = {name: module for module, names in _EXPORTS.items() for name in names}

__all__ = [
    "FrictionError", "ParameterError", "SignalError", "ExcitationError",
    "JointParams", "PRESETS", "preset", "stribeck", "stribeck_shape",
    "DT_DEFAULT", "PlantResponse", "make_rk4_step", "simulate",
    "Measurement", "sample", "irregular_sample_times",
    "Reference", "bandlimited_noise", "multisine_reference",
    "LuGreParams", "KarnoppParams", "AsymmetricParams", "FrictionDrift",
    "MODELS", "load_plant", "plant_from_dict", "plant_to_dict",
    "VARIANT_NAMES", "variant", "variants", "drift_case",
    "json_safe", "to_json", "axes_or_new",
]


def __getattr__(name: str):
    """Import the module of a re-exported ``name`` on first access (PEP 562) and cache the value here."""
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))


class _Package(types.ModuleType):
    """This package's module type: a submodule never shadows a re-exported name of the same spelling.

    Importing a submodule binds it on its package (``setattr(package, "name", module)``);
    where a re-exported object has that name (``plant.stribeck`` the function and
    ``plant/stribeck.py`` the module), the object wins, as with eager imports.
    """

    def __setattr__(self, name, value):
        if name in _WHERE and isinstance(value, types.ModuleType) and value.__name__ == f"{__name__}.{name}":
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
