"""Fitting layered Bragg materials to measurements: scatterogram matching by autograd."""

from .measured import ScatterogramImage, load_scatterogram, save_scatterogram_exr, save_scatterogram_png
from .scatterogram import (
    DEFAULT_CELLS,
    DEFAULT_HARMONICS,
    DEFAULT_INIT,
    ScatterogramAlternative,
    ScatterogramFit,
    bragg_structure,
    match_scatterogram,
    render_targets,
    scatterogram_loss,
)

__all__ = [
    "DEFAULT_CELLS",
    "DEFAULT_HARMONICS",
    "DEFAULT_INIT",
    "ScatterogramAlternative",
    "ScatterogramFit",
    "ScatterogramImage",
    "bragg_structure",
    "load_scatterogram",
    "match_scatterogram",
    "render_targets",
    "save_scatterogram_exr",
    "save_scatterogram_png",
    "scatterogram_loss",
]
