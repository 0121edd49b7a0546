"""Domains of the fast Bragg-colour methods (issue 21.5): ``piecewise`` and ``envelope`` average the
fringes, so they need many fringes in the range (``MIN_FRINGES``); outside it they warn, and
``method="auto"`` does not use them. ``auto`` weighs the batch size.

Reference: the converged ``method="spectral"`` colour (ΔE2000 of CIE Lab, D65)."""

from __future__ import annotations

import math
import warnings

import pytest
import torch

import torchirid as ti
from torchirid.color import delta_e_2000, xyz_to_lab
from torchirid.spectral.sampling import fringe_count
from torchirid.spectral.auto import choose_bragg_method
from torchirid.spectral.piecewise import MIN_FRINGES

F64 = torch.float64


def _grid(period, cells=20, n2=1.5):
    cos = torch.cos(torch.deg2rad(torch.arange(0.0, 85.0, 12.0, dtype=F64)))[:, None]
    d1 = period * torch.tensor([0.2, 0.5, 0.8], dtype=F64)
    return cos, 1.0, n2, d1, period - d1, cells


def _de(method, args, **kw):
    ref = xyz_to_lab(ti.bragg_xyz(*args, method="spectral"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        got = xyz_to_lab(ti.bragg_xyz(*args, method=method, **kw))
    return delta_e_2000(got, ref)


def test_fringe_count_closed_form():
    c = torch.tensor([1.0, 0.6, 0.0], dtype=F64)
    n1, n2, d1, d2, N = 1.2, 1.9, 80.0, 140.0, 15
    s2 = (n1 * n1) * (1 - c * c)
    opl = torch.sqrt(n1 * n1 - s2) * d1 + torch.sqrt(n2 * n2 - s2) * d2
    ref = N * opl * 2 * (1 / 380.0 - 1 / 780.0)
    torch.testing.assert_close(fringe_count(c, n1, n2, d1, d2, N), ref, rtol=1e-14, atol=0)
    assert float(fringe_count(1.0, 1.0, 1.5, 125.0, 375.0, 20, wavelength_range=(400.0, 700.0))) == pytest.approx(
        20 * 687.5 * 2 * (1 / 400 - 1 / 700))


@pytest.mark.parametrize("method", ["piecewise", "envelope"])
def test_short_periods_warn_and_are_far_off(method):
    # Λ = 40 nm: the first band is in the UV, ~3 fringes in the visible
    args = _grid(40.0)
    assert float(fringe_count(*args[:6]).max()) < MIN_FRINGES
    with pytest.warns(RuntimeWarning, match=rf"method='{method}'.*fewer than 8 fringes"):
        ti.bragg_xyz(*args, method=method)
    assert float(_de(method, args).max()) > 10  # why it warns (measured 24-25)


@pytest.mark.parametrize("method", ["piecewise", "envelope"])
def test_inside_the_domain_no_warning_and_small_error(method):
    args = _grid(500.0)  # 20 cells: 27-40 fringes
    assert float(fringe_count(*args[:6]).min()) >= MIN_FRINGES
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        ti.bragg_xyz(*args, method=method)
    assert float(_de(method, args).max()) < 3.0


def test_few_cells_are_outside_the_domain():
    args = _grid(244.0, cells=5)  # N = 5: ~4 fringes even at 244 nm
    assert float(fringe_count(*args[:6]).max()) < MIN_FRINGES
    with pytest.warns(RuntimeWarning, match="fewer than 8 fringes"):
        ti.bragg_xyz(*args, method="envelope")


@pytest.mark.parametrize("period", [10.0, 40.0, 80.0, 244.0])
def test_auto_stays_accurate_outside_the_fast_domain(period):
    args = _grid(period)
    choice = choose_bragg_method(*args)
    if float(fringe_count(*args[:6]).min()) < MIN_FRINGES:
        assert choice["config"]["method"] not in ("piecewise", "envelope")
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # auto never takes a method outside its domain
        de = _de("auto", args)
    assert float(torch.quantile(de, 0.95)) <= 1.0 + 1e-9


def test_auto_weighs_the_batch_size():
    # the same mirror: one colour per call → a short sampled integration (no per-call overhead);
    # thousands per call → the envelope method, whose ~1 ms fixed cost is then spread thin
    one = choose_bragg_method(1.0, 1.0, 1.5, 125.0, 375.0, 20)
    many = choose_bragg_method(torch.linspace(0.05, 1.0, 4000, dtype=F64), 1.0, 1.5, 125.0, 375.0, 20)
    assert one["config"]["method"] == "sampled" and many["config"]["method"] == "envelope"
    assert choose_bragg_method(1.0, 1.0, 1.5, 125.0, 375.0, 20, batch_size=4000)["config"] == many["config"]
    small = choose_bragg_method(1.0, 1.0, 1.5, 125.0, 375.0, 20, batch_size=1)
    big = choose_bragg_method(1.0, 1.0, 1.5, 125.0, 375.0, 20, batch_size=100000)
    assert big["us_per_colour"] < small["us_per_colour"] or big["config"] == small["config"]
    with pytest.raises(ValueError, match="batch_size"):
        choose_bragg_method(1.0, 1.0, 1.5, 125.0, 375.0, 20, batch_size=0)
    assert math.isfinite(many["us_per_colour"]) and many["p95"] <= 1.0
