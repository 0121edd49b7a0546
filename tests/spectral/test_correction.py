"""Angular correction w̃ of Fourneau et al. 2024, appendix B: reference integral, limits, shipped fit."""

import importlib.util
import json
import math
import os

import mpmath
import pytest
import torch

from tensors import F64, t64
from torchirid.optics import fresnel_reflectance
from torchirid.spectral import correction as corr
from torchirid.spectral.correction import (
    PAPER_COEFFICIENTS,
    angular_correction,
    angular_correction_limit,
    angular_correction_reference,
    fitted_coefficients,
)

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPT = os.path.join(ROOT, "training", "fit_angular_correction.py")


def _script():
    spec = importlib.util.spec_from_file_location("fit_angular_correction", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _shipped():
    with open(corr.DATA_FILE, encoding="utf-8") as fh:
        return json.load(fh)


# --- independent references (mpmath) ---------------------------------------------------------


def _w_mpmath(r12, N, dps=20):
    """(1/π) ∫₀^π R/R^e dx straight from the paper's R and R^e, |C|² = R1/(1 − R1), by mpmath.quad
    split at the zeros jπ/N of sin Nx (where the integrand dips to 0)."""
    with mpmath.workdps(dps):
        R12 = mpmath.mpf(r12)
        R1 = R12 + R12 * (1 - R12) ** 2 / (1 - R12**2)
        C2 = R1 / (1 - R1)

        def ratio(x):
            s2, S2 = mpmath.sin(x) ** 2, mpmath.sin(N * x) ** 2
            R = C2 / (C2 + s2 / S2)
            Re = C2 / (C2 + s2)
            return R / Re

        return float(mpmath.quad(ratio, [mpmath.pi * j / N for j in range(N + 1)]) / mpmath.pi)


def _w_limit_mpmath(r12):
    """N → ∞: 1 + 1/2c − (√c + (1 + c) arcsin(1/√(1 + c)))/(πc) (the unsimplified form)."""
    with mpmath.workdps(40):
        R = mpmath.mpf(r12)
        c = 2 * R / (1 - R)
        core = mpmath.sqrt(c) + (1 + c) * mpmath.asin(1 / mpmath.sqrt(1 + c))
        return float(1 + 1 / (2 * c) - core / (mpmath.pi * c))


# --- the reference integral ------------------------------------------------------------------


@pytest.mark.parametrize("r12,N", [(0.04, 20), (0.3, 20), (0.9999, 20), (0.5, 3)])
def test_reference_quadrature_matches_mpmath(r12, N):
    w = corr._bloch_average(t64([r12]), N, 64)
    assert abs(float(w) - _w_mpmath(r12, N)) <= 1e-8


def test_reference_at_an_angle_matches_mpmath():
    c, n1, n2 = 0.3, 1.33, 2.1
    r12 = float(fresnel_reflectance(t64(c), n1, n2))
    assert abs(float(angular_correction_reference(t64(c), n1, n2)) - _w_mpmath(r12, 20)) <= 1e-8


def test_reference_quadrature_converges():
    r = t64([0.0, 1e-4, 0.04, 0.3, 0.9, 0.99])
    for N in (1, 7, 20, 100):
        d = (corr._bloch_average(r, N, 64) - corr._bloch_average(r, N, 256)).abs()
        assert d[:-1].max() <= 1e-10 and d[-1] <= 1e-9


def test_reference_depends_only_on_the_index_ratio():
    c = torch.linspace(0, 1, 11, dtype=F64)
    w_a = angular_correction_reference(c, 1.33, 2.0)
    w_b = angular_correction_reference(c, 1.0, 2.0 / 1.33)
    assert (w_a - w_b).abs().max() <= 1e-12


def test_reference_limits():
    # R12 = 0 (same medium; p at Brewster's angle): R/R^e = sin² Nx, w = 1/2
    assert abs(float(angular_correction_reference(t64(0.7), 1.5, 1.5)) - 0.5) <= 1e-14
    c_brewster = 1 / math.sqrt(1 + 1.5**2)
    w_p = angular_correction_reference(t64(c_brewster), 1.0, 1.5, polarization="p")
    assert abs(float(w_p) - 0.5) <= 1e-12
    # R12 = 1: grazing incidence and total internal reflection give exactly 1
    assert float(angular_correction_reference(t64(0.0), 1.0, 1.5)) == 1.0
    assert float(angular_correction_reference(t64(0.3), 1.5, 1.0)) == 1.0
    # every value is a mean of ratios R/R^e in [0, 1]
    w = angular_correction_reference(torch.linspace(0, 1, 41, dtype=F64)[:, None], 1.0, t64([1.05, 1.5, 3.0, 4.0]))
    assert bool(((w >= 0.5 - 1e-12) & (w <= 1)).all())


def test_reference_near_grazing_rises_as_sqrt_cos():
    """1 − w ≈ cot(π/2N)/(N|C|) as R12 → 1, so 1 − w ∝ √(1 − R12) ∝ √cos θ1 (documented)."""
    N = 20
    for one_minus in (1e-6, 1e-8):
        r12 = 1 - one_minus
        c2 = 2 * r12 / (1 - r12)
        w = float(corr._bloch_average(t64([r12]), N, 128))
        assert (1 - w) == pytest.approx(1 / math.tan(math.pi / (2 * N)) / (N * math.sqrt(c2)), rel=2e-3)
    cos = t64([1e-6, 4e-6])
    w = angular_correction_reference(cos, 1.0, 1.5, samples=128)
    assert float((1 - w[0]) / (1 - w[1])) == pytest.approx(0.5, rel=1e-2)
    # and w increases monotonically towards 1 over the last 30 degrees
    theta = torch.linspace(60, 90, 31, dtype=F64)
    cos = torch.cos(torch.deg2rad(theta)).clamp(0, 1)
    cos[-1] = 0.0  # cos(deg2rad(90)) rounds to 6e-17, not 0
    w = angular_correction_reference(cos, 1.0, 1.5)
    assert bool((w.diff() > 0).all()) and float(w[-1]) == 1.0


def test_large_n_limit_closed_form():
    rs = [0.0, 1e-12, 1e-6, 1e-3, 0.01, 0.2, 1 / 3, 0.34, 0.7, 0.99, 1 - 1e-9]
    got = corr._bloch_average_limit(t64(rs))
    want = t64([0.5] + [_w_limit_mpmath(r) for r in rs[1:]])
    assert (got - want).abs().max() <= 1e-14
    # the reference with many cells converges to it
    c = t64([1.0, 0.6, 0.2])
    many = angular_correction_reference(c, 1.0, 1.6, cells=2000)
    assert (many - angular_correction_limit(c, 1.0, 1.6)).abs().max() <= 2e-6
    assert float(angular_correction_limit(t64(0.0), 1.0, 1.5)) == 1.0


def test_reference_is_roughly_invariant_to_cells():
    """Appendix B: 'w is roughly invariant to N for sufficiently large N'."""
    c = torch.cos(torch.deg2rad(torch.arange(0, 90, 10, dtype=F64)))[:, None]
    n2 = t64([1.1, 1.5, 2.5])
    w20 = angular_correction_reference(c, 1.0, n2, cells=20)
    for N in (10, 50, 100):
        assert (angular_correction_reference(c, 1.0, n2, cells=N) - w20).abs().max() <= 0.01
    assert (angular_correction_limit(c, 1.0, n2) - w20).abs().max() <= 0.01


# --- the Schlick approximation ---------------------------------------------------------------


def test_schlick_form():
    a, b = 0.6, 0.5
    r0 = ((1 - 1.7) / (1 + 1.7)) ** 2
    assert float(angular_correction(t64(1.0), 1.0, 1.7, coefficients=(a, b))) == pytest.approx(a * r0 + b, abs=1e-15)
    assert float(angular_correction(t64(0.0), 1.0, 1.7, coefficients=(a, b))) == 1.0
    c = t64(0.4)
    w0 = a * r0 + b
    want = w0 + (1 - w0) * 0.6**5
    assert float(angular_correction(c, 1.0, 1.7, coefficients=(a, b))) == pytest.approx(want, abs=1e-15)
    # named sets
    paper = angular_correction(c, 1.0, 1.7, coefficients="paper")
    assert float(paper) == float(angular_correction(c, 1.0, 1.7, coefficients=PAPER_COEFFICIENTS))
    assert float(angular_correction(c, 1.0, 1.7)) == float(angular_correction(c, 1.0, 1.7, coefficients="fitted"))
    assert float(angular_correction(c, 1.0, 1.7)) == float(angular_correction(c, 1.0, 1.7,
                                                                           coefficients=fitted_coefficients()))


def test_schlick_broadcasting_and_dtypes():
    c = torch.linspace(0, 1, 5, dtype=F64)[:, None]
    n2 = t64([1.2, 1.5, 2.0])
    w = angular_correction(c, 1.0, n2)
    assert w.shape == (5, 3) and w.dtype == F64
    w32 = angular_correction(c.float(), 1.0, n2.float())
    assert w32.dtype == torch.float32 and (w32.double() - w).abs().max() <= 1e-6
    coeffs = (t64([[0.5], [0.7]])[:, :, None], t64(0.53))  # a broadcasts as (2, 1, 1)
    assert angular_correction(c, 1.0, n2, coefficients=coeffs).shape == (2, 5, 3)
    r = angular_correction_reference(c.float(), 1.0, n2.float())
    assert r.dtype == torch.float32 and (r.double() - angular_correction_reference(c, 1.0, n2)).abs().max() <= 2e-5
    assert angular_correction_limit(c, 1.0, n2).shape == (5, 3)


def test_nan_propagates():
    c = t64([float("nan"), 0.5])
    assert torch.isnan(angular_correction(c, 1.0, 1.5)[0]) and not torch.isnan(angular_correction(c, 1.0, 1.5)[1])


def test_gradients():
    c = t64([0.2, 0.7]).requires_grad_()
    n2 = t64([1.3, 2.1]).requires_grad_()
    a = t64(0.6).requires_grad_()
    b = t64(0.53).requires_grad_()
    assert torch.autograd.gradcheck(lambda c, n2, a, b: angular_correction(c, 1.0, n2, coefficients=(a, b)),
                                    (c, n2, a, b))
    assert torch.autograd.gradcheck(lambda c, n2: angular_correction_reference(c, 1.0, n2, samples=16), (c, n2))
    assert torch.autograd.gradcheck(lambda c, n2: angular_correction_limit(c, 1.0, n2), (c, n2))
    # hard cases: grazing, normal, Brewster (p), same medium, total internal reflection, critical angle
    cb = 1 / math.sqrt(1 + 1.5**2)
    cases = [(0.0, 1.0, 1.5), (1.0, 1.0, 1.5), (cb, 1.0, 1.5), (0.5, 1.5, 1.5), (0.3, 1.5, 1.0),
             (math.sqrt(1 - (1 / 1.5) ** 2), 1.5, 1.0), (1e-6, 1.0, 1.5)]
    for cv, n1v, n2v in cases:
        for fn in (angular_correction, angular_correction_reference, angular_correction_limit):
            for pol in (("unpolarized", "p") if fn is not angular_correction else (None,)):
                x = t64(cv).requires_grad_()
                m1 = t64(n1v).requires_grad_()
                m2 = t64(n2v).requires_grad_()
                kw = {} if pol is None else {"polarization": pol}
                fn(x, m1, m2, **kw).backward()
                for g in (x.grad, m1.grad, m2.grad):
                    assert g is not None and bool(torch.isfinite(g).all()), (fn.__name__, cv, n1v, n2v, pol)


@pytest.mark.parametrize(
    "call,match",
    [
        (lambda: angular_correction(t64(1.5), 1.0, 1.5), "cos_theta"),
        (lambda: angular_correction(t64(0.5), -1.0, 1.5), "n1"),
        (lambda: angular_correction(t64(0.5), 1.0 + 0.1j, 1.5), "n1"),
        (lambda: angular_correction(t64(0.5), 1.0, 0.0), "n2"),
        (lambda: angular_correction(t64(0.5), 1.0, 1.5, coefficients="median"), "coefficients"),
        (lambda: angular_correction(t64(0.5), 1.0, 1.5, coefficients=(0.7,)), "coefficients"),
        (lambda: angular_correction(t64(0.5), 1.0, 1.5, coefficients=(float("nan"), 0.5)), "coefficients"),
        (lambda: angular_correction(t64(0.5), 1.0, 1.5, coefficients=(0.7, 0.5j)), "coefficients"),
        (lambda: angular_correction_reference(t64(-0.1), 1.0, 1.5), "cos_theta"),
        (lambda: angular_correction_reference(t64(0.5), 0.0, 1.5), "n1"),
        (lambda: angular_correction_reference(t64(0.5), 1.0, -2.0), "n2"),
        (lambda: angular_correction_reference(t64(0.5), 1.0, 1.5, cells=0), "cells"),
        (lambda: angular_correction_reference(t64(0.5), 1.0, 1.5, cells=2.5), "cells"),
        (lambda: angular_correction_reference(t64(0.5), 1.0, 1.5, samples=2), "samples"),
        (lambda: angular_correction_reference(t64(0.5), 1.0, 1.5, polarization="x"), "polarization"),
        (lambda: angular_correction_limit(t64(0.5), 1.0, 1.5, polarization="sp"), "polarization"),
    ],
)
def test_bad_input_raises(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_malformed_coefficients_file(tmp_path):
    bad = tmp_path / "w.json"
    bad.write_text(json.dumps({"format": "something else", "format_version": 1}))
    with pytest.raises(ValueError, match="format"):
        fitted_coefficients(bad)
    bad.write_text(json.dumps({"format": corr.FILE_FORMAT, "format_version": 1, "coefficients": {"a": 1.0}}))
    with pytest.raises(ValueError, match="coefficients"):
        fitted_coefficients(bad)
    with pytest.raises(FileNotFoundError):
        fitted_coefficients(tmp_path / "missing.json")


# --- the shipped fit -------------------------------------------------------------------------


def test_shipped_file_provenance():
    data = _shipped()
    prov = data["provenance"]
    assert data["format"] == corr.FILE_FORMAT and data["format_version"] == corr.FILE_FORMAT_VERSION
    assert (data["paper_coefficients"]["a"], data["paper_coefficients"]["b"]) == PAPER_COEFFICIENTS
    assert prov["reference"]["cells"] >= 10 and "R12(theta1)" in prov["reference"]["r12_reading"]
    assert prov["torchirid_version"] and prov["created"]
    fit = prov["fit"]
    assert fit["lstsq_check"]["max_diff"] <= 1e-8  # autograd optimum == closed-form least squares
    assert fit["errors"]["rms"] <= prov["paper_coefficient_errors"]["errors"]["rms"]  # the fit beats the paper's


def test_shipped_fit_reproduces_the_reference_to_its_reported_error():
    data = _shipped()
    prov = data["provenance"]
    ref = prov["reference"]
    table = data["reference_table"]
    angles = t64(table["angles_deg"])
    pairs = table["pairs_n1_n2"]
    w = t64(table["w"])
    a, b = fitted_coefficients()
    # the stored errors are those of the stored table
    n1 = t64([p[0] for p in pairs])[:, None]
    n2 = t64([p[1] for p in pairs])[:, None]
    cos = torch.cos(torch.deg2rad(angles)).clamp(0, 1)
    d = angular_correction(cos, n1, n2) - w
    assert float(d.abs().max()) == pytest.approx(prov["fit"]["errors"]["max_abs"], abs=1e-10)
    assert float(d.square().mean().sqrt()) == pytest.approx(prov["fit"]["errors"]["rms"], abs=1e-10)
    # recompute the reference on a subgrid: same values, and w̃ within the reported max error
    rows, cols = [0, len(pairs) // 2, len(pairs) - 1], slice(0, None, 11)
    sub = angular_correction_reference(cos[cols], n1[rows], n2[rows], cells=ref["cells"],
                                       samples=ref["samples_per_dip_interval"], polarization=ref["polarization"])
    assert (sub - w[rows][:, cols]).abs().max() <= 1e-11
    err = (angular_correction(cos[cols], n1[rows], n2[rows], coefficients=(a, b)) - sub).abs().max()
    assert float(err) <= prov["fit"]["errors"]["max_abs"] + 1e-12


def test_fit_is_reproducible():
    data = _shipped()
    table = data["reference_table"]
    a, b = fitted_coefficients()
    script = _script()
    pairs = [tuple(p) for p in table["pairs_n1_n2"]]
    angles = t64(table["angles_deg"])
    # the closed-form optimum on the stored table is the shipped (a, b)
    a_ls, b_ls = script.fit_lstsq(pairs, angles, t64(table["w"]))
    assert abs(a_ls - a) <= 1e-8 and abs(b_ls - b) <= 1e-8
    # an autograd fit on a small fresh grid lands close to the shipped coefficients
    small_pairs = [(1.0, 1.1), (1.0, 1.45), (1.0, 1.8), (1.0, 2.15), (1.0, 2.5), (1.33, 2.0)]
    small_angles = torch.arange(0.0, 90.0, 4.0, dtype=F64)
    ref = data["provenance"]["reference"]
    w = script.reference_table(small_pairs, small_angles, ref["cells"], ref["samples_per_dip_interval"],
                               ref["polarization"])
    fit = script.fit_autograd(small_pairs, small_angles, w)
    assert abs(fit["a"] - a) <= 0.03 and abs(fit["b"] - b) <= 0.005
    a2, b2 = script.fit_lstsq(small_pairs, small_angles, w)
    assert abs(fit["a"] - a2) <= 1e-7 and abs(fit["b"] - b2) <= 1e-7


def test_paper_coefficients_follow_from_the_paper_range():
    """The R12(θ1) reading reproduces the paper's (0.735, 0.532) when fitted over n2 ∈ [1.25, 1.75]."""
    script = _script()
    pairs = [(1.0, float(v)) for v in torch.linspace(1.25, 1.75, 6, dtype=F64)]
    angles = torch.arange(0.0, 90.0, 5.0, dtype=F64)
    w = script.reference_table(pairs, angles, 20, 64, "unpolarized")
    a, b = script.fit_lstsq(pairs, angles, w)
    assert abs(a - PAPER_COEFFICIENTS[0]) <= 0.03 and abs(b - PAPER_COEFFICIENTS[1]) <= 0.005


def test_script_end_to_end(tmp_path):
    out = tmp_path / "w.json"
    data = _script().main(["--angles", "10", "--n2-count", "4", "--extra-pairs", "1.33:2.0", "--eval-pairs", "",
                           "--invariance-cells", "20", "--json", str(out), "--no-figure", "--quiet"])
    loaded = fitted_coefficients(out)
    assert loaded == (data["coefficients"]["a"], data["coefficients"]["b"])
    assert not [p for p in os.listdir(tmp_path) if p.endswith(".tmp")]  # atomic write left no temp file


def test_reference_blocks_follow_the_chunk_knob():
    """The reference quadrature sums over blocks of dip intervals whose size (batch × nodes ×
    intervals) follows torchirid.options(chunk_size=...); None: every interval at once. The
    blocks split the sum, so the values agree to its rounding."""
    from block_sizes import largest_tensor

    c = torch.linspace(0.0, 1.0, 50, dtype=F64)
    call = lambda: angular_correction_reference(c, 1.0, 1.5, cells=20, samples=16)  # noqa: E731
    ref, whole = largest_tensor(call, None)
    got, block = largest_tensor(call, 1000)
    torch.testing.assert_close(got, ref, rtol=1e-15, atol=1e-15)
    assert whole >= 50 * 16 * 20  # one piece: batch × nodes × every interval
    assert block <= 1000
