r"""Single-reflection BRDF of a layered rough Bragg structure (Fourneau et al. 2024 §4.3, eq. 34–35).

Only light paths that reflect **once** — on one of the ``L`` rough Bragg layers or on the
Lambertian base — are modelled; every other crossing of a layer is the ballistic
transmission of §4.2 (direction unchanged, weight :math:`\tau_k(\theta)=\int T_\lambda F_\alpha
\,d\theta_d`, eq. 28). For a pair of directions (i, o) above the surface:

.. math::

    f_r(\mathbf i,\mathbf o) = f_{r,0}(\mathbf i,\mathbf o) + \frac{T_c(\mathbf i)T_c(\mathbf o)}{n_1^2}
        \sum_{l=1}^{L+1} f_{r,l}(\mathbf i',\mathbf o')\prod_{k=1}^{l-1}\tau_k(\mathbf i')\tau_k(\mathbf o')
    \qquad (34)

with :math:`f_{r,l}` the microfacet BRDF of eq. 17 with the layer's Yeh reflectance
:math:`R_\lambda(\mathbf i'\cdot\mathbf h)` (``l ≤ L``), :math:`f_{r,L+1} = \rho_d/\pi` the base,
``i'``, ``o'`` the directions refracted into the host ``n1`` and :math:`T_c = 1 - F` the
coating's Fresnel transmittance (unpolarized). Without a coating (``n1 = 1``) ``T_c = 1``
and nothing is refracted. The coating's own reflection :math:`f_{r,0}` is a Dirac delta in
the mirror direction; it is returned separately by ``coating_reflectance()`` and is not
part of the tabulated BRDF (it has no value at a pair of directions).

``f_t,0(i) f_t,0(o) / n1²`` of eq. 34 is :math:`T_c(\mathbf i)T_c(\mathbf o)/n_1^2`: radiance
entering the host is compressed by ``n1²`` and the solid angles refract
(:math:`n^2\cos\theta\,d\omega` is invariant), so the outer BRDF is
:math:`T_c(i)\,T_c(o)\,f_\text{inner}(i', o')/n_1^2`.

The per-layer tables are in :mod:`torchirid.layered.tables`, the base's inter-reflection in
:mod:`torchirid.layered.base_interreflection`, the sampling of eq. 35 in
:mod:`torchirid.layered.importance_sampling`.
"""

from __future__ import annotations

import math

import torch

from .. import _checks, _chunks
from . import _geometry
from ..microfacet.ggx import ggx_d_kernel, smith_g1_kernel
from .structure import LayeredBragg

from .base_interreflection import _base_return
from .tables import (REFLECTANCE_ANGLES, REFLECTANCE_MODES, TRANSMISSIVITY_ANGLES, _half_vector, _tables,
                     refract_into_host)

__all__ = ["single_reflection_brdf"]


# ----------------------------------------------------------------------------------------
# evaluation (eq. 34)
# ----------------------------------------------------------------------------------------
@_checks.arguments(structure=_geometry.STRUCTURE, wi=_geometry.GRAZING_DIRECTIONS, wo=_geometry.GRAZING_DIRECTIONS,
                   wavelength=_geometry.WAVELENGTHS, base_interreflection=_checks.FLAG,
                   reflectance=_checks.choice(REFLECTANCE_MODES), transmissivity_angles=_checks.integer(2),
                   reflectance_angles=_checks.integer(2), broadcast=("wi", "wo"))
def single_reflection_brdf(
    wavelength,
    wi,
    wo,
    structure,
    *,
    reflectance: str = "exact",
    transmissivity_angles: int = TRANSMISSIVITY_ANGLES,
    reflectance_angles: int = REFLECTANCE_ANGLES,
    base_interreflection: bool = False,
) -> torch.Tensor:
    r"""Single-reflection BRDF :math:`f_r(\mathbf i, \mathbf o)` of eq. 34, in sr⁻¹, for whole
    batches of direction pairs and all wavelengths at once.

    Args:
        structure: a :class:`LayeredBragg` (or a single :class:`RoughBraggLayer`).
        wi, wo: incident (towards the light) and outgoing (towards the viewer) unit vectors
            ``(*, 3)`` in the surface frame (z = geometric normal, z ≥ 0), broadcasting
            together.
        wavelength: ``(W,)`` wavelengths in nm.
        reflectance: how each mirror's reflectance is evaluated: ``"exact"`` (default, Yeh's
            closed form at every half-vector angle) or ``"lut"`` (interpolated in a per-layer
            table over the angle, :func:`reflectance_lut` with ``reflectance_angles`` nodes — the
            paper's "Model-LUT").
        transmissivity_angles: nodes of the per-layer 1-D tables of the integrated
            transmissivity τ(θ) (eq. 28), uniform in θ, built once per call.
        base_interreflection: ``False`` (default) is eq. 34 as published. ``True`` sums the
            light that bounces between the Lambertian base and the layers (and the coating)
            above it: the base term becomes
            :math:`\frac{\rho_d}{\pi}\prod_k\tau_k(\mathbf i')\tau_k(\mathbf o')\,/\,(1-\rho_d R_d)`
            with the return fraction :math:`R_d(\lambda)` of ``base_return_fraction``
            (its docstring states what is exact: one layer without coating, and what is
            approximated). No effect when ``ρd = 0``.

    Returns:
        ``(*, W)`` BRDF values (the coating's specular delta excluded, see
        ``coating_reflectance()``). Differentiable with respect to ``wi``, ``wo``.

    Example:
        >>> import torch
        >>> from torchirid.layered import LayeredBragg, RoughBraggLayer
        >>> s = LayeredBragg([RoughBraggLayer(1.0, 1.5, 250.0, 250.0, 10, 0.1)])
        >>> w = torch.tensor([[0.0, 0.0, 1.0]], dtype=torch.float64)
        >>> f = single_reflection_brdf(torch.tensor([500.0, 600.0], dtype=torch.float64), w, w, s)
        >>> f.shape
        torch.Size([1, 2])
    """
    lam = wavelength
    wi, wo = torch.broadcast_tensors(wi, wo)
    tables = _tables(structure, lam, transmissivity_angles, reflectance_angles, reflectance == "lut")
    rd = None
    if base_interreflection and structure.base_albedo > 0:
        rd = _base_return(structure, tables, lam)
    # block by block over large batches of direction pairs (torchirid._chunks): W values per pair
    params = tuple(t for layer in structure.layers for t in layer.tensors())
    out = _chunks.evaluate(_evaluate_block, (wi, wo), wi.shape[:-1], core=(1, 1), out_core=1, width=lam.numel(),
                           grad_inputs=params + ((rd,) if rd is not None else ()), structure=structure,
                           tables=tables, base_return=rd)
    return torch.where(_geometry.nan_rows(wi, wo).unsqueeze(-1), torch.nan, out)


def _evaluate_block(wi, wo, *, structure, tables, base_return):
    return _evaluate(structure, tables, wi, wo, base_return)



def _evaluate(structure: LayeredBragg, tables, wi, wo, base_return=None) -> torch.Tensor:
    n = structure.n_coating
    ci, co = wi[..., 2], wo[..., 2]
    wi_h = refract_into_host(wi, n)
    wo_h = refract_into_host(wo, n)
    zi, zo = wi_h[..., 2], wo_h[..., 2]
    up = (zi > 0) & (zo > 0)
    # guard: grazing pairs have f_r·cos = 0; feed safe cosines so 1/(4 zi zo) stays finite
    zi_s = torch.where(up, zi, torch.ones_like(zi))
    zo_s = torch.where(up, zo, torch.ones_like(zo))
    h = _half_vector(wi_h, wo_h)
    cos_d = (wi_h * h).sum(-1).clamp(0.0, 1.0)
    cos_h = h[..., 2].clamp(-1.0, 1.0)

    total = None
    through = None  # Π τ_k(i') τ_k(o') over the layers above the current one
    for l, tab in enumerate(tables):
        a = tab.layer.alpha
        # α was validated by RoughBraggLayer: the unchecked kernels skip per-call checks (host syncs)
        shading = ggx_d_kernel(cos_h, a) * smith_g1_kernel(zi_s, a) * smith_g1_kernel(zo_s, a) / (4.0 * zi_s * zo_s)
        f_l = shading.unsqueeze(-1) * tab.reflectance(cos_d)
        if through is not None:
            f_l = f_l * through
        total = f_l if total is None else total + f_l
        if l == len(tables) - 1 and not structure.base_albedo > 0:
            break  # nothing below the last layer reflects: its τ is never needed
        tt = tab.transmissivity(zi) * tab.transmissivity(zo)
        through = tt if through is None else through * tt
    if structure.base_albedo > 0:
        base = (structure.base_albedo / math.pi) * through
        if base_return is not None:  # the base's radiosity series B = ρd E0 / (1 − ρd R_d)
            base = base / (1.0 - structure.base_albedo * base_return)
        total = total + base
    total = torch.where(up.unsqueeze(-1), total, torch.zeros_like(total))
    if structure.coated:
        coat = _geometry.coating_transmittance(ci, n) * _geometry.coating_transmittance(co, n) / (n * n)
        total = total * coat.unsqueeze(-1)
    return total


