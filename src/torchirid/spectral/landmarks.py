r"""Spectral landmarks of a Bragg mirror (Fourneau et al. 2024, §3.2.1, eq. 12–13, appendix A).

In angular wavenumber ω = 2π/λ (nm⁻¹) the phases of the two layers are linear,
a = ω A and b = ω B with A = n1 d1 cos θ1, B = n2 d2 cos θ2 (nm), and the dispersion
relation (eq. 8) reads x(ω) = cos KΛ = cos ωA cos ωB − ½ Ω sin ωA sin ωB. Landmarks:

* **modes** ω_m = mπ/(A + B), m ∈ ℕ⁺ (eq. 13) — always inside a band gap, with
  sign x(ω_m) = (−1)^m (appendix A);
* **Airy points** ω_a: zeros of x between consecutive modes (there R^e = |r1|²);
* **band-gap edges** ω_b: |x| = 1, one on each side of every mode, between the mode and
  its neighbouring Airy points;
* **zero points** ω_z = zπ/B, z ∈ ℕ⁺ (eq. 12), where the envelope vanishes (r1 = 0).

Airy points and edges are found by a batched bisection (all modes of all angles,
parameters and polarizations at once; 12 halvings and a final secant step by default),
on the cancellation-free forms 1 ∓ x = 2 sin²/cos²(ω(A+B)/2) ± δ sin ωA sin ωB with
δ = (η1 − η2)²/(2η1η2) = Ω/2 − 1 ≥ 0. Modes are padded to the largest count in the batch;
padded entries are NaN in :func:`bragg_landmarks`'s output.
"""

from __future__ import annotations

import math

import torch

__all__ = ["bragg_landmarks", "dispersion_parts"]


def dispersion_parts(omega, A, B, delta):
    """(1 − x, 1 + x) of x = cos KΛ at ω from the product forms (no cancellation near |x| = 1)."""
    half = 0.5 * omega * (A + B)
    prod = delta * torch.sin(omega * A) * torch.sin(omega * B)
    sh, ch = torch.sin(half), torch.cos(half)
    return 2 * sh * sh + prod, 2 * ch * ch - prod


def _bisect(f, lo, hi, iterations):
    """Batched bisection for a sign change of ``f`` between ``lo`` and ``hi`` (same shapes),
    finished by one secant (false-position) step in the final bracket: the error falls from
    ~2^-iterations to ~(2^-iterations)² of the initial bracket."""
    f_lo = f(lo)
    s_lo = torch.sign(f_lo)
    f_hi = f(hi)
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        f_mid = f(mid)
        left = torch.sign(f_mid) == s_lo  # the root is in [mid, hi]
        lo, f_lo = torch.where(left, mid, lo), torch.where(left, f_mid, f_lo)
        hi, f_hi = torch.where(left, hi, mid), torch.where(left, f_hi, f_mid)
    den = f_hi - f_lo
    ok = (den != 0) & torch.isfinite(den)
    x = lo - f_lo * (hi - lo) / torch.where(ok, den, torch.ones_like(den))
    inside = ok & (x >= lo) & (x <= hi)
    return torch.where(inside, x, 0.5 * (lo + hi))


def bragg_landmarks(omega_min, omega_max, A, B, delta, *, iterations: int = 12):
    r"""Modes, Airy points, band-gap edges and zero points of a Bragg mirror in [ω_min, ω_max].

    Args:
        omega_min, omega_max: the ω range (nm⁻¹), Python floats.
        A, B: optical thicknesses n1 d1 cos θ1 and n2 d2 cos θ2 (nm), real ≥ 0, any
            broadcasting batch shape (angles × parameters × polarizations).
        delta: Ω/2 − 1 = (η1 − η2)²/(2 η1 η2) ≥ 0 for the polarization (batch-broadcast).
        iterations: bisection halvings before the final secant step; 12 put every landmark
            within ~2e-6 (relative) of its exact position (~1e-9 with 18): a colour moves by
            ≲ 1e-4 ΔE2000 — pass more for other uses.

    Returns:
        dict of tensors, batch shape ``(*,)`` first:
        ``modes (*, M)`` (ω_m, NaN-padded), ``m (*, M)`` (mode numbers), ``airy (*, M + 1)``
        (the zero of x between modes m − 1 and m, and after the last), ``edges_lo``,
        ``edges_hi (*, M)`` (the gap around each mode), ``zeros (*, Z)`` (eq. 12; NaN-padded).
        Every landmark returned lies in [ω_min, ω_max] or is NaN (gaps and Airy points are
        found on the modes just outside the range too and clipped, so partial gaps at the
        range ends are complete).

    Example (quarter-wave stack n = 1 / 1.5 designed for 600 nm: the gap around 600 nm):
        >>> import math, torch
        >>> A, B = torch.tensor(150.0, dtype=torch.float64), torch.tensor(150.0, dtype=torch.float64)
        >>> delta = (1.0 - 1.5) ** 2 / (2 * 1.5)
        >>> L = bragg_landmarks(2 * math.pi / 780, 2 * math.pi / 380, A, B, delta)
        >>> [round(2 * math.pi / w, 1) for w in L["modes"].tolist() if w == w]  # drop NaN padding
        [600.0]
        >>> [round(2 * math.pi / float(L[k][1]), 1) for k in ("edges_hi", "edges_lo")]  # gap in nm
        [531.8, 688.2]
    """
    A, B, delta = torch.broadcast_tensors(torch.as_tensor(A), torch.as_tensor(B), torch.as_tensor(delta))
    L = A + B  # optical thickness of a cell (nm)
    nan = float("nan")
    with torch.no_grad():
        m_lo = torch.floor(omega_min * L / math.pi)  # the mode at or below ω_min (0 is ω = 0)
        m_hi = torch.ceil(omega_max * L / math.pi)  # the mode at or above ω_max
        count = int((m_hi - m_lo).max().item()) + 1 if L.numel() else 1
    m = m_lo.unsqueeze(-1) + torch.arange(count, dtype=L.dtype, device=L.device)  # (*, M) mode numbers
    Ax, Bx, dx = (t.unsqueeze(-1) for t in (A, B, delta))
    modes = m * math.pi / (Ax + Bx)  # ω_m (eq. 13); m = 0 is ω = 0, where x = 1
    even = torch.remainder(m, 2) == 0  # x(ω_m) ≥ 1 for even m, ≤ −1 for odd m (appendix A)

    def x_of(w):
        omx, opx = dispersion_parts(w, Ax, Bx, dx)
        return torch.where(omx <= opx, 1 - omx, opx - 1)

    def one_minus_abs_x(even_mode):
        def f(w):  # 1 − |x| near a mode: 1 − x around even modes, 1 + x around odd ones
            omx, opx = dispersion_parts(w, Ax, Bx, dx)
            return torch.where(even_mode, omx, opx)

        return f

    # the Airy point between consecutive modes: x goes from (−1)^m to (−1)^(m+1)
    airy = _bisect(x_of, modes[..., :-1], modes[..., 1:], iterations)
    # each gap edge lies between its mode (1 − |x| ≤ 0) and the neighbouring Airy point (= 1)
    # both edges of every gap in one batched bisection: [mode, next Airy] and [Airy, next mode]
    both = _bisect(one_minus_abs_x(torch.cat([even[..., :-1], even[..., 1:]], -1)),
                   torch.cat([modes[..., :-1], airy], -1), torch.cat([airy, modes[..., 1:]], -1), iterations)
    up, down = both.split(airy.shape[-1], dim=-1)
    pad = torch.full_like(modes[..., :1], nan)
    edges_hi = torch.cat([up, pad], dim=-1)  # upper edge (larger ω) of the gap around each mode
    edges_lo = torch.cat([pad, down], dim=-1)  # lower edge
    # a closed gap (|x(ω_m)| = 1, e.g. p polarization at Brewster's angle): both edges at the mode
    omx_m, opx_m = dispersion_parts(modes, Ax, Bx, dx)
    closed = torch.where(even, omx_m, opx_m) >= 0
    real_mode = m >= 1
    edges_hi = torch.where(closed, modes, edges_hi)
    edges_lo = torch.where(closed, modes, edges_lo)

    def in_range(w, ok=True):
        keep = (w >= omega_min) & (w <= omega_max) & ok
        return torch.where(keep, w, torch.full_like(w, nan))

    out = {
        "modes": in_range(modes, real_mode),
        "m": m,
        "airy": in_range(airy),
        # gaps straddling the range ends are clipped to it (they still start/end a box)
        "edges_lo": torch.where(real_mode, edges_lo.clamp(omega_min, omega_max), torch.full_like(modes, nan)),
        "edges_hi": torch.where(real_mode, edges_hi.clamp(omega_min, omega_max), torch.full_like(modes, nan)),
    }
    # zero points ω_z = zπ/B (eq. 12)
    with torch.no_grad():
        safe_B = torch.where(B > 0, B, torch.ones_like(B))
        z_lo = torch.ceil(omega_min * safe_B / math.pi).clamp(min=1)
        z_hi = torch.floor(omega_max * safe_B / math.pi)
        zc = int((z_hi - z_lo).max().clamp(min=0).item()) + 1 if B.numel() else 1
    z = z_lo.unsqueeze(-1) + torch.arange(zc, dtype=L.dtype, device=L.device)
    zeros = z * math.pi / safe_B.unsqueeze(-1)
    out["zeros"] = in_range(zeros, (z <= z_hi.unsqueeze(-1)) & (B.unsqueeze(-1) > 0))
    return out
