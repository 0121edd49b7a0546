"""The figures of the ``torchirid`` command: data → ``matplotlib`` Figure → PNG, and ``.npz`` arrays.

Each product has a function that computes its data (a frozen dataclass of numpy arrays and a
JSON-ready ``params`` dict), a ``plot_*`` function that draws it (a ``matplotlib.figure.Figure``
built without pyplot: no backend is selected, nothing needs closing), and ``save_*_png`` /
``save_*_npz`` functions that write it atomically. Units: wavelengths and thicknesses in nm,
the angles of the grids in degrees (with their cosines alongside).

- :mod:`~torchirid.app.figures.reflectance_maps` — R(θ, λ) of a Bragg mirror or a thin film
  (``torchirid spectrum``);
- :mod:`~torchirid.app.figures.gradients` — the atlas of angular colour gradients of
  Fourneau et al. 2024, Fig. 4 (``torchirid gradients``);
- :mod:`~torchirid.app.figures.scatterograms` — scatterogram panels, PNG and ``.npz``
  (``torchirid scatterogram``; the forward model is :mod:`torchirid.layered.scatterograms`);
- :mod:`~torchirid.app.figures.spheres` — film-coated rough spheres of Hirayama et al. 2000
  (``torchirid render-sphere``);
- :mod:`~torchirid.app.figures.thin_film_ibl` — Kneiphof et al. 2019, Fig. 7 measured
  (``torchirid thin-film``);
- :mod:`~torchirid.app.figures.film_maps` — the per-pixel maps of ``torchirid fit-film``.
"""

from .film_maps import plot_film_map, save_film_map_png
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
from .reflectance_maps import (
    ReflectanceMap,
    bragg_reflectance_map,
    plot_reflectance_map,
    save_reflectance_map_npz,
    save_reflectance_map_png,
    thin_film_reflectance_map,
)
from .scatterograms import CIRCLES_DEG, plot_scatterograms, save_scatterograms_npz, save_scatterograms_png
from .spheres import (
    SpherePanels,
    SphereRender,
    chroma_stats,
    chroma_table_markdown,
    fig8_rows,
    lamp_spd,
    plot_panels,
    render_panels,
    render_sphere,
    save_panels_npz,
    save_panels_png,
    table1_objects,
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

__all__ = [
    "CIRCLES_DEG",
    "CURVE_WAVELENGTHS_NM",
    "GRADIENT_ATLAS_STEPS",
    "GRADIENT_METHODS",
    "GradientAtlas",
    "ReflectanceMap",
    "SpherePanels",
    "SphereRender",
    "THIN_FILM_IBL_METHODS",
    "THIN_FILM_IBL_PANELS",
    "ThinFilmIBLComparison",
    "bragg_reflectance_map",
    "chroma_stats",
    "chroma_table_markdown",
    "fig8_rows",
    "gradient_atlas",
    "lamp_spd",
    "plot_film_map",
    "plot_gradient_atlas",
    "plot_panels",
    "plot_reflectance_map",
    "plot_scatterograms",
    "plot_thin_film_ibl",
    "render_panels",
    "render_sphere",
    "save_film_map_png",
    "save_gradient_atlas_npz",
    "save_gradient_atlas_png",
    "save_panels_npz",
    "save_panels_png",
    "save_reflectance_map_npz",
    "save_reflectance_map_png",
    "thin_film_reflectance_map",
    "save_scatterograms_npz",
    "save_scatterograms_png",
    "save_thin_film_ibl_npz",
    "save_thin_film_ibl_png",
    "table1_objects",
    "thin_film_ibl_comparison",
]
