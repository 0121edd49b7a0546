"""Rough layered Bragg structures (Fourneau et al. 2024 §4): the ballistic transmission
filter F_α, integrated transmissivity, the single-reflection BRDF, a Monte Carlo reference
and the scatterogram forward model (§5, Fig. 9)."""

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
from .scatterograms import (
    PROJECTIONS,
    Scatterogram,
    projection_radius,
    projection_theta,
    scatterogram,
    scatterogram_directions,
    scatterogram_srgb,
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
    "PROJECTIONS",
    "RoughBraggLayer",
    "Scatterogram",
    "TRANSMISSION_MODES",
    "absorption",
    "coating_reflectance",
    "filter_quadrature",
    "integrated_transmissivity",
    "layer_reflection_probabilities",
    "montecarlo_brdf",
    "projection_radius",
    "projection_theta",
    "reflectance_lut",
    "sample_single_reflection",
    "scatterogram",
    "scatterogram_directions",
    "scatterogram_srgb",
    "single_reflection_brdf",
    "single_reflection_pdf",
    "transmission_filter",
    "transmission_filter_lut",
    "transmission_probability",
    "transmission_weight",
    "transmissivity_lut",
]
