r"""A reflectance-agnostic GGX microfacet BRDF (Fourneau et al. 2024 §4.1, eq. 17).

.. math::

    f_r(\mathbf i, \mathbf o) = \frac{D(\mathbf h)\,G(\mathbf i, \mathbf o, \mathbf h)\,
        R(\mathbf i\cdot\mathbf h)}{4\,|\mathbf i\cdot\mathbf n|\,|\mathbf o\cdot\mathbf n|},
    \qquad \mathbf h = \frac{\mathbf i + \mathbf o}{|\mathbf i + \mathbf o|},

with D the GGX distribution (eq. 18) and G the separable Smith term (eq. 19). The paper
plugs in the Yeh reflectance of a Bragg mirror for R; here R is any callable of the cosine
of the difference angle ``i·h`` (Fresnel, thin film, Bragg, a constant, ...).

Directions live in the local shading frame (geometric normal n = +z) and point away from
the surface.
"""

from __future__ import annotations

import torch
from torch import nn

from .. import _checks
from .ggx import ALPHA, ggx_d_kernel

__all__ = ["microfacet_brdf", "MicrofacetBRDF"]


def _g1_over_cos(c: torch.Tensor, a: torch.Tensor) -> torch.Tensor:
    """G1(c)/c = 2/(c + √(c² + α²(1−c²))) for c ∈ (0, 1]: the 1/|v·n| of eq. 17 folded into
    eq. 19 without dividing by c, so it stays finite (→ 2/α) as c → 0⁺."""
    c2 = (c * c).clamp(max=1.0)  # rounding: a unit vector's z may be 1 + ulp
    return 2.0 / (c + torch.sqrt(c2 + a * a * (1.0 - c2)))


def _check_reflectance(r, name):
    if not callable(r):
        _checks.check_nonnegative(r, name, unit="(a reflectance)")


#: a reflectance: a number or tensor ≥ 0, or a function R(cos θd) left as it is
REFLECTANCE = _checks.Arg(lambda v, name, dtype, device: v if callable(v) else _checks.as_real(v, name, dtype, device),
                          _check_reflectance, tensor=True)


@_checks.arguments(wi=_checks.VECTORS, wo=_checks.VECTORS, alpha=ALPHA, reflectance=REFLECTANCE)
def microfacet_brdf(wi, wo, alpha, reflectance=1.0) -> torch.Tensor:
    r"""GGX microfacet BRDF of eq. 17 (Fourneau et al. 2024), in sr⁻¹.

    .. math::

        f_r = \frac{D(\mathbf h)\,G_1(\mathbf i)\,G_1(\mathbf o)\,R(\mathbf i\cdot\mathbf h)}
            {4\,(\mathbf i\cdot\mathbf n)(\mathbf o\cdot\mathbf n)}

    For reflection with both directions above the surface, ``i·h = o·h > 0`` and
    ``h·n > 0``, so every χ⁺ of eq. 18–19 is 1.

    Args:
        wi: unit incident directions (pointing away from the surface), local frame with the
            geometric normal = +z, shape ``(*, 3)``.
        wo: unit outgoing directions, shape ``(*, 3)``.
        alpha: GGX roughness > 0, shape broadcasting with ``(*)``.
        reflectance: either a callable ``R(cos_d)`` taking the cosine ``i·h ∈ [0, 1]`` of
            the difference angle, shape ``(*)``, and returning ``(*)`` or, for a spectrum,
            ``(*, W)`` (wavelength on a new last axis, e.g.
            ``lambda c: bragg_reflectance(wl, c[..., None], ...)``); or a constant
            ``R ≥ 0`` (a float, or a tensor broadcasting with ``(*)``). Default 1 (a perfect
            mirror microsurface: the white-furnace configuration).

    Returns:
        ``f_r`` of shape ``(*)``, or ``(*, W)`` for a spectral ``R``; exactly 0 where
        ``wi`` or ``wo`` is at or below the horizon (``z <= 0``). Finite with finite
        gradients everywhere, including normal incidence ``i = o = n`` and grazing.

    Raises:
        ValueError: ``alpha <= 0``; ``wi``/``wo`` not of shape ``(*, 3)``; a constant
            ``reflectance < 0``; a callable returning a shape other than ``(*)`` / ``(*, W)``.

    >>> n = torch.tensor([0.0, 0.0, 1.0], dtype=torch.float64)
    >>> round(float(microfacet_brdf(n, n, 0.5)), 6)  # D(n)/4 = 1/(4πα²) at normal incidence
    0.31831
    >>> round(float(microfacet_brdf(n, n, 0.5, 0.04)), 6)  # constant R = 0.04
    0.012732
    """
    const = not callable(reflectance)
    i, o, a = wi, wo, alpha
    dtype, device = i.dtype, i.device
    r_const = reflectance

    ci, co = i[..., 2], o[..., 2]
    below = (ci <= 0) | (co <= 0)  # (NaN is not below: it propagates)
    # Below the horizon the result is 0; feed those entries safe stand-ins (n) so that
    # neither the forward nor the backward pass of the unused branch meets 0/0.
    n = torch.tensor([0.0, 0.0, 1.0], dtype=dtype, device=device)
    i_s = torch.where(below.unsqueeze(-1), n, i)
    o_s = torch.where(below.unsqueeze(-1), n, o)
    s = i_s + o_s
    h = s / torch.linalg.vector_norm(s, dim=-1, keepdim=True)  # |i+o| ≥ (i+o)·n > 0 here
    cos_d = (i_s * h).sum(-1).clamp(0.0, 1.0)  # i·h > 0; clamp rounding to the cosine range
    dg = 0.25 * ggx_d_kernel(h[..., 2], a) * _g1_over_cos(i_s[..., 2], a) * _g1_over_cos(o_s[..., 2], a)
    shape = dg.shape
    below = below.expand(shape)

    if const:
        out = dg * r_const
        return torch.where(below, torch.zeros_like(out), out)

    r = reflectance(cos_d.expand(shape))
    r = torch.as_tensor(r, device=device)
    if r.ndim == len(shape) + 1:  # spectral: wavelength on the last axis
        out = dg.unsqueeze(-1) * r
        mask = below.unsqueeze(-1)
    elif r.ndim == len(shape):
        out = dg * r
        mask = below
    else:
        raise ValueError(
            f"reflectance(cos_d) must return shape (*) or (*, W) for cos_d of shape {tuple(shape)}; "
            f"got {tuple(r.shape)}"
        )
    return torch.where(mask, torch.zeros_like(out), out)


class MicrofacetBRDF(nn.Module):
    """Learnable-roughness wrapper of :func:`microfacet_brdf`: ``forward(wi, wo)``.

    ``alpha`` is an unconstrained ``nn.Parameter`` (register a parametrization to keep it
    > 0 while fitting; the function raises ``ValueError`` otherwise). ``reflectance`` is
    passed through unchanged; when it is an ``nn.Module`` (e.g. a callable wrapping
    :class:`torchirid.BraggMirror`) its parameters are registered too.

    >>> brdf = MicrofacetBRDF(alpha=0.5)
    >>> n = torch.tensor([0.0, 0.0, 1.0], dtype=torch.float64)
    >>> round(float(brdf(n, n).detach()), 6)
    0.31831
    """

    def __init__(self, alpha=0.1, reflectance=1.0, *, dtype=torch.float64):
        super().__init__()
        self.alpha = nn.Parameter(torch.as_tensor(alpha, dtype=dtype).clone())
        self.reflectance = reflectance

    def forward(self, wi, wo):
        return microfacet_brdf(wi, wo, self.alpha, self.reflectance)
