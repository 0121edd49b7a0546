"""The reflectance-agnostic GGX microfacet BRDF (Fourneau et al. 2024 eq. 17)."""

import math

import numpy as np
import pytest
import torch

from microfacet_quadrature import F64, direction, gauss_panels, graded_edges, spherical, visible_hemisphere_grid
from torchirid.microfacet import MicrofacetBRDF, microfacet_brdf, reflect, sample_ggx_vndf, smith_g1

N = torch.tensor([0.0, 0.0, 1.0], dtype=F64)


def schlick(c):
    """A smooth, cosine-dependent reflectance (Schlick, F0 = 0.04) for the tests."""
    return 0.04 + 0.96 * (1.0 - c) ** 5


def random_pairs(n, seed):
    g = torch.Generator().manual_seed(seed)
    c = torch.rand(n, 2, generator=g, dtype=F64) * 0.97 + 0.02
    phi = torch.rand(n, 2, generator=g, dtype=F64) * 2 * math.pi
    return spherical(c[:, 0], phi[:, 0]), spherical(c[:, 1], phi[:, 1])


def test_matches_paper_equations_17_to_19():
    """Eq. 17 with D and G1 in the paper's tan θ forms (numpy, independent of the cos forms)."""
    wi, wo = random_pairs(300, 0)
    alpha = torch.rand(300, dtype=F64, generator=torch.Generator().manual_seed(1)) * 0.9 + 0.02
    i, o, a = wi.numpy(), wo.numpy(), alpha.numpy()
    h = (i + o) / np.linalg.norm(i + o, axis=-1, keepdims=True)
    tan2 = lambda c: (1 - c * c) / (c * c)  # noqa: E731
    d = a**2 / (np.pi * h[:, 2] ** 4 * (a**2 + tan2(h[:, 2])) ** 2)
    g1 = lambda c: 2 / (1 + np.sqrt(1 + a**2 * tan2(c)))  # noqa: E731
    cos_d = np.sum(i * h, -1)
    r = 0.04 + 0.96 * (1 - cos_d) ** 5
    expected = d * g1(i[:, 2]) * g1(o[:, 2]) * r / (4 * i[:, 2] * o[:, 2])
    np.testing.assert_allclose(microfacet_brdf(wi, wo, alpha, schlick).numpy(), expected, rtol=1e-11)


def test_normal_incidence_value():
    a = torch.tensor([0.01, 0.3, 1.0], dtype=F64)
    expected = 1.0 / (4 * math.pi * a * a)  # D(n) G1(1)² / 4
    torch.testing.assert_close(microfacet_brdf(N, N, a), expected, rtol=1e-14, atol=0)


def test_reciprocity():
    wi, wo = random_pairs(200, 2)
    torch.testing.assert_close(microfacet_brdf(wi, wo, 0.3, schlick), microfacet_brdf(wo, wi, 0.3, schlick),
                               rtol=1e-13, atol=0)


def test_zero_at_and_below_the_horizon():
    wi = direction(30.0)
    below = torch.stack([direction(95.0), torch.tensor([0.0, 1.0, 0.0], dtype=F64), -wi, direction(180.0)])
    assert torch.all(microfacet_brdf(wi, below, 0.3, schlick) == 0)
    assert torch.all(microfacet_brdf(below, wi, 0.3, schlick) == 0)
    # the reflectance callable only ever sees cosines in [0, 1]
    seen = []
    microfacet_brdf(wi, below, 0.3, lambda c: seen.append(c) or torch.ones_like(c))
    assert torch.all((seen[0] >= 0) & (seen[0] <= 1))


def test_white_furnace_is_bounded_near_grazing():
    """f_r cos θo at grazing wo stays finite and tends to 0 (G1(o) → 0)."""
    wi = direction(20.0)
    wo = torch.stack([direction(-t) for t in (89.0, 89.999, 89.9999999)])
    v = microfacet_brdf(wi, wo, 0.3) * wo[:, 2]
    assert torch.isfinite(v).all() and torch.all(v[1:] < v[:-1]) and v[-1] < 1e-6


def _furnace_halfvector_quadrature(theta, alpha):
    """∫ f_r(i, o) cos θo dωo with o = reflect(i, h), dωo = 4 (i·h) dωh, over the h with
    i·h > 0 and o·n > 0 (the BRDF is 0 elsewhere)."""
    wi = direction(theta)
    h, w = visible_hemisphere_grid(theta, alpha, reflected_above=True)
    o = reflect(wi, h)
    return torch.sum(w * microfacet_brdf(wi, o, alpha) * o[:, 2] * 4 * (wi * h).sum(-1)).item()


def _furnace_direct_quadrature(theta, alpha, n_phi=512):
    """∫ f_r(i, o) cos θo dωo on a (cos θo, φo) grid: Gauss–Legendre panels graded towards the
    specular cosine and the horizon, trapezoid (spectral for a periodic integrand) in φo."""
    wi = direction(theta)
    c, wc = gauss_panels(graded_edges(0.0, 1.0, points=(0.0, math.cos(math.radians(theta))), levels=12), 16)
    phi = torch.arange(n_phi, dtype=F64) * (2 * math.pi / n_phi)
    o = spherical(c[:, None], phi[None, :]).reshape(-1, 3)
    w = (wc[:, None] * (2 * math.pi / n_phi)).expand(-1, n_phi).reshape(-1)
    return torch.sum(w * microfacet_brdf(wi, o, alpha) * o[:, 2]).item()


@pytest.mark.parametrize("theta,alpha", [(0.0, 0.01), (0.0, 0.3), (45.0, 0.1), (60.0, 0.5), (80.0, 1.0)])
def test_white_furnace_equals_vndf_expectation_of_g1(theta, alpha):
    """With R = 1: ∫ f_r cos θo dωo = E_{m~VNDF}[G1(o(m))] ≤ 1 (o = reflect(i, m), 0 if o·n ≤ 0)."""
    quad = _furnace_halfvector_quadrature(theta, alpha)
    wi = direction(theta)
    m = sample_ggx_vndf(wi, alpha, torch.rand(100_000, 2, dtype=F64, generator=torch.Generator().manual_seed(7)))
    o = reflect(wi, m)
    g1o = torch.where(o[:, 2] > 0, smith_g1(o[:, 2].clamp(min=0), alpha), torch.zeros_like(o[:, 2]))
    mc, sd = g1o.mean().item(), g1o.std().item() / math.sqrt(g1o.numel())
    assert quad <= 1.0 + 1e-12
    assert abs(quad - mc) < 5 * sd + 1e-5, (quad, mc, sd)
    if alpha <= 0.01 and theta == 0.0:
        assert quad > 0.999  # a near-mirror loses almost nothing to masking


@pytest.mark.parametrize("theta,alpha", [(0.0, 1.0), (30.0, 0.5), (70.0, 0.7)])
def test_white_furnace_direct_quadrature_agrees(theta, alpha):
    """The direct ∫ dωo and the half-vector change of variables agree (checks the 1/(4|i·n||o·n|)
    normalisation and the Jacobian independently of sampling)."""
    assert abs(_furnace_direct_quadrature(theta, alpha) - _furnace_halfvector_quadrature(theta, alpha)) < 1e-9


def test_furnace_closed_form_alpha_1_normal_incidence():
    """α = 1, θi = 0: VNDF = cos θm/π, G1(o) = 2 cos θo/(cos θo + 1), cos θo = cos 2θm, so
    ∫ f_r cos θo dωo = 2 ∫₀^{π/4} (2 sin θ cos θ − tan θ) dθ = 1 − ln 2."""
    assert abs(_furnace_halfvector_quadrature(0.0, 1.0) - (1.0 - math.log(2.0))) < 1e-12
    assert abs(_furnace_direct_quadrature(0.0, 1.0) - (1.0 - math.log(2.0))) < 1e-12


def test_furnace_decreases_with_roughness():
    vals = [_furnace_halfvector_quadrature(60.0, a) for a in (0.01, 0.1, 0.5, 1.0)]
    assert 1.0 > vals[0] > vals[1] > vals[2] > vals[3]


def test_furnace_normal_incidence_closed_form_bound():
    """At θi = 0, o·n > 0 needs θm < 45°: P_VNDF(tan²θm < 1) = 1/(1 + α²) bounds the albedo."""
    for a in (0.3, 0.5, 1.0):
        val = _furnace_halfvector_quadrature(0.0, a)
        assert 0.5 / (1 + a * a) < val < 1.0 / (1 + a * a)


def test_spectral_reflectance_adds_last_axis():
    wi, wo = random_pairs(7, 3)
    f0 = torch.tensor([0.02, 0.04, 0.5, 1.0], dtype=F64)
    spectral = lambda c: f0 + (1 - f0) * (1 - c[..., None]) ** 5  # noqa: E731  (*, W)
    out = microfacet_brdf(wi, wo, 0.2, spectral)
    assert out.shape == (7, 4)
    for k in range(4):
        scalar = lambda c: f0[k] + (1 - f0[k]) * (1 - c) ** 5  # noqa: E731
        torch.testing.assert_close(out[:, k], microfacet_brdf(wi, wo, 0.2, scalar), rtol=1e-14, atol=0)
    below = torch.stack([direction(30.0), direction(100.0)])
    out = microfacet_brdf(direction(20.0), below, 0.2, spectral)
    assert out.shape == (2, 4) and torch.all(out[1] == 0) and torch.all(out[0] > 0)


def test_with_bragg_reflectance():
    """The paper's use: R = Yeh's Bragg reflectance, spectral (Fourneau et al. 2024 §4.1)."""
    from torchirid.optics.bragg import bragg_reflectance

    wl = torch.linspace(400.0, 700.0, 5, dtype=F64)
    R = lambda c: bragg_reflectance(wl, c[..., None], 1.0, 1.5, 100.0, 150.0, 10)  # noqa: E731
    wi, wo = random_pairs(3, 4)
    out = microfacet_brdf(wi, wo, 0.1, R)
    assert out.shape == (3, 5) and torch.all(out >= 0) and torch.isfinite(out).all()
    plain = microfacet_brdf(wi, wo, 0.1)
    cos_d = (wi * (wi + wo) / (wi + wo).norm(dim=-1, keepdim=True)).sum(-1)
    torch.testing.assert_close(out, plain[:, None] * R(cos_d), rtol=1e-12, atol=0)


def test_constant_reflectance():
    wi, wo = random_pairs(5, 5)
    torch.testing.assert_close(microfacet_brdf(wi, wo, 0.3, 0.25),
                               microfacet_brdf(wi, wo, 0.3, lambda c: torch.full_like(c, 0.25)), rtol=0, atol=0)
    torch.testing.assert_close(microfacet_brdf(wi, wo, 0.3, torch.tensor(0.25, dtype=F64)),
                               0.25 * microfacet_brdf(wi, wo, 0.3), rtol=1e-15, atol=0)


def test_broadcasting():
    wi = torch.stack([direction(t) for t in (0.0, 40.0)])[:, None, :]  # (2, 1, 3)
    wo = torch.stack([direction(-t) for t in (10.0, 20.0, 30.0)])  # (3, 3)
    alpha = torch.tensor([[0.1], [0.4]], dtype=F64)  # (2, 1)
    out = microfacet_brdf(wi, wo, alpha, schlick)
    assert out.shape == (2, 3)
    torch.testing.assert_close(out[1, 2], microfacet_brdf(wi[1, 0], wo[2], 0.4, schlick))
    seen = []
    microfacet_brdf(wi, wo, alpha, lambda c: seen.append(c.shape) or c)
    assert seen == [(2, 3)]  # the callable sees the full broadcast shape


def test_float32():
    wi, wo = random_pairs(100, 6)
    wi32, wo32 = wi.float(), wo.float()
    for a in (1e-3, 0.05, 1.0):
        out = microfacet_brdf(wi32, wo32, a, schlick)
        assert out.dtype == torch.float32 and torch.isfinite(out).all()
        ref = microfacet_brdf(wi, wo, a, schlick)
        if a >= 0.05:
            torch.testing.assert_close(out.double(), ref, rtol=1e-4, atol=1e-6)
    n32 = N.float()
    assert torch.isfinite(microfacet_brdf(n32, n32, 1e-3)).all()
    grazing = torch.tensor([1.0, 0.0, 1e-7], dtype=torch.float32)
    assert torch.isfinite(microfacet_brdf(grazing, n32, 0.3)).all()


def test_validation():
    wi = direction(30.0)
    for bad in (0.0, -1.0, torch.tensor([0.1, -0.1], dtype=F64)):
        with pytest.raises(ValueError, match="alpha"):
            microfacet_brdf(wi, wi, bad)
    with pytest.raises(ValueError, match="wi"):
        microfacet_brdf(torch.tensor([0.0, 1.0], dtype=F64), wi, 0.3)
    with pytest.raises(ValueError, match="wo"):
        microfacet_brdf(wi, torch.ones(2, 4, dtype=F64), 0.3)
    with pytest.raises(ValueError, match="reflectance"):
        microfacet_brdf(wi, wi, 0.3, -0.5)
    with pytest.raises(ValueError, match="reflectance"):
        microfacet_brdf(wi, wi, 0.3, lambda c: torch.ones(2, 3, 4, dtype=F64))


def test_nan_propagates():
    wi = torch.tensor([float("nan"), 0.0, 1.0], dtype=F64)
    assert torch.isnan(microfacet_brdf(wi, direction(10.0), 0.3))
    assert torch.isnan(microfacet_brdf(direction(10.0), direction(20.0), float("nan")))


def test_gradcheck_interior():
    wi, wo = random_pairs(3, 8)
    wi.requires_grad_(), wo.requires_grad_()
    a = torch.tensor([0.05, 0.3, 0.8], dtype=F64, requires_grad=True)
    assert torch.autograd.gradcheck(lambda i, o, al: microfacet_brdf(i, o, al, schlick), (wi, wo, a))


def test_finite_gradients_at_hard_cases():
    cases = [
        (N, N),  # normal incidence: h = n
        (direction(0.0), direction(40.0)),
        (torch.tensor([1.0, 0.0, 0.0], dtype=F64), N),  # wi exactly grazing: f = 0
        (direction(89.9999), direction(-89.9999)),  # both near grazing, opposite azimuths
        (direction(30.0), -direction(30.0)),  # wo = −wi: i + o = 0 (masked, no 0/0 in backward)
        (direction(30.0), direction(120.0)),  # wo below the horizon
    ]
    for wi, wo in cases:
        wi, wo = wi.clone().requires_grad_(), wo.clone().requires_grad_()
        a = torch.tensor(0.2, dtype=F64, requires_grad=True)
        out = microfacet_brdf(wi, wo, a, schlick)
        out.backward()
        for t in (wi, wo, a):
            assert torch.isfinite(t.grad).all(), (wi, wo, t.grad)
    # at normal incidence the gradient in alpha is the closed form d/dα 1/(4πα²)
    a = torch.tensor(0.2, dtype=F64, requires_grad=True)
    microfacet_brdf(N, N, a).backward()
    torch.testing.assert_close(a.grad, torch.tensor(-2.0 / (4 * math.pi * 0.2**3), dtype=F64), rtol=1e-12, atol=0)


def test_module_wrapper():
    brdf = MicrofacetBRDF(alpha=0.3, reflectance=schlick)
    wi, wo = random_pairs(4, 9)
    out = brdf(wi, wo)
    torch.testing.assert_close(out, microfacet_brdf(wi, wo, 0.3, schlick))
    out.sum().backward()
    assert brdf.alpha.grad is not None and torch.isfinite(brdf.alpha.grad)

    class Constant(torch.nn.Module):
        def __init__(self):
            super().__init__()
            self.r = torch.nn.Parameter(torch.tensor(0.5, dtype=F64))

        def forward(self, c):
            return self.r * torch.ones_like(c)

    brdf = MicrofacetBRDF(alpha=0.3, reflectance=Constant())
    assert {n for n, _ in brdf.named_parameters()} == {"alpha", "reflectance.r"}
    brdf(wi, wo).sum().backward()
    assert brdf.reflectance.r.grad > 0
