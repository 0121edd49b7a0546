"""How densely the ``"spectral"`` Bragg-colour method samples the spectrum: the fringe count of
a batch's worst mirror and the number of ω samples it needs (shared by
:func:`torchirid.spectral.bragg_color.bragg_xyz` and the ``method="auto"`` rule of
:mod:`torchirid.spectral.auto`)."""

from __future__ import annotations

import math

import torch

__all__ = ["max_fringes", "spectral_samples"]


def max_fringes(n1, n2, d1, d2, cells, lo, hi) -> float:
    """Fringes in [λ_lo, λ_hi] of the batch's worst mirror: max N (|n1| d1 + |n2| d2) · Δω / π
    (Δω = 2π(1/λ_lo − 1/λ_hi)); mirrors with a NaN or infinite parameter (NaN colour at any
    sampling) do not count. Shared by the ``"spectral"`` sampling rule and ``method="auto"``."""
    with torch.no_grad():
        opl = torch.as_tensor(n1).abs() * torch.as_tensor(d1) + torch.as_tensor(n2).abs() * torch.as_tensor(d2)
        length = torch.as_tensor(cells).to(opl.dtype) * opl
        length = length[torch.isfinite(length)]
        return (float(length.max()) if length.numel() else 0.0) * 2 * (1 / lo - 1 / hi)


def spectral_samples(n1, n2, d1, d2, cells, *, wavelength_range=(380.0, 780.0), samples_per_fringe=192.0,
                     min_samples=401, max_samples=262144) -> int:
    """Number of ω samples the ``"spectral"`` method uses for the worst mirror of a batch.

    ``ceil(samples_per_fringe · N · (|n1| d1 + |n2| d2) · Δω / π)``, clipped to
    ``[min_samples, max_samples]`` (see the module docstring). Mirrors with a NaN or infinite
    parameter (whose colour is NaN at any sampling) do not count.
    """
    wanted = samples_per_fringe * max_fringes(n1, n2, d1, d2, cells, *wavelength_range)
    if not math.isfinite(wanted) or wanted >= max_samples:  # (also absurd or overflowing inputs)
        return max_samples
    return int(min(max(math.ceil(wanted) + 1, min_samples), max_samples))
