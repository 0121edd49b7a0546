r"""Residuals of the fast band model over many pixels, shared by the peak method and the refinement.

The fast band model (:func:`~torchirid.estimation.measurement.band_reflectance_fast`) of a lossless film is an
elementwise function of its terms (a, b, e, k, h) — each ``(pol, A, B)``, from
``band_terms()`` — and the thickness d. These helpers evaluate it for P
pixels × C thickness candidates at once, in chunks of bounded size:

* :func:`pixel_chunks` — the pixel ranges of one pass (bounded work per chunk: the block size
  of :mod:`torchirid._chunks`, ``torchirid.options(chunk_size=...)``);
* :func:`residual_parts` — the residual model − data, its closed-form ∂/∂d and the partials
  reused by the second-order band term;
* :func:`cube_sse` — Σ (model − cube)² per pixel and candidate: Kobayashi et al.'s eq. 14
  criterion, also the misfit every later stage compares;
* :func:`order_candidates` — d and d ± one interference-order period (the neighbouring
  basins of the multimodal misfit in d);
* :func:`decimation` and :func:`thickness_grid` — the reduced cube and the thickness grid the
  searches use.

Shapes: a cube of pixels is ``(P, A, B)`` (angles, bands); thicknesses are ``(P, C)``; dtype and
device follow the cube.
"""

from __future__ import annotations

import math

import torch

from .. import _chunks

__all__ = [
]

ORDER_OFFSETS = (-1.0, 0.0, 1.0)  # interference orders tried around a thickness, in periods T: the two neighbours
THICKNESS_GRID_DIVISOR = 8  # grid step λ_min/(8 n): a quarter of the fringe period λ/(2n), so one node per basin


def pixel_chunks(count: int, per_pixel: int, budget: int | None = None, *, device=None) -> list[tuple[int, int]]:
    """Ranges ``(i0, i1)`` covering ``count`` pixels with at most ``budget`` model samples each
    (``per_pixel`` samples per pixel; at least one pixel per chunk). The default budget is the
    block size on ``device`` (:func:`torchirid._chunks.get_chunk_size`, set by
    ``torchirid.options(chunk_size=...)``: small blocks stay in cache); ``chunk_size=None``
    there gives one range.

    >>> pixel_chunks(5, 80_000, 200_000)
    [(0, 2), (2, 4), (4, 5)]
    """
    if budget is None:
        budget = _chunks.get_chunk_size(device)
        if budget is None:  # chunking off: one pass
            return [(0, count)] if count > 0 else []
    step = max(1, budget // max(per_pixel, 1))
    return [(i, min(count, i + step)) for i in range(0, count, step)]


def terms_size(terms) -> int:
    """Model samples per pixel and candidate: the size of one term, ``pol × A × B``."""
    return terms[0].numel()


def residual_parts(y, d, terms, with_jacobian: bool = True):
    r"""Residual of the fast band model for thickness candidates, and its closed-form ∂/∂d.

    Args:
        y: ``(p, A, B)`` measured band reflectance.
        d: ``(p, C)`` thickness candidates (nm).
        terms: (a, b, e, k, h), each ``(pol, A, B)``.
        with_jacobian: False skips the derivatives.

    Returns:
        ``(r, Jd, parts)``: r ``(p, C, A, B)`` = model − y (averaged over polarizations);
        Jd ``(p, C, A, B)`` = ∂r/∂d, the band term h d² R'' included; parts = (R, g, u, R')
        per polarization. Jd and parts are None without the Jacobian.
    """
    a, b, e, k, h = terms
    dd = d[:, :, None, None, None]
    D = k * dd  # (p, C, pol, A, B)
    u, s = torch.cos(D), torch.sin(D)
    g = 1 / (e + b * u)
    E = e - a
    g2 = g * g
    R = 1 - E * g
    R2 = -E * b * g2 * (u + 2 * b * s * s * g)
    hd2 = h * dd * dd
    npol = a.shape[0]
    model = (R + hd2 * R2).sum(2) / npol
    r = model - y[:, None]
    if not with_jacobian:
        return r, None, None
    R1 = -E * b * s * g2
    R3 = -E * b * s * (-g2 + 6 * b * g2 * g * (u + b * s * s * g))
    Jd = (R1 * k + 2 * h * dd * R2 + hd2 * R3 * k).sum(2) / npol
    return r, Jd, (R, g, u, R1)


def cube_sse(cube, terms, thickness) -> torch.Tensor:
    """Σ over angles and bands of (model − cube)² for thickness candidates ``(P, C)`` → ``(P, C)``.

    ``terms`` = (a, b, e, k, h), each ``(pol, A, B)`` (``band_terms()``);
    cube ``(P, A, B)``. NaN candidates → +inf. NaN cube samples (missing data) are left out of
    the sum, so a pixel without a single finite sample gives the empty sum 0 for every candidate:
    it adds nothing to a sum over pixels and cannot decide a choice;
    ``peak_method()`` and :func:`~torchirid.estimation.estimate_film`
    report NaN thickness and error for such pixels.

    Example (one noise-free pixel of a 400 nm MgF₂ film on PET, three candidates, one NaN):
        >>> from torchirid.estimation import model_cube
        >>> from torchirid.estimation.refine import model_terms
        >>> w = torch.arange(400.0, 721.0, 8.0, dtype=torch.float64)  # nm
        >>> cos_t = torch.tensor([0.98, 0.64], dtype=torch.float64)
        >>> n = torch.tensor([1.37], dtype=torch.float64)
        >>> cube = model_cube(n, "constant", torch.tensor([400.0], dtype=torch.float64), w, cos_t, 1.64)  # (1, 2, 41)
        >>> cand = torch.tensor([[380.0, 400.0, math.nan]], dtype=torch.float64)  # nm
        >>> [round(v, 4) for v in cube_sse(cube, model_terms(n, "constant", w, cos_t, 1.64), cand)[0].tolist()]
        [0.0115, 0.0, inf]
    """
    P, C = thickness.shape
    out = torch.empty(P, C, dtype=cube.dtype, device=cube.device)
    for i0, i1 in pixel_chunks(P, C * terms_size(terms), device=cube.device):
        r, _, _ = residual_parts(cube[i0:i1], thickness[i0:i1].nan_to_num(0.0), terms, with_jacobian=False)
        r = r.nan_to_num(0.0)
        out[i0:i1] = (r * r).sum((-1, -2))
    return torch.where(thickness.isnan(), torch.full_like(out, math.inf), out)


def order_candidates(thickness, period) -> torch.Tensor:
    """The thicknesses ``(P,)`` and their neighbouring orders d ± T (T = ``period``, nm) → ``(P, 3)``;
    candidates ≤ 0 are NaN (no such order).

    >>> order_candidates(torch.tensor([100.0, 250.0]), 150.0).tolist()
    [[nan, 100.0, 250.0], [100.0, 250.0, 400.0]]
    """
    d = thickness
    D = d[:, None] + period * torch.as_tensor(ORDER_OFFSETS, dtype=d.dtype, device=d.device)
    return torch.where(D > 0, D, torch.full_like(D, math.nan))


def decimation(angles: int, bands: int, stride: int) -> tuple[list[int], list[int]]:
    """Indices of a reduced cube: the first, middle and last angles and every ``stride``-th band
    (all angles and bands for ``stride`` 1) — enough to tell interference orders and indices apart.

    >>> decimation(5, 10, 3)
    ([0, 2, 4], [0, 3, 6, 9])
    """
    a_sel = sorted({0, angles // 2, angles - 1}) if stride > 1 else list(range(angles))
    return a_sel, list(range(0, bands, stride))


def thickness_grid(thickness_range, step: float, like: torch.Tensor) -> torch.Tensor:
    """Thicknesses from ``thickness_range[0]`` to ``thickness_range[1]`` (included) every ``step`` nm,
    in the dtype and on the device of ``like``."""
    lo, hi = map(float, thickness_range)
    return torch.arange(lo, hi + step, step, dtype=like.dtype, device=like.device)
