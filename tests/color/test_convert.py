"""Tests of torchirid.color.convert: spectrum → XYZ → L*a*b* / sRGB.

Reference: colour-science (``sd_to_XYZ`` with the 'Integration' method, ``XYZ_to_Lab``,
``Lab_to_XYZ``, ``XYZ_to_sRGB`` / ``XYZ_to_RGB``, ``eotf_inverse_sRGB``); properties
(Y = 1 for the perfect reflector on any grid, grid refinement, white → L* = 100 and
sRGB (1, 1, 1)); broadcasting, NaN propagation, float32, gradients, bad input.
"""

from __future__ import annotations

import warnings

import colour
import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from torchirid.color import (
    ILLUMINANTS,
    OBSERVERS,
    lab_to_xyz,
    linear_srgb_to_srgb,
    spectrum_to_xyz,
    white_point_xy,
    white_point_xyz,
    xyz_to_lab,
    xyz_to_linear_srgb,
    xyz_to_srgb,
    xyz_weights,
)
from torchirid.color.colorimetry import _OBSERVER_KEYS

from tensors import F64, t64

CIE_OBSERVERS = ("CIE 1931 2", "CIE 1964 10")
# kornia's XYZ → linear sRGB matrix (kornia.color.xyz_to_rgb), for colour-science's reference
KORNIA_XYZ_TO_RGB = np.array(
    [
        [3.2404813432005266, -1.5371515162713185, -0.4985363261688878],
        [-0.9692549499965682, 1.8759900014898907, 0.0415559265582928],
        [0.0556466391351772, -0.2040413383665112, 1.0573110696453443],
    ]
)


def _smooth_spectra(wl: np.ndarray) -> np.ndarray:
    """(6, W): narrow and broad Gaussians, a smooth oscillation, the perfect reflector."""
    rows = [np.exp(-0.5 * ((wl - c) / s) ** 2) for c, s in [(450, 20), (540, 30), (620, 40), (500, 80)]]
    rows += [0.3 + 0.5 * np.sin(wl / 40.0) ** 2, np.ones_like(wl)]
    return np.stack(rows)


def _colour_xyz(R: np.ndarray, wl: np.ndarray, observer: str, illuminant: str, step: float) -> np.ndarray:
    shape = colour.SpectralShape(wl[0], wl[-1], step)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # colour warns while aligning CMFs / illuminant to the grid
        cm = colour.MSDS_CMFS[_OBSERVER_KEYS[observer]].copy().align(shape)
        return (
            colour.colorimetry.sd_to_XYZ_integration(R, cm, colour.SDS_ILLUMINANTS[illuminant], shape=shape)
            / 100
        )


# ---------------------------------------------------------------------------------------
# spectrum → XYZ
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("observer", CIE_OBSERVERS)
@pytest.mark.parametrize("illuminant", ILLUMINANTS)
@pytest.mark.parametrize("step", [1.0, 5.0])
def test_spectrum_to_xyz_matches_colour(observer, illuminant, step):
    """colour.sd_to_XYZ(method='Integration') / 100 on 1 nm and 5 nm grids, 360–830 nm.

    Measured: ≤ 1.1e-7 relative on Y, ≤ 1.5e-5 on X and Z (the trapezoid's half weights at
    the two end samples against colour's rectangle sum).
    """
    wl = np.arange(360.0, 830.0 + step / 2, step)
    R = _smooth_spectra(wl)
    ours = spectrum_to_xyz(t64(R), t64(wl), observer=observer, illuminant=illuminant).numpy()
    ref = _colour_xyz(R, wl, observer, illuminant, step)
    np.testing.assert_allclose(ours[:, 1], ref[:, 1], rtol=2e-7, atol=0)
    np.testing.assert_allclose(ours, ref, rtol=2e-5, atol=0)


def test_spectrum_to_xyz_stiles_burch_matches_colour():
    """Stiles & Burch XYZ (colour's RGB→XYZ transform) integrated by colour on 390–830 nm, 5 nm.

    Measured: ≤ 3.9e-6 relative on Y, ≤ 1.4e-4 on Z (end-sample half weights, z̄(390) > 0).
    """
    wl = np.arange(390.0, 831.0, 5.0)
    cm = colour.colorimetry.XYZ_ColourMatchingFunctions(
        colour.colorimetry.RGB_10_degree_cmfs_to_XYZ_10_degree_cmfs(wl), wl
    )
    R = _smooth_spectra(wl)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref = colour.colorimetry.sd_to_XYZ_integration(R, cm, colour.SDS_ILLUMINANTS["D65"], shape=cm.shape) / 100
    ours = spectrum_to_xyz(t64(R), t64(wl), observer="Stiles & Burch 1959 10").numpy()
    np.testing.assert_allclose(ours[:, 1], ref[:, 1], rtol=5e-6, atol=0)
    np.testing.assert_allclose(ours, ref, rtol=2e-4, atol=0)


def test_trapezoid_end_weights_explain_the_difference_to_colour():
    """Rectangle-rule weights built from ours reproduce colour-science to rounding."""
    wl = np.arange(360.0, 831.0, 5.0)
    R = _smooth_spectra(wl)
    w = xyz_weights(t64(wl)).numpy()
    w[0] *= 2  # undo the trapezoid's half weights at the two end samples
    w[-1] *= 2
    rect = R @ w / w[:, 1].sum()
    np.testing.assert_allclose(rect, _colour_xyz(R, wl, "CIE 1931 2", "D65", 5.0), rtol=1e-12, atol=0)


@settings(max_examples=40, deadline=None)
@given(
    st.lists(st.floats(300.0, 900.0, allow_nan=False), min_size=2, max_size=60, unique=True),
    st.sampled_from(OBSERVERS),
    st.sampled_from(ILLUMINANTS),
)
def test_perfect_reflector_has_y_one_on_any_grid(points, observer, illuminant):
    wl = t64(sorted(points))
    w = xyz_weights(wl, observer=observer, illuminant=illuminant) if _overlaps(wl, observer) else None
    if w is None:
        with pytest.raises(ValueError, match="wavelength must have a sample inside"):
            xyz_weights(wl, observer=observer, illuminant=illuminant)
        return
    xyz = spectrum_to_xyz(torch.ones_like(wl), wl, observer=observer, illuminant=illuminant)
    assert abs(xyz[1].item() - 1.0) <= 1e-14
    assert abs(w[:, 1].sum().item() - 1.0) <= 1e-14


def _overlaps(wl, observer):
    lo = 390.0 if observer == "Stiles & Burch 1959 10" else 360.0
    # ȳ > 0 on the whole tabulated range, so the normaliser is > 0 iff a sample lies inside
    inside = (wl >= lo) & (wl <= 830.0)
    return bool(inside.any())


def test_non_uniform_grid_converges():
    """A random non-uniform grid (~0.47 nm mean spacing) agrees with a 0.25 nm uniform grid."""
    g = np.random.default_rng(7)
    fine = np.arange(360.0, 830.01, 0.25)
    ragged = np.sort(np.concatenate([[360.0, 830.0], g.uniform(360.0, 830.0, 998)]))
    ref = spectrum_to_xyz(t64(_smooth_spectra(fine)), t64(fine))
    ours = spectrum_to_xyz(t64(_smooth_spectra(ragged)), t64(ragged))
    np.testing.assert_allclose(ours.numpy(), ref.numpy(), rtol=1e-3)  # measured 1.8e-4


def test_samples_outside_the_observer_range_contribute_nothing():
    wide = np.arange(300.0, 901.0, 1.0)
    cie = np.arange(360.0, 831.0, 1.0)
    a = spectrum_to_xyz(t64(_smooth_spectra(wide)), t64(wide))
    b = spectrum_to_xyz(t64(_smooth_spectra(cie)), t64(cie))
    # only the trapezoid weight of the 360 and 830 nm samples changes: measured 1.2e-6 (Z of white)
    np.testing.assert_allclose(a.numpy(), b.numpy(), rtol=3e-6)
    R = _smooth_spectra(wide)
    R[:, (wide < 359) | (wide > 831)] = 1e6  # garbage outside the range is ignored
    np.testing.assert_array_equal(spectrum_to_xyz(t64(R), t64(wide)).numpy(), a.numpy())


def test_weights_fast_path_and_gradient():
    wl = t64(np.arange(380.0, 781.0, 10.0))
    R = torch.rand(5, wl.shape[0], dtype=F64, requires_grad=True)
    w = xyz_weights(wl, observer="CIE 1964 10", illuminant="A")
    xyz = spectrum_to_xyz(R, wl, observer="CIE 1964 10", illuminant="A")
    torch.testing.assert_close(R @ w, xyz, rtol=1e-14, atol=0)
    assert torch.autograd.gradcheck(lambda r: spectrum_to_xyz(r, wl), (R[:2],))
    (g,) = torch.autograd.grad(spectrum_to_xyz(R, wl)[:, 1].sum(), R)
    torch.testing.assert_close(g, xyz_weights(wl)[:, 1].expand_as(g))


def test_spectrum_broadcasting_nan_and_dtype():
    wl = t64(np.arange(400.0, 701.0, 5.0))
    R = torch.rand(2, 3, wl.shape[0], dtype=F64)
    xyz = spectrum_to_xyz(R, wl)
    assert xyz.shape == (2, 3, 3) and xyz.dtype == F64
    torch.testing.assert_close(xyz[1, 2], spectrum_to_xyz(R[1, 2], wl), rtol=1e-14, atol=1e-15)
    R[0, 1, 10] = float("nan")
    xyz = spectrum_to_xyz(R, wl)
    assert torch.isnan(xyz[0, 1]).all() and torch.isfinite(xyz[1]).all() and torch.isfinite(xyz[0, 0]).all()
    # float32 (spectrum and wavelength): measured 1.2e-6 relative to float64
    x32 = spectrum_to_xyz(R[1].float(), wl.float())
    assert x32.dtype == torch.float32
    torch.testing.assert_close(x32.double(), spectrum_to_xyz(R[1], wl), rtol=1e-5, atol=1e-7)
    # dtype follows the spectrum, not the wavelength
    assert spectrum_to_xyz(R[1].float(), wl).dtype == torch.float32
    # plain Python lists are accepted
    assert spectrum_to_xyz([1.0, 1.0, 1.0], [500.0, 550.0, 600.0]).shape == (3,)


@pytest.mark.parametrize(
    "spectrum, wavelength, match",
    [
        (torch.ones(3), [400.0, 500.0, 450.0], "wavelength must be strictly increasing"),
        (torch.ones(3), [400.0, 500.0, 500.0], "wavelength must be strictly increasing"),
        (torch.ones(1), [500.0], "wavelength must have at least 2"),
        (torch.ones(4), torch.ones(2, 2), "wavelength must be a 1-D"),
        (torch.ones(2), [400.0, float("nan")], "wavelength must be finite"),
        (torch.ones(2), [-5.0, 500.0], "wavelength must be in nm"),
        (torch.ones(2), [900.0, 1000.0], "wavelength must have a sample inside .*360–830"),
        (torch.ones(2), [300.0, 900.0], "wavelength must have a sample inside"),  # straddles, no sample in
        (torch.ones(4), [400.0, 500.0, 600.0], "spectrum must have 3 samples"),
        (torch.tensor(1.0), [400.0, 500.0], "spectrum must have shape"),
        (torch.ones(2, dtype=torch.complex64), [400.0, 500.0], "spectrum must be real"),
    ],
)
def test_spectrum_bad_input(spectrum, wavelength, match):
    with pytest.raises(ValueError, match=match):
        spectrum_to_xyz(spectrum, wavelength)


@pytest.mark.parametrize(
    "kwargs, param, valid",
    [({"observer": "CIE 1931"}, "observer", OBSERVERS), ({"illuminant": "D60"}, "illuminant", ILLUMINANTS)],
)
def test_bad_names_list_the_valid_ones(kwargs, param, valid):
    for call in (
        lambda: spectrum_to_xyz(torch.ones(2), [400.0, 500.0], **kwargs),
        lambda: xyz_weights([400.0, 500.0], **kwargs),
        lambda: xyz_to_lab(torch.ones(3), **kwargs),
        lambda: lab_to_xyz(torch.ones(3), **kwargs),
    ):
        with pytest.raises(ValueError) as err:
            call()
        assert str(err.value).startswith(param) and all(repr(v) in str(err.value) for v in valid)


# ---------------------------------------------------------------------------------------
# L*a*b*
# ---------------------------------------------------------------------------------------


def _xyz_samples(n=400, seed=11):
    g = np.random.default_rng(seed)
    xyz = g.uniform(0.0, 1.1, (n, 3))
    xyz[:4] = 0.0  # black
    xyz[4:12] *= 1e-3  # the linear segment (t < ε)
    xyz[12] = [216 / 24389, 216 / 24389, 216 / 24389]  # exactly at the switch (relative to Y_n=1)
    return xyz


@pytest.mark.parametrize("observer", OBSERVERS)
@pytest.mark.parametrize("illuminant", ILLUMINANTS)
def test_lab_matches_colour(observer, illuminant):
    """colour.XYZ_to_Lab / Lab_to_XYZ with our white point. Measured ≤ 2e-13 (Lab), 1.3e-15 (XYZ)."""
    xyz = _xyz_samples()
    wxy = white_point_xy(illuminant, observer).numpy()
    lab = xyz_to_lab(t64(xyz), illuminant=illuminant, observer=observer)
    np.testing.assert_allclose(lab.numpy(), colour.XYZ_to_Lab(xyz, wxy), rtol=0, atol=1e-9)
    back = lab_to_xyz(lab, illuminant=illuminant, observer=observer).numpy()
    np.testing.assert_allclose(back, colour.Lab_to_XYZ(lab.numpy(), wxy), rtol=0, atol=1e-12)
    np.testing.assert_allclose(back, xyz, rtol=0, atol=1e-12)


@pytest.mark.parametrize("illuminant", ILLUMINANTS)
def test_perfect_white_is_lab_100(illuminant):
    wl = t64(np.arange(360.0, 831.0, 1.0))
    white = spectrum_to_xyz(torch.ones_like(wl), wl, illuminant=illuminant)
    torch.testing.assert_close(white, white_point_xyz(illuminant), rtol=1e-14, atol=0)
    lab = xyz_to_lab(white, illuminant=illuminant)
    torch.testing.assert_close(lab, t64([100.0, 0.0, 0.0]), rtol=0, atol=1e-12)


def test_lab_gradients_finite_and_gradcheck():
    xyz = t64([[0.0, 0.0, 0.0], [-0.01, 0.0, 0.02], [216 / 24389] * 3, [1e-12, 1e-300, 0.0]]).requires_grad_()
    lab = xyz_to_lab(xyz)
    (g,) = torch.autograd.grad(lab.sum(), xyz)
    assert torch.isfinite(g).all()
    # on the linear segment the slope is exactly κ/116 per unit of t = X / X_n
    (gL,) = torch.autograd.grad(xyz_to_lab(xyz)[0, 0], xyz)
    assert gL[0, 1].item() == pytest.approx(24389 / 27, rel=1e-12)
    pts = t64(_xyz_samples(20, seed=3)[13:]).requires_grad_()
    assert torch.autograd.gradcheck(xyz_to_lab, (pts,))
    lab_pts = xyz_to_lab(pts.detach()).requires_grad_()
    assert torch.autograd.gradcheck(lab_to_xyz, (lab_pts,))


def test_lab_broadcasting_nan_float32_and_bad_shape():
    xyz = t64(_xyz_samples(24)).reshape(2, 3, 4, 3)
    lab = xyz_to_lab(xyz)
    assert lab.shape == (2, 3, 4, 3)
    torch.testing.assert_close(lab[1, 2, 3], xyz_to_lab(xyz[1, 2, 3]), rtol=1e-15, atol=1e-13)
    xyz[0, 0, 0, 0] = float("nan")  # X feeds a* only
    lab = xyz_to_lab(xyz)
    assert torch.isnan(lab[0, 0, 0, 1]) and torch.isfinite(lab[0, 0, 0, [0, 2]]).all()
    assert torch.isfinite(lab[1]).all()
    # float32: measured 5.9e-5 absolute on L*, a*, b* (values up to ~100)
    xyz32 = t64(_xyz_samples()).float()
    lab32 = xyz_to_lab(xyz32)
    assert lab32.dtype == torch.float32
    np.testing.assert_allclose(lab32.double().numpy(), xyz_to_lab(t64(_xyz_samples())).numpy(), atol=2e-4, rtol=0)
    with pytest.raises(ValueError, match=r"xyz must have shape \(\*, 3\)"):
        xyz_to_lab(torch.ones(4))
    with pytest.raises(ValueError, match=r"lab must have shape \(\*, 3\)"):
        lab_to_xyz(torch.tensor(1.0))


# ---------------------------------------------------------------------------------------
# sRGB (kornia)
# ---------------------------------------------------------------------------------------


def _srgb_kornia_matrix_colourspace():
    cs = colour.RGB_COLOURSPACES["sRGB"].copy()
    cs.matrix_XYZ_to_RGB = KORNIA_XYZ_TO_RGB
    cs.use_derived_matrix_XYZ_to_RGB = False
    return cs


def test_srgb_matches_colour_with_the_same_matrix():
    """colour.XYZ_to_RGB (sRGB, D65, cctf encoding) with kornia's matrix: measured 1.1e-14."""
    xyz = _xyz_samples()
    cs = _srgb_kornia_matrix_colourspace()
    ref = colour.XYZ_to_RGB(xyz, cs, illuminant=cs.whitepoint, apply_cctf_encoding=True)
    np.testing.assert_allclose(xyz_to_srgb(t64(xyz)).numpy(), ref, rtol=0, atol=1e-12)
    ref_lin = colour.XYZ_to_RGB(xyz, cs, illuminant=cs.whitepoint, apply_cctf_encoding=False)
    np.testing.assert_allclose(xyz_to_linear_srgb(t64(xyz)).numpy(), ref_lin, rtol=0, atol=1e-14)


def test_srgb_against_colour_default_iec_matrix():
    """colour.XYZ_to_sRGB uses the 4-decimal IEC 61966-2-1 matrix; kornia's differs by
    ≤ 3.55e-4 per entry: measured ≤ 3.7e-4 on linear RGB, ≤ 4.8e-3 after the transfer
    function (its slope is 12.92 near black), for XYZ in [0, 1.1]³."""
    cs = colour.RGB_COLOURSPACES["sRGB"]
    assert np.abs(KORNIA_XYZ_TO_RGB - cs.matrix_XYZ_to_RGB).max() < 3.6e-4
    xyz = _xyz_samples()
    lin_ref = colour.XYZ_to_RGB(xyz, cs, illuminant=cs.whitepoint, apply_cctf_encoding=False)
    np.testing.assert_allclose(xyz_to_linear_srgb(t64(xyz)).numpy(), lin_ref, rtol=0, atol=4e-4)
    np.testing.assert_allclose(xyz_to_srgb(t64(xyz)).numpy(), colour.XYZ_to_sRGB(xyz), rtol=0, atol=5e-3)


def test_transfer_function_matches_colour_and_has_finite_gradients():
    r = np.concatenate([np.linspace(-0.1, 1.2, 300), [0.0, 0.0031308, np.nextafter(0.0031308, 1)]])
    ours = linear_srgb_to_srgb(t64(r).reshape(-1, 3))
    np.testing.assert_allclose(ours.numpy().ravel(), colour.models.eotf_inverse_sRGB(r), rtol=0, atol=1e-15)
    # float32: measured 1.4e-7
    np.testing.assert_allclose(
        linear_srgb_to_srgb(t64(r).reshape(-1, 3).float()).double().numpy().ravel(),
        colour.models.eotf_inverse_sRGB(r),
        atol=1e-6,
    )
    x = t64([[0.0, 0.0031308, -0.0], [0.5, 1.0, -0.2]]).requires_grad_()
    (g,) = torch.autograd.grad(linear_srgb_to_srgb(x).sum(), x)
    assert torch.isfinite(g).all()
    assert g[0, 0].item() == pytest.approx(12.92)  # the linear toe's slope at black
    assert torch.autograd.gradcheck(xyz_to_srgb, (t64(_xyz_samples(20, seed=5)[13:17]).requires_grad_(),))


def test_d65_white_is_srgb_white():
    wl = t64(np.arange(360.0, 831.0, 1.0))
    white = spectrum_to_xyz(torch.ones_like(wl), wl, illuminant="D65")
    torch.testing.assert_close(xyz_to_linear_srgb(white), torch.ones(3, dtype=F64), rtol=0, atol=1e-4)  # 7.8e-5
    torch.testing.assert_close(xyz_to_srgb(white), torch.ones(3, dtype=F64), rtol=0, atol=1e-4)
    black = torch.zeros(3, dtype=F64, requires_grad=True)
    out = xyz_to_srgb(black)
    assert out.abs().max().item() == 0.0
    (g,) = torch.autograd.grad(out.sum(), black)
    assert torch.isfinite(g).all()


def test_srgb_broadcasting_nan_dtype_and_bad_shape():
    xyz = t64(_xyz_samples(24)).reshape(2, 3, 4, 3)
    rgb = xyz_to_srgb(xyz)
    assert rgb.shape == (2, 3, 4, 3)
    torch.testing.assert_close(rgb[1, 0, 2], xyz_to_srgb(xyz[1, 0, 2]), rtol=1e-15, atol=1e-15)
    xyz[1, 1, 1, 2] = float("nan")
    rgb = xyz_to_srgb(xyz)
    assert torch.isnan(rgb[1, 1, 1]).all() and torch.isfinite(rgb[0]).all()
    x32 = xyz_to_srgb(t64(_xyz_samples()).float())
    assert x32.dtype == torch.float32
    np.testing.assert_allclose(x32.double().numpy(), xyz_to_srgb(t64(_xyz_samples())).numpy(), atol=1e-5)
    for fn, name in ((xyz_to_srgb, "xyz"), (xyz_to_linear_srgb, "xyz"), (linear_srgb_to_srgb, "rgb")):
        with pytest.raises(ValueError, match=rf"{name} must have shape \(\*, 3\)"):
            fn(torch.ones(2, 4))
