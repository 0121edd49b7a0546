"""nn.Module wrappers: same values as the functions, gradients reach every parameter, fitting works."""

import torch

import torchirid as ti
from tensors import t64


def test_bragg_module_equals_function_and_learns():
    lam = torch.linspace(400, 700, 31, dtype=torch.float64)
    c = t64([1.0, 0.6])[:, None]
    m = ti.BraggMirror(n2=1.5, d1=125.0, d2=375.0, cells=20, polarization="s")
    R = m(lam, c)
    assert torch.equal(R, ti.bragg_reflectance(lam, c, 1.0, 1.5, 125.0, 375.0, 20, polarization="s"))
    R.sum().backward()
    for p in (m.n1, m.n2, m.d1, m.d2):
        assert p.grad is not None and torch.isfinite(p.grad).all() and p.grad.abs() > 0
    assert "cells=20" in repr(m)


def test_thin_film_fit_recovers_thickness():
    lam = torch.linspace(400, 700, 61, dtype=torch.float64)
    c = t64(0.9)
    target = ti.thin_film_reflectance(lam, c, 1.4, 310.0, 1.5)
    m = ti.ThinFilm(n_film=1.4, thickness=300.0, n_substrate=1.5)
    opt = torch.optim.LBFGS(m.parameters(), lr=1.0, max_iter=200, tolerance_grad=1e-14,
                            tolerance_change=1e-16, line_search_fn="strong_wolfe")
    m.n_film.requires_grad_(False)

    def closure():
        opt.zero_grad()
        loss = ((m(lam, c) - target) ** 2).sum()
        loss.backward()
        return loss

    opt.step(closure)
    assert abs(m.thickness.item() - 310.0) < 1e-4


def test_multilayer_module_complex_buffer():
    m = ti.Multilayer(torch.tensor([1.0, 1.5, 0.2 + 3.0j]), [80.0])
    R, T = m(t64(550.0), t64(1.0))
    Rf, Tf = ti.multilayer(t64(550.0), t64(1.0), torch.tensor([1.0, 1.5, 0.2 + 3.0j], dtype=torch.complex128),
                           t64([80.0]))
    assert torch.allclose(R, Rf, atol=1e-15) and torch.allclose(T, Tf, atol=1e-15) and T.item() > 0
    R.backward()
    assert m.thicknesses.grad is not None and torch.isfinite(m.thicknesses.grad).all()


def test_float32_modules_with_complex_media_stay_float32():
    """A float32 module keeps its dtype with a complex (absorbing) medium: the complex buffer is
    complex64, so the reflectance comes back float32 (it used to be promoted to float64)."""
    lam = torch.linspace(400, 700, 4, dtype=torch.float32)
    c = torch.tensor(0.8, dtype=torch.float32)
    film = ti.ThinFilm(n_film=1.4, thickness=300.0, n_substrate=0.2 + 3.0j, dtype=torch.float32)
    assert film.n_substrate.dtype == torch.complex64
    R = film(lam, c)
    assert R.dtype == torch.float32
    ref = ti.thin_film_reflectance(lam.double(), c.double(), 1.4, 300.0, 0.2 + 3.0j)
    assert torch.allclose(R.double(), ref, atol=1e-5)
    stack = ti.Multilayer(torch.tensor([1.0, 1.5, 0.2 + 3.0j]), [80.0], dtype=torch.float32)
    R, T = stack(lam, c)
    assert R.dtype == torch.float32 and T.dtype == torch.float32
