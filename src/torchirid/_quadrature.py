"""Shared quadrature rules (one cached copy for the filter, the base-return quadrature and the
scatterogram renderer)."""

from __future__ import annotations

import numpy as np
import torch
from ._cache import cache_dict

_GL_CACHE: dict[int, tuple[np.ndarray, np.ndarray]] = cache_dict()


def gauss_legendre01(n: int, dtype, device):
    """``n``-point Gauss–Legendre nodes and weights on [0, 1] (numpy's rule, cached per ``n``)."""
    if n not in _GL_CACHE:
        x, w = np.polynomial.legendre.leggauss(n)
        _GL_CACHE[n] = (0.5 * (x + 1.0), 0.5 * w)
    x, w = _GL_CACHE[n]
    return torch.as_tensor(x, dtype=dtype, device=device), torch.as_tensor(w, dtype=dtype, device=device)
