"""Tests of torchirid.spectral.cumulative: the cumulative CMF tables C̄(ω) (Fourneau eq. 15–16).

The reference is independent of the module: torchirid.color.spectrum_to_xyz of box
spectra sampled on a λ grid holding every tabulated knot of the CMFs (so the trapezoid
rule is exact on the piecewise-linear illuminant × CMF product) and each box boundary twice,
± 1e-9 nm (so a jump costs ≤ 1e-9 nm × |S x̄| / ∫S ȳ ≈ 1e-13).
"""

from __future__ import annotations

import math
import shutil
import warnings

import numpy as np
import pytest
import torch

from torchirid.color import spectrum_to_xyz
from torchirid.lut import LUT
from torchirid.spectral import cumulative as cm
from torchirid.spectral.cumulative import (
    CUMULATIVE_CMF_BUILDER,
    box_integrals,
    cumulative_cmf_lut,
    shipped_cumulative_cmf_lut,
    cumulative_cmf_path,
)

F64 = torch.float64
TWO_PI = 2.0 * math.pi
LO, HI = 380.0, 780.0
SHIPPED = [(o, i) for o in ("CIE 1931 2", "CIE 1964 10") for i in ("D65", "E")]
_JUMP = 1e-9  # nm: half-width of the sample pair straddling a box boundary


def _xyz_of_boxes(lam_edges, weights, observer="CIE 1931 2", illuminant="D65"):
    """spectrum_to_xyz of ``R(λ) = weights[b, j]`` for λ in ``[lam_edges[b, j], lam_edges[b, j+1])``
    (the last box closed; 0 elsewhere in [LO, HI]), ``lam_edges (B, J+1)`` increasing, nm → (B, 3)."""
    lam_edges = np.asarray(lam_edges, dtype=np.float64)
    weights = np.asarray(weights, dtype=np.float64)
    knots = np.arange(LO, HI + 0.5, 1.0)  # the CIE observers' 1 nm knots
    inner = lam_edges[(lam_edges > LO + _JUMP) & (lam_edges < HI - _JUMP)]
    grid = np.unique(np.concatenate((knots, inner - _JUMP, inner + _JUMP)))
    spectra = np.zeros((lam_edges.shape[0], grid.size))
    for b in range(lam_edges.shape[0]):
        j = np.searchsorted(lam_edges[b], grid, side="right") - 1
        j[grid == lam_edges[b, -1]] = weights.shape[1] - 1  # the last box is closed: [a, b]
        inside = (j >= 0) & (j < weights.shape[1])
        spectra[b, inside] = weights[b, j[inside]]
    return spectrum_to_xyz(torch.from_numpy(spectra), torch.from_numpy(grid),
                           observer=observer, illuminant=illuminant)


def _edges_omega(rng, batch, boxes):
    """Random increasing box boundaries in ω (nm⁻¹) inside the range, and weights in [0, 1]."""
    lam = np.sort(rng.uniform(LO, HI, size=(batch, boxes + 1)), axis=-1)
    omega = np.sort(TWO_PI / lam, axis=-1)
    return omega, rng.uniform(0.0, 1.0, size=(batch, boxes))


@pytest.fixture(scope="module")
def lut():
    return shipped_cumulative_cmf_lut()


# ----------------------------------------------------------------------------- totals
@pytest.mark.parametrize("observer, illuminant", SHIPPED)
def test_total_is_the_perfect_reflector(observer, illuminant):
    table = shipped_cumulative_cmf_lut(observer, illuminant)
    wl = torch.linspace(LO, HI, 4001, dtype=F64)  # 0.1 nm: holds the 1 nm knots
    white = spectrum_to_xyz(torch.ones_like(wl), wl, observer=observer, illuminant=illuminant)
    assert torch.allclose(table.values[-1], white, rtol=0, atol=1e-6)
    assert table.values[-1, 1].item() == 1.0  # Y = 1 exactly
    assert torch.equal(table.values[0], torch.zeros(3, dtype=F64))  # C̄(ω_min) = 0
    omega = table.axes["omega"]
    assert math.isclose(omega[0].item(), TWO_PI / HI, rel_tol=1e-15)
    assert math.isclose(omega[-1].item(), TWO_PI / LO, rel_tol=1e-15)
    assert bool((table.values[1:] >= table.values[:-1]).all())  # c̄ ≥ 0: non-decreasing


# ----------------------------------------------------------------------------- eq. 15
@pytest.mark.parametrize("observer, illuminant, boxes", [
    ("CIE 1931 2", "D65", 1), ("CIE 1931 2", "D65", 4), ("CIE 1931 2", "E", 7),
    ("CIE 1964 10", "D65", 3), ("CIE 1964 10", "E", 5)])
def test_piecewise_constant_spectra(observer, illuminant, boxes):
    rng = np.random.default_rng(boxes)
    omega, w = _edges_omega(rng, 8, boxes)
    table = shipped_cumulative_cmf_lut(observer, illuminant)
    got = (torch.from_numpy(w)[..., None] * box_integrals(torch.from_numpy(omega), table)).sum(-2)
    ref = _xyz_of_boxes(np.flip(TWO_PI / omega, -1), np.flip(w, -1), observer, illuminant)
    err = (got - ref).abs()
    # each boundary k errs by ≤ 1e-6 × |w_k − w_{k−1}| (w = 0 outside the boxes)
    jumps = np.abs(np.diff(np.pad(w, ((0, 0), (1, 1))), axis=-1)).sum(-1)
    assert bool((err <= 1e-6 * torch.from_numpy(jumps)[:, None] + 1e-12).all()), err.max()
    assert err.max().item() <= 2e-6


def test_boxes_tile_the_range(lut):
    """Boxes covering [ω_min, ω_max] (and beyond: clamped) sum to the perfect reflector."""
    edges = torch.linspace(0.5 * TWO_PI / HI, 1.5 * TWO_PI / LO, 57, dtype=F64)
    total = box_integrals(edges, lut).sum(-2)
    assert torch.allclose(total, lut.values[-1], rtol=0, atol=1e-13)
    outside = box_integrals(torch.tensor([0.001, 0.002, TWO_PI / HI], dtype=F64), lut)
    assert torch.equal(outside, torch.zeros(2, 3, dtype=F64))  # boxes outside contribute 0
    empty = box_integrals(torch.tensor([0.012, 0.012], dtype=F64), lut)
    assert torch.equal(empty, torch.zeros(1, 3, dtype=F64))


# ----------------------------------------------------------------------------- accuracy
@pytest.mark.parametrize("observer, illuminant", SHIPPED)
def test_interpolation_accuracy(observer, illuminant):
    rng = np.random.default_rng(7)
    omega = rng.uniform(TWO_PI / HI, TWO_PI / LO, 300)
    table = shipped_cumulative_cmf_lut(observer, illuminant)
    got = table(omega=torch.from_numpy(omega))
    # exact C̄(ω): the XYZ of the box [2π/ω, λ_max] with weight 1 (independent reference)
    lam = TWO_PI / omega
    ref = _xyz_of_boxes(np.stack((lam, np.full_like(lam, HI)), -1), np.ones((lam.size, 1)),
                        observer, illuminant)
    assert (got - ref).abs().max().item() <= 1e-6
    # the module's own exact integral agrees with the reference to rounding
    exact = cm._exact(observer, illuminant, LO, HI).cumulative(omega)
    assert np.abs(exact - ref.numpy()).max() <= 1e-12
    # and the measured error is recorded, ≤ the automatic tolerance
    assert max(table.parameters["max_interp_error"]) <= cm.CUMULATIVE_CMF_TOLERANCE


def test_recorded_error_is_the_true_maximum():
    """The recorded error is what a much denser check finds (to 1 %), and halves ~4x with 2x nodes."""
    exact = cm._exact("CIE 1931 2", "D65", LO, HI)
    coarse = cumulative_cmf_lut(nodes=400)
    fine = cumulative_cmf_lut(nodes=799)  # half the spacing
    for table in (coarse, fine):
        omega = torch.linspace(TWO_PI / HI, TWO_PI / LO, 400_001, dtype=F64)
        dense = (table(omega=omega) - torch.from_numpy(exact.cumulative(omega.numpy()))).abs().amax(0)
        recorded = torch.tensor(table.parameters["max_interp_error"], dtype=F64)
        assert bool((dense <= recorded * 1.0001).all()) and bool((dense >= 0.99 * recorded).all())
        assert table.parameters["tolerance"] is None and table.parameters["nodes"] == table.values.shape[0]
    ratio = np.array(coarse.parameters["max_interp_error"]) / np.array(fine.parameters["max_interp_error"])
    assert bool(((ratio > 3.5) & (ratio < 4.5)).all())


# ----------------------------------------------------------------------------- files
@pytest.mark.parametrize("observer, illuminant", SHIPPED)
def test_shipped_file_matches_a_fresh_build(observer, illuminant):
    path = cumulative_cmf_path(observer, illuminant)
    assert path.is_file(), f"missing shipped table {path}: run luts/build_cumulative_cmf.py"
    assert path.stat().st_size < 300_000
    shipped = LUT.read(path, builder=CUMULATIVE_CMF_BUILDER,
                       parameters={"observer": observer, "illuminant": illuminant,
                                   "wavelength_range": [LO, HI]})
    fresh = cumulative_cmf_lut(observer, illuminant)
    assert shipped.parameters == fresh.parameters
    assert torch.equal(shipped.axes["omega"], fresh.axes["omega"])
    assert torch.allclose(shipped.values, fresh.values, rtol=0, atol=1e-15)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the shipped file is used, without a warning
        assert torch.equal(cm._load_or_build(observer, illuminant, LO, HI).values, shipped.values)


def test_tampered_file_is_refused(tmp_path):
    src = cumulative_cmf_path("CIE 1931 2", "D65")
    dst = tmp_path / "tampered.npz"
    shutil.copy(src, dst)
    with np.load(dst, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["values"] = arrays["values"].copy()
    arrays["values"][1000, 1] += 1e-9  # one value nudged, metadata (and hash) untouched
    np.savez(dst, **arrays)
    with pytest.raises(ValueError, match="hash mismatch"):
        LUT.read(dst, builder=CUMULATIVE_CMF_BUILDER)


def test_stale_or_corrupt_shipped_file_falls_back_to_a_build(tmp_path, monkeypatch):
    other = cumulative_cmf_lut(nodes=50)  # not the automatic table: parameters differ
    other.write(tmp_path / "cie_1931_2_d65_380_780nm.npz")
    (tmp_path / "cie_1931_2_d65_380_780nm.npz").with_name("cie_1931_2_e_380_780nm.npz").write_bytes(b"junk")
    monkeypatch.setattr(cm, "cumulative_cmf_path",
                        lambda o, i, r: tmp_path / (cm._slug(o, i, *r) + ".npz"))
    for illuminant in ("D65", "E"):
        with pytest.warns(RuntimeWarning, match="ignoring the shipped table"):
            table = cm._load_or_build("CIE 1931 2", illuminant, LO, HI)
        assert table.parameters["tolerance"] == cm.CUMULATIVE_CMF_TOLERANCE
        assert table.values.shape[0] > 3000


def test_cache_dtype_device(lut):
    assert shipped_cumulative_cmf_lut() is lut and shipped_cumulative_cmf_lut("CIE 1931 2", "D65", [380, 780]) is lut
    f32 = shipped_cumulative_cmf_lut(dtype=torch.float32)
    assert f32.dtype == torch.float32 and f32 is shipped_cumulative_cmf_lut(dtype=torch.float32)
    assert torch.allclose(f32.values.double(), lut.values, rtol=0, atol=1e-7)
    # float32 landmarks: within ~1e-6 (ω rounding × slope c̄), see the module docstring
    rng = np.random.default_rng(3)
    omega = torch.from_numpy(np.sort(rng.uniform(TWO_PI / HI, TWO_PI / LO, (200, 6)), -1))
    b64 = box_integrals(omega, lut)
    b32 = box_integrals(omega.float(), f32)
    assert b32.dtype == torch.float32
    assert (b32.double() - b64).abs().max().item() <= 2e-6


# ----------------------------------------------------------------------------- autograd
def test_gradcheck(lut):
    g = lut.axes["omega"]
    idx = torch.tensor([[5, 900, 1800, 2500, 3600], [100, 101, 2000, 3000, 3300]])
    omega = (0.5 * (g[idx] + g[idx + 1])).requires_grad_(True)  # cell midpoints: generic
    eps = 1e-3 * (g[1] - g[0]).item()
    assert torch.autograd.gradcheck(lambda o: box_integrals(o, lut), (omega,), eps=eps, atol=1e-6)
    # the derivative is the mean density c̄ of the cell: close to the exact c̄ at the point
    (grad,) = torch.autograd.grad(box_integrals(omega, lut)[..., -1, :].sum(), omega)
    exact = torch.from_numpy(cm._exact("CIE 1931 2", "D65", LO, HI).density(omega.detach().numpy()))
    assert torch.allclose(grad[..., -1], exact[..., -1, :].sum(-1), rtol=1e-4, atol=1e-3)
    assert torch.isfinite(grad).all()


def test_gradient_zero_outside_and_finite_at_nodes(lut):
    g = lut.axes["omega"]
    omega = torch.stack([0.5 * g[0], g[0], g[1800], g[-1], 2 * g[-1]]).requires_grad_(True)
    box_integrals(omega, lut).sum().backward()
    assert torch.isfinite(omega.grad).all()
    assert omega.grad[0].item() == 0.0 and omega.grad[-1].item() == 0.0


# ----------------------------------------------------------------------------- shapes, errors
@pytest.mark.parametrize("shape", [(2,), (7,), (3, 5), (2, 3, 4)])
def test_batch_shapes(lut, shape):
    rng = np.random.default_rng(sum(shape))
    omega = torch.from_numpy(np.sort(rng.uniform(TWO_PI / HI, TWO_PI / LO, shape), -1))
    out = box_integrals(omega, lut)
    assert out.shape == shape[:-1] + (shape[-1] - 1, 3)
    flat = box_integrals(omega.reshape(-1, shape[-1]), lut)
    assert torch.equal(out.reshape(flat.shape), flat)
    # broadcasting of a shared edge set against the batch of the weights
    w = torch.rand(4, 1, dtype=F64)
    assert (w[..., None] * box_integrals(omega[..., :2].reshape(-1)[:2], lut)).shape == (4, 1, 3)


def test_nan_propagates(lut):
    out = box_integrals(torch.tensor([0.009, math.nan, 0.012], dtype=F64), lut)
    assert torch.isnan(out).any(-1).all() and out.shape == (2, 3)


@pytest.mark.parametrize("kwargs, match", [
    (dict(observer="CIE 2015"), "observer must be one of"),
    (dict(illuminant="F2"), "illuminant must be one of"),
    (dict(wavelength_range=(780.0, 380.0)), "wavelength_range"),
    (dict(wavelength_range=(0.0, 780.0)), "wavelength_range"),
    (dict(wavelength_range=(900.0, 1000.0)), "does not overlap"),
    (dict(wavelength_range=380.0), "wavelength_range"),
])
def test_bad_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        cumulative_cmf_lut(**kwargs)
    with pytest.raises(ValueError, match=match):
        shipped_cumulative_cmf_lut(**kwargs)


def test_bad_box_arguments(lut):
    with pytest.raises(ValueError, match="non-decreasing"):
        box_integrals(torch.tensor([0.012, 0.011], dtype=F64), lut)
    with pytest.raises(ValueError, match="J\\+1 >= 2"):
        box_integrals(torch.tensor([0.012], dtype=F64), lut)
    with pytest.raises(ValueError, match="J\\+1 >= 2"):
        box_integrals(torch.tensor(0.012, dtype=F64), lut)
    with pytest.raises(ValueError, match="must be real"):
        box_integrals(torch.tensor([0.01, 0.012], dtype=torch.complex128), lut)
    with pytest.raises(ValueError, match="3 channels"):
        box_integrals(torch.tensor([0.01, 0.012], dtype=F64), lut.values)
    with pytest.raises(ValueError, match="nodes"):
        cumulative_cmf_lut(nodes=1)
    with pytest.raises(ValueError, match="tolerance"):
        cumulative_cmf_lut(tolerance=0.0)
    with pytest.raises(ValueError, match="dtype"):
        shipped_cumulative_cmf_lut(dtype=torch.int64)
    with pytest.raises(ValueError, match="dtype"):
        shipped_cumulative_cmf_lut(dtype=torch.float16)
