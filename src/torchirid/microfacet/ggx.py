r"""Isotropic GGX (Trowbridge–Reitz) microfacet distribution and Smith masking.

Fourneau et al. 2024, eq. 18–19 (after Walter et al. 2007). Angles are given as cosines
with respect to the geometric normal; ``alpha`` is the GGX roughness (> 0; the paper uses
α ∈ [0, 1], α → 0 is a mirror).

Forms used (algebraically equal to the paper's, without ``tan`` so that they stay finite at
grazing and normal incidence):

.. math::

    D(\theta_m) = \frac{\alpha^2 \chi^+(\cos\theta_m)}{\pi\cos^4\theta_m(\alpha^2+\tan^2\theta_m)^2}
                = \frac{\alpha^2 \chi^+(\cos\theta_m)}{\pi\,\bigl(1 + (\alpha^2-1)\cos^2\theta_m\bigr)^2}

    G_1(\theta) = \frac{2}{1+\sqrt{1+\alpha^2\tan^2\theta}}
                = \frac{2\cos\theta}{\cos\theta + \sqrt{\cos^2\theta + \alpha^2(1-\cos^2\theta)}}
"""

from __future__ import annotations

import math

import torch

from .. import _checks

__all__ = ["ggx_d", "smith_g1", "smith_lambda"]


def _prepare(cos, alpha, cos_name):
    dtype, device = _checks.resolve_dtype_device(cos, alpha)
    c = _checks.as_real(cos, cos_name, dtype, device)
    a = _checks.as_real(alpha, "alpha", dtype, device)
    _checks.check_positive(a, "alpha", unit="(GGX roughness)")
    return c, a


def ggx_d(cos_theta_m, alpha) -> torch.Tensor:
    r"""GGX normal distribution :math:`D(\mathbf m)` (Fourneau et al. 2024 eq. 18), in sr⁻¹.

    Args:
        cos_theta_m: cosine of the microfacet normal's angle to the geometric normal, in
            [-1, 1]; ``D = 0`` for ``cos_theta_m <= 0`` (the χ⁺ factor).
        alpha: GGX roughness, > 0.

    Returns:
        ``D`` broadcast over the inputs. Normalised so that ∫ D cos θm dω = 1.

    >>> round(float(ggx_d(1.0, 0.5)), 6)  # 1 / (π α²) at the pole
    1.273239
    """
    c, a = _prepare(cos_theta_m, alpha, "cos_theta_m")
    with torch.no_grad():
        if bool((c.abs() > 1).any()):
            raise ValueError("cos_theta_m must lie in [-1, 1]")
    a2 = a * a
    c2 = c * c
    denom = 1.0 + (a2 - 1.0) * c2  # = cos⁴θ (α² + tan²θ)² ** ½, ≥ min(1, α²) > 0
    d = a2 / (math.pi * denom * denom)
    return torch.where(c > 0, d, torch.zeros_like(d))


def smith_lambda(cos_theta, alpha) -> torch.Tensor:
    r"""Smith's Λ for GGX: :math:`\Lambda = (\sqrt{1+\alpha^2\tan^2\theta} - 1)/2`, so
    :math:`G_1 = 1/(1+\Lambda)`. Infinite at grazing (``cos_theta = 0``).

    >>> round(float(smith_lambda(0.5, 0.5)), 6)
    0.161438
    """
    c, a = _prepare(cos_theta, alpha, "cos_theta")
    c = c.abs()
    root = torch.sqrt(c * c + a * a * (1.0 - c * c))
    return 0.5 * (root - c) / c


def smith_g1(cos_theta, alpha) -> torch.Tensor:
    r"""Smith masking :math:`G_1` for GGX (Fourneau et al. 2024 eq. 19, without the χ⁺ factor).

    Args:
        cos_theta: cosine of the direction's angle to the geometric normal; the sign is
            ignored (a direction below the surface is masked by the flipped surface).
        alpha: GGX roughness, > 0.

    Returns:
        ``G1 ∈ [0, 1]``: 1 at normal incidence, 0 at grazing. The microfacet-side χ⁺
        term of eq. 19 (``(i·m)/(i·n) > 0``) is applied by the callers that know ``m``.

    >>> round(float(smith_g1(0.5, 0.5)), 6)
    0.861002
    """
    c, a = _prepare(cos_theta, alpha, "cos_theta")
    c = c.abs()
    root = torch.sqrt(c * c + a * a * (1.0 - c * c))  # > 0 for α > 0 (safe at c = 0)
    return 2.0 * c / (c + root)
