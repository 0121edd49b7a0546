"""torchirid.fitting.scatterogram: the exposure-robust loss, recovering Λ by autograd, and the
PNG / OpenEXR reading and writing of measured scatterograms."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from torchirid.color import xyz_to_lab
from torchirid.fitting import (
    ScatterogramFit,
    bragg_structure,
    read_scatterogram,
    match_scatterogram,
    render_targets,
    write_scatterogram,
    write_scatterogram,
    scatterogram_loss,
)
from torchirid.color import linear_srgb_to_xyz
from torchirid.fitting.measured import _read_png, _write_png
from torchirid.layered.presets import jewel_beetle
from torchirid.layered import scatterogram, scatterogram_directions

F64 = torch.float64
LAM = torch.linspace(380.0, 780.0, 41, dtype=F64)
INCS = [(0.0, 0.0), (40.0, 0.0)]



@pytest.fixture(scope="module")
def green_target():
    return render_targets(jewel_beetle("green"), INCS, resolution=12, wavelength=LAM)


# ---------------------------------------------------------------------------- the loss
def test_loss_exposure_invariant(green_target):
    t = green_target / green_target[..., 1].max()
    wrong = render_targets(bragg_structure(170.0, 0.51, 1.59, 1.67, 8, 0.05), INCS, resolution=12, wavelength=LAM)
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
    model = render_targets(bragg_structure(period, 0.51, 1.59, 1.67, 8, 0.05), INCS, resolution=12, wavelength=LAM)
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


# ---------------------------------------------------------------------------- PNG
def _in_gamut_xyz(res, seed=0):
    lin = 0.05 + 0.85 * torch.rand(res, res, 3, dtype=F64, generator=torch.Generator().manual_seed(seed))
    return linear_srgb_to_xyz(lin)


@pytest.mark.parametrize("bits, tol", [(16, 1e-4), (8, 1e-2)])
def test_png_round_trip(tmp_path, bits, tol):
    _, disc = scatterogram_directions(16)
    xyz = torch.where(disc[..., None], _in_gamut_xyz(16), torch.zeros(()))
    path = write_scatterogram(tmp_path / "sg.png", xyz, exposure=0.5, bits=bits, mask=disc)
    image = read_scatterogram(path, exposure=2.0)
    assert image.xyz.shape == (16, 16, 3) and image.params["bits"] == bits
    assert bool((image.mask == disc).all())
    torch.testing.assert_close(image.xyz, xyz, atol=tol, rtol=0)


def test_png_round_trip_rendered_and_fitted_grid(tmp_path):
    """A rendered scatterogram written with the auto exposure and read back into the fit's grid."""
    sg = scatterogram(jewel_beetle("red"), incident_deg=(0.0, 0.0), resolution=16, wavelength=LAM)
    e = 0.8 / float(sg.xyz[..., 1].max())
    image = read_scatterogram(write_scatterogram(tmp_path / "red.png", sg, exposure=e), exposure=1 / e)
    lab_in, lab_out = xyz_to_lab(sg.xyz * e), xyz_to_lab(image.xyz * e)
    # out-of-gamut (negative linear RGB) colours are clipped on writing: compare where in gamut
    from torchirid.color import xyz_to_linear_srgb
    ok = image.mask & (xyz_to_linear_srgb(sg.xyz * e) >= 0).all(-1) & (xyz_to_linear_srgb(sg.xyz * e) < 1).all(-1)
    assert int(ok.sum()) > 100
    assert float((lab_in - lab_out)[ok].norm(dim=-1).max()) < 0.05


def test_png_center_radius_rotation_and_saturation(tmp_path):
    """The disc placed off-centre in a larger canvas, rotated by 90°, one pixel saturated."""
    res = 16
    _, disc = scatterogram_directions(res)
    xyz = torch.where(disc[..., None], _in_gamut_xyz(res, seed=1), torch.zeros(()))
    small = tmp_path / "small.png"
    write_scatterogram(small, xyz, bits=16, mask=disc)
    rgb, _, _ = _read_png(small)
    canvas = np.zeros((30, 40, 3), np.uint16)
    canvas[5:5 + res, 11:11 + res] = np.rint(rgb * 65535).astype(np.uint16)
    canvas[5 + 3, 11 + 7] = 65535  # a clipped pixel: excluded from the mask
    # rotate the content by 90° counter-clockwise: the file's +x axis is the grid's −y (azimuth −90°)
    canvas[5:5 + res, 11:11 + res] = np.rot90(canvas[5:5 + res, 11:11 + res], k=1)
    big = tmp_path / "big.png"
    _write_png(big, canvas)
    image = read_scatterogram(big, center=(11 + 7.5, 5 + 7.5), radius_px=8.0, resolution=res, rotation_deg=-90.0)
    assert int((disc & ~image.mask).sum()) == 1  # the saturated pixel
    torch.testing.assert_close(image.xyz[image.mask], xyz[image.mask], atol=1e-4, rtol=0)


def test_png_other_projection_resamples(tmp_path):
    """An orthographic file read onto an equidistant grid: the value at θ = 30° comes from ρ = 0.5."""
    res = 64
    d, disc = scatterogram_directions(res, projection="orthographic")
    y = torch.where(disc, torch.nan_to_num(d[..., 2]), torch.zeros(()))  # cos θ as a grey level
    white = torch.tensor([0.95047, 1.0, 1.08883], dtype=F64)
    path = write_scatterogram(tmp_path / "ortho.png", 0.5 * y[..., None] * white, mask=disc)
    image = read_scatterogram(path, projection="orthographic", grid_projection="equidistant", resolution=res)
    d2, _ = scatterogram_directions(res, projection="equidistant")
    inner = image.mask & (d2[..., 2] > math.cos(math.radians(70.0)))  # cos θ is steep in ρ near the rim
    assert int(inner.sum()) > 1500
    torch.testing.assert_close(image.xyz[..., 1][inner], 0.5 * d2[..., 2][inner], atol=3e-3, rtol=0)


def test_load_value_errors(tmp_path):
    with pytest.raises(FileNotFoundError):
        read_scatterogram(tmp_path / "scan.exr")
    not_exr = tmp_path / "fake.exr"
    not_exr.write_bytes(b"not an exr file")
    with pytest.raises(ValueError, match="OpenEXR"):
        read_scatterogram(not_exr)
    bad = tmp_path / "bad.png"
    bad.write_bytes(b"not a png at all")
    with pytest.raises(ValueError, match="PNG"):
        read_scatterogram(bad)
    good = write_scatterogram(tmp_path / "g.png", _in_gamut_xyz(4))
    with pytest.raises(ValueError, match="projection"):
        read_scatterogram(good, projection="fisheye")
    with pytest.raises(ValueError, match="radius_px"):
        read_scatterogram(good, radius_px=0.0)
    with pytest.raises(ValueError, match="exposure"):
        read_scatterogram(good, exposure=-1.0)
    with pytest.raises(ValueError, match="center"):
        read_scatterogram(good, center=(1.0,))
    with pytest.raises(ValueError, match="resolution"):
        read_scatterogram(good, resolution=0)
    with pytest.raises(ValueError, match="saturation"):
        read_scatterogram(good, saturation=1.0)
    with pytest.raises(ValueError, match="bits"):
        write_scatterogram(tmp_path / "h.png", _in_gamut_xyz(4), bits=12)
    with pytest.raises(FileNotFoundError):
        read_scatterogram(tmp_path / "missing.png")


# ---------------------------------------------------------------------------- OpenEXR
def test_exr_round_trip(tmp_path):
    """Linear float32 RGB: the same resolution comes back to float32 rounding."""
    pytest.importorskip("OpenEXR")
    _, disc = scatterogram_directions(16)
    xyz = torch.where(disc[..., None], _in_gamut_xyz(16, seed=2), torch.zeros(()))
    path = write_scatterogram(tmp_path / "sg.exr", xyz, exposure=0.5, mask=disc)
    image = read_scatterogram(path, exposure=2.0)
    assert image.xyz.shape == (16, 16, 3) and image.params["format"] == "exr"
    assert bool((image.mask == disc).all())  # black off the disc is valid, but off the grid's disc
    torch.testing.assert_close(image.xyz, xyz, rtol=1e-6, atol=1e-9)


def test_exr_round_trip_rendered_unclipped(tmp_path):
    """A rendered scatterogram, out-of-gamut colours and values above 1 included: nothing is clipped."""
    pytest.importorskip("OpenEXR")
    from torchirid.color import xyz_to_linear_srgb

    sg = scatterogram(jewel_beetle("green"), incident_deg=(0.0, 0.0), resolution=16, wavelength=LAM)
    e = 3.0 / float(sg.xyz[..., 1].max())
    image = read_scatterogram(write_scatterogram(tmp_path / "green.exr", sg, exposure=e), exposure=1 / e)
    rgb = xyz_to_linear_srgb(sg.xyz * e)[sg.mask]
    assert bool((rgb < 0).any()) and bool((rgb > 1).any())  # the test covers both
    assert bool((image.mask == sg.mask).all())
    scale = float(sg.xyz[sg.mask].abs().max())
    torch.testing.assert_close(image.xyz[sg.mask], sg.xyz[sg.mask], rtol=1e-6, atol=1e-6 * scale)


def test_exr_invalid_pixels_leave_mask(tmp_path):
    """NaN / infinite colours, transparent or NaN alpha, and (optionally) saturated pixels are invalid;
    a half-float file with alpha is read."""
    OpenEXR = pytest.importorskip("OpenEXR")
    res = 16
    _, disc = scatterogram_directions(res)
    from torchirid.color import xyz_to_linear_srgb

    rgb = xyz_to_linear_srgb(_in_gamut_xyz(res, seed=3)).numpy().astype(np.float32)
    alpha = np.ones((res, res), np.float32)
    rgb[3, 7, 0] = np.nan
    rgb[8, 8, 2] = np.inf
    alpha[9, 4] = 0.0
    alpha[10, 10] = np.nan
    rgb[6, 6] = 50.0  # bright, kept unless a saturation level is given
    channels = {c: np.ascontiguousarray(rgb[..., i]).astype(np.float16 if c == "G" else np.float32)
                for i, c in enumerate("RGB")}
    channels["A"] = alpha.astype(np.float16)
    path = tmp_path / "holes.exr"
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    OpenEXR.File(header, dict(channels)).write(str(path))  # (the binding turns the dict's arrays into Channels)
    bad = {(3, 7), (8, 8), (9, 4), (10, 10)}
    assert all(disc[p] for p in bad | {(6, 6)})
    image = read_scatterogram(path)
    assert {tuple(p) for p in (disc & ~image.mask).nonzero().tolist()} == bad
    assert bool(torch.isfinite(image.xyz).all())
    image = read_scatterogram(path, saturation=10.0)
    assert {tuple(p) for p in (disc & ~image.mask).nonzero().tolist()} == bad | {(6, 6)}
    assert image.params["saturation"] == 10.0
    # the half-float G channel is read as stored
    lin = torch.as_tensor(np.stack([channels[c].astype(np.float64) for c in "RGB"], -1))
    expect = linear_srgb_to_xyz(lin)
    ok = image.mask
    torch.testing.assert_close(image.xyz[ok], expect[ok], rtol=1e-6, atol=1e-9)


def test_exr_without_openexr_says_pip_install(tmp_path, monkeypatch):
    import sys

    path = tmp_path / "scan.exr"
    path.write_bytes(b"\x76\x2f\x31\x01" + bytes(60))  # the OpenEXR magic number
    monkeypatch.setitem(sys.modules, "OpenEXR", None)  # import OpenEXR raises ImportError
    with pytest.raises(ImportError, match="pip install openexr"):
        read_scatterogram(path)
    with pytest.raises(ImportError, match="pip install openexr"):
        write_scatterogram(tmp_path / "out.exr", _in_gamut_xyz(4))
