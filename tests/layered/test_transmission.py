"""Integrated transmissivity (Fourneau et al. 2024 eq. 28), its 1-D tables, absorption and the
transmission sampling probability / weights (eq. 30–33).

The reference for τ is a brute-force 2-D integration of eq. 23 over the hemisphere of
microfacet normals m (tanh-sinh in θm, Gauss–Legendre in φm up to the χ⁺ cut i·m = 0), which
never goes through the filter F_α.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from torchirid.layered.filter import filter_quadrature
from torchirid.layered.structure import RoughBraggLayer
from torchirid.layered.transmission import (
    absorption,
    integrated_transmissivity,
    transmission_probability,
    transmission_weight,
    transmissivity_lut,
)
from torchirid.lut import LUT
from torchirid.microfacet.ggx import smith_g1

from _quad import tanh_sinh

F64 = torch.float64


def t64(x):
    return torch.as_tensor(x, dtype=F64)


def tau_hemisphere(layer, theta_i, lam):
    """Eq. 23: ∫∫ (cos θd / cos θi) T(θd) G1²(θi) D(θm) sin θm dθm dφm over m with i·m > 0."""
    a = layer.alpha
    ci, si = math.cos(theta_i), math.sin(theta_i)
    g1 = 2.0 / (1.0 + math.sqrt(1.0 + a * a * math.tan(theta_i) ** 2))
    x, w = np.polynomial.legendre.leggauss(48)
    u, wu = 0.5 * (x + 1), 0.5 * w

    def f(theta_m):  # (n, p) → (n, p, W)
        cm, sm = np.cos(theta_m), np.sin(theta_m)
        # φ range where i·m ≥ 0: [0, φ*] (×2 by symmetry)
        arg = np.where(si * sm > 0, -ci * cm / np.maximum(si * sm, 1e-300), -2.0)
        phi_max = np.where(arg <= -1.0, math.pi, np.arccos(np.clip(arg, -1, 1)))
        phi = phi_max[..., None] * u
        cos_d = np.clip(si * sm[..., None] * np.cos(phi) + ci * cm[..., None], 0.0, 1.0)
        d = a * a / (math.pi * (1.0 + (a * a - 1.0) * cm**2) ** 2)  # eq. 18
        t = 1.0 - layer.reflectance(t64(lam), t64(cos_d).unsqueeze(-1)).numpy()  # (n, p, q, W)
        inner = (cos_d[..., None] * t * (wu[:, None] * phi_max[..., None, None])).sum(-2)
        return 2.0 * inner * (g1 * g1 / ci * d * sm)[..., None]

    edges = sorted({0.0, math.pi / 2, *(e for e in (a / 4, a, 3 * a, 10 * a, math.pi / 2 - theta_i)
                                         if 0 < e < math.pi / 2)})
    return tanh_sinh(f, np.array(edges), level=6)


@pytest.mark.parametrize("theta_deg", [0.0, 30.0, 65.0])
def test_tau_matches_brute_force_hemisphere_integral(theta_deg):
    layer = RoughBraggLayer(1.0, 1.5, 110.0, 75.0, 5, 0.2)
    lam = np.array([450.0, 600.0])
    theta = math.radians(theta_deg)
    ref, err = tau_hemisphere(layer, theta, lam)
    assert err.max() < 1e-9
    c = t64([math.cos(theta)])
    tau = integrated_transmissivity(t64(lam), c.unsqueeze(-1), layer, nodes=512)[0].numpy()
    np.testing.assert_allclose(tau, ref, rtol=0, atol=1e-7)
    tau_default = integrated_transmissivity(t64(lam), c.unsqueeze(-1), layer)[0].numpy()
    np.testing.assert_allclose(tau_default, ref, rtol=0, atol=1e-4)
    lut = transmissivity_lut(t64(lam), layer)
    np.testing.assert_allclose(lut(c)[0].numpy(), ref, rtol=0, atol=2e-4)


class _Clear(RoughBraggLayer):
    """A layer whose mirrors transmit everything (T = 1)."""

    def _reflectance_kernel(self, lam, cos_theta):  # (what the layered models evaluate)
        return torch.zeros(torch.broadcast_shapes(lam.shape, cos_theta.shape), dtype=cos_theta.dtype)


def test_tau_is_g1_when_transparent_and_below_g1_otherwise():
    c = torch.linspace(0.0, 1.0, 41, dtype=F64)
    lam = t64([400.0, 550.0, 700.0])
    for alpha in (0.02, 0.3, 1.0):
        g1 = smith_g1(c, alpha)
        tau = integrated_transmissivity(lam, c.unsqueeze(-1), _Clear(1.0, 1.5, 100.0, 80.0, 10, alpha), nodes=32)
        torch.testing.assert_close(tau, g1.unsqueeze(-1).expand_as(tau), rtol=1e-13, atol=1e-15)
        lut = transmissivity_lut(lam, _Clear(1.0, 1.5, 100.0, 80.0, 10, alpha), theta_d_cells=256)
        torch.testing.assert_close(lut.values, smith_g1(lut.axes["cos_theta"], alpha).unsqueeze(-1).expand_as(lut.values),
                                   rtol=1e-12, atol=1e-15)
        layer = RoughBraggLayer(1.0, 1.6, 90.0, 70.0, 30, alpha)
        tau = integrated_transmissivity(lam, c.unsqueeze(-1), layer, nodes=64)
        assert bool((tau >= 0).all()) and bool((tau <= g1.unsqueeze(-1) * (1 + 1e-14)).all())


def test_lut_layout_values_and_round_trip(tmp_path):
    layer = RoughBraggLayer(1.0, 1.5, 110.0, 75.0, 10, 0.1)
    lam = torch.linspace(420.0, 680.0, 5, dtype=F64)
    lut = transmissivity_lut(lam, layer)
    c = lut.axes["cos_theta"]
    assert lut.axis_names == ("cos_theta",) and lut.channel_shape == (5,)
    assert float(c[0]) == 0.0 and float(c[-1]) == 1.0 and c.numel() >= 361
    # at its nodes the table is the integral (product integration vs 2048-node quadrature)
    ref = integrated_transmissivity(lam, c[::7].unsqueeze(-1), layer, nodes=2048)
    torch.testing.assert_close(lut.values[::7], ref, rtol=0, atol=5e-6)
    # between nodes: linear interpolation over the incidence angle (0.25° steps)
    cm = 0.5 * (c[1:] + c[:-1])[::5]
    ref = integrated_transmissivity(lam, cm.unsqueeze(-1), layer, nodes=2048)
    assert float((lut(cm) - ref).abs().max()) < 2e-3
    path = lut.write(tmp_path / "tau.npz")
    back = LUT.read(path, builder="torchirid.layered.transmission.transmissivity_lut",
                    parameters={"cells": 10, "alpha": 0.1})
    assert back.hash == lut.hash
    torch.testing.assert_close(back(cm), lut(cm), rtol=0, atol=0)


def test_lut_is_differentiable_and_float32():
    layer = RoughBraggLayer(1.0, 1.5, 110.0, 75.0, 10, 0.1)
    lut = transmissivity_lut(torch.tensor([450.0, 550.0]), layer)
    assert lut.dtype == torch.float32
    c = torch.tensor([0.0, 0.5, 1.0], requires_grad=True)
    out = lut(c)
    assert out.shape == (3, 2) and bool(torch.isfinite(out).all())
    out.sum().backward()
    assert bool(torch.isfinite(c.grad).all())


def test_absorption_is_one_minus_g1():
    c = torch.linspace(0, 1, 11, dtype=F64)
    for alpha in (0.05, 0.5):
        a = absorption(c, alpha)
        torch.testing.assert_close(a, 1 - smith_g1(c, alpha), rtol=0, atol=1e-15)
        assert float(a[0]) == 1.0 and float(a[-1]) == 0.0
    # Appendix C: the filter integrates to G1, so 1 − Σw = A
    _, w = filter_quadrature(c[1:-1], 0.3, nodes=128, normalize=False)
    torch.testing.assert_close(1 - w.sum(-1), absorption(c[1:-1], 0.3), rtol=0, atol=1e-12)


def test_probability_and_weight_identities():
    g = torch.Generator().manual_seed(3)
    c = torch.rand(6, 4, generator=g, dtype=F64)
    alpha = t64([0.05, 0.2, 0.5, 1.0])
    g1 = smith_g1(c, alpha)
    tau = torch.rand(6, 4, 7, generator=g, dtype=F64) * g1.unsqueeze(-1)  # 0 ≤ τ ≤ G1
    for multiplexed in (True, False):
        p = transmission_probability(tau, c, alpha, multiplexed=multiplexed)
        w = transmission_weight(tau, c, alpha, multiplexed=multiplexed)
        assert p.shape == ((6, 4, 1) if multiplexed else (6, 4, 7))
        assert w.shape == ((6, 4, 7) if multiplexed else (6, 4, 1))
        assert bool(((p >= 0) & (p <= 1)).all())
        torch.testing.assert_close(w * p, tau, rtol=1e-13, atol=1e-15)  # weight × p_trans = τ
    p = transmission_probability(tau, c, alpha)
    torch.testing.assert_close(p, 2 * tau.mean(-1, keepdim=True) / (1 + g1.unsqueeze(-1)), rtol=1e-14, atol=0)
    w = transmission_weight(tau, c, alpha)
    torch.testing.assert_close(w.mean(-1), (1 + g1) / 2, rtol=1e-13, atol=0)  # eq. 33 averages to eq. 32
    torch.testing.assert_close(transmission_weight(tau, c, alpha, multiplexed=False).squeeze(-1), (1 + g1) / 2)
    # extremes: τ = G1 at normal incidence → p = 1; τ = 0 → p = 0 and multiplexed weight 0
    one = transmission_probability(t64([[1.0, 1.0]]), t64([1.0]), 0.3)
    assert float(one) == 1.0
    zero = t64([[0.0, 0.0]])
    assert float(transmission_probability(zero, t64([0.5]), 0.3)) == 0.0
    assert float(transmission_weight(zero, t64([0.5]), 0.3).abs().max()) == 0.0


def test_probability_from_real_tau_in_unit_interval():
    layer = RoughBraggLayer(1.0, 1.7, 95.0, 70.0, 20, 0.15)
    c = torch.linspace(0, 1, 21, dtype=F64)
    lam = torch.linspace(400, 700, 6, dtype=F64)
    tau = integrated_transmissivity(lam, c.unsqueeze(-1), layer, nodes=64)
    for multiplexed in (True, False):
        p = transmission_probability(tau, c, layer.alpha, multiplexed=multiplexed)
        assert bool(((p >= 0) & (p <= 1)).all())


def test_gradients():
    layer = RoughBraggLayer(1.0, 1.5, 110.0, 75.0, 6, 0.25)
    lam = t64([500.0, 640.0])
    c = t64([[0.35], [0.8]]).requires_grad_()
    assert torch.autograd.gradcheck(lambda x: integrated_transmissivity(lam, x, layer, nodes=24), (c,))
    # finite at grazing and at normal incidence; at cos θ = 1 it is the limit of the slope
    c = t64([[0.0], [1.0]]).requires_grad_()
    (g,) = torch.autograd.grad(integrated_transmissivity(lam, c, layer, nodes=256).sum(), c)
    assert bool(torch.isfinite(g).all())
    h = 1e-3
    ends = integrated_transmissivity(lam, t64([[1.0], [1.0 - h]]), layer, nodes=256).sum(-1)
    slope = float((ends[0] - ends[1]) / h)
    assert abs(float(g[1]) - slope) < 2e-2 * abs(slope)
    tau = t64([[0.2, 0.4]]).requires_grad_()
    assert torch.autograd.gradcheck(lambda t: transmission_weight(t, t64([0.6]), 0.2), (tau,))
    assert torch.autograd.gradcheck(lambda t: transmission_probability(t, t64([0.6]), 0.2), (tau,))


def test_broadcasting_and_float32():
    layer = RoughBraggLayer(1.0, 1.5, 110.0, 75.0, 10, 0.1)
    tau = integrated_transmissivity(t64([450.0, 500.0, 550.0, 600.0]), torch.rand(2, 3, 1, dtype=F64), layer, nodes=16)
    assert tau.shape == (2, 3, 4)
    c = torch.linspace(0, 1, 9)
    lam = torch.tensor([450.0, 650.0])
    t32 = integrated_transmissivity(lam, c.unsqueeze(-1), layer, nodes=64)
    t64_ = integrated_transmissivity(lam.double(), c.double().unsqueeze(-1), layer, nodes=64)
    assert t32.dtype == torch.float32 and bool(torch.isfinite(t32).all())
    assert float((t32.double() - t64_).abs().max()) < 1e-5


def test_validation_names_the_parameter():
    layer = RoughBraggLayer(1.0, 1.5, 110.0, 75.0, 10, 0.1)
    lam = t64([500.0])
    cases = [
        (lambda: integrated_transmissivity(lam, 0.5, "layer"), "layer"),
        (lambda: integrated_transmissivity(lam, 1.5, layer), "cos_theta"),
        (lambda: integrated_transmissivity(t64([-1.0]), 0.5, layer), "wavelength"),
        (lambda: integrated_transmissivity(lam, 0.5, layer, nodes=1), "nodes"),
        (lambda: integrated_transmissivity(t64([1.0, 2.0, 3.0]), t64([0.1, 0.2]), layer), "broadcast"),
        (lambda: transmissivity_lut(t64([[500.0]]), layer), "wavelength"),
        (lambda: transmissivity_lut(lam, layer, angles=1), "angles"),
        (lambda: transmissivity_lut(lam, layer, theta_d_cells=0), "theta_d_cells"),
        (lambda: absorption(-0.1, 0.1), "cos_theta"),
        (lambda: absorption(0.5, 0.0), "alpha"),
        (lambda: transmission_probability(t64(0.3), t64(0.5), 0.1), "tau"),
        (lambda: transmission_probability(t64([[-0.1]]), t64([0.5]), 0.1), "tau"),
        (lambda: transmission_probability(t64([[0.1, 0.2]]), t64([[0.5]]), 0.1), "cos_theta"),
        (lambda: transmission_weight(t64([[0.1]]), t64([2.0]), 0.1), "cos_theta"),
        (lambda: transmission_weight(t64([[0.1]]), t64([0.5]), -1.0), "alpha"),
    ]
    for call, name in cases:
        with pytest.raises(ValueError, match=name):
            call()
