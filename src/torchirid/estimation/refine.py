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
the terms (a, b, e, k, h) of :func:`~torchirid.estimation.band_terms` are differentiated in θ
by forward-mode autograd (``torch.func.jacfwd``) on the small (polarization × angle × band)
grid, the elementwise partials of the band model in those terms and in d by one batched
reverse-mode pass over the pixels, and the two chained — the band-width term h d² R''
included (the tests compare the whole Jacobian with ``torch.func.jacfwd`` of the residual).

d is multimodal (one basin per interference order): :func:`refine_film` keeps the order
from its start, then re-tests every pixel at d ± one order period T = λ/(2√(n²−sin²θ)) in
one batched call (a few d-only Gauss–Newton steps each) and keeps the best. Pixels whose
misfit stays above 10× the median are left out of the index update (robust to stray orders).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import torch

from .. import _checks
from .dispersion import INDEX_MODELS, index_model
from .measurement import band_terms

__all__ = ["RefineResult", "model_terms", "lm_jacobian", "d_only_gauss_newton", "refine_film", "scan_index"]


def model_terms(params, index_model_name, wavelength, cos_theta, n_substrate, *, bandwidth=4.0, passband="box",
                n_incident=1.0, polarization="s"):
    """Terms (a, b, e, k, h), each ``(pol, A, B)``, of :func:`~torchirid.estimation.band_reflectance_fast`
    for index parameters ``params`` ``(K,)``; ``wavelength`` ``(B,)`` nm, ``cos_theta`` ``(A,)``.
    """
    return band_terms(wavelength, cos_theta[:, None], lambda lam: index_model(lam, params, index_model_name),
                      n_substrate, bandwidth=bandwidth, passband=passband, n_incident=n_incident, polarization=polarization)


def _chunks(P: int, per_pixel: int, budget: int = 200_000):
    step = max(1, budget // max(per_pixel, 1))  # small chunks stay in cache: ~3x faster than large ones
    return [(i, min(P, i + step)) for i in range(0, P, step)]


def _residual_parts(y, d, terms, with_jacobian=True):
    """Residual, ∂R_b/∂d and the uncorrected partials for d ``(p, C)``; y ``(p, A, B)`` → ``(p, C, A, B)``."""
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


def a_size(terms) -> int:
    return terms[0].numel()


def _band_model(terms, d):
    """Elementwise fast band model R + h d² R'' (:func:`~torchirid.estimation.band_reflectance_fast`
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
    (:func:`~torchirid.estimation.band_reflectance_fast`, band-width term h d² R'' included), an
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
    """
    if dterms is None:  # thickness only: the closed-form ∂r/∂d (same values, no graph)
        r, Jd, _ = _residual_parts(y, d[:, None], terms)
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


def d_only_gauss_newton(cube, thickness, terms, *, iterations: int = 3, max_step: float = 30.0):
    """Per-pixel, per-candidate Gauss–Newton on d with the index fixed (batched, no loops over pixels).

    Args:
        cube: ``(P, A, B)``; thickness ``(P, C)`` starts (C candidates per pixel, NaN ignored).
        terms: from :func:`model_terms` / :func:`~torchirid.estimation.band_terms`, ``(pol, A, B)``.

    Returns:
        ``(d, sse)`` both ``(P, C)``; a step that raises a candidate's misfit is refused.
    """
    P, C = thickness.shape
    d = thickness.clone()
    nan = d.isnan()
    d = d.nan_to_num(0.0)
    sse_out = torch.empty_like(d)
    for i0, i1 in _chunks(P, C * a_size(terms)):
        y, dd = cube[i0:i1], d[i0:i1]
        r, Jd, _ = _residual_parts(y, dd, terms)
        r = r.nan_to_num(0.0)
        sse = (r * r).sum((-1, -2))
        for it in range(iterations):
            g = (Jd * r).sum((-1, -2))
            H = (Jd * Jd).sum((-1, -2))
            step = (-g / H.clamp_min(torch.finfo(H.dtype).tiny)).clamp(-max_step, max_step)
            new = (dd + step).clamp_min(0.0)
            last = it + 1 == iterations
            r2, Jd2, _ = _residual_parts(y, new, terms, with_jacobian=not last)
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


def _smooth_terms(d_img, weight):
    """(value, gradient, diagonal) of weight·Σ_{4-neighbours}(d_p − d_q)² for an image (H, W)."""
    if weight == 0 or d_img.ndim != 2:
        z = torch.zeros_like(d_img)
        return d_img.new_zeros(()), z, z
    dx = d_img[:, 1:] - d_img[:, :-1]
    dy = d_img[1:, :] - d_img[:-1, :]
    val = weight * ((dx * dx).sum() + (dy * dy).sum())
    g = torch.zeros_like(d_img)
    g[:, 1:] += 2 * weight * dx
    g[:, :-1] -= 2 * weight * dx
    g[1:, :] += 2 * weight * dy
    g[:-1, :] -= 2 * weight * dy
    deg = torch.zeros_like(d_img)
    deg[:, 1:] += 1
    deg[:, :-1] += 1
    deg[1:, :] += 1
    deg[:-1, :] += 1
    return val, g, 2 * weight * deg


@dataclass
class RefineResult:
    """params ``(K,)`` of the index model; thickness ``(*)`` nm; sse ``(*)`` per-pixel misfit;
    loss history; iterations run; reordered: pixels whose order changed in the order check."""

    params: torch.Tensor
    index_model: str
    thickness: torch.Tensor
    sse: torch.Tensor
    history: list = field(default_factory=list)
    iterations: int = 0
    reordered: int = 0


def scan_index(cube, thickness, n_start, wavelength, cos_theta, n_substrate, *, rel_range=0.15, steps: int = 21,
               slopes=(0.0,), bandwidth=4.0, passband="box", polarization="s", n_incident=1.0):
    """Best index n(λ) = A + B/λ_µm² on a grid by total misfit of ``cube`` ``(P, A, B)``.

    The grid: n(λ_mid) ∈ n_start·[1 − r, 1 + r] (``steps`` values) × B ∈ ``slopes`` (µm²;
    ``(0,)``: constant index). For each grid value the pixel's optical thickness is kept
    (d·√(n²−s²) fixed), the three nearest interference orders are tried and polished by
    :func:`d_only_gauss_newton`. Guards against a biased eq. 12 estimate (dispersive films:
    Kobayashi et al.'s ZnS). Returns ``(params (2,) = (A, B), d_best (P,), grid (N, 2), losses (N,))``.
    """
    dtype = cube.dtype
    lam = torch.as_tensor(wavelength, dtype=dtype)
    c = torch.as_tensor(cos_theta, dtype=dtype)
    s2 = (n_incident ** 2) * (1 - c * c)
    lam_mid = float(lam.median())
    inv_mid = (1000.0 / lam_mid) ** 2
    mids = n_start * torch.linspace(1 - rel_range, 1 + rel_range, steps, dtype=dtype)
    grid = torch.tensor([[float(m) - b * inv_mid, b] for m in mids for b in slopes], dtype=dtype)
    losses, ds = [], []
    nc0 = float(torch.sqrt(n_start ** 2 - s2).mean())
    for A_, B_ in grid.tolist():
        n_mid = A_ + B_ * inv_mid
        terms = band_terms(lam, c[:, None], lambda l: A_ + B_ * (1000.0 / l) ** 2, n_substrate, bandwidth=bandwidth,
                           passband=passband, n_incident=n_incident, polarization=polarization)
        nc = float(torch.sqrt(n_mid ** 2 - s2).mean())
        D = (thickness * (nc0 / nc))[:, None] + (lam_mid / (2 * nc)) * torch.tensor([-1.0, 0.0, 1.0], dtype=dtype)
        D = torch.where(D > 0, D, torch.full_like(D, math.nan))
        dd, sse = d_only_gauss_newton(cube, D, terms, iterations=3)
        best = sse.argmin(-1, keepdim=True)
        losses.append(float(sse.gather(-1, best).sum()))
        ds.append(dd.gather(-1, best)[:, 0])
    losses = torch.tensor(losses, dtype=dtype)
    i = int(losses.argmin())
    return grid[i], ds[i], grid, losses


@_checks.fits_with_autograd  # (autograd inside: a caller's inference mode must not switch it off)
def refine_film(cube, wavelength, cos_theta, n_substrate, thickness_init, index_init, *, index_model_name="constant",
                bandwidth=4.0, passband="box", polarization="s", n_incident=1.0, smoothness: float = 0.0,
                iterations: int = 12, fit_index: bool = True, order_check: bool = True, tol: float = 1e-7,
                progress=None) -> RefineResult:
    r"""Joint Levenberg–Marquardt fit of the shared index model and per-pixel thickness (module docstring).

    Args:
        cube: ``(*, A, B)`` (an image ``(H, W, A, B)`` enables ``smoothness``).
        wavelength: ``(B,)`` nm; cos_theta ``(A,)``; n_substrate: real.
        thickness_init: ``(*)`` starting d (nm), e.g. from :func:`~torchirid.estimation.peak_method`.
        index_init: ``(K,)`` starting index parameters (or a number: A, the rest 0).
        index_model_name: ``"constant"``, ``"cauchy"`` or ``"cauchy3"``.
        smoothness: μ_s ≥ 0 (reflectance² per nm²), only for an image cube.
        fit_index: False keeps the index fixed (thickness only).
        order_check: re-test d ± one order period per pixel at the end.
        progress: optional callable ``progress(step_name)`` called once per iteration.

    Returns:
        :class:`RefineResult`.
    """
    if index_model_name not in INDEX_MODELS:
        raise ValueError(f"index_model_name must be one of {_checks.names(tuple(INDEX_MODELS))}; got {index_model_name!r}")
    if not (smoothness >= 0 and math.isfinite(smoothness)):
        raise ValueError(f"smoothness must be >= 0; got {smoothness!r}")
    y_all = torch.as_tensor(cube)
    dtype = y_all.dtype
    batch = y_all.shape[:-2]
    A, B = y_all.shape[-2:]
    Y = y_all.reshape(-1, A, B)
    P = Y.shape[0]
    valid_y = ~Y.isnan()
    Y = Y.nan_to_num(0.0)
    lam = torch.as_tensor(wavelength, dtype=dtype)
    c = torch.as_tensor(cos_theta, dtype=dtype).reshape(-1)
    K = INDEX_MODELS[index_model_name]
    theta = torch.as_tensor(index_init, dtype=dtype).reshape(-1).clone()
    if theta.numel() == 1 and K > 1:
        theta = torch.cat([theta, theta.new_zeros(K - 1)])
    if theta.numel() != K:
        raise ValueError(f"index_init must have {K} parameters for {index_model_name!r}; got {theta.numel()}")
    d = torch.as_tensor(thickness_init, dtype=dtype).reshape(-1).clone()
    if d.numel() != P:
        raise ValueError(f"thickness_init must have one value per pixel ({P}); got {d.numel()}")
    d = d.nan_to_num(float(d[~d.isnan()].median()) if bool((~d.isnan()).any()) else 100.0).clamp_min(0.0)
    ns = float(n_substrate)
    image = len(batch) == 2 and smoothness > 0

    def terms_of(th):
        return model_terms(th, index_model_name, lam, c, ns, bandwidth=bandwidth, passband=passband, n_incident=n_incident,
                           polarization=polarization)

    def sse_of(th, dd):
        terms = terms_of(th)
        out = torch.empty(P, dtype=dtype)
        for i0, i1 in _chunks(P, a_size(terms)):
            r, _, _ = _residual_parts(Y[i0:i1], dd[i0:i1, None], terms, with_jacobian=False)
            r = torch.where(valid_y[i0:i1, None], r, torch.zeros_like(r))
            out[i0:i1] = (r * r).sum((-1, -2))[:, 0]
        return out

    def smooth_of(dd):
        return _smooth_terms(dd.reshape(batch), smoothness) if image else _smooth_terms(dd, 0.0)

    def total(sse, dd):
        return float(sse.sum() + smooth_of(dd)[0])

    history = []
    sse = sse_of(theta, d)
    mu = 1e-3
    it_done = 0
    for it in range(iterations):
        terms = terms_of(theta)
        npol = terms[0].shape[0]
        if fit_index:
            # ∂(a, b, e, k, h)/∂θ on the small (pol, A, B) grid, once per iteration: 5 × (pol, A, B, K)
            dterms = torch.func.jacfwd(terms_of)(theta)
            Htt_p = torch.empty(P, K, K, dtype=dtype)
            gt_p = torch.empty(P, K, dtype=dtype)
        Hdd = torch.empty(P, dtype=dtype)
        gd = torch.empty(P, dtype=dtype)
        Hdt = torch.zeros(P, K, dtype=dtype)
        for i0, i1 in _chunks(P, a_size(terms)):
            r, Jd, Jt = lm_jacobian(Y[i0:i1], d[i0:i1], terms, dterms if fit_index else None)
            m = valid_y[i0:i1]
            r = torch.where(m, r, torch.zeros_like(r))
            Jd = torch.where(m, Jd, torch.zeros_like(Jd))
            Hdd[i0:i1] = (Jd * Jd).sum((-1, -2))
            gd[i0:i1] = (Jd * r).sum((-1, -2))
            if fit_index:
                Jt = torch.where(m[..., None], Jt, torch.zeros_like(Jt))
                Hdt[i0:i1] = torch.einsum("pab,pabk->pk", Jd, Jt)
                Htt_p[i0:i1] = torch.einsum("pabk,pabl->pkl", Jt, Jt)
                gt_p[i0:i1] = torch.einsum("pabk,pab->pk", Jt, r)
        if fit_index:
            inlier = (sse <= 10 * sse.median()).to(dtype)  # robust: stray-order pixels do not steer n
            Hdt_in = Hdt * inlier[:, None]
            Htt = (Htt_p * inlier[:, None, None]).sum(0)
            gt = (gt_p * inlier[:, None]).sum(0)
        _, sg, sdiag = smooth_of(d)
        gdt = gd + sg.reshape(-1) / 2  # gradient of ½L
        Hdd_t = Hdd + sdiag.reshape(-1) / 2
        loss0 = total(sse, d)
        accepted = False
        while mu < 1e8:
            Hd = Hdd_t * (1 + mu) + torch.finfo(dtype).tiny
            if fit_index:
                S = Htt + mu * torch.diag(torch.diagonal(Htt)) - torch.einsum("pk,pl->kl", Hdt_in / Hd[:, None], Hdt_in)
                rhs = -gt + (Hdt_in * (gdt / Hd)[:, None]).sum(0)
                dth = torch.linalg.solve(S, rhs)
                dd_step = -(gdt + Hdt_in @ dth) / Hd
            else:
                dth = torch.zeros(K, dtype=dtype)
                dd_step = -gdt / Hd
            dd_step = dd_step.clamp(-30.0, 30.0)  # stay in the current interference order
            th_new, d_new = theta + dth, (d + dd_step).clamp_min(0.0)
            sse_new = sse_of(th_new, d_new)
            loss1 = total(sse_new, d_new)
            if loss1 < loss0:
                theta, d, sse = th_new, d_new, sse_new
                mu = max(mu / 3, 1e-9)
                accepted = True
                break
            mu *= 5
        it_done = it + 1
        history.append(total(sse, d))
        if progress is not None:
            progress("refine")
        if not accepted or (loss0 - history[-1]) <= tol * loss0:
            break
    reordered = 0
    if order_check:
        terms = terms_of(theta)
        n_mid = index_model(lam.median(), theta, index_model_name)
        s2 = (n_incident ** 2) * (1 - c * c)
        T = float(lam.median()) / (2 * float(torch.sqrt(n_mid ** 2 - s2).mean()))
        D = d[:, None] + T * torch.tensor([-1.0, 0.0, 1.0], dtype=dtype)
        D = torch.where(D > 0, D, torch.full_like(D, math.nan))
        Dn, S = d_only_gauss_newton(Y, D, terms, iterations=3)
        best = S.argmin(-1)
        changed = best != 1
        reordered = int(changed.sum())
        if reordered:
            d = torch.where(changed, Dn.gather(-1, best[:, None])[:, 0], d)
            sse = sse_of(theta, d)
            if progress is not None:
                progress("order check")
    # a pixel without a single finite sample has no estimate (its residuals were 0 by the NaN fill)
    empty = ~valid_y.any(-1).any(-1)
    d, sse = torch.where(empty, math.nan, d), torch.where(empty, math.nan, sse)
    return RefineResult(params=theta, index_model=index_model_name, thickness=d.reshape(batch), sse=sse.reshape(batch),
                        history=history, iterations=it_done, reordered=reordered)


def grid_scan(cube, wavelength, cos_theta, n_substrate, n_grid, *, thickness_range=(20.0, 2000.0),
              bandwidth=4.0, passband="box", polarization="s", n_incident=1.0):
    """Exhaustive search, independent of any peak: for each constant index of ``n_grid`` the
    best thickness of every pixel of ``cube`` ``(P, A, B)`` on a grid of step λ_min/(8√(n²−s²))
    (inside one interference basin), polished by two Gauss–Newton steps.

    Returns ``(losses (N,), thickness (N, P))`` — the total misfit per index and the thicknesses.
    Cost N × P × (grid size) model evaluations: meant for a pixel sample or few pixels.
    """
    dtype = cube.dtype
    lam = torch.as_tensor(wavelength, dtype=dtype)
    c = torch.as_tensor(cos_theta, dtype=dtype)
    s2 = (n_incident ** 2) * (1 - c * c)
    lo, hi = map(float, thickness_range)
    losses, ds = [], []
    for n in torch.as_tensor(n_grid, dtype=dtype).tolist():
        terms = band_terms(lam, c[:, None], n, n_substrate, bandwidth=bandwidth, passband=passband, n_incident=n_incident,
                           polarization=polarization)
        step = float(lam.min()) / (8 * float(torch.sqrt(n * n - s2).max()))
        grid = torch.arange(lo, hi + step, step, dtype=dtype)
        from .peaks import cube_sse

        sse = cube_sse(cube, terms, grid.expand(cube.shape[0], -1))
        d0 = grid[sse.argmin(-1)][:, None]
        d, s = d_only_gauss_newton(cube, d0, terms, iterations=2, max_step=step)
        losses.append(float(s.sum()))
        ds.append(d[:, 0])
    return torch.tensor(losses, dtype=dtype), torch.stack(ds)
