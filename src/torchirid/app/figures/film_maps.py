"""Per-pixel maps of ``torchirid fit-film`` (film thickness, fit residual, error) → PNG.

One image with a colour bar per figure, built without pyplot (``matplotlib.figure.Figure``
with the Agg canvas that ``savefig`` picks for PNG): no backend is selected or changed.
"""

from __future__ import annotations

import os

import numpy as np

from ..._io import atomic_write

__all__ = ["plot_film_map", "save_film_map_png"]


def plot_film_map(image, title: str, label: str, *, cmap: str = "viridis"):
    """A ``(H, W)`` map as an image with a colour bar labelled ``label``; returns the Figure."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(5, 4.2), layout="constrained")
    ax = fig.add_subplot()
    im = ax.imshow(np.asarray(image), cmap=cmap)
    ax.set_title(title, fontsize=10)
    ax.set_xticks([])
    ax.set_yticks([])
    fig.colorbar(im, ax=ax, label=label)
    return fig


def save_film_map_png(image, path: str | os.PathLike, title: str, label: str, *, cmap: str = "viridis",
                      dpi: int = 100):
    """Draw :func:`plot_film_map` and write it atomically to ``path`` as a PNG; returns the ``Path``.

    The directory must exist; ``OSError`` propagates.
    """
    fig = plot_film_map(image, title, label, cmap=cmap)
    return atomic_write(path, lambda f: fig.savefig(f, format="png", dpi=dpi))
