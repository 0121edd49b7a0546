"""Accurate float64 quadrature on the hemisphere for the microfacet tests.

Composite Gauss–Legendre on panels graded geometrically towards the points where the
integrand is peaked (the GGX lobe at cos θ = 1 has width ~α²) or has a kink/√-type
endpoint (the horizon of ``max(0, i·m)``); each panel then holds a smooth piece.
"""

import math

import numpy as np
import torch

F64 = torch.float64


def graded_edges(a, b, points=(), levels=32, ratio=0.5):
    """Panel edges on [a, b] refined geometrically towards each of ``points`` (and kept)."""
    base = sorted({a, b, *(p for p in points if a <= p <= b)})
    edges = set(base)
    for p in points:
        if not a <= p <= b:
            continue
        k = base.index(p)
        for nb in (base[k - 1] if k > 0 else None, base[k + 1] if k + 1 < len(base) else None):
            if nb is None:
                continue
            d = nb - p
            for j in range(1, levels + 1):
                edges.add(p + d * ratio**j)
    return np.array(sorted(edges))


def gauss_panels(edges, n):
    """Nodes and weights of n-point Gauss–Legendre on each panel [edges[k], edges[k+1]]."""
    x, w = np.polynomial.legendre.leggauss(n)
    lo, hi = edges[:-1, None], edges[1:, None]
    nodes = 0.5 * (hi - lo) * x + 0.5 * (hi + lo)
    weights = 0.5 * (hi - lo) * w
    return torch.as_tensor(nodes.ravel(), dtype=F64), torch.as_tensor(weights.ravel(), dtype=F64)


def direction(theta_deg):
    """A unit vector in the xz plane at polar angle theta (degrees), as float64."""
    t = math.radians(theta_deg)
    return torch.tensor([math.sin(t), 0.0, math.cos(t)], dtype=F64)


def spherical(c, phi):
    """Unit vectors from cos θ and φ (broadcast), shape (*, 3)."""
    s = torch.sqrt((1.0 - c * c).clamp(min=0.0))
    return torch.stack(torch.broadcast_tensors(s * torch.cos(phi), s * torch.sin(phi), c), -1)


def _azimuth_bound(c, A_num, B_den):
    """φ* ∈ [0, π] with {|φ| < φ*} = {cos φ > q}, q = A_num/B_den (B_den ≥ 0; q = −∞ if B_den = 0 and A_num < 0)."""
    pos = B_den > 0
    q = torch.where(pos, A_num / torch.where(pos, B_den, torch.ones_like(B_den)), torch.where(A_num < 0, -2.0, 2.0))
    return torch.acos(q.clamp(-1.0, 1.0))


def visible_hemisphere_grid(theta_i_deg, alpha, n_c=16, n_phi=24, reflected_above=False):
    """Nodes m (N, 3) and weights dω (N,) covering {m·n > 0, m·i > 0} for i at theta_i.

    With ``reflected_above``, also only where the mirror direction o = reflect(i, m) has o·n > 0.
    For each cos θm = c these sets are |φ| < φ*(c) (m·i > 0: cos φ > −c cos θi/(√(1−c²) sin θi);
    o·n > 0: cos φ > (cos θi/(2c) − c cos θi)/(√(1−c²) sin θi)); Gauss–Legendre in φ on that
    interval (the integrands are smooth inside), panels in c graded towards the GGX peak c = 1
    and the c where a bound reaches 0 or π (θm = 90° − θi, (90° ± θi)/2), √-type points.
    """
    ti = math.radians(theta_i_deg)
    points = {1.0, math.sin(ti)}
    if reflected_above:
        points |= {math.cos((math.pi / 2 - ti) / 2), math.cos((math.pi / 2 + ti) / 2)}
    edges = graded_edges(0.0, 1.0, points=tuple(p for p in points if 0.0 < p <= 1.0))
    c, wc = gauss_panels(edges, n_c)
    s = torch.sqrt(1.0 - c * c)
    B = s * math.sin(ti)
    phi0 = _azimuth_bound(c, -c * math.cos(ti), B)
    if reflected_above:
        phi0 = torch.minimum(phi0, _azimuth_bound(c, math.cos(ti) / (2 * c) - c * math.cos(ti), B))
    x, w = np.polynomial.legendre.leggauss(n_phi)
    x, w = torch.as_tensor(x, dtype=F64), torch.as_tensor(w, dtype=F64)
    phi = phi0[:, None] * x[None, :]
    weights = wc[:, None] * phi0[:, None] * w[None, :]
    m = spherical(c[:, None], phi)
    return m.reshape(-1, 3), weights.reshape(-1)
