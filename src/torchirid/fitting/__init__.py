"""Fitting layered Bragg materials to measurements: scatterogram matching by autograd."""

from .measured import ScatterogramImage, read_scatterogram, write_scatterogram
from .results import ScatterogramAlternative, ScatterogramFit
from .scatterogram import match_scatterogram
from .targets import bragg_structure, render_targets, scatterogram_loss

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
