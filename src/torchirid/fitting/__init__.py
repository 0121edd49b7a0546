"""Fitting layered Bragg materials to measurements: scatterogram matching by autograd."""

from .measured import ScatterogramImage, read_scatterogram, write_scatterogram
from .scatterogram import (
    ScatterogramAlternative,
    ScatterogramFit,
    bragg_structure,
    match_scatterogram,
    render_targets,
    scatterogram_loss,
)

__all__ = [
    "ScatterogramAlternative",
    "ScatterogramFit",
    "ScatterogramImage",
    "bragg_structure",
    "read_scatterogram",
    "match_scatterogram",
    "render_targets",
    "write_scatterogram",
    "scatterogram_loss",
]
