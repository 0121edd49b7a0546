r"""The per-layer tables of the single-reflection model (Fourneau et al. 2024 §4.3): each rough
Bragg layer's Yeh reflectance over the angle (:func:`reflectance_lut`, the paper's "Model-LUT")
and its integrated transmissivity τ(θ) (eq. 28), built once per call; the directions refracted
into the host and the coating's Fresnel reflectance."""

from __future__ import annotations

import math

import torch

from .. import _checks
from . import _geometry
from ..lut import LUT
from ..optics.fresnel import fresnel_reflectance
from .structure import RoughBraggLayer
from .transmission import transmissivity_lut

__all__ = ["reflectance_lut"]

#: default angular resolution of the per-call 1-D transmissivity tables (uniform in θ)
TRANSMISSIVITY_ANGLES = 361
#: default angular resolution of :func:`reflectance_lut`
REFLECTANCE_ANGLES = 1441




# ----------------------------------------------------------------------------------------
# inputs
# ----------------------------------------------------------------------------------------
_check_structure = _geometry.as_structure


# ----------------------------------------------------------------------------------------
# geometry
# ----------------------------------------------------------------------------------------
def refract_into_host(w: torch.Tensor, n_incident: float) -> torch.Tensor:
    """Direction ``w`` (*, 3) above a smooth air | ``n_incident`` interface, refracted into the host.

    Snell: the tangential part scales by ``1/n_incident``; ``z' = sqrt(1 − |t|²/n²)``. For
    ``n_incident = 1`` the input is returned unchanged (for ``n_incident < 1``, directions beyond
    the critical angle have no host direction and become the normal; their coating
    transmittance is 0).
    """
    return _geometry.refract_in(w, n_incident)[0]


coating_transmittance = _geometry.coating_transmittance


@_checks.arguments(cos_theta=_checks.COSINE)
def coating_reflectance(cos_theta, n_incident) -> torch.Tensor:
    """The coating's specular reflectance ``F`` (unpolarized), i.e. the weight of the Dirac
    delta :math:`f_{r,0}` of eq. 34 in the mirror direction (0 when ``n_incident = 1``).

    Example (a coating of index 1.5: 4 % at normal incidence):
        >>> import torch
        >>> F = coating_reflectance(torch.tensor([1.0, 0.5], dtype=torch.float64), 1.5)  # cos θ in air
        >>> [round(v, 4) for v in F.tolist()]
        [0.04, 0.0892]
        >>> float(coating_reflectance(torch.tensor(1.0, dtype=torch.float64), 1.0))  # no coating
        0.0
    """
    c = cos_theta
    if float(n_incident) == 1.0:
        return torch.zeros_like(c)
    return fresnel_reflectance.__wrapped__(c, torch.ones_like(c), torch.full_like(c, float(n_incident)))


# ----------------------------------------------------------------------------------------
# tables
# ----------------------------------------------------------------------------------------
@_checks.arguments(layer=_geometry.LAYER, angles=_checks.integer(2), wavelength=_geometry.WAVELENGTHS)
def reflectance_lut(wavelength, layer: RoughBraggLayer, *, angles: int = REFLECTANCE_ANGLES) -> LUT:
    """The layer's unpolarized Yeh reflectance tabulated over the angle in the host (the "LUT"
    variant of the model, Fourneau et al. 2024 §5 / Table 2 "Model-LUT").

    Axis ``theta`` (radians, uniform on [0, π/2], ``angles`` nodes); the wavelengths are the
    channel axis, so ``lut.interp(theta)`` returns ``(*, W)``.

    Example:
        >>> import torch
        >>> from torchirid.layered import RoughBraggLayer
        >>> layer = RoughBraggLayer(n1=1.0, n2=1.5, d1=125.0, d2=375.0, cells=20, alpha=0.1)  # nm
        >>> lam = torch.tensor([500.0, 600.0], dtype=torch.float64)  # nm
        >>> lut = reflectance_lut(lam, layer, angles=91)  # a node every 1°
        >>> lut.values.shape  # (angles, W)
        torch.Size([91, 2])
        >>> theta = torch.tensor([0.0, 0.3], dtype=torch.float64)  # radians, in the host
        >>> lut.interp(theta).shape
        torch.Size([2, 2])
        >>> torch.allclose(lut.interp(theta)[0], layer.reflectance(lam, torch.tensor(1.0, dtype=torch.float64)))
        True
    """
    lam = wavelength
    dtype, device = lam.dtype, lam.device
    theta = torch.linspace(0.0, math.pi / 2, angles, dtype=dtype, device=device)
    cos = torch.cos(theta).clamp(0.0, 1.0)
    R = layer._reflectance_kernel(lam, cos.unsqueeze(-1))  # (angles, W)
    return LUT(
        R,
        {"theta": theta},
        builder="torchirid.layered.single_reflection.reflectance_lut",
        parameters={
            **{k: (str(v) if isinstance(v, complex) else v) for k, v in layer.numbers().items()},
            "angles": angles, "wavelength_nm": [float(x) for x in lam.tolist()],
        },
        units={"theta": "rad", "values": "reflectance (unpolarized), channels = wavelengths"},
    )


class _LayerTables:
    """Per-call 1-D tables of one layer at the call's wavelengths (checked by the public function
    that builds them, as the table sizes): τ(θ) when first needed (a last layer over a black base
    never needs it), R(θ) when asked; ``alpha``: the layer's α as a tensor of the call's dtype."""

    def __init__(self, layer, lam, transmissivity_angles, reflectance_angles, use_reflectance_lut):
        self.layer = layer
        self.lam = lam
        self.alpha = _geometry.layer_alpha(layer, lam.dtype, lam.device)
        self._angles = transmissivity_angles
        self._tau = None
        self.R = reflectance_lut.__wrapped__(lam, layer, angles=reflectance_angles) if use_reflectance_lut else None

    @property
    def tau(self):
        if self._tau is None:
            self._tau = transmissivity_lut.__wrapped__(self.lam, self.layer, angles=self._angles)
        return self._tau

    def transmissivity(self, cos_theta: torch.Tensor) -> torch.Tensor:
        return self.tau(cos_theta)

    def reflectance(self, cos_theta: torch.Tensor) -> torch.Tensor:
        if self.R is not None:
            return self.R.interp(torch.acos(cos_theta.clamp(-1.0, 1.0)))
        return self.layer._reflectance_kernel(self.lam, cos_theta.unsqueeze(-1))


#: how a mirror's reflectance is evaluated (``reflectance=``): Yeh's closed form, or its angle table
REFLECTANCE_MODES = ("exact", "lut")


def _tables(structure, lam, transmissivity_angles, reflectance_angles, use_lut):
    return [_LayerTables(layer, lam, transmissivity_angles, reflectance_angles, use_lut) for layer in structure.layers]

def _half_vector(wi_h: torch.Tensor, wo_h: torch.Tensor) -> torch.Tensor:
    """Unit half vector of two host directions (a zero sum — exact backscatter at grazing — stays 0)."""
    h = wi_h + wo_h
    return h / torch.linalg.vector_norm(h, dim=-1, keepdim=True).clamp_min(torch.finfo(h.dtype).tiny)

