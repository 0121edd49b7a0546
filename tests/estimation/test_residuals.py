"""Tests of torchirid.estimation.residuals: the misfit of the fast band model over many pixels.

``cube_sse`` is checked against the sum written out here over the model of
``measurement.band_reflectance_fast`` (one pass, no chunks), on a cube large enough to be cut
into several chunks, with missing samples, a pixel without data and NaN candidates; the
helpers against their closed forms. (``residual_parts``' ∂r/∂d against autograd:
tests/estimation/test_refine.py.)
"""

from __future__ import annotations

import math

import pytest
import torch

from torchirid.estimation.measurement import band_reflectance_fast
from torchirid.estimation.gauss_newton import model_terms
import torchirid
from torchirid.estimation.residuals import (cube_sse, decimation, order_candidates, pixel_chunks, terms_size,
                                            thickness_grid)

F64 = torch.float64


def _terms():
    w = torch.arange(400.0, 721.0, 8.0, dtype=F64)
    c = torch.tensor([0.98, 0.8, 0.64], dtype=F64)
    return model_terms(torch.tensor([1.37], dtype=F64), "constant", w, c, 1.64)  # each (pol = 2, A = 3, B = 41)


def test_cube_sse_is_the_sum_of_squared_residuals_over_chunks():
    g = torch.Generator().manual_seed(3)
    terms = _terms()
    P, C = 1500, 3
    truth = 150.0 + 600.0 * torch.rand(P, generator=g, dtype=F64)
    cube = band_reflectance_fast(tuple(t[:, None] for t in terms), truth[:, None, None])  # (P, A, B)
    cube = cube + 0.002 * torch.randn(cube.shape, generator=g, dtype=F64)
    cube[7, 1, 5] = math.nan  # a missing sample
    cube[11] = math.nan  # a pixel without data
    cand = truth[:, None] + torch.tensor([-20.0, 0.0, 35.0], dtype=F64)
    cand[4, 2] = math.nan  # no such candidate
    assert len(pixel_chunks(P, C * terms_size(terms), 50_000)) > 1  # the test crosses chunk boundaries

    with torchirid.options(chunk_size=50_000):  # (blocks of 50 000 model samples: 67 pixels)
        got = cube_sse(cube, terms, cand)

    model = band_reflectance_fast(tuple(t[:, None, None] for t in terms), cand.nan_to_num(0.0)[..., None, None])
    ref = ((model - cube[:, None]) ** 2).nansum((-1, -2))
    ref[4, 2] = math.inf
    torch.testing.assert_close(got, ref, rtol=1e-12, atol=1e-15)
    assert got[4, 2] == math.inf and torch.all(got[11] == 0.0)  # NaN candidate: +inf; no data: the empty sum
    has_data = torch.ones(P, dtype=torch.bool)
    has_data[11] = False
    assert torch.all(got[has_data].argmin(-1) == 1)  # the truth fits best (noise 0.002)


def test_cube_sse_follows_the_cube_dtype():
    terms = tuple(t.float() for t in _terms())
    cube = torch.zeros(4, 3, 41, dtype=torch.float32)
    out = cube_sse(cube, terms, torch.full((4, 2), 300.0, dtype=torch.float32))
    assert out.dtype == torch.float32 and out.shape == (4, 2)


@pytest.mark.parametrize("count, per_pixel, budget", [(5, 80_000, 200_000), (1000, 7, 100), (3, 10**7, 1000),
                                                      (0, 10, 100), (10, 0, 100)])
def test_pixel_chunks_cover_every_pixel_once_within_the_budget(count, per_pixel, budget):
    chunks = pixel_chunks(count, per_pixel, budget)
    assert [i for a, b in chunks for i in range(a, b)] == list(range(count))
    assert all(b > a for a, b in chunks)
    assert all((b - a) == 1 or (b - a) * per_pixel <= budget for a, b in chunks)


def test_pixel_chunks_follow_the_chunk_knob():
    """Without a budget, the ranges hold torchirid.options(chunk_size=...) model samples (the
    block size of torchirid._chunks on the device); None: one range. cube_sse's pixels are
    independent: the same values in any ranges."""
    with torchirid.options(chunk_size=250):
        assert pixel_chunks(10, 100) == [(0, 2), (2, 4), (4, 6), (6, 8), (8, 10)]
    with torchirid.options(chunk_size=None):
        assert pixel_chunks(10**6, 10**6) == [(0, 10**6)] and pixel_chunks(0, 5) == []
    terms = _terms()
    g = torch.Generator().manual_seed(5)
    cube = 0.1 * torch.rand(200, 3, 41, generator=g, dtype=F64)
    cand = 100.0 + 500.0 * torch.rand(200, 2, generator=g, dtype=F64)
    with torchirid.options(chunk_size=None):
        ref = cube_sse(cube, terms, cand)
    with torchirid.options(chunk_size=5000):  # 10 pixels per range
        got = cube_sse(cube, terms, cand)
    torch.testing.assert_close(got, ref, rtol=1e-15, atol=0)


def test_order_candidates_are_the_neighbouring_orders():
    d = torch.tensor([100.0, 250.0, 600.0], dtype=F64)
    got = order_candidates(d, 150.0)
    want = torch.tensor([[math.nan, 100.0, 250.0], [100.0, 250.0, 400.0], [450.0, 600.0, 750.0]], dtype=F64)
    torch.testing.assert_close(got, want, equal_nan=True, rtol=0, atol=0)
    assert torch.isnan(order_candidates(torch.tensor([150.0], dtype=F64), 150.0)[0, 0])  # d − T = 0: no order


def test_decimation_keeps_the_first_middle_and_last_angles():
    assert decimation(5, 10, 3) == ([0, 2, 4], [0, 3, 6, 9])
    assert decimation(2, 4, 2) == ([0, 1], [0, 2])
    assert decimation(4, 3, 1) == ([0, 1, 2, 3], [0, 1, 2])


def test_thickness_grid_includes_both_ends_in_the_dtype_of_like():
    grid = thickness_grid((100.0, 200.0), 25.0, torch.zeros(1, dtype=torch.float32))
    assert grid.dtype == torch.float32 and grid.tolist() == [100.0, 125.0, 150.0, 175.0, 200.0]
