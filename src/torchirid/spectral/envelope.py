r"""Fast Bragg colour without landmarks: the fringe-averaged spectrum on a uniform ω grid.

The piecewise method (:mod:`torchirid.spectral.piecewise`, ``weights="averaged"``) replaces
Yeh's finite-N spectrum by a smooth model and integrates it on boxes between spectral
landmarks. The model is

* in the pass bands, Yeh's R averaged over its fast fringes (the phase NKΛ uniform at fixed
  |C|² and KΛ):

  .. math:: \langle R \rangle = 1 - \sqrt{1 - R^e}, \qquad
            R^e = \frac{|C|^2}{|C|^2 + \sin^2 K\Lambda} \quad \text{(eq. 11)};

* inside the band gaps, the exact finite-N reflectance (no fringes there).

It is smooth between the gap edges, where it behaves like √(ω − ω_edge), so it needs no
landmarks at all to be integrated: this module samples it at ``samples`` nodes uniform in
ω = 2π/λ and integrates its piecewise-linear interpolant exactly against the CMFs × illuminant
(product integration with hat functions, weights from the cumulative tables of
:func:`torchirid.spectral.cumulative.shipped_cumulative_cmf_lut`, computed once per grid and cached).
The cost is that of ``samples`` evaluations of Yeh's closed form, with no search, sort or
gather; the fringes that a ``"sampled"`` grid must resolve are averaged out analytically, so
the same accuracy takes several times fewer samples (Fourneau's Fig. 4 grid, N = 20: 64 ω
samples beat 128 uniform-λ samples of the exact spectrum at every period; see
docs/performance.md, "Bragg mirror colour"). What limits it is the model, not the sampling:
the fringes next to the gap edges are wide for small N and are not averaged well — on the
Fig. 4 grid the converged model (``samples`` → ∞) is within median 0.05–0.12 / p95
0.6–0.9 ΔE2000 of the exact colour.

Scope as the piecewise method: a lossless mirror embedded in n1 (``n_incident`` = None or n1),
light propagating in n2. Gradients flow to every parameter (the grid does not move).
"""

from __future__ import annotations

import math

import torch

from .. import _autograd, _checks, _chunks
from ..optics.bragg import yeh_reflectance_kernel
from .cumulative import shipped_cumulative_cmf_lut
from .piecewise import _check_domain, _embedded_mirror, _envelope, _fringe_mean, _parts
from .._cache import cached

__all__ = ["bragg_xyz_envelope"]


@cached(maxsize=64)
@_autograd.normal_tensors
def _hat_weights(samples, observer, illuminant, lo, hi, dtype, device):
    omega_min, omega_max = 2 * math.pi / hi, 2 * math.pi / lo
    table = shipped_cumulative_cmf_lut(observer, illuminant, (lo, hi), dtype=torch.float64, device="cpu")
    grid, v = table.axes["omega"].to(torch.float64), table.values.to(torch.float64)
    omega0, step = float(grid[0]), float(grid[-1] - grid[0]) / (grid.numel() - 1)
    dv = v[1:] - v[:-1]
    # D(ω_i) = ∫ C̄ dω of the table's linear interpolant at its nodes (exact trapezoids)
    D_nodes = torch.cat([torch.zeros_like(v[:1]), torch.cumsum(step * (v[:-1] + 0.5 * dv), dim=0)])
    nodes = torch.linspace(omega_min, omega_max, samples, dtype=torch.float64)
    cells = dv.shape[0]
    pos = ((nodes - omega0) / step).clamp(0, cells)
    i = torch.floor(pos).clamp(max=cells - 1)
    t = (pos - i).unsqueeze(-1)
    i = i.to(torch.int64)
    c0, dc, d0 = v[i], dv[i], D_nodes[i]
    C = c0 + dc * t  # C̄ at the nodes
    D = d0 + step * t * (c0 + 0.5 * t * dc)  # ∫ C̄ dω at the nodes
    h = (omega_max - omega_min) / (samples - 1)
    mean_C = (D[1:] - D[:-1]) / h  # (1/h) ∫ C̄ over each cell
    # hat function φ_k: ∫_cell (ω − a)/h dC̄ = C̄(b) − mean, ∫_cell (b − ω)/h dC̄ = mean − C̄(a)
    rising, falling = C[1:] - mean_C, mean_C - C[:-1]
    W = torch.zeros(samples, 3, dtype=torch.float64)
    W[1:] += rising
    W[:-1] += falling
    return W.to(dtype=dtype, device=device)


def _fringe_averaged(omega, A, B, delta, C_coef, N, trailing=True):
    """The model spectrum at ``omega`` for the (P, *) mirror parameters of
    :func:`~torchirid.spectral.piecewise._embedded_mirror`: (P, *, K) for ``omega`` (K,) on a
    trailing axis, or broadcast with them (``trailing=False``)."""
    Ax, Bx, dx, Cx, Nx = ((t.unsqueeze(-1) if trailing else t) for t in (A, B, delta, C_coef, N.to(A.dtype)))
    omx, opx, sin_b = _parts(omega, Ax, Bx, dx)
    C2 = Cx * (sin_b * sin_b)  # |C|²
    sin2 = torch.clamp(omx * opx, min=0)  # sin² KΛ outside the gaps (0 inside)
    fringe_mean = _fringe_mean(_envelope(C2, sin2))
    eps = torch.minimum(omx, opx)  # 1 − |cos KΛ|: < 0 inside a gap
    gap_R = yeh_reflectance_kernel(C2, torch.ones_like(C2), eps, Nx, safe=torch.is_grad_enabled())
    return torch.where(eps < 0, gap_R, fringe_mean)


def fringe_averaged_reflectance(wavelength, cos_theta, n1, n2, d1, d2, cells, *,
                                polarization: str = "unpolarized") -> torch.Tensor:
    r"""The smooth model spectrum of the envelope and piecewise methods (module docstring).

    1 − √(1 − R^e) in the pass bands (Yeh's R averaged over its fringes), Yeh's finite-N R in
    the band gaps; a lossless mirror embedded in n1.

    Args:
        wavelength: (nm), broadcasting with the other arguments (as in
            :func:`torchirid.bragg_reflectance`).
        cos_theta, n1, n2, d1, d2, cells, polarization: as :func:`bragg_xyz_envelope`.

    Returns:
        the broadcast reflectance in [0, 1]; dtype/device from the inputs.

    Example (quarter-wave stack for 600 nm, N = 20: the gap centre and a pass-band point):
        >>> import torch
        >>> lam = torch.tensor([600.0, 450.0], dtype=torch.float64)
        >>> R = fringe_averaged_reflectance(lam, 1.0, 1.0, 1.5, 150.0, 100.0, 20)
        >>> [round(v, 4) for v in R.tolist()]
        [1.0, 0.0835]
    """
    _checks.check_polarization(polarization)
    dtype, device = _checks.resolve_dtype_device(wavelength, cos_theta, n1, n2, d1, d2)
    lam = _checks.as_real(wavelength, "wavelength", dtype, device)
    _checks.check_wavelength(lam)
    c, n1, n2, d1, d2 = (_checks.as_real(v, name, dtype, device) for v, name in
                         ((cos_theta, "cos_theta"), (n1, "n1"), (n2, "n2"), (d1, "d1"), (d2, "d2")))
    mirror = _embedded_mirror(c, n1, n2, d1, d2, cells, polarization, (1.0, 2.0), "envelope")
    omega = 2 * math.pi / lam
    A = mirror["A"]
    shape = _checks.broadcast_shapes(omega.shape, A.shape, mirror["N"].shape)

    def leading_p(t):  # (P, *a) → (P, 1, …, 1, *a): the batch axes right-aligned with `shape`
        return t.reshape(t.shape[:1] + (1,) * (len(shape) - t.ndim + 1) + t.shape[1:])

    R = _fringe_averaged(omega, A, mirror["B"], leading_p(mirror["delta"]), leading_p(mirror["C_coef"]),
                         mirror["N"], trailing=False)
    out = R[0] if R.shape[0] == 1 else 0.5 * (R[0] + R[1])
    return torch.where(mirror["grazing"], torch.ones_like(out), out)


def envelope_weights(samples: int, *, observer: str = "CIE 1931 2", illuminant: str = "D65",
                     wavelength_range=(380.0, 780.0), dtype=torch.float64, device="cpu") -> torch.Tensor:
    r"""Product-integration weights ``(samples, 3)`` of hat functions on a uniform ω grid.

    Row k is :math:`\int \varphi_k(\omega)\, \bar{\mathbf c}(\omega)\, d\omega` with φ_k the
    piecewise-linear hat on the nodes ω_k = linspace(2π/λ_max, 2π/λ_min, samples) and
    :math:`\bar{\mathbf c}` the CMFs × illuminant in ω of
    :mod:`torchirid.spectral.cumulative` (normalised so that the Y column sums to 1), so
    that ``f(ω_k) @ W`` is the exact XYZ of the linear interpolant of f. Computed in float64
    from the cumulative tables (≤ 1e-6 of the white) and cached per grid.

    Example:
        >>> W = envelope_weights(64)
        >>> W.shape, round(W[:, 1].sum().item(), 9)
        (torch.Size([64, 3]), 1.0)
    """
    _checks.check_int(samples, "samples", 2)
    lo, hi = _checks.check_wavelength_range(wavelength_range)
    return _hat_weights(samples, observer, illuminant, lo, hi, dtype, torch.device(device)).clone()  # cache stays intact


def bragg_xyz_envelope(cos_theta, n1, n2, d1, d2, cells, *, polarization: str = "unpolarized", samples: int = 64,
                       observer: str = "CIE 1931 2", illuminant: str = "D65",
                       wavelength_range=(380.0, 780.0)) -> torch.Tensor:
    r"""XYZ of a Bragg mirror embedded in n1 from its fringe-averaged spectrum (module docstring).

    Args:
        cos_theta: cosine of the incidence angle in n1, in [0, 1].
        n1, n2: real refractive indices (n2 must be reached: n2 ≥ n1 sin θ).
        d1, d2: layer thicknesses (nm).
        cells: N, used inside the band gaps (the finite-N gap reflectance).
        polarization: ``"s"``, ``"p"`` or ``"unpolarized"``.
        samples: nodes uniform in ω over ``wavelength_range`` (≥ 2; 64 by default).
        observer, illuminant, wavelength_range: as :func:`torchirid.spectral.bragg_xyz`.

    Returns:
        XYZ ``(*, 3)``, Y = 1 for a perfect reflector; dtype/device from the inputs.

    Example (Fourneau Fig. 1's mirror at normal incidence; the exact colour is
    [0.203, 0.074, 0.772]):
        >>> import torch
        >>> xyz = bragg_xyz_envelope(torch.tensor(1.0, dtype=torch.float64), 1.0, 1.5, 125.0, 375.0, 20)
        >>> [round(v, 3) for v in xyz.tolist()]
        [0.203, 0.074, 0.773]
    """
    _checks.check_polarization(polarization)
    _checks.check_int(samples, "samples", 2)
    mirror = _embedded_mirror(cos_theta, n1, n2, d1, d2, cells, polarization, wavelength_range, "envelope")
    _check_domain(mirror, "envelope")
    lo, hi = mirror["range"]
    A, B, delta, C_coef, N = mirror["A"], mirror["B"], mirror["delta"], mirror["C_coef"], mirror["N"]
    dtype, device = A.dtype, A.device
    W = _hat_weights(samples, observer, illuminant, lo, hi, dtype, device)  # cached; read only
    omega = torch.linspace(2 * math.pi / hi, 2 * math.pi / lo, samples, dtype=dtype, device=device)
    grazing = mirror["grazing"]
    batch = _checks.broadcast_shapes(A.shape, B.shape, N.shape, delta.shape[1:], C_coef.shape[1:], grazing.shape)
    # block by block over large batches (torchirid._chunks): P × K model reflectances per colour;
    # the polarization axis moves last to ride along as a core axis
    return _chunks.evaluate(_envelope_xyz, (A, B, delta.movedim(0, -1), C_coef.movedim(0, -1), N, grazing), batch,
                            core=(0, 0, 1, 1, 0, 0), out_core=1, width=delta.shape[0] * samples, omega=omega, W=W)


def _envelope_xyz(A, B, delta, C_coef, N, grazing, *, omega, W):
    """XYZ of one block of mirrors (polarizations on the last axis of ``delta`` and ``C_coef``)."""
    R = _fringe_averaged(omega, A, B, delta.movedim(-1, 0), C_coef.movedim(-1, 0), N)  # (P, *, K)
    xyz = R @ W  # (P, *, 3)
    out = xyz[0] if xyz.shape[0] == 1 else 0.5 * (xyz[0] + xyz[1])
    white = W.sum(dim=0)  # XYZ of R ≡ 1 on this grid (Y = 1)
    return torch.where(grazing.unsqueeze(-1), white.expand_as(out), out)
