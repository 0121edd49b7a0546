"""Shared inputs and coating geometry of the layered models (single-reflection BRDF, Monte Carlo)."""

from __future__ import annotations

import torch

from .. import _checks
from ..optics.fresnel import fresnel_reflectance
from .structure import LayeredBragg, RoughBraggLayer


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


def as_structure(structure, name: str = "structure", dtype=None, device=None) -> LayeredBragg:
    """``structure`` as a :class:`LayeredBragg` (one :class:`RoughBraggLayer` becomes a stack of
    one over a black base); ValueError naming ``name`` for anything else."""
    if isinstance(structure, RoughBraggLayer):
        return LayeredBragg([structure])
    if not isinstance(structure, LayeredBragg):
        raise ValueError(f"{name} must be a LayeredBragg (or one RoughBraggLayer); got {type(structure).__name__}")
    return structure


# the argument specs of the layered models (``_checks.arguments``)
#: a LayeredBragg, or one RoughBraggLayer (over a black base), converted to a LayeredBragg
STRUCTURE = _checks.Arg(as_structure)
#: one rough Bragg layer
LAYER = _checks.instance(RoughBraggLayer)
#: unit directions ``(*, 3)`` strictly above the surface (z > 0), renormalised
DIRECTIONS = _checks.Arg(lambda w, name, dtype, device: directions(w, name, dtype, device, grazing=False),
                         tensor=True)
#: unit directions ``(*, 3)`` above the surface, grazing (z = 0) allowed, renormalised
GRAZING_DIRECTIONS = _checks.Arg(lambda w, name, dtype, device: directions(w, name, dtype, device, grazing=True),
                                 tensor=True)
#: the spectral grid ``(W,)`` of a call: non-empty, 1-D, finite wavelengths in nm
WAVELENGTHS = _checks.Arg(lambda w, name, dtype, device: wavelengths(w, dtype, device), tensor=True)
#: GGX roughness, > 0
ALPHA = _checks.positive("(GGX roughness)")


def unit(w: torch.Tensor) -> torch.Tensor:
    """``w / |w|`` on the last axis: the renormalisation :data:`DIRECTIONS` applies, for an internal
    caller that hands its own unit directions to a public function's body."""
    return w / torch.linalg.vector_norm(w, dim=-1, keepdim=True)


def layer_alpha(layer: RoughBraggLayer, dtype, device) -> torch.Tensor:
    """The layer's GGX roughness (checked at construction) as a tensor of the call's ``dtype``,
    converted once per call for the GGX kernels and bodies (as their argument check would)."""
    return _checks.as_real(layer.alpha, "alpha", dtype, device)


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


def fresnel(cos_theta: torch.Tensor, n_incident, n_substrate) -> torch.Tensor:
    """Unpolarized Fresnel reflectance ``F(θ, n_incident → n_substrate)`` at the cosines
    ``cos_theta`` (a tensor in [0, 1]): the body of
    :func:`~torchirid.optics.fresnel.fresnel_reflectance` on its arguments converted as its check
    would (float64 when any of them is; the indices: numbers or a layer's 0-dim tensors, checked
    at construction), without checking them again per call."""
    wide = (torch.float64, torch.complex128)
    double = any(isinstance(x, torch.Tensor) and x.dtype in wide for x in (cos_theta, n_incident, n_substrate))
    dtype, device = (torch.float64 if double else torch.float32), cos_theta.device
    return fresnel_reflectance.__wrapped__(_checks.as_real(cos_theta, "cos_theta", dtype, device),
                                           _checks.as_index(n_incident, "n_incident", dtype, device),
                                           _checks.as_index(n_substrate, "n_substrate", dtype, device))


def coating_transmittance(cos_outer: torch.Tensor, n1: float) -> torch.Tensor:
    """Unpolarized Fresnel transmittance of the coating seen from the air, ``1 − F(θ, 1 → n1)``."""
    if n1 == 1.0:
        return torch.ones_like(cos_outer)
    return 1.0 - fresnel(cos_outer.clamp(0.0, 1.0), 1.0, n1)
