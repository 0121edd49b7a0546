"""torchirid: exact, fast, differentiable reflectance and colour of iridescent materials.

Conventions (every public function): wavelengths and thicknesses in nm; angles as the
cosine of the incidence angle in the incident medium; refractive index n + iκ with κ ≥ 0
meaning absorption; tensor arguments broadcast together (Python scalars accepted); dtype
and device follow the inputs (float32 → complex64, float64 → complex128); polarization is
"s", "p" or "unpolarized" (mean of the s and p reflectances).
"""

from ._compile import compile_enabled, set_compile
from .optics import (
    BraggMirror,
    Multilayer,
    ThinFilm,
    bragg_dispersion,
    bragg_envelope,
    bragg_reflectance,
    fresnel_reflectance,
    multilayer,
    thin_film_reflectance,
)

__version__ = "0.1.0"

__all__ = [
    "__version__",
    "BraggMirror",
    "Multilayer",
    "ThinFilm",
    "bragg_dispersion",
    "compile_enabled",
    "set_compile",
    "bragg_envelope",
    "bragg_reflectance",
    "fresnel_reflectance",
    "multilayer",
    "thin_film_reflectance",
]
