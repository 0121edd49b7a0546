r"""The whole estimate: peak method → index scan → global order test → joint refinement.

:func:`estimate_film` chains, for a cube ``(*, A, B)``:

1. ``peak_method()`` — Kobayashi et al. eq. 8–14: a robust n and a
   per-pixel d (eq. 14 over the admissible orders, scored on a decimated cube);
2. on a seeded pixel sample (``sample``, 512), on a decimated cube (3 angles, every 3rd band):
   :func:`~torchirid.estimation.gauss_newton.scan_index`, the best constant n within ±15 % of
   eq. 12's (eq. 12 is biased for a dispersive film: the paper's ZnS came out 2.674 for
   2.37), checked against an exhaustive (n, d) search on 128 pixels
   (:func:`~torchirid.estimation.gauss_newton.grid_scan`) — when the peaks mislead (noise, films
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

**Missing data.** A non-finite sample (NaN — :func:`~torchirid.estimation.read_cube` turns an
ENVI header's ``data ignore value`` into NaN — or ±inf) is missing: it is left out of every sum.
A pixel without a single finite sample (a dead pixel) is *invalid*: it is dropped before stage 1,
so it enters no score (peaks, index scan and grid check, BIC, order hypotheses, noise level,
thickness search, final pass, :func:`film_metrics`), and the result reports it —
``FilmEstimate.valid`` is False there and its thickness and RMS are NaN. A pixel with only some
samples missing stays valid and is fitted from the rest; its RMS residual is taken over its
finite samples. The pixel sample of stages 2–3 is the one of the same cube without the invalid
pixels (the seeded permutation of every pixel, invalid ones skipped), so a few dead pixels leave
the estimate unchanged. A cube with no valid pixel raises ``ValueError`` naming ``cube``.

In the code each stage is a private function (:func:`_validate_inputs`, :func:`_peak_stage`,
:func:`_index_scan`, :func:`_select_index_model`, :func:`_image_thickness`,
:func:`_order_check`, :func:`_final_pass`, :func:`_noise_check`); the numbers above are the
module-level constants (``SCAN_*``, ``GRID_CHECK_*``, ``RESTART_RATIO``, ...), each with the
reason for its value. dtype and device follow the cube, wavelength and cos_theta.

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
from ._validation import (band_settings, cube_axes, real_index, sorted_angles, tensor, uniform_bands, value_range,
                          weight)
from .dispersion import INDEX_MODELS, REFERENCE_WAVELENGTH, index_model
from .measurement import band_reflectance_fast, band_terms
from .peaks import peak_method
from .refine import refine_film
from .gauss_newton import POLISH_ITERATIONS, d_only_gauss_newton, grid_scan, model_terms, scan_index
from .residuals import THICKNESS_GRID_DIVISOR, cube_sse, decimation, order_candidates, thickness_grid

__all__ = ["FilmEstimate",
           "estimate_film", "film_metrics", "model_cube", "noise_level"]

INDEX_CHOICES = ("auto",) + tuple(INDEX_MODELS)  # what estimate_film / fit-film accept
NOISE_WARNING_RATIO = 3.0  # median RMS residual / noise level above which estimate_film warns
DECIMATION_STRIDE = 3  # index stages: every 3rd band of the first, middle, last angles (~8x cheaper, orders distinct)
SCAN_REL_RANGE = 0.15  # the index scan spans n_peak ± 15 %: the paper's ZnS eq. 12 bias was +13 %
GRID_CHECK_PIXELS = 128  # sample pixels in the exhaustive (n, d) check: enough to expose a wrong n; cost ∝ pixels
GRID_CHECK_INDICES = 32  # log-spaced constant indices over n_range in that check (3.5 % apart for 1.2–3.5)
RESTART_RATIO = 0.8  # restart from the grid when its misfit is below 0.8x the peaks' start: clearly better, not noise
FINE_SCAN_REL_RANGE = 0.05  # after a restart, n_grid ± 5 %: covers the ±1.75 % half-spacing of the check's grid
FINE_SCAN_STEPS = 11  # 1 % steps over that range; the joint fit then converges from the nearest
SLOPE_SCAN_REL_RANGE = 0.05  # dispersive scan: n(λ_mid) within ± 5 % of the constant index found
SLOPE_SCAN_STEPS = 11  # 1 % steps for n(λ_mid) in the dispersive scan
SLOPE_SCAN_SLOPES = tuple(0.015 * i for i in range(7))  # Cauchy B (µm²) 0–0.09 by 0.015: ZnS's B ≈ 0.06 inside
ORDER_SHIFTS = (0.0, -1.0, 1.0)  # stage 3's global order hypotheses d + jT; the peaks' order first (it wins ties)
EXHAUSTIVE_MISFIT_RATIO = 3.0  # pixels above 3x the sample's mean misfit get the exhaustive thickness search
MAD_TO_SIGMA = 1.482602218505602  # σ of a Gaussian per unit median absolute deviation, 1/Φ⁻¹(3/4)
DIFF4_NOISE_GAIN = 70.0  # the 4th difference multiplies white-noise variance by 1² + 4² + 6² + 4² + 1² = 70


@dataclass
class FilmEstimate:
    """Result of :func:`estimate_film`.

    params ``(K,)`` of ``index_model``; n: the index at 589.3 nm; thickness ``(*)`` nm;
    rms ``(*)`` per-pixel RMS residual (reflectance) over the pixel's finite samples; n_peak /
    thickness_peak: the peak method's estimates (eq. 12–14); timings: seconds per stage;
    valid ``(*)`` bool: the pixels with at least one finite sample — thickness, rms and
    thickness_peak are NaN elsewhere (dead pixels, module docstring); None (an estimate built
    by hand) means the pixels of finite thickness.

    Example (the estimate of a 2 × 2 pixel synthetic MgF₂ cube, n = 1.37; few iterations, for speed):
        >>> from torchirid.estimation import synthetic_cube
        >>> c = synthetic_cube("mgf2_400", height=2, width=2, seed=1)
        >>> est = estimate_film(c.cube, c.wavelength, c.cos_theta, 1.64, thickness_range=(300.0, 500.0),
        ...                     iterations=2, final_iterations=0)
        >>> est.index_model, round(est.n, 2), tuple(est.thickness.shape), bool(est.valid_pixels().all())
        ('constant', 1.37, (2, 2), True)
        >>> round(float(est.index(550.0)), 2), bool(est.rms.max() < 0.002)  # n at 550 nm; RMS ≈ the 1 % noise
        (1.37, True)
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
    valid: torch.Tensor | None = None

    def valid_pixels(self) -> torch.Tensor:
        """``(*)`` bool: :attr:`valid`, or where it is None the pixels of finite thickness."""
        return self.valid if self.valid is not None else self.thickness.isfinite()

    def index(self, wavelength) -> torch.Tensor:
        """n(λ) of the estimate (λ in nm)."""
        lam = torch.as_tensor(wavelength, dtype=self.params.dtype, device=self.params.device)
        return index_model(lam, self.params, self.index_model)


def noise_level(cube) -> float:
    r"""Noise standard deviation of a cube ``(*, B)`` estimated from its spectra (reflectance units).

    The 4th difference along the bands, Δ⁴y_b = y_{b−2} − 4y_{b−1} + 6y_b − 4y_{b+1} + y_{b+2},
    multiplies white noise of standard deviation σ by √70 and a smooth spectrum of fringe
    period T bands by (2 sin(π/T))⁴ (≈ 0.01 at T = 20 bands): so σ̂ = 1.4826 · median|Δ⁴y| / √70
    (the MAD, robust to outliers and peaks). An upper bound when the fringes are only a few
    bands wide. Non-finite samples (NaN, ±inf: missing data) are skipped; NaN when no 5
    consecutive finite bands exist.

    Example (white noise of σ = 0.01 on a smooth spectrum):
        >>> import torch
        >>> g = torch.Generator().manual_seed(0)
        >>> lam = torch.linspace(400, 720, 81, dtype=torch.float64)
        >>> y = 0.1 + 0.05 * torch.cos(lam / 30) + 0.01 * torch.randn(200, 81, generator=g, dtype=torch.float64)
        >>> round(noise_level(y), 3)
        0.01
    """
    y = tensor(cube)
    if y.ndim < 1 or y.shape[-1] < 5:
        raise ValueError(f"cube must have at least 5 bands on its last axis; got shape {tuple(y.shape)}")
    y = y.to(torch.float64) if not y.is_floating_point() else y
    d4 = y[..., :-4] - 4 * y[..., 1:-3] + 6 * y[..., 2:-2] - 4 * y[..., 3:-1] + y[..., 4:]
    d4 = d4[d4.isfinite()]  # (a missing sample spoils the five differences that contain it)
    if d4.numel() == 0:
        return math.nan
    return float(MAD_TO_SIGMA * d4.abs().median() / math.sqrt(DIFF4_NOISE_GAIN))


@dataclass
class _Setup:
    """A validated estimate_film problem: the cube ``y`` ``(*, A, B)`` (non-finite samples → NaN),
    its valid-pixel mask ``valid`` ``(P,)`` over all P pixels, the valid pixels ``Y`` ``(V, A, B)``
    (missing samples NaN) and their finite-sample counts ``count`` ``(V,)``, the axes, the band model
    ``band`` and the decimation ``a_sel``/``b_sel``. Every stage works on ``Y``: the invalid pixels
    enter no sum."""

    y: torch.Tensor
    valid: torch.Tensor
    Y: torch.Tensor
    count: torch.Tensor
    lam: torch.Tensor
    c: torch.Tensor
    ns: float
    band: dict
    n_range: tuple
    thickness_range: tuple
    a_sel: list
    b_sel: list
    progress: object  # the caller's progress(done, total), or None
    total: int  # the units of work that progress counts (estimate_film's docstring)
    done: int = 0

    def step(self, units: int = 1) -> None:
        """Report ``units`` more units of work done to ``progress``."""
        self.done += units
        if self.progress is not None:
            self.progress(self.done, self.total)

    @property
    def s2(self) -> torch.Tensor:
        """n₀² sin²θ per angle."""
        return (self.band["n_incident"] ** 2) * (1 - self.c * self.c)

    @property
    def lam_mid(self) -> float:
        """The median band centre (nm)."""
        return float(self.lam.median())

    @property
    def batch(self) -> torch.Size:
        """The pixel axes ``(*)`` of the cube."""
        return self.y.shape[:-2]

    def scatter(self, x) -> torch.Tensor:
        """Per-valid-pixel values ``(V,)`` on the whole image ``(*)``, NaN at the invalid pixels."""
        out = torch.full((self.valid.numel(),), math.nan, dtype=x.dtype, device=x.device)
        return out.masked_scatter(self.valid, x).reshape(self.batch)

    def scalar(self, value) -> torch.Tensor:
        """A 0-d tensor of ``value`` in the problem's dtype and device."""
        return torch.as_tensor(value, dtype=self.Y.dtype, device=self.Y.device)

    def decimated(self, Y) -> torch.Tensor:
        """Pixels ``(p, A, B)`` reduced to the decimated angles and bands."""
        return Y[:, self.a_sel][:, :, self.b_sel]

    def terms(self, n, full_bands=False, all_angles=False):
        """Band terms of a constant index ``n`` on the decimated (or full) bands and angles."""
        lam = self.lam if full_bands else self.lam[self.b_sel]
        c = self.c if all_angles else self.c[self.a_sel]
        return band_terms(lam, c[:, None], n, self.ns, **self.band)

    def model_terms(self, theta, model, full_bands=False, all_angles=False):
        """Terms of the index model ``theta`` on the decimated (or full) bands and angles."""
        lam = self.lam if full_bands else self.lam[self.b_sel]
        c = self.c if all_angles else self.c[self.a_sel]
        return model_terms(theta, model, lam, c, self.ns, **self.band)

    def period(self, n: float) -> float:
        """Interference-order period T = λ_mid / (2 mean√(n² − n₀² sin²θ)) in nm."""
        return self.lam_mid / (2 * float(torch.sqrt(n * n - self.s2).mean()))


@dataclass
class _Scan:
    """The index-scan sample: pixels ``ys`` ``(p, A, B)``, their decimated cube ``yd``, the
    scanned constant index and thicknesses, and whether the grid overruled the peaks."""

    ys: torch.Tensor
    yd: torch.Tensor
    n: float
    d: torch.Tensor
    restarted: bool


def _validate_inputs(cube, wavelength, cos_theta, n_substrate, index_model_name, band, n_range, thickness_range,
                     smoothness, sample, iterations, final_iterations, seed, progress) -> _Setup:
    """Check every argument of :func:`estimate_film` (ValueError naming it) before any work."""
    _checks.check_choice(index_model_name, "index_model_name", INDEX_CHOICES)
    y, lam, c = cube_axes(cube, wavelength, cos_theta, pixel_axes=1)
    if lam.numel() < 7:
        raise ValueError(f"wavelength must have at least 7 bands; got {lam.numel()}")
    uniform_bands(lam)
    sorted_angles(c)
    band_settings(band["bandwidth"], band["passband"], band["polarization"])
    band = dict(band, n_incident=real_index(band["n_incident"], "n_incident", y, incident=True))
    ns = real_index(n_substrate, "n_substrate", y)
    n_range = value_range(n_range, "n_range", positive=True)
    thickness_range = value_range(thickness_range, "thickness_range", positive=False, nm=True)
    weight(smoothness, "smoothness")
    _checks.check_int(sample, "sample")
    _checks.check_int(iterations, "iterations", minimum=0)
    _checks.check_int(final_iterations, "final_iterations", minimum=0)
    _checks.check_int(seed, "seed", minimum=0)
    if progress is not None and not callable(progress):
        raise ValueError(f"progress must be None or a callable progress(done, total); got {progress!r}")
    # progress units: peaks, index scan, each order hypothesis of each index model tried, order
    # check, thickness, and each joint iteration of the final pass
    models = len(INDEX_MODELS) if index_model_name == "auto" else 1
    final = 0 if final_iterations == 0 and smoothness == 0 else max(final_iterations, 1)
    y = torch.where(y.isfinite(), y, math.nan)  # ±inf samples are missing data, like NaN (a new tensor)
    pixels = y.reshape(-1, *y.shape[-2:])
    finite = ~pixels.isnan()
    valid = finite.any(-1).any(-1)
    if not bool(valid.any()):
        raise ValueError(f"cube must have at least one pixel with a finite sample; all {valid.numel()} pixels are "
                         "NaN or infinite (dead pixels, e.g. an ENVI 'data ignore value')")
    a_sel, b_sel = decimation(*y.shape[-2:], DECIMATION_STRIDE)
    return _Setup(y=y, valid=valid, Y=pixels[valid], count=finite[valid].sum((-1, -2)).to(y.dtype), lam=lam, c=c,
                  ns=ns, band=band, n_range=n_range, thickness_range=thickness_range, a_sel=a_sel, b_sel=b_sel,
                  progress=progress, total=4 + len(ORDER_SHIFTS) * models + final)


def _peak_stage(st: _Setup):
    """Stage 1, the peak method (eq. 8–14) on the valid pixels → ``(PeakResult, d_peak (V,))``; a pixel
    without a peak estimate gets a finite seed (the median)."""
    pk = peak_method(st.Y, st.lam, st.c, st.ns, n_range=st.n_range, thickness_range=st.thickness_range, **st.band)
    d_peak = pk.thickness.reshape(-1)
    if bool(d_peak.isnan().any()):
        fill = d_peak.nanmedian() if bool((~d_peak.isnan()).any()) else st.scalar(st.thickness_range[0])
        d_peak = torch.where(d_peak.isnan(), fill, d_peak)
    st.step()  # peaks
    return pk, d_peak


def _index_scan(st: _Setup, d_peak, n_peak: float, sample: int, seed: int) -> _Scan:
    """Stage 2 on a seeded pixel sample: the best constant n near the peaks' (:func:`scan_index`),
    then :func:`_grid_check`. The sample: the first ``sample`` valid pixels of a seeded permutation
    of every pixel — without invalid pixels, the sample of the same cube without them."""
    valid = st.valid.cpu()
    g = torch.Generator(device="cpu").manual_seed(int(seed))  # (the same sample on every device)
    perm = torch.randperm(valid.numel(), generator=g, device="cpu")
    rank = valid.cumsum(0) - 1  # position of each valid pixel among the valid ones (the rows of st.Y)
    idx = rank[perm[valid[perm]]][: min(st.Y.shape[0], sample)].to(st.Y.device)
    ys, ds = st.Y[idx], d_peak[idx]
    yd = st.decimated(ys)
    p_scan, d_scan, _, _ = scan_index(yd, ds, n_peak, st.lam[st.b_sel], st.c[st.a_sel], st.ns,
                                      rel_range=SCAN_REL_RANGE, **st.band)
    n_scan, d_scan, restarted = _grid_check(st, yd, float(p_scan[0]), d_scan)
    st.step()  # index scan
    return _Scan(ys=ys, yd=yd, n=n_scan, d=d_scan, restarted=restarted)


def _grid_check(st: _Setup, yd, n_scan: float, d_scan):
    """The peaks may mislead (noise, too few extrema, dispersion): an exhaustive (n, d) search on
    ``GRID_CHECK_PIXELS`` pixels settles which start to trust; when the grid is clearly better
    (``RESTART_RATIO``) a fine scan around its n replaces the scan → ``(n, d, restarted)``."""
    few = yd[: min(yd.shape[0], GRID_CHECK_PIXELS)]
    lo, hi = st.n_range
    n_grid = torch.exp(torch.linspace(math.log(lo), math.log(hi), GRID_CHECK_INDICES, dtype=yd.dtype, device=yd.device))
    kw = dict(thickness_range=st.thickness_range, **st.band)
    lam_d, c_d = st.lam[st.b_sel], st.c[st.a_sel]
    g_loss, _ = grid_scan(few, lam_d, c_d, st.ns, n_grid, **kw)
    d_few, _ = d_only_gauss_newton(few, d_scan[: few.shape[0], None], st.terms(n_scan), iterations=POLISH_ITERATIONS)
    peak_loss = float(cube_sse(few, st.terms(n_scan), d_few).sum())
    if not float(g_loss.min()) < RESTART_RATIO * peak_loss:
        return n_scan, d_scan, False
    fine = float(n_grid[g_loss.argmin()]) * torch.linspace(1 - FINE_SCAN_REL_RANGE, 1 + FINE_SCAN_REL_RANGE,
                                                          FINE_SCAN_STEPS, dtype=yd.dtype, device=yd.device)
    f_loss, f_d = grid_scan(yd, lam_d, c_d, st.ns, fine, **kw)
    return float(fine[f_loss.argmin()]), f_d[f_loss.argmin()], True


def _model_start(st: _Setup, scan: _Scan, model: str, slope_cache: dict):
    """Starting ``(theta (K,), d (p,), n at λ_mid)`` of one index model: the scanned constant index,
    or for a dispersive model a second scan over (n(λ_mid), Cauchy slope B), shared by the Cauchy
    models through ``slope_cache`` (a thick dispersive film otherwise falls into a wrong
    (index slope, order) pair)."""
    K = INDEX_MODELS[model]
    if K == 1:
        return st.scalar([scan.n]), scan.d, scan.n
    if "scan" not in slope_cache:
        slope_cache["scan"] = scan_index(scan.yd, scan.d, scan.n, st.lam[st.b_sel], st.c[st.a_sel], st.ns,
                                         rel_range=SLOPE_SCAN_REL_RANGE, steps=SLOPE_SCAN_STEPS,
                                         slopes=SLOPE_SCAN_SLOPES, **st.band)[:2]
    p2, d_start = slope_cache["scan"]
    theta0 = torch.cat([p2, p2.new_zeros(K - 2)])
    return theta0, d_start, float(index_model(st.scalar(st.lam_mid), theta0, model))


def _misfit(sse) -> float:
    """Σ of per-pixel misfits as a float; NaN (which would make every comparison False and so
    silently keep the first candidate) counts as +inf."""
    total = float(sse.sum())
    return total if not math.isnan(total) else math.inf


def _order_hypotheses(st: _Setup, scan: _Scan, model: str, theta0, d_start, n_start: float, iterations: int):
    """Stage 3 for one model: the joint fit (:func:`refine_film`) from each global order shift of
    ``ORDER_SHIFTS`` → ``(sse, RefineResult, shift, {shift: sse})`` of the least misfit (the shift
    keys ``"+0"``, ``"-1"``, ``"+1"``; None for a shift that would start at d ≤ 0)."""
    best, tried = None, {}
    T = st.period(n_start)
    for j in ORDER_SHIFTS:
        start = d_start + j * T
        if bool((start <= 0).any()):
            tried[f"{j:+.0f}"] = None
            st.step()  # (an order hypothesis, skipped)
            continue
        res = refine_film(scan.ys, st.lam, st.c, st.ns, start, theta0, index_model_name=model, iterations=iterations,
                          **st.band)
        loss = _misfit(res.sse)
        tried[f"{j:+.0f}"] = loss
        if best is None or loss < best[0]:
            best = (loss, res, j)
        st.step()  # an order hypothesis
    return (*best, tried)


def _select_index_model(st: _Setup, scan: _Scan, candidates, iterations: int):
    """Stage 3 for every candidate model; the one of least BIC over the sample's finite samples
    wins → ``(model, RefineResult on the sample, selection {model: sse, bic, params, order_shift,
    order_sse})``. The sample holds valid pixels only, so every misfit is a finite sum."""
    n_obs = int((~scan.ys.isnan()).sum())  # samples in the BIC (missing samples do not count)
    slope_cache, selection, results = {}, {}, {}
    for model in candidates:
        theta0, d_start, n_start = _model_start(st, scan, model, slope_cache)
        sse, res, shift, tried = _order_hypotheses(st, scan, model, theta0, d_start, n_start, iterations)
        K = INDEX_MODELS[model]
        sse_m = max(sse, torch.finfo(st.Y.dtype).tiny)
        bic = n_obs * math.log(sse_m / max(n_obs, 1)) + K * math.log(max(n_obs, 2))
        selection[model] = dict(sse=sse, bic=bic, params=res.params.tolist(), order_shift=shift, order_sse=tried)
        results[model] = res
    model = min(selection, key=lambda m: selection[m]["bic"])
    return model, results[model], selection


def _image_thickness(st: _Setup, theta, model: str, d_peak, n_peak: float):
    """Stage 4a, every pixel at the fitted index: the peak thicknesses rescaled to it (same optical
    thickness), their three nearest orders polished on the decimated cube, the best kept →
    ``(d0 (P, 1), misfit (P,), n at λ_mid)``."""
    n_mid = float(index_model(st.scalar(st.lam_mid), theta, model))
    s2 = st.s2
    scale = float(torch.sqrt(n_peak ** 2 - s2).mean()) / float(torch.sqrt(n_mid ** 2 - s2).mean())
    D = order_candidates(d_peak * scale, st.period(n_mid))
    Dn, S = d_only_gauss_newton(st.decimated(st.Y), D, st.model_terms(theta, model), iterations=POLISH_ITERATIONS)
    return Dn.gather(-1, S.argmin(-1, keepdim=True)), S.min(-1).values, n_mid


def _order_check(st: _Setup, scan: _Scan, theta, model: str, d0, s0, n_mid: float, sample_fit):
    """Stage 4b: pixels with no good order among the peak-based candidates — misfit above
    ``EXHAUSTIVE_MISFIT_RATIO`` × the sample's mean at the fitted index, or all of them when the
    peaks misled the index search — get an exhaustive thickness search on every band of the
    decimated angles; it replaces d0 where it fits better → ``(d0, pixels searched)``. Misfits are
    compared per finite sample (scaled to a whole pixel): a pixel missing some samples is not
    mistaken for a well-fitted one."""
    per_pixel = scan.yd.shape[-2] * scan.yd.shape[-1]  # samples of a whole decimated pixel
    sample_sse = cube_sse(scan.yd, st.model_terms(theta, model), sample_fit.thickness[:, None]).sum()
    ref = float(sample_sse / scan.yd.shape[0]) * (scan.yd.shape[0] * per_pixel / max(1, int((~scan.yd.isnan()).sum())))
    scale = per_pixel / (~st.decimated(st.Y).isnan()).sum((-1, -2)).clamp_min(1).to(s0.dtype)  # 1 for whole pixels
    bad = (s0 * scale > EXHAUSTIVE_MISFIT_RATIO * ref) | torch.full_like(s0, float(scan.restarted), dtype=torch.bool)
    if bool(bad.any()):
        gstep = float(st.lam.min()) / (THICKNESS_GRID_DIVISOR * float(torch.sqrt(n_mid ** 2 - st.s2).max()))
        grid = thickness_grid(st.thickness_range, gstep, st.Y)
        terms_b = st.model_terms(theta, model, full_bands=True)  # every band: no fringe aliasing
        yb = st.Y[bad][:, st.a_sel]
        sg = cube_sse(yb, terms_b, grid.expand(int(bad.sum()), -1))
        db, sb = d_only_gauss_newton(yb, grid[sg.argmin(-1)][:, None], terms_b, iterations=POLISH_ITERATIONS,
                                     max_step=gstep)
        s_old = cube_sse(yb, terms_b, d0[bad])
        d0[bad] = torch.where(sb < s_old, db, d0[bad])
    st.step()  # order check
    return d0, int(bad.sum())


def _final_pass(st: _Setup, theta, model: str, d0, final_iterations: int, smoothness: float):
    """Stage 4c: d polished on the full cube, then ``final_iterations`` joint iterations on every
    valid pixel (with the smoothness term) → ``(theta, d (V,), sse (V,))``. The smoothness term
    needs the image: it then runs on the whole cube, where :func:`refine_film` leaves the pixels
    without data out of every sum and out of the neighbour pairs."""
    d, S = d_only_gauss_newton(st.Y, d0, st.model_terms(theta, model, full_bands=True, all_angles=True),
                               iterations=POLISH_ITERATIONS)
    d = d[:, 0]
    st.step()  # thickness
    if final_iterations == 0 and smoothness == 0:
        return theta, d, S[:, 0]
    image = smoothness > 0 and len(st.batch) == 2
    base = st.done
    progress = None if st.progress is None else (lambda done, total: st.step(base + done - st.done))
    res = refine_film(st.y if image else st.Y, st.lam, st.c, st.ns, st.scatter(d) if image else d, theta,
                      index_model_name=model, iterations=max(final_iterations, 1), smoothness=smoothness,
                      order_check=False, fit_index=final_iterations > 0, progress=progress, **st.band)
    d, sse = res.thickness.reshape(-1), res.sse.reshape(-1)
    return res.params, (d[st.valid] if image else d), (sse[st.valid] if image else sse)


def _noise_advice(model: str, requested: str) -> str:
    """What the noise warning suggests: a richer index model only when one was not tried already
    (``"auto"`` tried them all; nothing is richer than the richest, the Cauchy models are nested)."""
    check = "check the substrate index, the angles and the polarization (an absorbing film is not modelled)"
    if requested == "auto":
        return (f"none of the index models {_checks.names(tuple(INDEX_MODELS))} explains the cube "
                f"({model!r} has the least BIC) — {check}")
    richer = [m for m in INDEX_MODELS if INDEX_MODELS[m] > INDEX_MODELS[model]]
    if not richer:
        return f"the {model!r} index model, the richest, does not explain the cube — {check}"
    return (f"the {model!r} index model does not explain the cube — try index_model_name='auto' (or "
            f"{richer[-1]!r} for a dispersive film), or {check}")


def _noise_check(st: _Setup, rms, model: str, requested: str):
    """Compare the median RMS residual (valid pixels) with the data's noise level; warn
    (``RuntimeWarning``, advice by :func:`_noise_advice`) above ``NOISE_WARNING_RATIO`` →
    ``(noise level, ratio)``."""
    sigma = noise_level(st.Y)
    ratio = float(rms[rms.isfinite()].median()) / sigma if sigma > 0 else math.inf
    if ratio > NOISE_WARNING_RATIO:
        warnings.warn(f"estimate_film: the median RMS residual is {ratio:.1f}x the noise level of the data "
                      f"({sigma:.2g}); {_noise_advice(model, requested)}", RuntimeWarning, stacklevel=4)
    return sigma, ratio


@_checks.fits_with_autograd  # (autograd inside: a caller's inference mode must not switch it off)
def estimate_film(cube, wavelength, cos_theta, n_substrate, *, index_model_name: str = "constant", bandwidth=4.0,
                  passband: str = "box", polarization: str = "unpolarized", n_incident=1.0, n_range=(1.2, 3.5),
                  thickness_range=(20.0, 2000.0), smoothness: float = 0.0, sample: int = 512,
                  iterations: int = 10, final_iterations: int = 2, seed: int = 0, progress=None) -> FilmEstimate:
    """Film index (shared) and per-pixel thickness from a cube (module docstring).

    Args:
        cube: ``(*, A, B)`` band reflectance (e.g. ``(H, W, A, B)``), angles sorted by increasing θ.
        wavelength: ``(B,)`` uniformly spaced band centres (nm); cos_theta ``(A,)``.
        n_substrate: real substrate index (known, as in the paper: PET 1.64).
        index_model_name: ``"constant"``, a dispersive ``"cauchy"`` / ``"cauchy3"``, or ``"auto"``
            (the model of least BIC on the sample, module docstring; one index search per model
            tried; its cost: docs/performance.md, "Thin-film estimation from hyperspectral cubes").
        bandwidth, passband: the camera's band model.
        polarization: ``"unpolarized"``, ``"s"`` or ``"p"``; Kobayashi et al.'s camera sees the
            s wave through a polarizer: their setup is ``polarization="s"``.
        n_incident: real index of the incident medium.
        n_range, thickness_range: the admissible film index and thickness (nm).
        smoothness: spatial smoothness weight μ_s ≥ 0 of the final pass (image cubes).
        sample: pixels used for the index search (stages 2–3).
        iterations: joint iterations per order hypothesis on the sample (stage 3).
        final_iterations: joint iterations on the full image (0: index from the sample only).
        seed: seeds the pixel sample.
        progress: ``None`` or a callable ``progress(done, total)``: ``done`` stages out of
            ``total`` = 4 (peaks, index scan, order check, thickness) + 3 order hypotheses per
            index model tried + the final pass's joint iterations (``max(final_iterations, 1)``,
            none when ``final_iterations`` and ``smoothness`` are 0), after each; the last call
            has ``done == total``.

    Returns:
        :class:`FilmEstimate`; dtype and device follow cube, wavelength and cos_theta.

    Example (a 2 × 2 pixel synthetic cube of MgF₂, n = 1.37, about 400 nm on PET, n = 1.64: 5
    angles × 81 bands; a narrow thickness range and few iterations keep it quick):
        >>> from torchirid.estimation import synthetic_cube
        >>> c = synthetic_cube("mgf2_400", height=2, width=2, seed=1)
        >>> est = estimate_film(c.cube, c.wavelength, c.cos_theta, 1.64, thickness_range=(300.0, 500.0),
        ...                     iterations=2, final_iterations=0)
        >>> round(est.n, 2), tuple(est.thickness.shape)  # the shared index; one thickness (nm) per pixel
        (1.37, (2, 2))
        >>> bool((est.thickness - c.thickness).abs().max() < 1.0)  # within 1 nm of the truth
        True
    """
    band = dict(bandwidth=bandwidth, passband=passband, polarization=polarization, n_incident=n_incident)
    st = _validate_inputs(cube, wavelength, cos_theta, n_substrate, index_model_name, band, n_range, thickness_range,
                          smoothness, sample, iterations, final_iterations, seed, progress)
    times = {}
    t0 = time.perf_counter()
    pk, d_peak = _peak_stage(st)
    times["peaks"] = time.perf_counter() - t0
    t1 = time.perf_counter()
    scan = _index_scan(st, d_peak, pk.n, sample, seed)
    candidates = tuple(INDEX_MODELS) if index_model_name == "auto" else (index_model_name,)
    model, sample_fit, selection = _select_index_model(st, scan, candidates, iterations)
    times["index"] = time.perf_counter() - t1
    t2 = time.perf_counter()
    d0, s0, n_mid = _image_thickness(st, sample_fit.params, model, d_peak, pk.n)
    d0, exhaustive = _order_check(st, scan, sample_fit.params, model, d0, s0, n_mid, sample_fit)
    theta, d, sse = _final_pass(st, sample_fit.params, model, d0, final_iterations, smoothness)
    times["thickness"] = time.perf_counter() - t2
    times["total"] = time.perf_counter() - t0
    rms = (sse / st.count).sqrt()  # over the pixel's finite samples
    sigma, ratio = _noise_check(st, rms, model, index_model_name)
    P, V = st.valid.numel(), st.Y.shape[0]
    return FilmEstimate(
        params=theta, index_model=model, n=float(index_model(st.scalar(REFERENCE_WAVELENGTH), theta, model)),
        thickness=st.scatter(d), rms=st.scatter(rms), n_peak=pk.n, thickness_peak=st.scatter(pk.thickness.reshape(-1)),
        timings=times, valid=st.valid.reshape(st.batch),
        settings=dict(st.band, n_substrate=st.ns, index_model=model, index_start="grid" if scan.restarted else "peaks",
                      index_model_requested=index_model_name, index_selection=selection, noise_level=sigma,
                      residual_to_noise=ratio, exhaustive_pixels=exhaustive, smoothness=smoothness, sample=sample,
                      seed=seed, pixels=P, invalid_pixels=P - V,
                      pixels_missing_samples=int((st.count < st.Y.shape[-2] * st.Y.shape[-1]).sum())))


def model_cube(params, index_model_name, thickness, wavelength, cos_theta, n_substrate, **kw) -> torch.Tensor:
    """Noise-free band reflectance ``(*, A, B)`` of an estimate (fast band model), for the metrics;
    dtype and device follow ``thickness``.

    Args:
        params: ``(K,)`` parameters of the index model ``index_model_name``
            (:func:`~torchirid.estimation.index_model`).
        thickness: ``(*)`` film thickness (nm); wavelength ``(B,)`` band centres (nm);
            cos_theta ``(A,)``; n_substrate: real.
        kw: the band model of ``band_terms()`` (``bandwidth``,
            ``passband``, ``polarization``, ``n_incident``).

    Example (a 4 × 4 image of a 400 nm MgF₂ film, n = 1.37, on PET at 3 angles, 400–720 nm):
        >>> import torch
        >>> w = torch.arange(400.0, 721.0, 4.0, dtype=torch.float64)  # nm
        >>> cos_t = torch.cos(torch.deg2rad(torch.tensor([10.0, 30.0, 50.0], dtype=torch.float64)))
        >>> d = torch.full((4, 4), 400.0, dtype=torch.float64)  # nm
        >>> R = model_cube(torch.tensor([1.37], dtype=torch.float64), "constant", d, w, cos_t, 1.64)
        >>> tuple(R.shape), round(float(R[0, 0, 0, 37]), 4)  # (H, W, A, B); R at 10°, 548 nm
        ((4, 4, 3, 81), 0.0586)
    """
    d = tensor(thickness)
    lam = torch.as_tensor(wavelength, dtype=d.dtype, device=d.device)
    c = torch.as_tensor(cos_theta, dtype=d.dtype, device=d.device)
    terms = model_terms(params, index_model_name, lam, c, real_index(n_substrate, "n_substrate", d), **kw)
    # the polarization axis leads the terms: pixels go after it, angles and bands last
    R = band_reflectance_fast(tuple(t[:, None] for t in terms), d.reshape(1, -1, 1, 1))
    return R.reshape(*d.shape, *R.shape[-2:])


def film_metrics(estimate: FilmEstimate, truth) -> dict:
    """Table-1 metrics of an estimate against a :class:`~torchirid.estimation.SyntheticCube`.

    n error at 589.3 nm; mean and max |d error| (nm); mean ΔE*ab (CIE 1976, D65, CIE 1931 2°)
    between the true noise-free band spectra and the re-rendered estimate, averaged over
    pixels and angles; spectral RMSE (reflectance units) averaged the same way. Every average
    runs over the estimate's valid pixels (:meth:`FilmEstimate.valid_pixels`; ``valid_pixels``
    counts them): a dead pixel has no estimate to score.

    Returns a dict of floats (and ``valid_pixels``, an int): ``n_true``, ``n_est``, ``n_error``,
    ``n_peak``, ``d_true_mean``, ``d_est_mean``, ``d_error_mean``, ``d_error_max``,
    ``d_error_peak_mean`` (nm), ``delta_e_mean``, ``rmse_mean``, ``time_s`` (the estimate's).

    Example (a 2 × 2 pixel synthetic MgF₂ cube; few iterations, for speed):
        >>> from torchirid.estimation import synthetic_cube
        >>> c = synthetic_cube("mgf2_400", height=2, width=2, seed=1)
        >>> est = estimate_film(c.cube, c.wavelength, c.cos_theta, 1.64, thickness_range=(300.0, 500.0),
        ...                     iterations=2, final_iterations=0)
        >>> m = film_metrics(est, c)
        >>> round(m["n_error"], 2), m["valid_pixels"], m["d_error_max"] < 1.0, m["delta_e_mean"] < 0.5
        (0.0, 4, True, True)
    """
    kw = {k: estimate.settings[k] for k in ("bandwidth", "passband", "polarization", "n_incident")}
    ok = estimate.valid_pixels()
    est = model_cube(estimate.params, estimate.index_model, estimate.thickness[ok], truth.wavelength,
                     truth.cos_theta, truth.sample.n_substrate, **kw)
    clean = truth.clean[ok]
    lab_t = xyz_to_lab(spectrum_to_xyz(clean, truth.wavelength))
    lab_e = xyz_to_lab(spectrum_to_xyz(est, truth.wavelength))
    de = delta_e_1976(lab_t, lab_e)
    rmse = ((est - clean) ** 2).mean(-1).sqrt()
    d_true = truth.thickness[ok]
    err = (estimate.thickness[ok] - d_true).abs()
    return {
        "n_true": truth.sample.n_reference,
        "n_est": estimate.n,
        "n_error": abs(estimate.n - truth.sample.n_reference),
        "n_peak": estimate.n_peak,
        "valid_pixels": int(ok.sum()),
        "d_true_mean": float(d_true.mean()),
        "d_est_mean": float(estimate.thickness[ok].mean()),
        "d_error_mean": float(err.mean()),
        "d_error_max": float(err.max()),
        "d_error_peak_mean": float((estimate.thickness_peak[ok] - d_true).abs().mean()),
        "delta_e_mean": float(de.mean()),
        "rmse_mean": float(rmse.mean()),
        "time_s": float(estimate.timings.get("total", math.nan)),
    }
