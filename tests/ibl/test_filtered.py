import math

import numpy as np
import pytest
import torch

from torchirid.ibl import thin_film_xyz_filtered, thin_film_xyz_fourier

F64 = torch.float64
FILM = dict(n_film=1.3, thickness=600.0, n_substrate=complex(2.0, 0.5))  # Kneiphof's Fig. 2 film


def _frame(theta_o):
    s, c = math.sin(theta_o), math.cos(theta_o)
    wo = torch.tensor([s, 0.0, c], dtype=F64)
    r = torch.tensor([-s, 0.0, c], dtype=F64)  # mirror of wo about the normal h = +z
    t1 = torch.tensor([c, 0.0, s], dtype=F64)
    t2 = torch.tensor([0.0, 1.0, 0.0], dtype=F64)
    return wo, r, t1, t2


def _gaussian_lobe(theta_o, sigma, n=24):
    """Light directions normalize(r + σ(x t1 + y t2)), (x, y) ~ N(0, I) by Gauss–Hermite; exact moments."""
    wo, r, t1, t2 = _frame(theta_o)
    x, w = np.polynomial.hermite_e.hermegauss(n)
    w = w / w.sum()
    X, Y = (torch.tensor(v.ravel()) for v in np.meshgrid(x, x))
    W = torch.tensor((w[:, None] * w[None]).ravel())
    wi = r + sigma * (X[:, None] * t1 + Y[:, None] * t2)
    wi = wi / wi.norm(dim=-1, keepdim=True)
    mean = (W[:, None] * wi).sum(0)
    dev = wi - mean
    cov = (W[:, None, None] * dev[:, :, None] * dev[:, None, :]).sum(0)
    return wo, wi, W, mean, cov


def _reference(wo, wi, W, **film):
    cos_h = torch.sqrt((1 + (wi * wo).sum(-1)) / 2)  # ⟨h, ωi⟩ per light direction (eq. 22)
    xyz = thin_film_xyz_fourier(cos_h, film["n_film"], film["thickness"], film["n_substrate"], terms=2,
                                sensitivity="exact")
    return (W[:, None] * xyz).sum(0)


@pytest.mark.parametrize("theta_o", [0.0, 0.4, 1.1])
@pytest.mark.parametrize("n_substrate", [1.5, complex(2.0, 0.5)])
def test_delta_light_equals_fourier_at_mirror(theta_o, n_substrate):
    wo, r, _, _ = _frame(theta_o)
    got = thin_film_xyz_filtered(wo, r, torch.zeros(3, 3, dtype=F64), 1.3, 600.0, n_substrate, terms=2, sensitivity="exact")
    cos_h = torch.sqrt((1 + (wo * r).sum()) / 2)
    ref = thin_film_xyz_fourier(cos_h, 1.3, 600.0, n_substrate, terms=2, sensitivity="exact")
    assert (got - ref).abs().max() < 1e-12
    # Σ → 0 continuously
    tiny = thin_film_xyz_filtered(wo, r, 1e-12 * torch.eye(3, dtype=F64), 1.3, 600.0, n_substrate, terms=2, sensitivity="exact")
    assert (tiny - ref).abs().max() < 1e-6


@pytest.mark.parametrize("theta_o", [0.3, 0.7, 1.0])
@pytest.mark.parametrize("sigma,tol", [(0.02, 2e-4), (0.05, 1e-3), (0.1, 3e-3)])
def test_matches_average_over_gaussian_lobe(theta_o, sigma, tol):
    wo, wi, W, mean, cov = _gaussian_lobe(theta_o, sigma)
    ref = _reference(wo, wi, W, **FILM)
    got = thin_film_xyz_filtered(wo, mean, cov, **FILM, sensitivity="exact")
    assert (got - ref).abs().max() < tol


@pytest.mark.parametrize("theta_o", [0.3, 0.7])
def test_filtering_beats_the_mean_direction(theta_o):
    # where the Fresnel terms vary little, the spread of D is what matters (Kneiphof Fig. 2)
    wo, wi, W, mean, cov = _gaussian_lobe(theta_o, 0.1)
    ref = _reference(wo, wi, W, **FILM)
    err = (thin_film_xyz_filtered(wo, mean, cov, **FILM, sensitivity="exact") - ref).abs().max()
    err0 = (thin_film_xyz_filtered(wo, mean, torch.zeros_like(cov), **FILM, sensitivity="exact") - ref).abs().max()
    assert err < 0.25 * err0


def test_broadcasting_and_batch_consistency():
    g = torch.Generator().manual_seed(0)
    wo = torch.nn.functional.normalize(torch.rand(4, 1, 3, generator=g, dtype=F64) + 0.2, dim=-1)
    mean = 0.9 * torch.nn.functional.normalize(torch.rand(1, 5, 3, generator=g, dtype=F64) + 0.2, dim=-1)
    A = 0.05 * torch.randn(5, 3, 3, generator=g, dtype=F64)
    cov = A @ A.transpose(-1, -2)
    d = torch.tensor([[200.0], [400.0], [600.0], [800.0]], dtype=F64)
    out = thin_film_xyz_filtered(wo, mean, cov, 1.4, d, complex(1.2, 2.0), sensitivity="exact")
    assert out.shape == (4, 5, 3)
    for i, j in ((0, 0), (3, 4), (2, 1)):
        one = thin_film_xyz_filtered(wo[i, 0], mean[0, j], cov[j], 1.4, d[i, 0], complex(1.2, 2.0), sensitivity="exact")
        assert torch.allclose(out[i, j], one, atol=1e-14)
    assert thin_film_xyz_filtered(wo, mean, cov, 1.4, d, 1.5, terms=0, sensitivity="exact").shape == (4, 5, 3)


def test_gradients_finite_at_zero_covariance_and_float32():
    wo, r, _, _ = _frame(0.5)
    cov = torch.zeros(3, 3, dtype=F64, requires_grad=True)
    mean = r.clone().requires_grad_(True)
    d = torch.tensor(500.0, dtype=F64, requires_grad=True)
    thin_film_xyz_filtered(wo, mean, cov, 1.3, d, complex(2.0, 0.5), sensitivity="exact").sum().backward()
    for t in (cov, mean, d):
        assert torch.isfinite(t.grad).all()
    assert cov.grad.abs().sum() > 0  # σ²_D enters linearly: the blur has a gradient at Σ = 0
    out32 = thin_film_xyz_filtered(wo.float(), r.float(), 1e-3 * torch.eye(3), 1.3, 600.0, 1.5, sensitivity="exact")
    out64 = thin_film_xyz_filtered(wo, r, 1e-3 * torch.eye(3, dtype=F64), 1.3, 600.0, 1.5, sensitivity="exact")
    assert out32.dtype == torch.float32 and (out32.double() - out64).abs().max() < 1e-5


def test_backscatter_and_grazing_finite():
    wo = torch.tensor([0.0, 0.0, 1.0], dtype=F64)
    out = thin_film_xyz_filtered(wo, -wo, torch.zeros(3, 3, dtype=F64), 1.0, 300.0, 1.5, sensitivity="exact")  # cos θ1 = 0, η2 = η1
    assert torch.isfinite(out).all()


@pytest.mark.parametrize("kwargs,name", [
    (dict(wo=torch.zeros(3, dtype=F64)), "wo"),
    (dict(wo=torch.ones(2, dtype=F64)), "wo"),
    (dict(light_mean=torch.ones(4, dtype=F64)), "light_mean"),
    (dict(light_mean=torch.tensor([0.0, 0.0, 1.5], dtype=F64)), "light_mean"),
    (dict(light_cov=torch.zeros(3, dtype=F64)), "light_cov"),
    (dict(light_cov=torch.zeros(2, 2, dtype=F64)), "light_cov"),
    (dict(thickness=-1.0), "thickness"),
    (dict(n_film=0.0), "n_film"),
    (dict(n_film=0.9), "n_film"),
    (dict(terms=-1), "terms"),
    (dict(terms=1.5), "terms"),
    (dict(polarization="x"), "polarization"),
])
def test_bad_input_raises(kwargs, name):
    args = dict(wo=torch.tensor([0.0, 0.0, 1.0], dtype=F64), light_mean=torch.tensor([0.0, 0.0, 1.0], dtype=F64),
                light_cov=torch.zeros(3, 3, dtype=F64), n_film=1.3, thickness=600.0, n_substrate=1.5)
    args.update(kwargs)
    with pytest.raises(ValueError, match=name):
        thin_film_xyz_filtered(**args)


@pytest.mark.parametrize("arg", ["wo", "light_mean", "light_cov", "thickness"])
def test_nan_propagates(arg):
    """NaN inputs give NaN colours (the guarded √ of cos θ1* used to turn a NaN mean direction into 0)."""
    nan = float("nan")
    args = dict(wo=torch.tensor([[0.0, 0.0, 1.0]] * 2, dtype=torch.float64),
                light_mean=torch.tensor([[0.1, 0.0, 0.9]] * 2, dtype=torch.float64),
                light_cov=0.01 * torch.eye(3, dtype=torch.float64).expand(2, 3, 3).clone(),
                thickness=torch.tensor([300.0, 300.0], dtype=torch.float64))
    bad = args[arg].clone()
    bad[0] = nan
    args[arg] = bad
    out = thin_film_xyz_filtered(args["wo"], args["light_mean"], args["light_cov"], 1.4, args["thickness"], 1.5, sensitivity="exact")
    assert torch.isnan(out[0]).all() and torch.isfinite(out[1]).all()
