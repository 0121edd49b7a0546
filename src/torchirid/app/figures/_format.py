"""The file format of a figure from its path: PNG, PDF or SVG (the suffix decides)."""

from __future__ import annotations

import os

__all__ = ["FIGURE_FORMATS", "figure_format"]

#: formats every figure command writes (``--format``)
FIGURE_FORMATS = ("png", "pdf", "svg")


def figure_format(path) -> str:
    """``"png"``, ``"pdf"`` or ``"svg"`` from the suffix of ``path``; ValueError for another one.

    >>> figure_format("out/spectrum.svg")
    'svg'
    """
    suffix = os.path.splitext(os.fspath(path))[1].lower().lstrip(".")
    if suffix not in FIGURE_FORMATS:
        raise ValueError(f"path {os.fspath(path)!r}: a figure is written as one of "
                         f"{', '.join('.' + f for f in FIGURE_FORMATS)}")
    return suffix
