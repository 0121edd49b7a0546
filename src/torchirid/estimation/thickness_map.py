r"""The per-pixel thickness map at the fitted index: stage 4 of ``estimate_film``.

On the whole image (the valid pixels of the :class:`~torchirid.estimation.problem.FilmProblem`):

a. :func:`image_thickness` — d at the fitted index from the three nearest orders of the peak
   thicknesses rescaled to it (batched Gauss–Newton on the decimated cube);
b. :func:`order_check` — an exhaustive thickness search for the pixels whose misfit stays above
   ``EXHAUSTIVE_MISFIT_RATIO`` × the sample's (all pixels when the index search restarted from
   its grid);
c. :func:`final_pass` — a polish on the full cube, then ``final_iterations`` joint
   Levenberg–Marquardt iterations on every pixel (:func:`~torchirid.estimation.refine_film`,
   with the optional smoothness term).
"""

from __future__ import annotations

import torch

from .dispersion import index_model
from .gauss_newton import POLISH_ITERATIONS, d_only_gauss_newton
from .index_search import IndexSample
from .problem import FilmProblem
from .refine import refine_film
from .residuals import THICKNESS_GRID_DIVISOR, cube_sse, order_candidates, thickness_grid

__all__ = []

EXHAUSTIVE_MISFIT_RATIO = 3.0  # pixels above 3x the sample's mean misfit get the exhaustive thickness search


def image_thickness(st: FilmProblem, theta, model: str, d_peak, n_peak: float):
    """Stage 4a, every pixel at the fitted index: the peak thicknesses rescaled to it (same optical
    thickness), their three nearest orders polished on the decimated cube, the best kept →
    ``(d0 (P, 1), misfit (P,), n at λ_mid)``."""
    n_mid = float(index_model(st.scalar(st.lam_mid), theta, model))
    s2 = st.s2
    scale = float(torch.sqrt(n_peak ** 2 - s2).mean()) / float(torch.sqrt(n_mid ** 2 - s2).mean())
    D = order_candidates(d_peak * scale, st.period(n_mid))
    Dn, S = d_only_gauss_newton(st.decimated(st.Y), D, st.model_terms(theta, model), iterations=POLISH_ITERATIONS)
    return Dn.gather(-1, S.argmin(-1, keepdim=True)), S.min(-1).values, n_mid


def order_check(st: FilmProblem, scan: IndexSample, theta, model: str, d0, s0, n_mid: float, sample_fit):
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


def final_pass(st: FilmProblem, theta, model: str, d0, final_iterations: int, smoothness: float):
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
