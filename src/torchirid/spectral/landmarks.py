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

Airy points and edges are found together (all kinds, modes, angles, parameters and
polarizations in one batch) in the phase φ = ω(A + B), where with γ = (A − B)/(A + B) and
k = δ/(2 + δ) (δ = (η1 − η2)²/(2η1η2) = Ω/2 − 1 ≥ 0) the product forms without cancellation
near |x| = 1 read

    1 − x = (2 + δ) sin²(φ/2) − δ sin²(γφ/2),   1 + x = (2 + δ) cos²(φ/2) − δ cos²(γφ/2),

and x = ((2 + δ) cos φ − δ cos γφ)/2. Each landmark has a narrow a-priori bracket: a gap
edge lies within 2 asin √k of its mode (sin²(u/2) = k sin²(…) ≤ k, u = φ − mπ) and an Airy
point within asin k of the midpoint between modes (cos φ = k cos γφ). In its bracket every
root solves one smooth equation with a simple root — for an edge the square root of the
product form, sin(u/2) = √k |sin(γφ/2 + p)| with the sign the sine has at the mode (so the
root stays simple where a gap closes) — which 5 Newton steps from the bracket midpoint, each
kept inside the bracket, solve to ~1e-14 for ordinary mirrors and within 1e-7
(relative) at grazing incidence with δ up to 10¹⁰ (:func:`_roots`). Modes are padded to the
largest count in the batch; padded entries are NaN in :func:`bragg_landmarks`'s output.
"""

from __future__ import annotations

import math

import torch

from .. import _checks

__all__ = ["bragg_landmarks"]


def dispersion_parts(omega, A, B, delta):
    """(1 − x, 1 + x) of x = cos KΛ at ω from the product forms (no cancellation near |x| = 1).

    ``omega`` in nm⁻¹ (ω = 2π/λ), ``A = n1 d1 cos θ1`` and ``B = n2 d2 cos θ2`` in nm, ``delta``
    = δ of the module docstring; all broadcast together.

    Example (n = 1 | 1.5, d = 125 | 375 nm, normal incidence: mode m = 2 at λ = 687.5 nm):
        >>> import math, torch
        >>> A, B, delta = 1.0 * 125.0, 1.5 * 375.0, (1.0 - 1.5) ** 2 / (2 * 1.0 * 1.5)
        >>> omega = 2 * math.pi / torch.tensor([687.5, 600.0], dtype=torch.float64)  # nm⁻¹
        >>> below, above = dispersion_parts(omega, A, B, delta)  # 1 − x, 1 + x
        >>> [round(v, 4) for v in below.tolist()]  # < 0: x > 1, inside the band gap
        [-0.069, 0.3604]
        >>> torch.allclose(below + above, torch.full_like(omega, 2.0))
        True
    """
    half = 0.5 * omega * (A + B)
    prod = delta * torch.sin(omega * A) * torch.sin(omega * B)
    sh, ch = torch.sin(half), torch.cos(half)
    return 2 * sh * sh + prod, 2 * ch * ch - prod


#: bisection halvings of the a-priori brackets (module docstring, at most π wide in φ) before
#: the Newton steps of :func:`_roots` (none needed: Newton kept in the bracket converges)
HALVINGS = 0
#: Newton steps after the halvings: every landmark of a stress set with grazing angles
#: (cos θ down to 1e-6) and δ up to 10¹⁰ within 1e-7 (relative) of its converged position,
#: of Fourneau's Fig. 4 grid within 1e-14
NEWTON_STEPS = 5


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
            # counts over finite mirrors (a NaN or ∞ mirror's landmarks come out NaN at any count);
            # the two spans may have different shapes (L = A + B vs B): one max each, one sync
            spans = [(m_hi - m_lo).nan_to_num(0.0, 0.0, 0.0).amax(), (z_hi - z_lo).nan_to_num(0.0, 0.0, 0.0).amax()]
            count, zc = (int(v) for v in torch.stack(spans).clamp(min=0).tolist())
        else:
            count, zc = 0, 0
    m = m_lo.unsqueeze(-1) + torch.arange(count + 1, dtype=L.dtype, device=L.device)  # (*, M) mode numbers
    z = z_lo.unsqueeze(-1) + torch.arange(zc + 1, dtype=L.dtype, device=L.device)
    return m, z, z_hi


def _roots(A, B, delta, m, halvings=HALVINGS, steps=NEWTON_STEPS):
    """Gap edges and Airy points between the consecutive modes ``m (*, M)`` of :func:`_counts`
    (no data-dependent sizes or host syncs: usable inside ``torch.compile(fullgraph=True)``).

    Returns ω (nm⁻¹) of ``(up, airy, down)``, each ``(*, M − 1)``: for modes m_j, m_{j+1}
    the upper edge of gap m_j, the Airy point between them and the lower edge of gap m_{j+1}
    (a closed gap's edges are its mode; the "gap" of m = 0, ω = 0, has its upper edge at 0).

    Every root has one equation F(x) = sin(x + c₁) + K sin(β₂x + c₂) = 0 in its own variable x
    (a multiple of the phase φ = ω(A + B)), with F ≤ 0 left of the root and ≥ 0 right of it in
    its a-priori bracket (module docstring):

    * upper edge of gap M (u = φ − Mπ ≥ 0): sin(u/2) = √k |S(φ)|, S = sin(γφ/2 + p_M)
      (p_M = π/2 for odd M) — the square root of (2 + δ) sin²(φ/2 + p_M) = δ sin²(γφ/2 + p_M),
      i.e. 1 ∓ x = 0; |S| is taken with the sign S has at the mode, which it keeps up to the
      edge (where S = 0, 1 ∓ x > 0), so F is smooth and its root simple even where the gap
      closes (no double root);
    * lower edge (u = Mπ − φ): the same (x = ψ = −φ/2; upper edges: x = φ/2);
    * Airy point, φ = (m + ½)π + v: sin v = (−1)^(m+1) k cos γφ, i.e. cos KΛ = 0 (x = φ).

    ``halvings`` bisection steps on the sign of F shrink every bracket by 2^halvings, then
    ``steps`` Newton steps start at the bracket midpoint, each kept inside the bracket.
    """
    half = 0.5 * math.pi
    L = A + B
    gamma = (A - B) / L
    k = delta / (2 + delta)
    rk = torch.sqrt(k)
    # the root axis first, (3(M − 1), *): the batch axes, long and contiguous, are innermost
    base = m.movedim(-1, 0) * math.pi  # (M, *) mode phases Mπ
    p = torch.remainder(m.movedim(-1, 0), 2) * half  # p_M: π/2 for odd M
    rho = torch.sign(torch.sin(torch.addcmul(p, gamma, base, value=0.5)))  # sign of S at each mode
    lo_m, hi_m, p_lo, p_hi = base[:-1], base[1:], p[:-1], p[1:]
    j = lo_m.shape[0]
    # each root in its own variable x, with F(x) = sin(x + c₁) + K sin(β₂x + c₂): upper edges in
    # ψ = φ/2, Airy points in φ, lower edges in ψ = −φ/2 (their equation then reads like an
    # upper edge's and the bracket starts exactly at the mode: a closed gap's edges land on it
    # bit for bit); ω = x / (L·scale), scale = ½, 1, −½
    x_up, x_airy, x_down = 0.5 * lo_m, lo_m + half, -0.5 * hi_m
    w_edge = torch.asin(rk).expand_as(lo_m)  # half the edge bracket in φ
    w_airy = torch.asin(k).expand_as(lo_m)
    a = torch.cat([x_up, x_airy - w_airy, x_down])  # the root is in [a, a + h]
    h = torch.cat([w_edge, 2 * w_airy, w_edge])
    c1 = -torch.cat([x_up, x_airy, x_down])
    shape = (3 * j,) + (1,) * gamma.dim()
    scale = torch.tensor([0.5] * j + [1.0] * j + [-0.5] * j, dtype=a.dtype, device=a.device).view(shape)
    beta2 = torch.sign(scale) * gamma  # S = sin(γψ + p) for the edges (γ/2 per unit of φ), cos γφ for Airy points
    c2 = torch.cat([p_lo, torch.full_like(p_lo, half), p_hi])
    # K: −√k ρ (edges), (−1)^m k (Airy points: 1 − 4p/π = ±1)
    rk = -rk
    K = torch.cat([rk * rho[:-1], k * (1 - p_lo * (4 / math.pi)), rk * rho[1:]])

    def F(x):
        return torch.addcmul(torch.sin(x + c1), K, torch.sin(torch.addcmul(c2, beta2, x)))

    for i in range(halvings):
        # the root is in [mid, mid + h/2^(i+1)] where F(mid) < 0, else in [a, mid] (a kept exactly)
        a = torch.addcmul(a, h, 1 - torch.sign(F(torch.add(a, h, alpha=0.5 ** (i + 1)))), value=0.5 ** (i + 2))
    if halvings:
        h = h * 0.5 ** halvings
    b = a + h
    x = torch.add(a, h, alpha=0.5)
    if steps:
        # the four phases x + c₁, β₂x + c₂ and the same + π/2 (F' from sines too): one addcmul and
        # one sine per step
        Kb2 = K * beta2
        offsets = torch.stack([c1, c2, c1 + half, c2 + half])  # (4, 3(M − 1), *)
        slopes = torch.stack([torch.ones_like(beta2), beta2]).repeat((2,) + (1,) * beta2.dim())
    for _ in range(steps):
        s1, s2, c1_, c2_ = torch.sin(torch.addcmul(offsets, slopes, x)).unbind(0)  # sines; cosines of t₁, t₂
        Fx, dF = torch.addcmul(s1, K, s2), torch.addcmul(c1_, Kb2, c2_)
        x = torch.clamp(torch.addcdiv(x, Fx, dF, value=-1), a, b)
    if steps:  # guard: 0/0 (F' = 0 at a root) leaves the bracket midpoint
        x = torch.where(torch.isnan(x), torch.add(a, h, alpha=0.5), x)
    roots = (x / (scale * L)).movedim(0, -1)
    return roots[..., :j], roots[..., j:2 * j], roots[..., 2 * j:]  # (not split: j = 0 for an empty batch)


def _zeros(omega_min, omega_max, B, z, z_hi):
    """Zero points ω_z = zπ/B (eq. 12) of the numbers ``z`` of :func:`_counts`, NaN-padded."""
    safe_B = torch.where(B > 0, B, torch.ones_like(B)).unsqueeze(-1)
    zeros = z * math.pi / safe_B
    keep = (zeros >= omega_min) & (zeros <= omega_max) & (z <= z_hi.unsqueeze(-1)) & (B.unsqueeze(-1) > 0)
    return torch.where(keep, zeros, float("nan"))


def clamped_landmarks(omega_min, omega_max, A, B, delta, m, z, halvings=HALVINGS, steps=NEWTON_STEPS):
    """``(airy, edges_lo, edges_hi, zeros)`` as :func:`bragg_landmarks`, but every landmark
    clamped into [ω_min, ω_max] instead of NaN-padded (what lies outside, or is padding, sits
    on a range end: zero-width boxes for :mod:`torchirid.spectral.piecewise`); the outer
    edges of the gaps around the first and last modes, not searched, are the range ends."""
    up, airy, down = _roots(A, B, delta, m, halvings, steps)
    end = up.new_full(up.shape[:-1] + (1,), math.inf)  # (not up[..., :1]: no roots when M = 1)
    edges_hi = torch.cat([up, end], dim=-1).clamp(omega_min, omega_max)
    edges_lo = torch.cat([-end, down], dim=-1).clamp(omega_min, omega_max)
    # z beyond the range, and B = 0 (no zero points), land above ω_max
    zeros = (z * math.pi / B.unsqueeze(-1).clamp(min=torch.finfo(B.dtype).tiny)).clamp(omega_min, omega_max)
    return airy.clamp(omega_min, omega_max), edges_lo, edges_hi, zeros


def bragg_landmarks(omega_min, omega_max, A, B, delta, *, iterations: int = HALVINGS,
                    newton_steps: int = NEWTON_STEPS):
    r"""Modes, Airy points, band-gap edges and zero points of a Bragg mirror in [ω_min, ω_max].

    Args:
        omega_min, omega_max: the ω range (nm⁻¹), Python floats.
        A, B: optical thicknesses n1 d1 cos θ1 and n2 d2 cos θ2 (nm), real ≥ 0, any
            broadcasting batch shape (angles × parameters × polarizations).
        delta: Ω/2 − 1 = (η1 − η2)²/(2 η1 η2) ≥ 0 for the polarization (batch-broadcast).
        iterations: bisection halvings of the a-priori brackets (module docstring) before
            ``newton_steps`` Newton steps (each kept in the bracket): the defaults 0 and 5 put
            every landmark within 1e-7 (relative) of its exact position on a stress set with
            grazing angles (cos θ down to 1e-6) and δ up to 10¹⁰, ~1e-12 for ordinary mirrors.

    Returns:
        dict of tensors, batch shape ``(*,)`` first:
        ``modes (*, M)`` (ω_m, NaN-padded), ``m (*, M)`` (mode numbers), ``airy (*, M - 1)``
        (the zero of x between consecutive modes), ``edges_lo``,
        ``edges_hi (*, M)`` (the gap around each mode), ``zeros (*, Z)`` (eq. 12; NaN-padded).
        Every landmark returned lies in [ω_min, ω_max] or is NaN (gaps and Airy points are
        found on the modes just outside the range too and clipped, so partial gaps at the
        range ends are complete; a closed gap has both edges at its mode).

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
    for name, v in (("iterations", iterations), ("newton_steps", newton_steps)):
        _checks.check_int(v, name, 0)
    A, B, delta = torch.broadcast_tensors(torch.as_tensor(A), torch.as_tensor(B), torch.as_tensor(delta))
    m, z, z_hi = _counts(omega_min, omega_max, A, B)
    up, airy, down = _roots(A, B, delta, m, iterations, newton_steps)
    nan = float("nan")
    modes = m * math.pi / (A + B).unsqueeze(-1)  # ω_m (eq. 13); m = 0 is ω = 0
    real = m >= 1
    end = torch.full_like(modes[..., :1], math.inf)
    # the gaps around the first and last modes (at or beyond the range ends) extend past them:
    # their outer edges, not searched, are clipped to the range
    e_hi = torch.where(real, torch.cat([up, end], dim=-1).clamp(omega_min, omega_max), nan)
    e_lo = torch.where(real, torch.cat([-end, down], dim=-1).clamp(omega_min, omega_max), nan)

    def in_range(w, ok=True):
        return torch.where((w >= omega_min) & (w <= omega_max) & ok, w, nan)

    zeros = _zeros(omega_min, omega_max, B, z, z_hi)
    return {"modes": in_range(modes, real), "m": m, "airy": in_range(airy), "edges_lo": e_lo, "edges_hi": e_hi,
            "zeros": zeros}
