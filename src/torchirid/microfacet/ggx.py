r"""Isotropic GGX (Trowbridge–Reitz) microfacet distribution, Smith masking, and sampling of
the distribution of visible normals.

Fourneau et al. 2024, eq. 18–19 (after Walter et al. 2007); visible normals after Heitz 2014
("Understanding the masking-shadowing function", its definition of D_ωi) and Heitz 2018 ("Sampling the GGX
distribution of visible normals"). Scalar functions take cosines with respect to the
geometric normal; vector functions (``smith_g``, ``sample_ggx_vndf``, ``ggx_vndf_pdf``,
``reflect``) take ``(*, 3)`` directions in the local frame whose normal is +z. ``alpha`` is
the GGX roughness (> 0; the paper uses α ∈ [0, 1], α → 0 is a mirror).

Forms used (algebraically equal to the paper's, without ``tan`` so that they stay finite at
grazing and normal incidence):

.. math::

    D(\theta_m) = \frac{\alpha^2 \chi^+(\cos\theta_m)}{\pi\cos^4\theta_m(\alpha^2+\tan^2\theta_m)^2}
                = \frac{\alpha^2 \chi^+(\cos\theta_m)}{\pi\,\bigl(\sin^2\theta_m + \alpha^2\cos^2\theta_m\bigr)^2}

(the denominator summed as ``(1 − c)(1 + c) + α² c²``: two non-negative terms, so small α
keeps full relative precision at the peak ``c = 1``)

    G_1(\theta) = \frac{2}{1+\sqrt{1+\alpha^2\tan^2\theta}}
                = \frac{2\cos\theta}{\cos\theta + \sqrt{\cos^2\theta + \alpha^2(1-\cos^2\theta)}}
"""

from __future__ import annotations

import math

import torch

from .. import _checks

__all__ = ["ggx_d", "ggx_vndf_pdf", "reflect", "sample_ggx_vndf", "smith_g", "smith_g1",
           "smith_lambda"]


def _prepare(cos, alpha, cos_name):
    dtype, device = _checks.resolve_dtype_device(cos, alpha)
    c = _checks.as_real(cos, cos_name, dtype, device)
    a = _checks.as_real(alpha, "alpha", dtype, device)
    _checks.check_signed_cosine(c, cos_name)  # (the sign is the χ⁺ test of ggx_d, ignored by Λ and G1)
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
    return ggx_d_kernel(c, a)


def smith_lambda(cos_theta, alpha) -> torch.Tensor:
    r"""Smith's Λ for GGX: :math:`\Lambda = (\sqrt{1+\alpha^2\tan^2\theta} - 1)/2`, so
    :math:`G_1 = 1/(1+\Lambda)`. At grazing (``cos_theta = 0``) Λ takes its limit ``+inf``
    (G1 = 0) with a zero gradient (the library's convention for a one-sided infinite slope),
    not the NaN of 0/0 in backward.

    >>> round(float(smith_lambda(0.5, 0.5)), 6)
    0.161438
    >>> smith_lambda(0.0, 0.3)
    tensor(inf)
    """
    c, a = _prepare(cos_theta, alpha, "cos_theta")
    c = c.abs()
    grazing = c == 0  # guard: 0/0 in backward; Λ → +∞ there (a NaN c is not grazing: it propagates)
    c_safe = torch.where(grazing, torch.ones_like(c), c)
    root = torch.sqrt(c_safe * c_safe + a * a * (1.0 - c_safe * c_safe))
    lam = 0.5 * (root - c_safe) / c_safe
    return torch.where(grazing, torch.full_like(lam, math.inf), lam)


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
    return smith_g1_kernel(c.abs(), a)


# ---------------------------------------------------------------------------------------
# Vector helpers (local shading frame: geometric normal n = +z)
# ---------------------------------------------------------------------------------------


def ggx_d_kernel(c: torch.Tensor, a: torch.Tensor) -> torch.Tensor:
    """GGX normal distribution D(m) (eq. 18) without validation: the kernel of :func:`ggx_d`
    for callers that validated ``cos θm`` (``c``, may exceed 1 by rounding) and ``α > 0``
    (``a``) themselves, on tensors of one dtype/device. 0 for ``c ≤ 0``; NaN propagates.

    Example (at the peak, cos θm = 1: D = 1/(πα²)):
        >>> import torch
        >>> c = torch.tensor([0.2, 0.7, 1.0], dtype=torch.float64)  # cos θm
        >>> a = torch.tensor(0.3, dtype=torch.float64)  # α
        >>> torch.equal(ggx_d_kernel(c, a), ggx_d(c, a))
        True
        >>> round(float(ggx_d_kernel(c, a)[-1]), 6)
        3.536777
    """
    a2 = a * a
    # cos²θ (α² + tan²θ) = 1 + (α² − 1)cos²θ, summed as sin²θ + α² cos²θ: two terms ≥ 0, so no
    # cancellation at the peak (1 + (α² − 1) loses ~log10(1/α²) digits there)
    denom = (1.0 - c) * (1.0 + c) + a2 * (c * c)
    d = a2 / (math.pi * denom * denom)
    return torch.where(c <= 0, torch.zeros_like(d), d)  # χ⁺; NaN propagates


def smith_g1_kernel(c: torch.Tensor, a: torch.Tensor) -> torch.Tensor:
    """Smith G1 (eq. 19, without χ⁺) without validation: the kernel of :func:`smith_g1` for
    callers that validated ``c = cos θ ≥ 0`` and ``a = α > 0`` themselves.

    Example:
        >>> import torch
        >>> c = torch.tensor([0.2, 0.7, 1.0], dtype=torch.float64)  # cos θ
        >>> a = torch.tensor(0.3, dtype=torch.float64)  # α
        >>> torch.equal(smith_g1_kernel(c, a), smith_g1(c, a))
        True
        >>> [round(v, 4) for v in smith_g1_kernel(c, a).tolist()]
        [0.72, 0.9776, 1.0]
    """
    c2 = (c * c).clamp(max=1.0)  # rounding: |v| may be 1 + ulp
    root = torch.sqrt(c2 + a * a * (1.0 - c2))  # > 0 for α > 0 (safe sqrt at c = 0 and 1)
    return 2.0 * c / (c + root)


def _check_above(wz: torch.Tensor, name: str) -> None:
    with torch.no_grad():
        if bool((wz <= 0).any()):
            raise ValueError(
                f"{name} must point above the surface ({name}[..., 2] > 0 in the local frame with "
                f"normal +z); got min z = {wz.min().item():g}"
            )


def _check_direction_above(t: torch.Tensor, name: str) -> None:
    _checks.check_vectors(t, name)
    if _checks.value_checks_enabled():
        _check_above(t[..., 2], name)


def _check_samples(t: torch.Tensor, name: str) -> None:
    if t.ndim == 0 or t.shape[-1] != 2:
        raise ValueError(f"{name} must have shape (*, 2) (two uniform numbers per sample); got {tuple(t.shape)}")
    if _checks.value_checks_enabled():
        with torch.no_grad():
            if bool(((t < 0) | (t > 1)).any()):
                raise ValueError(f"{name} must lie in [0, 1] (uniform random numbers)")


#: the arguments of this module: GGX roughness, directions (above the surface), uniform samples
ALPHA = _checks.positive("(GGX roughness)")
ABOVE = _checks.Arg(_checks.as_real, _check_direction_above, tensor=True)
SAMPLES = _checks.Arg(_checks.as_real, _check_samples, tensor=True)


@_checks.arguments(wi=_checks.VECTORS, m=_checks.VECTORS)
def reflect(wi, m) -> torch.Tensor:
    r"""Mirror reflection of ``wi`` about the normal ``m``: :math:`\mathbf o = 2(\mathbf i\cdot\mathbf m)\mathbf m - \mathbf i`.

    Args:
        wi: directions pointing away from the surface, shape ``(*, 3)``.
        m: unit normals, shape ``(*, 3)`` (broadcast with ``wi``).

    Returns:
        ``(*, 3)``; a unit vector when ``wi`` and ``m`` are unit vectors.

    >>> reflect(torch.tensor([0.6, 0.0, 0.8]), torch.tensor([0.0, 0.0, 1.0])).tolist()
    [-0.6000000238418579, 0.0, 0.800000011920929]
    """
    return reflect_kernel(wi, m)


def reflect_kernel(i: torch.Tensor, n: torch.Tensor) -> torch.Tensor:
    """:func:`reflect` on checked ``(*, 3)`` tensors of one dtype and device."""
    return 2.0 * (i * n).sum(-1, keepdim=True) * n - i


@_checks.arguments(wi=ABOVE, alpha=ALPHA, u=SAMPLES)
def sample_ggx_vndf(wi, alpha, u) -> torch.Tensor:
    r"""Sample a microfacet normal from the GGX distribution of visible normals (isotropic α).

    Heitz 2018, "Sampling the GGX Distribution of Visible Normals" (JCGT 7(4)), listing 1:
    stretch ``wi`` by α to the hemisphere configuration, sample the projected area of a
    unit hemisphere (a disk, warped by ``s = (1 + cos θ_h)/2``), lift to the hemisphere,
    and unstretch. The density of the returned ``m`` in solid angle is
    :func:`ggx_vndf_pdf`, :math:`D_{wi}(\mathbf m) = G_1(\mathbf i)\,\max(0,\mathbf i\cdot\mathbf m)\,D(\mathbf m)/\cos\theta_i`.

    Args:
        wi: viewing directions in the local frame (geometric normal = +z), shape ``(*, 3)``.
            Need not be normalised (the sample only depends on the direction) but must
            point above the surface: ``wi[..., 2] > 0``, else ``ValueError``.
        alpha: GGX roughness > 0, shape broadcasting with the leading dims ``(*)``.
        u: uniform random numbers in [0, 1], shape ``(*, 2)``.

    Returns:
        Unit microfacet normals ``m`` with ``m[..., 2] >= 0``, shape ``(*, 3)`` broadcast
        over ``wi``, ``alpha`` and ``u``. Differentiable in ``alpha`` and ``wi``
        (reparameterisation), finite at normal incidence.

    >>> m = sample_ggx_vndf(torch.tensor([0.0, 0.0, 1.0]), 0.5, torch.tensor([0.0, 0.0]))
    >>> m.tolist()  # u1 = 0 samples the centre of the disk: m = n
    [0.0, 0.0, 1.0]
    """
    v, a, uu = wi, alpha, u
    a = a.unsqueeze(-1) if a.ndim > 0 else a
    # stretch to the α = 1 configuration
    vh = torch.cat([a * v[..., :2], v[..., 2:].expand(*_checks.broadcast_shapes(a.shape, v[..., 2:].shape))], -1)
    vh = vh / torch.linalg.vector_norm(vh, dim=-1, keepdim=True)  # |vh| ≥ vh.z > 0
    # orthonormal basis (T1, T2, vh); T1 = x at normal incidence (lensq = 0, guarded sqrt)
    lensq = vh[..., 0] ** 2 + vh[..., 1] ** 2
    has_xy = lensq > 0
    inv_len = torch.rsqrt(torch.where(has_xy, lensq, torch.ones_like(lensq)))
    zero = torch.zeros_like(lensq)
    t1 = torch.stack(
        [
            torch.where(has_xy, -vh[..., 1] * inv_len, torch.ones_like(lensq)),
            torch.where(has_xy, vh[..., 0] * inv_len, zero),
            zero,
        ],
        -1,
    )
    t2 = torch.linalg.cross(vh, t1, dim=-1)
    # uniform point on the unit disk, warped towards the visible half
    r = _checks.safe_sqrt(uu[..., 0])
    phi = (2.0 * math.pi) * uu[..., 1]
    p1 = r * torch.cos(phi)
    p2 = r * torch.sin(phi)
    s = 0.5 * (1.0 + vh[..., 2])
    p1, p2, s = torch.broadcast_tensors(p1, p2, s)
    p2 = (1.0 - s) * _checks.safe_sqrt(1.0 - p1 * p1) + s * p2
    # lift to the hemisphere
    p3 = _checks.safe_sqrt(1.0 - p1 * p1 - p2 * p2)
    nh = p1.unsqueeze(-1) * t1 + p2.unsqueeze(-1) * t2 + p3.unsqueeze(-1) * vh
    # unstretch back to the α configuration
    ne = torch.cat([a * nh[..., :2], nh[..., 2:].clamp(min=0.0)], -1)
    return ne / torch.linalg.vector_norm(ne, dim=-1, keepdim=True)  # |ne| > 0: nh is unit, α > 0


@_checks.arguments(wi=ABOVE, m=_checks.VECTORS, alpha=ALPHA)
def ggx_vndf_pdf(wi, m, alpha) -> torch.Tensor:
    r"""Density (sr⁻¹) of :func:`sample_ggx_vndf`: the GGX distribution of visible normals

    .. math::

        D_{\mathbf i}(\mathbf m) = \frac{G_1(\mathbf i)\,\max(0, \mathbf i\cdot\mathbf m)\,D(\mathbf m)}{\cos\theta_i}

    (Heitz 2014's distribution of visible normals; D and G1 from Fourneau et al. 2024
    eq. 18–19). It integrates to 1
    over the hemisphere of ``m`` for every ``wi`` above the surface.

    Args:
        wi: unit viewing directions, local frame (normal = +z), shape ``(*, 3)``,
            ``wi[..., 2] > 0`` (else ``ValueError``).
        m: unit microfacet normals, shape ``(*, 3)``; the density is 0 for ``m[..., 2] <= 0``
            or ``wi·m <= 0``.
        alpha: GGX roughness > 0, shape broadcasting with ``(*)``.

    Returns:
        The density, shape ``(*)``.

    >>> n = torch.tensor([0.0, 0.0, 1.0])
    >>> round(float(ggx_vndf_pdf(n, n, 0.5)), 6)  # = D(n) = 1/(π α²) at normal incidence
    1.273239
    """
    i, mm, a = wi, m, alpha
    ci = i[..., 2]
    dot = (i * mm).sum(-1)
    g1_over_c = smith_g1_kernel(ci, a) / ci  # ci > 0 (validated)
    return g1_over_c * dot.clamp(min=0.0) * ggx_d_kernel(mm[..., 2], a)


@_checks.arguments(wi=_checks.VECTORS, wo=_checks.VECTORS, m=_checks.VECTORS, alpha=ALPHA)
def smith_g(wi, wo, m, alpha) -> torch.Tensor:
    r"""Separable Smith shadowing–masking :math:`G(\mathbf i,\mathbf o,\mathbf m) = G_1(\mathbf i,\mathbf m)\,G_1(\mathbf o,\mathbf m)`
    (Fourneau et al. 2024 eq. 19, with its χ⁺ factors), on vectors.

    .. math::

        G_1(\mathbf v,\mathbf m) = \chi^+\!\Bigl(\frac{\mathbf v\cdot\mathbf m}{\mathbf v\cdot\mathbf n}\Bigr)
            \frac{2}{1+\sqrt{1+\alpha^2\tan^2\theta_v}}

    The χ⁺ test is evaluated as ``(v·m)(v·n) > 0`` (no division), so directions below the
    surface are allowed: e.g. the ballistic transmission of eq. 22 uses ``G(i, -i, m)``.

    Args:
        wi, wo: unit directions in the local frame (normal n = +z), shape ``(*, 3)``.
        m: unit microfacet normal, shape ``(*, 3)``.
        alpha: GGX roughness > 0, shape broadcasting with ``(*)``.

    Returns:
        ``G ∈ [0, 1]``, shape ``(*)``; 0 at grazing (``v·n = 0``) and where a χ⁺ fails.

    >>> n = torch.tensor([0.0, 0.0, 1.0])
    >>> v = torch.tensor([0.8660254037844386, 0.0, 0.5], dtype=torch.float64)
    >>> round(float(smith_g(v, n, n, 0.5)), 6)  # = G1(cos 60°) · G1(1)
    0.861002
    """
    i, o, mm, a = wi, wo, m, alpha
    ci, co = i[..., 2], o[..., 2]
    # χ⁺((v·m)/(v·n)) tested as (v·m)(v·n) > 0, without dividing by v·n; NaN propagates
    im, om = (i * mm).sum(-1), (o * mm).sum(-1)
    masked = (im * ci <= 0) | (om * co <= 0)
    g = smith_g1_kernel(ci.abs(), a) * smith_g1_kernel(co.abs(), a)
    g = torch.where(masked, torch.zeros_like(g), g)
    return torch.where(torch.isnan(im + om), torch.nan, g)  # (G₁ does not see m: its NaN goes by the mask)
