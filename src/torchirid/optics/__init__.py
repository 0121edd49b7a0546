"""Exact optics: Fresnel amplitudes, thin films, multilayers, Bragg mirrors."""

from .bragg import bragg_dispersion, bragg_envelope, bragg_reflectance
from .fresnel import fresnel_reflectance
from .modules import BraggMirror, Multilayer, ThinFilm, raw_parameters
from .transfer import multilayer
from .thin_film import thin_film_reflectance
from .film_stack import (FilmStack, film_reflectance, hirayama_stacks, smooth_directions,
                               smooth_radiance, stack_indices)
from .film_tables import interpolation_error, film_reflectance_lut, lookup_film_reflectance
from .he_torrance import (coherent_attenuation, effective_roughness, he_directional_diffuse, he_shadowing,
                          roughness_factor)
from .rough_surface import rough_multilayer_diffuse, rough_multilayer_reflectance, stack_transmittance_to_last_film

__all__ = [
    "BraggMirror",
    "Multilayer",
    "ThinFilm",
    "raw_parameters",
    "bragg_dispersion",
    "bragg_envelope",
    "bragg_reflectance",
    "fresnel_reflectance",
    "multilayer",
    "thin_film_reflectance",
    "FilmStack",
    "film_reflectance",
    "hirayama_stacks",
    "smooth_directions",
    "smooth_radiance",
    "stack_indices",
    "interpolation_error",
    "film_reflectance_lut",
    "lookup_film_reflectance",
    "coherent_attenuation",
    "effective_roughness",
    "he_directional_diffuse",
    "he_shadowing",
    "rough_multilayer_diffuse",
    "rough_multilayer_reflectance",
    "roughness_factor",
    "stack_transmittance_to_last_film",
]
