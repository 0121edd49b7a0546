"""Exact optics: Fresnel amplitudes, thin films, multilayers, Bragg mirrors."""

from .bragg import bragg_dispersion, bragg_envelope, bragg_reflectance
from .fresnel import fresnel_reflectance
from .modules import BraggMirror, Multilayer, ThinFilm
from .multilayer import multilayer
from .thin_film import thin_film_reflectance

__all__ = [
    "BraggMirror",
    "Multilayer",
    "ThinFilm",
    "bragg_dispersion",
    "bragg_envelope",
    "bragg_reflectance",
    "fresnel_reflectance",
    "multilayer",
    "thin_film_reflectance",
]
