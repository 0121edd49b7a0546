"""Per-pixel maps of ``torchirid fit-film`` (film thickness, fit residual, error) → PNG.

One image with a colour bar per figure, built without pyplot (``matplotlib.figure.Figure``
with the Agg canvas that ``savefig`` picks for PNG): no backend is selected or changed.
Pixels without an estimate (NaN or ±inf: dead pixels, e.g. an ENVI ``data ignore value``) are
drawn in ``INVALID_COLOUR``, outside the colour map, and counted under the image.
"""

from __future__ import annotations

import os

import numpy as np

from ..._io import atomic_write
from ._format import figure_format

__all__ = ["INVALID_COLOUR", "plot_film_map", "save_film_map_png"]

INVALID_COLOUR = "#808080"  # mid grey: in none of the colour maps used (viridis, magma), so "no data" stands out


def plot_film_map(image, title: str, label: str, *, cmap: str = "viridis", invalid_colour: str = INVALID_COLOUR):
    """A ``(H, W)`` map as an image with a colour bar labelled ``label``; non-finite pixels in
    ``invalid_colour``, their count under the image. Returns the Figure."""
    import matplotlib
    from matplotlib.figure import Figure

    data = np.ma.masked_invalid(np.asarray(image, dtype=np.float64))
    invalid = int(np.ma.count_masked(data))
    fig = Figure(figsize=(5, 4.2), layout="constrained")
    ax = fig.add_subplot()
    im = ax.imshow(data, cmap=matplotlib.colormaps[cmap].with_extremes(bad=invalid_colour))
    ax.set_title(title, fontsize=10)
    ax.set_xticks([])
    ax.set_yticks([])
    if invalid:
        ax.set_xlabel(f"grey: {invalid} pixel{'s' if invalid > 1 else ''} without data (invalid)", fontsize=9)
    fig.colorbar(im, ax=ax, label=label)
    return fig


def save_film_map_png(image, path: str | os.PathLike, title: str, label: str, *, cmap: str = "viridis",
                      dpi: int = 100):
    """Draw :func:`plot_film_map` and write it atomically to ``path`` as a PNG; returns the ``Path``.

    The directory must exist; ``OSError`` propagates.
    """
    fig = plot_film_map(image, title, label, cmap=cmap)
    return atomic_write(path, lambda f: fig.savefig(f, format=figure_format(path), dpi=dpi))
