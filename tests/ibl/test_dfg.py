import math

import numpy as np
import pytest
import torch

from torchirid.ibl import dfg_lut
from torchirid.ibl.dfg import DFG_BUILDER
from torchirid.microfacet import smith_g1

F64 = torch.float64


def _brute(cv, alpha, n=600):
    """(A, B) by a tensor-product rule over the half vector h (GGX-D warp in cos θh, Gauss–Legendre × midpoint φ)."""
    x, w = np.polynomial.legendre.leggauss(n)
    u1, w1 = torch.tensor((x + 1) / 2), torch.tensor(w / 2)
    phi = (torch.arange(n, dtype=F64) + 0.5) / n * 2 * math.pi
    ch = torch.sqrt((1 - u1) / (1 + (alpha ** 2 - 1) * u1))[:, None]  # pdf(h) = D(h) cos θh
    sh = torch.sqrt(1 - ch ** 2)
    h = torch.stack([sh * torch.cos(phi), sh * torch.sin(phi), ch.expand(-1, n)], -1)
    v = torch.tensor([math.sqrt(1 - cv * cv), 0.0, cv], dtype=F64)
    vh = (h * v).sum(-1)
    l = 2 * vh[..., None] * h - v
    ok = (vh > 0) & (l[..., 2] > 0)
    g = smith_g1(torch.tensor(cv, dtype=F64), alpha) * torch.where(
        ok, smith_g1(l[..., 2].clamp(0, 1), alpha), torch.zeros_like(vh))
    f = g * vh.clamp(min=0) / (cv * ch)  # D G (v·h)/cosθv per dω_h, over pdf D cos θh
    fc = (1 - vh.clamp(0, 1)) ** 5
    W = w1[:, None] / n
    return torch.stack([(W * f * (1 - fc)).sum(), (W * f * fc).sum()])


def test_matches_brute_force_quadrature():
    lut = dfg_lut(5, samples=1024)
    assert lut.builder == DFG_BUILDER and lut.channel_shape == (2,)
    for cv, al in [(1.0, 0.5), (0.5, 0.25), (0.25, 0.75), (0.75, 1.0)]:
        got = lut.values[round(cv * 4), round(al * 4)]
        assert (got - _brute(cv, al)).abs().max() < 1e-3


def test_mirror_limit_and_interpolation():
    lut = dfg_lut(9, samples=256)
    c = torch.tensor([1.0, 0.5], dtype=F64)
    ab = lut(cos_theta_o=c, alpha=torch.zeros(2, dtype=F64))
    assert torch.allclose(ab[:, 0] + ab[:, 1], torch.ones(2, dtype=F64), atol=1e-4)  # mirror: F0 A + B at F0 = 1
    assert torch.allclose(ab[1, 1], torch.tensor(0.5 ** 5, dtype=F64), atol=1e-4)  # Schlick's F_c = (1 − cos)^5
    assert (lut.values >= 0).all() and (lut.values.sum(-1) <= 1 + 1e-12).all()
    assert dfg_lut(4, samples=16, dtype=torch.float32).values.dtype == torch.float32


@pytest.mark.parametrize("kwargs,name", [(dict(resolution=1), "resolution"), (dict(samples=0), "samples"),
                                         (dict(resolution=2.5), "resolution"), (dict(dtype=torch.int32), "dtype")])
def test_bad_input_raises(kwargs, name):
    with pytest.raises(ValueError, match=name):
        dfg_lut(**kwargs)
