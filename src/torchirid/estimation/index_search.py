r"""The search for the film's index on a pixel sample: stages 2 and 3 of ``estimate_film``.

**Stage 2** (:func:`scan_sample`): on a seeded pixel sample (``sample``, 512) of the valid pixels,
on a decimated cube (3 angles, every 3rd band), the best constant n within ±15 % of eq. 12's
(``scan_index`` of :mod:`~torchirid.estimation.gauss_newton`; eq. 12 is biased for a dispersive
film: the paper's ZnS came out 2.674 for 2.37), checked against an exhaustive (n, d) search on
128 pixels (``grid_scan``) — when the peaks mislead (noise, films with no extremum in range),
the search restarts from the grid's best n (:class:`IndexSample` ``.restarted``).

**Stage 3** (:func:`select_index_model`): for each index model tried, the start (the scanned
constant index, or for a dispersive model a second scan over (n(λ_mid), Cauchy slope B)), then
the joint fit (:func:`~torchirid.estimation.refine_film`) from the three global orders d, d ± T
(T = λ/(2√(n² − sin²θ))), keeping the lowest misfit — a dispersive index and a shifted order can
otherwise explain the same peaks. Of several models, the one of least Bayesian information
criterion over the sample's N finite samples wins, BIC = N ln(SSE/N) + K ln N (the per-pixel
thicknesses are common to all models and cancel).

The numbers are the module-level constants (``SCAN_*``, ``GRID_CHECK_*``, ``RESTART_RATIO``,
``ORDER_SHIFTS``, ...), each with the reason for its value.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch

from .dispersion import INDEX_MODELS, index_model
from .gauss_newton import POLISH_ITERATIONS, d_only_gauss_newton, grid_scan, scan_index
from .problem import FilmProblem
from .refine import refine_film
from .residuals import cube_sse

__all__ = []

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


@dataclass
class IndexSample:
    """The index-scan sample: pixels ``ys`` ``(p, A, B)``, their decimated cube ``yd``, the
    scanned constant index and thicknesses, and whether the grid overruled the peaks."""

    ys: torch.Tensor
    yd: torch.Tensor
    n: float
    d: torch.Tensor
    restarted: bool


def scan_sample(st: FilmProblem, d_peak, n_peak: float, sample: int, seed: int) -> IndexSample:
    """Stage 2 on a seeded pixel sample: the best constant n near the peaks' (``scan_index``),
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
    return IndexSample(ys=ys, yd=yd, n=n_scan, d=d_scan, restarted=restarted)


def _grid_check(st: FilmProblem, yd, n_scan: float, d_scan):
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


def _model_start(st: FilmProblem, scan: IndexSample, model: str, slope_cache: dict):
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


def _order_hypotheses(st: FilmProblem, scan: IndexSample, model: str, theta0, d_start, n_start: float,
                      iterations: int):
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


def select_index_model(st: FilmProblem, scan: IndexSample, candidates, iterations: int):
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
