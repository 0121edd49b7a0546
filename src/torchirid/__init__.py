"""torchirid: exact, fast, differentiable reflectance and colour of iridescent materials.

Conventions (every public function, details in docs/conventions.md): wavelengths and
thicknesses in nm; angles as the cosine of the incidence angle in the incident medium
(``cos_theta``); refractive index n + iκ with κ ≥ 0 meaning absorption; the incident medium
is ``n_incident`` and the exit medium ``n_substrate``; tensor arguments broadcast together
(Python scalars accepted); dtype and device follow the inputs (float32 → complex64,
float64 → complex128); polarization is "s", "p" or "unpolarized" (mean of the s and p
reflectances).

The top level holds the entry points users reach for first; everything else lives in the
subpackages, whose ``__all__`` is their whole public surface:

- :mod:`torchirid.optics` — Fresnel, thin films, multilayers, Bragg mirrors, rough surfaces;
- :mod:`torchirid.microfacet` — GGX microfacets;
- :mod:`torchirid.layered` — rough Bragg layers, F_α, the layered BRDF, scatterograms;
- :mod:`torchirid.color` — CMFs, illuminants, XYZ / Lab / sRGB, ΔE;
- :mod:`torchirid.spectral` — the colour of Bragg mirrors (spectral, sampled, piecewise, envelope);
- :mod:`torchirid.ibl` — thin-film colour, also for image-based lighting (Belcour–Barla, Kneiphof);
- :mod:`torchirid.estimation` — film index and thickness from hyperspectral cubes;
- :mod:`torchirid.fitting` — matching layered Bragg materials to scatterograms;
- :mod:`torchirid.design` — inverse design of coatings and structural colours for a target;
- :mod:`torchirid.realtime` — textures and GLSL for shaders;
- :mod:`torchirid.presets` — the papers' structures (jewel beetles, Hirayama's coatings, Kobayashi's films);
- :mod:`torchirid.materials`, :mod:`torchirid.lut`, :mod:`torchirid.export`.

Subpackages load on first use (``import torchirid`` alone imports none of them), and so do
the entry points below. :func:`options` reads and sets the library's switches (value checks,
block size, threads for small calls, ``torch.compile``); :func:`clear_caches` empties every
cache. The ``torchirid`` command and the figures live in ``torchirid.app`` (not imported here);
``torchirid.scale`` (Dask) is imported explicitly.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from ._cache import clear_caches
from ._options import options
from ._version import __version__

__all__ = [
    "__version__",
    # subpackages
    "color",
    "design",
    "estimation",
    "export",
    "fitting",
    "ibl",
    "layered",
    "lut",
    "materials",
    "microfacet",
    "optics",
    "presets",
    "realtime",
    "spectral",
    # reflectance
    "BraggMirror",
    "Multilayer",
    "ThinFilm",
    "bragg_reflectance",
    "multilayer",
    "thin_film_reflectance",
    # colour
    "delta_e",
    "spectrum_to_xyz",
    "xyz_to_lab",
    "xyz_to_srgb",
    # colour of structures
    "bragg_xyz",
    "thin_film_xyz",
    # environment lighting
    "prefilter_environment",
    "read_environment",
    "shade_thin_film_environment",
    # rough layered structures
    "LayeredBragg",
    "MicrofacetBRDF",
    "RoughBraggLayer",
    "montecarlo_brdf",
    "scatterogram",
    "single_reflection_brdf",
    # measurements
    "estimate_film",
    "match_scatterogram",
    "read_cube",
    "read_scatterogram",
    # tables, materials, exports
    "LUT",
    "export_lut",
    "refractive_index",
    # configuration
    "clear_caches",
    "options",
]

_SUBPACKAGES = frozenset(
    ("color", "design", "estimation", "export", "fitting", "ibl", "layered", "lut", "materials", "microfacet", "optics",
     "presets", "realtime", "spectral", "scale"))

#: entry point → the subpackage that defines it
_ENTRY_POINTS = {
    **dict.fromkeys(("BraggMirror", "Multilayer", "ThinFilm", "bragg_reflectance", "multilayer",
                     "thin_film_reflectance"), "optics"),
    **dict.fromkeys(("delta_e", "spectrum_to_xyz", "xyz_to_lab", "xyz_to_srgb"), "color"),
    "bragg_xyz": "spectral",
    **dict.fromkeys(("thin_film_xyz", "prefilter_environment", "read_environment", "shade_thin_film_environment"),
                    "ibl"),
    **dict.fromkeys(("LayeredBragg", "RoughBraggLayer", "montecarlo_brdf", "scatterogram",
                     "single_reflection_brdf"), "layered"),
    "MicrofacetBRDF": "microfacet",
    **dict.fromkeys(("estimate_film", "read_cube"), "estimation"),
    **dict.fromkeys(("match_scatterogram", "read_scatterogram"), "fitting"),
    "LUT": "lut",
    "export_lut": "export",
    "refractive_index": "materials",
}


def __getattr__(name: str):
    """Import a subpackage, or the subpackage of an entry point, on first use (PEP 562)."""
    if name in _SUBPACKAGES:
        return importlib.import_module(f".{name}", __name__)
    package = _ENTRY_POINTS.get(name)
    if package is None:
        raise AttributeError(f"module 'torchirid' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{package}", __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))


if TYPE_CHECKING:  # the names for static tools; at run time they load on first use
    from . import color, design, estimation, export, fitting, ibl, layered, lut, materials, microfacet, optics, realtime
    from . import presets, spectral
    from .color import delta_e, spectrum_to_xyz, xyz_to_lab, xyz_to_srgb
    from .estimation import estimate_film, read_cube
    from .export import export_lut
    from .fitting import match_scatterogram, read_scatterogram
    from .ibl import prefilter_environment, read_environment, shade_thin_film_environment, thin_film_xyz
    from .layered import LayeredBragg, RoughBraggLayer, montecarlo_brdf, scatterogram, single_reflection_brdf
    from .lut import LUT
    from .materials import refractive_index
    from .microfacet import MicrofacetBRDF
    from .optics import BraggMirror, Multilayer, ThinFilm, bragg_reflectance, multilayer
    from .optics import thin_film_reflectance
    from .spectral import bragg_xyz
