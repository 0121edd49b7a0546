r"""The Gauss–Newton pieces of the film fits, shared by the refinement and the pipeline: the band
model's terms (:func:`model_terms`), its exact Jacobian (:func:`lm_jacobian`: forward-mode in the
index parameters, reverse-mode over the pixels, chained), d-only Gauss–Newton steps
(:func:`d_only_gauss_newton`), the smoothness terms, and the scans of the index
(:func:`scan_index`, :func:`grid_scan`)."""


from __future__ import annotations

import math

import torch

from .. import _autograd, _checks
from ._validation import band_settings, cube_axes, real_index, value_range
from .dispersion import index_model
from .measurement import band_terms
from .residuals import (THICKNESS_GRID_DIVISOR, cube_sse, order_candidates, pixel_chunks, residual_parts, terms_size,
                        thickness_grid)

__all__ = []

MAX_THICKNESS_STEP = 30.0  # nm per step: under a quarter of the shortest fringe period (λ/(2n) ≈ 120 nm for ZnS)


SCAN_ITERATIONS = 3  # d-only Gauss–Newton steps per candidate and grid index in scan_index


POLISH_ITERATIONS = 2  # Gauss–Newton steps polishing a thickness found on a grid (a quarter fringe away at most)



def model_terms(params, index_model_name, wavelength, cos_theta, n_substrate, *, bandwidth=4.0, passband="box",
                n_incident=1.0, polarization="unpolarized"):
    """Terms (a, b, e, k, h), each ``(pol, A, B)``, of :func:`~torchirid.estimation.measurement.band_reflectance_fast`
    for index parameters ``params`` ``(K,)``; ``wavelength`` ``(B,)`` nm, ``cos_theta`` ``(A,)``.

    Example (a Cauchy film n(λ) = 1.45 + 0.004/λ_µm² on PET, 3 angles × 41 bands):
        >>> w = torch.arange(400.0, 721.0, 8.0, dtype=torch.float64)  # nm
        >>> cos_t = torch.tensor([0.98, 0.77, 0.64], dtype=torch.float64)
        >>> terms = model_terms(torch.tensor([1.45, 0.004], dtype=torch.float64), "cauchy", w, cos_t, 1.64)
        >>> len(terms), tuple(terms[0].shape)  # (a, b, e, k, h); unpolarized: the s and p terms
        (5, (2, 3, 41))
    """
    return band_terms(wavelength, cos_theta[:, None], lambda lam: index_model(lam, params, index_model_name),
                      n_substrate, bandwidth=bandwidth, passband=passband, n_incident=n_incident, polarization=polarization)



def _band_model(terms, d):
    """Elementwise fast band model R + h d² R'' (:func:`~torchirid.estimation.measurement.band_reflectance_fast`
    before the mean over polarizations), broadcasting terms and d."""
    a, b, e, k, h = terms
    D = k * d
    u, s = torch.cos(D), torch.sin(D)
    g = 1 / (e + b * u)
    E = e - a
    return 1 - E * g - h * d * d * E * b * g * g * (u + 2 * b * s * s * g)



@_autograd.fits_with_autograd  # (its Jacobian is one reverse-mode pass)
def lm_jacobian(y, d, terms, dterms=None):
    r"""Residual and its exact Jacobian for one Levenberg–Marquardt step, pixels ``y`` ``(p, A, B)``.

    r_pab = R_b(θ_a; n_θ, d_p) − y_pab is the fast band model
    (:func:`~torchirid.estimation.measurement.band_reflectance_fast`, band-width term h d² R'' included), an
    elementwise function f(a, b, e, k, h, d) of the terms of :func:`model_terms` and the pixel's
    d, averaged over polarizations. One reverse-mode autograd pass through f, with the terms and
    d broadcast to the full ``(p, pol, A, B)`` grid, gives every elementwise partial ∂f/∂t at
    once (the gradient of Σf with respect to an element is that element's own partial, f being
    elementwise); then, exactly,

    .. math:: ∂r_{pab}/∂d_p = \overline{∂f/∂d}, \qquad
              ∂r_{pab}/∂θ_j = \overline{\textstyle\sum_t ∂f/∂t \; ∂t_{ab}/∂θ_j},

    the bar the mean over polarizations and ``dterms`` = ∂t/∂θ on the small ``(pol, A, B)`` grid
    (e.g. ``torch.func.jacfwd`` of :func:`model_terms`). ∂r/∂d is diagonal in the pixels (d_p
    only moves pixel p), so it is returned as one value per sample.

    Args:
        y: ``(p, A, B)`` measured band reflectance (NaN-free); d: ``(p,)`` thickness (nm).
        terms: (a, b, e, k, h), each ``(pol, A, B)``; dterms: their θ-Jacobians ``(pol, A, B, K)`` or None.

    Returns:
        ``(r, Jd, Jt)``: ``(p, A, B)``, ``(p, A, B)`` and ``(p, A, B, K)`` (None without ``dterms``).

    Example (3 pixels, 2 angles × 41 bands, a constant index: K = 1):
        >>> w = torch.arange(400.0, 721.0, 8.0, dtype=torch.float64)  # nm
        >>> cos_t = torch.tensor([0.98, 0.64], dtype=torch.float64)
        >>> theta = torch.tensor([1.37], dtype=torch.float64)
        >>> terms = model_terms(theta, "constant", w, cos_t, 1.64)
        >>> dterms = torch.func.jacfwd(lambda t: model_terms(t, "constant", w, cos_t, 1.64))(theta)
        >>> y = torch.zeros(3, 2, 41, dtype=torch.float64)
        >>> d = torch.tensor([380.0, 400.0, 420.0], dtype=torch.float64)  # nm
        >>> r, Jd, Jt = lm_jacobian(y, d, terms, dterms)
        >>> tuple(r.shape), tuple(Jd.shape), tuple(Jt.shape)
        ((3, 2, 41), (3, 2, 41), (3, 2, 41, 1))
        >>> r2 = lm_jacobian(y, d + 1e-6, terms)[0]  # ∂r/∂d against a finite difference
        >>> bool(((r2 - r) / 1e-6 - Jd).abs().max() < 1e-8)
        True
    """
    if dterms is None:  # thickness only: the closed-form ∂r/∂d (same values, no graph)
        r, Jd, _ = residual_parts(y, d[:, None], terms)
        return r[:, 0], Jd[:, 0], None
    P = y.shape[0]
    npol = terms[0].shape[0]
    full = (P,) + tuple(terms[0].shape)
    with torch.enable_grad():
        dd = d.detach()[:, None, None, None].expand(full).requires_grad_(True)
        leaves = [t.detach().expand(full).requires_grad_(True) for t in terms]
        f = _band_model(leaves, dd)
        grads = torch.autograd.grad(f.sum(), [dd] + leaves)
    r = f.detach().sum(1) / npol - y
    Jd = grads[0].sum(1) / npol
    Jt = sum(torch.einsum("pxab,xabk->pabk", g, dt) for g, dt in zip(grads[1:], dterms)) / npol
    return r, Jd, Jt



def d_only_gauss_newton(cube, thickness, terms, *, iterations: int = 3, max_step: float = MAX_THICKNESS_STEP):
    """Per-pixel, per-candidate Gauss–Newton on d with the index fixed (batched, no loops over pixels).

    Args:
        cube: ``(P, A, B)``; thickness ``(P, C)`` starts (C candidates per pixel, NaN ignored).
        terms: from :func:`model_terms` / ``band_terms()``, ``(pol, A, B)``.
        iterations: Gauss–Newton steps (≥ 0); max_step: the most one step moves d (nm, > 0).

    Returns:
        ``(d, sse)`` both ``(P, C)``; a step that raises a candidate's misfit is refused.

    Example (two noise-free pixels, 380 and 420 nm, from starts up to 15 nm off; NaN: no candidate):
        >>> from torchirid.estimation import model_cube
        >>> w = torch.arange(400.0, 721.0, 8.0, dtype=torch.float64)  # nm
        >>> cos_t = torch.tensor([0.98, 0.77, 0.64], dtype=torch.float64)
        >>> n = torch.tensor([1.37], dtype=torch.float64)
        >>> cube = model_cube(n, "constant", torch.tensor([380.0, 420.0], dtype=torch.float64), w, cos_t, 1.64)
        >>> start = torch.tensor([[370.0, 395.0], [430.0, math.nan]], dtype=torch.float64)  # (P, C) nm
        >>> d, sse = d_only_gauss_newton(cube, start, model_terms(n, "constant", w, cos_t, 1.64))
        >>> [[round(v, 6) for v in row] for row in d.tolist()], sse[1, 1].item()
        ([[380.0, 380.0], [420.0, nan]], inf)
    """
    iterations = _checks.check_int(iterations, "iterations", minimum=0)
    if not max_step > 0:
        raise ValueError(f"max_step must be > 0 nm; got {max_step!r}")
    if cube.ndim != 3 or thickness.ndim != 2 or thickness.shape[0] != cube.shape[0]:
        raise ValueError(f"cube must be (P, A, B) and thickness (P, C); got {tuple(cube.shape)} and "
                         f"{tuple(thickness.shape)}")
    P, C = thickness.shape
    d = thickness.clone()
    nan = d.isnan()
    d = d.nan_to_num(0.0)
    sse_out = torch.empty_like(d)
    for i0, i1 in pixel_chunks(P, C * terms_size(terms), device=cube.device):
        y, dd = cube[i0:i1], d[i0:i1]
        r, Jd, _ = residual_parts(y, dd, terms)
        r = r.nan_to_num(0.0)
        sse = (r * r).sum((-1, -2))
        for it in range(iterations):
            g = (Jd * r).sum((-1, -2))
            H = (Jd * Jd).sum((-1, -2))
            step = (-g / H.clamp_min(torch.finfo(H.dtype).tiny)).clamp(-max_step, max_step)
            new = (dd + step).clamp_min(0.0)
            last = it + 1 == iterations
            r2, Jd2, _ = residual_parts(y, new, terms, with_jacobian=not last)
            r2 = r2.nan_to_num(0.0)
            sse2 = (r2 * r2).sum((-1, -2))
            better = sse2 < sse
            dd = torch.where(better, new, dd)
            sse = torch.where(better, sse2, sse)
            if not last:
                m = better[:, :, None, None]
                r, Jd = torch.where(m, r2, r), torch.where(m, Jd2, Jd)
        d[i0:i1] = dd
        sse_out[i0:i1] = sse
    d = torch.where(nan, torch.full_like(d, math.nan), d)
    sse_out = torch.where(nan, torch.full_like(sse_out, math.inf), sse_out)
    return d, sse_out



def _smooth_terms(d_img, mu_s, mask=None):
    """(value, gradient, diagonal) of mu_s·Σ_{4-neighbours}(d_p − d_q)² for an image (H, W); with a
    ``mask`` (H, W) only the pairs of two pixels in the mask count (a pixel without data is no
    neighbour)."""
    if mu_s == 0 or d_img.ndim != 2:
        z = torch.zeros_like(d_img)
        return d_img.new_zeros(()), z, z
    if mask is None:
        mask = torch.ones_like(d_img, dtype=torch.bool)
    wx = (mask[:, 1:] & mask[:, :-1]).to(d_img.dtype)
    wy = (mask[1:, :] & mask[:-1, :]).to(d_img.dtype)
    dx = (d_img[:, 1:] - d_img[:, :-1]) * wx
    dy = (d_img[1:, :] - d_img[:-1, :]) * wy
    val = mu_s * ((dx * dx).sum() + (dy * dy).sum())
    g = torch.zeros_like(d_img)
    g[:, 1:] += 2 * mu_s * dx
    g[:, :-1] -= 2 * mu_s * dx
    g[1:, :] += 2 * mu_s * dy
    g[:-1, :] -= 2 * mu_s * dy
    deg = torch.zeros_like(d_img)
    deg[:, 1:] += wx
    deg[:, :-1] += wx
    deg[1:, :] += wy
    deg[:-1, :] += wy
    return val, g, 2 * mu_s * deg



def _pixels_axes(cube, wavelength, cos_theta, thickness=None):
    """Validated ``(P, A, B)`` pixels with their axes for :func:`scan_index` / :func:`grid_scan`."""
    y, lam, c = cube_axes(cube, wavelength, cos_theta)
    if y.ndim != 3:
        raise ValueError(f"cube must have shape (P, A, B); got {tuple(y.shape)}")
    if thickness is not None:
        d = _checks.as_real(thickness, "thickness", y.dtype, y.device)
        if d.shape != y.shape[:1]:
            raise ValueError(f"thickness must have one value per pixel ({y.shape[0]}); got shape {tuple(d.shape)}")
        return y, lam, c, d
    return y, lam, c



def scan_index(cube, thickness, n_start, wavelength, cos_theta, n_substrate, *, rel_range=0.15, steps: int = 21,
               slopes=(0.0,), bandwidth=4.0, passband="box", polarization="unpolarized", n_incident=1.0):
    """Best index n(λ) = A + B/λ_µm² on a grid by total misfit of ``cube`` ``(P, A, B)``.

    The grid: n(λ_mid) ∈ n_start·[1 − r, 1 + r] (``steps`` values) × B ∈ ``slopes`` (µm²;
    ``(0,)``: constant index). For each grid value the pixel's optical thickness is kept
    (d·√(n²−s²) fixed), the three nearest interference orders are tried and polished by
    :func:`d_only_gauss_newton` (``SCAN_ITERATIONS`` steps). Guards against a biased eq. 12
    estimate (dispersive films: Kobayashi et al.'s ZnS). Returns
    ``(params (2,) = (A, B), d_best (P,), grid (N, 2), losses (N,))``.

    Example (two noise-free MgF₂ pixels, n = 1.37, from n_start = 1.40 and thicknesses 5 nm off):
        >>> from torchirid.estimation import model_cube
        >>> w = torch.arange(400.0, 721.0, 8.0, dtype=torch.float64)  # nm
        >>> cos_t = torch.tensor([0.98, 0.77, 0.64], dtype=torch.float64)
        >>> cube = model_cube(torch.tensor([1.37], dtype=torch.float64), "constant",
        ...                   torch.tensor([380.0, 420.0], dtype=torch.float64), w, cos_t, 1.64)
        >>> d0 = torch.tensor([385.0, 415.0], dtype=torch.float64)  # nm
        >>> params, d, grid, losses = scan_index(cube, d0, 1.40, w, cos_t, 1.64, rel_range=0.05, steps=11)
        >>> round(float(params[0]), 2), float(params[1]), tuple(grid.shape), [round(v) for v in d.tolist()]
        (1.37, 0.0, (11, 2), [379, 419])
    """
    y, lam, c, thickness = _pixels_axes(cube, wavelength, cos_theta, thickness)
    band_settings(bandwidth, passband, polarization)
    n_start = real_index(n_start, "n_start", y)
    ns = real_index(n_substrate, "n_substrate", y)
    n_incident = real_index(n_incident, "n_incident", y, incident=True)
    steps = _checks.check_int(steps, "steps")
    if not 0 <= rel_range < 1:
        raise ValueError(f"rel_range must be in [0, 1); got {rel_range!r}")
    try:
        slopes = tuple(float(b) for b in slopes)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"slopes must be a sequence of numbers (Cauchy B in µm²); got {slopes!r}") from exc
    dtype, device = y.dtype, y.device
    s2 = (n_incident ** 2) * (1 - c * c)
    lam_mid = float(lam.median())
    inv_mid = (1000.0 / lam_mid) ** 2
    mids = n_start * torch.linspace(1 - rel_range, 1 + rel_range, steps, dtype=dtype, device=device)
    grid = torch.tensor([[float(m) - b * inv_mid, b] for m in mids for b in slopes], dtype=dtype, device=device)
    losses, ds = [], []
    nc0 = float(torch.sqrt(n_start ** 2 - s2).mean())
    for A_, B_ in grid.tolist():
        n_mid = A_ + B_ * inv_mid
        terms = band_terms(lam, c[:, None], lambda l: A_ + B_ * (1000.0 / l) ** 2, ns, bandwidth=bandwidth,
                           passband=passband, n_incident=n_incident, polarization=polarization)
        nc = float(torch.sqrt(n_mid ** 2 - s2).mean())
        D = order_candidates(thickness * (nc0 / nc), lam_mid / (2 * nc))
        dd, sse = d_only_gauss_newton(y, D, terms, iterations=SCAN_ITERATIONS)
        best = sse.argmin(-1, keepdim=True)
        losses.append(float(sse.gather(-1, best).sum()))
        ds.append(dd.gather(-1, best)[:, 0])
    losses = torch.tensor(losses, dtype=dtype, device=device)
    i = int(losses.argmin())
    return grid[i], ds[i], grid, losses



def grid_scan(cube, wavelength, cos_theta, n_substrate, n_grid, *, thickness_range=(20.0, 2000.0),
              bandwidth=4.0, passband="box", polarization="unpolarized", n_incident=1.0):
    """Exhaustive search, independent of any peak: for each constant index of ``n_grid`` the
    best thickness of every pixel of ``cube`` ``(P, A, B)`` on a grid of step λ_min/(8√(n²−s²))
    (``THICKNESS_GRID_DIVISOR``: inside one interference basin), polished by ``POLISH_ITERATIONS``
    Gauss–Newton steps.

    Returns ``(losses (N,), thickness (N, P))`` — the total misfit per index and the thicknesses.
    Cost N × P × (grid size) model evaluations: meant for a pixel sample or few pixels.

    Example (two noise-free MgF₂ pixels, n = 1.37, 380 and 420 nm; three indices tried):
        >>> from torchirid.estimation import model_cube
        >>> w = torch.arange(400.0, 721.0, 8.0, dtype=torch.float64)  # nm
        >>> cos_t = torch.tensor([0.98, 0.77, 0.64], dtype=torch.float64)
        >>> cube = model_cube(torch.tensor([1.37], dtype=torch.float64), "constant",
        ...                   torch.tensor([380.0, 420.0], dtype=torch.float64), w, cos_t, 1.64)
        >>> losses, d = grid_scan(cube, w, cos_t, 1.64, [1.30, 1.37, 1.45], thickness_range=(300.0, 500.0))
        >>> int(losses.argmin()), tuple(d.shape), [round(v, 3) for v in d[1].tolist()]
        (1, (3, 2), [380.0, 420.0])
    """
    y, lam, c = _pixels_axes(cube, wavelength, cos_theta)
    band_settings(bandwidth, passband, polarization)
    ns = real_index(n_substrate, "n_substrate", y)
    n_incident = real_index(n_incident, "n_incident", y, incident=True)
    thickness_range = value_range(thickness_range, "thickness_range", positive=False, nm=True)
    _checks.check_numbers(n_grid=n_grid)
    n_grid = _checks.as_real(n_grid, "n_grid", y.dtype, y.device).reshape(-1)
    _checks.check_index(n_grid, "n_grid")
    s2 = (n_incident ** 2) * (1 - c * c)
    losses, ds = [], []
    for n in n_grid.tolist():
        terms = band_terms(lam, c[:, None], n, ns, bandwidth=bandwidth, passband=passband, n_incident=n_incident,
                           polarization=polarization)
        step = float(lam.min()) / (THICKNESS_GRID_DIVISOR * float(torch.sqrt(n * n - s2).max()))
        grid = thickness_grid(thickness_range, step, y)
        sse = cube_sse(y, terms, grid.expand(y.shape[0], -1))
        d0 = grid[sse.argmin(-1)][:, None]
        d, s = d_only_gauss_newton(y, d0, terms, iterations=POLISH_ITERATIONS, max_step=step)
        losses.append(float(s.sum()))
        ds.append(d[:, 0])
    return torch.tensor(losses, dtype=y.dtype, device=y.device), torch.stack(ds)

