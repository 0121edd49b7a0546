r"""Environment-lit thin-film shading: Kneiphof et al. 2019 eq. 12 with a prefiltered map (§4, §5).

Kneiphof's eq. 12 factors the reflected radiance of a GGX surface whose facets carry a thin
film into three integrals,

.. math:: L_o(ω_o) ≈ \underbrace{\int \tilde ρ\,⟨n, ω_i⟩\,dω_i}_{A(\cos θ_o,\,α)}\;
          \underbrace{\int p_{L_i} L_i\,dω_i}_{\bar L(ω_r,\,α)}\;
          \underbrace{\int p_R\,R(⟨h, ω_i⟩)\,dω_i}_{\text{reflectance term}},

- :math:`A` — the prefiltered BRDF with a constant reflectance term (eq. 10, 12): Karis'
  split-sum table with F ≡ 1, i.e. scale + bias of :func:`~torchirid.ibl.shipped_dfg_lut`
  (:math:`F_0 A + B` at :math:`F_0 = 1`);
- :math:`\bar L` — the prefiltered environment map of :func:`~torchirid.ibl.prefilter_environment`
  read at the ideal reflection direction :math:`ω_r = 2⟨ω_o, n⟩n - ω_o` (split sum: the lobe is
  taken with :math:`ω_o = n = ω_r`);
- the reflectance term — eq. 20–29 (:func:`~torchirid.ibl.thin_film_xyz_filtered`) with
  :math:`ω_o` = the view direction and the light mean μ_ωi and covariance Σ_ωi read from the
  nine prefiltered moment channels at :math:`ω_r` (§4.2, "computed from the prefiltered moments at
  runtime"), or, for ``method="belcour_barla"`` (the paper's "original"), eq. 4 at the ideal
  reflection, cos θ₁ = ⟨n, ω_o⟩ (:func:`~torchirid.ibl.thin_film_xyz_fourier`).

The environment is linear RGB (sRGB primaries, as the map), so the reflectance term's XYZ
(white Y = 1 under D65) is taken to linear sRGB (:func:`~torchirid.color.xyz_to_linear_srgb`,
the D65 white → (1, 1, 1)) and multiplies :math:`\bar L` channel by channel — the renderer's
RGB product. ``output="xyz"`` converts that product back to XYZ.

Lookup. The radiance and moment maps are interpolated bilinearly on the equirectangular output
grid (periodic in φ, clamped at the texel centres nearest the poles) and linearly in α between
the prefiltered roughness levels (α must lie within them). Moments are interpolated before the
covariance is formed (a mixture's moments are the mixture of its moments), so |μ| ≤ 1 holds.

Accuracy (tests/ibl/test_shading.py). Under a constant environment :math:`L_i ≡ c` the
prefiltered radiance is c exactly, and the result differs from the converged ground truth
:math:`c\,A\,\mathrm{XYZ}_{\text{uniform}}` (:func:`~torchirid.ibl.thin_film_xyz_uniform` times
its albedo) by the split-sum moments (an isotropic lobe about ω_r instead of the true p_R) plus
eq. 20–29's own approximation. At d = 600 nm, η₂ = 1.3, base 2 + 0.5i, θo ∈ {0°, 30°,
60°, 75°} × α ∈ {0.1, 0.3, 0.5} (α = 0.3 interpolated between levels 0.25 and 0.5; a 32 × 64
map prefiltered to 16 × 32) the test holds it within ΔE2000 11 (max) and 4.5 (mean), closer
on average than eq. 20–29 fed the exact moments (:func:`~torchirid.ibl.uniform_light_moments`)
and than ``method="belcour_barla"`` (the measured values: the test's docstring). (That the
split-sum moments beat the exact ones here is a cancellation of the two approximations at
grazing, not a general property.) The albedo from the shipped 64² DFG table agrees with the
converged lobe quadrature to 1e-3 (tested).
"""

from __future__ import annotations

import math

import torch

from .. import _checks
from ..color.convert import linear_srgb_to_xyz, xyz_to_linear_srgb
from .dfg import shipped_dfg_lut
from .filtered import _ARGS, thin_film_xyz_filtered
from .fitted import thin_film_xyz_fitted
from .fourier import thin_film_xyz_fourier
from .prefilter import PrefilteredEnvironment, light_moments_to_mean_cov

__all__ = ["shade_thin_film_environment", "SHADING_METHODS"]

#: Reflectance term of :func:`shade_thin_film_environment`: Kneiphof's eq. 20–29 with the
#: prefiltered moments, or Belcour–Barla's eq. 4 at the ideal reflection direction.
SHADING_METHODS = ("kneiphof", "belcour_barla", "fitted")
#: Colour space of the result.
SHADING_OUTPUTS = ("rgb", "xyz")


def _safe_norm2(x, y):
    """√(x² + y²) with a zero (not NaN) gradient at the origin (the poles of the map); NaN propagates."""
    return _checks.safe_sqrt(x * x + y * y)


def _lookup(pre: PrefilteredEnvironment, r: torch.Tensor, alpha: torch.Tensor) -> torch.Tensor:
    """Trilinear read of (radiance, moments) ``(*, 12)`` at direction r ``(*, 3)`` (unit) and α ``(*)``."""
    vals = torch.cat([pre.radiance, pre.moments], -1).to(r.dtype)  # (A, H, W, 12)
    order = torch.argsort(pre.alphas)
    vals, levels = vals[order], pre.alphas[order].to(r.dtype)
    A, H, W = vals.shape[:3]
    theta = torch.atan2(_safe_norm2(r[..., 0], r[..., 1]), r[..., 2])  # [0, π]
    phi = torch.remainder(torch.atan2(r[..., 1], r[..., 0]), 2.0 * math.pi)
    # rows: texel centres at (i + ½)π/H; beyond the first/last centre the edge row is used
    x = (theta * (H / math.pi) - 0.5).clamp(0.0, H - 1.0)
    # (indices of NaN directions: any valid texel; their NaN weights make the result NaN)
    i0 = x.detach().nan_to_num(0.0).floor().clamp(max=max(H - 2, 0)).long()
    ti = x - i0
    i1 = (i0 + 1).clamp(max=H - 1)
    # columns: periodic in φ
    y = phi * (W / (2.0 * math.pi)) - 0.5
    j0f = y.detach().nan_to_num(0.0).floor()
    tj = y - j0f
    j0 = torch.remainder(j0f.long(), W)
    j1 = torch.remainder(j0 + 1, W)
    # roughness levels: linear in α between the sorted levels
    if A == 1:
        k0 = torch.zeros_like(i0)
        tk = torch.zeros_like(alpha)
    else:
        k0 = (torch.searchsorted(levels, alpha.detach().contiguous(), right=True) - 1).clamp(0, A - 2)
        tk = (alpha - levels[k0]) / (levels[k0 + 1] - levels[k0])
    k1 = (k0 + 1).clamp(max=A - 1)
    k0, k1, i0, i1, j0, j1 = torch.broadcast_tensors(k0, k1, i0, i1, j0, j1)
    ti, tj, tk = (t[..., None] for t in (ti, tj, tk))

    def plane(k):
        top = torch.lerp(vals[k, i0, j0], vals[k, i0, j1], tj)
        bottom = torch.lerp(vals[k, i1, j0], vals[k, i1, j1], tj)
        return torch.lerp(top, bottom, ti)

    return torch.lerp(plane(k0), plane(k1), tk)


@_checks.arguments(prefiltered=_checks.instance(PrefilteredEnvironment, "PrefilteredEnvironment (from prefilter_environment)"),
                   method=_checks.choice(SHADING_METHODS), output=_checks.choice(SHADING_OUTPUTS),
                   normal=_checks.VECTORS, view=_checks.VECTORS, alpha=_checks.REAL,
                   **{k: a for k, a in _ARGS.items() if k != "illuminant"})
def shade_thin_film_environment(prefiltered: PrefilteredEnvironment, normal, view, alpha, n_film, thickness,
                                n_substrate, *, n_incident=1.0, method: str = "kneiphof", terms: int = 4,
                                observer: str = "CIE 1931 2", polarization: str = "unpolarized",
                                sensitivity: str = "lut", output: str = "rgb", dfg=None) -> torch.Tensor:
    r"""Radiance reflected by a rough thin-film surface under a prefiltered environment (Kneiphof eq. 12).

    :math:`L_o = A(⟨n, ω_o⟩, α)\;\bar L(ω_r, α) ⊙ \mathrm{RGB}[\text{reflectance term}]`, ω_r =
    reflect(ω_o, n): the split-sum albedo (DFG at F ≡ 1) × the prefiltered radiance × the
    filtered thin-film colour of eq. 20–29 with the light mean/covariance from the prefiltered
    moments (module docstring). All directions are in the environment map's world frame
    (equirectangular convention of :mod:`torchirid.ibl.prefilter`).

    Args:
        prefiltered: a :class:`~torchirid.ibl.PrefilteredEnvironment` (A ≥ 1 roughness levels).
        normal: surface normal n, ``(*, 3)`` (normalised here; non-zero).
        view: direction towards the viewer ω_o, ``(*, 3)`` (normalised here; ⟨n, ω_o⟩ > 0).
        alpha: GGX roughness, ``(*)``, within the prefiltered levels [min α, max α] and ≤ 1
            (the DFG table's range); interpolated linearly between levels.
        n_film: real film index η₂ ≥ ``n_incident``; thickness: film thickness d in nm (≥ 0);
            n_substrate: base η₃ + iκ₃ (non-dispersive) — each ``(*)``.
        n_incident: real outer index η₁ (default 1).
        method: ``"kneiphof"`` (default: eq. 20–29 with the prefiltered moments),
            ``"belcour_barla"`` (eq. 4 at the ideal reflection, cos θ₁ = ⟨n, ω_o⟩) or
            ``"fitted"`` (:func:`~torchirid.ibl.thin_film_xyz_fitted`: the light-mixture table
            fitted to *uniform* light — best under uniform or slowly varying light; under a sky
            with a sun Kneiphof's moments carry the light's direction and do better: docs/performance.md,
            "Thin-film colour on rough surfaces under uniform light", under an environment map) —
            :data:`SHADING_METHODS`.
        terms: Fourier terms M ≥ 0 (default 4; the paper's is 2).
        observer: colour-matching functions of the reflectance term (illuminant fixed to D65,
            the white of the sRGB primaries the map is in).
        polarization: ``"unpolarized"`` (default), ``"s"`` or ``"p"``.
        sensitivity: ``"lut"`` (default) or ``"exact"`` — how Ŝ(μ, σ²) / Ŝ(D) is evaluated (the
            shipped tables, or quadrature).
        output: ``"rgb"`` (default: linear sRGB radiance, the map's units) or ``"xyz"``.
        dfg: split-sum :class:`~torchirid.lut.LUT` from :func:`~torchirid.ibl.dfg_lut`; default
            :func:`~torchirid.ibl.shipped_dfg_lut`.

    Returns:
        ``(*, 3)`` radiance in the map's units (``(*)`` = broadcast of the geometry and film
        inputs), real dtype of the inputs, differentiable w.r.t. the directions, α, the film
        parameters and the maps.

    Example:
        >>> import torch
        >>> from torchirid.ibl import prefilter_environment
        >>> pre = prefilter_environment(torch.ones(16, 32, 3, dtype=torch.float64), [0.2, 0.4], resolution=8)
        >>> n = torch.tensor([0.0, 0.0, 1.0], dtype=torch.float64)
        >>> v = torch.tensor([0.6, 0.0, 0.8], dtype=torch.float64)
        >>> rgb = shade_thin_film_environment(pre, n, v, 0.3, 1.3, 600.0, complex(2.0, 0.5))
        >>> [round(c, 3) for c in rgb.tolist()]
        [0.054, 0.054, 0.09]
    """
    n, v, a = normal, view, alpha
    dtype, device = n.dtype, n.device
    levels = prefiltered.alphas.to(dtype=dtype, device=device)
    with torch.no_grad():
        nn_, vn = torch.linalg.vector_norm(n, dim=-1), torch.linalg.vector_norm(v, dim=-1)
        if bool((nn_ <= 0).any()):
            raise ValueError("normal must be a non-zero vector")
        if bool((vn <= 0).any()):
            raise ValueError("view must be a non-zero vector (towards the viewer)")
        tol = 1e-6 * float(levels.max())  # rounding of α read back from a LUT / float32
        lo, hi = float(levels.min()), float(levels.max())
        if bool(((a < lo - tol) | (a > hi + tol)).any()):
            raise ValueError(f"alpha must lie within the prefiltered roughness levels [{lo:g}, {hi:g}]")
        if bool(((a <= 0) | (a > 1)).any()):
            raise ValueError("alpha must be in (0, 1] (GGX roughness; the DFG table's range)")
    n = n / torch.linalg.vector_norm(n, dim=-1, keepdim=True)
    v = v / torch.linalg.vector_norm(v, dim=-1, keepdim=True)
    cos_o = (n * v).sum(-1)
    with torch.no_grad():
        if bool((cos_o <= 0).any()):
            raise ValueError("view must be in the hemisphere of normal (<normal, view> > 0); mask "
                             "back-facing points before shading")
    cos_o = cos_o.clamp(max=1.0)
    r = 2.0 * cos_o[..., None] * n - v  # ω_r = reflect(ω_o, n), unit
    shape = _checks.broadcast_shapes(r.shape[:-1], a.shape)
    r, a_ = r.expand(*shape, 3), a.expand(shape)
    looked = _lookup(prefiltered, r, a_.clamp(lo, hi))
    radiance, moments = looked[..., :3], looked[..., 3:]
    # eq. 12, first factor: the split-sum albedo at F ≡ 1 (scale + bias)
    table = shipped_dfg_lut(dtype=dtype, device=device) if dfg is None else dfg.to(dtype=dtype, device=device)
    ab = table(cos_theta_o=cos_o.expand(shape), alpha=a_)
    albedo = ab[..., 0] + ab[..., 1]
    # eq. 12, third factor
    kw = dict(n_incident=n_incident, terms=terms, observer=observer, illuminant="D65", polarization=polarization,
              sensitivity=sensitivity)
    # (the colour functions' bodies: their arguments are checked above, the derived ones by construction)
    if method == "kneiphof":
        mean, cov = light_moments_to_mean_cov(moments)
        xyz = thin_film_xyz_filtered.__wrapped__(v, mean, cov, n_film, thickness, n_substrate, **kw)
    elif method == "fitted":
        xyz = thin_film_xyz_fitted.__wrapped__(cos_o, a_, n_film, thickness, n_substrate, **kw)
    else:
        xyz = thin_film_xyz_fourier.__wrapped__(cos_o, n_film, thickness, n_substrate, **kw)
    rgb = xyz_to_linear_srgb(xyz) * radiance * albedo[..., None]
    if output == "xyz":
        return linear_srgb_to_xyz(rgb)
    return rgb
