"""The piecewise-constant Bragg colour against the converged spectral colour (the accuracy bar)."""

import math

import numpy as np
import pytest
import torch

import torchirid as ti
from tensors import F64, t64
from torchirid.color import delta_e_2000, white_point_xyz, xyz_to_lab


def _errors(seed, count, **kw):
    rng = np.random.default_rng(seed)
    c = torch.cos(torch.deg2rad(torch.linspace(0, 89, 30, dtype=F64)))
    out = []
    for _ in range(count):
        n2, lam_, f, N = rng.uniform(1.2, 2.4), rng.uniform(150, 1000), rng.uniform(0.1, 0.9), int(rng.integers(10, 51))
        d1, d2 = f * lam_, (1 - f) * lam_
        ref = xyz_to_lab(ti.bragg_xyz(c, 1.0, n2, d1, d2, N))
        out.append(delta_e_2000(xyz_to_lab(ti.bragg_xyz(c, 1.0, n2, d1, d2, N, method="piecewise", **kw)), ref))
    return torch.cat(out).numpy()


@pytest.mark.filterwarnings(r"ignore:bragg_xyz\(method=.*fewer than:RuntimeWarning")  # paper grids, out-of-domain colours included
def test_default_piecewise_meets_the_bar():
    """Mirrors in n1, cells 10–50, Λ 150–1000 nm, 0–89°: median ΔE2000 ≤ 2, 95th pct ≤ 6
    (measured on this set: median 0.42, p95 1.5 with s = 8 and fringe-averaged weights)."""
    d = _errors(7, 30)
    assert np.median(d) <= 2 and np.percentile(d, 95) <= 6


@pytest.mark.filterwarnings(r"ignore:bragg_xyz\(method=.*fewer than:RuntimeWarning")  # paper grids, out-of-domain colours included
def test_published_weights_fall_short_of_the_bar():
    """The paper's weights (w̃·R^e, app. B) with its s = 3: measured median ~2.6, p95 ~5.9 —
    above the median bar; this is why the default uses fringe-averaged weights and s = 8."""
    d = _errors(7, 30, weights="paper", subdivisions=3)
    assert np.median(d) > 2


def test_grazing_is_white_and_shapes():
    c = t64([0.0, 0.5, 1.0])
    xyz = ti.bragg_xyz(c, 1.0, 1.5, 125.0, 375.0, 20, method="piecewise")
    assert xyz.shape == (3, 3)
    white = ti.bragg_xyz(t64(0.0), 1.0, 1.5, 125.0, 375.0, 20, method="sampled", samples=4001)
    assert (xyz[0] - white).abs().max() <= 1e-5
    assert abs(float(xyz[0, 1]) - 1.0) <= 1e-12
    N = torch.tensor([10, 40])[:, None]
    assert ti.bragg_xyz(c, 1.0, 1.5, 125.0, 375.0, N, method="piecewise").shape == (2, 3, 3)


def test_scope_errors():
    c = t64([0.5])
    with pytest.raises(ValueError, match="n_incident"):
        ti.bragg_xyz(c, 1.0, 1.5, 125.0, 375.0, 20, method="piecewise", n_incident=1.33)
    with pytest.raises(ValueError, match="propagating"):
        ti.bragg_xyz(t64([0.1]), 1.6, 1.2, 125.0, 375.0, 20, method="piecewise")
    with pytest.raises(ValueError, match="real"):
        ti.bragg_xyz(c, 1.0, torch.tensor(1.5 + 0.1j), 125.0, 375.0, 20, method="piecewise")
    with pytest.raises(ValueError, match="subdivisions"):
        ti.bragg_xyz(c, 1.0, 1.5, 125.0, 375.0, 20, method="piecewise", subdivisions=0)
    with pytest.raises(ValueError, match="weights"):
        ti.bragg_xyz(c, 1.0, 1.5, 125.0, 375.0, 20, method="piecewise", weights="exact")


def test_gradients_through_landmarks_match_finite_differences():
    """Landmark positions carry gradients (implicit-function theorem on their equations)."""
    c = t64([0.3, 0.8, 1.0])
    base = dict(n2=1.6, d1=130.0, d2=300.0)
    for name in ("n2", "d1", "d2"):
        p = t64(base[name]).requires_grad_()

        def f(v):
            kw = dict(base, **{name: v})
            return ti.bragg_xyz(c, 1.0, kw["n2"], kw["d1"], kw["d2"], 20, method="piecewise")

        (g,) = torch.autograd.grad(f(p).sum(), p)
        h = 1e-4 * max(1.0, abs(base[name]))
        fd = (f(p.detach() + h).sum() - f(p.detach() - h).sum()) / (2 * h)
        assert torch.isfinite(g) and abs(float(g) - float(fd)) <= 1e-3 * abs(float(fd)) + 1e-7


@pytest.mark.parametrize("pol", ["s", "p"])
def test_gap_weights_are_yehs_reflectance_inside_the_gaps(pol):
    # the gap branch of the closed form used for the gap boxes, against bragg_reflectance, from
    # the gap centre to within 1e-9 of its edges, for N = 20 … 10^6 (no overflow)
    from torchirid.spectral.landmarks import bragg_landmarks
    from torchirid.spectral.piecewise import _embedded_mirror, _gap_reflectance, _parts

    c, d1, d2 = t64(0.6), 130.0, 170.0
    mir = _embedded_mirror(c, 1.0, 1.5, d1, d2, 20, pol, (380.0, 780.0), "piecewise")
    A, B, delta, C_coef = mir["A"], mir["B"], mir["delta"][0], mir["C_coef"][0]
    L = bragg_landmarks(2 * math.pi / 780, 2 * math.pi / 380, A, B, delta)
    ok = ~torch.isnan(L["modes"]) & (L["edges_hi"] - L["edges_lo"] > 0)
    lo, hi = L["edges_lo"][ok][0], L["edges_hi"][ok][0]
    f = t64([1e-9, 1e-4, 0.1, 0.5, 0.9, 1 - 1e-4, 1 - 1e-9])
    w = lo + f * (hi - lo)
    omx, opx, sin_b = _parts(w, A, B, delta)
    for N in (20, 1000, 10 ** 6):
        got = _gap_reflectance(C_coef * sin_b ** 2, torch.minimum(omx, opx), t64(float(N)))
        ref = ti.bragg_reflectance(2 * math.pi / w, c, 1.0, 1.5, d1, d2, N, polarization=pol)
        assert torch.allclose(got, ref, rtol=1e-9, atol=1e-12)
