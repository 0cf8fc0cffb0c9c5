"""Physics of a robot joint with sliding dynamic friction: the bottom layer (imports nothing of the package).

Ruderman's plant (eqs. 1-3): ``J*dw/dt = u - f``, ``tau*df/dt + f = F(w)``, with the
Stribeck map ``F``; a fixed-step RK4 integrator at 1 kHz, a sampler with the
paper's measurement defects, and excitation generators.
"""

from plant.errors import ExcitationError, FrictionError, ParameterError, SignalError
from plant.excitation import Reference, bandlimited_noise, multisine_reference
from plant.friction import PRESETS, JointParams, preset, stribeck, stribeck_shape
from plant.asymmetric import AsymmetricParams
from plant.drift import FrictionDrift
from plant.karnopp import KarnoppParams
from plant.lugre import LuGreParams
from plant.models import MODELS, load_plant, plant_from_dict, plant_to_dict
from plant.variants import VARIANT_NAMES, drift_case, variant, variants
from plant.joint import DT_DEFAULT, PlantResponse, make_rk4_step, simulate
from plant.sampling import Measurement, irregular_sample_times, sample

__all__ = [
    "FrictionError", "ParameterError", "SignalError", "ExcitationError",
    "JointParams", "PRESETS", "preset", "stribeck", "stribeck_shape",
    "DT_DEFAULT", "PlantResponse", "make_rk4_step", "simulate",
    "Measurement", "sample", "irregular_sample_times",
    "Reference", "bandlimited_noise", "multisine_reference",
    "LuGreParams", "KarnoppParams", "AsymmetricParams", "FrictionDrift",
    "MODELS", "load_plant", "plant_from_dict", "plant_to_dict",
    "VARIANT_NAMES", "variant", "variants", "drift_case",
]
