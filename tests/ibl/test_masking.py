"""The height_correlated (Smith-joint) masking option of the uniform-light reference and the fitted table.

Kneiphof et al. 2019 (§6) render with "a GGX normal distribution and Smith-Joint geometry term":
G₂ = 1/(1 + Λ(ω_i) + Λ(ω_o)). Checked against a brute-force hemisphere quadrature that builds G₂
from ``smith_lambda`` (independent of the lobe quadrature's D·cos sampling and of its G₁ form).
"""

import math

import numpy as np
import pytest
import torch

from torchirid import spectrum_to_xyz, thin_film_reflectance, xyz_to_lab
from torchirid.color import delta_e_2000
from torchirid.ibl import (
    thin_film_xyz_fitted,
    light_mixture,
    light_mixture_lut,
    path_difference_moments,
    shipped_light_mixture_lut,
    uniform_light_moments,
    thin_film_xyz_uniform,
)
from torchirid.ibl.uniform import MASKING_MODES, cos_theta1_distribution, uniform_lobe_quadrature
from torchirid.ibl.fitted import light_mixture_path
from torchirid.microfacet import ggx_d, smith_g1, smith_lambda

F64 = torch.float64
HC = "height_correlated"


def _brute(c, alpha, masking, n=400):
    """Weights of ρ̃⟨n,ωi⟩ dωi on a tensor Gauss–Legendre grid in (cos θi, φi), and ⟨h, ωo⟩."""
    x, w = np.polynomial.legendre.leggauss(n)
    ci = torch.tensor(0.5 * (x + 1), dtype=F64)
    phi = torch.tensor(math.pi * (x + 1), dtype=F64)
    CI, PH = torch.meshgrid(ci, phi, indexing="ij")
    W = torch.tensor(0.5 * w)[:, None] * torch.tensor(math.pi * w)[None, :]
    si = torch.sqrt(1 - CI ** 2)
    wi = torch.stack([si * torch.cos(PH), si * torch.sin(PH), CI], -1)
    wo = torch.tensor([math.sqrt(1 - c * c), 0.0, c], dtype=F64)
    h = wi + wo
    h = h / h.norm(dim=-1, keepdim=True)
    co = torch.tensor(c, dtype=F64)
    if masking == HC:  # Heitz 2014: G2 = 1/(1 + Λ(ωi) + Λ(ωo)) (both above the surface: χ⁺ = 1)
        g = 1.0 / (1.0 + smith_lambda(CI, alpha) + smith_lambda(co, alpha))
    else:
        g = smith_g1(CI, alpha) * smith_g1(co, alpha)
    rho = ggx_d(h[..., 2], alpha) * g / (4 * c)
    return (W * rho).reshape(-1), wi.reshape(-1, 3), (h * wo).sum(-1).reshape(-1)


@pytest.mark.parametrize("c,alpha", [(0.9, 0.3), (0.3, 0.5), (0.05, 0.8)])
def test_height_correlated_albedo_and_moments_match_brute_force(c, alpha):
    w, wi, _ = _brute(c, alpha, HC)
    A = w.sum()
    mu = (w[:, None] * wi).sum(0) / A
    second = torch.einsum("q,qi,qj->ij", w, wi, wi) / A
    A2, mu2, cov2 = uniform_light_moments(torch.tensor(c, dtype=F64), alpha, nodes=128, masking=HC)
    assert abs(A2 - A) < 5e-5  # O(nodes⁻²): measured 0.8–1.6e-5 at 128 nodes
    assert (mu2 - mu).abs().max() < 5e-5
    assert (cov2 - (second - mu[:, None] * mu[None])).abs().max() < 5e-4
    # and the option changes something where Λ(ωo) > 0: the separable albedo is smaller
    A_sep, _, _ = uniform_light_moments(torch.tensor(c, dtype=F64), alpha, nodes=128)
    assert A2 - A_sep > 1e-4  # 1.7e-4 / 0.031 / 0.21 for the three cases


def test_height_correlated_weights_bound_separable_ones():
    """G₂ ≥ G₁G₁ pointwise (so every lobe weight and the albedo), equal at normal view (Λ(ωo) = 0)."""
    c = torch.tensor([1.0, 0.8, 0.4, 0.1, 0.02], dtype=F64)[:, None]
    a = torch.tensor([0.05, 0.3, 0.7, 1.0], dtype=F64)[None, :]
    _, _, w_sep = uniform_lobe_quadrature(c, a, nodes=24)
    _, _, w_hc = uniform_lobe_quadrature(c, a, nodes=24, masking=HC)
    assert (w_hc >= w_sep).all()
    assert torch.allclose(w_hc[0], w_sep[0], rtol=1e-14, atol=0)
    # the same lobe, reweighted: the joint G's weight over the separable one is 1/(G1i + G1o − G1i G1o) ≥ 1
    assert (w_hc[1:].sum(-1) > w_sep[1:].sum(-1)).all()


def test_height_correlated_colour_and_path_moments_match_brute_force():
    """thin_film_xyz_uniform and path_difference_moments with the joint G against the brute-force
    grid (XYZ[R](cos θ1) interpolated linearly from 4097 exact nodes)."""
    c, alpha, nf, d, ns = 0.35, 0.4, 1.33, 450.0, complex(1.5, 2.0)
    w, _, c1 = _brute(c, alpha, HC, n=300)
    p = w / w.sum()
    wl = torch.linspace(360, 830, 471, dtype=F64)
    grid = torch.linspace(0, 1, 4097, dtype=F64)
    f = spectrum_to_xyz(thin_film_reflectance(wl, grid[:, None], nf, d, ns), wl)  # (4097, 3)
    x = c1.clamp(0, 1) * 4096
    i0 = x.floor().clamp(max=4095).long()
    t = (x - i0)[:, None]
    ref = (p[:, None] * ((1 - t) * f[i0] + t * f[i0 + 1])).sum(0)
    got = thin_film_xyz_uniform(torch.tensor(c, dtype=F64), alpha, nf, d, ns, nodes=96, masking=HC)
    assert delta_e_2000(xyz_to_lab(got), xyz_to_lab(ref)) < 0.01
    sep = thin_film_xyz_uniform(torch.tensor(c, dtype=F64), alpha, nf, d, ns, nodes=96)
    assert delta_e_2000(xyz_to_lab(sep), xyz_to_lab(ref)) > 0.05  # the option matters here
    D = 2 * nf * d * torch.sqrt(1 - (1 / nf) ** 2 * (1 - c1 * c1))
    mD, vD, _, _ = path_difference_moments(torch.tensor(c, dtype=F64), alpha, nf, d, nodes=96, masking=HC)
    m = (p * D).sum()
    assert abs(mD - m) < 0.05 and abs(vD - ((p * D * D).sum() - m * m)) / vD < 5e-3


def test_distribution_and_mixture_follow_the_option():
    c = torch.tensor([0.15, 0.7], dtype=F64)
    a = torch.tensor([0.6, 0.2], dtype=F64)
    grid, w, A = cos_theta1_distribution(c, a, bins=256, nodes=32, masking=HC)
    _, h, q = uniform_lobe_quadrature(c, a, nodes=32, masking=HC)
    wo = torch.stack([torch.sqrt(1 - c * c), torch.zeros_like(c), c], -1)
    c1 = (h * wo[:, None]).sum(-1)
    assert torch.allclose(A, q.sum(-1))
    assert torch.allclose((w * grid).sum(-1), (q * c1).sum(-1) / q.sum(-1), atol=1e-12)
    mix = light_mixture(c, a, nodes=32, masking=HC)
    wk, mk, vk = mix.unbind(-1)
    assert torch.allclose((wk * mk).sum(-1), (w * grid).sum(-1), atol=2e-4)  # bins=2048 vs 256: same mean ±h²
    assert not torch.allclose(mix, light_mixture(c, a, nodes=32), atol=1e-3)


def test_shipped_height_correlated_table():
    assert light_mixture_path(HC).name == "light_mixture_height_correlated.npz"
    sep, hc = shipped_light_mixture_lut(), shipped_light_mixture_lut(masking=HC)
    assert hc.parameters["masking"] == HC and sep.parameters.get("masking", "separable") == "separable"
    cs, ss = hc.axes["cos_theta_o"][12], hc.axes["sqrt_alpha"][40]  # θo ≈ 67°, α ≈ 0.72
    assert torch.allclose(hc(cos_theta_o=cs, sqrt_alpha=ss), light_mixture(cs, ss * ss, masking=HC), atol=2e-6)
    assert (hc.values - sep.values).abs().max() > 1e-2


def test_fitted_height_correlated_matches_its_reference():
    """The fitted table with the joint G against the joint-G ground truth, where the two G differ most
    (grazing, rough): the separable table misses it by 2.2 ΔE2000, the joint-G table by < 0.85."""
    th = torch.deg2rad(torch.tensor([60.0, 75.0, 85.0], dtype=F64))[:, None]
    c = torch.cos(th)
    a = torch.tensor([0.5, 1.0], dtype=F64)[None, :]
    film = (1.33, 300.0, 1.5)
    ref = xyz_to_lab(thin_film_xyz_uniform(c, a, *film, nodes=48, masking=HC))
    de = delta_e_2000(xyz_to_lab(thin_film_xyz_fitted(c, a, *film, masking=HC, sensitivity="exact")), ref)
    wrong = delta_e_2000(xyz_to_lab(thin_film_xyz_fitted(c, a, *film, sensitivity="exact")), ref)
    assert de.max() < 1.0 and de.mean() < 0.6  # measured 0.84 / 0.55
    assert wrong.max() > 2 * de.max() and wrong.mean() > 2 * de.mean()  # measured 2.19 / 1.29


def test_masking_validation_and_table_mismatch():
    c = torch.tensor(0.5, dtype=F64)
    calls = [lambda m: uniform_lobe_quadrature(c, 0.3, nodes=4, masking=m),
             lambda m: uniform_light_moments(c, 0.3, nodes=4, masking=m),
             lambda m: cos_theta1_distribution(c, 0.3, nodes=4, masking=m),
             lambda m: path_difference_moments(c, 0.3, 1.3, 500.0, nodes=4, masking=m),
             lambda m: thin_film_xyz_uniform(c, 0.3, 1.3, 500.0, 1.5, nodes=4, masking=m),
             lambda m: light_mixture(c, 0.3, nodes=4, masking=m),
             lambda m: light_mixture_lut(theta_nodes=2, alpha_nodes=2, nodes=4, masking=m),
             lambda m: shipped_light_mixture_lut(masking=m),
             lambda m: thin_film_xyz_fitted(c, 0.3, 1.3, 500.0, 1.5, masking=m, sensitivity="exact")]
    for call in calls:
        with pytest.raises(ValueError, match="masking must be one of 'separable', 'height_correlated'"):
            call("smith-joint")
    assert MASKING_MODES == ("separable", HC)
    lut = light_mixture_lut(theta_nodes=2, alpha_nodes=2, nodes=4, masking=HC)
    assert lut.parameters["masking"] == HC
    with pytest.raises(ValueError, match="masking"):
        thin_film_xyz_fitted(c, 0.3, 1.3, 500.0, 1.5, table=lut, sensitivity="exact")  # a joint-G table, separable requested
    assert torch.isfinite(thin_film_xyz_fitted(c, 0.3, 1.3, 500.0, 1.5, table=lut, masking=HC, sensitivity="exact")).all()
