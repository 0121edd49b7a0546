"""The colour of thin films, smooth and rough, also under image-based lighting: Belcour–Barla's
Fourier colour, Kneiphof et al. 2019's prefiltering, and the fitted light-mixture table.

:func:`thin_film_xyz` is the family's one entry point (``method=`` a key of
:data:`THIN_FILM_XYZ_METHODS`, each the suffix of a ``thin_film_xyz_<method>`` function)."""

from .fourier import thin_film_xyz_fourier
from .sensitivity import (
    fourier_sensitivity_lut,
    prefiltered_sensitivity_lut,
    fourier_sensitivity,
    shipped_fourier_sensitivity_lut,
    lookup_prefiltered_sensitivity,
    shipped_prefiltered_sensitivity_lut,
)
from .dfg import dfg_lut, shipped_dfg_lut
from .filtered import thin_film_xyz_filtered, thin_film_xyz_gaussian_path
from .fitted import light_mixture_lut, thin_film_xyz_fitted, light_mixture, shipped_light_mixture_lut
from .uniform import path_difference_moments, uniform_light_moments, thin_film_xyz_uniform
from .prefilter import PrefilteredEnvironment, read_environment, prefilter_environment, synthetic_environment
from .methods import THIN_FILM_XYZ_METHODS, thin_film_xyz
from .shading import SHADING_METHODS, shade_thin_film_environment

__all__ = [
    "SHADING_METHODS",
    "THIN_FILM_XYZ_METHODS",
    "thin_film_xyz",
    "dfg_lut",
    "thin_film_xyz_filtered",
    "thin_film_xyz_fitted",
    "fourier_sensitivity",
    "fourier_sensitivity_lut",
    "thin_film_xyz_gaussian_path",
    "light_mixture",
    "light_mixture_lut",
    "read_environment",
    "lookup_prefiltered_sensitivity",
    "path_difference_moments",
    "prefilter_environment",
    "prefiltered_sensitivity_lut",
    "PrefilteredEnvironment",
    "shade_thin_film_environment",
    "shipped_dfg_lut",
    "shipped_fourier_sensitivity_lut",
    "shipped_light_mixture_lut",
    "shipped_prefiltered_sensitivity_lut",
    "synthetic_environment",
    "thin_film_xyz_fourier",
    "uniform_light_moments",
    "thin_film_xyz_uniform",
]
