r"""Integrated transmissivity of a rough Bragg layer and the transmission sampling weights
(Fourneau et al. 2024 §4.2.2–4.2.3, eq. 28 and 30–33).

* :func:`integrated_transmissivity` — :math:`\tau(\theta_i) = f_t(\theta_i)\cos\theta_i =
  \int_0^{\pi/2} T_\lambda(\theta_d) F_\alpha(\theta_i,\theta_d)\,d\theta_d` (eq. 28) with
  :math:`T_\lambda = 1 - R_\lambda` of the layer's Bragg mirror, by the Gauss–Legendre rule of
  :func:`~torchirid.layered.filter.filter_quadrature` (weights ∝ F_α, normalised to G1).
* :func:`transmissivity_lut` — the paper's "1-D table per layer": τ over the incidence angle,
  one channel per wavelength (a :class:`torchirid.lut.LUT`).
* :func:`absorption` — :math:`A = 1 - G_1(\theta_i)` (eq. 30, Appendix C).
* :func:`transmission_probability` — :math:`p_\mathrm{trans} = 2\tau/(1+G_1)` (eq. 31),
  multiplexed: τ replaced by its mean over wavelengths.
* :func:`transmission_weight` — :math:`(1+G_1)/2` (eq. 32), multiplexed
  :math:`\frac{1+G_1}{2}\,\tau/\langle\tau\rangle_\lambda` (eq. 33); always
  ``weight × p_trans = τ``.

Shapes: τ carries wavelength on its **last** axis ``(*, W)``. In the probability and weight
functions ``cos_theta`` and ``alpha`` describe the batch ``*`` only (no wavelength axis):
they broadcast with ``tau.shape[:-1]``.
"""

from __future__ import annotations

import math

import torch

from .. import _autograd, _checks, _chunks
from . import _geometry
from ..lut import LUT
from .filter import _hat_weights, _normal_cap, _quadrature, _quadrature_cos
from .structure import RoughBraggLayer
from .._cache import cached

__all__ = [
    "integrated_transmissivity",
    "transmissivity_lut",
]

#: default Gauss–Legendre nodes per incidence angle for eq. 28 (see integrated_transmissivity)
DEFAULT_NODES = 256
#: default number of incidence angles of :func:`transmissivity_lut` (0.25° steps, as the paper)
DEFAULT_ANGLES = 361
#: default number of θd cells of the product integration in :func:`transmissivity_lut`
DEFAULT_THETA_D_CELLS = 4096

_LUT_BUILDER = "torchirid.layered.transmission.transmissivity_lut"


def _g1(c: torch.Tensor, alpha) -> torch.Tensor:
    """Smith G1 (eq. 19) for cos θ ∈ [0, 1] (no validation)."""
    a2 = alpha * alpha
    return 2.0 * c / (c + torch.sqrt(c * c + a2 * (1.0 - c * c)))


def _tau_rule(layer, theta_d, weight, lam):
    cos_d = torch.cos(theta_d).clamp(0.0, 1.0)
    t = 1.0 - layer._reflectance_kernel(lam.unsqueeze(-1), cos_d)  # (S, K)
    return (weight * t).sum(-1)


def _tau(layer: RoughBraggLayer, c: torch.Tensor, lam: torch.Tensor, nodes: int) -> torch.Tensor:
    """τ for cos θ ``c`` (S1) and wavelengths ``lam`` (S2) → broadcast (S).

    Near normal incidence the gradient is that of the rule at ``cos θmin`` (see
    ``torchirid.layered.filter._quadrature_cos``) and the value is recomputed at the exact
    cosine (a second, gradient-free pass, only when such lanes exist).
    """
    a = torch.full_like(c, layer.numbers()["alpha"])
    tau = _tau_rule(layer, *_quadrature_cos(c, a, nodes, True), lam)
    near = c > _normal_cap(c, a)
    with torch.no_grad():
        if not bool(near.any()):
            return tau
        exact = _tau_rule(layer, *_quadrature(torch.acos(c), a, nodes, True, c), lam)
    return torch.where(near, tau + (exact - tau).detach(), tau)


@_checks.arguments(layer=_geometry.LAYER, nodes=_checks.integer(2), cos_theta=_checks.COSINE,
                   wavelength=_checks.WAVELENGTH, broadcast=("cos_theta", "wavelength"))
def integrated_transmissivity(wavelength, cos_theta, layer, *, nodes: int = DEFAULT_NODES) -> torch.Tensor:
    r"""Integrated transmissivity :math:`\tau = f_t(\theta_i)\cos\theta_i` of a rough Bragg layer
    (Fourneau et al. 2024 eq. 28), the weight of a ballistic transmission.

    .. math:: \tau(\theta_i) = \int_0^{\pi/2} \bigl(1 - R_\lambda(\theta_d)\bigr)\,F_\alpha(\theta_i,\theta_d)\,d\theta_d

    Args:
        layer: a :class:`~torchirid.layered.structure.RoughBraggLayer` (its Bragg mirror gives
            ``R_λ``, unpolarized; its ``alpha`` the filter).
        cos_theta: cosine of the incidence angle in the host medium, in [0, 1].
        wavelength: wavelengths in nm (> 0), broadcasting with ``cos_theta`` — e.g.
            ``cos_theta`` ``(*, 1)`` with ``wavelength`` ``(W,)`` gives ``(*, W)``.
        nodes: Gauss–Legendre nodes per incidence angle (``filter_quadrature()``). The
            weights are positive and sum to G1 exactly, so ``0 ≤ τ ≤ G1`` and ``τ = G1`` when
            ``R = 0``. The error is that of resolving the fringes and band edges of
            ``R(θd)`` under the filter. Measured max |Δτ| (n = 1 | 1.5, d = 110 | 75 nm,
            α ∈ {0.025, 0.1, 0.4}, θi ∈ {0, 20, 45, 70, 85}°, 400–700 nm):

            ======  ========  ========  ========  ========
            cells   K = 128   K = 256   K = 512   K = 1024
            ======  ========  ========  ========  ========
            10      1.8e-3    4.7e-4    6.1e-6    1.3e-7
            50      2.4e-2    6.0e-3    3.0e-3    1.2e-3
            200     6.2e-2    2.3e-2    9.5e-3    2.9e-3
            1000    6.0e-2    7.8e-2    2.1e-2    1.3e-2
            ======  ========  ========  ========  ========

            (roughly ``K ≳ 10 × cells`` for 1e-3). For long stacks or many angles prefer
            :func:`transmissivity_lut` (product integration: 4e-4 for 200 cells at its default).

    Returns:
        τ, broadcast shape of ``cos_theta`` and ``wavelength``; differentiable with respect
        to ``cos_theta`` (finite at 0 and 1). ``τ = 0`` at grazing (G1 = 0).

    >>> import torch
    >>> from torchirid.layered import RoughBraggLayer
    >>> layer = RoughBraggLayer(1.0, 1.5, 100.0, 80.0, 10, 0.1)
    >>> tau = integrated_transmissivity(torch.tensor([450.0, 550.0], dtype=torch.float64),
    ...                                 torch.tensor([[1.0], [0.5]], dtype=torch.float64), layer)
    >>> tau.shape
    torch.Size([2, 2])
    """
    c, lam = cos_theta, wavelength
    # block by block over large batches (torchirid._chunks): ``nodes`` reflectances per point
    return _chunks.evaluate(_tau_block, (c, lam), _checks.broadcast_shapes(c.shape, lam.shape), width=nodes,
                            grad_inputs=layer.tensors(), layer=layer, nodes=nodes)


def _tau_block(c, lam, *, layer, nodes):
    return _tau(layer, c, lam, nodes)


#: step of the extra grazing nodes ``cos θ = α sinh(s)`` of :func:`transmissivity_lut`
_GRAZING_STEP = 0.025


def _lut_cosines(alpha: float, angles: int, dtype, device) -> torch.Tensor:
    """Increasing cosines: ``angles`` nodes uniform in θ, plus nodes ``α sinh(k·0.025)`` below
    ``cos θ = 4α`` — near grazing τ ∝ G1 bends on the scale ``cos θ ~ α`` (G1'' ≈ −4/α² at 0),
    which 0.25° steps would interpolate to ~1e-2 for α = 0.025 (measured); with them, ~1e-4."""
    theta = torch.linspace(0.0, math.pi / 2, angles, dtype=torch.float64)
    cos = torch.cos(theta)
    cos[-1] = 0.0  # exactly 0 at grazing
    top = min(4.0 * alpha, 1.0)
    s = torch.arange(1, int(math.asinh(top / alpha) / _GRAZING_STEP) + 1, dtype=torch.float64) * _GRAZING_STEP
    cos = torch.cat([cos, alpha * torch.sinh(s)]).clamp(0.0, 1.0)
    cos = torch.unique(cos)  # sorted increasing
    keep = torch.cat([torch.tensor([True]), (cos[1:] - cos[:-1]) > 1e-9])
    cos = cos[keep]
    return cos.to(dtype=dtype, device=device)


@cached(maxsize=8)
@_autograd.normal_tensors  # (a first call in inference mode must not cache inference tensors)
def _lut_weights(alpha: float, angles: int, cells: int, dtype: torch.dtype, device: str):
    """(cos nodes increasing, θd grid, product weights (nodes, cells + 1)); layer-independent, cached."""
    cos = _lut_cosines(alpha, angles, dtype, device)
    # The weights are evaluated in float32 (≈4× faster: this is the one-off cost per roughness)
    # and renormalised in the table's dtype so that each row sums to G1 exactly; they then
    # differ from float64 weights by ≤ 1.2e-5 in relative L1 per row (measured, α = 0.05).
    c32 = cos.to(torch.float32)
    weights = _hat_weights(torch.acos(c32), torch.tensor(float(alpha), dtype=torch.float32, device=device), cells,
                           cos_i=c32).to(dtype)
    a2 = float(alpha) ** 2
    g1 = 2.0 * cos / (cos + torch.sqrt(cos * cos + a2 * (1.0 - cos * cos)))
    total = weights.sum(-1)
    ok = total > 0
    weights = weights * torch.where(ok, g1 / torch.where(ok, total, torch.ones_like(total)), torch.ones_like(total)).unsqueeze(-1)
    grid = torch.linspace(0.0, math.pi / 2, cells + 1, dtype=dtype, device=device)
    return cos, grid, weights


@_checks.arguments(layer=_geometry.LAYER, angles=_checks.integer(2), theta_d_cells=_checks.integer(2),
                   wavelength=_geometry.WAVELENGTHS)
def transmissivity_lut(wavelength, layer, *, angles: int = DEFAULT_ANGLES,
                       theta_d_cells: int = DEFAULT_THETA_D_CELLS) -> LUT:
    r"""The integrated transmissivity of eq. 28 tabulated over the incidence angle — the paper's
    "1-D table per layer" (§4.2.2) — with one channel per wavelength.

    Computed by product integration: ``T = 1 − R`` is sampled once on a uniform θd grid of
    ``theta_d_cells`` cells and integrated piecewise-linearly against F_α,
    :math:`\tau_r = \sum_j W_{rj} T(\theta_j)` with :math:`W_{rj} = \int F_\alpha(\theta_{i,r},\cdot)\,\phi_j`
    (hat functions; the weights depend on α only and are cached). The error is that of
    linear interpolation of ``T`` between θd nodes — no quadrature error over the fringes of
    ``R``. Measured against a converged reference (Bragg n = 1 | 1.5, d = 110 | 75 nm,
    α ∈ {0.025, 0.1, 0.4}, 400–700 nm) with the default 4096 cells: max |Δτ| ≤ 3e-6 for
    10 cells, 3e-5 for 50, 4e-4 for 200, 2e-3 for 1000 (error ∝ cells⁻²: raise
    ``theta_d_cells`` for long stacks).

    Args:
        layer: a :class:`~torchirid.layered.structure.RoughBraggLayer`.
        wavelength: ``(W,)`` wavelengths in nm (> 0).
        angles: number of incidence angles uniform in θ on [0, π/2] (361: 0.25° steps, the
            paper's resolution); the table adds ~80 nodes ``cos θ = α sinh(0.025 k) < 4α``
            near grazing, where τ ∝ G1 bends on the scale ``cos θ ~ α``.
        theta_d_cells: cells of the uniform θd grid on which ``R`` is sampled.

    Returns:
        a :class:`~torchirid.lut.LUT` with one axis ``cos_theta`` (the nodes' cosines,
        increasing, from exactly 0 to 1) and ``W`` channels: ``lut(cos_theta)`` of shape
        ``(*)`` interpolates to ``(*, W)`` (batched, differentiable). Saved and loaded through
        the LUT container (builder ``torchirid.layered.transmission.transmissivity_lut``,
        parameters: the layer, ``angles``, ``theta_d_cells``, the wavelengths). Values obey
        ``0 ≤ τ ≤ G1`` (positive weights summing to G1).

    >>> import torch
    >>> from torchirid.layered import RoughBraggLayer
    >>> layer = RoughBraggLayer(1.0, 1.5, 100.0, 80.0, 10, 0.1)
    >>> lut = transmissivity_lut(torch.tensor([450.0, 550.0], dtype=torch.float64), layer)
    >>> lut(torch.tensor([0.3, 0.9], dtype=torch.float64)).shape
    torch.Size([2, 2])
    """
    lam = wavelength  # (W,), finite (the table's metadata stores it)
    dtype, device = lam.dtype, lam.device
    plain = layer.numbers()  # tensor parameters (fitting) → numbers for the weights' cache and the metadata
    cos, grid, weights = _lut_weights(plain["alpha"], angles, theta_d_cells, dtype, str(device))
    t = 1.0 - layer._reflectance_kernel(lam, torch.cos(grid).clamp(0.0, 1.0).unsqueeze(-1))  # (cells + 1, W)
    values = weights @ t  # (angles, W)
    return LUT(
        values,
        {"cos_theta": cos},
        builder=_LUT_BUILDER,
        parameters={
            "n1": plain["n1"], "n2": str(plain["n2"]), "d1": plain["d1"], "d2": plain["d2"], "cells": layer.cells,
            "alpha": plain["alpha"], "angles": angles, "theta_d_cells": theta_d_cells,
            "wavelength_nm": [float(x) for x in lam.tolist()],
        },
        units={"cos_theta": "1", "values": "1 (tau = f_t cos theta), channels = wavelengths"},
    )


@_checks.arguments(cos_theta=_checks.COSINE, alpha=_geometry.ALPHA)
def absorption(cos_theta, alpha) -> torch.Tensor:
    r"""Absorption of a rough Bragg layer :math:`A = 1 - G_1(\theta_i)` (eq. 30): the energy the
    single-scattering microfacet model loses (Appendix C: :math:`\int F_\alpha = G_1`).

    Args:
        cos_theta: cosine of the incidence angle, in [0, 1].
        alpha: GGX roughness > 0.

    Returns:
        ``A ∈ [0, 1]`` broadcast over the inputs (0 at normal incidence, 1 at grazing).

    >>> round(float(absorption(torch.tensor(0.5, dtype=torch.float64), 0.1)), 9)
    0.007389566
    """
    return 1.0 - _g1(cos_theta, alpha)


def _as_tau(tau, name, dtype, device) -> torch.Tensor:
    t = _checks.as_real(tau, name, dtype, device)
    if t.dim() == 0:
        raise ValueError(f"{name} must have a last (wavelength) axis (*, W); got a scalar")
    if t.shape[-1] < 1:
        raise ValueError(f"{name} must have at least one wavelength on its last axis")
    return t


def _check_tau(t, name) -> None:
    with torch.no_grad():
        if bool((t < 0).any()):
            raise ValueError(f"{name} must be >= 0 (a transmissivity); got min {t.min().item():g}")


#: an integrated transmissivity ``(*, W)`` (wavelengths on the last axis), ≥ 0
TAU = _checks.Arg(_as_tau, _check_tau, values=True, tensor=True)


def _batch(t: torch.Tensor, c: torch.Tensor, a: torch.Tensor):
    """``cos_theta`` and ``alpha`` against τ's batch shape ``tau.shape[:-1]`` (ValueError naming
    them), each given a trailing axis of size 1 (the wavelengths)."""
    for name, x in (("cos_theta", c), ("alpha", a)):
        if x.dim() > t.dim() - 1:
            raise ValueError(
                f"{name} must broadcast with tau's batch shape tau.shape[:-1] = {tuple(t.shape[:-1])} "
                f"(no wavelength axis); got shape {tuple(x.shape)}"
            )
    try:
        _checks.broadcast_shapes(c.shape, a.shape, t.shape[:-1])
    except RuntimeError:
        raise ValueError(
            f"cos_theta {tuple(c.shape)} and alpha {tuple(a.shape)} must broadcast with tau.shape[:-1] "
            f"= {tuple(t.shape[:-1])}"
        ) from None
    return c.unsqueeze(-1), a.unsqueeze(-1)


def probability_kernel(t: torch.Tensor, c: torch.Tensor, a: torch.Tensor, multiplexed: bool) -> torch.Tensor:
    """:func:`transmission_probability` on checked tensors of one dtype: τ ``(*, W)``, and the
    cosine and α with their trailing axis of size 1 (the transport's kernel, per event)."""
    num = t.mean(-1, keepdim=True) if multiplexed else t
    p = 2.0 * num / (1.0 + _g1(c, a))
    return torch.clamp(p, max=1.0)  # only rounding can exceed 1 when τ ≤ G1


def weight_kernel(t: torch.Tensor, c: torch.Tensor, a: torch.Tensor, multiplexed: bool) -> torch.Tensor:
    """:func:`transmission_weight` on checked tensors (as :func:`probability_kernel`)."""
    half = 0.5 * (1.0 + _g1(c, a))
    if not multiplexed:
        return half.expand(_checks.broadcast_shapes(half.shape, t.shape[:-1] + (1,)))
    mean = t.mean(-1, keepdim=True)
    zero = mean <= 0  # (not ``mean > 0``: a NaN τ stays NaN)
    ratio = torch.where(zero, torch.zeros_like(t), t / torch.where(zero, torch.ones_like(mean), mean))
    return half * ratio


_TAU_ARGS = {"tau": TAU, "cos_theta": _checks.COSINE, "alpha": _geometry.ALPHA, "multiplexed": _checks.FLAG}


@_checks.arguments(**_TAU_ARGS)
def transmission_probability(tau, cos_theta, alpha, *, multiplexed: bool = True) -> torch.Tensor:
    r"""Probability of sampling transmission through a rough Bragg layer (eq. 31):

    .. math:: p_\mathrm{trans} = \frac{\tau}{1 - A/2} = \frac{2\tau}{1 + G_1(\theta_i)}

    (half of the absorption A is charged to each of reflection and transmission).

    Args:
        tau: integrated transmissivity ``(*, W)`` (eq. 28), wavelengths on the last axis.
        cos_theta: cosine of the incidence angle in [0, 1], broadcasting with
            ``tau.shape[:-1]`` (no wavelength axis).
        alpha: GGX roughness > 0, broadcasting likewise.
        multiplexed: ``True`` (default): one probability for all wavelengths, τ replaced by
            its mean over the last axis (§4.2.3); ``False``: one per wavelength.

    Returns:
        ``(*, 1)`` when multiplexed (the wavelength axis kept, of size 1), else ``(*, W)``;
        in [0, 1] whenever ``0 ≤ τ ≤ G1`` (clamped to 1 against rounding).

    >>> tau = torch.tensor([[0.4, 0.6]], dtype=torch.float64)
    >>> transmission_probability(tau, torch.tensor([1.0], dtype=torch.float64), 0.1)
    tensor([[0.5000]], dtype=torch.float64)
    """
    return probability_kernel(tau, *_batch(tau, cos_theta, alpha), multiplexed)


@_checks.arguments(**_TAU_ARGS)
def transmission_weight(tau, cos_theta, alpha, *, multiplexed: bool = True) -> torch.Tensor:
    r"""Path weight after sampling transmission with :func:`transmission_probability`.

    Per wavelength (eq. 32): :math:`(1 + G_1)/2 = 1 - A/2`. Multiplexed (eq. 33):
    :math:`\frac{1+G_1}{2}\,\tau/\langle\tau\rangle_\lambda`, wavelength-dependent. In both
    cases ``weight × p_trans = τ`` (up to the clamp of ``p_trans`` at 1).

    Args:
        tau, cos_theta, alpha, multiplexed: as in :func:`transmission_probability`.

    Returns:
        ``(*, W)`` when multiplexed, ``(*, 1)`` otherwise. Where ``⟨τ⟩ = 0`` (transmission
        is never sampled) the multiplexed weight is 0.

    >>> tau = torch.tensor([[0.4, 0.6]], dtype=torch.float64)
    >>> transmission_weight(tau, torch.tensor([1.0], dtype=torch.float64), 0.1)
    tensor([[0.8000, 1.2000]], dtype=torch.float64)
    """
    return weight_kernel(tau, *_batch(tau, cos_theta, alpha), multiplexed)
