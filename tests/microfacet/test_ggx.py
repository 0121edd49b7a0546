"""GGX distribution, Smith masking and visible-normal sampling (Fourneau et al. 2024 eq. 18–19;
Heitz 2014, 2018)."""

import math

import numpy as np
import pytest
import torch

from microfacet_quadrature import F64, direction, gauss_panels, graded_edges, spherical, visible_hemisphere_grid
from torchirid.microfacet import ggx_d, ggx_vndf_pdf, reflect, sample_ggx_vndf, smith_g, smith_g1, smith_lambda

ALPHAS = (0.01, 0.05, 0.3, 1.0)


# --------------------------------------------------------------------------------------
# closed forms of the paper (tan θ forms, independent of the implementation's cos forms)
# --------------------------------------------------------------------------------------


def test_d_and_g1_match_paper_tan_forms():
    rng = np.random.default_rng(1)
    c = rng.uniform(0.02, 0.999, 200)
    a = rng.uniform(0.01, 1.0, 200)
    tan2 = (1 - c * c) / (c * c)
    d_paper = a**2 / (np.pi * c**4 * (a**2 + tan2) ** 2)  # eq. 18
    g1_paper = 2.0 / (1.0 + np.sqrt(1.0 + a**2 * tan2))  # eq. 19
    lam_paper = 0.5 * (np.sqrt(1.0 + a**2 * tan2) - 1.0)
    ct, at = torch.as_tensor(c), torch.as_tensor(a)
    np.testing.assert_allclose(ggx_d(ct, at).numpy(), d_paper, rtol=1e-12)
    np.testing.assert_allclose(smith_g1(ct, at).numpy(), g1_paper, rtol=1e-12)
    np.testing.assert_allclose(smith_lambda(ct, at).numpy(), lam_paper, rtol=1e-9, atol=1e-15)


def test_limits_normal_incidence_and_grazing():
    a = torch.tensor([0.01, 0.3, 1.0], dtype=F64)
    torch.testing.assert_close(ggx_d(torch.ones(3, dtype=F64), a), 1.0 / (math.pi * a * a), rtol=1e-14, atol=0)
    assert torch.all(ggx_d(torch.zeros(3, dtype=F64), a) == 0)  # χ⁺: the horizon has no facets
    assert torch.all(ggx_d(-0.5 * torch.ones(3, dtype=F64), a) == 0)
    assert torch.all(smith_g1(torch.ones(3, dtype=F64), a) == 1)
    assert torch.all(smith_g1(torch.zeros(3, dtype=F64), a) == 0)


@pytest.mark.parametrize("alpha", ALPHAS)
def test_d_projected_area_normalisation(alpha):
    """∫ D(m) cos θm dωm = 2π ∫₀¹ D(c) c dc = 1 (graded Gauss–Legendre towards the peak)."""
    c, w = gauss_panels(graded_edges(0.0, 1.0, points=(1.0,)), 20)
    total = 2.0 * math.pi * torch.sum(w * ggx_d(c, torch.tensor(alpha, dtype=F64)) * c)
    assert abs(total.item() - 1.0) <= 1e-8


def test_d_normalisation_against_mpmath():
    """Independent integrator: mpmath tanh-sinh with break points across the GGX lobe."""
    mpmath = pytest.importorskip("mpmath")
    alpha = 0.05
    a2 = alpha * alpha
    breaks = [0.0, 1 - 100 * a2, 1 - 10 * a2, 1 - a2, 1 - 0.1 * a2, 1.0]
    f = lambda x: 2 * mpmath.pi * float(ggx_d(torch.tensor(float(x), dtype=F64), alpha)) * x  # noqa: E731
    total = mpmath.quad(f, breaks)
    assert abs(float(total) - 1.0) <= 1e-9


# --------------------------------------------------------------------------------------
# visible normals: weak white furnace (Heitz 2014) and the pdf of the sampler
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("alpha", (0.01, 0.1, 0.5, 1.0))
def test_vndf_normalisation(alpha):
    """∫ G1(i) max(0, i·m) D(m) dωm = cos θi, i.e. ggx_vndf_pdf integrates to 1."""
    for theta in (0.0, 30.0, 60.0, 80.0, 89.0):
        wi = direction(theta)
        m, w = visible_hemisphere_grid(theta, alpha)
        total = torch.sum(w * ggx_vndf_pdf(wi, m, alpha)).item()
        assert abs(total - 1.0) <= 1e-9, (theta, alpha, total)


def test_vndf_pdf_is_zero_for_back_facing_and_below_horizon_normals():
    wi = direction(60.0)
    m_back = spherical(torch.tensor(0.3, dtype=F64), torch.tensor(math.pi, dtype=F64))  # i·m < 0
    assert (wi * m_back).sum() < 0
    assert ggx_vndf_pdf(wi, m_back, 0.5).item() == 0.0
    m_below = torch.tensor([1.0, 0.0, -0.1], dtype=F64)
    m_below = m_below / m_below.norm()
    assert ggx_vndf_pdf(wi, m_below, 0.5).item() == 0.0


def test_vndf_pdf_formula_at_a_point():
    wi, m, a = direction(40.0), spherical(torch.tensor(0.9, dtype=F64), torch.tensor(0.3, dtype=F64)), 0.4
    expected = smith_g1(wi[2], a) * (wi * m).sum() * ggx_d(m[2], a) / wi[2]
    torch.testing.assert_close(ggx_vndf_pdf(wi, m, a), expected, rtol=1e-14, atol=0)


def test_sampler_basic_properties():
    g = torch.Generator().manual_seed(3)
    u = torch.rand(4000, 2, generator=g, dtype=F64)
    for theta in (0.0, 45.0, 89.9):
        for alpha in (0.01, 0.5, 1.0):
            wi = direction(theta)
            m = sample_ggx_vndf(wi, alpha, u)
            assert m.shape == (4000, 3)
            torch.testing.assert_close(m.norm(dim=-1), torch.ones(4000, dtype=F64), rtol=0, atol=1e-14)
            assert torch.all(m[:, 2] >= 0)
            assert torch.all((m * wi).sum(-1) >= -1e-12)  # only visible normals
    # u1 = 0 samples the centre of the projected disk: at normal incidence, m = n
    n = torch.tensor([0.0, 0.0, 1.0], dtype=F64)
    assert torch.equal(sample_ggx_vndf(n, 0.3, torch.tensor([0.0, 0.7], dtype=F64)), n)


def test_sampler_mirror_limit():
    """α → 0: every sampled normal is the geometric normal."""
    u = torch.rand(1000, 2, dtype=F64, generator=torch.Generator().manual_seed(0))
    m = sample_ggx_vndf(direction(70.0), 1e-6, u)
    assert torch.all(m[:, 2] > 1 - 1e-9)


def _chi2_sf(x, dof):
    """Survival function of χ²_dof at x: the regularised upper incomplete gamma Q(dof/2, x/2)."""
    return torch.special.gammaincc(torch.tensor(dof / 2.0, dtype=F64), torch.tensor(x / 2.0, dtype=F64)).item()


def test_chi2_sf_reference_values():
    # χ²_1 tail at 3.841458820694124 (the 95 % quantile) and χ²_10 at its mean
    assert abs(_chi2_sf(3.841458820694124, 1) - 0.05) < 1e-12
    assert abs(_chi2_sf(10.0, 10) - 0.44049328506521257) < 1e-12


def _chi2_vndf(theta, alpha, alpha_sampler, n_samples=100_000, n_v=16, n_phi=24, n_gl=12, seed=0):
    """Mitsuba-style χ² test of sample_ggx_vndf against ggx_vndf_pdf; returns the p-value.

    Bins: n_phi uniform in φ ∈ [−π, π) times n_v uniform in v = tan²θ/(α² + tan²θ) (the
    cumulative D·cos mass, so that even α = 0.01 spreads over the bins). Expected counts:
    the pdf integrated over each bin by Gauss–Legendre in (v, φ), φ clipped to the
    visible azimuths.
    Bins expected to hold < 5 samples are pooled.
    """
    wi = direction(theta)
    g = torch.Generator().manual_seed(seed)
    m = sample_ggx_vndf(wi, alpha_sampler, torch.rand(n_samples, 2, generator=g, dtype=F64))
    a2 = alpha * alpha
    # observed
    c = m[:, 2].clamp(max=1.0)
    tan2 = (1.0 - c * c) / (c * c)
    vb = (tan2 / (a2 + tan2) * n_v).floor().clamp(0, n_v - 1).long()
    pb = ((torch.atan2(m[:, 1], m[:, 0]) + math.pi) / (2 * math.pi) * n_phi).floor().clamp(0, n_phi - 1).long()
    observed = torch.bincount(vb * n_phi + pb, minlength=n_v * n_phi).to(F64)
    # expected: Gauss–Legendre per bin in (t, φ)
    x, w = np.polynomial.legendre.leggauss(n_gl)
    x, w = torch.as_tensor(x, dtype=F64), torch.as_tensor(w, dtype=F64)
    v_edges = torch.linspace(0.0, 1.0, n_v + 1, dtype=F64)
    lo_v, hi_v = v_edges[:-1], v_edges[1:]
    # in each bin substitute v = 1 − t²: cos θ = t/r, r = √(α² + (1−α²)t²), dcos θ/dt = α²/r³
    # (smooth, whereas the visible pdf has a (1 − v)^(−1/2) tail at grazing θm)
    lo_t, hi_t = torch.sqrt(1.0 - hi_v), torch.sqrt(1.0 - lo_v)
    tt = 0.5 * (hi_t - lo_t)[:, None] * x + 0.5 * (hi_t + lo_t)[:, None]  # (n_v, n_gl)
    r = torch.sqrt(a2 + (1.0 - a2) * tt * tt)
    cc = tt / r
    wcc = 0.5 * (hi_t - lo_t)[:, None] * w * a2 / r**3
    # visible azimuths |φ| < φ0(cos θ): clip each φ bin to them (the kink of max(0, i·m))
    ti = math.radians(theta)
    sin_m = torch.sqrt(1.0 - cc * cc)
    ratio = -cc * math.cos(ti) / torch.where(sin_m * math.sin(ti) > 0, sin_m * math.sin(ti), torch.ones_like(cc))
    ratio = torch.where(sin_m * math.sin(ti) > 0, ratio, torch.full_like(cc, -2.0))
    phi0 = torch.acos(ratio.clamp(-1.0, 1.0))[:, :, None]  # (n_v, n_gl, 1); π when all visible
    phi_edges = torch.linspace(-math.pi, math.pi, n_phi + 1, dtype=F64)
    lo_p = torch.maximum(phi_edges[:-1], -phi0)  # (n_v, n_gl, n_phi)
    hi_p = torch.minimum(phi_edges[1:], phi0).clamp(min=lo_p)
    pp = 0.5 * (hi_p - lo_p)[..., None] * x + 0.5 * (hi_p + lo_p)[..., None]  # (n_v, n_gl, n_phi, n_gl)
    wpp = 0.5 * (hi_p - lo_p)[..., None] * w
    mm = spherical(cc[:, :, None, None], pp)
    pdf = ggx_vndf_pdf(wi, mm, alpha)
    expected = n_samples * torch.einsum("vipj,vi,vipj->vp", pdf, wcc, wpp).reshape(-1)
    assert abs(expected.sum().item() / n_samples - 1.0) < 1e-4  # the bins cover the pdf's mass
    small = expected < 5.0
    obs = torch.cat([observed[~small], observed[small].sum().reshape(1)])
    exp = torch.cat([expected[~small], expected[small].sum().reshape(1)])
    keep = exp > 0
    obs, exp = obs[keep], exp[keep]
    chi2 = torch.sum((obs - exp) ** 2 / exp).item()
    dof = obs.numel() - 1
    assert dof >= 20  # the test has resolution
    return _chi2_sf(chi2, dof)


@pytest.mark.parametrize("theta,alpha", [(0.0, 0.3), (0.0, 0.01), (45.0, 0.5), (70.0, 0.05), (85.0, 0.3), (85.0, 1.0), (89.0, 0.1)])
def test_sampler_chi2(theta, alpha):
    assert _chi2_vndf(theta, alpha, alpha) > 0.01


def test_sampler_chi2_has_power():
    """The same test rejects a sampler whose roughness is off by 10 %."""
    assert _chi2_vndf(45.0, 0.5, 0.55) < 1e-6


def test_sampler_monte_carlo_moment_matches_quadrature():
    """E_{m~VNDF}[m_x + m_z³] by Monte Carlo equals ∫ (m_x + m_z³) pdf dωm."""
    theta, alpha = 60.0, 0.5
    wi = direction(theta)
    m = sample_ggx_vndf(wi, alpha, torch.rand(200_000, 2, dtype=F64, generator=torch.Generator().manual_seed(5)))
    f = lambda v: v[..., 0] + v[..., 2] ** 3  # noqa: E731
    mc, sd = f(m).mean().item(), f(m).std().item() / math.sqrt(m.shape[0])
    mq, wq = visible_hemisphere_grid(theta, alpha)
    quad = torch.sum(wq * f(mq) * ggx_vndf_pdf(wi, mq, alpha)).item()
    assert abs(mc - quad) < 5 * sd


# --------------------------------------------------------------------------------------
# vectors: reflect, smith_g
# --------------------------------------------------------------------------------------


def test_reflect():
    wi = direction(35.0)
    m = spherical(torch.tensor(0.95, dtype=F64), torch.tensor(1.0, dtype=F64))
    o = reflect(wi, m)
    torch.testing.assert_close(o.norm(), torch.tensor(1.0, dtype=F64), rtol=0, atol=1e-15)
    torch.testing.assert_close((o * m).sum(), (wi * m).sum(), rtol=1e-14, atol=0)
    h = (wi + o) / (wi + o).norm()
    torch.testing.assert_close(h, m, rtol=0, atol=1e-14)


def test_smith_g_separable_with_chi_plus():
    wi, wo, a = direction(30.0), direction(-50.0), 0.4
    m = torch.tensor([0.0, 0.0, 1.0], dtype=F64)
    torch.testing.assert_close(smith_g(wi, wo, m, a), smith_g1(wi[2], a) * smith_g1(wo[2], a), rtol=1e-14, atol=0)
    # a facet facing away from wo: χ⁺((o·m)/(o·n)) = 0
    m_away = direction(60.0)
    assert (wo * m_away).sum() < 0
    assert smith_g(wi, wo, m_away, a).item() == 0.0
    # ballistic transmission G(i, −i, m) (eq. 22): the χ⁺ ratios are both positive
    m_t = direction(10.0)
    torch.testing.assert_close(smith_g(wi, -wi, m_t, a), smith_g1(wi[2], a) ** 2, rtol=1e-14, atol=0)
    assert smith_g(wi, -wi, direction(-70.0), a).item() == 0.0  # i·m < 0


def test_broadcasting():
    wi = torch.stack([direction(t) for t in (0.0, 30.0, 60.0)])  # (3, 3)
    alpha = torch.tensor([[0.1], [0.5]], dtype=F64)  # (2, 1)
    u = torch.rand(2, 3, 2, dtype=F64, generator=torch.Generator().manual_seed(1))
    m = sample_ggx_vndf(wi, alpha, u)
    assert m.shape == (2, 3, 3)
    torch.testing.assert_close(m[1, 2], sample_ggx_vndf(wi[2], 0.5, u[1, 2]))
    assert ggx_vndf_pdf(wi, m, alpha).shape == (2, 3)
    torch.testing.assert_close(ggx_vndf_pdf(wi, m, alpha)[1, 2], ggx_vndf_pdf(wi[2], m[1, 2], 0.5))
    assert smith_g(wi, wi, m, alpha).shape == (2, 3)
    assert reflect(wi, m).shape == (2, 3, 3)
    assert ggx_d(torch.rand(4, 1, dtype=F64), alpha.reshape(2)).shape == (4, 2)


def test_float32_stays_float32_and_finite():
    u = torch.rand(5000, 2, generator=torch.Generator().manual_seed(2))
    for theta in (0.0, 60.0, 89.99):
        wi = direction(theta).float()
        for alpha in (1e-3, 0.3, 1.0):
            m = sample_ggx_vndf(wi, alpha, u)
            assert m.dtype == torch.float32 and torch.isfinite(m).all()
            p = ggx_vndf_pdf(wi, m, alpha)
            assert p.dtype == torch.float32 and torch.isfinite(p).all() and torch.all(p >= 0)
            assert torch.isfinite(smith_g(wi, wi, m, alpha)).all()
    c = torch.linspace(0, 1, 101)
    assert torch.isfinite(ggx_d(c, 1e-3)).all() and torch.isfinite(smith_g1(c, 1e-3)).all()


# --------------------------------------------------------------------------------------
# validation
# --------------------------------------------------------------------------------------


def test_validation_alpha():
    wi, m = direction(30.0), direction(10.0)
    u = torch.tensor([0.5, 0.5], dtype=F64)
    for bad in (0.0, -0.1, torch.tensor([0.2, 0.0], dtype=F64)):
        for call in (
            lambda: ggx_d(0.5, bad),
            lambda: smith_g1(0.5, bad),
            lambda: sample_ggx_vndf(wi, bad, u),
            lambda: ggx_vndf_pdf(wi, m, bad),
            lambda: smith_g(wi, wi, m, bad),
        ):
            with pytest.raises(ValueError, match="alpha"):
                call()


def test_validation_vectors_and_u():
    u = torch.tensor([0.5, 0.5], dtype=F64)
    below = torch.tensor([[0.0, 0.0, 1.0], [0.6, 0.0, -0.8]], dtype=F64)
    with pytest.raises(ValueError, match="wi"):
        sample_ggx_vndf(below, 0.3, u)
    with pytest.raises(ValueError, match="wi"):
        ggx_vndf_pdf(torch.tensor([1.0, 0.0, 0.0], dtype=F64), direction(0.0), 0.3)  # grazing
    with pytest.raises(ValueError, match="wi"):
        sample_ggx_vndf(torch.tensor([0.0, 1.0], dtype=F64), 0.3, u)  # not (*, 3)
    with pytest.raises(ValueError, match="u"):
        sample_ggx_vndf(direction(0.0), 0.3, torch.tensor([0.5, 1.5], dtype=F64))
    with pytest.raises(ValueError, match="u"):
        sample_ggx_vndf(direction(0.0), 0.3, torch.tensor([0.5, 0.5, 0.5], dtype=F64))
    with pytest.raises(ValueError, match="m"):
        ggx_vndf_pdf(direction(0.0), torch.tensor([0.0, 1.0], dtype=F64), 0.3)
    with pytest.raises(ValueError, match="cos_theta_m"):
        ggx_d(1.5, 0.3)


def test_nan_propagates():
    assert math.isnan(ggx_d(float("nan"), 0.3).item())
    m = sample_ggx_vndf(direction(0.0), float("nan"), torch.tensor([0.3, 0.3], dtype=F64))
    assert torch.isnan(m).any()
    # a NaN random number is not "fixed" into the disk centre (the guarded √ used to return 0 for NaN)
    m = sample_ggx_vndf(direction(0.3), 0.3, torch.tensor([[float("nan"), 0.3], [0.3, 0.3]], dtype=F64))
    assert torch.isnan(m[0]).all() and torch.isfinite(m[1]).all()


# --------------------------------------------------------------------------------------
# gradients
# --------------------------------------------------------------------------------------


def test_gradcheck_d_g1_interior():
    c = torch.tensor([0.1, 0.5, 0.93], dtype=F64, requires_grad=True)
    a = torch.tensor([0.05, 0.3, 0.9], dtype=F64, requires_grad=True)
    assert torch.autograd.gradcheck(ggx_d, (c, a))
    assert torch.autograd.gradcheck(smith_g1, (c, a))
    assert torch.autograd.gradcheck(smith_lambda, (c, a))


def test_gradcheck_vndf_pdf_and_sampler():
    wi = direction(40.0).requires_grad_()
    m = spherical(torch.tensor([0.8, 0.95], dtype=F64), torch.tensor([0.4, -2.0], dtype=F64)).requires_grad_()
    a = torch.tensor(0.35, dtype=F64, requires_grad=True)
    assert torch.autograd.gradcheck(ggx_vndf_pdf, (wi, m, a))
    u = torch.tensor([[0.2, 0.3], [0.7, 0.9]], dtype=F64)
    assert torch.autograd.gradcheck(lambda w, al: sample_ggx_vndf(w, al, u), (wi, a))


def test_finite_gradients_at_normal_incidence_and_grazing():
    n = torch.tensor([0.0, 0.0, 1.0], dtype=F64, requires_grad=True)
    a = torch.tensor(0.3, dtype=F64, requires_grad=True)
    u = torch.tensor([[0.0, 0.0], [0.5, 0.25], [0.999, 0.5]], dtype=F64)
    m = sample_ggx_vndf(n, a, u)
    (m.sum() + ggx_vndf_pdf(n, m, a).sum()).backward()
    assert torch.isfinite(n.grad).all() and torch.isfinite(a.grad).all()
    c = torch.tensor([0.0, 1.0], dtype=F64, requires_grad=True)
    a = torch.tensor(0.3, dtype=F64, requires_grad=True)
    (ggx_d(c, a).sum() + smith_g1(c, a).sum()).backward()
    assert torch.isfinite(c.grad).all() and torch.isfinite(a.grad).all()
    # near-grazing viewing direction for the sampler and the pdf
    wi = torch.tensor([1.0, 0.0, 1e-6], dtype=F64)
    wi = (wi / wi.norm()).requires_grad_()
    a = torch.tensor(0.3, dtype=F64, requires_grad=True)
    m = sample_ggx_vndf(wi, a, u)
    (m.sum() + ggx_vndf_pdf(wi, m.detach(), a).sum()).backward()
    assert torch.isfinite(wi.grad).all() and torch.isfinite(a.grad).all()


def test_smith_lambda_at_grazing_is_the_limit_with_a_finite_gradient():
    """Λ → +∞ as cos θ → 0 (G1 → 0): the limit at cos θ = 0, with finite (zero) gradients
    instead of the NaN of 0/0; next to grazing it still grows like α/(2 cos θ)."""
    c = torch.tensor([0.0, 1e-9, 0.5], dtype=F64, requires_grad=True)
    a = torch.tensor(0.3, dtype=F64, requires_grad=True)
    lam = smith_lambda(c, a)
    assert math.isinf(lam[0].item()) and lam[0].item() > 0
    assert abs(lam[1].item() - 0.5 * (0.3 / 1e-9 - 1)) / lam[1].item() < 1e-6
    lam[0].backward()
    assert c.grad.isfinite().all() and a.grad.isfinite().all() and c.grad[0] == 0 and a.grad == 0
    nan = smith_lambda(torch.tensor([float("nan"), 0.5], dtype=F64), 0.3)
    assert nan[0].isnan() and nan[1].isfinite()
