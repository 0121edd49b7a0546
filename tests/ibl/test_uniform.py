"""Ground truth under uniform light (torchirid.ibl.uniform): against brute-force hemisphere quadrature."""

import math

import numpy as np
import pytest
import torch

from torchirid import spectrum_to_xyz, thin_film_reflectance, xyz_to_lab
from torchirid.color import delta_e_2000
from torchirid.ibl import (
    dfg_lut,
    thin_film_xyz_filtered,
    thin_film_xyz_gaussian_path,
    path_difference_moments,
    thin_film_xyz_fourier,
    uniform_light_moments,
    thin_film_xyz_uniform,
)
from torchirid.ibl.uniform import cos_theta1_distribution, uniform_lobe_quadrature
from torchirid.microfacet import ggx_d, smith_g1

F64 = torch.float64
FILM = dict(n_film=1.3, thickness=600.0, n_substrate=complex(2.0, 0.5))


def _brute(c, alpha, n=400):
    """∫ ρ̃⟨n,ωi⟩ f dωi over the hemisphere of ωi by a tensor Gauss–Legendre rule in (cos θi, φi)."""
    x, w = np.polynomial.legendre.leggauss(n)
    ci = torch.tensor(0.5 * (x + 1)); wc = torch.tensor(0.5 * w)
    phi = torch.tensor(math.pi * (x + 1)); wp = torch.tensor(math.pi * w)
    CI, PH = torch.meshgrid(ci, phi, indexing="ij")
    W = wc[:, None] * wp[None, :]
    si = torch.sqrt(1 - CI ** 2)
    wi = torch.stack([si * torch.cos(PH), si * torch.sin(PH), CI], -1)
    wo = torch.tensor([math.sqrt(1 - c * c), 0.0, c], dtype=F64)
    h = wi + wo
    h = h / h.norm(dim=-1, keepdim=True)
    rho = ggx_d(h[..., 2], alpha) * smith_g1(CI, alpha) * smith_g1(torch.tensor(c, dtype=F64), alpha) / (4 * c)
    return wi, h, (W * rho).reshape(-1), wi.reshape(-1, 3), (h * wo).sum(-1).reshape(-1)


@pytest.mark.parametrize("c,alpha", [(0.9, 0.3), (0.3, 0.5), (0.05, 0.8), (1.0, 1.0)])
def test_albedo_and_moments_match_brute_force(c, alpha):
    _, _, w, wi, _ = _brute(c, alpha)
    A = w.sum()
    mu = (w[:, None] * wi).sum(0) / A
    second = torch.einsum("q,qi,qj->ij", w, wi, wi) / A
    A2, mu2, cov2 = uniform_light_moments(torch.tensor(c, dtype=F64), alpha, nodes=128)
    assert abs(A2 - A) < 1e-4  # O(nodes⁻²): the horizon is a kink (G1 → 0), 6e-5 at 128 nodes
    assert (mu2 - mu).abs().max() < 2e-4
    assert (cov2 - (second - mu[:, None] * mu[None])).abs().max() < 5e-4


def test_white_furnace_closed_form():
    # normal view, α = 1: A = E_vndf[G1(ωi)] = 1 − ln 2 (separable Smith GGX)
    A, _, _ = uniform_light_moments(torch.tensor(1.0, dtype=F64), 1.0, nodes=256)
    assert abs(float(A) - (1 - math.log(2))) < 3e-5


def test_albedo_matches_dfg_table():
    lut = dfg_lut(5, samples=4096)
    c = torch.tensor([0.25, 0.5, 0.75, 1.0], dtype=F64)[:, None]
    a = torch.tensor([0.25, 0.5, 0.75, 1.0], dtype=F64)[None, :]
    A, _, _ = uniform_light_moments(c, a)
    ab = lut(cos_theta_o=c, alpha=a)
    assert (A - ab.sum(-1)).abs().max() < 2e-3  # Hammersley 4096 vs our converged rule


def test_quadrature_converges_and_mirror_limit():
    c = torch.tensor([0.02, 0.5, 0.99], dtype=F64)
    a = torch.tensor([0.05, 0.02, 0.9], dtype=F64)
    x64 = thin_film_xyz_uniform(c, a, **FILM, nodes=64)
    x128 = thin_film_xyz_uniform(c, a, **FILM, nodes=128)
    assert delta_e_2000(xyz_to_lab(x64), xyz_to_lab(x128)).max() < 0.01
    # α → 0: the smooth film at cos θ1 = cos θo
    wl = torch.linspace(360, 830, 471, dtype=F64)
    c = torch.tensor([0.3, 0.7, 1.0], dtype=F64)
    smooth = spectrum_to_xyz(thin_film_reflectance(wl, c[:, None], 1.3, 600.0, complex(2.0, 0.5)), wl)
    assert (thin_film_xyz_uniform(c, 1e-6, **FILM) - smooth).abs().max() < 1e-4


def test_reference_equals_direct_sum_without_binning():
    c, a = 0.4, 0.3
    wi, h, w = uniform_lobe_quadrature(torch.tensor(c, dtype=F64), a, nodes=24)
    wo = torch.tensor([math.sqrt(1 - c * c), 0.0, c], dtype=F64)
    c1 = (h * wo).sum(-1).clamp(0, 1)
    wl = torch.linspace(360, 830, 471, dtype=F64)
    f = spectrum_to_xyz(thin_film_reflectance(wl, c1[:, None], 1.3, 600.0, complex(2.0, 0.5)), wl)
    direct = (w[:, None] * f).sum(0) / w.sum()
    binned = thin_film_xyz_uniform(torch.tensor(c, dtype=F64), a, **FILM, nodes=24, bins=4096)
    assert (direct - binned).abs().max() < 2e-6


def test_distribution_preserves_mass_and_mean():
    c = torch.tensor([0.2, 0.8], dtype=F64)
    a = torch.tensor([0.6, 0.1], dtype=F64)
    grid, w, A = cos_theta1_distribution(c, a, bins=64, nodes=32)
    assert torch.allclose(w.sum(-1), torch.ones(2, dtype=F64), atol=1e-12)
    _, h, q = uniform_lobe_quadrature(c, a, nodes=32)
    wo = torch.stack([torch.sqrt(1 - c * c), torch.zeros_like(c), c], -1)
    c1 = (h * wo[:, None]).sum(-1)
    assert torch.allclose((w * grid).sum(-1), (q * c1).sum(-1) / q.sum(-1), atol=1e-12)  # linear splat: exact mean
    assert torch.allclose(A, q.sum(-1))


def test_path_difference_moments_direct():
    c, a = 0.5, 0.4
    _, h, q = uniform_lobe_quadrature(torch.tensor(c, dtype=F64), a, nodes=48)
    wo = torch.tensor([math.sqrt(1 - c * c), 0.0, c], dtype=F64)
    c1 = (h * wo).sum(-1)
    D = 2 * 1.3 * 600 * torch.sqrt(1 - (1 / 1.3) ** 2 * (1 - c1 * c1))
    p = q / q.sum()
    m = (p * D).sum()
    v = (p * D * D).sum() - m * m
    mD, vD, _, _ = path_difference_moments(torch.tensor(c, dtype=F64), a, 1.3, 600.0, nodes=48, bins=8192)
    assert abs(mD - m) < 1e-3 and abs(vD - v) / v < 1e-3


def test_gaussian_path_consistency():
    c = torch.tensor([0.3, 0.9], dtype=F64)
    D = 2 * 1.3 * 600 * torch.sqrt(1 - (1 / 1.3) ** 2 * (1 - c * c))
    a = thin_film_xyz_gaussian_path(c, **FILM, path_mean=D, path_var=0.0, sensitivity="exact")
    b = thin_film_xyz_fourier(c, **FILM, sensitivity="exact")  # (the same default terms in both)
    assert (a - b).abs().max() < 1e-12
    a2 = thin_film_xyz_gaussian_path(c, **FILM, path_mean=D, path_var=0.0, terms=2, sensitivity="exact")
    assert (a2 - thin_film_xyz_fourier(c, **FILM, terms=2, sensitivity="exact")).abs().max() < 1e-12
    with pytest.raises(ValueError, match="path_var"):
        thin_film_xyz_gaussian_path(c, **FILM, path_mean=D, path_var=-1.0)


def test_kneiphof_beats_original_at_high_roughness():
    """Kneiphof et al.'s claim (Fig. 7): with the exact light moments, eq. 29 beats the original for α ≥ 0.25."""
    th = torch.deg2rad(torch.tensor([10.0, 40.0, 65.0, 80.0], dtype=F64))[:, None]
    c = torch.cos(th)
    a = torch.tensor([0.25, 0.5, 0.8], dtype=F64)[None, :]
    ref = xyz_to_lab(thin_film_xyz_uniform(c, a, **FILM, nodes=48))
    orig = thin_film_xyz_fourier(c.expand(4, 3), **FILM, terms=2, sensitivity="exact")
    A, mu, cov = uniform_light_moments(c, a, nodes=48)
    wo = torch.stack([torch.sqrt(1 - c * c), torch.zeros_like(c), c], -1).expand(4, 3, 3)
    kn = thin_film_xyz_filtered(wo, mu, cov, **FILM, sensitivity="exact")
    assert delta_e_2000(xyz_to_lab(kn), ref).mean() < 0.5 * delta_e_2000(xyz_to_lab(orig), ref).mean()


def test_validation():
    with pytest.raises(ValueError, match="cos_theta_o"):
        uniform_light_moments(torch.tensor(0.0, dtype=F64), 0.3)
    with pytest.raises(ValueError, match="alpha"):
        uniform_light_moments(torch.tensor(0.5, dtype=F64), 0.0)
    with pytest.raises(ValueError, match="nodes"):
        uniform_lobe_quadrature(torch.tensor(0.5, dtype=F64), 0.3, nodes=1)
    with pytest.raises(ValueError, match="bins"):
        cos_theta1_distribution(torch.tensor(0.5, dtype=F64), 0.3, bins=0)
    with pytest.raises(ValueError, match="n_film"):
        path_difference_moments(torch.tensor(0.5, dtype=F64), 0.3, 0.9, 100.0)


@pytest.mark.parametrize("function", ["uniform_light_moments", "cos_theta1_distribution"])
def test_geometry_blocks_follow_the_chunk_knob(function):
    """Geometries are evaluated in blocks of torchirid.options(chunk_size=...) // (2 · nodes²)
    points (torchirid._chunks); None: in one piece. Each geometry is independent: the same values."""
    from block_sizes import largest_tensor

    c = torch.linspace(0.05, 1.0, 400, dtype=F64)
    if function == "uniform_light_moments":
        call = lambda: torch.cat([t.reshape(400, -1) for t in uniform_light_moments(c, 0.3, nodes=4)], -1)  # noqa: E731
    else:
        call = lambda: torch.cat([t.reshape(400, -1) for t in cos_theta1_distribution(c, 0.3, nodes=4, bins=16)[1:]],
                                 -1)  # noqa: E731
    ref, whole = largest_tensor(call, None)
    got, block = largest_tensor(call, 2048)
    torch.testing.assert_close(got, ref, rtol=1e-15, atol=1e-17)
    assert whole >= 400 * 32 * 3  # one piece: every geometry's quadrature directions at once
    assert block < whole / 4  # blocks of 64 geometries (2048 // 32 = 64, the least a block holds)


def test_film_blocks_of_thin_film_xyz_uniform_follow_the_chunk_knob():
    """The films' spectra on the cos θ1 grid are computed in blocks of films (films × bins × W ≤
    torchirid.options(chunk_size=...), at least one film; None: all at once). Films are
    independent: the same colours."""
    from block_sizes import largest_tensor

    d = torch.linspace(100.0, 700.0, 12, dtype=F64)
    lam = torch.linspace(380.0, 780.0, 41, dtype=F64)
    call = lambda: thin_film_xyz_uniform(torch.tensor(0.7, dtype=F64), 0.2, 1.3, d, 1.5, bins=16, nodes=4,  # noqa: E731
                                         wavelength=lam)
    ref, whole = largest_tensor(call, None)
    got, block = largest_tensor(call, 2 * 17 * 41)  # two films per block
    torch.testing.assert_close(got, ref, rtol=1e-15, atol=1e-17)
    assert whole >= 12 * 17 * 41  # one piece: every film's spectra on the grid
    assert block < whole / 4
