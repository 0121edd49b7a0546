"""optics._transfer_scan: the recursion as a tree of 2×2 products equals the film loop, and
optics.transfer.stack_pieces / stack_response equal torchirid.multilayer."""

from __future__ import annotations

import pytest
import torch

import torchirid
from torchirid.optics._transfer_fast import reflect_transmit
from torchirid.optics._transfer_scan import fits, reflect_transmit_scan
from torchirid.optics.transfer import stack_pieces, stack_response


@pytest.mark.parametrize("L", [1, 2, 3, 5, 8, 13, 40, 96])
@pytest.mark.parametrize("P", [1, 2])
def test_tree_equals_loop(L, P):
    g = torch.Generator().manual_seed(L * 10 + P)
    batch = (4, 3, 2)
    r = torch.complex(torch.randn(P, 1, 3, 2, L + 1, generator=g, dtype=torch.float64),
                      torch.randn(P, 1, 3, 2, L + 1, generator=g, dtype=torch.float64)) * 0.35
    t2 = torch.rand(P, 1, 3, 2, L + 1, generator=g, dtype=torch.float64) + 0.5
    k = torch.complex(torch.rand(4, 3, 2, L, generator=g, dtype=torch.float64) * 3000,
                      torch.rand(4, 3, 2, L, generator=g, dtype=torch.float64) * 30)  # absorbing films
    u = torch.rand(3, 1, generator=g, dtype=torch.float64) * 0.002 + 0.001
    a = reflect_transmit_scan(r, t2, k, u, batch)
    b = reflect_transmit(r, t2, k, u, batch)
    torch.testing.assert_close(a[0], b[0], rtol=1e-12, atol=1e-14)
    torch.testing.assert_close(a[1], b[1], rtol=1e-11, atol=1e-300)


def test_gradients_equal():
    L = 9
    g = torch.Generator().manual_seed(0)
    r = torch.complex(torch.randn(2, 5, L + 1, generator=g, dtype=torch.float64),
                      torch.zeros(2, 5, L + 1, dtype=torch.float64)) * 0.3
    t2 = torch.rand(2, 5, L + 1, generator=g, dtype=torch.float64) + 0.5
    d = (torch.rand(5, L, generator=g, dtype=torch.float64) * 200).requires_grad_(True)
    u = torch.tensor(1 / 550.0, dtype=torch.float64)
    grads = []
    for fn in (reflect_transmit_scan, lambda *a: reflect_transmit(*a)):
        d.grad = None
        R, T = fn(r, t2, (2 * 3.14159 * 1.6) * d + 0j, u, (5,))
        (R.sum() + 0.3 * T.sum()).backward()
        grads.append(d.grad.clone())
    torch.testing.assert_close(grads[0], grads[1], rtol=1e-10, atol=1e-14)


def test_out_of_range_gives_none_and_the_response_falls_back():
    """Films at exactly 0/0 (a zero-thickness film between two grazing-like media) leave the
    normal range: the tree answers None and stack_response takes the guarded film loop."""
    r = torch.tensor([[[-1.0 + 0j, 1.0 + 0j]]], dtype=torch.complex128)  # r = -1 then +1
    t2 = torch.ones(1, 1, 2, dtype=torch.float64)
    k = torch.zeros(1, 1, dtype=torch.complex128)
    assert reflect_transmit_scan(r, t2, k, torch.tensor(1.0, dtype=torch.float64), (1,)) is None
    R, T = stack_response(r, t2, k, torch.zeros(1, 1, dtype=torch.float64), torch.tensor(1.0, dtype=torch.float64),
                          (1,))
    assert torch.isfinite(R).all() and torch.isfinite(T).all()


def test_fits():
    assert fits(20, 2, (40, 1, 1)) and not fits(20, 2, (80, 50, 1)) and not fits(97, 1, (1,))
    assert not fits(0, 1, (1,))


@pytest.mark.parametrize("polarization", ["s", "p", "unpolarized"])
@pytest.mark.parametrize("B", [3, 300])  # the tree, the loop
def test_pieces_and_response_equal_multilayer(polarization, B):
    g = torch.Generator().manual_seed(B)
    lam = torch.tensor([450.0, 550.0, 700.0], dtype=torch.float64)
    c = torch.tensor([1.0, 0.6, 0.1], dtype=torch.float64)
    n = torch.tensor([1.0, 2.3, 1.46 + 0.01j, 2.3, 1.46, 0.2 + 3.0j], dtype=torch.complex128)
    d = torch.rand(B, 4, generator=g, dtype=torch.float64) * 300
    r, t2, kq = stack_pieces(c, n.expand(3, 1, 6), polarization)  # [P, W=3, A=3, ...]
    R, T = stack_response(r, t2, kq, d[:, None, None, :], (1 / lam)[:, None], (B, 3, 3))
    Rm, Tm = torchirid.multilayer(lam[:, None], c, n, d[:, None, None, :], polarization=polarization)
    torch.testing.assert_close(R, Rm, rtol=1e-12, atol=1e-14)
    torch.testing.assert_close(T, Tm, rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("polarization", ["s", "p"])
def test_stack_fluxes_equal_tmm_absorption_per_layer(polarization):
    import math

    import numpy as np
    import tmm

    from torchirid.optics.transfer import stack_fluxes

    n = [1.0, 2.0 + 0.3j, 1.46, 0.15 + 3.5j, 1.8, 1.52 + 0.01j]
    d = [80.0, 120.0, 15.0, 60.0]
    for lam, c in ((500.0, 1.0), (620.0, 0.6), (700.0, 0.2)):
        F = stack_fluxes(torch.tensor(c, dtype=torch.float64), torch.tensor(n, dtype=torch.complex128),
                         torch.tensor(d, dtype=torch.float64), torch.tensor(1 / lam, dtype=torch.float64), polarization)
        res = tmm.coh_tmm(polarization, n, [np.inf, *d, np.inf], math.acos(c), lam)
        np.testing.assert_allclose((F[:-1] - F[1:]).numpy(), tmm.absorp_in_each_layer(res)[1:-1], atol=1e-13)
        assert F[0].item() == pytest.approx(1 - res["R"], abs=1e-13)
        assert F[-1].item() == pytest.approx(res["T"], abs=1e-13)


def test_stack_fluxes_through_a_thick_absorber_stay_finite():
    """30 µm of an absorber inside the stack (fields grow e^{Im δ} ~ e^{60} upwards): rescaled
    film by film, the fluxes stay finite; it absorbs all that enters it, nothing crosses it."""
    from torchirid.optics.transfer import stack_fluxes

    n = torch.tensor([1.0, 1.46, 4.0 + 0.2j, 1.46, 1.5], dtype=torch.complex128)
    d = torch.tensor([100.0, 30000.0, 100.0], dtype=torch.float64)
    F = stack_fluxes(torch.tensor(1.0, dtype=torch.float64), n, d, torch.tensor(1 / 600.0, dtype=torch.float64), "s")
    assert torch.isfinite(F).all()
    R, _ = torchirid.multilayer(torch.tensor(600.0, dtype=torch.float64), 1.0, n, d, polarization="s")
    assert F[0].item() == pytest.approx(1 - R.item(), abs=1e-12)
    assert F[2].item() < 1e-40 and (F[1] - F[2]).item() == pytest.approx(F[1].item(), rel=1e-12)
