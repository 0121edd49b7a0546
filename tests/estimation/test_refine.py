import math

import pytest
import torch

from torchirid.estimation import estimate_film, film_metrics, index_model, refine_film, synthetic_cube
from torchirid.estimation.measurement import band_reflectance_fast
from torchirid.estimation.gauss_newton import d_only_gauss_newton
from torchirid.estimation.gauss_newton import _smooth_terms, model_terms
from torchirid.estimation.residuals import residual_parts

F64 = torch.float64


def test_analytic_thickness_jacobian_matches_autograd():
    lam = torch.arange(400.0, 721.0, 16.0, dtype=F64)
    c = torch.cos(torch.deg2rad(torch.tensor([10.0, 45.0], dtype=F64)))
    terms = model_terms(torch.tensor([2.3, 0.04, 0.001], dtype=F64), "cauchy3", lam, c, 1.64, polarization="s")
    d = torch.tensor([[210.0, 777.0]], dtype=F64, requires_grad=True)
    y = torch.zeros(1, 2, lam.numel(), dtype=F64)
    r, Jd, _ = residual_parts(y, d, terms)
    auto = torch.autograd.grad(r.sum(), d)[0]
    assert torch.allclose(Jd.sum((-1, -2)), auto, rtol=1e-10, atol=1e-14)
    # and the model part is band_reflectance_fast
    R = band_reflectance_fast(tuple(t[:, None] for t in terms), d.detach().reshape(1, -1, 1, 1))
    assert torch.allclose(r[0].detach(), R, atol=1e-15)


def test_smoothness_gradient_matches_autograd():
    d = torch.rand(5, 6, dtype=F64, requires_grad=True)
    val, g, _ = _smooth_terms(d.detach(), 0.7)
    dx, dy = d[:, 1:] - d[:, :-1], d[1:] - d[:-1]
    auto = torch.autograd.grad(0.7 * ((dx ** 2).sum() + (dy ** 2).sum()), d)[0]
    expected = 0.7 * float(((dx ** 2).sum() + (dy ** 2).sum()).detach())
    assert torch.allclose(g, auto, atol=1e-13) and abs(float(val) - expected) < 1e-12


def test_refine_recovers_index_and_thickness_from_a_perturbed_start():
    cube = synthetic_cube("mgf2_400", height=10, width=10, seed=5, polarization="s")
    res = refine_film(cube.cube, cube.wavelength, cube.cos_theta, 1.64, cube.thickness + 8.0, 1.40, polarization="s")
    assert abs(float(res.params[0]) - 1.37) < 2e-3
    assert float((res.thickness - cube.thickness).abs().mean()) < 1.0
    assert all(b <= a * (1 + 1e-12) for a, b in zip(res.history, res.history[1:]))


def test_order_check_fixes_a_wrong_order():
    cube = synthetic_cube("mgf2_600", height=4, width=4, seed=1, gaussian_noise=0.002, shot_noise=0.002,
                          polarization="s")
    T = 560.0 / (2 * math.sqrt(1.37 ** 2 - 0.2))
    start = cube.thickness.clone()
    start[0, :] += T  # one row one order off
    res = refine_film(cube.cube, cube.wavelength, cube.cos_theta, 1.64, start, 1.37, fit_index=False, polarization="s")
    assert res.reordered >= 4
    assert float((res.thickness - cube.thickness).abs().max()) < 2.0


def test_d_only_gauss_newton_nan_candidates():
    cube = synthetic_cube("mgf2_400", height=1, width=3, gaussian_noise=0, shot_noise=0, polarization="s")
    terms = model_terms(torch.tensor([1.37], dtype=F64), "constant", cube.wavelength, cube.cos_theta, 1.64,
                        polarization="s")
    D = torch.stack([cube.thickness.reshape(-1) + 5, torch.full((3,), math.nan, dtype=F64)], -1)
    d, sse = d_only_gauss_newton(cube.clean.reshape(-1, 5, 81), D, terms)
    assert torch.isinf(sse[:, 1]).all() and torch.isnan(d[:, 1]).all()
    assert (d[:, 0] - cube.thickness.reshape(-1)).abs().max() < 0.05


@pytest.mark.parametrize("name,model", [("mgf2_400", "constant"), ("mgf2_600", "constant"), ("zns_500", "cauchy3")])
def test_bars_at_reduced_size(name, model):
    """The acceptance bars (1 % noise: |Δn| ≤ 0.01, mean |Δd| ≤ 5 nm) on 24 × 24 cubes."""
    cube = synthetic_cube(name, height=24, width=24, seed=0, polarization="s")
    est = estimate_film(cube.cube, cube.wavelength, cube.cos_theta, 1.64, index_model_name=model, sample=256,
                        polarization="s")
    m = film_metrics(est, cube)
    assert m["n_error"] <= 0.01
    assert m["d_error_mean"] <= 5.0
    assert m["delta_e_mean"] < 0.5 and m["rmse_mean"] < 0.005


def test_metrics_are_zero_for_the_truth():
    cube = synthetic_cube("zns_500", height=3, width=3, seed=0, polarization="s")
    from torchirid.estimation import FilmEstimate, fit_index_model

    lam = torch.linspace(380, 760, 200, dtype=F64)
    p = fit_index_model(lam, cube.sample.n_at(lam), "cauchy3")
    est = FilmEstimate(params=p, index_model="cauchy3", n=float(index_model(torch.tensor(589.3, dtype=F64), p, "cauchy3")),
                       thickness=cube.thickness, rms=torch.zeros(3, 3), n_peak=0.0, thickness_peak=cube.thickness,
                       settings=dict(bandwidth=4.0, passband="box", polarization="s", n_incident=1.0))
    m = film_metrics(est, cube)
    assert m["d_error_mean"] == 0 and m["n_error"] < 2e-3 and m["delta_e_mean"] < 0.1


def _check_progress(seen):
    """progress(done, total): non-decreasing int pairs, done <= total, ending at done == total."""
    assert seen and all(type(d) is int and type(t) is int and 0 <= d <= t for d, t in seen)
    assert all(a[0] <= b[0] and a[1] <= b[1] for a, b in zip(seen, seen[1:]))
    assert seen[-1][0] == seen[-1][1]


def test_refine_film_progress_counts_iterations_and_the_order_check():
    cube = synthetic_cube("mgf2_400", height=4, width=4, seed=1)
    d0 = torch.full((4, 4), 400.0, dtype=F64)
    seen = []
    res = refine_film(cube.cube, cube.wavelength, cube.cos_theta, 1.64, d0, 1.35, iterations=5,
                      progress=lambda d, t: seen.append((d, t)))
    _check_progress(seen)
    assert {t for _, t in seen} == {6}  # 5 iterations + the order check
    assert [d for d, _ in seen[:res.iterations]] == list(range(1, res.iterations + 1))
    seen.clear()
    refine_film(cube.cube, cube.wavelength, cube.cos_theta, 1.64, d0, 1.35, iterations=0, order_check=False,
                progress=lambda d, t: seen.append((d, t)))
    assert seen == [(0, 0)]


def test_estimate_film_progress_counts_stages():
    c = synthetic_cube("mgf2_400", height=2, width=2, seed=1)
    seen = []
    estimate_film(c.cube, c.wavelength, c.cos_theta, 1.64, index_model_name="constant", thickness_range=(300.0, 500.0),
                  iterations=2, final_iterations=1, progress=lambda d, t: seen.append((d, t)))
    _check_progress(seen)
    # peaks, index scan, 3 order hypotheses, order check, thickness, 1 final joint iteration
    assert seen == [(d, 8) for d in range(1, 9)]


def test_refine_errors():
    cube = synthetic_cube("mgf2_400", height=2, width=2)
    with pytest.raises(ValueError, match="progress"):
        refine_film(cube.cube, cube.wavelength, cube.cos_theta, 1.64, cube.thickness, 1.4, progress="bar")
    with pytest.raises(ValueError, match="progress"):
        estimate_film(cube.cube, cube.wavelength, cube.cos_theta, 1.64, progress=1)
    with pytest.raises(ValueError, match="index_model_name"):
        refine_film(cube.cube, cube.wavelength, cube.cos_theta, 1.64, cube.thickness, 1.4, index_model_name="drude")
    with pytest.raises(ValueError, match="thickness_init"):
        refine_film(cube.cube, cube.wavelength, cube.cos_theta, 1.64, torch.ones(3), 1.4)
    with pytest.raises(ValueError, match="smoothness"):
        refine_film(cube.cube, cube.wavelength, cube.cos_theta, 1.64, cube.thickness, 1.4, smoothness=-1.0)
    with pytest.raises(ValueError, match="cube"):
        estimate_film(torch.zeros(5, 81), cube.wavelength, cube.cos_theta, 1.64)


def test_dead_pixels_smoothness_and_float32():
    cube = synthetic_cube("mgf2_400", height=16, width=16, seed=3, polarization="s")
    y = cube.cube.clone()
    y[0, 0] = math.nan  # a dead pixel: every angle and band
    y[5, 5, 2, 10:20] = math.nan  # a few dropped samples
    est = estimate_film(y, cube.wavelength, cube.cos_theta, 1.64, sample=128, smoothness=1e-6, polarization="s")
    assert abs(est.n - 1.37) < 0.005
    err = (est.thickness - cube.thickness).abs()
    err[0, 0] = 0
    assert float(err.mean()) < 2.0 and float(err[5, 5]) < 2.0
    est32 = estimate_film(cube.cube.float(), cube.wavelength.float(), cube.cos_theta.float(), 1.64, sample=128,
                          polarization="s")
    assert est32.thickness.dtype == torch.float32
    assert abs(est32.n - 1.37) < 0.005 and float((est32.thickness.double() - cube.thickness).abs().mean()) < 2.0


@pytest.mark.parametrize("sample,model,kw", [
    ("mgf2_400", "constant", dict(gaussian_noise=0.05, shot_noise=0.05)),  # eq. 12 lands at ~1.9 here
    ("thin", "constant", {}),  # MgF2 150 nm: no extremum inside 400-720 nm at most angles
    ("thick_zns", "cauchy3", {}),  # ZnS 1200 nm: index slope and order trade off
])
def test_hard_cases(sample, model, kw):
    from torchirid.estimation import FilmSample
    from torchirid.estimation.dispersion import zns_index

    s = {"thin": FilmSample("thin", "MgF2 150 nm", 1.37, 150.0),
         "thick_zns": FilmSample("thick", "ZnS 1200 nm", zns_index, 1200.0)}.get(sample, sample)
    cube = synthetic_cube(s, height=16, width=16, seed=1, polarization="s", **kw)
    est = estimate_film(cube.cube, cube.wavelength, cube.cos_theta, 1.64, index_model_name=model, sample=256,
                        polarization="s")
    m = film_metrics(est, cube)
    assert m["n_error"] <= 0.01 and m["d_error_mean"] <= 5.0


def test_grid_scan_and_slope_scan_find_the_index():
    from torchirid.estimation.gauss_newton import grid_scan, scan_index

    cube = synthetic_cube("zns_500", height=4, width=4, seed=0, gaussian_noise=0.0, shot_noise=0.0, polarization="s")
    Y = cube.clean.reshape(-1, 5, 81)
    grid = torch.tensor([1.6, 2.0, 2.4, 2.8], dtype=F64)
    losses, d = grid_scan(Y, cube.wavelength, cube.cos_theta, 1.64, grid, polarization="s")
    assert int(losses.argmin()) == 2 and d.shape == (4, 16)
    p, dd, g, l = scan_index(Y, d[2], 2.4, cube.wavelength, cube.cos_theta, 1.64, rel_range=0.05, steps=11,
                             slopes=(0.0, 0.03, 0.06), polarization="s")
    assert p.shape == (2,) and g.shape == (33, 2) and float(p[1]) > 0  # ZnS needs a positive Cauchy slope


@pytest.mark.parametrize("model,theta", [("constant", [2.31]), ("cauchy", [2.25, 0.035]),
                                         ("cauchy3", [2.27, 0.024, 0.0035])])
@pytest.mark.parametrize("polarization", ["s", "unpolarized"])
def test_lm_jacobian_is_the_exact_jacobian_of_the_residual(model, theta, polarization):
    """The full Jacobian of an LM step (index parameters and every d) against torch.func.jacfwd
    of the residual r(θ, d) = band_reflectance_fast(terms(θ), d) − y, band-width term included."""
    from torchirid.estimation.gauss_newton import lm_jacobian

    lam = torch.arange(400.0, 721.0, 8.0, dtype=F64)
    c = torch.cos(torch.deg2rad(torch.tensor([10.0, 30.0, 50.0], dtype=F64)))
    th = torch.tensor(theta, dtype=F64)
    d = torch.tensor([180.0, 480.0, 530.0, 1210.0], dtype=F64)
    y = 0.05 + 0.02 * torch.rand(4, 3, lam.numel(), dtype=F64, generator=torch.Generator().manual_seed(0))
    kw = dict(bandwidth=6.0, polarization=polarization)

    def residual(t, dd):  # written from the public forward model, not from refine's internals
        terms = model_terms(t, model, lam, c, 1.64, **kw)
        return band_reflectance_fast(tuple(x[:, None] for x in terms), dd[:, None, None]) - y

    J_th, J_d = torch.func.jacfwd(residual, argnums=(0, 1))(th, d)  # (P, A, B, K), (P, A, B, P)
    terms = model_terms(th, model, lam, c, 1.64, **kw)
    dterms = torch.func.jacfwd(lambda t: model_terms(t, model, lam, c, 1.64, **kw))(th)
    r, Jd, Jt = lm_jacobian(y, d, terms, dterms)
    assert torch.allclose(r, residual(th, d), rtol=0, atol=1e-15)
    assert torch.allclose(Jt, J_th, rtol=1e-10, atol=1e-12 * float(J_th.abs().max()))
    eye = torch.eye(4, dtype=torch.bool)
    assert float(J_d.movedim(-1, 1)[~eye].abs().max()) == 0.0  # d_p only moves pixel p
    diag = torch.einsum("pabp->pab", J_d)
    assert torch.allclose(Jd, diag, rtol=1e-10, atol=1e-12 * float(diag.abs().max()))
    r0, Jd0, none = lm_jacobian(y, d, terms)  # thickness-only path (closed form)
    assert none is None and torch.allclose(Jd0, diag, rtol=1e-10, atol=1e-12 * float(diag.abs().max()))
    # the band-width term matters: dropping h changes the index Jacobian by more than the tolerance
    no_h = tuple(t if i < 4 else torch.zeros_like(t) for i, t in enumerate(dterms))
    _, _, Jt0 = lm_jacobian(y, d, terms, no_h)
    assert float((Jt0 - J_th).norm() / J_th.norm()) > 1e-6


def test_noise_level_matches_the_added_noise():
    from torchirid.estimation.noise import noise_level

    for name in ("mgf2_400", "zns_500"):
        cube = synthetic_cube(name, height=12, width=12, seed=4, gaussian_noise=0.01, shot_noise=0.0, polarization="s")
        true = float((cube.cube - cube.clean).std())
        assert abs(noise_level(cube.cube) - true) < 0.1 * true
    assert noise_level(torch.full((3, 7), math.nan, dtype=F64)) != noise_level(torch.zeros(3, 7))  # NaN: no data
    with pytest.raises(ValueError, match="5 bands"):
        noise_level(torch.zeros(3, 4))


def test_auto_index_model_picks_dispersion_for_zns_and_warns_for_a_constant_index():
    """Synthetic ZnS (Debenham dispersion, 500 nm, 1 % noise): the constant index fails far
    above the noise (n 2.41, ~110 nm off) and says so; "auto" picks a Cauchy model by BIC and meets the bars."""
    cube = synthetic_cube("zns_500", height=24, width=24, seed=0, polarization="s")
    with pytest.warns(RuntimeWarning, match="noise level"):
        bad = estimate_film(cube.cube, cube.wavelength, cube.cos_theta, 1.64, index_model_name="constant", sample=256,
                            polarization="s")
    assert bad.settings["residual_to_noise"] > 3 and film_metrics(bad, cube)["d_error_mean"] > 20
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        est = estimate_film(cube.cube, cube.wavelength, cube.cos_theta, 1.64, index_model_name="auto", sample=256,
                            polarization="s")
    sel = est.settings["index_selection"]
    assert set(sel) == {"constant", "cauchy", "cauchy3"} and est.settings["index_model_requested"] == "auto"
    assert est.index_model in ("cauchy", "cauchy3") and sel[est.index_model]["bic"] == min(v["bic"] for v in sel.values())
    assert est.settings["residual_to_noise"] < 1.5
    m = film_metrics(est, cube)
    assert m["n_error"] <= 0.01 and m["d_error_mean"] <= 5.0


def test_auto_index_model_keeps_a_constant_index_for_mgf2():
    cube = synthetic_cube("mgf2_600", height=16, width=16, seed=1, polarization="s")
    est = estimate_film(cube.cube, cube.wavelength, cube.cos_theta, 1.64, index_model_name="auto", sample=128,
                        polarization="s")
    assert est.index_model == "constant" and abs(est.n - 1.37) < 0.005
    with pytest.raises(ValueError, match="auto"):
        estimate_film(cube.cube, cube.wavelength, cube.cos_theta, 1.64, index_model_name="sellmeier")
