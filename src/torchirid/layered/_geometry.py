"""Shared inputs and coating geometry of the layered models (single-reflection BRDF, Monte Carlo)."""

from __future__ import annotations

import torch

from .. import _checks
from ..optics.fresnel import fresnel_reflectance


def directions(w, name: str, dtype, device, *, grazing: bool) -> torch.Tensor:
    """``w`` as unit vectors ``(*, 3)`` above the surface (z = normal), renormalised.

    ValueError naming ``name`` unless the last axis is 3, every norm is 1 within 1e-3 and
    ``z > 0`` (``z >= 0`` when ``grazing`` is allowed)."""
    t = _checks.as_real(w, name, dtype, device)
    if t.dim() == 0 or t.shape[-1] != 3:
        raise ValueError(f"{name} must have shape (*, 3) (unit vectors, z = surface normal); got {tuple(t.shape)}")
    with torch.no_grad():
        below = (t[..., 2] < 0) if grazing else (t[..., 2] <= 0)
        if bool(below.any()):
            bound = ">= 0" if grazing else "> 0"
            raise ValueError(f"{name} must point into the upper hemisphere ({name}[..., 2] {bound})")
        norm = torch.linalg.vector_norm(t, dim=-1)
        if bool(((norm - 1).abs() > 1e-3).any()):
            raise ValueError(f"{name} must hold unit vectors (|{name}| = 1 within 1e-3)")
    return t / torch.linalg.vector_norm(t, dim=-1, keepdim=True)


def wavelengths(wavelength, dtype, device) -> torch.Tensor:
    """``wavelength`` as a non-empty 1-D tensor (W,) of positive, finite values in nm.

    The wavelengths of the layered models are one spectral grid shared by every sample (the
    τ/R tables are built on it, and multiplexed paths mix its entries), not a batch axis: a NaN
    there is refused with a ValueError instead of spreading to the whole grid."""
    lam = _checks.as_real(wavelength, "wavelength", dtype, device)
    if lam.dim() != 1 or lam.numel() == 0:
        raise ValueError(f"wavelength must be a non-empty 1-D tensor (W,) in nm; got shape {tuple(lam.shape)}")
    if not bool(torch.isfinite(lam).all()):
        raise ValueError("wavelength must be finite (one spectral grid shared by all samples); got "
                         f"{int((~torch.isfinite(lam)).sum())} non-finite value(s)")
    _checks.check_wavelength(lam)
    return lam


def refract_in(w: torch.Tensor, n1: float):
    """``w`` (*, 3) above a smooth air | ``n1`` coating → (direction in the host, exists?).

    Snell: the tangential part scales by ``1/n1``. For ``n1 < 1`` part of the outer
    hemisphere is totally reflected and has no host direction (``exists = False``, the
    direction is replaced by the normal)."""
    if n1 == 1.0:
        return w, torch.ones_like(w[..., 0], dtype=torch.bool)
    t = w[..., :2] / n1
    s2 = (t * t).sum(-1)
    ok = s2 < 1.0
    z = torch.sqrt((1.0 - s2).clamp_min(0.0))
    v = torch.cat([t, z.unsqueeze(-1)], -1)
    n = torch.zeros_like(v)
    n[..., 2] = 1.0
    return torch.where((s2 >= 1.0).unsqueeze(-1), n, v), ok  # (not ``ok``: a NaN w stays NaN)


def nan_rows(*vectors: torch.Tensor) -> torch.Tensor:
    """Mask (*) of the entries where any of the vectors ``(*, k)`` has a NaN component (their
    results are set to NaN: docs/conventions.md, NaN inputs propagate instead of being masked to 0)."""
    bad = None
    for v in vectors:
        b = torch.isnan(v).any(-1)
        bad = b if bad is None else bad | b
    return bad


def refract_out(w_in: torch.Tensor, n1: float):
    """Host direction ``w_in`` (z > 0) leaving through the coating → (outer direction, exits?);
    beyond the critical angle (total internal reflection) it does not exit."""
    if n1 == 1.0:
        return w_in, torch.ones_like(w_in[..., 0], dtype=torch.bool)
    t = w_in[..., :2] * n1
    s2 = (t * t).sum(-1)
    exits = s2 < 1.0
    z = torch.sqrt((1.0 - s2).clamp_min(0.0))
    return torch.cat([t, z.unsqueeze(-1)], dim=-1), exits


def coating_transmittance(cos_outer: torch.Tensor, n1: float) -> torch.Tensor:
    """Unpolarized Fresnel transmittance of the coating seen from the air, ``1 − F(θ, 1 → n1)``."""
    if n1 == 1.0:
        return torch.ones_like(cos_outer)
    return 1.0 - fresnel_reflectance(cos_outer.clamp(0.0, 1.0), 1.0, n1)
