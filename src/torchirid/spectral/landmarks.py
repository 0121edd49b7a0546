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

Airy points and edges are found by one batched bisection (all kinds, modes, angles,
parameters and polarizations at once; 12 halvings and a final secant step by default) in the
phase φ = ω(A + B), where with γ = (A − B)/(A + B) and k = δ/(2 + δ) (δ = (η1 − η2)²/(2η1η2)
= Ω/2 − 1 ≥ 0) the product forms without cancellation near |x| = 1 read

    1 − x = (2 + δ) sin²(φ/2) − δ sin²(γφ/2),   1 + x = (2 + δ) cos²(φ/2) − δ cos²(γφ/2),

(evaluated as k₀ + k₁ cos φ + k₂ cos γφ in the bisection, whose steps need only the sign), and each landmark has a narrow a-priori bracket: a gap edge lies
within 2 asin √k of its mode (sin²(u/2) = k sin²(…) ≤ k, u = φ − mπ) and an Airy point within
asin k of the midpoint between modes (cos φ = k cos γφ). Modes are padded to the largest count
in the batch; padded entries are NaN in :func:`bragg_landmarks`'s output.
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


def _secant(lo, hi, f_lo, f_hi):
    """One secant (false-position) step in the final bracket [lo, hi] of a bisection: the error
    falls from ~2^-k to ~(2^-k)² of the initial bracket (the midpoint if the step fails)."""
    den = f_hi - f_lo
    ok = (den != 0) & torch.isfinite(den)
    x = lo - f_lo * (hi - lo) / torch.where(ok, den, torch.ones_like(den))
    inside = ok & (x >= lo) & (x <= hi)
    return torch.where(inside, x, 0.5 * (lo + hi))


#: bisection halvings of :func:`bragg_landmarks` (of the a-priori brackets of the module
#: docstring, at most π wide in φ; with the final secant step every landmark of a stress set
#: with grazing angles and δ up to 10³ lies within 1e-5 of its converged position, relative)
ITERATIONS = 12


def _counts(omega_min, omega_max, A, B):
    """Mode numbers ``m (*, M)`` and zero-point numbers ``z (*, Z)`` to search, and the last
    zero number ``z_hi (*,)`` (eager: the counts M, Z are data dependent; one host sync each)."""
    L = A + B
    with torch.no_grad():
        m_lo = torch.floor(omega_min * L / math.pi)  # the mode at or below ω_min (0 is ω = 0)
        m_hi = torch.ceil(omega_max * L / math.pi)  # the mode at or above ω_max
        safe_B = torch.where(B > 0, B, torch.ones_like(B))
        z_lo = torch.ceil(omega_min * safe_B / math.pi).clamp(min=1)
        z_hi = torch.floor(omega_max * safe_B / math.pi)
        if L.numel():
            count, zc = (int(v) for v in torch.stack([(m_hi - m_lo).max(), (z_hi - z_lo).max().clamp(min=0)]).tolist())
        else:
            count, zc = 0, 0
    m = m_lo.unsqueeze(-1) + torch.arange(count + 1, dtype=L.dtype, device=L.device)  # (*, M) mode numbers
    z = z_lo.unsqueeze(-1) + torch.arange(zc + 1, dtype=L.dtype, device=L.device)
    return m, z, z_hi


def _landmarks(omega_min, omega_max, A, B, delta, m, iterations=ITERATIONS, missing=float("nan")):
    """Landmarks from the mode numbers of :func:`_counts` (no data-dependent sizes or host
    syncs: usable inside ``torch.compile(fullgraph=True)``).

    Returns ``(modes, airy, edges_lo, edges_hi)`` as in :func:`bragg_landmarks`, with
    ``missing`` (NaN by default) in place of the landmarks that are not there.

    Every Airy point and gap edge between modes m and m + 1 lies in [ω_m, ω_{m+1}]: there
    1 ∓ x (the sign for mode m) is ≤ 0 only in gap m, 1 ± x (for mode m + 1) only in gap
    m + 1, and x changes sign once; so one batched bisection finds all three kinds, on
    g = c₀ + c₁ sin²(φ/2 + p) − c₂ sin²(γφ/2 + p) (φ = ωL, p ∈ {0, π/2}; evaluated as
    k₀ + k₁ cos φ + k₂ cos γφ) with per-root
    coefficients chosen so that g ≤ 0 left of the root and > 0 right of it, each in its
    a-priori bracket (module docstring).
    """
    Ax, Bx, dx = (t.unsqueeze(-1) for t in (A, B, delta))
    Lx = Ax + Bx
    modes = m * math.pi / Lx  # ω_m (eq. 13); m = 0 is ω = 0, where x = 1
    even = torch.remainder(m, 2) == 0  # x(ω_m) ≥ 1 for even m, ≤ −1 for odd m (appendix A)
    ev = even[..., :-1].to(A.dtype)  # parity of the lower mode of each bracket (1 even, 0 odd)
    od = 1 - ev
    sgn = ev - od  # +1 for even m, −1 for odd m
    # per root, in order (u = φ − mπ; all ≤ 0 left of the root, > 0 right of it):
    # * the upper edge of gap m: 1 − x (even m), 1 + x (odd m) = (2 + δ) sin²(φ/2 + p) − δ sin²(γφ/2 + p)
    #   with p = 0 (even), π/2 (odd); in u ∈ [0, 2 asin √k];
    # * the Airy point: −x (even m), x (odd m) = sgn ((2 + δ) sin²(φ/2) − δ sin²(γφ/2) − 1);
    #   in φ ∈ mπ + π/2 ± asin k;
    # * the lower edge of gap m + 1: −(1 + x) (even m), −(1 − x) (odd m), p = π/2 (even m), 0 (odd m);
    #   in φ ∈ [(m + 1)π − 2 asin √k, (m + 1)π]
    # the bisection runs with the root axis first, (3(M − 1), *): the batch axes, long and
    # contiguous, are innermost (vectorised when compiled)
    ev, od, sgn = (t.movedim(-1, 0) for t in (ev, od, sgn))
    zero = torch.zeros_like(ev)
    one = zero + 1
    scale = torch.cat([one, sgn, -one], 0)
    c0 = torch.cat([zero, -sgn, zero], 0)
    c1 = scale * (2 + delta)
    c2 = scale * delta
    # sin²(y + p) = (1 − s cos 2y)/2 with s = cos 2p = ±1 (p ∈ {0, π/2}): g is evaluated as
    # k0 + k1 cos φ + k2 cos γφ, two cosines and three more ops per bisection step. Only the sign
    # of g steers the bisection, so the cancellation at its root costs ~ε·(2 + δ)/|g'| in φ.
    s = 1 - 2 * torch.cat([od, zero, ev], 0)
    k0 = c0 + 0.5 * (c1 - c2)
    k1 = -0.5 * s * c1
    k2 = 0.5 * s * c2
    gamma = (A - B) / (A + B)
    k = delta / (2 + delta)
    w_edge = (2 * torch.asin(torch.sqrt(k))).expand_as(ev)
    w_airy = torch.asin(k).expand_as(ev)
    base = m[..., :-1].movedim(-1, 0) * math.pi
    a = torch.cat([base, base + (0.5 * math.pi - w_airy), base + (math.pi - w_edge)], 0)  # the root is in [a, a + h]
    h = torch.cat([w_edge, 2 * w_airy, w_edge], 0)

    def g(phi):
        return torch.addcmul(torch.addcmul(k0, k1, torch.cos(phi)), k2, torch.cos(gamma * phi))

    for _ in range(iterations):
        h = 0.5 * h
        mid = a + h
        a = torch.where(g(mid) <= 0, mid, a)  # the root is in [mid, mid + h]
    b = a + h
    roots = _secant(a, b, g(a), g(b)).movedim(0, -1) / Lx
    up, airy, down = roots.split(m.shape[-1] - 1, dim=-1)
    # the gaps around the first and last modes (at or beyond the range ends) extend past them:
    # their outer edges, not searched, are clipped to the range below
    edges_hi = torch.cat([up, torch.full_like(modes[..., :1], math.inf)], dim=-1)  # upper edge (larger ω)
    edges_lo = torch.cat([torch.full_like(modes[..., :1], -math.inf), down], dim=-1)  # lower edge
    # a closed gap (|x(ω_m)| = 1, e.g. p polarization at Brewster's angle): both edges at the mode
    omx_m, opx_m = dispersion_parts(modes, Ax, Bx, dx)
    closed = torch.where(even, omx_m, opx_m) >= 0
    real_mode = m >= 1
    edges_hi = torch.where(closed, modes, edges_hi)
    edges_lo = torch.where(closed, modes, edges_lo)

    def in_range(w, ok):
        keep = (w >= omega_min) & (w <= omega_max) & ok
        return torch.where(keep, w, missing)

    return (in_range(modes, real_mode), in_range(airy, True),
            # gaps straddling the range ends are clipped to it (they still start/end a box)
            torch.where(real_mode, edges_lo.clamp(omega_min, omega_max), missing),
            torch.where(real_mode, edges_hi.clamp(omega_min, omega_max), missing))


def _zeros(omega_min, omega_max, B, z, z_hi, missing=float("nan")):
    """Zero points ω_z = zπ/B (eq. 12) of the numbers ``z`` of :func:`_counts`, padded with ``missing``."""
    safe_B = torch.where(B > 0, B, torch.ones_like(B)).unsqueeze(-1)
    zeros = z * math.pi / safe_B
    keep = (zeros >= omega_min) & (zeros <= omega_max) & (z <= z_hi.unsqueeze(-1)) & (B.unsqueeze(-1) > 0)
    return torch.where(keep, zeros, missing)


def bragg_landmarks(omega_min, omega_max, A, B, delta, *, iterations: int = ITERATIONS):
    r"""Modes, Airy points, band-gap edges and zero points of a Bragg mirror in [ω_min, ω_max].

    Args:
        omega_min, omega_max: the ω range (nm⁻¹), Python floats.
        A, B: optical thicknesses n1 d1 cos θ1 and n2 d2 cos θ2 (nm), real ≥ 0, any
            broadcasting batch shape (angles × parameters × polarizations).
        delta: Ω/2 − 1 = (η1 − η2)²/(2 η1 η2) ≥ 0 for the polarization (batch-broadcast).
        iterations: bisection halvings of the a-priori brackets (module docstring) before the
            final secant step; 12 put every landmark within ~1e-5 (relative) of its exact
            position in the worst cases (grazing, large δ), ~3e-8 for δ ≲ 0.1: a colour moves by
            ≲ 1e-4 ΔE2000 — pass more for other uses.

    Returns:
        dict of tensors, batch shape ``(*,)`` first:
        ``modes (*, M)`` (ω_m, NaN-padded), ``m (*, M)`` (mode numbers), ``airy (*, M - 1)``
        (the zero of x between consecutive modes), ``edges_lo``,
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
    m, z, z_hi = _counts(omega_min, omega_max, A, B)
    modes, airy, e_lo, e_hi = _landmarks(omega_min, omega_max, A, B, delta, m, iterations)
    zeros = _zeros(omega_min, omega_max, B, z, z_hi)
    return {"modes": modes, "m": m, "airy": airy, "edges_lo": e_lo, "edges_hi": e_hi, "zeros": zeros}
