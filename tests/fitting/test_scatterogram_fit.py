"""torchirid.fitting.scatterogram: the exposure-robust loss and recovering Λ by autograd (the
harmonics: test_scatterogram_harmonics.py; reading and writing measured scatterograms:
test_measured.py)."""

from __future__ import annotations

import math

import pytest
import torch

from torchirid.color import xyz_to_lab
from torchirid.fitting import (
    ScatterogramFit,
    bragg_structure,
    match_scatterogram,
    render_targets,
    scatterogram_loss,
)
from torchirid.presets import jewel_beetle

F64 = torch.float64
LAM = torch.linspace(380.0, 780.0, 41, dtype=F64)
INCS = [(0.0, 0.0), (40.0, 0.0)]



@pytest.fixture(scope="module")
def green_target():
    return render_targets(jewel_beetle("green"), INCS, resolution=12, wavelength=LAM)


# ---------------------------------------------------------------------------- the loss
def test_loss_exposure_invariant(green_target):
    t = green_target / green_target[..., 1].max()
    wrong = render_targets(bragg_structure(1.59, 1.67, 170.0, 0.51, 8, 0.05), INCS, resolution=12, wavelength=LAM)
    base = scatterogram_loss(wrong, t)
    for k in (1e-3, 0.37, 12.0):
        torch.testing.assert_close(scatterogram_loss(k * wrong, t), base, rtol=1e-10, atol=0)
    assert float(base) > 1.0  # a 10 nm error in Λ is visible
    assert float(scatterogram_loss(5.0 * t, t)) < 1e-20
    # a fixed (wrong) exposure is not invariant: the scale matters when given
    assert float(scatterogram_loss(t, t, scale=2.0)) > 10.0
    assert float(scatterogram_loss(t, t, loss="de2000")) == 0.0


def test_loss_is_lab_distance():
    g = torch.Generator().manual_seed(3)
    a, b = torch.rand(2, 4, 4, 3, dtype=F64, generator=g), torch.rand(2, 4, 4, 3, dtype=F64, generator=g)
    expected = ((xyz_to_lab(a) - xyz_to_lab(b)) ** 2).sum(-1).mean()
    torch.testing.assert_close(scatterogram_loss(a, b, scale=1.0), expected)


def test_loss_gradients_finite(green_target):
    period = torch.tensor(163.0, dtype=F64, requires_grad=True)
    model = render_targets(bragg_structure(1.59, 1.67, period, 0.51, 8, 0.05), INCS, resolution=12, wavelength=LAM)
    loss = scatterogram_loss(model, green_target / green_target[..., 1].max())
    loss.backward()
    assert math.isfinite(float(period.grad)) and float(period.grad) > 0  # too long: the gradient says shorten


# ---------------------------------------------------------------------------- the fit
def test_recovers_period_from_nearby_start(green_target):
    noisy = 2.7 * green_target * (1 + 0.01 * torch.randn(green_target.shape, dtype=F64,
                                                         generator=torch.Generator().manual_seed(0)))
    fit = match_scatterogram(noisy, incident_deg=INCS, n1=1.59, cells=(8,), period_range=None, wavelength=LAM,
                             init={"period": 166.0, "delta": 0.51, "dn": 0.08, "alpha": 0.07},
                             short_iter=8, max_iter=25)
    assert isinstance(fit, ScatterogramFit)
    assert abs(fit.period - 160.0) < 1.0
    assert abs(fit.alpha - 0.05) < 0.01
    assert fit.cells == 8
    assert abs(fit.exposure / 2.7 - 1.0) < 0.1
    assert fit.delta_e2000 < 1.0 and fit.iterations > 0 and fit.evaluations > fit.iterations


def test_grid_stage_finds_the_basin(green_target):
    """From a generic start, the Λ grid alone lands within a few nm (the refinement does the rest)."""
    fit = match_scatterogram(green_target, incident_deg=INCS, n1=1.59, cells=(8,), period_range=(120.0, 260.0),
                             period_step=4.0, starts=1, short_iter=1, max_iter=0, wavelength=LAM)
    assert abs(fit.stages["grid"]["minima"][0][0] - 160.0) <= 8.0


def test_progress_counts_stages_up_to_done_equals_total(green_target):
    """grid (1) + starts (2) + one other N (1) + polish (1) + two harmonics, both outside period_range (2);
    the polish's loss, once a log message, is in stages."""
    seen = []
    fit = match_scatterogram(green_target, incident_deg=INCS, n1=1.59, cells=(7, 8), period_range=(140.0, 330.0),
                             period_step=10.0, starts=2, short_iter=2, max_iter=1, harmonics=(2.0, 0.5),
                             wavelength=LAM, progress=lambda d, t: seen.append((d, t)))
    assert seen == [(d, 7) for d in range(1, 8)] and all(type(d) is int and type(t) is int for d, t in seen)
    assert fit.stages["polish"] == [{"cells": fit.cells, "loss": fit.loss}]


def test_match_value_errors(green_target):
    ok = dict(incident_deg=INCS, wavelength=LAM)
    with pytest.raises(ValueError, match="progress"):
        match_scatterogram(green_target, progress="tqdm", **ok)
    with pytest.raises(ValueError, match="incident"):
        match_scatterogram(green_target, incident_deg=[(0.0, 0.0)])
    with pytest.raises(ValueError, match="target_xyz"):
        match_scatterogram(green_target[..., :2], **ok)
    with pytest.raises(ValueError, match="cells"):
        match_scatterogram(green_target, cells=(0, 3), **ok)
    with pytest.raises(ValueError, match="projection"):
        match_scatterogram(green_target, projection="fisheye", **ok)
    with pytest.raises(ValueError, match="loss"):
        match_scatterogram(green_target, loss="l2", **ok)
    with pytest.raises(ValueError, match="init"):
        match_scatterogram(green_target, init={"delta": 1.5}, **ok)
    with pytest.raises(ValueError, match="period_range"):
        match_scatterogram(green_target, period_range=(300.0, 100.0), **ok)
    with pytest.raises(ValueError, match="mask"):
        match_scatterogram(green_target, mask=torch.zeros(12, 12, dtype=torch.bool), **ok)
    with pytest.raises(ValueError, match="Y > 0"):
        match_scatterogram(torch.zeros_like(green_target), **ok)
    with pytest.raises(ValueError, match="loss"):
        scatterogram_loss(green_target, green_target, loss="l1")
    with pytest.raises(ValueError, match="shape"):
        scatterogram_loss(green_target, green_target[:1])
