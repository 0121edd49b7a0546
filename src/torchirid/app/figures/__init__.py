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

The names below load their module on first use (PEP 562): a command imports only its own
figure module, and ``torchirid --help`` none.
"""

from __future__ import annotations

import importlib

#: each public name → its module
_MODULES = {
    "CIRCLES_DEG": "scatterograms",
    "CURVE_WAVELENGTHS_NM": "gradients",
    "GRADIENT_ATLAS_STEPS": "gradients",
    "GRADIENT_METHODS": "gradients",
    "GradientAtlas": "gradients",
    "ReflectanceMap": "reflectance_maps",
    "SpherePanels": "spheres",
    "SphereRender": "spheres",
    "THIN_FILM_IBL_METHODS": "thin_film_ibl",
    "THIN_FILM_IBL_PANELS": "thin_film_ibl",
    "ThinFilmIBLComparison": "thin_film_ibl",
    "bragg_reflectance_map": "reflectance_maps",
    "chroma_stats": "spheres",
    "chroma_table_markdown": "spheres",
    "fig8_rows": "spheres",
    "gradient_atlas": "gradients",
    "lamp_spd": "spheres",
    "plot_film_map": "film_maps",
    "plot_gradient_atlas": "gradients",
    "plot_panels": "spheres",
    "plot_reflectance_map": "reflectance_maps",
    "plot_scatterograms": "scatterograms",
    "plot_thin_film_ibl": "thin_film_ibl",
    "render_panels": "spheres",
    "render_sphere": "spheres",
    "save_film_map_png": "film_maps",
    "save_gradient_atlas_npz": "gradients",
    "save_gradient_atlas_png": "gradients",
    "save_panels_npz": "spheres",
    "save_panels_png": "spheres",
    "save_reflectance_map_npz": "reflectance_maps",
    "save_reflectance_map_png": "reflectance_maps",
    "thin_film_reflectance_map": "reflectance_maps",
    "save_scatterograms_npz": "scatterograms",
    "save_scatterograms_png": "scatterograms",
    "save_thin_film_ibl_npz": "thin_film_ibl",
    "save_thin_film_ibl_png": "thin_film_ibl",
    "table1_objects": "spheres",
    "thin_film_ibl_comparison": "thin_film_ibl",
}

__all__ = [
    "CIRCLES_DEG",
    "CURVE_WAVELENGTHS_NM",
    "GRADIENT_ATLAS_STEPS",
    "GRADIENT_METHODS",
    "THIN_FILM_IBL_METHODS",
    "THIN_FILM_IBL_PANELS",
    "GradientAtlas",
    "ReflectanceMap",
    "SpherePanels",
    "SphereRender",
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
    "save_scatterograms_npz",
    "save_scatterograms_png",
    "save_thin_film_ibl_npz",
    "save_thin_film_ibl_png",
    "table1_objects",
    "thin_film_ibl_comparison",
    "thin_film_reflectance_map",
]


def __getattr__(name: str):
    if name in _MODULES:
        value = getattr(importlib.import_module(f".{_MODULES[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
