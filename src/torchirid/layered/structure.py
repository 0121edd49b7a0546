r"""Description of a layered Bragg structure (Fourneau et al. 2024 §4.1, Fig. 2(e)).

From top to bottom: an optional smooth coating (present when the host index ``n1 ≠ 1``: a
flat interface air | n1), ``L`` *rough Bragg layers* — each a GGX distribution (roughness α)
of identical Bragg mirrors ``(n2, d2), (n1, d1)`` × ``cells`` embedded in the host ``n1`` —
and an optional Lambertian base of albedo ρd. The host medium is lossless and thick enough
that layers do not interfere; polarization is not tracked between layers (unpolarized
reflectance per layer).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import torch


from .. import _checks
from ..optics.bragg import bragg_reflectance, bragg_reflectance_kernel

__all__ = ["RoughBraggLayer", "LayeredBragg"]


@dataclass(frozen=True)
class RoughBraggLayer:
    """One rough Bragg layer: a GGX distribution (``alpha``) of Bragg mirrors.

    Attributes:
        n1: host (low) index, real > 0 — the medium around the mirrors.
        n2: second index of the cell, real > 0 (complex allowed: absorbing).
        d1, d2: thicknesses in nm (> 0).
        cells: number of (n2, n1) cells N ≥ 1.
        alpha: GGX roughness of the mirror orientations, > 0.
        n_incident: index of the medium the mirrors are lit from (the host around them), real
            > 0; ``None`` (default) is replaced by ``n1`` at construction (eq. 2–10). Otherwise each mirror is ``n_incident | (n2, d2), (n1, d1) × N | n1``
            with Fourneau's appendix D reflectance (e.g. the jewel-beetle cuticle in air).

    ``n1``, ``n2``, ``d1``, ``d2`` and ``alpha`` may also be 0-dim floating tensors (``n2``
    also complex), e.g. with ``requires_grad`` for fitting: the same ranges are checked on
    their values, and gradients flow through the mirrors' reflectance and the GGX shading of
    :func:`~torchirid.layered.single_reflection.single_reflection_brdf`. Not through the
    integrated transmissivity's filter weights, which are tabulated per ``float(alpha)``
    (τ still depends on ``n1, n2, d1, d2``). ``cells`` stays a Python int, ``n_incident`` a number (or ``n1``).

    Example (Fourneau's Fig. 1 mirror in air, α = 0.1; a thickness as a tensor to fit):
        >>> import torch
        >>> layer = RoughBraggLayer(n1=1.0, n2=1.5, d1=125.0, d2=375.0, cells=20, alpha=0.1)  # nm
        >>> layer.n_incident  # None became n1
        1.0
        >>> lam = torch.tensor([500.0, 600.0], dtype=torch.float64)  # nm
        >>> R = layer.reflectance(lam, torch.tensor(1.0, dtype=torch.float64))  # cos θ = 1 in the host
        >>> [round(v, 4) for v in R.tolist()]
        [0.1693, 0.0387]
        >>> d2 = torch.tensor(375.0, dtype=torch.float64, requires_grad=True)
        >>> fit = RoughBraggLayer(1.0, 1.5, 125.0, d2, 20, 0.1)
        >>> fit.reflectance(lam, torch.tensor(1.0, dtype=torch.float64)).sum().backward()
        >>> d2.grad is not None, fit.numbers()["d2"]
        (True, 375.0)
    """

    n1: float
    n2: float | complex
    d1: float
    d2: float
    cells: int
    alpha: float
    n_incident: float | None = None

    def __post_init__(self):
        for name in ("n1", "d1", "d2", "alpha"):
            v = getattr(self, name)
            if isinstance(v, torch.Tensor):
                ok = v.dim() == 0 and v.dtype.is_floating_point and bool(v.detach() > 0)
            else:
                ok = not isinstance(v, bool) and isinstance(v, (int, float)) and v > 0
            if not ok:
                raise ValueError(f"{name} must be a real number > 0 (or a 0-dim floating tensor); got {v!r}")
        n2 = self.n2
        if isinstance(n2, torch.Tensor):
            if n2.dim() != 0 or not (n2.dtype.is_floating_point or n2.dtype.is_complex):
                raise ValueError(f"n2 must be a refractive index (a number or a 0-dim float/complex tensor); got {n2!r}")
            n2 = complex(n2.detach()) if n2.dtype.is_complex else float(n2.detach())
        if isinstance(n2, bool) or not isinstance(n2, (int, float, complex)) or not n2.real > 0:
            raise ValueError(f"n2 must be a refractive index with real part > 0; got {self.n2!r}")
        if isinstance(n2, complex) and n2.imag < 0:
            raise ValueError(f"n2 must have Im(n2) >= 0 (absorption); got {self.n2!r}")
        nh = self.n_incident
        if nh is not None and (isinstance(nh, bool) or not isinstance(nh, (int, float)) or not nh > 0):
            raise ValueError(f"n_incident must be None or a real number > 0; got {nh!r}")
        _checks.check_int(self.cells, "cells", 1)
        if nh is None:  # resolved once: the mirrors are lit from their own low index
            object.__setattr__(self, "n_incident", self.n1)

    def numbers(self) -> dict:
        """The parameters as plain Python numbers (tensors detached): JSON-ready metadata.

        >>> RoughBraggLayer(1.0, 1.5, 100.0, 80.0, 10, 0.1).numbers()["d2"]
        80.0
        """
        def plain(v):
            if isinstance(v, torch.Tensor):
                v = v.detach()
                return complex(v) if v.dtype.is_complex else float(v)
            return v

        return {name: plain(getattr(self, name)) for name in ("n1", "n2", "d1", "d2", "cells", "alpha", "n_incident")}

    def tensors(self) -> tuple[torch.Tensor, ...]:
        """The parameters given as tensors (those a gradient can flow to)."""
        return tuple(v for v in (self.n1, self.n2, self.d1, self.d2, self.alpha) if isinstance(v, torch.Tensor))

    def reflectance(self, wavelength, cos_theta) -> torch.Tensor:
        """Unpolarized Yeh reflectance R_λ of one mirror lit from the host at ``cos_theta``
        (the cosine in the host medium; broadcast with ``wavelength`` in nm)."""
        nh = None if self.n_incident is self.n1 or self.n_incident == self.n1 else self.n_incident
        return bragg_reflectance(
            wavelength, cos_theta, self.n1, self.n2, self.d1, self.d2, self.cells, n_incident=nh,
            polarization="unpolarized",
        )

    def _reflectance_kernel(self, lam: torch.Tensor, c: torch.Tensor) -> torch.Tensor:
        """:meth:`reflectance` on checked tensors of one dtype and device (the layered models'
        tables and transport call it per evaluation): the layer's parameters, checked at
        construction, go to Yeh's kernel without a second check."""
        dtype, device = lam.dtype, lam.device
        n1 = _checks.as_index(self.n1, "n1", dtype, device)
        n2 = _checks.as_index(self.n2, "n2", dtype, device)
        d1 = _checks.as_real(self.d1, "d1", dtype, device)
        d2 = _checks.as_real(self.d2, "d2", dtype, device)
        same = self.n_incident is self.n1 or self.n_incident == self.n1
        nh = None if same else _checks.as_index(self.n_incident, "n_incident", dtype, device)
        N = torch.scalar_tensor(int(self.cells), dtype=torch.int64, device=device)
        return bragg_reflectance_kernel(lam, c, n1, n2, d1, d2, nh, N, polarization="unpolarized",
                                        n_max=int(self.cells))


@dataclass(frozen=True)
class LayeredBragg:
    """A stack of rough Bragg layers over an optional Lambertian base, under an optional coating.

    Attributes:
        layers: the rough Bragg layers, top first (at least one). All share the host ``n1``.
        base_albedo: Lambertian albedo ρd ∈ [0, 1] of the base (0: a black, absorbing base).

    The coating is implied by the host index (``n1``, or the layers' ``n_incident``): 1 means no coating (f_r,0 = 0,
    f_t,0 = 1 in eq. 34); otherwise a smooth air | n_incident interface sits on top.

    Example (two layers in a host of index 1.5 over a grey base; thicknesses in nm):
        >>> s = LayeredBragg([RoughBraggLayer(1.5, 1.8, 100.0, 90.0, 10, 0.1),
        ...                   RoughBraggLayer(1.5, 1.8, 130.0, 110.0, 10, 0.3)], base_albedo=0.2)
        >>> len(s.layers), s.base_albedo
        (2, 0.2)
        >>> s.coated, s.n_coating  # the host index 1.5 implies a smooth coating on top
        (True, 1.5)

    Pass it to :func:`~torchirid.layered.single_reflection.single_reflection_brdf`,
    :func:`~torchirid.layered.scatterograms.scatterogram` and the other functions of
    :mod:`torchirid.layered` that take a ``structure``.
    """

    layers: Sequence[RoughBraggLayer]
    base_albedo: float = 0.0

    def __post_init__(self):
        layers = tuple(self.layers)
        if not layers or not all(isinstance(layer, RoughBraggLayer) for layer in layers):
            raise ValueError("layers must be a non-empty sequence of RoughBraggLayer")
        hosts = {float(layer.n_incident) for layer in layers}  # by value: tensor parameters hash by id
        if len(hosts) != 1:
            raise ValueError(f"layers must share one host index n1 / n_incident (the coating medium); got {sorted(hosts)}")
        rho = self.base_albedo
        if isinstance(rho, bool) or not isinstance(rho, (int, float)) or not 0.0 <= rho <= 1.0:
            raise ValueError(f"base_albedo must lie in [0, 1]; got {rho!r}")
        object.__setattr__(self, "layers", layers)

    @property
    def n_coating(self) -> float:
        """The host index shared by all layers: the coating's index (1: no coating)."""
        return self.layers[0].n_incident

    @property
    def coated(self) -> bool:
        """True when a smooth coating air | n1 sits on top (n1 ≠ 1)."""
        return self.n_coating != 1.0


