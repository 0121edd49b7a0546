"""Products as images and arrays: reflectance maps, gradient atlases and scatterograms → PNG + ``.npz``.

The library behind the ``torchirid`` command (:mod:`torchirid.cli`): each product has a
function that computes its data (a frozen dataclass of numpy arrays and a JSON-ready
``params`` dict), a ``plot_*`` function that draws it (a ``matplotlib`` Figure, no pyplot),
and ``save_*_png`` / ``save_*_npz`` functions that write it atomically. Units: wavelengths
and thicknesses in nm, angles of the grids in degrees (with their cosines alongside).
"""

from .gradients import (
    CURVE_WAVELENGTHS_NM,
    GRADIENT_ATLAS_STEPS,
    GRADIENT_METHODS,
    GradientAtlas,
    gradient_atlas,
    plot_gradient_atlas,
    save_gradient_atlas_npz,
    save_gradient_atlas_png,
)
from .scatterogram import (
    CIRCLES_DEG,
    PROJECTIONS,
    Scatterogram,
    plot_scatterograms,
    projection_radius,
    projection_theta,
    save_scatterograms_npz,
    save_scatterograms_png,
    scatterogram,
    scatterogram_directions,
    scatterogram_srgb,
)
from .sphere import (
    SpherePanels,
    SphereRender,
    chroma_stats,
    chroma_table_markdown,
    lamp_spd,
    plot_panels,
    render_panels,
    render_sphere,
    save_panels_npz,
    save_panels_png,
)
from .thin_film_ibl import (
    THIN_FILM_IBL_METHODS,
    THIN_FILM_IBL_PANELS,
    ThinFilmIBLComparison,
    plot_thin_film_ibl,
    save_thin_film_ibl_npz,
    save_thin_film_ibl_png,
    thin_film_ibl_comparison,
)
from .spectrum import (
    ReflectanceMap,
    bragg_reflectance_map,
    plot_reflectance_map,
    save_reflectance_map_npz,
    save_reflectance_map_png,
    thin_film_reflectance_map,
)

__all__ = [
    "CIRCLES_DEG",
    "PROJECTIONS",
    "Scatterogram",
    "plot_scatterograms",
    "projection_radius",
    "projection_theta",
    "save_scatterograms_npz",
    "save_scatterograms_png",
    "scatterogram",
    "scatterogram_directions",
    "scatterogram_srgb",
    "CURVE_WAVELENGTHS_NM",
    "GRADIENT_ATLAS_STEPS",
    "GRADIENT_METHODS",
    "GradientAtlas",
    "ReflectanceMap",
    "bragg_reflectance_map",
    "gradient_atlas",
    "plot_gradient_atlas",
    "plot_reflectance_map",
    "save_gradient_atlas_npz",
    "save_gradient_atlas_png",
    "save_reflectance_map_npz",
    "save_reflectance_map_png",
    "thin_film_reflectance_map",
    "SpherePanels",
    "SphereRender",
    "chroma_stats",
    "chroma_table_markdown",
    "lamp_spd",
    "plot_panels",
    "render_panels",
    "render_sphere",
    "save_panels_npz",
    "save_panels_png",
    "THIN_FILM_IBL_METHODS",
    "THIN_FILM_IBL_PANELS",
    "ThinFilmIBLComparison",
    "plot_thin_film_ibl",
    "save_thin_film_ibl_npz",
    "save_thin_film_ibl_png",
    "thin_film_ibl_comparison",
]
