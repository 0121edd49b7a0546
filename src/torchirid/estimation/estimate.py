r"""The whole estimate: peak method → index scan → global order test → joint refinement.

:func:`estimate_film` chains, for a cube ``(*, A, B)``:

1. :func:`~torchirid.estimation.peak_method` — Kobayashi et al. eq. 8–14: a robust n and a
   per-pixel d (eq. 14 over the admissible orders, scored on a decimated cube);
2. on a seeded pixel sample (512), on a decimated cube (3 angles, every 3rd band):
   :func:`~torchirid.estimation.refine.scan_index`, the best constant n within ±15 % of
   eq. 12's (eq. 12 is biased for a dispersive film: the paper's ZnS came out 2.674 for
   2.37), checked against an exhaustive (n, d) search on 128 pixels
   (:func:`~torchirid.estimation.refine.grid_scan`) — when the peaks mislead (noise, films
   with no extremum in range), the search restarts from the grid's best n;
   for a dispersive model a second scan over (n(λ_mid), Cauchy slope B);
3. on the same sample, the joint fit of the index model from the three global orders
   d, d ± T (T = λ/(2√(n² − sin²θ))), keeping the lowest misfit — a dispersive index and
   a shifted order can otherwise explain the same peaks;
4. on the whole image: d at that index from the three nearest orders (batched Gauss–Newton
   on the decimated cube), an exhaustive thickness search for the pixels whose misfit stays
   above 3× the sample's (all pixels when step 2 restarted), a polish on the full cube, then
   ``final_iterations`` joint Levenberg–Marquardt iterations on every pixel
   (:func:`~torchirid.estimation.refine_film`, with the optional smoothness term).

``index_model_name="auto"`` runs stage 3 for every model of
:data:`~torchirid.estimation.INDEX_MODELS` on the sample (stage 2 and the dispersive scan are
shared) and keeps the one of least Bayesian information criterion over the sample's N
samples, BIC = N ln(SSE/N) + K ln N (the per-pixel thicknesses are common to all models and
cancel): a dispersive film such as ZnS then gets a Cauchy model, a non-dispersive one keeps
the constant index unless dispersion pays for its parameters.

After the fit the per-pixel RMS residual is compared with the noise level of the data
(:func:`noise_level`); a median ratio above ``NOISE_WARNING_RATIO`` warns (``RuntimeWarning``)
— the model does not explain the data (wrong index model, absorbing film, wrong substrate or
angles).

:func:`film_metrics` scores an estimate against a synthetic truth as in Table 1 (n error,
mean |d error|, mean ΔE*ab over angles under D65 / CIE 1931 2°, spectral RMSE).
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, field

import torch

from .. import _checks
from ..color import delta_e_1976, spectrum_to_xyz, xyz_to_lab
from .dispersion import INDEX_MODELS, REFERENCE_WAVELENGTH, index_model
from .measurement import band_terms, band_reflectance_fast
from .peaks import peak_method
from .refine import d_only_gauss_newton, grid_scan, model_terms, refine_film, scan_index

__all__ = ["INDEX_CHOICES", "NOISE_WARNING_RATIO", "FilmEstimate", "estimate_film", "film_metrics", "model_cube",
           "noise_level"]

INDEX_CHOICES = ("auto",) + tuple(INDEX_MODELS)  # what estimate_film / fit-film accept
NOISE_WARNING_RATIO = 3.0  # median RMS residual / noise level above which estimate_film warns


@dataclass
class FilmEstimate:
    """Result of :func:`estimate_film`.

    params ``(K,)`` of ``index_model``; n: the index at 589.3 nm; thickness ``(*)`` nm;
    rms ``(*)`` per-pixel RMS residual (reflectance); n_peak / thickness_peak: the peak
    method's estimates (eq. 12–14); timings: seconds per stage.
    """

    params: torch.Tensor
    index_model: str
    n: float
    thickness: torch.Tensor
    rms: torch.Tensor
    n_peak: float
    thickness_peak: torch.Tensor
    timings: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)

    def index(self, wavelength) -> torch.Tensor:
        """n(λ) of the estimate (λ in nm)."""
        return index_model(torch.as_tensor(wavelength, dtype=self.params.dtype), self.params, self.index_model)


def _sse_at(cube, d, terms):
    from .peaks import cube_sse

    return cube_sse(cube, terms, d).sum()


def noise_level(cube) -> float:
    r"""Noise standard deviation of a cube ``(*, B)`` estimated from its spectra (reflectance units).

    The 4th difference along the bands, Δ⁴y_b = y_{b−2} − 4y_{b−1} + 6y_b − 4y_{b+1} + y_{b+2},
    multiplies white noise of standard deviation σ by √70 and a smooth spectrum of fringe
    period T bands by (2 sin(π/T))⁴ (≈ 0.01 at T = 20 bands): so σ̂ = 1.4826 · median|Δ⁴y| / √70
    (the MAD, robust to outliers and peaks). An upper bound when the fringes are only a few
    bands wide. NaN samples are skipped; NaN when no 5 consecutive finite bands exist.

    Example (white noise of σ = 0.01 on a smooth spectrum):
        >>> import torch
        >>> g = torch.Generator().manual_seed(0)
        >>> lam = torch.linspace(400, 720, 81, dtype=torch.float64)
        >>> y = 0.1 + 0.05 * torch.cos(lam / 30) + 0.01 * torch.randn(200, 81, generator=g, dtype=torch.float64)
        >>> round(noise_level(y), 3)
        0.01
    """
    y = torch.as_tensor(cube)
    if y.ndim < 1 or y.shape[-1] < 5:
        raise ValueError(f"cube must have at least 5 bands on its last axis; got shape {tuple(y.shape)}")
    y = y.to(torch.float64) if not y.is_floating_point() else y
    d4 = y[..., :-4] - 4 * y[..., 1:-3] + 6 * y[..., 2:-2] - 4 * y[..., 3:-1] + y[..., 4:]
    d4 = d4[~d4.isnan()]
    if d4.numel() == 0:
        return math.nan
    return float(1.482602218505602 * d4.abs().median() / math.sqrt(70.0))


@_checks.fits_with_autograd  # (autograd inside: a caller's inference mode must not switch it off)
def estimate_film(cube, wavelength, cos_theta, n_substrate, *, index_model_name: str = "constant", bandwidth=4.0,
                  passband: str = "box", polarization: str = "s", n_incident=1.0, n_range=(1.2, 3.5),
                  thickness_range=(20.0, 2000.0), smoothness: float = 0.0, sample: int = 512,
                  iterations: int = 10, final_iterations: int = 2, seed: int = 0, progress=None) -> FilmEstimate:
    """Film index (shared) and per-pixel thickness from a cube (module docstring).

    Args:
        cube: ``(*, A, B)`` band reflectance (e.g. ``(H, W, A, B)``), angles sorted by increasing θ.
        wavelength: ``(B,)`` uniformly spaced band centres (nm); cos_theta ``(A,)``.
        n_substrate: real substrate index (known, as in the paper: PET 1.64).
        index_model_name: ``"constant"``, a dispersive ``"cauchy"`` / ``"cauchy3"``, or ``"auto"``
            (the model of least BIC on the sample, module docstring; ~1.5× the index stage).
        bandwidth, passband: the camera's band model.
        sample: pixels used for the index search (stages 2–3).
        final_iterations: joint iterations on the full image (0: index from the sample only).
        progress: optional callable ``progress(stage_name)``.

    Returns:
        :class:`FilmEstimate`.
    """
    if index_model_name not in INDEX_CHOICES:
        raise ValueError(f"index_model_name must be one of {_checks.names(INDEX_CHOICES)}; got {index_model_name!r}")
    requested = index_model_name
    y = torch.as_tensor(cube)
    if y.ndim < 3:
        raise ValueError(f"cube must have shape (*, A, B) with at least one pixel axis; got {tuple(y.shape)}")
    y = y.to(torch.float64) if not y.is_floating_point() else y
    dtype = y.dtype
    batch = y.shape[:-2]
    A, B = y.shape[-2:]
    lam = torch.as_tensor(wavelength, dtype=dtype)
    c = torch.as_tensor(cos_theta, dtype=dtype).reshape(-1)
    if lam.shape != (B,) or c.shape != (A,):
        raise ValueError(f"wavelength must have {B} values and cos_theta {A} for a cube of shape {tuple(y.shape)}")
    ns = float(n_substrate)
    kw = dict(bandwidth=bandwidth, passband=passband, polarization=polarization, n_incident=n_incident)
    step = progress if progress is not None else (lambda name: None)

    def terms_for(n, lam_, c_):
        return band_terms(lam_, c_[:, None], n, ns, **kw)

    times = {}
    t0 = time.perf_counter()
    pk = peak_method(y, lam, c, ns, n_range=n_range, thickness_range=thickness_range, **kw)
    times["peaks"] = time.perf_counter() - t0
    step("peaks")
    Y = y.reshape(-1, A, B)
    P = Y.shape[0]
    d_peak = pk.thickness.reshape(-1)
    if bool(d_peak.isnan().any()):  # pixels without data (NaN from peak_method): a finite seed inside
        fill = d_peak.nanmedian() if bool((~d_peak.isnan()).any()) else torch.tensor(float(thickness_range[0]), dtype=dtype)
        d_peak = torch.where(d_peak.isnan(), fill, d_peak)  # (their estimate is set to NaN at the end)
    # 2. index scan on a seeded sample
    t1 = time.perf_counter()
    g = torch.Generator().manual_seed(int(seed))
    idx = torch.randperm(P, generator=g)[: min(P, sample)]
    ys, ds = Y[idx], d_peak[idx]
    a_sel = sorted({0, A // 2, A - 1})  # decimated cube for the scans: 3 angles, every 3rd band
    b_sel = list(range(0, B, 3))
    yd = ys[:, a_sel][:, :, b_sel]
    p_scan, d_scan, _, _ = scan_index(yd, ds, pk.n, lam[b_sel], c[a_sel], ns, **kw)
    n_scan = float(p_scan[0])
    # the peaks may mislead (noise, too few extrema, dispersion): an exhaustive (n, d) search on a
    # smaller sample settles which of the two to trust, then a fine scan around the winner
    few = yd[: min(yd.shape[0], 128)]
    n_grid = torch.exp(torch.linspace(math.log(n_range[0]), math.log(n_range[1]), 32, dtype=dtype))
    g_loss, _ = grid_scan(few, lam[b_sel], c[a_sel], ns, n_grid, thickness_range=thickness_range, **kw)
    d_few, _ = d_only_gauss_newton(few, d_scan[: few.shape[0], None], terms_for(n_scan, lam[b_sel], c[a_sel]),
                                   iterations=2)
    n_best_grid = float(n_grid[g_loss.argmin()])
    peak_loss = float(_sse_at(few, d_few, terms_for(n_scan, lam[b_sel], c[a_sel])))
    if float(g_loss.min()) < 0.8 * peak_loss:  # the peak-based start is clearly worse: restart from the grid
        fine = n_best_grid * torch.linspace(0.95, 1.05, 11, dtype=dtype)
        f_loss, f_d = grid_scan(yd, lam[b_sel], c[a_sel], ns, fine, thickness_range=thickness_range, **kw)
        n_scan, d_scan = float(fine[f_loss.argmin()]), f_d[f_loss.argmin()]
        restarted = True
    else:
        restarted = False
    step("index scan")
    s2 = (float(n_incident) ** 2) * (1 - c * c)
    lam_mid = float(lam.median())

    def period(n):
        return lam_mid / (2 * float(torch.sqrt(n * n - s2).mean()))

    candidates = tuple(INDEX_MODELS) if index_model_name == "auto" else (index_model_name,)
    n_obs = int((~ys.isnan()).sum())  # samples in the BIC (NaN samples do not count)
    slope_scan = None
    selection = {}
    for model in candidates:
        K = INDEX_MODELS[model]
        theta0, d_start, n_start = torch.tensor([n_scan], dtype=dtype), d_scan, n_scan
        if K > 1:
            # dispersive model: a second scan over (n(λ_mid), dn/d(1/λ²)) around the constant index;
            # a thick dispersive film otherwise falls into a wrong (index slope, order) pair
            if slope_scan is None:  # shared by the Cauchy models
                slope_scan = scan_index(yd, d_scan, n_scan, lam[b_sel], c[a_sel], ns, rel_range=0.05, steps=11,
                                        slopes=tuple(0.015 * i for i in range(7)), **kw)[:2]
            p2, d_start = slope_scan
            theta0 = torch.cat([p2, torch.zeros(K - 2, dtype=dtype)])
            n_start = float(index_model(torch.tensor(lam_mid, dtype=dtype), theta0, model))
        # 3. global order hypotheses with the full index model
        best_m = None
        T = period(n_start)
        for j in (0.0, -1.0, 1.0):
            start = d_start + j * T
            if bool((start <= 0).any()):
                continue
            res = refine_film(ys, lam, c, ns, start, theta0, index_model_name=model, iterations=iterations, **kw)
            loss = float(res.sse.sum())
            if best_m is None or loss < best_m[0]:
                best_m = (loss, res)
            step("order hypothesis")
        sse_m = max(best_m[0], torch.finfo(dtype).tiny)
        bic = n_obs * math.log(sse_m / max(n_obs, 1)) + K * math.log(max(n_obs, 2))
        selection[model] = dict(sse=best_m[0], bic=bic, params=best_m[1].params.tolist(), result=best_m)
    index_model_name = min(selection, key=lambda m: selection[m]["bic"])
    best = selection[index_model_name].pop("result")
    for v in selection.values():
        v.pop("result", None)
    theta = best[1].params
    times["index"] = time.perf_counter() - t1
    # 4. full image: d at that index from the three nearest orders, then joint polish
    t2 = time.perf_counter()
    n_mid = float(index_model(torch.tensor(lam_mid, dtype=dtype), theta, index_model_name))
    scale = float(torch.sqrt(pk.n ** 2 - s2).mean()) / float(torch.sqrt(n_mid ** 2 - s2).mean())
    Tm = period(n_mid)
    D = (d_peak * scale)[:, None] + Tm * torch.tensor([-1.0, 0.0, 1.0], dtype=dtype)
    D = torch.where(D > 0, D, torch.full_like(D, math.nan))
    # the order: 3 candidates polished on the decimated cube, then the winner on the full cube
    terms_s = model_terms(theta, index_model_name, lam[b_sel], c[a_sel], ns, **kw)
    Dn, S = d_only_gauss_newton(Y[:, a_sel][:, :, b_sel], D, terms_s, iterations=2)
    d0 = Dn.gather(-1, S.argmin(-1, keepdim=True))
    s0 = S.min(-1).values
    # pixels with no good order among the peak-based candidates (misfit well above what the
    # sample reached at the fitted index) get an exhaustive search; all of them when the
    # peaks misled the index search (index_start == "grid")
    ref = float(_sse_at(yd, best[1].thickness[:, None], terms_s) / yd.shape[0])
    bad = (s0 > 3 * ref) | torch.full_like(s0, float(restarted), dtype=torch.bool)
    if bool(bad.any()):
        from .peaks import cube_sse

        lo, hi = map(float, thickness_range)
        gstep = float(lam.min()) / (8 * float(torch.sqrt(n_mid ** 2 - s2).max()))
        grid = torch.arange(lo, hi + gstep, gstep, dtype=dtype)
        terms_b = model_terms(theta, index_model_name, lam, c[a_sel], ns, **kw)  # every band: no fringe aliasing
        yb = Y[bad][:, a_sel]
        sg = cube_sse(yb, terms_b, grid.expand(int(bad.sum()), -1))
        db, sb = d_only_gauss_newton(yb, grid[sg.argmin(-1)][:, None], terms_b, iterations=2, max_step=gstep)
        s_old = cube_sse(yb, terms_b, d0[bad])
        d0[bad] = torch.where(sb < s_old, db, d0[bad])
    step("order check")
    terms = model_terms(theta, index_model_name, lam, c, ns, **kw)
    d, S = d_only_gauss_newton(Y, d0, terms, iterations=2)
    d = d[:, 0]
    step("thickness")
    if final_iterations > 0 or smoothness > 0:
        res = refine_film(y, lam, c, ns, d.reshape(batch), theta, index_model_name=index_model_name,
                          iterations=max(final_iterations, 1), smoothness=smoothness, order_check=False,
                          fit_index=final_iterations > 0, progress=progress, **kw)
        theta, d, sse = res.params, res.thickness.reshape(-1), res.sse.reshape(-1)
    else:
        sse = S[:, 0]
    times["thickness"] = time.perf_counter() - t2
    times["total"] = time.perf_counter() - t0
    n_ref = float(index_model(torch.tensor(REFERENCE_WAVELENGTH, dtype=dtype), theta, index_model_name))
    rms = (sse / (A * B)).sqrt()
    empty = Y.isnan().all(-1).all(-1)  # no finite sample: no estimate (its residuals were 0 by the NaN fill)
    d, rms = torch.where(empty, math.nan, d), torch.where(empty, math.nan, rms)
    sigma = noise_level(Y)
    ratio = float(rms[rms.isfinite()].median()) / sigma if sigma > 0 else math.inf
    if ratio > NOISE_WARNING_RATIO:
        warnings.warn(f"estimate_film: the median RMS residual is {ratio:.1f}x the noise level of the data "
                      f"({sigma:.2g}); the {index_model_name!r} index model does not explain the cube — try "
                      f"index_model_name='auto' or 'cauchy3' (dispersive film), or check the substrate index, "
                      f"angles and polarization", RuntimeWarning, stacklevel=2)
    return FilmEstimate(params=theta, index_model=index_model_name, n=n_ref, thickness=d.reshape(batch),
                        rms=rms.reshape(batch), n_peak=pk.n, thickness_peak=pk.thickness,
                        timings=times, settings=dict(kw, n_substrate=ns, index_model=index_model_name, index_start='grid' if restarted else 'peaks',
                                                     index_model_requested=requested, index_selection=selection,
                                                     noise_level=sigma, residual_to_noise=ratio,
                                                     exhaustive_pixels=int(bad.sum()),
                                                     smoothness=smoothness, sample=sample, seed=seed))


def model_cube(params, index_model_name, thickness, wavelength, cos_theta, n_substrate, **kw) -> torch.Tensor:
    """Noise-free band reflectance ``(*, A, B)`` of an estimate (fast band model), for the metrics."""
    lam = torch.as_tensor(wavelength, dtype=torch.as_tensor(thickness).dtype)
    terms = model_terms(params, index_model_name, lam, torch.as_tensor(cos_theta, dtype=lam.dtype), float(n_substrate), **kw)
    d = torch.as_tensor(thickness)
    # the polarization axis leads the terms: pixels go after it, angles and bands last
    R = band_reflectance_fast(tuple(t[:, None] for t in terms), d.reshape(1, -1, 1, 1))
    return R.reshape(*d.shape, *R.shape[-2:])


def film_metrics(estimate: FilmEstimate, truth) -> dict:
    """Table-1 metrics of an estimate against a :class:`~torchirid.estimation.SyntheticCube`.

    n error at 589.3 nm; mean and max |d error| (nm); mean ΔE*ab (CIE 1976, D65, CIE 1931 2°)
    between the true noise-free band spectra and the re-rendered estimate, averaged over
    pixels and angles; spectral RMSE (reflectance units) averaged the same way.
    """
    kw = {k: estimate.settings[k] for k in ("bandwidth", "passband", "polarization", "n_incident")}
    est = model_cube(estimate.params, estimate.index_model, estimate.thickness, truth.wavelength, truth.cos_theta,
                     truth.sample.n_substrate, **kw)
    lab_t = xyz_to_lab(spectrum_to_xyz(truth.clean, truth.wavelength))
    lab_e = xyz_to_lab(spectrum_to_xyz(est, truth.wavelength))
    de = delta_e_1976(lab_t, lab_e)
    rmse = ((est - truth.clean) ** 2).mean(-1).sqrt()
    err = (estimate.thickness - truth.thickness).abs()
    return {
        "n_true": truth.sample.n_reference,
        "n_est": estimate.n,
        "n_error": abs(estimate.n - truth.sample.n_reference),
        "n_peak": estimate.n_peak,
        "d_true_mean": float(truth.thickness.mean()),
        "d_est_mean": float(estimate.thickness.mean()),
        "d_error_mean": float(err.mean()),
        "d_error_max": float(err.max()),
        "d_error_peak_mean": float((estimate.thickness_peak - truth.thickness).abs().mean()),
        "delta_e_mean": float(de.mean()),
        "rmse_mean": float(rmse.mean()),
        "time_s": float(estimate.timings.get("total", math.nan)),
    }
