"""Rough layered Bragg structures (Fourneau et al. 2024 §4): the ballistic transmission
filter F_α, integrated transmissivity, the single-reflection BRDF, a Monte Carlo reference
and the scatterogram forward model (§5, Fig. 9)."""

from .filter import transmission_filter
from .filter_lut import FilterLUT, transmission_filter_lut
from .montecarlo import montecarlo_brdf
from .tables import reflectance_lut
from .importance_sampling import sample_single_reflection, single_reflection_pdf
from .single_reflection import single_reflection_brdf
from .scatterograms import (
    PROJECTIONS,
    Scatterogram,
    projection_radius,
    scatterogram,
    scatterogram_directions,
    scatterogram_srgb,
)
from .structure import LayeredBragg, RoughBraggLayer
from .transmission import integrated_transmissivity, transmissivity_lut

__all__ = [
    "FilterLUT",
    "LayeredBragg",
    "PROJECTIONS",
    "RoughBraggLayer",
    "Scatterogram",
    "integrated_transmissivity",
    "montecarlo_brdf",
    "projection_radius",
    "reflectance_lut",
    "sample_single_reflection",
    "scatterogram",
    "scatterogram_directions",
    "scatterogram_srgb",
    "single_reflection_brdf",
    "single_reflection_pdf",
    "transmission_filter",
    "transmission_filter_lut",
    "transmissivity_lut",
]
