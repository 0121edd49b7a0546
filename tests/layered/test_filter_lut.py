"""The table of the transmission filter F_α (torchirid.layered.filter_lut): its interpolation error
against the closed form (tests/layered/test_filter.py checks the closed form against mpmath) on
dense random and grid points, the file round trip, dtype, batching and gradients.
"""

from __future__ import annotations

import math

import pytest
import torch

from torchirid.layered.filter import transmission_filter
from torchirid.layered.filter_lut import FilterLUT, transmission_filter_lut
from torchirid.lut import LUT

F64 = torch.float64
HALF_PI = math.pi / 2


def t64(x):
    return torch.as_tensor(x, dtype=F64)


def _dense_points(alpha, n=60000, seed=0):
    g = torch.Generator().manual_seed(seed)
    top = math.radians(89.5)

    def rand(m):
        return torch.rand(m, generator=g, dtype=F64)

    ti = [rand(n) * top, rand(n) * top, rand(n) * top, rand(n) * min(top, 8 * alpha)]
    td = [rand(n) * HALF_PI,
          ti[1] + alpha * torch.randn(n, generator=g, dtype=F64),
          HALF_PI - ti[2] + 0.05 * alpha * torch.randn(n, generator=g, dtype=F64),
          ti[3] + alpha * torch.randn(n, generator=g, dtype=F64)]
    gi, gd = torch.meshgrid(torch.linspace(0, top, 180, dtype=F64), torch.linspace(0, HALF_PI, 360, dtype=F64),
                            indexing="ij")
    ti.append(gi.flatten())
    td.append(gd.flatten())
    return torch.cat(ti), torch.cat(td).clamp(0, HALF_PI)


@pytest.mark.parametrize("alpha", [0.025, 0.1, 0.4])
def test_lut_interpolation_error_below_1e3_of_peak(alpha):
    lut = transmission_filter_lut(alpha)
    ti, td = _dense_points(alpha)
    exact = transmission_filter(ti, td, alpha)
    peak = float(transmission_filter(t64(0.0), torch.linspace(0, 0.5, 20001, dtype=F64), alpha).max())
    err = (lut(ti, td) - exact).abs().max()
    assert float(err) <= 1e-3 * peak
    n_i, n_u = lut.lut.values.shape
    assert n_i >= 361 and n_i * n_u < 200_000  # at least the paper's 0.25° steps; < 1.6 MB


def test_lut_save_load_round_trip(tmp_path):
    lut = transmission_filter_lut(0.2)
    path = lut.write(tmp_path / "filter.npz")
    back = FilterLUT.read(path, alpha=0.2)
    assert back.alpha == 0.2 and back.lut.hash == lut.lut.hash
    params = back.lut.parameters
    assert back.lut.builder == "torchirid.layered.filter.transmission_filter_lut"
    assert params["alpha"] == 0.2 and params["resolution"]["theta_i_step_deg"] == 0.25
    assert params["resolution"]["theta_i_nodes"] == lut.lut.values.shape[0]
    ti, td = t64([0.1, 0.8, 1.4]), t64([0.2, 0.8, 0.1])
    torch.testing.assert_close(back(ti, td), lut(ti, td), rtol=0, atol=0)
    with pytest.raises(ValueError, match="alpha"):
        FilterLUT.read(path, alpha=0.3)
    other = LUT(torch.zeros(2, 2, dtype=F64), {"theta_i": t64([0, 1]), "u": t64([0, 1])}, builder="x")
    with pytest.raises(ValueError, match="built by"):
        FilterLUT(other)


def test_lut_dtype_batching_and_gradients():
    lut32 = transmission_filter_lut(0.1, dtype=torch.float32)
    out = lut32(torch.rand(4, 1) * 1.5, torch.rand(3) * 1.5)
    assert out.shape == (4, 3) and out.dtype == torch.float32 and bool(torch.isfinite(out).all())
    lut = transmission_filter_lut(0.3)
    ti = t64([0.0, 0.5, 0.5, 1.2]).requires_grad_()
    td = t64([0.1, 0.5, HALF_PI - 0.5, HALF_PI]).requires_grad_()
    lut(ti, td).sum().backward()
    assert bool(torch.isfinite(ti.grad).all()) and bool(torch.isfinite(td.grad).all())
    with pytest.raises(ValueError, match="theta_d"):
        lut(0.3, 2.0)
