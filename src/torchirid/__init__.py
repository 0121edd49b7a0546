"""torchirid: exact, fast, differentiable reflectance and colour of iridescent materials.

Conventions (every public function): wavelengths and thicknesses in nm; angles as the
cosine of the incidence angle in the incident medium; refractive index n + iκ with κ ≥ 0
meaning absorption; tensor arguments broadcast together (Python scalars accepted); dtype
and device follow the inputs (float32 → complex64, float64 → complex128); polarization is
"s", "p" or "unpolarized" (mean of the s and p reflectances).
"""

from . import color, estimation, export, fitting, ibl, layered, lut, materials, microfacet, optics, render, spectral
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
from .layered import (
    LayeredBragg,
    RoughBraggLayer,
    absorption,
    filter_quadrature,
    integrated_transmissivity,
    montecarlo_brdf,
    sample_single_reflection,
    single_reflection_brdf,
    transmission_filter,
    transmission_filter_lut,
    transmission_probability,
    transmission_weight,
    transmissivity_lut,
)
from .fitting import load_scatterogram, match_scatterogram
from .ibl import fitted_thin_film_xyz, filtered_thin_film_xyz, thin_film_xyz_fourier, uniform_thin_film_xyz
from .lut import LUT
from .render import scatterogram
from .microfacet import (
    MicrofacetBRDF,
    ggx_d,
    ggx_vndf_pdf,
    microfacet_brdf,
    sample_ggx_vndf,
    smith_g,
    smith_g1,
)
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
    FilmStack,
    film_reflectance,
    hirayama_stacks,
    reflectance_table,
    rough_multilayer_diffuse,
    rough_multilayer_reflectance,
    smooth_radiance,
    table_reflectance,
)
from .materials import available_materials, material_range, refractive_index
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
    "LayeredBragg",
    "MicrofacetBRDF",
    "RoughBraggLayer",
    "absorption",
    "filter_quadrature",
    "ggx_d",
    "ggx_vndf_pdf",
    "integrated_transmissivity",
    "microfacet_brdf",
    "montecarlo_brdf",
    "sample_ggx_vndf",
    "sample_single_reflection",
    "single_reflection_brdf",
    "smith_g",
    "smith_g1",
    "transmission_filter",
    "transmission_filter_lut",
    "transmission_probability",
    "transmission_weight",
    "transmissivity_lut",
    "load_scatterogram",
    "match_scatterogram",
    "scatterogram",
    "thin_film_xyz_fourier",
    "filtered_thin_film_xyz",
    "fitted_thin_film_xyz",
    "uniform_thin_film_xyz",
    "FilmStack",
    "film_reflectance",
    "hirayama_stacks",
    "reflectance_table",
    "rough_multilayer_diffuse",
    "rough_multilayer_reflectance",
    "smooth_radiance",
    "table_reflectance",
    "available_materials",
    "material_range",
    "refractive_index",
]
