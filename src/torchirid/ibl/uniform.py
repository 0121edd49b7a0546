r"""Ground truth for a rough thin-film surface under uniform illumination (Kneiphof et al. 2019, Fig. 7).

Under constant radiance :math:`L_i ≡ 1` the light reflected by a GGX microfacet surface whose
facets carry a thin film (Kneiphof eq. 6, 10–12 with :math:`L_i = 1`) is

.. math:: L_o(ω_o) = \int_{Ω} \tilde ρ(ω_i, ω_o)\,⟨n, ω_i⟩\,R(⟨h, ω_i⟩)\,dω_i
          = A(ω_o)\;\underbrace{\int p_R(ω_i)\,R(⟨h, ω_i⟩)\,dω_i}_{\text{reflectance term}},
          \qquad \tilde ρ = \frac{D(h)\,G(ω_i, ω_o)}{4⟨n,ω_i⟩⟨n,ω_o⟩},

with the albedo :math:`A = ∫\tilde ρ\,⟨n,ω_i⟩\,dω_i` (the split-sum "DFG" integral with F = 1,
shared exactly by every method that multiplies a prefiltered BRDF by a reflectance term) and
:math:`p_R ∝ \tilde ρ\,⟨n, ω_i⟩`. The functions here compute the reflectance term's colour, the
moments of :math:`p_R` (what Kneiphof's nine moment channels estimate) and the distribution
of the path difference D, all by one deterministic quadrature:

**Lobe quadrature.** The microfacet normal h is drawn from GGX's D·cos density,
:math:`\tan^2θ_h = α^2 u/(1-u)` with u uniform, φ_h uniform, and ω_i = reflect(ω_o, h); the weight
of :math:`\tilde ρ⟨n,ω_i⟩` per unit (u, φ/2π) is then :math:`G(ω_i,ω_o)⟨ω_o,h⟩/(\cos θ_o\cos θ_h)`
(0 below the horizon or on back-facing facets: the χ⁺ factors). u = sin²(πs/2) removes the
square roots at both ends (Gauss–Legendre in s) and φ is integrated by the periodic trapezoid
rule: ``nodes`` × 2·``nodes`` points. The integrand is continuous but has a kink where ω_i
crosses the horizon, so the error falls as nodes⁻²: the albedo at normal view and α = 1
(exactly 1 − ln 2) errs by 2.4e-4 / 6.1e-5 / 1.5e-5 at 64 / 128 / 256 nodes; the reference
colours below move by ΔE2000 < 0.005 from 64 to 256 nodes at grazing and small α
(tests/ibl/test_uniform.py).

**Reflectance term.** The film's reflectance depends on ω_i only through
:math:`\cos θ_1 = ⟨h, ω_i⟩ = ⟨h, ω_o⟩`, so the term is :math:`∫_0^1 p(\cos θ_1)\,
\mathrm{XYZ}[R](\cos θ_1)\,d\cos θ_1`. The quadrature points are splatted linearly onto a
uniform grid of ``bins`` cells in cos θ1 and the film's exact XYZ (spectral Airy reflectance,
:func:`~torchirid.optics.thin_film_reflectance`, integrated by
:func:`~torchirid.color.spectrum_to_xyz` on a 1 nm grid over 360–830 nm) is evaluated at the
grid nodes: the sum is then the exact integral of the piecewise-linear interpolant of
XYZ[R](cos θ1), which errs by ≤ h²/8·max|XYZ''| (≈ 1e-6 for d ≤ 1 µm at 2048 bins).
Independent of Belcour–Barla's Fourier series, so it is a reference for it.

**Masking–shadowing** (``masking=``, every function here). With Smith's GGX
:math:`Λ(ω) = (\sqrt{1 + α^2\tan^2θ} - 1)/2` and :math:`G_1 = 1/(1 + Λ)`:

* ``"separable"`` (default): :math:`G = G_1(ω_i)\,G_1(ω_o)`, the library's microfacet BRDF
  (:func:`~torchirid.microfacet.smith_g`, :func:`~torchirid.microfacet.microfacet_brdf`) and its
  DFG table (:func:`~torchirid.ibl.dfg_lut`), so the albedo here is that table's;
* ``"height_correlated"``: Smith's height-correlated (Smith-joint) form
  :math:`G_2 = 1/(1 + Λ(ω_i) + Λ(ω_o))` (Heitz 2014, height-correlated masking and shadowing),
  the "Smith-Joint geometry term" of Kneiphof et al. 2019 (§6: their Unity HDRP BRDF). Computed
  as the equal :math:`G_1(ω_i)G_1(ω_o)/(G_1(ω_i) + G_1(ω_o) - G_1(ω_i)G_1(ω_o))` (no Λ = ∞ at
  grazing; 0 there). :math:`G_2 ≥ G_1G_1` (equal at normal view, where Λ(ω_o) = 0), so its
  albedo is larger, most at grazing view and high roughness: α = 1 gives 0.4091 → 0.4507 at
  θo = 60° and 0.5845 → 0.8478 at cos θo = 0.05.

The two reweight the same lobe, so the reflectance term's colour moves little except at
grazing view on rough surfaces: ΔE2000 median 0.002, p95 0.78, max 6.2 on the 10,368 films ×
geometries of ``benchmarks/fitted_terms_error.py``. Use the G of the BRDF being matched (the
default is the library's own, so that the reflectance term and the DFG albedo describe one BRDF).
"""

from __future__ import annotations

import math

import torch

from .. import _checks
from .._chunks import evaluate as _chunk_evaluate, get_chunk_size as _chunk_size
from .._quadrature import gauss_legendre01
from ..color.convert import xyz_weights_kernel
from ..microfacet.ggx import reflect_kernel, smith_g1_kernel
from ..optics.thin_film import thin_film_reflectance
from .sensitivity import ILLUMINANT, OBSERVER

__all__ = [
    "uniform_light_moments",
    "path_difference_moments",
    "thin_film_xyz_uniform",
]

#: ``masking=`` values of the uniform-light functions and the fitted table (module docstring).
MASKING_MODES = ("separable", "height_correlated")


def _check_masking(masking) -> str:
    """Validate ``masking`` (one of :data:`MASKING_MODES`) and return it."""
    return _checks.check_choice(masking, "masking", MASKING_MODES)


def _check_view(c, name):
    with torch.no_grad():
        if bool(((c <= 0) | (c > 1)).any()):
            raise ValueError(f"{name} must be in (0, 1] (a view above the horizon)")


#: the lobe's geometry: a view above the horizon and a GGX roughness > 0, broadcast together
_LOBE = dict(cos_theta_o=_checks.real(_check_view), alpha=_checks.positive("(GGX roughness)"),
             nodes=_checks.integer(2), masking=_checks.choice(MASKING_MODES))


def _geometry(c, a):
    """Checked cos θo and α broadcast together, with their dtype and device."""
    shape = _checks.broadcast_shapes(c.shape, a.shape, names=("cos_theta_o", "alpha"))
    return c.expand(shape), a.expand(shape), c.dtype, c.device


def _view(c: torch.Tensor) -> torch.Tensor:
    """ω_o in the xz-plane: (sin θo, 0, cos θo).

    sin θo = √(1 − cos²θo + ε²), ε = 1e-8: the same value to ≲ 1e-16 except within ~1e-16 of
    normal incidence, and a finite slope in cos θo there. At cos θo = 1 the chain rule then gives
    the true derivative of the (even in sin θo) lobe integrals, ∂f/∂s · ∂s/∂c → −2c ∂f/∂(s²),
    instead of 0 · ∞ = NaN (guard: √'s infinite slope at 0)."""
    s = torch.sqrt((1.0 - c * c).clamp_min(0.0) + 1e-16)
    return torch.stack([s, torch.zeros_like(s), c], -1)


def _lobe_rule(nodes, dtype, device):
    """Nodes (u, φ) and weights for ∫∫ g du dφ/(2π): Gauss–Legendre in s with u = sin²(πs/2), trapezoid in φ.

    u is the GGX D·cos CDF variable (tan²θh = α² u/(1 − u)); cos θh ∝ √(1 − u) has a square
    root at u = 1 that u = sin²(πs/2) removes (du = (π/2) sin(πs) ds). The integrand is
    2π-periodic in φ, where the trapezoid rule converges geometrically.
    """
    s, w = gauss_legendre01(nodes, dtype, device)
    u = torch.sin(0.5 * math.pi * s) ** 2
    wu = w * (0.5 * math.pi) * torch.sin(math.pi * s)
    nphi = 2 * nodes
    phi = (torch.arange(nphi, dtype=dtype, device=device) + 0.5) * (2.0 * math.pi / nphi)
    uu, pp = (t.reshape(-1) for t in torch.meshgrid(u, phi, indexing="ij"))
    return uu, pp, (wu[:, None] / nphi).expand(nodes, nphi).reshape(-1)


@_checks.arguments(**_LOBE)
def uniform_lobe_quadrature(cos_theta_o, alpha, *, nodes: int = 64, masking: str = "separable"):
    r"""Quadrature of :math:`∫\tilde ρ(ω_i,ω_o)⟨n,ω_i⟩ f(ω_i)\,dω_i` over a GGX lobe (module docstring).

    Args:
        cos_theta_o: cos θo in (0, 1]; ω_o = (sin θo, 0, cos θo), normal +z. Shape ``(*)``.
        alpha: GGX roughness > 0, broadcast with ``cos_theta_o``.
        nodes: Gauss–Legendre nodes in the polar variable (≥ 2); 2·nodes azimuths.
        masking: the G of ρ̃: ``"separable"`` (default, G₁(ω_i)G₁(ω_o)) or ``"height_correlated"``
            (1/(1 + Λ(ω_i) + Λ(ω_o)), Kneiphof's Smith-joint G); module docstring.

    Returns:
        ``(wi, h, weight)``: light directions ``(*, Q, 3)``, the microfacet normals ``(*, Q, 3)``
        and weights ``(*, Q)`` (Q = 2·nodes²; 0 below the horizon or on back-facing facets) with
        :math:`Σ_q w_q f(ω_{i,q}) ≈ ∫\tilde ρ⟨n,ω_i⟩ f\,dω_i`; ``weight.sum(-1)`` is the albedo A.

    Example:
        >>> import torch
        >>> wi, h, w = uniform_lobe_quadrature(torch.tensor(1.0, dtype=torch.float64), 1e-6)
        >>> round(float(w.sum()), 6), round(float((w * wi[..., 2]).sum()), 4)  # a near-mirror: A = 1, ω_i ≈ n
        (1.0, 1.0)
        >>> c = torch.tensor(0.5, dtype=torch.float64)  # θo = 60°, α = 1: the joint G's albedo is larger
        >>> [round(float(uniform_lobe_quadrature(c, 1.0, masking=m)[2].sum()), 4) for m in MASKING_MODES]
        [0.4091, 0.4507]
    """
    c, a, dtype, device = _geometry(cos_theta_o, alpha)
    u, phi, wq = _lobe_rule(nodes, dtype, device)
    a_ = a[..., None]
    # h from the D·cos CDF: tan²θh = α² u/(1 − u), i.e. cos²θh = (1 − u)/(1 − u + α² u)
    den = (1.0 - u) + a_ * a_ * u
    cos_h = torch.sqrt((1.0 - u) / den)
    sin_h = torch.sqrt(a_ * a_ * u / den)
    h = torch.stack([sin_h * torch.cos(phi), sin_h * torch.sin(phi), cos_h], -1)  # (*, Q, 3)
    v = _view(c)[..., None, :]
    vh = (v * h).sum(-1)
    wi = reflect_kernel(v, h)
    z = wi[..., 2]
    ok = (z > 0) & (vh > 0) & (cos_h > 0)
    zs = torch.where(ok, z, torch.ones_like(z))
    # ρ̃⟨n,ωi⟩ / p(ωi) = G(ωi, ωo)⟨ωo,h⟩ / (cos θo cos θh), p(ωi) = D cos θh / (4⟨ωo,h⟩)
    gi, go = smith_g1_kernel(zs, a_), smith_g1_kernel(c, a)[..., None]
    if masking == "separable":
        g = gi * go
    else:  # 1/(1 + Λi + Λo) with 1 + Λ = 1/G1; the denominator ≥ max(G1i, G1o) > 0 (G1o > 0: θo < 90°)
        g = gi * go / (gi + go - gi * go)
    wgt = g * vh / (c[..., None] * torch.where(ok, cos_h, torch.ones_like(cos_h)))
    wgt = torch.where(ok, wgt, torch.zeros_like(wgt))
    return wi, h, torch.where(torch.isnan(z + vh), torch.nan, wgt) * wq  # (NaN geometry: NaN weights)


@_checks.arguments(**_LOBE)
def uniform_light_moments(cos_theta_o, alpha, *, nodes: int = 64, masking: str = "separable"):
    r"""Albedo, mean and covariance of the light directions p_R ∝ ρ̃⟨n,ω_i⟩ under uniform light.

    These are the "ground-truth μ_ωi and Σ_ωi" of Kneiphof et al. 2019, Fig. 7 (b, f): the exact
    moments, where a renderer reads approximations from the nine prefiltered moment channels.

    Args:
        cos_theta_o, alpha, nodes, masking: as ``uniform_lobe_quadrature()``.

    Returns:
        ``(albedo (*), mean (*, 3), cov (*, 3, 3))`` in the frame n = +z, ω_o = (sin θo, 0, cos θo).

    Example:
        >>> import torch
        >>> A, mu, cov = uniform_light_moments(torch.tensor(0.8, dtype=torch.float64), 0.3)
        >>> round(float(A), 4), [round(v, 4) for v in mu.tolist()]
        (0.856, [-0.399, 0.0, 0.7063])
    """
    c, a, dtype, device = _geometry(cos_theta_o, alpha)
    shape = c.shape
    # block by block over large batches (torchirid._chunks): 2 · nodes² quadrature points per geometry
    out = _chunk_evaluate(_light_moments, (c, a), shape, out_core=1, width=2 * nodes * nodes, nodes=nodes,
                          masking=masking)
    return out[..., 0].contiguous(), out[..., 1:4].contiguous(), out[..., 4:].reshape(*shape, 3, 3).contiguous()


_lobe_quadrature = uniform_lobe_quadrature.__wrapped__  # (the bodies, on checked arguments)


def _light_moments(c, a, *, nodes, masking):
    """Albedo, mean and covariance of one block, packed as ``(*, 1 + 3 + 9)``."""
    shape = c.shape
    wi, _, w = _lobe_quadrature(c.reshape(-1), a.reshape(-1), nodes=nodes, masking=masking)
    A = w.sum(-1)
    p = w / A[..., None]
    mu = (p[..., None] * wi).sum(-2)
    second = torch.einsum("nq,nqi,nqj->nij", p, wi, wi)
    cov = second - mu[..., :, None] * mu[..., None, :]
    return torch.cat([A[..., None], mu, cov.reshape(-1, 9)], -1).reshape(*shape, 13)


@_checks.arguments(bins=_checks.integer(1), **_LOBE)
def cos_theta1_distribution(cos_theta_o, alpha, *, bins: int = 2048, nodes: int = 64,
                            masking: str = "separable"):
    r"""The distribution of :math:`\cos θ_1 = ⟨h, ω_i⟩` under p_R, as linear-splat weights on a grid.

    Args:
        cos_theta_o, alpha, nodes, masking: as ``uniform_lobe_quadrature()``.
        bins: cells of the uniform grid on cos θ1 ∈ [0, 1] (≥ 1; bins + 1 nodes).

    Returns:
        ``(grid (bins+1,), weights (*, bins+1), albedo (*))``; weights ≥ 0 sum to 1 (all NaN for
        a NaN input), and ``weights @ f(grid)`` is the mean of the piecewise-linear interpolant
        of f under p_R.

    Example:
        >>> import torch
        >>> g, w, A = cos_theta1_distribution(torch.tensor(0.5, dtype=torch.float64), 1e-6, bins=4)
        >>> [round(v, 4) for v in w.tolist()]  # a near-mirror at 60°: cos θ1 ≈ 0.5 (GGX tails: 2e-6)
        [0.0, 0.0, 1.0, 0.0, 0.0]
    """
    c, a, dtype, device = _geometry(cos_theta_o, alpha)
    shape = c.shape
    grid = torch.linspace(0.0, 1.0, bins + 1, dtype=dtype, device=device)
    # block by block over large batches (torchirid._chunks): 2 · nodes² quadrature points per geometry
    out = _chunk_evaluate(_cos_theta1_histogram, (c, a), shape, out_core=1, width=2 * nodes * nodes, bins=bins,
                          nodes=nodes, masking=masking)
    return grid, out[..., 1:].contiguous(), out[..., 0].contiguous()


def _cos_theta1_histogram(c, a, *, bins, nodes, masking):
    """Albedo and the splat weights of cos θ1 of one block, packed as ``(*, 1 + bins + 1)``."""
    shape = c.shape
    cc = c.reshape(-1)
    _, h, w = _lobe_quadrature(cc, a.reshape(-1), nodes=nodes, masking=masking)
    c1 = (h * _view(cc)[..., None, :]).sum(-1).clamp(0.0, 1.0)  # ⟨h, ω_o⟩ = ⟨h, ω_i⟩
    x = c1 * bins
    i0 = x.nan_to_num(0.0).floor().clamp(max=bins - 1)  # (NaN: any bin; its NaN weight t marks it)
    t = x - i0
    i0 = i0.long()
    A = w.sum(-1)
    p = w / A[..., None]
    hist = torch.zeros(cc.shape[0], bins + 1, dtype=c.dtype, device=c.device)
    hist.scatter_add_(-1, i0, p * (1.0 - t))
    hist.scatter_add_(-1, i0 + 1, p * t)
    # a NaN sample marked only its two bins: the whole distribution of that sample is NaN
    hist = torch.where(hist.isnan().any(-1, keepdim=True), torch.full_like(hist, math.nan), hist)
    return torch.cat([A[..., None], hist], -1).reshape(*shape, bins + 2)


_distribution = cos_theta1_distribution.__wrapped__


@_checks.arguments(n_film=_checks.REAL, thickness=_checks.THICKNESS, n_incident=_checks.positive(""),
                   bins=_checks.integer(1), **_LOBE)
def path_difference_moments(cos_theta_o, alpha, n_film, thickness, *, n_incident=1.0, bins: int = 2048,
                            nodes: int = 64, masking: str = "separable"):
    r"""Exact mean and variance of the path difference D = 2η₂d cos θ₂ under p_R (uniform light).

    The "ground-truth μ_D and σ²_D" of Kneiphof et al. 2019, Fig. 7 (c, g): the moments of
    :math:`\cos θ_2 = \sqrt{1 - (η_1/η_2)^2(1 - \cos^2θ_1)}` over the distribution of
    ``cos_theta1_distribution()``, scaled by 2η₂d (eq. 27–28 without the linearisation).

    Args:
        cos_theta_o, alpha: geometry, shape ``(*G)``.
        n_film: real film index η₂ ≥ ``n_incident``; thickness: nm ≥ 0; both broadcast with ``(*G)``.
        n_incident: real outer index η₁.
        bins, nodes: resolution (see ``cos_theta1_distribution()``).
        masking: ``"separable"`` (default) or ``"height_correlated"`` (see ``uniform_lobe_quadrature()``).

    Returns:
        ``(mean_D, var_D, mean_cos2, var_cos2)``, broadcast shape, nm / nm² / 1 / 1.

    Example:
        >>> import torch
        >>> mD, vD, _, _ = path_difference_moments(torch.tensor(1.0, dtype=torch.float64), 1e-3, 1.3, 600.0)
        >>> round(float(mD), 1)  # a near-mirror at normal incidence: D = 2·1.3·600
        1560.0
    """
    grid, w, _ = _distribution(cos_theta_o, alpha, bins=bins, nodes=nodes, masking=masking)
    nf, d, n0 = n_film, thickness, n_incident
    if _checks.value_checks_enabled() and bool((nf < n0).any()):
        raise ValueError("n_film must be >= n_incident (a propagating wave in the film)")
    # block by block over large batches (torchirid._chunks): bins + 1 weights per point
    batch = _checks.broadcast_shapes(w.shape[:-1], nf.shape, n0.shape, names=("cos_theta_o, alpha", "n_film", "n_incident"))
    m1, var = _chunk_evaluate(_cos2_moments, (w, nf, n0), batch, core=(1, 0, 0), width=grid.numel(), grid=grid)
    scale = 2.0 * nf * d
    return scale * m1, scale * scale * var, m1, var


def _cos2_moments(w, nf, n0, *, grid):
    """Mean and variance of cos θ2 under the weights ``w`` on ``grid`` (one block)."""
    k = (n0 / nf)[..., None] ** 2
    c2 = torch.sqrt((1.0 - k * (1.0 - grid * grid)).clamp_min(0.0))  # (*, bins+1)
    m1 = (w * c2).sum(-1)
    m2 = (w * c2 * c2).sum(-1)
    return m1, (m2 - m1 * m1).clamp_min(0.0)


@_checks.arguments(n_film=_checks.REAL, thickness=_checks.THICKNESS, n_substrate=_checks.INDEX,
                   n_incident=_checks.INCIDENT_INDEX, wavelength=_checks.WAVELENGTH | None, observer=OBSERVER,
                   illuminant=ILLUMINANT, polarization=_checks.POLARIZATION, bins=_checks.integer(1), **_LOBE)
def thin_film_xyz_uniform(cos_theta_o, alpha, n_film, thickness, n_substrate, *, n_incident=1.0,
                          observer: str = "CIE 1931 2", illuminant: str = "D65",
                          polarization: str = "unpolarized", bins: int = 2048, nodes: int = 64,
                          wavelength=None, masking: str = "separable"):
    r"""Reference XYZ of the reflectance term of a rough thin-film surface under uniform light.

    :math:`∫ p_R(ω_i)\,\mathrm{XYZ}[R(⟨h, ω_i⟩)]\,dω_i` (module docstring): what Kneiphof's eq. 29,
    Belcour–Barla at the mirror direction and :func:`~torchirid.ibl.thin_film_xyz_fitted`
    approximate. Multiply by the albedo (third output of ``cos_theta1_distribution()``, or
    ``uniform_light_moments(...)[0]``) for the reflected radiance :math:`L_o`.

    Args:
        cos_theta_o: cos θo in (0, 1]; alpha: GGX roughness > 0 — geometry, shape ``(*G)``.
        n_film: real film index η₂; thickness: d in nm; n_substrate: base η₃ + iκ₃ (non-dispersive
            here, as in Belcour–Barla) — broadcast with ``(*G)`` to ``(*)``.
        n_incident: real outer index η₁ (default 1).
        observer, illuminant: colour space (XYZ normalised so the perfect reflector has Y = 1).
        polarization: ``"unpolarized"`` (default), ``"s"`` or ``"p"``.
        bins, nodes: cos θ1 grid cells and lobe quadrature nodes per axis.
        wavelength: ``(W,)`` nm for the spectral integration; default 360–830 nm at 1 nm.
        masking: the lobe's G, ``"separable"`` (default) or ``"height_correlated"`` (Kneiphof's
            Smith-joint G; see ``uniform_lobe_quadrature()``).

    Returns:
        ``(*, 3)`` XYZ (white Y = 1).

    Example:
        >>> import torch
        >>> xyz = thin_film_xyz_uniform(torch.tensor(0.8, dtype=torch.float64), 0.25, 1.3, 600.0, complex(2.0, 0.5))
        >>> [round(v, 4) for v in xyz.tolist()]
        [0.0647, 0.067, 0.1077]
    """
    dtype, device = cos_theta_o.dtype, cos_theta_o.device
    grid, w, _ = _distribution(cos_theta_o, alpha, bins=bins, nodes=nodes, masking=masking)
    if wavelength is None:
        lam = torch.linspace(360.0, 830.0, 471, dtype=dtype, device=device)
    else:
        lam = wavelength
        if lam.ndim != 1 or lam.numel() < 2 or not bool((lam[1:] > lam[:-1]).all()):
            raise ValueError(f"wavelength must be a 1-D, strictly increasing grid of >= 2 samples (nm); got "
                             f"shape {tuple(lam.shape)}")
    W = xyz_weights_kernel(lam, observer, illuminant)  # (W, 3)
    nf, d, ns, n0 = n_film, thickness, n_substrate, n_incident
    film_shape = _checks.broadcast_shapes(nf.shape, d.shape, ns.shape, names=("n_film", "thickness", "n_substrate"))
    nf, d, ns = (t.expand(film_shape).reshape(-1) for t in (nf, d, ns))
    # XYZ[R](cos θ1) on the grid for every film, in blocks of films that bound the (films, bins, W)
    # spectra: films × bins × W ≤ the block size of torchirid._chunks (at least one film; None: all)
    chunk = _chunk_size(device)
    per = max(1, nf.numel()) if chunk is None else max(1, chunk // (grid.numel() * lam.numel()))
    rows = []
    for s in range(0, max(nf.numel(), 1), per):  # (once for an empty batch)
        sl = slice(s, s + per)
        R = _reflectance(lam, grid[:, None], nf[sl, None, None], d[sl, None, None],
                         ns[sl, None, None], n_incident=n0, polarization=polarization)
        rows.append(R @ W)  # (f, bins+1, 3)
    F = torch.cat(rows).reshape(*film_shape, grid.numel(), 3)
    # Σ_k w_k F_k over the broadcast of geometries and films, in blocks (a broadcast matmul would
    # copy w and F to the full (*, bins+1, 3) batch first)
    batch = _checks.broadcast_shapes(w.shape[:-1], film_shape)
    return _chunk_evaluate(_mixture_xyz, (w, F), batch, core=(1, 2), out_core=1, width=3 * grid.numel())


_reflectance = thin_film_reflectance.__wrapped__.__wrapped__  # (below the small-call and check decorators)


def _mixture_xyz(w, F):
    return torch.matmul(w[..., None, :], F)[..., 0, :]
