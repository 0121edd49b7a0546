"""Tests of torchirid.color.colorimetry: observers, illuminants and white points.

Reference: colour-science's datasets and functions themselves (the tables must be the
same numbers, never retyped), its tabulated white-point chromaticities, and
``colour.sd_to_XYZ`` for the perfect reflector.
"""

from __future__ import annotations

import warnings

import colour
import numpy as np
import pytest
import torch

from torchirid.color import (
    ILLUMINANTS,
    OBSERVERS,
    cmfs,
    illuminant_spd,
    spectrum_to_xyz,
    white_point_xy,
    white_point_xyz,
)
from torchirid.color.colorimetry import _OBSERVER_KEYS

from tensors import F64

CIE_OBSERVERS = ("CIE 1931 2", "CIE 1964 10")
SB = "Stiles & Burch 1959 10"


@pytest.mark.parametrize("observer", OBSERVERS)
def test_cmfs_are_colour_science_data(observer):
    wl, v = cmfs(observer)
    data = colour.MSDS_CMFS[_OBSERVER_KEYS[observer]]
    assert wl.dtype == F64 and v.dtype == F64 and v.shape == (wl.shape[0], 3)
    np.testing.assert_array_equal(wl.numpy(), data.wavelengths)
    if observer == SB:
        expected = colour.colorimetry.RGB_10_degree_cmfs_to_XYZ_10_degree_cmfs(data.wavelengths)
    else:
        expected = data.values
    np.testing.assert_array_equal(v.numpy(), expected)


def test_stiles_burch_rgb_and_xyz():
    wl, rgb = cmfs(SB, space="RGB")
    data = colour.MSDS_CMFS["Stiles & Burch 1959 10 Degree RGB CMFs"]
    np.testing.assert_array_equal(rgb.numpy(), data.values)
    assert (rgb < 0).any()  # genuine RGB CMFs have negative lobes
    # the XYZ transform of Stiles & Burch is close to (not equal to) the CIE 1964 10° observer
    _, xyz = cmfs(SB)
    wl10, xyz10 = cmfs("CIE 1964 10")
    on_grid = torch.isin(wl10, wl)
    diff = (xyz - xyz10[on_grid]).abs().max().item()
    assert 1e-3 < diff < 0.07  # measured 0.066 (z̄ near 450 nm, peak ≈ 2)


@pytest.mark.parametrize("dtype", [torch.float32, torch.float64])
def test_cmfs_dtype_device_and_copies(dtype):
    wl, v = cmfs("CIE 1931 2", dtype=dtype, device="cpu")
    assert wl.dtype == dtype and v.dtype == dtype and v.device.type == "cpu"
    np.testing.assert_array_equal(v.numpy(), cmfs("CIE 1931 2")[1].to(dtype).numpy())
    v.zero_()  # in-place edits of a returned tensor must not reach the cache
    assert cmfs("CIE 1931 2", dtype=dtype)[1].abs().sum() > 100


@pytest.mark.parametrize("name", ILLUMINANTS)
def test_illuminants_are_colour_science_data(name):
    wl, s = illuminant_spd(name)
    sd = colour.SDS_ILLUMINANTS[name]
    np.testing.assert_array_equal(wl.numpy(), sd.wavelengths)
    np.testing.assert_array_equal(s.numpy(), sd.values)
    if name == "E":
        assert bool((s == 100).all())  # colour-science's equal-energy illuminant is flat 100
    else:
        assert s[wl == 560].item() == pytest.approx(100.0, abs=1e-9)
    s32 = illuminant_spd(name, dtype=torch.float32)[1]
    assert s32.dtype == torch.float32


@pytest.mark.parametrize("observer", OBSERVERS)
@pytest.mark.parametrize("illuminant", ILLUMINANTS)
def test_white_point_is_the_perfect_reflector(observer, illuminant):
    """White = spectrum_to_xyz(R ≡ 1) on the observer's grid; ≈ colour.sd_to_XYZ / 100."""
    white = white_point_xyz(illuminant, observer)
    assert white[1].item() == 1.0
    wl, _ = cmfs(observer)
    ones = torch.ones_like(wl)
    xyz = spectrum_to_xyz(ones, wl, observer=observer, illuminant=illuminant)
    torch.testing.assert_close(xyz, white, rtol=1e-14, atol=0)

    data = colour.MSDS_CMFS[_OBSERVER_KEYS[observer]]
    if observer == SB:
        data = colour.colorimetry.XYZ_ColourMatchingFunctions(
            colour.colorimetry.RGB_10_degree_cmfs_to_XYZ_10_degree_cmfs(data.wavelengths), data.wavelengths
        )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # colour warns while aligning the illuminant to the CMF grid
        ref = colour.sd_to_XYZ(
            colour.SpectralDistribution(np.ones(len(data.wavelengths)), data.wavelengths),
            data,
            colour.SDS_ILLUMINANTS[illuminant],
            method="Integration",
        ) / 100
    # trapezoid (ours) vs rectangle sum (colour): only the two end samples differ.
    # measured: ≤ 2.9e-6 relative for the CIE observers, ≤ 2.7e-4 for Stiles & Burch (its
    # 5 nm grid starts at 390 nm where z̄ is not yet small)
    rtol = 3e-4 if observer == SB else 5e-6
    np.testing.assert_allclose(white.numpy(), ref, rtol=rtol, atol=0)

    xy = white_point_xy(illuminant, observer)
    np.testing.assert_allclose(xy.numpy(), colour.XYZ_to_xy(white.numpy()), rtol=1e-14)


@pytest.mark.parametrize("observer", CIE_OBSERVERS)
@pytest.mark.parametrize("illuminant", ILLUMINANTS)
def test_white_point_xy_matches_tabulated_chromaticities(observer, illuminant):
    tabulated = colour.CCS_ILLUMINANTS[_OBSERVER_KEYS[observer]][illuminant]
    # CIE tabulates 4–5 decimals: measured differences ≤ 3.7e-5
    np.testing.assert_allclose(white_point_xy(illuminant, observer).numpy(), tabulated, atol=5e-5, rtol=0)


def test_white_point_dtype():
    w32 = white_point_xyz("D65", dtype=torch.float32)
    assert w32.dtype == torch.float32
    torch.testing.assert_close(w32.double(), white_point_xyz("D65"), rtol=1e-7, atol=0)
    assert white_point_xy("A", "CIE 1964 10", dtype=torch.float32).dtype == torch.float32


@pytest.mark.parametrize(
    "call, param, valid",
    [
        (lambda: cmfs("CIE 1931"), "observer", OBSERVERS),
        (lambda: cmfs(None), "observer", OBSERVERS),
        (lambda: illuminant_spd("D66"), "name", ILLUMINANTS),
        (lambda: white_point_xyz("F2"), "illuminant", ILLUMINANTS),
        (lambda: white_point_xyz("D65", "2 degree"), "observer", OBSERVERS),
        (lambda: white_point_xy("D65", "CIE 2015 2"), "observer", OBSERVERS),
        (lambda: cmfs("CIE 1931 2", space="Lab"), "space", ("XYZ", "RGB")),
    ],
)
def test_bad_names_list_the_valid_ones(call, param, valid):
    with pytest.raises(ValueError) as err:
        call()
    msg = str(err.value)
    assert msg.startswith(param)
    for name in valid:
        assert repr(name) in msg


def test_rgb_space_only_for_rgb_observer_and_float_dtype():
    with pytest.raises(ValueError, match="space='RGB'.*Stiles & Burch"):
        cmfs("CIE 1931 2", space="RGB")
    with pytest.raises(ValueError, match="dtype"):
        cmfs("CIE 1931 2", dtype=torch.int64)
    with pytest.raises(ValueError, match="dtype"):
        illuminant_spd("D65", dtype="float64")
