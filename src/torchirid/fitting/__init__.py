"""Fitting layered Bragg materials to measurements: scatterogram matching by autograd."""

from .scatterogram import (
    DEFAULT_CELLS,
    DEFAULT_INIT,
    ScatterogramFit,
    bragg_structure,
    match_scatterogram,
    render_targets,
    scatterogram_loss,
)

__all__ = [
    "DEFAULT_CELLS",
    "DEFAULT_INIT",
    "ScatterogramFit",
    "bragg_structure",
    "match_scatterogram",
    "render_targets",
    "scatterogram_loss",
]
