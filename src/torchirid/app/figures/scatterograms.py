"""Scatterogram figures and files (Fourneau et al. 2024 §5, Fig. 9): panels → PNG, XYZ → ``.npz``.

The forward model — :func:`~torchirid.layered.scatterograms.scatterogram`, the angular
mappings and :func:`~torchirid.layered.scatterograms.scatterogram_srgb` — is in the library
(:mod:`torchirid.layered.scatterograms`). Here: :func:`plot_scatterograms` lays out a grid of
scatterograms (sRGB, an exposure, the 5°, 30°, 60° and 90° circles in red as in Fig. 9, no
colour bar), :func:`save_scatterograms_png` writes it; :func:`save_scatterograms_npz` writes
the XYZ arrays.
"""

from __future__ import annotations

import json
import math
import os
from typing import Sequence

import numpy as np
import torch

from ..._io import atomic_write, json_ready
from ._format import figure_format
from ...layered import Scatterogram, projection_radius, scatterogram_srgb

__all__ = [
    "CIRCLES_DEG",
    "plot_scatterograms",
    "save_scatterograms_npz",
    "save_scatterograms_png",
]

#: the circles of Fig. 9 (reflection angles θ_o in degrees)
CIRCLES_DEG = (5.0, 30.0, 60.0, 90.0)


def _grid(scatterograms) -> list[list[Scatterogram]]:
    if isinstance(scatterograms, Scatterogram):
        return [[scatterograms]]
    rows = list(scatterograms)
    if rows and all(isinstance(s, Scatterogram) for s in rows):
        return [rows]
    rows = [list(r) for r in rows]
    if not rows or not all(r and all(isinstance(s, Scatterogram) for s in r) for r in rows):
        raise ValueError("scatterograms must be a Scatterogram, a sequence of them, or a sequence of rows of them")
    return rows


def plot_scatterograms(scatterograms, *, exposure="auto", row_labels: Sequence[str] | None = None,
                       circles: Sequence[float] = CIRCLES_DEG, panel_inches: float = 2.2):
    """Draw scatterograms side by side: one panel each (sRGB, black outside the disc), the
    reflection-angle ``circles`` in red with their labels (as in Fig. 9), each panel's title
    above it, optional row labels on the left; no axes, no colour bar.

    Args:
        scatterograms: a :class:`~torchirid.layered.scatterograms.Scatterogram`, a sequence
            (one row) or a sequence of rows.
        exposure: a number > 0 multiplying every XYZ, or ``"auto"`` (each panel's brightest Y → 1).
        row_labels: one label per row (e.g. the illumination).
        circles: reflection angles θ_o of the red circles, in degrees.

    Returns a ``matplotlib.figure.Figure`` built without pyplot (no backend change, no closing).
    """
    from matplotlib.figure import Figure
    from matplotlib.patches import Circle

    rows = _grid(scatterograms)
    ncols = max(len(r) for r in rows)
    if row_labels is not None and len(row_labels) != len(rows):
        raise ValueError(f"row_labels must have one label per row ({len(rows)}); got {len(row_labels)}")
    left = 0.35 if row_labels else 0.05
    fig = Figure(figsize=(left + panel_inches * ncols, 0.15 + (panel_inches + 0.3) * len(rows)))
    fig.patch.set_facecolor("white")
    gs = fig.add_gridspec(len(rows), ncols, left=left / fig.get_figwidth(), right=0.995, bottom=0.01,
                          top=1 - 0.3 / fig.get_figheight(), wspace=0.04, hspace=0.14)
    for i, row in enumerate(rows):
        for j, sg in enumerate(row):
            ax = fig.add_subplot(gs[i, j])
            ax.imshow(scatterogram_srgb(sg, exposure), extent=(-1, 1, -1, 1), origin="upper",
                      interpolation="nearest")
            for deg in circles:
                r = float(projection_radius(math.radians(deg), sg.projection))
                ax.add_patch(Circle((0, 0), r, fill=False, ec="red", lw=0.6, alpha=0.9))
                ax.text(r * math.cos(math.radians(40)) + 0.015, r * math.sin(math.radians(40)) + 0.015,
                        f"{deg:g}°", color="red", fontsize=5.5, ha="left", va="bottom")
            ax.set_xlim(-1.04, 1.04)
            ax.set_ylim(-1.04, 1.04)
            ax.set_aspect("equal")
            ax.axis("off")
            if sg.title:
                ax.set_title(sg.title, fontsize=7, pad=2)
            if row_labels and j == 0:
                ax.text(-1.12, 0.0, row_labels[i], rotation=90, ha="right", va="center", fontsize=7,
                        transform=ax.transData)
    return fig


def save_scatterograms_png(scatterograms, path: str | os.PathLike, *, dpi: int = 150, **plot_kwargs):
    """Draw :func:`plot_scatterograms` and write it atomically to ``path`` as a PNG.

    The directory must exist; ``OSError`` propagates. Returns ``path`` as a ``Path``.
    """
    fig = plot_scatterograms(scatterograms, **plot_kwargs)
    return atomic_write(path, lambda f: fig.savefig(f, format=figure_format(path), dpi=dpi, facecolor="white"))


def save_scatterograms_npz(scatterograms, path: str | os.PathLike):
    """Write the scatterograms' arrays atomically to ``path`` (readable with ``allow_pickle=False``):
    ``xyz`` (R, C, H, W, 3) float64, ``mask`` (H, W), ``wavelength_nm`` (W,), ``titles`` (R, C) and
    ``params`` (a JSON string: one dict per panel). All panels must share the resolution."""
    rows = _grid(scatterograms)
    if len({len(r) for r in rows}) != 1 or len({tuple(s.xyz.shape) for r in rows for s in r}) != 1:
        raise ValueError("save_scatterograms_npz needs a full grid of scatterograms of one resolution")
    xyz = np.stack([np.stack([s.xyz.detach().cpu().to(torch.float64).numpy() for s in r]) for r in rows])
    arrays = dict(
        xyz=xyz,
        mask=rows[0][0].mask.cpu().numpy(),
        wavelength_nm=rows[0][0].wavelength.detach().cpu().to(torch.float64).numpy(),
        titles=np.array([[s.title for s in r] for r in rows]),
        params=np.array(json.dumps(json_ready([[s.params | {"title": s.title} for s in r] for r in rows]), sort_keys=True, allow_nan=False)),
    )
    return atomic_write(path, lambda f: np.savez(f, **arrays))
