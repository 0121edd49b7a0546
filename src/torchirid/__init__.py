"""torchirid: exact, fast, differentiable reflectance and colour of iridescent materials.

Conventions (every public function, details in docs/conventions.md): wavelengths and
thicknesses in nm; angles as the cosine of the incidence angle in the incident medium
(``cos_theta``); refractive index n + iκ with κ ≥ 0 meaning absorption; the incident medium
is ``n_incident`` and the exit medium ``n_substrate``; tensor arguments broadcast together
(Python scalars accepted); dtype and device follow the inputs (float32 → complex64,
float64 → complex128); polarization is "s", "p" or "unpolarized" (mean of the s and p
reflectances).

The top level holds the entry points users reach for; everything else lives in the
subpackages, each with its own ``__all__``:

- :mod:`torchirid.optics` — Fresnel, thin films, multilayers, Bragg mirrors, rough surfaces;
- :mod:`torchirid.microfacet` — GGX microfacets;
- :mod:`torchirid.layered` — rough Bragg layers, F_α, the layered BRDF, scatterograms;
- :mod:`torchirid.color` — CMFs, illuminants, XYZ / Lab / sRGB, ΔE;
- :mod:`torchirid.spectral` — the colour of Bragg mirrors (spectral, sampled, piecewise, envelope);
- :mod:`torchirid.ibl` — thin-film colour for image-based lighting (Belcour–Barla, Kneiphof);
- :mod:`torchirid.estimation` — film index and thickness from hyperspectral cubes;
- :mod:`torchirid.fitting` — matching layered Bragg materials to scatterograms;
- :mod:`torchirid.materials`, :mod:`torchirid.lut`, :mod:`torchirid.export`.

The ``torchirid`` command and the figures live in :mod:`torchirid.app` (not imported here).
"""

from . import color, estimation, export, fitting, ibl, layered, lut, materials, microfacet, optics, spectral
from ._cache import clear_caches
from ._checks import set_value_checks, value_checks, value_checks_enabled
from ._chunks import chunk_size, get_chunk_size, set_chunk_size
from ._threads import get_small_work_threads, set_small_work_threads
from ._compile import compile_enabled, set_compile
from ._version import __version__
from .color import delta_e, delta_e_2000, illuminant_spd, cmfs, spectrum_to_xyz, xyz_to_lab, xyz_to_srgb
from .estimation import estimate_film
from .estimation.cube_io import read_cube
from .export import export_lut
from .fitting import load_scatterogram, match_scatterogram
from .ibl import (
    filtered_thin_film_xyz,
    fitted_thin_film_xyz,
    load_environment,
    prefilter_environment,
    shade_thin_film_environment,
    thin_film_xyz_fourier,
    uniform_thin_film_xyz,
)
from .layered import (
    LayeredBragg,
    RoughBraggLayer,
    montecarlo_brdf,
    sample_single_reflection,
    single_reflection_brdf,
    transmission_filter,
)
from .lut import LUT
from .layered import scatterogram
from .materials import available_materials, refractive_index
from .microfacet import MicrofacetBRDF, microfacet_brdf
from .optics import (
    BraggMirror,
    FilmStack,
    Multilayer,
    ThinFilm,
    bragg_dispersion,
    bragg_envelope,
    bragg_reflectance,
    film_reflectance,
    film_reflectance_lut,
    fresnel_reflectance,
    lookup_film_reflectance,
    multilayer,
    rough_multilayer_diffuse,
    rough_multilayer_reflectance,
    thin_film_reflectance,
)
from .spectral import BRAGG_XYZ_METHODS, bragg_xyz

__all__ = [
    "__version__",
    # subpackages
    "color",
    "estimation",
    "export",
    "fitting",
    "ibl",
    "layered",
    "lut",
    "materials",
    "microfacet",
    "optics",
    "spectral",
    # reflectance
    "BraggMirror",
    "FilmStack",
    "Multilayer",
    "ThinFilm",
    "bragg_dispersion",
    "bragg_envelope",
    "bragg_reflectance",
    "film_reflectance",
    "fresnel_reflectance",
    "multilayer",
    "rough_multilayer_diffuse",
    "rough_multilayer_reflectance",
    "thin_film_reflectance",
    # colour
    "cmfs",
    "delta_e",
    "delta_e_2000",
    "illuminant_spd",
    "spectrum_to_xyz",
    "xyz_to_lab",
    "xyz_to_srgb",
    # Bragg colour
    "BRAGG_XYZ_METHODS",
    "bragg_xyz",
    # layered BRDF
    "LayeredBragg",
    "MicrofacetBRDF",
    "RoughBraggLayer",
    "microfacet_brdf",
    "montecarlo_brdf",
    "sample_single_reflection",
    "scatterogram",
    "single_reflection_brdf",
    "transmission_filter",
    # thin-film IBL
    "filtered_thin_film_xyz",
    "fitted_thin_film_xyz",
    "load_environment",
    "prefilter_environment",
    "shade_thin_film_environment",
    "thin_film_xyz_fourier",
    "uniform_thin_film_xyz",
    # estimation and matching
    "estimate_film",
    "load_scatterogram",
    "match_scatterogram",
    "read_cube",
    # tables, materials, exports
    "LUT",
    "available_materials",
    "export_lut",
    "film_reflectance_lut",
    "lookup_film_reflectance",
    "refractive_index",
    # switches
    "clear_caches",
    "compile_enabled",
    "set_compile",
    "set_value_checks",
    "chunk_size",
    "get_chunk_size",
    "set_chunk_size",
    "get_small_work_threads",
    "set_small_work_threads",
    "value_checks",
    "value_checks_enabled",
]
