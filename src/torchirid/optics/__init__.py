"""Exact optics: Fresnel amplitudes, thin films, multilayers, Bragg mirrors."""

from .bragg import bragg_dispersion, bragg_envelope, bragg_reflectance
from .fresnel import fresnel_reflectance
from .modules import BraggMirror, Multilayer, ThinFilm, raw_parameters
from .transfer import multilayer
from .thin_film import thin_film_reflectance
from .film_stack import FilmStack, film_reflectance
from .film_tables import film_reflectance_lut, lookup_film_reflectance
from .he_torrance import he_directional_diffuse
from .rough_surface import rough_multilayer_diffuse, rough_multilayer_reflectance

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
    "film_reflectance_lut",
    "lookup_film_reflectance",
    "he_directional_diffuse",
    "rough_multilayer_diffuse",
    "rough_multilayer_reflectance",
]
