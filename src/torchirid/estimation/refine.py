r"""Refinement of the film index (shared) and per-pixel thickness by batched Levenberg–Marquardt.

The objective is the least-squares misfit of the band-integrated model to the whole cube
(every pixel, angle and band; Kobayashi et al. eq. 14 extended to all unknowns at once),

.. math:: L(θ, d) = \sum_{p,a,b} \big(R_b(θ_a; n_θ, d_p) - y_{pab}\big)^2
          + μ_s \sum_{p \sim q} (d_p - d_q)^2,

with n_θ(λ) an index model of :mod:`~torchirid.estimation.dispersion` (θ = its K ≤ 3
parameters, shared by all pixels), d_p one thickness per pixel, and an optional smoothness
weight μ_s over the 4-neighbours of an image (Kobayashi et al.'s third assumption, §4).

Each Gauss–Newton step is exact for the arrow-shaped normal matrix — one scalar block per
pixel plus the K×K index block — by the Schur complement, so a 256 × 256 cube costs one
Jacobian pass, not a 65 536-dimensional solve. The Jacobian is exact (:func:`lm_jacobian`):
the terms (a, b, e, k, h) of ``band_terms()`` are differentiated in θ
by forward-mode autograd (``torch.func.jacfwd``) on the small (polarization × angle × band)
grid, the elementwise partials of the band model in those terms and in d by one batched
reverse-mode pass over the pixels, and the two chained — the band-width term h d² R''
included (the tests compare the whole Jacobian with ``torch.func.jacfwd`` of the residual).

d is multimodal (one basin per interference order): :func:`refine_film` keeps the order
from its start, then re-tests every pixel at d ± one order period T = λ/(2√(n²−sin²θ)) in
one batched call (a few d-only Gauss–Newton steps each) and keeps the best. Pixels whose
misfit stays above 10× the median are left out of the index update (robust to stray orders).

Missing data: a non-finite sample of the cube (NaN, ±inf) is left out of every sum; a pixel
without a single finite sample enters no sum — neither the misfit, nor the median of the inlier
test, nor a smoothness pair — and comes back with NaN thickness and misfit.

:func:`refine_film` runs in stages — :func:`_refine_inputs` (validation), :func:`_lm_fit` (the
damped iterations: :func:`_normal_equations` then :func:`_damped_step`) and :func:`_order_check`.
The tuning constants (``LM_*``, ``INLIER_MISFIT_RATIO``, ``MAX_THICKNESS_STEP``, ...) are
module-level names, each with the reason for its value.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import torch

from .. import _autograd, _checks
from ._validation import band_settings, cube_axes, real_index, weight
from .dispersion import INDEX_MODELS, index_model
from .gauss_newton import MAX_THICKNESS_STEP, _smooth_terms, d_only_gauss_newton, lm_jacobian, model_terms
from .residuals import order_candidates, pixel_chunks, residual_parts, terms_size

__all__ = [
    "RefineResult",
    "refine_film",
]

LM_DAMPING_START = 1e-3  # initial Levenberg–Marquardt damping μ: nearly Gauss–Newton, the start is usually close


LM_DAMPING_MIN = 1e-9  # floor of μ after accepted steps (keeps the damped system well conditioned)


LM_DAMPING_MAX = 1e8  # an iteration gives up once μ exceeds this: the step is then ~0, no descent left


LM_DAMPING_DECREASE = 3.0  # μ /= 3 after an accepted step (Marquardt's usual factors: slower down than up)


LM_DAMPING_INCREASE = 5.0  # μ *= 5 after a refused step: a few refusals reach a short gradient step


INLIER_MISFIT_RATIO = 10.0  # pixels above 10× the median misfit (stray orders) do not steer the index


ORDER_CHECK_ITERATIONS = 3  # d-only Gauss–Newton steps per order candidate in refine_film's final order check


FALLBACK_THICKNESS = 100.0  # nm: start where thickness_init is NaN everywhere (any finite value; empty pixels end NaN)



@dataclass
class RefineResult:
    """params ``(K,)`` of the index model; thickness ``(*)`` nm; sse ``(*)`` per-pixel misfit;
    loss history; iterations run; reordered: pixels whose order changed in the order check.

    Example (what :func:`refine_film` returns, here for a 2 × 2 pixel synthetic MgF₂ cube):
        >>> from torchirid.estimation import synthetic_cube
        >>> c = synthetic_cube("mgf2_400", height=2, width=2, seed=1)
        >>> r = refine_film(c.cube, c.wavelength, c.cos_theta, 1.64, torch.full((2, 2), 400.0, dtype=torch.float64),
        ...                 1.35, iterations=5)
        >>> r.index_model, round(float(r.params[0]), 2), tuple(r.sse.shape), r.iterations, len(r.history)
        ('constant', 1.37, (2, 2), 5, 5)
    """

    params: torch.Tensor
    index_model: str
    thickness: torch.Tensor
    sse: torch.Tensor
    history: list = field(default_factory=list)
    iterations: int = 0
    reordered: int = 0



class _Fit:
    """One validated refinement problem: the pixels ``Y`` ``(P, A, B)`` (missing samples → 0) with
    their mask of finite samples ``valid``, the band grid, the index model and the band-model
    keywords; evaluates the misfit. ``has_data`` ``(P,)``: pixels with at least one finite sample."""

    def __init__(self, Y, valid, lam, c, ns, model, band, batch, smoothness):
        self.Y, self.valid, self.lam, self.c, self.ns = Y, valid, lam, c, ns
        self.model, self.band, self.batch, self.smoothness = model, band, batch, smoothness
        self.image = len(batch) == 2 and smoothness > 0
        self.has_data = valid.any(-1).any(-1)

    @property
    def data(self):
        """The pixels with their missing samples NaN (what :func:`d_only_gauss_newton` skips)."""
        return torch.where(self.valid, self.Y, math.nan)

    def terms(self, theta):
        """Terms (a, b, e, k, h) of the index parameters ``theta`` on the whole grid."""
        return model_terms(theta, self.model, self.lam, self.c, self.ns, **self.band)

    def sse(self, theta, d):
        """Per-pixel misfit ``(P,)`` at index ``theta`` and thickness ``d`` ``(P,)`` (NaN samples skipped)."""
        terms = self.terms(theta)
        P = self.Y.shape[0]
        out = torch.empty(P, dtype=self.Y.dtype, device=self.Y.device)
        for i0, i1 in pixel_chunks(P, terms_size(terms), device=self.Y.device):
            r, _, _ = residual_parts(self.Y[i0:i1], d[i0:i1, None], terms, with_jacobian=False)
            r = torch.where(self.valid[i0:i1, None], r, torch.zeros_like(r))
            out[i0:i1] = (r * r).sum((-1, -2))[:, 0]
        return out

    def smooth(self, d):
        """(value, gradient, diagonal) of the smoothness term (zeros unless an image with μ_s > 0)."""
        if not self.image:
            return _smooth_terms(d, 0.0)
        return _smooth_terms(d.reshape(self.batch), self.smoothness, self.has_data.reshape(self.batch))

    def total(self, sse, d) -> float:
        """The objective L: misfit plus smoothness."""
        return float(sse.sum() + self.smooth(d)[0])



class _Normal(NamedTuple):
    """Gauss–Newton pieces of ½L: the thickness diagonal ``Hdd`` and gradient ``gd`` ``(P,)``
    (smoothness included), the inlier cross terms ``Hdt`` ``(P, K)``, the index block ``Htt``
    ``(K, K)`` and gradient ``gt`` ``(K,)`` (None without the index)."""

    Hdd: torch.Tensor
    gd: torch.Tensor
    Hdt: torch.Tensor | None
    Htt: torch.Tensor | None
    gt: torch.Tensor | None



def _refine_inputs(cube, wavelength, cos_theta, n_substrate, thickness_init, index_init, index_model_name, band,
                   smoothness, iterations, tol):
    """Validate :func:`refine_film`'s arguments (ValueError naming the parameter) and prepare the
    problem → ``(fit, theta (K,), d (P,))``; NaN starts become the median start."""
    _checks.check_choice(index_model_name, "index_model_name", INDEX_MODELS)
    smoothness = weight(smoothness, "smoothness")
    _checks.check_int(iterations, "iterations", minimum=0)
    weight(tol, "tol")
    band_settings(band["bandwidth"], band["passband"], band["polarization"])
    y_all, lam, c = cube_axes(cube, wavelength, cos_theta)
    band = dict(band, n_incident=real_index(band["n_incident"], "n_incident", y_all, incident=True))
    ns = real_index(n_substrate, "n_substrate", y_all)
    dtype, device = y_all.dtype, y_all.device
    batch = y_all.shape[:-2]
    Y = y_all.reshape(-1, *y_all.shape[-2:])
    P = Y.shape[0]
    K = INDEX_MODELS[index_model_name]
    _checks.check_numbers(index_init=index_init, thickness_init=thickness_init)
    theta = _checks.as_real(index_init, "index_init", dtype, device).reshape(-1).clone()
    if theta.numel() == 1 and K > 1:
        theta = torch.cat([theta, theta.new_zeros(K - 1)])
    if theta.numel() != K:
        raise ValueError(f"index_init must have {K} parameters for {index_model_name!r}; got {theta.numel()}")
    d = _checks.as_real(thickness_init, "thickness_init", dtype, device).reshape(-1).clone()
    if d.numel() != P:
        raise ValueError(f"thickness_init must have one value per pixel ({P}); got {d.numel()}")
    d = d.nan_to_num(float(d[~d.isnan()].median()) if bool((~d.isnan()).any()) else FALLBACK_THICKNESS).clamp_min(0.0)
    finite = Y.isfinite()  # ±inf samples are missing data, like NaN
    fit = _Fit(torch.where(finite, Y, 0.0), finite, lam, c, ns, index_model_name, band, batch, smoothness)
    return fit, theta, d



def _normal_equations(fit, theta, d, sse, fit_index) -> _Normal:
    """The Gauss–Newton system at (θ, d): exact Jacobians by chunks of pixels (:func:`lm_jacobian`),
    ∂terms/∂θ once by forward mode; pixels above ``INLIER_MISFIT_RATIO`` × the median misfit are
    left out of the index rows."""
    terms = fit.terms(theta)
    P, K = fit.Y.shape[0], theta.numel()
    dtype, device = fit.Y.dtype, fit.Y.device
    if fit_index:
        # ∂(a, b, e, k, h)/∂θ on the small (pol, A, B) grid, once per iteration: 5 × (pol, A, B, K)
        dterms = torch.func.jacfwd(fit.terms)(theta)
        Htt_p = torch.empty(P, K, K, dtype=dtype, device=device)
        gt_p = torch.empty(P, K, dtype=dtype, device=device)
        Hdt = torch.zeros(P, K, dtype=dtype, device=device)
    Hdd = torch.empty(P, dtype=dtype, device=device)
    gd = torch.empty(P, dtype=dtype, device=device)
    for i0, i1 in pixel_chunks(P, terms_size(terms), device=fit.Y.device):
        r, Jd, Jt = lm_jacobian(fit.Y[i0:i1], d[i0:i1], terms, dterms if fit_index else None)
        m = fit.valid[i0:i1]
        r = torch.where(m, r, torch.zeros_like(r))
        Jd = torch.where(m, Jd, torch.zeros_like(Jd))
        Hdd[i0:i1] = (Jd * Jd).sum((-1, -2))
        gd[i0:i1] = (Jd * r).sum((-1, -2))
        if fit_index:
            Jt = torch.where(m[..., None], Jt, torch.zeros_like(Jt))
            Hdt[i0:i1] = torch.einsum("pab,pabk->pk", Jd, Jt)
            Htt_p[i0:i1] = torch.einsum("pabk,pabl->pkl", Jt, Jt)
            gt_p[i0:i1] = torch.einsum("pabk,pab->pk", Jt, r)
    _, sg, sdiag = fit.smooth(d)
    Hdd, gd = Hdd + sdiag.reshape(-1) / 2, gd + sg.reshape(-1) / 2  # of ½L
    if not fit_index:
        return _Normal(Hdd, gd, None, None, None)
    median = torch.where(fit.has_data, sse, math.nan).nanmedian()  # (a pixel without data has misfit 0: no say)
    inlier = (sse <= INLIER_MISFIT_RATIO * median).to(dtype)  # robust: stray-order pixels do not steer n
    return _Normal(Hdd, gd, Hdt * inlier[:, None], (Htt_p * inlier[:, None, None]).sum(0),
                   (gt_p * inlier[:, None]).sum(0))



def _damped_step(fit, theta, d, sse, system, mu, loss0):
    """One Levenberg–Marquardt step from (θ, d): solve the damped arrow-shaped system by the Schur
    complement of the per-pixel block, raising μ until the objective falls below ``loss0``.

    Returns ``(theta, d, sse, mu, accepted)`` — unchanged with accepted False when μ passes
    ``LM_DAMPING_MAX``."""
    tiny = torch.finfo(fit.Y.dtype).tiny
    while mu < LM_DAMPING_MAX:
        Hd = system.Hdd * (1 + mu) + tiny
        if system.Htt is not None:
            Hdt = system.Hdt
            S = (system.Htt + mu * torch.diag(torch.diagonal(system.Htt))
                 - torch.einsum("pk,pl->kl", Hdt / Hd[:, None], Hdt))
            rhs = -system.gt + (Hdt * (system.gd / Hd)[:, None]).sum(0)
            dth = torch.linalg.solve(S, rhs)
            dd_step = -(system.gd + Hdt @ dth) / Hd
        else:
            dth = torch.zeros_like(theta)
            dd_step = -system.gd / Hd
        dd_step = dd_step.clamp(-MAX_THICKNESS_STEP, MAX_THICKNESS_STEP)  # stay in the current interference order
        th_new, d_new = theta + dth, (d + dd_step).clamp_min(0.0)
        sse_new = fit.sse(th_new, d_new)
        if fit.total(sse_new, d_new) < loss0:
            return th_new, d_new, sse_new, max(mu / LM_DAMPING_DECREASE, LM_DAMPING_MIN), True
        mu *= LM_DAMPING_INCREASE
    return theta, d, sse, mu, False



def _lm_fit(fit, theta, d, *, iterations, fit_index, tol, progress):
    """Up to ``iterations`` Levenberg–Marquardt iterations; stops when a step is refused or the
    objective falls by no more than ``tol`` (relative); ``progress(iterations done)`` after each, if given.
    → ``(theta, d, sse, history, iterations run)``."""
    history = []
    sse = fit.sse(theta, d)
    mu = LM_DAMPING_START
    it_done = 0
    for it in range(iterations):
        system = _normal_equations(fit, theta, d, sse, fit_index)
        loss0 = fit.total(sse, d)
        theta, d, sse, mu, accepted = _damped_step(fit, theta, d, sse, system, mu, loss0)
        it_done = it + 1
        history.append(fit.total(sse, d))
        if progress is not None:
            progress(it_done)
        if not accepted or (loss0 - history[-1]) <= tol * loss0:
            break
    return theta, d, sse, history, it_done



def _order_check(fit, theta, d, sse):
    """Re-test every pixel at d ± one order period T = λ_mid/(2√(n²−sin²θ)) (``ORDER_CHECK_ITERATIONS``
    d-only steps each) and keep the best order → ``(d, sse, pixels reordered)``."""
    terms = fit.terms(theta)
    lam_mid = fit.lam.median()
    n_mid = index_model(lam_mid, theta, fit.model)
    s2 = (fit.band["n_incident"] ** 2) * (1 - fit.c * fit.c)
    T = float(lam_mid) / (2 * float(torch.sqrt(n_mid ** 2 - s2).mean()))
    Dn, S = d_only_gauss_newton(fit.data, order_candidates(d, T), terms, iterations=ORDER_CHECK_ITERATIONS)
    best = S.argmin(-1)
    changed = (best != 1) & fit.has_data  # (a pixel without data scores every order 0: no choice)
    reordered = int(changed.sum())
    if reordered:
        d = torch.where(changed, Dn.gather(-1, best[:, None])[:, 0], d)
        sse = fit.sse(theta, d)
    return d, sse, reordered



@_autograd.fits_with_autograd  # (autograd inside: a caller's inference mode must not switch it off)
def refine_film(cube, wavelength, cos_theta, n_substrate, thickness_init, index_init, *, index_model_name="constant",
                bandwidth=4.0, passband="box", polarization="unpolarized", n_incident=1.0, smoothness: float = 0.0,
                iterations: int = 12, fit_index: bool = True, order_check: bool = True, tol: float = 1e-7,
                progress=None) -> RefineResult:
    r"""Joint Levenberg–Marquardt fit of the shared index model and per-pixel thickness (module docstring).

    Args:
        cube: ``(*, A, B)`` (an image ``(H, W, A, B)`` enables ``smoothness``).
        wavelength: ``(B,)`` nm; cos_theta ``(A,)``; n_substrate: real.
        thickness_init: ``(*)`` starting d (nm), e.g. from ``peak_method()``.
        index_init: ``(K,)`` starting index parameters (or a number: A, the rest 0).
        index_model_name: ``"constant"``, ``"cauchy"`` or ``"cauchy3"``.
        bandwidth, passband, polarization, n_incident: the band model
            (``band_terms()``; Kobayashi et al.'s camera: ``polarization="s"``).
        smoothness: μ_s ≥ 0 (reflectance² per nm²), only for an image cube.
        iterations: at most this many joint iterations (≥ 0).
        fit_index: False keeps the index fixed (thickness only).
        order_check: re-test d ± one order period per pixel at the end.
        tol: stop when an iteration lowers the objective by less than this fraction.
        progress: ``None`` or a callable ``progress(done, total)``: ``done`` steps out of
            ``total = iterations`` (+ 1 with ``order_check``), after each joint iteration and
            after the order check; a fit that stops early (``tol``, a refused step) skips to
            ``done = iterations``; the last call has ``done == total``.

    Returns:
        :class:`RefineResult`; dtype and device follow cube, wavelength and cos_theta.

    Example (a 4 × 4 pixel synthetic cube of MgF₂, n = 1.37, 360–440 nm thick, from n = 1.35 and
    d = 400 nm everywhere):
        >>> from torchirid.estimation import synthetic_cube
        >>> c = synthetic_cube("mgf2_400", height=4, width=4, seed=1)
        >>> d0 = torch.full((4, 4), 400.0, dtype=torch.float64)  # nm, e.g. peak_method's thickness
        >>> r = refine_film(c.cube, c.wavelength, c.cos_theta, 1.64, d0, 1.35, iterations=5)
        >>> round(float(r.params[0]), 2), bool((r.thickness - c.thickness).abs().max() < 1.0)  # d within 1 nm
        (1.37, True)
    """
    band = dict(bandwidth=bandwidth, passband=passband, n_incident=n_incident, polarization=polarization)
    if progress is not None and not callable(progress):
        raise ValueError(f"progress must be None or a callable progress(done, total); got {progress!r}")
    fit, theta, d = _refine_inputs(cube, wavelength, cos_theta, n_substrate, thickness_init, index_init,
                                   index_model_name, band, smoothness, iterations, tol)
    total = iterations + int(bool(order_check))
    theta, d, sse, history, it_done = _lm_fit(fit, theta, d, iterations=iterations, fit_index=fit_index, tol=tol,
                                              progress=None if progress is None else (lambda done: progress(done, total)))
    if progress is not None and (it_done < iterations or total == 0):
        progress(iterations, total)  # stopped early (or nothing to do)
    reordered = 0
    if order_check:
        d, sse, reordered = _order_check(fit, theta, d, sse)
        if progress is not None:
            progress(total, total)
    # a pixel without a single finite sample has no estimate (its residuals were 0 by the NaN fill)
    empty = ~fit.valid.any(-1).any(-1)
    d, sse = torch.where(empty, math.nan, d), torch.where(empty, math.nan, sse)
    return RefineResult(params=theta, index_model=index_model_name, thickness=d.reshape(fit.batch),
                        sse=sse.reshape(fit.batch), history=history, iterations=it_done, reordered=reordered)

