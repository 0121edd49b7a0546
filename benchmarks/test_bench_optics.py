"""pytest-benchmark suite for the exact optics (same grid as benchmarks/speed_vs_error.py).

    .venv/bin/python -m pytest benchmarks --benchmark-only
    .venv/bin/python -m pytest benchmarks --benchmark-only --benchmark-group-by=param:pol

The comparison table with errors and speed ratios is written by speed_vs_error.py into
docs/performance.md; this suite gives the per-call statistics (min, median, IQR).
"""

from __future__ import annotations

import numpy as np
import pytest
import torch

import torchirid as ti

torch.set_num_threads(2)

N1, N2, D1, D2, CELLS = 1.0, 1.5, 125.0, 375.0, 20


@pytest.fixture(scope="module")
def grid():
    lam = torch.linspace(380, 780, 401, dtype=torch.float64)
    theta = torch.deg2rad(torch.linspace(0, 89, 90, dtype=torch.float64))
    return lam, torch.cos(theta)[:, None], theta


@pytest.mark.parametrize("pol", ["s", "unpolarized"])
def test_bragg_reflectance(benchmark, grid, pol):
    lam, cos, _ = grid
    R = benchmark(ti.bragg_reflectance, lam, cos, N1, N2, D1, D2, CELLS, polarization=pol)
    assert R.shape == (90, 401)


@pytest.mark.parametrize("cells", [20, 10**6])
def test_bragg_cost_independent_of_cells(benchmark, grid, cells):
    lam, cos, _ = grid
    R = benchmark(ti.bragg_reflectance, lam, cos, N1, N2, D1, D2, cells, polarization="s")
    assert torch.isfinite(R).all()


@pytest.mark.parametrize("pol", ["s", "unpolarized"])
def test_multilayer_explicit_stack(benchmark, grid, pol):
    lam, cos, _ = grid
    idx = torch.tensor([N1] + [N2, N1] * CELLS + [N1], dtype=torch.float64)
    d = torch.tensor([D2, D1] * CELLS, dtype=torch.float64)
    R, T = benchmark(ti.multilayer, lam, cos, idx, d, polarization=pol)
    assert torch.allclose(R + T, torch.ones_like(R), atol=1e-12)


@pytest.mark.parametrize("pol", ["s", "p"])
def test_tmm_fast_peer(benchmark, grid, pol):
    tmm_fast = pytest.importorskip("tmm_fast")
    lam, _, theta = grid
    idx = [N1] + [N2, N1] * CELLS + [N1]
    M = torch.tensor(idx, dtype=torch.complex128)[None, :, None].expand(1, len(idx), lam.numel()).contiguous()
    T = torch.tensor([np.inf] + [D2 * 1e-9, D1 * 1e-9] * CELLS + [np.inf], dtype=torch.float64)[None]
    out = benchmark(tmm_fast.coh_tmm, pol, M, T, theta, lam * 1e-9, device="cpu")
    assert out["R"].shape == (1, 90, 401)
