"""torchirid.fitting.measured: reading and writing measured scatterograms — PNG (8 and 16 bits, sRGB;
placed, rotated and resampled discs; saturated pixels) and OpenEXR (linear, unclipped; invalid pixels
out of the mask) — by round trips, against files written independently (numpy arrays, the OpenEXR
binding) and rendered scatterograms."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from torchirid.color import linear_srgb_to_xyz, xyz_to_lab
from torchirid.fitting import read_scatterogram, write_scatterogram
from torchirid.fitting.measured import _read_png, _write_png
from torchirid.layered import scatterogram, scatterogram_directions
from torchirid.presets import jewel_beetle

F64 = torch.float64
LAM = torch.linspace(380.0, 780.0, 41, dtype=F64)


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
