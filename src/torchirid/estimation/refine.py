r"""Refinement of the film index (shared) and per-pixel thickness by batched Levenberg–Marquardt.

The objective is the least-squares misfit of the band-integrated model to the whole cube
(every pixel, angle and band; Kobayashi et al. eq. 14 extended to all unknowns at once),

.. math:: L(θ, d) = \sum_{p,a,b} \big(R_b(θ_a; n_θ, d_p) - y_{pab}\big)^2
          + μ_s \sum_{p \sim q} (d_p - d_q)^2,

with n_θ(λ) an index model of :mod:`~torchirid.estimation.dispersion` (θ = its K ≤ 3
parameters, shared by all pixels), d_p one thickness per pixel, and an optional smoothness
weight μ_s over the 4-neighbours of an image (Kobayashi et al.'s third assumption, §4).

Each Gauss–Newton step is exact for the arrow-shaped normal matrix — one scalar block per
pixel plus the K×K index block — by the Schur complement, so a 256 × 256 cube costs one
Jacobian pass, not a 65 536-dimensional solve. The Jacobian is exact (:func:`lm_jacobian`):
the terms (a, b, e, k, h) of ``band_terms()`` are differentiated in θ
by forward-mode autograd (``torch.func.jacfwd``) on the small (polarization × angle × band)
grid, the elementwise partials of the band model in those terms and in d by one batched
reverse-mode pass over the pixels, and the two chained — the band-width term h d² R''
included (the tests compare the whole Jacobian with ``torch.func.jacfwd`` of the residual).

d is multimodal (one basin per interference order): :func:`refine_film` keeps the order
from its start, then re-tests every pixel at d ± one order period T = λ/(2√(n²−sin²θ)) in
one batched call (a few d-only Gauss–Newton steps each) and keeps the best. Pixels whose
misfit stays above 10× the median are left out of the index update (robust to stray orders).

Missing data: a non-finite sample of the cube (NaN, ±inf) is left out of every sum; a pixel
without a single finite sample enters no sum — neither the misfit, nor the median of the inlier
test, nor a smoothness pair — and comes back with NaN thickness and misfit.

:func:`refine_film` runs in stages — :func:`_refine_inputs` (validation), :func:`_lm_fit` (the
damped iterations: :func:`_normal_equations` then :func:`_damped_step`) and :func:`_order_check`.
The tuning constants (``LM_*``, ``INLIER_MISFIT_RATIO``, ``MAX_THICKNESS_STEP``, ...) are
module-level names, each with the reason for its value.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import torch

from .. import _checks
from ._validation import band_settings, cube_axes, real_index, value_range, weight
from .dispersion import INDEX_MODELS, index_model
from .measurement import band_terms
from .residuals import (THICKNESS_GRID_DIVISOR, cube_sse, order_candidates, pixel_chunks, residual_parts, terms_size,
                        thickness_grid)

__all__ = [
    "RefineResult",
    "refine_film",
]

LM_DAMPING_START = 1e-3  # initial Levenberg–Marquardt damping μ: nearly Gauss–Newton, the start is usually close
LM_DAMPING_MIN = 1e-9  # floor of μ after accepted steps (keeps the damped system well conditioned)
LM_DAMPING_MAX = 1e8  # an iteration gives up once μ exceeds this: the step is then ~0, no descent left
LM_DAMPING_DECREASE = 3.0  # μ /= 3 after an accepted step (Marquardt's usual factors: slower down than up)
LM_DAMPING_INCREASE = 5.0  # μ *= 5 after a refused step: a few refusals reach a short gradient step
INLIER_MISFIT_RATIO = 10.0  # pixels above 10× the median misfit (stray orders) do not steer the index
MAX_THICKNESS_STEP = 30.0  # nm per step: under a quarter of the shortest fringe period (λ/(2n) ≈ 120 nm for ZnS)
ORDER_CHECK_ITERATIONS = 3  # d-only Gauss–Newton steps per order candidate in refine_film's final order check
SCAN_ITERATIONS = 3  # d-only Gauss–Newton steps per candidate and grid index in scan_index
POLISH_ITERATIONS = 2  # Gauss–Newton steps polishing a thickness found on a grid (a quarter fringe away at most)
FALLBACK_THICKNESS = 100.0  # nm: start where thickness_init is NaN everywhere (any finite value; empty pixels end NaN)


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


@_checks.fits_with_autograd  # (its Jacobian is one reverse-mode pass)
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


@dataclass
class RefineResult:
    """params ``(K,)`` of the index model; thickness ``(*)`` nm; sse ``(*)`` per-pixel misfit;
    loss history; iterations run; reordered: pixels whose order changed in the order check.

    Example (what :func:`refine_film` returns, here for a 2 × 2 pixel synthetic MgF₂ cube):
        >>> from torchirid.estimation import synthetic_cube
        >>> c = synthetic_cube("mgf2_400", height=2, width=2, seed=1)
        >>> r = refine_film(c.cube, c.wavelength, c.cos_theta, 1.64, torch.full((2, 2), 400.0, dtype=torch.float64),
        ...                 1.35, iterations=5)
        >>> r.index_model, round(float(r.params[0]), 2), tuple(r.sse.shape), r.iterations, len(r.history)
        ('constant', 1.37, (2, 2), 5, 5)
    """

    params: torch.Tensor
    index_model: str
    thickness: torch.Tensor
    sse: torch.Tensor
    history: list = field(default_factory=list)
    iterations: int = 0
    reordered: int = 0


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


class _Fit:
    """One validated refinement problem: the pixels ``Y`` ``(P, A, B)`` (missing samples → 0) with
    their mask of finite samples ``valid``, the band grid, the index model and the band-model
    keywords; evaluates the misfit. ``has_data`` ``(P,)``: pixels with at least one finite sample."""

    def __init__(self, Y, valid, lam, c, ns, model, band, batch, smoothness):
        self.Y, self.valid, self.lam, self.c, self.ns = Y, valid, lam, c, ns
        self.model, self.band, self.batch, self.smoothness = model, band, batch, smoothness
        self.image = len(batch) == 2 and smoothness > 0
        self.has_data = valid.any(-1).any(-1)

    @property
    def data(self):
        """The pixels with their missing samples NaN (what :func:`d_only_gauss_newton` skips)."""
        return torch.where(self.valid, self.Y, math.nan)

    def terms(self, theta):
        """Terms (a, b, e, k, h) of the index parameters ``theta`` on the whole grid."""
        return model_terms(theta, self.model, self.lam, self.c, self.ns, **self.band)

    def sse(self, theta, d):
        """Per-pixel misfit ``(P,)`` at index ``theta`` and thickness ``d`` ``(P,)`` (NaN samples skipped)."""
        terms = self.terms(theta)
        P = self.Y.shape[0]
        out = torch.empty(P, dtype=self.Y.dtype, device=self.Y.device)
        for i0, i1 in pixel_chunks(P, terms_size(terms), device=self.Y.device):
            r, _, _ = residual_parts(self.Y[i0:i1], d[i0:i1, None], terms, with_jacobian=False)
            r = torch.where(self.valid[i0:i1, None], r, torch.zeros_like(r))
            out[i0:i1] = (r * r).sum((-1, -2))[:, 0]
        return out

    def smooth(self, d):
        """(value, gradient, diagonal) of the smoothness term (zeros unless an image with μ_s > 0)."""
        if not self.image:
            return _smooth_terms(d, 0.0)
        return _smooth_terms(d.reshape(self.batch), self.smoothness, self.has_data.reshape(self.batch))

    def total(self, sse, d) -> float:
        """The objective L: misfit plus smoothness."""
        return float(sse.sum() + self.smooth(d)[0])


class _Normal(NamedTuple):
    """Gauss–Newton pieces of ½L: the thickness diagonal ``Hdd`` and gradient ``gd`` ``(P,)``
    (smoothness included), the inlier cross terms ``Hdt`` ``(P, K)``, the index block ``Htt``
    ``(K, K)`` and gradient ``gt`` ``(K,)`` (None without the index)."""

    Hdd: torch.Tensor
    gd: torch.Tensor
    Hdt: torch.Tensor | None
    Htt: torch.Tensor | None
    gt: torch.Tensor | None


def _refine_inputs(cube, wavelength, cos_theta, n_substrate, thickness_init, index_init, index_model_name, band,
                   smoothness, iterations, tol):
    """Validate :func:`refine_film`'s arguments (ValueError naming the parameter) and prepare the
    problem → ``(fit, theta (K,), d (P,))``; NaN starts become the median start."""
    _checks.check_choice(index_model_name, "index_model_name", INDEX_MODELS)
    smoothness = weight(smoothness, "smoothness")
    _checks.check_int(iterations, "iterations", minimum=0)
    weight(tol, "tol")
    band_settings(band["bandwidth"], band["passband"], band["polarization"])
    y_all, lam, c = cube_axes(cube, wavelength, cos_theta)
    band = dict(band, n_incident=real_index(band["n_incident"], "n_incident", y_all, incident=True))
    ns = real_index(n_substrate, "n_substrate", y_all)
    dtype, device = y_all.dtype, y_all.device
    batch = y_all.shape[:-2]
    Y = y_all.reshape(-1, *y_all.shape[-2:])
    P = Y.shape[0]
    K = INDEX_MODELS[index_model_name]
    _checks.check_numbers(index_init=index_init, thickness_init=thickness_init)
    theta = _checks.as_real(index_init, "index_init", dtype, device).reshape(-1).clone()
    if theta.numel() == 1 and K > 1:
        theta = torch.cat([theta, theta.new_zeros(K - 1)])
    if theta.numel() != K:
        raise ValueError(f"index_init must have {K} parameters for {index_model_name!r}; got {theta.numel()}")
    d = _checks.as_real(thickness_init, "thickness_init", dtype, device).reshape(-1).clone()
    if d.numel() != P:
        raise ValueError(f"thickness_init must have one value per pixel ({P}); got {d.numel()}")
    d = d.nan_to_num(float(d[~d.isnan()].median()) if bool((~d.isnan()).any()) else FALLBACK_THICKNESS).clamp_min(0.0)
    finite = Y.isfinite()  # ±inf samples are missing data, like NaN
    fit = _Fit(torch.where(finite, Y, 0.0), finite, lam, c, ns, index_model_name, band, batch, smoothness)
    return fit, theta, d


def _normal_equations(fit, theta, d, sse, fit_index) -> _Normal:
    """The Gauss–Newton system at (θ, d): exact Jacobians by chunks of pixels (:func:`lm_jacobian`),
    ∂terms/∂θ once by forward mode; pixels above ``INLIER_MISFIT_RATIO`` × the median misfit are
    left out of the index rows."""
    terms = fit.terms(theta)
    P, K = fit.Y.shape[0], theta.numel()
    dtype, device = fit.Y.dtype, fit.Y.device
    if fit_index:
        # ∂(a, b, e, k, h)/∂θ on the small (pol, A, B) grid, once per iteration: 5 × (pol, A, B, K)
        dterms = torch.func.jacfwd(fit.terms)(theta)
        Htt_p = torch.empty(P, K, K, dtype=dtype, device=device)
        gt_p = torch.empty(P, K, dtype=dtype, device=device)
        Hdt = torch.zeros(P, K, dtype=dtype, device=device)
    Hdd = torch.empty(P, dtype=dtype, device=device)
    gd = torch.empty(P, dtype=dtype, device=device)
    for i0, i1 in pixel_chunks(P, terms_size(terms), device=fit.Y.device):
        r, Jd, Jt = lm_jacobian(fit.Y[i0:i1], d[i0:i1], terms, dterms if fit_index else None)
        m = fit.valid[i0:i1]
        r = torch.where(m, r, torch.zeros_like(r))
        Jd = torch.where(m, Jd, torch.zeros_like(Jd))
        Hdd[i0:i1] = (Jd * Jd).sum((-1, -2))
        gd[i0:i1] = (Jd * r).sum((-1, -2))
        if fit_index:
            Jt = torch.where(m[..., None], Jt, torch.zeros_like(Jt))
            Hdt[i0:i1] = torch.einsum("pab,pabk->pk", Jd, Jt)
            Htt_p[i0:i1] = torch.einsum("pabk,pabl->pkl", Jt, Jt)
            gt_p[i0:i1] = torch.einsum("pabk,pab->pk", Jt, r)
    _, sg, sdiag = fit.smooth(d)
    Hdd, gd = Hdd + sdiag.reshape(-1) / 2, gd + sg.reshape(-1) / 2  # of ½L
    if not fit_index:
        return _Normal(Hdd, gd, None, None, None)
    median = torch.where(fit.has_data, sse, math.nan).nanmedian()  # (a pixel without data has misfit 0: no say)
    inlier = (sse <= INLIER_MISFIT_RATIO * median).to(dtype)  # robust: stray-order pixels do not steer n
    return _Normal(Hdd, gd, Hdt * inlier[:, None], (Htt_p * inlier[:, None, None]).sum(0),
                   (gt_p * inlier[:, None]).sum(0))


def _damped_step(fit, theta, d, sse, system, mu, loss0):
    """One Levenberg–Marquardt step from (θ, d): solve the damped arrow-shaped system by the Schur
    complement of the per-pixel block, raising μ until the objective falls below ``loss0``.

    Returns ``(theta, d, sse, mu, accepted)`` — unchanged with accepted False when μ passes
    ``LM_DAMPING_MAX``."""
    tiny = torch.finfo(fit.Y.dtype).tiny
    while mu < LM_DAMPING_MAX:
        Hd = system.Hdd * (1 + mu) + tiny
        if system.Htt is not None:
            Hdt = system.Hdt
            S = (system.Htt + mu * torch.diag(torch.diagonal(system.Htt))
                 - torch.einsum("pk,pl->kl", Hdt / Hd[:, None], Hdt))
            rhs = -system.gt + (Hdt * (system.gd / Hd)[:, None]).sum(0)
            dth = torch.linalg.solve(S, rhs)
            dd_step = -(system.gd + Hdt @ dth) / Hd
        else:
            dth = torch.zeros_like(theta)
            dd_step = -system.gd / Hd
        dd_step = dd_step.clamp(-MAX_THICKNESS_STEP, MAX_THICKNESS_STEP)  # stay in the current interference order
        th_new, d_new = theta + dth, (d + dd_step).clamp_min(0.0)
        sse_new = fit.sse(th_new, d_new)
        if fit.total(sse_new, d_new) < loss0:
            return th_new, d_new, sse_new, max(mu / LM_DAMPING_DECREASE, LM_DAMPING_MIN), True
        mu *= LM_DAMPING_INCREASE
    return theta, d, sse, mu, False


def _lm_fit(fit, theta, d, *, iterations, fit_index, tol, progress):
    """Up to ``iterations`` Levenberg–Marquardt iterations; stops when a step is refused or the
    objective falls by no more than ``tol`` (relative); ``progress(iterations done)`` after each, if given.
    → ``(theta, d, sse, history, iterations run)``."""
    history = []
    sse = fit.sse(theta, d)
    mu = LM_DAMPING_START
    it_done = 0
    for it in range(iterations):
        system = _normal_equations(fit, theta, d, sse, fit_index)
        loss0 = fit.total(sse, d)
        theta, d, sse, mu, accepted = _damped_step(fit, theta, d, sse, system, mu, loss0)
        it_done = it + 1
        history.append(fit.total(sse, d))
        if progress is not None:
            progress(it_done)
        if not accepted or (loss0 - history[-1]) <= tol * loss0:
            break
    return theta, d, sse, history, it_done


def _order_check(fit, theta, d, sse):
    """Re-test every pixel at d ± one order period T = λ_mid/(2√(n²−sin²θ)) (``ORDER_CHECK_ITERATIONS``
    d-only steps each) and keep the best order → ``(d, sse, pixels reordered)``."""
    terms = fit.terms(theta)
    lam_mid = fit.lam.median()
    n_mid = index_model(lam_mid, theta, fit.model)
    s2 = (fit.band["n_incident"] ** 2) * (1 - fit.c * fit.c)
    T = float(lam_mid) / (2 * float(torch.sqrt(n_mid ** 2 - s2).mean()))
    Dn, S = d_only_gauss_newton(fit.data, order_candidates(d, T), terms, iterations=ORDER_CHECK_ITERATIONS)
    best = S.argmin(-1)
    changed = (best != 1) & fit.has_data  # (a pixel without data scores every order 0: no choice)
    reordered = int(changed.sum())
    if reordered:
        d = torch.where(changed, Dn.gather(-1, best[:, None])[:, 0], d)
        sse = fit.sse(theta, d)
    return d, sse, reordered


@_checks.fits_with_autograd  # (autograd inside: a caller's inference mode must not switch it off)
def refine_film(cube, wavelength, cos_theta, n_substrate, thickness_init, index_init, *, index_model_name="constant",
                bandwidth=4.0, passband="box", polarization="unpolarized", n_incident=1.0, smoothness: float = 0.0,
                iterations: int = 12, fit_index: bool = True, order_check: bool = True, tol: float = 1e-7,
                progress=None) -> RefineResult:
    r"""Joint Levenberg–Marquardt fit of the shared index model and per-pixel thickness (module docstring).

    Args:
        cube: ``(*, A, B)`` (an image ``(H, W, A, B)`` enables ``smoothness``).
        wavelength: ``(B,)`` nm; cos_theta ``(A,)``; n_substrate: real.
        thickness_init: ``(*)`` starting d (nm), e.g. from ``peak_method()``.
        index_init: ``(K,)`` starting index parameters (or a number: A, the rest 0).
        index_model_name: ``"constant"``, ``"cauchy"`` or ``"cauchy3"``.
        bandwidth, passband, polarization, n_incident: the band model
            (``band_terms()``; Kobayashi et al.'s camera: ``polarization="s"``).
        smoothness: μ_s ≥ 0 (reflectance² per nm²), only for an image cube.
        iterations: at most this many joint iterations (≥ 0).
        fit_index: False keeps the index fixed (thickness only).
        order_check: re-test d ± one order period per pixel at the end.
        tol: stop when an iteration lowers the objective by less than this fraction.
        progress: ``None`` or a callable ``progress(done, total)``: ``done`` steps out of
            ``total = iterations`` (+ 1 with ``order_check``), after each joint iteration and
            after the order check; a fit that stops early (``tol``, a refused step) skips to
            ``done = iterations``; the last call has ``done == total``.

    Returns:
        :class:`RefineResult`; dtype and device follow cube, wavelength and cos_theta.

    Example (a 4 × 4 pixel synthetic cube of MgF₂, n = 1.37, 360–440 nm thick, from n = 1.35 and
    d = 400 nm everywhere):
        >>> from torchirid.estimation import synthetic_cube
        >>> c = synthetic_cube("mgf2_400", height=4, width=4, seed=1)
        >>> d0 = torch.full((4, 4), 400.0, dtype=torch.float64)  # nm, e.g. peak_method's thickness
        >>> r = refine_film(c.cube, c.wavelength, c.cos_theta, 1.64, d0, 1.35, iterations=5)
        >>> round(float(r.params[0]), 2), bool((r.thickness - c.thickness).abs().max() < 1.0)  # d within 1 nm
        (1.37, True)
    """
    band = dict(bandwidth=bandwidth, passband=passband, n_incident=n_incident, polarization=polarization)
    if progress is not None and not callable(progress):
        raise ValueError(f"progress must be None or a callable progress(done, total); got {progress!r}")
    fit, theta, d = _refine_inputs(cube, wavelength, cos_theta, n_substrate, thickness_init, index_init,
                                   index_model_name, band, smoothness, iterations, tol)
    total = iterations + int(bool(order_check))
    theta, d, sse, history, it_done = _lm_fit(fit, theta, d, iterations=iterations, fit_index=fit_index, tol=tol,
                                              progress=None if progress is None else (lambda done: progress(done, total)))
    if progress is not None and (it_done < iterations or total == 0):
        progress(iterations, total)  # stopped early (or nothing to do)
    reordered = 0
    if order_check:
        d, sse, reordered = _order_check(fit, theta, d, sse)
        if progress is not None:
            progress(total, total)
    # a pixel without a single finite sample has no estimate (its residuals were 0 by the NaN fill)
    empty = ~fit.valid.any(-1).any(-1)
    d, sse = torch.where(empty, math.nan, d), torch.where(empty, math.nan, sse)
    return RefineResult(params=theta, index_model=index_model_name, thickness=d.reshape(fit.batch),
                        sse=sse.reshape(fit.batch), history=history, iterations=it_done, reordered=reordered)


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
