r"""Scatterogram matching by autograd: recover a rough Bragg layer from its scatterogram.

:func:`match_scatterogram` recovers the parameters of one rough Bragg layer — the period
Λ (nm), δ (the fraction of Λ in the high-index layer, as in
:mod:`~torchirid.layered.presets`), the index contrast n2 − n1 (n1 fixed, or fitted), the
number of cells N and the GGX roughness α — from a target scatterogram (one or several
narrow-beam incidences and/or the white environment of
:func:`~torchirid.layered.scatterograms.scatterogram`) whose exposure is unknown
(Fourneau et al. 2024 §5).

The loss lives in CIE L*a*b* (D65): the target is normalised once so that its brightest Y
is 1, the model is multiplied by a free exposure ``s = exp(log s)`` (started at the
closed-form least-squares scale in XYZ and then optimised with the other parameters), and
the loss is the mean over the disc of ``|Lab(s · model) − Lab(target)|²`` (ΔE*ab², smooth:
L-BFGS friendly); :func:`scatterogram_loss` evaluates it. The mean CIEDE2000 is reported.

Iridescence makes the loss in Λ strongly multimodal (the hue cycles as the Bragg peak
sweeps the visible), so the search is coarse to fine:

1. **grid in Λ** (no gradients): every ``period_step`` nm over ``period_range`` with the
   other parameters at their start values and N at its middle candidate, the exposure in
   closed form; the ``starts`` best local minima (at least 15 nm apart) are kept;
2. **refine each start** with L-BFGS (strong-Wolfe line search) over
   (Λ, δ, n2 − n1, α, log s) for ``short_iter`` iterations; the best start wins;
3. **enumerate N** over ``cells`` around the winner (warm start, n2 − n1 rescaled to keep
   N (n2 − n1) — roughly the peak reflectance — constant), ``short_iter`` iterations each;
4. **polish** the best N for up to ``max_iter`` iterations.

Parameters are optimised unconstrained: Λ in units of 10 nm, δ through a logistic,
n2 − n1, α and s through logarithms.

Reading and writing measured scatterograms (PNG, OpenEXR) is in :mod:`torchirid.fitting.measured`.
"""

from __future__ import annotations

import math
import numbers
import time
from dataclasses import dataclass, field

import numpy as np
import torch

from .. import _checks
from ..color import delta_e_2000, xyz_to_lab
from ..layered.structure import LayeredBragg, RoughBraggLayer
from ..layered.scatterograms import (
    PROJECTIONS,
    scatterogram,
    scatterogram_directions,
)

__all__ = [
    "DEFAULT_CELLS",
    "DEFAULT_INIT",
    "ScatterogramFit",
    "bragg_structure",
    "match_scatterogram",
    "render_targets",
    "scatterogram_loss",
]

#: the candidate numbers of cells N enumerated by default
DEFAULT_CELLS = tuple(range(4, 13))
#: the generic start (Λ is replaced by the grid search): δ, n1, n2 − n1, α
DEFAULT_INIT = {"period": 200.0, "delta": 0.5, "n1": 1.6, "dn": 0.06, "alpha": 0.1}
#: default wavelengths of the fit: 380–780 nm in 10 nm steps
DEFAULT_FIT_WAVELENGTHS = (380.0, 780.0, 41)
_LOSSES = ("lab", "de2000")


# ----------------------------------------------------------------------------------------
# the model
# ----------------------------------------------------------------------------------------
def bragg_structure(period, delta, n1, n2, cells: int, alpha, *, n_incident: float = 1.0,
                    base_albedo: float = 0.0) -> LayeredBragg:
    """One rough Bragg layer ``d2 = δΛ``, ``d1 = (1 − δ)Λ`` (the preset convention) as a
    :class:`~torchirid.layered.structure.LayeredBragg`; tensor parameters keep their graph.

    >>> s = bragg_structure(160.0, 0.51, 1.59, 1.67, 8, 0.05)
    >>> l = s.layers[0]
    >>> round(l.d1, 6), round(l.d2, 6), l.n_incident
    (78.4, 81.6, 1.0)
    """
    layer = RoughBraggLayer(n1, n2, (1.0 - delta) * period, delta * period, cells, alpha, n_incident=n_incident)
    return LayeredBragg([layer], base_albedo=base_albedo)


def _check_incident(incident_deg) -> list:
    """``incident_deg``: one illumination (None or (θ, φ)) or a list of them → list."""
    if incident_deg is None or (isinstance(incident_deg, (tuple, list)) and len(incident_deg) == 2
                            and all(isinstance(v, numbers.Real) for v in incident_deg)):
        return [incident_deg]
    if not isinstance(incident_deg, (tuple, list)) or not incident_deg:
        raise ValueError(f"incident_deg must be None, (theta_deg, phi_deg) or a non-empty list of them; got {incident_deg!r}")
    out = []
    for inc in incident_deg:
        if inc is not None and not (isinstance(inc, (tuple, list)) and len(inc) == 2
                                    and all(isinstance(v, numbers.Real) for v in inc)):
            raise ValueError(f"incident_deg must be None, (theta_deg, phi_deg) or a list of them; got item {inc!r}")
        out.append(None if inc is None else (float(inc[0]), float(inc[1])))
    return out


def render_targets(structure, incident_deg, *, resolution: int, wavelength=None, projection: str = "equidistant",
                   lut: bool = False) -> torch.Tensor:
    """The scatterograms of ``structure`` under each illumination of ``incident_deg`` stacked:
    ``(K, H, W, 3)`` XYZ (differentiable, see :func:`~torchirid.layered.scatterograms.scatterogram`)."""
    incs = _check_incident(incident_deg)
    return torch.stack([scatterogram(structure, incident_deg=inc, resolution=resolution, wavelength=wavelength,
                                     projection=projection, lut=lut).xyz for inc in incs])


# ----------------------------------------------------------------------------------------
# the loss
# ----------------------------------------------------------------------------------------
def _lsq_scale(model: torch.Tensor, target: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """Closed-form least-squares exposure argmin_s Σ_mask |s·model − target|² (XYZ)."""
    m, t = model[mask], target[mask]
    den = (m * m).sum()
    tiny = torch.finfo(m.dtype).tiny
    return (m * t).sum() / den.clamp_min(tiny)  # guard: an all-black model gets a finite scale


def scatterogram_loss(model_xyz, target_xyz, mask=None, *, scale=None, loss: str = "lab") -> torch.Tensor:
    r"""Exposure-robust perceptual loss between two stacks of scatterograms.

    Args:
        model_xyz, target_xyz: ``(*, H, W, 3)`` XYZ (same shape; the target normalised so
            that its white has Y = 1 — :func:`match_scatterogram` divides by its peak Y).
        mask: ``(H, W)`` (or broadcastable to ``(*, H, W)``) bool, the pixels compared;
            default all.
        scale: the exposure applied to the model (number or tensor); ``None``: the
            closed-form least-squares scale in XYZ, so the loss does not change when the
            model (or, with a matching target, the target) is multiplied by a constant.
        loss: ``"lab"`` — mean ΔE*ab² (squared Euclidean distance in CIE L*a*b*, D65) — or
            ``"de2000"`` — mean CIEDE2000.

    Returns:
        a 0-dim tensor (differentiable in both inputs and ``scale``).

    >>> t = torch.rand(2, 5, 5, 3, dtype=torch.float64, generator=torch.Generator().manual_seed(0))
    >>> float(scatterogram_loss(3.7 * t, t)) < 1e-20  # exposure invariance
    True
    """
    if loss not in _LOSSES:
        raise ValueError(f"loss must be one of {_checks.names(_LOSSES)}; got {loss!r}")
    model_xyz = torch.as_tensor(model_xyz)
    target_xyz = torch.as_tensor(target_xyz)
    if model_xyz.shape != target_xyz.shape or model_xyz.dim() < 3 or model_xyz.shape[-1] != 3:
        raise ValueError(f"model_xyz and target_xyz must share a shape (*, H, W, 3); got {tuple(model_xyz.shape)} "
                         f"and {tuple(target_xyz.shape)}")
    if mask is None:
        mask = torch.ones(model_xyz.shape[:-1], dtype=torch.bool, device=model_xyz.device)
    mask = torch.as_tensor(mask, dtype=torch.bool, device=model_xyz.device).expand(model_xyz.shape[:-1])
    if scale is None:
        scale = _lsq_scale(model_xyz, target_xyz, mask)
    lab_m = xyz_to_lab(scale * model_xyz[mask])
    lab_t = xyz_to_lab(target_xyz[mask])
    if loss == "lab":
        return ((lab_m - lab_t) ** 2).sum(-1).mean()
    return delta_e_2000(lab_m, lab_t).mean()


# ----------------------------------------------------------------------------------------
# the fit
# ----------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ScatterogramFit:
    """The result of :func:`match_scatterogram`.

    Attributes:
        period, delta, n1, n2, alpha: the recovered layer (nm, fraction, indices, roughness).
        cells: the recovered number of cells N.
        exposure: the scale ``s`` that maps the model onto the target *as given*
            (``target ≈ s · model``).
        loss: the final loss (mean ΔE*ab², or mean ΔE00 with ``loss="de2000"``).
        delta_e2000: mean CIEDE2000 over the disc between the fitted and the target images.
        delta_e2000_lit: the same over the lit pixels (target L* > 5 after normalisation).
        iterations: L-BFGS iterations in all stages; evaluations: renders (with and without gradients).
        seconds: wall time of the fit.
        stages: a JSON-ready log of the stages (grid minima, starts, N enumeration, polish).
    """

    period: float
    delta: float
    n1: float
    n2: float
    cells: int
    alpha: float
    exposure: float
    loss: float
    delta_e2000: float
    delta_e2000_lit: float
    iterations: int
    evaluations: int
    seconds: float
    stages: dict = field(default_factory=dict, repr=False)

    def structure(self, *, n_incident: float = 1.0, base_albedo: float = 0.0) -> LayeredBragg:
        """The recovered layer as a structure (float parameters)."""
        return bragg_structure(self.period, self.delta, self.n1, self.n2, self.cells, self.alpha,
                               n_incident=n_incident, base_albedo=base_albedo)

    def numbers(self) -> dict:
        """JSON-ready parameters and figures (no stage log)."""
        keys = ("period", "delta", "n1", "n2", "cells", "alpha", "exposure", "loss", "delta_e2000",
                "delta_e2000_lit", "iterations", "evaluations", "seconds")
        return {k: getattr(self, k) for k in keys}


class _Problem:
    """Target, renderer and the unconstrained parametrisation shared by the stages."""

    def __init__(self, target, mask, incs, lam, projection, lut, n_incident, base_albedo, fit_n1, loss):
        self.target, self.mask, self.incs, self.lam = target, mask, incs, lam
        self.projection, self.lut, self.n_incident, self.base_albedo = projection, lut, n_incident, base_albedo
        self.fit_n1, self.loss_name = fit_n1, loss
        self.resolution = target.shape[-2]
        self.full_mask = mask.expand(target.shape[:-1])
        self.evaluations = 0
        self.iterations = 0

    # x = [Λ/10, logit δ, log Δn, log α, log s, (log n1)]
    def params(self, x, n1_fixed):
        period = 10.0 * x[0]
        delta = torch.sigmoid(x[1])
        dn = torch.exp(x[2])
        alpha = torch.exp(x[3])
        n1 = torch.exp(x[5]) if self.fit_n1 else torch.as_tensor(n1_fixed, dtype=x.dtype)
        return period, delta, n1, n1 + dn, alpha, torch.exp(x[4])

    def encode(self, period, delta, n1, dn, alpha, scale):
        v = [period / 10.0, math.log(delta / (1.0 - delta)), math.log(dn), math.log(alpha), math.log(scale)]
        if self.fit_n1:
            v.append(math.log(n1))
        return torch.tensor(v, dtype=self.target.dtype)

    def render(self, period, delta, n1, n2, cells, alpha):
        self.evaluations += 1
        s = bragg_structure(period, delta, n1, n2, cells, alpha, n_incident=self.n_incident, base_albedo=self.base_albedo)
        return render_targets(s, self.incs, resolution=self.resolution, wavelength=self.lam,
                              projection=self.projection, lut=self.lut)

    def loss(self, model, scale=None):
        return scatterogram_loss(model, self.target, self.full_mask, scale=scale, loss=self.loss_name)

    def objective(self, x, cells, n1_fixed):
        period, delta, n1, n2, alpha, scale = self.params(x, n1_fixed)
        return self.loss(self.render(period, delta, n1, n2, cells, alpha), scale)

    def refine(self, x0, cells, n1_fixed, iterations):
        """L-BFGS from ``x0`` for up to ``iterations`` iterations → (x, loss)."""
        x = x0.clone().requires_grad_(True)
        opt = torch.optim.LBFGS([x], lr=1.0, max_iter=iterations, history_size=20, line_search_fn="strong_wolfe",
                                tolerance_grad=1e-9, tolerance_change=1e-12)
        best = {"loss": math.inf, "x": x0.clone()}

        def closure():
            opt.zero_grad()
            value = self.objective(x, cells, n1_fixed)
            if not torch.isfinite(value):  # guard: a step into an invalid region is rejected by the line search
                return value
            value.backward()
            if float(value.detach()) < best["loss"]:
                best["loss"], best["x"] = float(value.detach()), x.detach().clone()
            return value

        try:
            opt.step(closure)
        except ValueError:  # a line-search trial left the layer's valid range (e.g. δ rounding to 0 or 1)
            pass
        self.iterations += opt.state[opt._params[0]].get("n_iter", 0)
        return best["x"], best["loss"]


def _check_range(name, value, lo=0.0):
    if (not isinstance(value, (tuple, list)) or len(value) != 2
            or not all(isinstance(v, numbers.Real) and not isinstance(v, bool) for v in value)
            or not lo < value[0] < value[1]):
        raise ValueError(f"{name} must be a pair (low, high) with {lo} < low < high; got {value!r}")
    return float(value[0]), float(value[1])


@_checks.fits_with_autograd  # (autograd inside: a caller's inference mode must not switch it off)
def match_scatterogram(
    target_xyz,
    mask=None,
    *,
    incident_deg=(0.0, 0.0),
    n1: float = DEFAULT_INIT["n1"],
    fit_n1: bool = False,
    cells=DEFAULT_CELLS,
    init: dict | None = None,
    period_range=(100.0, 350.0),
    period_step: float = 2.0,
    starts: int = 3,
    short_iter: int = 15,
    max_iter: int = 60,
    wavelength=None,
    projection: str = "equidistant",
    lut: bool = False,
    n_incident: float = 1.0,
    base_albedo: float = 0.0,
    loss: str = "lab",
    log=None,
) -> ScatterogramFit:
    r"""Recover (Λ, δ, n2 − n1, N, α) of one rough Bragg layer from a target scatterogram.

    The target is what :func:`~torchirid.layered.scatterograms.scatterogram` renders (or
    :func:`load_scatterogram` reads) for each illumination of ``incident_deg``, at any unknown
    exposure; the strategy (Λ grid → multi-start L-BFGS → N enumeration → polish) and the
    loss are described in the module docstring.

    Args:
        target_xyz: ``(K, H, W, 3)`` (or ``(H, W, 3)`` for one illumination) XYZ, ``H = W``
            the scatterogram resolution; any positive overall scale.
        mask: ``(H, W)`` bool, the pixels to compare (default: the disc of
            :func:`~torchirid.layered.scatterograms.scatterogram_directions`); False for
            saturated or missing pixels of a measurement.
        incident_deg: the K illuminations, each ``(θ_i, φ_i)`` in degrees or ``None`` (white
            environment); one illumination alone may be given bare.
        n1: the low index (fixed unless ``fit_n1``; then the start value).
        fit_n1: also fit n1 (weakly identifiable: the period absorbs most of it).
        cells: the candidate numbers of cells N (integers ≥ 1), enumerated.
        init: start values ``{"delta", "dn", "alpha"}`` (and ``"period"``, used only when
            ``period_range`` is None: no grid search); defaults :data:`DEFAULT_INIT`.
        period_range: ``(low, high)`` nm of the Λ grid; ``None`` to start from ``init["period"]``.
        period_step: grid step in nm (> 0).
        starts: how many grid minima are refined (≥ 1).
        short_iter: L-BFGS iterations per start and per N candidate.
        max_iter: L-BFGS iterations of the final polish.
        wavelength: ``(W,)`` nm of the model's spectra (default 380–780 nm, 41 values).
        projection: the scatterogram's angular mapping (see
            :data:`~torchirid.layered.scatterograms.PROJECTIONS`).
        lut: render the mirrors' reflectance from a per-call angle table.
        n_incident, base_albedo: the medium above the layer and the base (the jewel-beetle
            presets: air, black).
        loss: ``"lab"`` (mean ΔE*ab², default) or ``"de2000"`` (mean ΔE00).
        log: optional callable receiving one progress string per stage.

    Returns:
        a :class:`ScatterogramFit`.

    Raises:
        ValueError: a bad argument, named, before any work.

    Example (a tiny 12-pixel image, from a start 6 nm away; no grid, N known):
        >>> from torchirid.layered.presets import jewel_beetle
        >>> t = render_targets(jewel_beetle("green"), [(0.0, 0.0), (40.0, 0.0)], resolution=12,
        ...                    wavelength=torch.linspace(380.0, 780.0, 41, dtype=torch.float64))
        >>> fit = match_scatterogram(2.5 * t, incident_deg=[(0.0, 0.0), (40.0, 0.0)], n1=1.59, cells=(8,),
        ...                          period_range=None, init={"period": 166.0, "delta": 0.51, "dn": 0.08,
        ...                          "alpha": 0.05}, short_iter=5, max_iter=20)
        >>> abs(fit.period - 160.0) < 0.5
        True
    """
    t_start = time.perf_counter()
    incs = _check_incident(incident_deg)
    target = torch.as_tensor(target_xyz)
    if not target.is_floating_point():
        raise ValueError(f"target_xyz must be a floating tensor; got dtype {target.dtype}")
    if target.dim() == 3:
        target = target.unsqueeze(0)
    if target.dim() != 4 or target.shape[-1] != 3 or target.shape[1] != target.shape[2]:
        raise ValueError("target_xyz must have shape (K, H, H, 3) or (H, H, 3); got "
                         f"{tuple(torch.as_tensor(target_xyz).shape)}")
    if target.shape[0] != len(incs):
        raise ValueError(f"target_xyz holds {target.shape[0]} scatterograms but incident_deg names {len(incs)} "
                         "illuminations")
    if projection not in PROJECTIONS:
        raise ValueError(f"projection must be one of {_checks.names(PROJECTIONS)}; got {projection!r}")
    if loss not in _LOSSES:
        raise ValueError(f"loss must be one of {_checks.names(_LOSSES)}; got {loss!r}")
    if isinstance(n1, bool) or not isinstance(n1, numbers.Real) or not n1 > 0:
        raise ValueError(f"n1 must be a real number > 0; got {n1!r}")
    cells = tuple(cells) if isinstance(cells, (tuple, list, range)) else cells
    if not isinstance(cells, tuple) or not cells or not all(
            isinstance(c, int) and not isinstance(c, bool) and c >= 1 for c in cells):
        raise ValueError(f"cells must be a non-empty sequence of integers >= 1; got {cells!r}")
    cells = tuple(sorted(set(cells)))
    start = dict(DEFAULT_INIT)
    if init is not None:
        if not isinstance(init, dict) or not set(init) <= {"period", "delta", "dn", "alpha"}:
            raise ValueError(f"init must be a dict with keys among period, delta, dn, alpha; got {init!r}")
        start.update({k: float(v) for k, v in init.items()})
    if not (0.0 < start["delta"] < 1.0 and start["dn"] > 0 and start["alpha"] > 0 and start["period"] > 0):
        raise ValueError(f"init needs 0 < delta < 1 and period, dn, alpha > 0; got {start!r}")
    if period_range is not None:
        period_range = _check_range("period_range", period_range)
    if isinstance(period_step, bool) or not isinstance(period_step, numbers.Real) or not period_step > 0:
        raise ValueError(f"period_step must be a number > 0 (nm); got {period_step!r}")
    starts = _checks.check_int(starts, "starts")
    short_iter = _checks.check_int(short_iter, "short_iter")
    max_iter = _checks.check_int(max_iter, "max_iter", 0)
    dtype = target.dtype
    res = target.shape[1]
    _, disc = scatterogram_directions(res, projection=projection, dtype=dtype)
    if mask is None:
        mask = disc
    mask = torch.as_tensor(mask, dtype=torch.bool)
    if mask.shape != (res, res):
        raise ValueError(f"mask must have shape ({res}, {res}); got {tuple(mask.shape)}")
    mask = mask & disc
    if not bool(mask.any()):
        raise ValueError("mask selects no pixel of the disc")
    peak = target[..., 1][mask.expand(target.shape[:-1])].max()
    if not bool(peak > 0):
        raise ValueError("target_xyz has no pixel with Y > 0 inside the mask")
    if wavelength is None:
        lam = torch.linspace(*DEFAULT_FIT_WAVELENGTHS[:2], DEFAULT_FIT_WAVELENGTHS[2], dtype=dtype)
    else:
        lam = _checks.as_real(wavelength, "wavelength", dtype, torch.device("cpu"))
    say = log if callable(log) else (lambda s: None)

    norm = float(peak)
    target_n = target.detach() / norm
    prob = _Problem(target_n, mask, incs, lam, projection, lut, float(n_incident), float(base_albedo), bool(fit_n1), loss)
    stages: dict = {}
    n_mid = cells[len(cells) // 2]

    # 1. grid in Λ (no gradients; exposure in closed form)
    if period_range is None:
        seeds = [start["period"]]
    else:
        lo, hi = period_range
        grid = np.arange(lo, hi + 1e-9, float(period_step))
        values = []
        with torch.no_grad():
            for p in grid:
                model = prob.render(float(p), start["delta"], float(n1), float(n1) + start["dn"], n_mid, start["alpha"])
                values.append(float(prob.loss(model)))
        values = np.asarray(values)
        order = np.argsort(values)
        local = [i for i in order if (i == 0 or values[i] <= values[i - 1])
                 and (i == len(values) - 1 or values[i] <= values[i + 1])]
        seeds = []
        for i in local:
            if all(abs(grid[i] - s) >= 15.0 for s in seeds):
                seeds.append(float(grid[i]))
            if len(seeds) == starts:
                break
        stages["grid"] = {"periods_nm": [float(grid[0]), float(grid[-1]), len(grid)], "cells": n_mid,
                          "minima": [[s, float(values[np.argmin(np.abs(grid - s))])] for s in seeds]}
        say(f"grid: {len(grid)} periods, minima at {', '.join(f'{s:.0f}' for s in seeds)} nm")

    def x_start(period, cells_n, dn=start["dn"], delta=start["delta"], alpha=start["alpha"], n1v=float(n1)):
        with torch.no_grad():
            model = prob.render(period, delta, n1v, n1v + dn, cells_n, alpha)
            s = float(_lsq_scale(model, target_n, prob.full_mask))
        return prob.encode(period, delta, n1v, dn, alpha, s if s > 0 else 1.0)

    # 2. refine each start at the middle N
    results = []
    for p in seeds:
        x, value = prob.refine(x_start(p, n_mid), n_mid, n1, short_iter)
        results.append((value, x, n_mid))
        say(f"start {p:.1f} nm → Λ {10 * float(x[0]):.2f} nm, loss {value:.4g}")
    results.sort(key=lambda r: r[0])
    stages["starts"] = [[10 * float(x[0]), v] for v, x, _ in results]
    best_value, best_x, best_n = results[0]

    # 3. enumerate N (warm start, N·Δn kept)
    tried = {best_n: (best_value, best_x)}
    for c in cells:
        if c in tried:
            continue
        x0 = best_x.clone()
        x0[2] = x0[2] + math.log(best_n / c)
        x, value = prob.refine(x0, c, n1, short_iter)
        tried[c] = (value, x)
        say(f"N = {c}: loss {value:.4g}")
    stages["cells"] = {str(c): v for c, (v, _) in sorted(tried.items())}
    best_n = min(tried, key=lambda c: tried[c][0])
    best_value, best_x = tried[best_n]

    # 4. polish
    if max_iter > 0:
        x, value = prob.refine(best_x, best_n, n1, max_iter)
        if value <= best_value:
            best_value, best_x = value, x
    say(f"polish N = {best_n}: loss {best_value:.4g}")

    with torch.no_grad():
        period, delta, n1v, n2v, alpha, scale = prob.params(best_x, n1)
        model = prob.render(period, delta, n1v, n2v, best_n, alpha)
        full = prob.full_mask
        lab_m = xyz_to_lab(scale * model[full])
        lab_t = xyz_to_lab(target_n[full])
        de = delta_e_2000(lab_m, lab_t)
        lit = lab_t[:, 0] > 5.0
        de_lit = float(de[lit].mean()) if bool(lit.any()) else float("nan")
    return ScatterogramFit(
        period=float(period), delta=float(delta), n1=float(n1v), n2=float(n2v), cells=int(best_n),
        alpha=float(alpha), exposure=float(scale) * norm, loss=float(best_value), delta_e2000=float(de.mean()),
        delta_e2000_lit=de_lit, iterations=prob.iterations, evaluations=prob.evaluations,
        seconds=time.perf_counter() - t_start, stages=stages,
    )
