"""Rough layered Bragg structures (Fourneau et al. 2024 §4): the ballistic transmission
filter F_α, integrated transmissivity, the single-reflection BRDF and a Monte Carlo reference."""

from .filter import filter_quadrature, transmission_filter
from .filter_lut import FilterLUT, transmission_filter_lut
from .montecarlo import TRANSMISSION_MODES, montecarlo_brdf
from .single_reflection import (
    coating_reflectance,
    layer_reflection_probabilities,
    reflectance_lut,
    sample_single_reflection,
    single_reflection_brdf,
    single_reflection_pdf,
)
from .structure import LayeredBragg, RoughBraggLayer
from .transmission import (
    absorption,
    integrated_transmissivity,
    transmission_probability,
    transmission_weight,
    transmissivity_lut,
)

__all__ = [
    "FilterLUT",
    "LayeredBragg",
    "RoughBraggLayer",
    "TRANSMISSION_MODES",
    "absorption",
    "coating_reflectance",
    "filter_quadrature",
    "integrated_transmissivity",
    "layer_reflection_probabilities",
    "montecarlo_brdf",
    "reflectance_lut",
    "sample_single_reflection",
    "single_reflection_brdf",
    "single_reflection_pdf",
    "transmission_filter",
    "transmission_filter_lut",
    "transmission_probability",
    "transmission_weight",
    "transmissivity_lut",
]
