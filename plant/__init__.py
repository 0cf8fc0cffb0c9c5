"""Physics of a robot joint with sliding dynamic friction: the bottom layer (imports nothing of the package).

Ruderman's plant (eqs. 1-3): ``J*dw/dt = u - f``, ``tau*df/dt + f = F(w)``, with the
Stribeck map ``F``; a fixed-step RK4 integrator at 1 kHz, a sampler with the
paper's measurement defects, excitation generators and the references a robot runs (point-to-point
moves, reversals).

The names below are imported lazily (``lazy_loader``, Scientific Python SPEC 1):
``import plant`` is cheap, and ``plant.simulate`` or ``from plant import simulate``
imports :mod:`plant.joint` (and whatever it needs, e.g. scipy) on first use.
"""

import lazy_loader

__getattr__, __dir__, _ = lazy_loader.attach(__name__, submod_attrs={
    "errors": ["ExcitationError", "FrictionError", "ParameterError", "SignalError"],
    "excitation": ["Reference", "bandlimited_noise", "multisine_reference"],
    "motion": ["point_to_point_reference", "reversing_reference", "trapezoid_profile"],
    "friction": ["PRESETS", "JointParams", "preset", "stribeck", "stribeck_shape"],
    "asymmetric": ["AsymmetricParams"],
    "drift": ["FrictionDrift"],
    "ripple": ["FrictionRipple"],
    "payload": ["PayloadStep"],
    "karnopp": ["KarnoppParams"],
    "lugre": ["LuGreParams"],
    "models": ["MODELS", "load_plant", "plant_from_dict", "plant_to_dict"],
    "variant_plants": ["VARIANT_NAMES", "drift_case", "variant", "variants"],
    "joint": ["DT_DEFAULT", "PlantResponse", "make_rk4_step", "simulate"],
    "sampling": ["Measurement", "irregular_sample_times", "sample"],
    "results": ["json_safe", "to_json", "axes_or_new"],
})

__all__ = [
    "FrictionError", "ParameterError", "SignalError", "ExcitationError",
    "JointParams", "PRESETS", "preset", "stribeck", "stribeck_shape",
    "DT_DEFAULT", "PlantResponse", "make_rk4_step", "simulate",
    "Measurement", "sample", "irregular_sample_times",
    "Reference", "bandlimited_noise", "multisine_reference",
    "point_to_point_reference", "reversing_reference", "trapezoid_profile",
    "LuGreParams", "KarnoppParams", "AsymmetricParams", "FrictionDrift", "FrictionRipple", "PayloadStep",
    "MODELS", "load_plant", "plant_from_dict", "plant_to_dict",
    "VARIANT_NAMES", "variant", "variants", "drift_case",
    "json_safe", "to_json", "axes_or_new",
]
