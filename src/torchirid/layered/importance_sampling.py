r"""Importance sampling of the single-reflection BRDF (Fourneau et al. 2024 eq. 35): the reflecting
layer chosen with :math:`p_{\mathrm{refl},l} = (1-p_{\mathrm{trans},l})\prod_{k<l} p_{\mathrm{trans},k}`
(eq. 31 multiplexed over wavelengths; the base takes the remaining :math:`\prod_k p_{\mathrm{trans},k}`),
then the layer's GGX VNDF or the base's cosine lobe."""

from __future__ import annotations

import math

import torch

from .. import _checks
from . import _geometry
from ..microfacet.ggx import ggx_d_kernel, smith_g1_kernel, sample_ggx_vndf
from .transmission import probability_kernel

from .tables import REFLECTANCE_ANGLES, TRANSMISSIVITY_ANGLES, _half_vector, _tables, refract_into_host

__all__ = ["sample_single_reflection", "single_reflection_pdf"]


# ----------------------------------------------------------------------------------------
# importance sampling (eq. 35)
# ----------------------------------------------------------------------------------------
@_checks.arguments(structure=_geometry.STRUCTURE, cos_theta=_checks.COSINE, wavelength=_geometry.WAVELENGTHS,
                   transmissivity_angles=_checks.integer(2))
def layer_reflection_probabilities(wavelength, cos_theta, structure, *, transmissivity_angles: int = TRANSMISSIVITY_ANGLES):
    r"""Probabilities of eq. 35 that the single reflection happens on layer ``l`` (last entry:
    the base), multiplexed over wavelengths: ``(*, L + 1)`` summing to 1.

    ``cos_theta`` is the incidence cosine **in the host** (already refracted).

    Example (two layers over a grey base; the base takes what both layers let through):
        >>> import torch
        >>> from torchirid.layered import LayeredBragg, RoughBraggLayer
        >>> s = LayeredBragg([RoughBraggLayer(1.0, 1.5, 250.0, 250.0, 10, 0.1),
        ...                   RoughBraggLayer(1.0, 1.5, 200.0, 200.0, 10, 0.1)], base_albedo=0.5)
        >>> lam = torch.tensor([500.0, 680.0], dtype=torch.float64)  # nm
        >>> p = layer_reflection_probabilities(lam, torch.tensor([1.0, 0.5], dtype=torch.float64), s)  # cos θ
        >>> p.shape  # (*, L + 1)
        torch.Size([2, 3])
        >>> [round(v, 4) for v in p[0].tolist()]
        [0.0518, 0.4442, 0.5041]
        >>> torch.allclose(p.sum(-1), torch.ones(2, dtype=torch.float64))
        True
    """
    tables = _tables(structure, wavelength, transmissivity_angles, REFLECTANCE_ANGLES, False)
    return _reflection_probabilities(structure, tables, cos_theta)


def _reflection_probabilities(structure, tables, c):
    probs = []
    carry = torch.ones_like(c)
    for tab in tables:
        tau = tab.transmissivity(c)
        p_t = probability_kernel(tau, c.unsqueeze(-1), tab.alpha.unsqueeze(-1), True)  # eq. 31, multiplexed
        p_t = p_t.squeeze(-1) if p_t.dim() > c.dim() else p_t
        probs.append(carry * (1.0 - p_t))
        carry = carry * p_t
    probs.append(carry)  # the base (or absorption when ρd = 0: its f_r is 0)
    return torch.stack(probs, dim=-1)


def _cosine_hemisphere(u: torch.Tensor) -> torch.Tensor:
    r = torch.sqrt(u[..., 0])
    phi = 2.0 * math.pi * u[..., 1]
    z = torch.sqrt((1.0 - u[..., 0]).clamp_min(0.0))
    return torch.stack([r * torch.cos(phi), r * torch.sin(phi), z], dim=-1)


def _as_uniforms(u, name, dtype, device) -> torch.Tensor:
    u = _checks.as_real(u, name, dtype, device)
    if u.dim() == 0 or u.shape[-1] != 3:
        raise ValueError(f"{name} must have shape (*, 3) (uniforms in [0, 1)); got {tuple(u.shape)}")
    return u


def _check_uniforms(u, name) -> None:
    with torch.no_grad():
        if bool(((u < 0) | (u > 1)).any()):  # (NaN passes: it propagates)
            raise ValueError(f"{name} must lie in [0, 1] (uniform random numbers)")


#: three uniform random numbers per sample, ``(*, 3)`` in [0, 1]
UNIFORMS = _checks.Arg(_as_uniforms, _check_uniforms, values=True, tensor=True)


@_checks.arguments(structure=_geometry.STRUCTURE, wi=_geometry.GRAZING_DIRECTIONS, wavelength=_geometry.WAVELENGTHS,
                   u=UNIFORMS, transmissivity_angles=_checks.integer(2),
                   broadcast=("wi", "u"))
def sample_single_reflection(wavelength, wi, structure, u, *, transmissivity_angles: int = TRANSMISSIVITY_ANGLES):
    r"""Importance-sample an outgoing direction of the single-reflection model (eq. 35).

    A layer is chosen with the probabilities of eq. 35 (``u[..., 0]``), then a visible
    microfacet normal of that layer (``u[..., 1:3]``, Heitz 2018) is reflected; the base is
    sampled with a cosine lobe. With a coating the sampled host direction is refracted out
    (directions trapped by total internal reflection come back with ``pdf = 0``).

    Args:
        structure: :class:`LayeredBragg`; wi: ``(*, 3)`` unit vectors (z ≥ 0);
        wavelength: ``(W,)`` nm; u: ``(*, 3)`` uniforms in [0, 1).

    Returns:
        ``(wo, pdf)``: ``wo (*, 3)`` and its solid-angle density :func:`single_reflection_pdf`
        (``0`` where the sample is invalid: below the horizon or trapped).

    Example (five samples at normal incidence, seeded):
        >>> import torch
        >>> from torchirid.layered import LayeredBragg, RoughBraggLayer
        >>> s = LayeredBragg([RoughBraggLayer(1.0, 1.5, 250.0, 250.0, 10, 0.1)], base_albedo=0.5)
        >>> lam = torch.tensor([500.0, 680.0], dtype=torch.float64)  # nm
        >>> wi = torch.tensor([0.0, 0.0, 1.0], dtype=torch.float64)
        >>> u = torch.rand(5, 3, generator=torch.Generator().manual_seed(0), dtype=torch.float64)
        >>> wo, pdf = sample_single_reflection(lam, wi, s, u)
        >>> wo.shape, pdf.shape
        (torch.Size([5, 3]), torch.Size([5]))
        >>> torch.allclose(pdf, single_reflection_pdf(lam, wi, wo, s))
        True
    """
    lam = wavelength
    dtype = lam.dtype
    wi, u = torch.broadcast_tensors(wi, u)
    tables = _tables(structure, lam, transmissivity_angles, REFLECTANCE_ANGLES, False)
    n = structure.n_coating
    wi_h = refract_into_host(wi, n)
    probs = _reflection_probabilities(structure, tables, wi_h[..., 2])
    cdf = torch.cumsum(probs, dim=-1)
    choice = torch.searchsorted(cdf.contiguous(), u[..., :1].contiguous(), right=True).squeeze(-1)
    choice = choice.clamp(max=len(tables))
    # one candidate per layer and for the base, then pick (no per-sample Python loop)
    cands = []
    zi = wi_h[..., 2].clamp_min(torch.finfo(dtype).tiny)
    wi_s = torch.cat([wi_h[..., :2], zi.unsqueeze(-1)], -1)
    for tab in tables:
        m = sample_ggx_vndf.__wrapped__(wi_s, tab.alpha, u[..., 1:3])
        cands.append(2.0 * (wi_s * m).sum(-1, keepdim=True) * m - wi_s)
    cands.append(_cosine_hemisphere(u[..., 1:3]))
    cands = torch.stack(cands, dim=-2)
    wo_h = torch.gather(cands, -2, choice[..., None, None].expand(*choice.shape, 1, 3)).squeeze(-2)
    wo, exits = _geometry.refract_out(wo_h, n)
    valid = exits & (wo_h[..., 2] > 0)
    wo = torch.where(valid.unsqueeze(-1), wo, torch.zeros_like(wo))
    pdf = torch.where(valid, _pdf(structure, tables, wi, wo, probs), 0.0)
    bad = _geometry.nan_rows(wi, u)
    return torch.where(bad.unsqueeze(-1), torch.nan, wo), torch.where(bad, torch.nan, pdf)


@_checks.arguments(structure=_geometry.STRUCTURE, wi=_geometry.GRAZING_DIRECTIONS, wo=_geometry.GRAZING_DIRECTIONS,
                   wavelength=_geometry.WAVELENGTHS, transmissivity_angles=_checks.integer(2), broadcast=("wi", "wo"))
def single_reflection_pdf(wavelength, wi, wo, structure, *, transmissivity_angles: int = TRANSMISSIVITY_ANGLES) -> torch.Tensor:
    """Solid-angle density (sr⁻¹, in the outer medium) of :func:`sample_single_reflection`.

    ``wi``, ``wo``: ``(*, 3)`` unit vectors (z ≥ 0, broadcasting); ``wavelength``: ``(W,)`` nm.
    Returns ``(*,)``: one density for all wavelengths (the layer choice is multiplexed).

    Example (integrated over the hemisphere: 1, bar what the lobes send below the horizon):
        >>> import math, torch
        >>> from torchirid.layered import LayeredBragg, RoughBraggLayer
        >>> s = LayeredBragg([RoughBraggLayer(1.0, 1.5, 250.0, 250.0, 10, 0.1)], base_albedo=0.5)
        >>> lam = torch.tensor([500.0, 680.0], dtype=torch.float64)  # nm
        >>> wi = torch.tensor([0.0, 0.0, 1.0], dtype=torch.float64)
        >>> dt, dp = math.pi / 2 / 512, 2 * math.pi / 8  # midpoint rule in (θ, φ)
        >>> t, p = torch.meshgrid((torch.arange(512, dtype=torch.float64) + 0.5) * dt,
        ...                       (torch.arange(8, dtype=torch.float64) + 0.5) * dp, indexing="ij")
        >>> wo = torch.stack([t.sin() * p.cos(), t.sin() * p.sin(), t.cos()], -1)
        >>> pdf = single_reflection_pdf(lam, wi, wo, s)
        >>> pdf.shape
        torch.Size([512, 8])
        >>> round(float((pdf * t.sin()).sum() * dt * dp), 3)
        0.999
    """
    wi, wo = torch.broadcast_tensors(wi, wo)
    tables = _tables(structure, wavelength, transmissivity_angles, REFLECTANCE_ANGLES, False)
    probs = _reflection_probabilities(structure, tables, refract_into_host(wi, structure.n_coating)[..., 2])
    return torch.where(_geometry.nan_rows(wi, wo), torch.nan, _pdf(structure, tables, wi, wo, probs))


def _pdf(structure, tables, wi, wo, probs):
    n = structure.n_coating
    wi_h = refract_into_host(wi, n)
    wo_h = refract_into_host(wo, n)
    zi, zo = wi_h[..., 2], wo_h[..., 2]
    ok = (zi > 0) & (zo > 0)
    zi_s = torch.where(ok, zi, torch.ones_like(zi))
    h = _half_vector(wi_h, wo_h)
    cos_d = (wi_h * h).sum(-1).clamp_min(torch.finfo(h.dtype).tiny)
    pdf = probs[..., -1] * zo / math.pi  # base: cosine lobe in the host
    for l, tab in enumerate(tables):
        a = tab.layer.alpha
        vndf = smith_g1_kernel(zi_s, a) * cos_d * ggx_d_kernel(h[..., 2].clamp(-1.0, 1.0), a) / zi_s
        pdf = pdf + probs[..., l] * vndf / (4.0 * cos_d)
    # host solid angle → outer solid angle: dω' = cos θo / (n² cos θo') dω
    if n != 1.0:
        pdf = pdf * wo[..., 2] / (n * n * zo.clamp_min(torch.finfo(zo.dtype).tiny))
    return torch.where(ok, pdf, torch.zeros_like(pdf))
