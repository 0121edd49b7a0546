"""Single-reflection BRDF (Fourneau et al. 2024 eq. 34–35) against independent evaluations."""

import math

import pytest
import torch

from torchirid.layered import LayeredBragg, RoughBraggLayer
from torchirid.layered.tables import coating_reflectance, reflectance_lut
from torchirid.layered.importance_sampling import (
    layer_reflection_probabilities,
    sample_single_reflection,
    single_reflection_pdf,
)
from torchirid.layered.single_reflection import single_reflection_brdf
from torchirid.optics import bragg_reflectance

F64 = torch.float64
LAM = torch.tensor([420.0, 510.0, 633.0], dtype=F64)
A = RoughBraggLayer(1.0, 1.5, 250.0, 250.0, 10, 0.1)
B = RoughBraggLayer(1.0, 1.5, 494.0, 494.0, 10, 0.05)


def _dir(theta_deg, phi_deg):
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return torch.tensor([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)], dtype=F64)


def _pairs():
    wi = torch.stack([_dir(t, 0.0) for t in (0.0, 20.0, 45.0, 70.0, 85.0)])
    wo = torch.stack([_dir(t, p) for t, p in ((0.0, 0.0), (25.0, 180.0), (40.0, 170.0), (60.0, 90.0), (80.0, 200.0))])
    return wi[:, None, :].expand(5, 5, 3), wo[None, :, :].expand(5, 5, 3)


def _paper_d(cos_m, alpha):
    # eq. 18 written with tan (independent of the library's tan-free form)
    tan2 = (1 - cos_m**2) / cos_m**2
    return alpha**2 / (math.pi * cos_m**4 * (alpha**2 + tan2) ** 2)


def _paper_g1(cos_v, alpha):
    tan2 = (1 - cos_v**2) / cos_v**2
    return 2 / (1 + torch.sqrt(1 + alpha**2 * tan2))


def _eq17(layer, wi, wo, lam):
    h = wi + wo
    h = h / h.norm(dim=-1, keepdim=True)
    ci, co = wi[..., 2], wo[..., 2]
    R = bragg_reflectance(lam, (wi * h).sum(-1, keepdim=True), layer.n1, layer.n2, layer.d1, layer.d2, layer.cells)
    D = _paper_d(h[..., 2], layer.alpha)
    G = _paper_g1(ci, layer.alpha) * _paper_g1(co, layer.alpha)
    return (D * G / (4 * ci * co)).unsqueeze(-1) * R


def test_single_layer_is_the_microfacet_brdf():
    wi, wo = _pairs()
    f = single_reflection_brdf(LAM, wi, wo, LayeredBragg([B]))
    assert f.shape == (5, 5, 3)
    ref = _eq17(B, wi, wo, LAM)
    torch.testing.assert_close(f, ref, rtol=1e-10, atol=0)


def test_transparent_layer_filters_by_g1():
    # a layer of n2 = n1 reflects nothing and transmits τ = ∫ F_α dθd = G1 (appendix C)
    clear = RoughBraggLayer(1.0, 1.0, 100.0, 100.0, 3, 0.3)
    wi, wo = _pairs()
    f = single_reflection_brdf(LAM, wi, wo, LayeredBragg([clear, A]))
    g1 = _paper_g1(wi[..., 2], 0.3) * _paper_g1(wo[..., 2], 0.3)
    ref = g1.unsqueeze(-1) * _eq17(A, wi, wo, LAM)
    torch.testing.assert_close(f, ref, rtol=2e-4, atol=1e-12)


def test_lambertian_base_under_a_transparent_layer():
    clear = RoughBraggLayer(1.0, 1.0, 100.0, 100.0, 3, 0.2)
    wi, wo = _pairs()
    f = single_reflection_brdf(LAM, wi, wo, LayeredBragg([clear], base_albedo=0.5))
    ref = 0.5 / math.pi * _paper_g1(wi[..., 2], 0.2) * _paper_g1(wo[..., 2], 0.2)
    torch.testing.assert_close(f, ref.unsqueeze(-1).expand_as(f), rtol=2e-4, atol=1e-12)


def test_coating_factor_and_reciprocity():
    coated = RoughBraggLayer(1.35, 1.5, 250.0, 250.0, 10, 0.1)
    s = LayeredBragg([coated, coated], base_albedo=0.5)
    wi, wo = _pairs()
    f = single_reflection_brdf(LAM, wi, wo, s)
    g = single_reflection_brdf(LAM, wo, wi, s)
    torch.testing.assert_close(f, g, rtol=1e-9, atol=1e-14)
    # one coated layer: T_c(i) T_c(o) f_17(i', o') / n1²
    one = single_reflection_brdf(LAM, wi, wo, LayeredBragg([coated]))
    n = 1.35

    def refr(w):
        t = w[..., :2] / n
        return torch.cat([t, torch.sqrt(1 - (t * t).sum(-1, keepdim=True))], -1)

    Tc = (1 - coating_reflectance(wi[..., 2], n)) * (1 - coating_reflectance(wo[..., 2], n))
    ref = (Tc / n**2).unsqueeze(-1) * _eq17(coated, refr(wi), refr(wo), LAM)
    torch.testing.assert_close(one, ref, rtol=1e-10, atol=0)


def test_lut_variant_close_to_exact():
    wi, wo = _pairs()
    s = LayeredBragg([A, B], base_albedo=0.5)
    exact = single_reflection_brdf(LAM, wi, wo, s)
    approx = single_reflection_brdf(LAM, wi, wo, s, reflectance="lut")
    err = ((approx - exact).abs() / exact.abs().clamp_min(1e-3)).max()
    assert err < 2e-3


def test_reflectance_lut_nodes_exact():
    lut = reflectance_lut(LAM, A, angles=91)
    theta = lut.axes["theta"]
    ref = bragg_reflectance(LAM, torch.cos(theta).unsqueeze(-1), 1.0, 1.5, 250.0, 250.0, 10)
    torch.testing.assert_close(lut.values, ref, rtol=0, atol=1e-15)


def test_layer_probabilities_sum_to_one():
    c = torch.linspace(0.05, 1.0, 7, dtype=F64)
    p = layer_reflection_probabilities(LAM, c, LayeredBragg([A, B], base_albedo=0.5))
    assert p.shape == (7, 3)
    assert bool((p >= 0).all())
    torch.testing.assert_close(p.sum(-1), torch.ones(7, dtype=F64))


@pytest.mark.parametrize("coat", [1.0, 1.35])
def test_sampling_is_unbiased(coat):
    # E[f cos θo / pdf] over the sampler = ∫ f cos θo dωo (quadrature over the hemisphere)
    la = RoughBraggLayer(coat, 1.5, 250.0, 250.0, 10, 0.3)
    lb = RoughBraggLayer(coat, 1.5, 494.0, 494.0, 10, 0.4)
    s = LayeredBragg([la, lb], base_albedo=0.5)
    wi = _dir(35.0, 0.0).to(F64)
    g = torch.Generator().manual_seed(3)
    u = torch.rand(20000, 3, generator=g, dtype=F64)
    wo, pdf = sample_single_reflection(LAM, wi.expand(20000, 3), s, u)
    ok = pdf > 0
    f = single_reflection_brdf(LAM, wi.expand(int(ok.sum()), 3), wo[ok], s)
    est = f * (wo[ok][:, 2] / pdf[ok]).unsqueeze(-1)
    mean = est.sum(0) / 20000
    se = torch.cat([est, torch.zeros(20000 - est.shape[0], 3, dtype=F64)]).std(0) / math.sqrt(20000)
    # quadrature: θ in Gauss–Legendre, φ uniform
    xt, wt = _gauss(200, 0.0, math.pi / 2)
    nphi = 200
    phi = torch.arange(nphi, dtype=F64) * 2 * math.pi / nphi
    T, P = torch.meshgrid(xt, phi, indexing="ij")
    wq = torch.stack([torch.sin(T) * torch.cos(P), torch.sin(T) * torch.sin(P), torch.cos(T)], -1)
    fq = single_reflection_brdf(LAM, wi.expand_as(wq), wq, s)
    w = (wt[:, None] * (2 * math.pi / nphi) * torch.sin(T) * torch.cos(T)).unsqueeze(-1)
    albedo = (fq * w).sum((0, 1))
    assert bool(((mean - albedo).abs() < 4 * se + 2e-3 * albedo).all()), (mean, albedo, se)
    # the density integrates to at most one (trapped / absorbed samples are lost)
    pq = single_reflection_pdf(LAM, wi.expand_as(wq), wq, s)
    total = (pq * w[..., 0] / torch.cos(T).clamp_min(1e-300)).sum()
    assert 0.5 < float(total) <= 1.0 + 1e-3


def _gauss(n, a, b):
    import numpy as np

    x, w = np.polynomial.legendre.leggauss(n)
    x = torch.as_tensor(x, dtype=F64)
    w = torch.as_tensor(w, dtype=F64)
    return 0.5 * (b - a) * x + 0.5 * (b + a), 0.5 * (b - a) * w


def test_gradients_finite_at_normal_incidence_and_grazing():
    s = LayeredBragg([A, B], base_albedo=0.5)
    n = torch.tensor([0.0, 0.0, 1.0], dtype=F64)
    wi = n.clone().requires_grad_(True)
    f = single_reflection_brdf(LAM, wi, n, s).sum()
    f.backward()
    assert torch.isfinite(wi.grad).all()
    graze = torch.tensor([1.0, 0.0, 0.0], dtype=F64, requires_grad=True)
    f = single_reflection_brdf(LAM, graze, n, s)
    assert torch.isfinite(f).all() and bool((f == 0).all())
    f.sum().backward()
    assert torch.isfinite(graze.grad).all()


def test_validation():
    w = torch.tensor([0.0, 0.0, 1.0], dtype=F64)
    with pytest.raises(ValueError, match="wi"):
        single_reflection_brdf(LAM, torch.tensor([0.0, 0.0, -1.0], dtype=F64), w, LayeredBragg([A]))
    with pytest.raises(ValueError, match="wo"):
        single_reflection_brdf(LAM, w, torch.ones(2, dtype=F64), LayeredBragg([A]))
    with pytest.raises(ValueError, match="wavelength"):
        single_reflection_brdf(torch.tensor([-1.0], dtype=F64), w, w, LayeredBragg([A]))
    with pytest.raises(ValueError, match="structure"):
        single_reflection_brdf(LAM, w, w, "A")
    with pytest.raises(ValueError, match="n1"):
        LayeredBragg([A, RoughBraggLayer(1.35, 1.5, 250.0, 250.0, 10, 0.1)])
    with pytest.raises(ValueError, match="alpha"):
        RoughBraggLayer(1.0, 1.5, 250.0, 250.0, 10, 0.0)
    with pytest.raises(ValueError, match="base_albedo"):
        LayeredBragg([A], base_albedo=1.5)


def test_layer_with_another_host_uses_appendix_d():
    # mirrors (n2 | n1) × N standing in air (n_incident = 1 ≠ n1): the layer's R is appendix D's
    layer = RoughBraggLayer(1.56, 1.68, 120.0, 110.0, 12, 0.05, n_incident=1.0)
    s = LayeredBragg([layer])
    assert not s.coated and s.n_coating == 1.0
    wi, wo = _pairs()
    h = wi + wo
    h = h / h.norm(dim=-1, keepdim=True)
    R = bragg_reflectance(LAM, (wi * h).sum(-1, keepdim=True), 1.56, 1.68, 120.0, 110.0, 12, n_incident=1.0)
    D = _paper_d(h[..., 2], 0.05)
    G = _paper_g1(wi[..., 2], 0.05) * _paper_g1(wo[..., 2], 0.05)
    ref = (D * G / (4 * wi[..., 2] * wo[..., 2])).unsqueeze(-1) * R
    torch.testing.assert_close(single_reflection_brdf(LAM, wi, wo, s), ref, rtol=1e-10, atol=0)
    with pytest.raises(ValueError, match="n_incident"):
        RoughBraggLayer(1.56, 1.68, 120.0, 110.0, 12, 0.05, n_incident=-1.0)
