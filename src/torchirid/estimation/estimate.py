r"""The whole estimate: peak method → index search → thickness map, for a cube ``(*, A, B)``.

:func:`estimate_film` chains the stages of the film estimation, each in the module of its
concept, on the :class:`~torchirid.estimation.problem.FilmProblem` that checks and prepares its
arguments once (:mod:`~torchirid.estimation.problem`):

1. ``peak_method()`` — Kobayashi et al. eq. 8–14: a robust n and a
   per-pixel d (eq. 14 over the admissible orders, scored on a decimated cube);
2. on a seeded pixel sample (``sample``, 512), on a decimated cube (3 angles, every 3rd band):
   the best constant n within ±15 % of eq. 12's (eq. 12 is biased for a dispersive film: the
   paper's ZnS came out 2.674 for 2.37), checked against an exhaustive (n, d) search on 128
   pixels — when the peaks mislead (noise, films with no extremum in range), the search
   restarts from the grid's best n; for a dispersive model a second scan over (n(λ_mid),
   Cauchy slope B) (:mod:`~torchirid.estimation.index_search`);
3. on the same sample, the joint fit of the index model from the three global orders
   d, d ± T (T = λ/(2√(n² − sin²θ))), keeping the lowest misfit — a dispersive index and
   a shifted order can otherwise explain the same peaks (:mod:`~torchirid.estimation.index_search`);
4. on the whole image: d at that index from the three nearest orders (batched Gauss–Newton
   on the decimated cube), an exhaustive thickness search for the pixels whose misfit stays
   above 3× the sample's (all pixels when step 2 restarted), a polish on the full cube, then
   ``final_iterations`` joint Levenberg–Marquardt iterations on every pixel
   (:func:`~torchirid.estimation.refine_film`, with the optional smoothness term)
   (:mod:`~torchirid.estimation.thickness_map`).

``index_model_name="auto"`` runs stage 3 for every model of
:data:`~torchirid.estimation.INDEX_MODELS` on the sample (stage 2 and the dispersive scan are
shared) and keeps the one of least Bayesian information criterion over the sample's N
samples, BIC = N ln(SSE/N) + K ln N (the per-pixel thicknesses are common to all models and
cancel): a dispersive film such as ZnS then gets a Cauchy model, a non-dispersive one keeps
the constant index unless dispersion pays for its parameters.

After the fit the per-pixel RMS residual is compared with the noise level of the data
(:func:`~torchirid.estimation.noise_level`, :mod:`~torchirid.estimation.noise`); a median ratio
above ``NOISE_WARNING_RATIO`` warns (``RuntimeWarning``) — the model does not explain the data
(wrong index model, absorbing film, wrong substrate or angles).

**Missing data.** A non-finite sample (NaN — :func:`~torchirid.estimation.read_cube` turns an
ENVI header's ``data ignore value`` into NaN — or ±inf) is missing: it is left out of every sum.
A pixel without a single finite sample (a dead pixel) is *invalid*: it is dropped before stage 1,
so it enters no score (peaks, index scan and grid check, BIC, order hypotheses, noise level,
thickness search, final pass, :func:`~torchirid.estimation.film_metrics`), and the result reports it —
``FilmEstimate.valid`` is False there and its thickness and RMS are NaN. A pixel with only some
samples missing stays valid and is fitted from the rest; its RMS residual is taken over its
finite samples. The pixel sample of stages 2–3 is the one of the same cube without the invalid
pixels (the seeded permutation of every pixel, invalid ones skipped), so a few dead pixels leave
the estimate unchanged. A cube with no valid pixel raises ``ValueError`` naming ``cube``.

In the code each stage is a function of its module (``prepare_problem``, :func:`_peak_stage`,
``scan_sample``, ``select_index_model``, ``image_thickness``, ``order_check``, ``final_pass``,
``noise_check``); the numbers above are their modules' constants (``SCAN_*``, ``GRID_CHECK_*``,
``RESTART_RATIO``, ``EXHAUSTIVE_MISFIT_RATIO``, ...), each with the reason for its value. dtype
and device follow the cube, wavelength and cos_theta. The Table-1 metrics of an estimate are in
:mod:`~torchirid.estimation.metrics`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import torch

from .. import _autograd, _threads
from .dispersion import INDEX_MODELS, REFERENCE_WAVELENGTH, index_model
from .index_search import ORDER_SHIFTS, scan_sample, select_index_model
from .noise import noise_check
from .peaks import NoTrackError, peak_method, radians_hint
from .problem import DEFAULT_INDEX_MODEL, FilmProblem, prepare_problem
from .thickness_map import final_pass, image_thickness, order_check

__all__ = ["FilmEstimate", "estimate_film"]

#: the flag of a fit whose index search fell back from the peaks to the (n, d) grid (``settings["flags"]``)
RESTART_FLAG = ("the peak method's index (eq. 12) misled the index search, which fell back to an exhaustive "
                "(n, d) grid: check the result (noise, a film with few extrema in range, the angles)")


@dataclass
class FilmEstimate:
    """Result of :func:`estimate_film`.

    params ``(K,)`` of ``index_model``; n: the index at 589.3 nm; thickness ``(*)`` nm;
    rms ``(*)`` per-pixel RMS residual (reflectance) over the pixel's finite samples; n_peak /
    thickness_peak: the peak method's estimates (eq. 12–14); timings: seconds per stage;
    settings: the settings used and what the fit found — among them ``flags``, a list of
    one-line reasons to doubt the fit (the residual far above the data's noise, the same text
    as the ``RuntimeWarning``; an index search that fell back from the peaks to a grid), empty
    for a clean fit: ``fit_batch`` marks a flagged fit ``"flagged"``, not ``"ok"``;
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


def _peak_stage(st: FilmProblem):
    """Stage 1, the peak method (eq. 8–14) on the valid pixels → ``(PeakResult, d_peak (V,))``; a pixel
    without a peak estimate gets a finite seed (the median). No extremum followed over the angles:
    :class:`NoTrackError` naming estimate_film's remedies (it takes no ``n_film``)."""
    try:
        pk = peak_method(st.Y, st.lam, st.c, st.ns, n_range=st.n_range, thickness_range=st.thickness_range,
                         **st.band)
    except NoTrackError as exc:
        hint = radians_hint(exc.angles_deg)
        raise NoTrackError(
            f"no extremum could be followed over the angles with an index inside n_range {exc.n_range}: the film's "
            f"index cannot be estimated (eq. 12); "
            f"{hint + ' (cos_theta = torch.cos(torch.deg2rad(angles_deg))); ' if hint else ''}"
            "check cos_theta and widen n_range if the index lies outside it; a film whose index is known: "
            "peak_method(..., n_film=n) for the thicknesses, then refine_film(..., index_init=n, fit_index=False)",
            exc.angles_deg, exc.n_range) from None
    d_peak = pk.thickness.reshape(-1)
    if bool(d_peak.isnan().any()):
        fill = d_peak.nanmedian() if bool((~d_peak.isnan()).any()) else st.scalar(st.thickness_range[0])
        d_peak = torch.where(d_peak.isnan(), fill, d_peak)
    st.step()  # peaks
    return pk, d_peak


@_threads.large_work  # (the free cores on a shared machine: torchirid._threads)
@_autograd.fits_with_autograd  # (autograd inside: a caller's inference mode must not switch it off)
def estimate_film(cube, wavelength, cos_theta, n_substrate, *, index_model_name: str = DEFAULT_INDEX_MODEL,
                  bandwidth=4.0, passband: str = "box", polarization: str = "unpolarized", n_incident=1.0,
                  n_range=(1.2, 3.5), thickness_range=(20.0, 2000.0), smoothness: float = 0.0, sample: int = 512,
                  iterations: int = 10, final_iterations: int = 2, seed: int = 0, progress=None) -> FilmEstimate:
    """Film index (shared) and per-pixel thickness from a cube (module docstring).

    Args:
        cube: ``(*, A, B)`` band reflectance (e.g. ``(H, W, A, B)``), angles sorted by increasing θ.
        wavelength: ``(B,)`` uniformly spaced band centres (nm); cos_theta ``(A,)``.
        n_substrate: real substrate index (known, as in the paper: PET 1.64).
        index_model_name: ``"auto"`` (default: the model of least BIC on the sample, module
            docstring; one index search per model tried, its cost: docs/performance.md,
            "Thin-film estimation from hyperspectral cubes"), ``"constant"``, or a dispersive
            ``"cauchy"`` / ``"cauchy3"``. The same default in ``torchirid fit-film`` and
            ``fit_batch("film")``: ``"constant"`` misfits a dispersive film such as ZnS.
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
    st = prepare_problem(cube, wavelength, cos_theta, n_substrate, index_model_name, band, n_range, thickness_range,
                         smoothness, sample, iterations, final_iterations, seed, progress)
    candidates = tuple(INDEX_MODELS) if index_model_name == "auto" else (index_model_name,)
    # progress units: peaks, index scan, each order hypothesis of each index model tried, order
    # check, thickness, and each joint iteration of the final pass
    final = 0 if final_iterations == 0 and smoothness == 0 else max(final_iterations, 1)
    st.total = 4 + len(ORDER_SHIFTS) * len(candidates) + final
    times = {}
    t0 = time.perf_counter()
    pk, d_peak = _peak_stage(st)
    times["peaks"] = time.perf_counter() - t0
    t1 = time.perf_counter()
    scan = scan_sample(st, d_peak, pk.n, sample, seed)
    model, sample_fit, selection = select_index_model(st, scan, candidates, iterations)
    times["index"] = time.perf_counter() - t1
    t2 = time.perf_counter()
    d0, s0, n_mid = image_thickness(st, sample_fit.params, model, d_peak, pk.n)
    d0, exhaustive = order_check(st, scan, sample_fit.params, model, d0, s0, n_mid, sample_fit)
    theta, d, sse = final_pass(st, sample_fit.params, model, d0, final_iterations, smoothness)
    times["thickness"] = time.perf_counter() - t2
    times["total"] = time.perf_counter() - t0
    rms = (sse / st.count).sqrt()  # over the pixel's finite samples
    sigma, ratio, noise_flag = noise_check(st.Y, rms, model, index_model_name)
    flags = ([RESTART_FLAG] if scan.restarted else []) + ([noise_flag] if noise_flag else [])
    P, V = st.valid.numel(), st.Y.shape[0]
    return FilmEstimate(
        params=theta, index_model=model, n=float(index_model(st.scalar(REFERENCE_WAVELENGTH), theta, model)),
        thickness=st.scatter(d), rms=st.scatter(rms), n_peak=pk.n, thickness_peak=st.scatter(pk.thickness.reshape(-1)),
        timings=times, valid=st.valid.reshape(st.batch),
        settings=dict(st.band, n_substrate=st.ns, index_model=model, index_start="grid" if scan.restarted else "peaks",
                      index_model_requested=index_model_name, index_selection=selection, noise_level=sigma,
                      residual_to_noise=ratio, exhaustive_pixels=exhaustive, smoothness=smoothness, sample=sample,
                      seed=seed, pixels=P, invalid_pixels=P - V, flags=flags,
                      pixels_missing_samples=int((st.count < st.Y.shape[-2] * st.Y.shape[-1]).sum())))
