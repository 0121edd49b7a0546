r"""Karis' split-sum prefiltered BRDF table ("DFG"), GGX with importance sampling of visible normals.

Karis 2013 ("Real Shading in Unreal Engine 4") splits the image-based-lighting integral into
the prefiltered radiance and the BRDF integral under constant light; with Schlick's Fresnel
:math:`F = F_0 + (1 - F_0)(1 - v\cdot h)^5` the latter is linear in F0:

.. math:: \int f_{spec}(l, v)\,\cos θ_l\,dl = F_0\,A + B,\quad
          A = \int \frac{DG}{4\cosθ_v\cosθ_l}(1 - F_c)\cosθ_l\,dl,\quad
          B = \int \frac{DG}{4\cosθ_v\cosθ_l}F_c\cosθ_l\,dl,\quad F_c = (1 - v\cdot h)^5.

This is the first integral of Kneiphof et al. 2019 eq. 12 (their prefiltered BRDF). Sampling h
from the visible normals :math:`D_v(h) = G_1(v)\max(0, v\cdot h)D(h)/\cosθ_v` (Heitz 2018,
:func:`~torchirid.microfacet.sample_ggx_vndf`) and l = reflect(v, h) gives the pdf
:math:`D_v(h)/(4\,v\cdot h)`, so each sample weighs :math:`G(v, l)/G_1(v) = G_1(l)` for the
library's separable Smith G (:func:`~torchirid.microfacet.smith_g`), 0 where l is below the
surface. Samples: a 2-D Hammersley set (deterministic, so the table is reproducible).
"""

from __future__ import annotations

import importlib.resources

import torch

from .. import _autograd, _checks
from ..lut import LUT
from ..microfacet.ggx import reflect_kernel, sample_ggx_vndf, smith_g1
from .._cache import cached

__all__ = ["dfg_lut", "shipped_dfg_lut"]

DFG_BUILDER = "torchirid.ibl.dfg:dfg_lut"
_COS_MIN = 1e-4  # the cos θo = 0 node is evaluated here (VNDF sampling needs a view above the horizon)
_ALPHA_MIN = 1e-3  # the α = 0 node is evaluated here (GGX needs α > 0; a mirror to ~1e-6)
#: parameters of the shipped table ``data/dfg/dfg_64.npz`` (built by ``luts/build_dfg.py``)
DFG_SHIPPED = {"resolution": 64, "samples": 4096}
_DFG_FILE = ("data", "dfg", "dfg_64.npz")


def _hammersley(n: int, dtype) -> torch.Tensor:
    i = torch.arange(n, dtype=torch.int64)
    rev = torch.zeros(n, dtype=torch.float64)
    bit, k = 0.5, i.clone()
    while bool((k > 0).any()):
        rev = rev + bit * (k & 1).to(torch.float64)
        k = k >> 1
        bit *= 0.5
    return torch.stack([(i.to(torch.float64) + 0.5) / n, rev], -1).to(dtype)


def dfg_lut(resolution: int = 32, *, samples: int = 1024, dtype: torch.dtype = torch.float64) -> LUT:
    r"""The split-sum table (A, B) over (cos θo, α): specular albedo under constant light = F0·A + B.

    Args:
        resolution: nodes per axis (≥ 2), uniform in cos θo ∈ [0, 1] and α ∈ [0, 1]
            (cos θo = 0 evaluated at 1e-4, α = 0 at 1e-3).
        samples: Hammersley samples per node (≥ 1).
        dtype: ``torch.float64`` or ``torch.float32``.

    Returns:
        :class:`~torchirid.lut.LUT` with axes ``"cos_theta_o"``, ``"alpha"`` and channels ``(2,)``
        = (scale A, bias B); CPU.

    Example:
        >>> lut = dfg_lut(8, samples=256)
        >>> ab = lut(cos_theta_o=torch.tensor(1.0, dtype=torch.float64), alpha=torch.tensor(0.0, dtype=torch.float64))
        >>> [round(v, 3) for v in ab.tolist()]  # a mirror at normal incidence: F = F0
        [1.0, 0.0]
    """
    for name, v, lo in (("resolution", resolution, 2), ("samples", samples, 1)):
        _checks.check_int(v, name, lo)
    if dtype not in (torch.float64, torch.float32):
        raise ValueError(f"dtype must be torch.float64 or torch.float32; got {dtype!r}")
    grid = torch.linspace(0.0, 1.0, resolution, dtype=dtype)
    c = grid.clamp_min(_COS_MIN)
    alpha = grid.clamp_min(_ALPHA_MIN)
    s = torch.sqrt((1.0 - c * c).clamp_min(0.0))
    v = torch.stack([s, torch.zeros_like(s), c], -1)[:, None, None, :]  # (C, 1, 1, 3)
    u = _hammersley(samples, dtype)  # (N, 2)
    a = alpha[None, :, None]  # (1, A, 1)
    m = sample_ggx_vndf(v, a, u)  # (C, A, N, 3)
    l = reflect_kernel(v, m)
    w = torch.where(l[..., 2] > 0, smith_g1(l[..., 2].clamp_min(0.0), a), torch.zeros_like(l[..., 2]))
    fc = (1.0 - (v * m).sum(-1).clamp(0.0, 1.0)) ** 5
    values = torch.stack([((1.0 - fc) * w).mean(-1), (fc * w).mean(-1)], -1)  # (C, A, 2)
    return LUT(values, {"cos_theta_o": grid, "alpha": grid.clone()}, builder=DFG_BUILDER,
               parameters={"resolution": resolution, "samples": samples, "sampling": "ggx vndf, hammersley",
                           "masking": "separable smith", "cos_min": _COS_MIN, "alpha_min": _ALPHA_MIN},
               units={"cos_theta_o": "1", "alpha": "1", "values": "1 (scale, bias of F0)"})


@cached(maxsize=None)
@_autograd.normal_tensors  # (a first call in inference mode must not cache inference tensors)
def _shipped(dtype, device) -> LUT:
    path = importlib.resources.files("torchirid").joinpath(*_DFG_FILE)
    with importlib.resources.as_file(path) as p:
        if p.exists():
            lut = LUT.read(p, builder=DFG_BUILDER)
            if {k: lut.parameters.get(k) for k in DFG_SHIPPED} != DFG_SHIPPED:
                raise ValueError(f"{p}: not the shipped DFG table ({lut.parameters})")
        else:  # a source tree without the data file: build it (≈ 2 s)
            lut = dfg_lut(**DFG_SHIPPED)
    return lut.to(dtype=dtype, device=device)


def shipped_dfg_lut(*, dtype: torch.dtype = torch.float64, device=None) -> LUT:
    """The shipped split-sum table (64 × 64 nodes, 4096 samples each; float32 on disk), cached.

    Example:
        >>> lut = shipped_dfg_lut()
        >>> [round(v, 3) for v in lut(cos_theta_o=torch.tensor(1.0, dtype=torch.float64),
        ...                          alpha=torch.tensor(0.0, dtype=torch.float64)).tolist()]
        [1.0, 0.0]
    """
    return _shipped(dtype, torch.device("cpu") if device is None else torch.device(device))
