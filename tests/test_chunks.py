"""Chunked evaluation (issue 23.1): large batches are evaluated block by block when no gradient is
wanted; the values equal the one-piece evaluation (to the last bit or two: vectorised loop tails),
and gradients, shapes and dtypes are unchanged."""

from __future__ import annotations

import pytest
import torch

import torchirid as ti

F64 = torch.float64


def _grid(W=401, A=90, dtype=F64):
    lam = torch.linspace(380.0, 780.0, W, dtype=dtype)
    c = torch.cos(torch.linspace(0.0, 1.5707963, A, dtype=dtype))[:, None]
    return lam, c


CASES = {
    "bragg": lambda lam, c: ti.bragg_reflectance(lam, c, 1.0, 1.5, 125.0, 375.0, 20),
    "bragg_tir": lambda lam, c: ti.bragg_reflectance(lam, c, 1.5, 1.2, 125.0, 375.0, 20),
    "bragg_absorbing": lambda lam, c: ti.bragg_reflectance(lam, c, 1.0, 1.5 + 0.01j, 125.0, 375.0, 9),
    "bragg_host": lambda lam, c: ti.bragg_reflectance(lam, c, 1.2, 1.6, 125.0, 375.0, 20, n_incident=1.0),
    "thin_film": lambda lam, c: ti.thin_film_reflectance(lam, c, 1.33, 800.0, 0.2 + 3.0j),
    "thin_film_batch_d": lambda lam, c: ti.thin_film_reflectance(lam, c[:, :, None], 1.33,
                                                                 torch.tensor([[10.0], [300.0]], dtype=lam.dtype), 1.5),
}


@pytest.mark.parametrize("name", sorted(CASES))
@pytest.mark.parametrize("points", [1, 977, 5000])
def test_chunked_equals_one_piece(name, points):
    lam, c = _grid()
    with ti.chunk_size(None):
        ref = CASES[name](lam, c)
    with ti.chunk_size(points):
        got = CASES[name](lam, c) if points > 1 else CASES[name](lam[:37], c[:5])
    if points == 1:
        with ti.chunk_size(None):
            ref = CASES[name](lam[:37], c[:5])
    assert got.shape == ref.shape and got.dtype == ref.dtype
    # ≤ a few ulp (vectorised loop tails); Bragg's real closed form picks its guarded branch near
    # critical angles from the minimum over the batch it is given, so a block may take the other
    # (equally accurate, 1e-12 vs tmm) branch: up to 5e-13 there (bragg_tir)
    torch.testing.assert_close(got, ref, rtol=0, atol=1e-12 if name.startswith("bragg") else 2e-15)
    assert not got.is_inference()


def test_float32_and_gradients_unchanged():
    lam, c = _grid(dtype=torch.float32)
    with ti.chunk_size(None):
        ref = CASES["bragg"](lam, c)
    with ti.chunk_size(1000):
        got = CASES["bragg"](lam, c)
    assert got.dtype == torch.float32
    torch.testing.assert_close(got, ref, rtol=0, atol=2e-6)
    d = torch.tensor(300.0, dtype=F64, requires_grad=True)
    lam, c = _grid()
    with ti.chunk_size(1000):  # a gradient is wanted: one piece, autograd as usual
        R = ti.thin_film_reflectance(lam, c, 1.33, d, 1.5)
    R.sum().backward()
    assert d.grad is not None and torch.isfinite(d.grad)


def test_knob():
    assert ti.get_chunk_size() == 1 << 15
    with ti.chunk_size(123):
        assert ti.get_chunk_size() == 123
        with ti.chunk_size(0):
            assert ti.get_chunk_size() is None
    assert ti.get_chunk_size() == 1 << 15
    for bad in (-1, 2.5, True, "1"):
        with pytest.raises(ValueError, match="points"):
            ti.set_chunk_size(bad)
