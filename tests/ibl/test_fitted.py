"""The fitted light-mixture table (torchirid.ibl.fitted)."""

import math

import pytest
import torch

from torchirid import xyz_to_lab
from torchirid.color import delta_e_2000
from torchirid.ibl import (
    light_mixture_lut,
    thin_film_xyz_fitted,
    thin_film_xyz_filtered,
    light_mixture,
    shipped_light_mixture_lut,
    thin_film_xyz_fourier,
    uniform_light_moments,
    thin_film_xyz_uniform,
)
from torchirid.ibl.uniform import cos_theta1_distribution

F64 = torch.float64
FILM = dict(n_film=1.3, thickness=600.0, n_substrate=complex(2.0, 0.5))


def test_mixture_preserves_mass_mean_and_second_moment():
    c = torch.tensor([0.1, 0.6, 0.95], dtype=F64)
    a = torch.tensor([0.8, 0.3, 0.05], dtype=F64)
    mix = light_mixture(c, a, nodes=32)
    grid, w, _ = cos_theta1_distribution(c, a, nodes=32)
    wk, mk, vk = mix.unbind(-1)
    assert torch.allclose(wk.sum(-1), torch.ones(3, dtype=F64), atol=1e-12)
    assert torch.allclose((wk * mk).sum(-1), (w * grid).sum(-1), atol=1e-12)
    assert torch.allclose((wk * (vk + mk * mk)).sum(-1), (w * grid * grid).sum(-1), atol=1e-12)
    assert (mk[..., 1:] >= mk[..., :-1] - 1e-12).all()  # pieces are ordered in cos θ1


def test_table_nodes_equal_direct_mixture_and_shipped_table():
    lut = light_mixture_lut(theta_nodes=3, alpha_nodes=3, nodes=32, dtype=F64)
    c = lut.axes["cos_theta_o"][1]
    sa = lut.axes["sqrt_alpha"][2]
    direct = light_mixture(c, sa * sa, nodes=32)
    assert torch.allclose(lut(cos_theta_o=c, sqrt_alpha=sa), direct, atol=1e-12)
    shipped = shipped_light_mixture_lut()
    assert shipped.parameters["quantiles"] == [0.05, 0.3, 0.7, 0.95]
    cs, ss = shipped.axes["cos_theta_o"][30], shipped.axes["sqrt_alpha"][20]
    assert torch.allclose(shipped(cos_theta_o=cs, sqrt_alpha=ss), light_mixture(cs, ss * ss), atol=2e-6)


def test_fitted_beats_kneiphof_and_original():
    th = torch.deg2rad(torch.tensor([5.0, 30.0, 55.0, 70.0, 82.0], dtype=F64))[:, None]
    c = torch.cos(th)
    a = torch.tensor([0.03, 0.2, 0.45, 0.9], dtype=F64)[None, :]
    d = 600.0
    ref = xyz_to_lab(thin_film_xyz_uniform(c, a, **FILM, nodes=48))
    fit = delta_e_2000(xyz_to_lab(thin_film_xyz_fitted(c, a, **FILM, sensitivity="exact")), ref)
    A, mu, cov = uniform_light_moments(c, a, nodes=48)
    wo = torch.stack([torch.sqrt(1 - c * c), torch.zeros_like(c), c], -1).expand(5, 4, 3)
    kn = delta_e_2000(xyz_to_lab(thin_film_xyz_filtered(wo, mu, cov, **FILM, sensitivity="exact")), ref)
    orig = delta_e_2000(xyz_to_lab(thin_film_xyz_fourier(c.expand(5, 4), **FILM, terms=2, sensitivity="exact")), ref)
    assert fit.mean() < 0.5 and fit.max() < 2.0
    assert fit.mean() < 0.25 * kn.mean() and fit.mean() < 0.1 * orig.mean()


@pytest.mark.parametrize("base", [1.5, complex(0.2, 3.0)])
def test_fitted_generalises_to_other_films(base):
    """The table depends on the geometry only: other film indices, thicknesses and bases."""
    c = torch.tensor([0.9, 0.5, 0.2], dtype=F64)
    a = torch.tensor([0.1, 0.4, 0.7], dtype=F64)
    for nf, d in ((1.6, 350.0), (2.0, 900.0)):
        ref = xyz_to_lab(thin_film_xyz_uniform(c, a, nf, d, base, nodes=48))
        de = delta_e_2000(xyz_to_lab(thin_film_xyz_fitted(c, a, nf, d, base, sensitivity="exact")), ref)
        assert de.max() < 2.0


def test_gradients_and_validation():
    lut = shipped_light_mixture_lut(dtype=F64)
    d = torch.tensor([650.0], dtype=F64, requires_grad=True)
    nf = torch.tensor(1.4, dtype=F64, requires_grad=True)
    c = torch.tensor([0.4], dtype=F64)
    assert torch.autograd.gradcheck(lambda d, nf: thin_film_xyz_fitted(c, 0.3, nf, d, 1.5, table=lut, sensitivity="exact"), (d, nf))
    xyz = thin_film_xyz_fitted(c, 0.3, nf, d, 1.5, sensitivity="exact")
    xyz.sum().backward()
    assert torch.isfinite(d.grad).all() and torch.isfinite(nf.grad)
    with pytest.raises(ValueError, match="table"):
        thin_film_xyz_fitted(c, 0.3, 1.3, 600.0, 1.5, table="nope", sensitivity="exact")
    with pytest.raises(ValueError, match="cos_theta_o"):
        thin_film_xyz_fitted(torch.tensor(1.5, dtype=F64), 0.3, 1.3, 600.0, 1.5, sensitivity="exact")
    with pytest.raises(ValueError, match="quantiles"):
        light_mixture(torch.tensor(0.5, dtype=F64), 0.3, quantiles=(0.5, 0.2))


@pytest.mark.slow
def test_sensitivity_lut_mode_close_to_exact():
    c = torch.tensor([0.9, 0.5, 0.15], dtype=F64)
    a = torch.tensor([0.05, 0.3, 0.6], dtype=F64)
    d = torch.tensor([150.0, 600.0, 950.0], dtype=F64)
    ex = xyz_to_lab(thin_film_xyz_fitted(c, a, 1.3, d, complex(2.0, 0.5), sensitivity="exact"))
    lut = xyz_to_lab(thin_film_xyz_fitted(c, a, 1.3, d, complex(2.0, 0.5), sensitivity="lut"))
    assert delta_e_2000(lut, ex).max() < 0.3
    with pytest.raises(ValueError, match="sensitivity"):
        thin_film_xyz_fitted(c, a, 1.3, d, 1.5, sensitivity="table")


def test_film_batches_broadcast_against_scalar_lobe_arguments():
    """A scalar cos θo / α with a batch of film parameters (the mixture axis used to meet the film
    axes: a shape error, or shape (3,) for a thickness of shape (1,))."""
    from torchirid.ibl import thin_film_xyz_fitted

    d = torch.tensor([300.0, 450.0], dtype=torch.float64)
    out = thin_film_xyz_fitted(0.8, 0.3, 1.33, d, 1.5, sensitivity="exact")
    assert out.shape == (2, 3)
    for i in range(2):
        assert torch.allclose(out[i], thin_film_xyz_fitted(0.8, 0.3, 1.33, d[i], 1.5, sensitivity="exact"), rtol=1e-12, atol=0)
    assert thin_film_xyz_fitted(0.8, 0.3, 1.33, d[:1], 1.5, sensitivity="exact").shape == (1, 3)
    sub = torch.tensor([1.5, 2.0 + 0.5j], dtype=torch.complex128)
    both = thin_film_xyz_fitted(0.8, 0.3, 1.33, d[0], sub, sensitivity="exact")
    assert torch.allclose(both[1], thin_film_xyz_fitted(0.8, 0.3, 1.33, d[0], 2.0 + 0.5j, sensitivity="exact"), rtol=1e-12, atol=0)


def test_alpha_above_the_table_raises_instead_of_clamping():
    """α > 1 is outside the fitted table: a ValueError, not a silent α = 1 (the uniform-light
    reference computes α = 2 and differs)."""
    from torchirid.ibl import thin_film_xyz_fitted, thin_film_xyz_uniform

    c = torch.tensor(0.8, dtype=torch.float64)
    with pytest.raises(ValueError, match="alpha must be <= 1"):
        thin_film_xyz_fitted(c, 2.0, 1.3, 600.0, 1.5, sensitivity="exact")
    assert torch.isfinite(thin_film_xyz_fitted(c, 1.0, 1.3, 600.0, 1.5, sensitivity="exact")).all()
    assert torch.isfinite(thin_film_xyz_uniform(c, 2.0, 1.3, 600.0, 1.5, nodes=16)).all()
