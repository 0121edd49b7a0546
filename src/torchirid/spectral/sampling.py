"""How densely the ``"spectral"`` Bragg-colour method samples the spectrum: the fringe count of
a batch's worst mirror and the number of ω samples it needs (shared by
:func:`torchirid.spectral.bragg_color.bragg_xyz` and the ``method="auto"`` rule of
:mod:`torchirid.spectral.auto`)."""

from __future__ import annotations

import math

import torch

__all__ = ["spectral_samples"]


def fringe_count(cos_theta, n1, n2, d1, d2, cells, *, n_incident=None, wavelength_range=(380.0, 780.0)):
    r"""Fringes of each mirror's spectrum in ``wavelength_range``, at its angle (no gradient).

    .. math:: F = N\,(n_1 d_1 \cos θ_1 + n_2 d_2 \cos θ_2)\,(ω_{max} − ω_{min})/π ,
        \qquad ω = 2π/λ,\quad n_j \cos θ_j = \sqrt{n_j^2 − n_0^2 \sin^2 θ_0},

    the change of the Bloch phase KΛ ≈ ω Σ n_j d_j cos θ_j across the range, in units of π
    (real parts of the indices; a layer in total internal reflection contributes 0). It is
    the domain parameter of the fast colour methods: ``piecewise`` and ``envelope`` replace the
    fringes by their average, which the CMFs only reproduce when there are many
    (``benchmarks/bragg_color_domain.py``; ``torchirid.spectral.piecewise.MIN_FRINGES``).

    Args:
        cos_theta: cosine of the incidence angle in the incident medium, in [0, 1].
        n1, n2, d1, d2, cells: the mirror (indices, thicknesses in nm, number of cells).
        n_incident: incident medium (default ``None``: n1).
        wavelength_range: ``(λ_min, λ_max)`` in nm.

    Returns:
        Real tensor of the broadcast batch shape (float64 unless the inputs are float32).

    >>> round(float(fringe_count(1.0, 1.0, 1.5, 125.0, 375.0, 20)), 2)
    37.11
    """
    lo, hi = wavelength_range
    with torch.no_grad():
        args = (cos_theta, n1, n2, d1, d2, cells)
        single = any(torch.is_tensor(x) and x.dtype in (torch.float32, torch.complex64) for x in args)
        dtype = torch.float32 if single else torch.float64
        def real(x):  # Python numbers straight in dtype (no float32 detour); complex → real part
            if isinstance(x, complex) or (torch.is_tensor(x) and x.is_complex()):
                return torch.as_tensor(x).real.to(dtype)
            return x.to(dtype) if torch.is_tensor(x) else torch.as_tensor(x, dtype=dtype)

        c, a, b, t1, t2, N = (real(x) for x in args)
        n0 = a if n_incident is None else real(n_incident)
        s2 = (n0 * n0) * (1 - c * c).clamp(min=0)
        k1 = (a * a - s2).clamp(min=0).sqrt()
        k2 = (b * b - s2).clamp(min=0).sqrt()
        return N * (k1 * t1 + k2 * t2) * 2 * (1 / lo - 1 / hi)


def max_fringes(n1, n2, d1, d2, cells, lo, hi) -> float:
    """Fringes in [λ_lo, λ_hi] of the batch's worst mirror: max N (|n1| d1 + |n2| d2) · Δω / π
    (Δω = 2π(1/λ_lo − 1/λ_hi)); mirrors with a NaN or infinite parameter (NaN colour at any
    sampling) do not count. Shared by the ``"spectral"`` sampling rule and ``method="auto"``.

    Example (two mirrors; d1 in nm; the longer one counts):
        >>> import torch
        >>> round(max_fringes(1.0, 1.5, torch.tensor([125.0, 250.0]), 375.0, 20, 380.0, 780.0), 2)
        43.86
        >>> round(max_fringes(1.0, 1.5, 125.0, 375.0, 20, 380.0, 780.0), 2)  # = fringe_count at 0°
        37.11
    """
    with torch.no_grad():
        opl = torch.as_tensor(n1).abs() * torch.as_tensor(d1) + torch.as_tensor(n2).abs() * torch.as_tensor(d2)
        length = torch.as_tensor(cells).to(opl.dtype) * opl
        length = length[torch.isfinite(length)]
        return (float(length.max()) if length.numel() else 0.0) * 2 * (1 / lo - 1 / hi)


def spectral_samples(n1, n2, d1, d2, cells, *, wavelength_range=(380.0, 780.0), samples_per_fringe=192.0,
                     min_samples=401, max_samples=262144) -> int:
    """Number of ω samples the ``"spectral"`` method uses for the worst mirror of a batch.

    ``ceil(samples_per_fringe · N · (|n1| d1 + |n2| d2) · Δω / π) + 1``, clipped to
    ``[min_samples, max_samples]`` (see the module docstring). Mirrors with a NaN or infinite
    parameter (whose colour is NaN at any sampling) do not count.

    Example (thicknesses in nm; 380–780 nm by default):
        >>> spectral_samples(1.0, 1.5, 125.0, 375.0, 20)  # 37.1 fringes × 192
        7127
        >>> spectral_samples(1.0, 1.5, 10.0, 10.0, 5)  # a thin mirror: min_samples
        401
    """
    wanted = samples_per_fringe * max_fringes(n1, n2, d1, d2, cells, *wavelength_range)
    if not math.isfinite(wanted) or wanted >= max_samples:  # (also absurd or overflowing inputs)
        return max_samples
    return int(min(max(math.ceil(wanted) + 1, min_samples), max_samples))
