"""torchirid: exact, fast, differentiable reflectance and colour of iridescent materials.

Conventions (every public function): wavelengths and thicknesses in nm; angles as the
cosine of the incidence angle in the incident medium; refractive index n + iκ with κ ≥ 0
meaning absorption; tensor arguments broadcast together (Python scalars accepted); dtype
and device follow the inputs (float32 → complex64, float64 → complex128); polarization is
"s", "p" or "unpolarized" (mean of the s and p reflectances).
"""

from . import color, lut, optics, spectral
from ._compile import compile_enabled, set_compile
from .color import (
    DELTA_E_METHODS,
    ILLUMINANTS,
    OBSERVERS,
    cmfs,
    delta_e,
    delta_e_1976,
    delta_e_2000,
    illuminant_spd,
    lab_to_xyz,
    linear_srgb_to_srgb,
    spectrum_to_xyz,
    white_point_xy,
    white_point_xyz,
    xyz_to_lab,
    xyz_to_linear_srgb,
    xyz_to_srgb,
    xyz_weights,
)
from .lut import LUT
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
from .spectral import BRAGG_XYZ_METHODS, bragg_xyz

__version__ = "0.1.0"

__all__ = [
    "__version__",
    "BRAGG_XYZ_METHODS",
    "DELTA_E_METHODS",
    "ILLUMINANTS",
    "LUT",
    "OBSERVERS",
    "bragg_xyz",
    "cmfs",
    "delta_e",
    "delta_e_1976",
    "delta_e_2000",
    "illuminant_spd",
    "lab_to_xyz",
    "linear_srgb_to_srgb",
    "spectrum_to_xyz",
    "white_point_xy",
    "white_point_xyz",
    "xyz_to_lab",
    "xyz_to_linear_srgb",
    "xyz_to_srgb",
    "xyz_weights",
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
