"""nn.Module wrappers: same values as the functions, gradients reach every parameter, fitting works."""

import pytest
import torch

import torchirid as ti
from tensors import t64
from torchirid.optics.modules import raw_parameters


def test_bragg_module_equals_function_and_learns():
    lam = torch.linspace(400, 700, 31, dtype=torch.float64)
    c = t64([1.0, 0.6])[:, None]
    m = ti.BraggMirror(n2=1.5, d1=125.0, d2=375.0, cells=20, polarization="s")
    R = m(lam, c)
    # n1 = 1 starts 1e-12 inside its bound (module docstring)
    torch.testing.assert_close(R, ti.bragg_reflectance(lam, c, 1.0, 1.5, 125.0, 375.0, 20, polarization="s"),
                               rtol=0, atol=1e-10)
    R.sum().backward()
    raw = raw_parameters(m)
    assert sorted(raw) == ["d1", "d2", "n1", "n2"]
    for name in ("n2", "d1", "d2"):
        p = raw[name]
        assert p.grad is not None and torch.isfinite(p.grad).all() and p.grad.abs() > 0
    assert "cells=20" in repr(m)


def test_thin_film_fit_recovers_thickness():
    lam = torch.linspace(400, 700, 61, dtype=torch.float64)
    c = t64(0.9)
    target = ti.thin_film_reflectance(lam, c, 1.4, 310.0, 1.5)
    m = ti.ThinFilm(n_film=1.4, thickness=300.0, n_substrate=1.5)
    opt = torch.optim.LBFGS(m.parameters(), lr=1.0, max_iter=200, tolerance_grad=1e-14,
                            tolerance_change=1e-16, line_search_fn="strong_wolfe")
    raw_parameters(m)["n_film"].requires_grad_(False)

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
    g = raw_parameters(m)["thicknesses"].grad
    assert g is not None and torch.isfinite(g).all()


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


def test_any_optimiser_step_leaves_a_valid_structure():
    """Issue 22.6: one huge step used to give d < 0 or n < 1, and the next call raised mid-training.
    Now every raw value maps to a valid stack (d > 0, n > 1) and the call after the step works."""
    lam = torch.linspace(400, 700, 16, dtype=torch.float64)
    c = t64(0.8)
    for module in (ti.BraggMirror(n2=1.5, d1=125.0, d2=375.0, cells=10), ti.ThinFilm(n_film=1.4, thickness=300.0,
                                                                                      n_substrate=1.5),
                   ti.Multilayer(torch.tensor([1.0, 1.5, 2.0, 1.52]), [80.0, 120.0])):
        opt = torch.optim.SGD(module.parameters(), lr=1e6)
        for sign in (1.0, -1.0):
            out = module(lam, c)
            loss = sign * (out[0] if isinstance(out, tuple) else out).sum()
            opt.zero_grad()
            loss.backward()
            opt.step()  # a step of ~1e6 in the raw values
            out = module(lam, c)  # raised ValueError before
            R = out[0] if isinstance(out, tuple) else out
            assert torch.isfinite(R).all() and bool(((R >= 0) & (R <= 1)).all())
        for name, raw in raw_parameters(module).items():
            value = getattr(module, name)
            assert torch.isfinite(value).all(), name
            assert bool((value >= (1.0 if name.startswith("n") else 0.0)).all()), (name, value)  # (softplus may underflow to the bound)


def test_values_round_trip_and_bounds_are_checked():
    m = ti.ThinFilm(n_film=1.38, thickness=123.4)
    assert abs(m.n_film.item() - 1.38) < 1e-12 and abs(m.thickness.item() - 123.4) < 1e-12
    m32 = ti.ThinFilm(n_film=2.0, thickness=5000.0, dtype=torch.float32)  # no overflow in float32
    assert abs(m32.thickness.item() - 5000.0) < 1e-3 and m32.thickness.dtype == torch.float32
    with pytest.raises(ValueError, match="thickness"):
        ti.ThinFilm(thickness=-1.0)
    with pytest.raises(ValueError, match="n_film"):
        ti.ThinFilm(n_film=0.9)
    assert ti.ThinFilm(n_film=0.9, min_index=0.5).n_film.item() == pytest.approx(0.9)
    mirror = ti.BraggMirror(cells=20)
    with pytest.raises(ValueError, match="cells"):
        mirror.cells = 20.5
    mirror.cells = 30
    assert mirror.cells == 30 and "cells=30" in repr(mirror)
