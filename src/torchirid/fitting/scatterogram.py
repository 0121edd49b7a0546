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
4. **polish** the best N for up to ``max_iter`` iterations;
5. **harmonics**: refit the result at each period factor k of ``harmonics`` (Λ/2, 2Λ, 2Λ/3,
   3Λ/2, Λ/3, 3Λ by default) whose k·Λ lies inside ``period_range`` (Λ within k·Λ ÷× 1.08,
   δ started at the maxima of the harmonic's Bragg order, N near N/k, N/√k or N); a refit
   with a lower loss replaces the result (stages 3–4 rerun around it), and every one is
   listed in :attr:`ScatterogramFit.alternatives` with its loss and ΔE00 — near-degenerate,
   and the fit :attr:`~ScatterogramFit.ambiguous`, when its render lies within
   ``ambiguity_de2000`` (mean CIEDE2000 over the lit pixels, default 1) of the fit's.

Every parameter stays inside the range it is given: L-BFGS runs on unconstrained
coordinates mapped through a scaled logistic onto ``period_range`` (Λ; each harmonic's
window), ``delta_range`` (δ, by default (0, 1)), and in log onto ``dn_range``,
``alpha_range`` and ``n1_range`` (n2 − n1, α, n1), so no line-search step can leave them.
Without a range Λ is optimised in units of 10 nm and n2 − n1, α, n1 through logarithms;
the exposure s always through its logarithm.

**What a visible-only scatterogram identifies.** A layer of period Λ reflects in order m at
λ_m ≈ 2 n̄ Λ cos θ / m (n̄ = (1 − δ) n1 + δ n2), with a strength that grows with
N (n2 − n1) |sin(mπδ)| / m. Seen only between 380 and 780 nm, the first-order peak of Λ is
also the second-order peak of 2Λ (δ near 1/4 or 3/4, fewer cells, a larger contrast) and the
third-order peak of 3Λ (δ near 1/2): the *order* of the visible peak, hence Λ up to these
harmonics, is not identified, and neither is N once N (n2 − n1) is. Measured on a synthetic
target (Λ = 178 nm, δ = 0.6, N = 10, α = 0.03, n1 = 1.6, n2 = 1.66; beams at 0°, 30°, 60°;
32 px, 1 % noise; the true layer's loss against it, the noise floor, is 0.037, its mean
ΔE00 over the lit pixels 0.59):

* the fit (Λ 178.2 nm, δ 0.60, N 11, α 0.0301) has loss 0.036; its 2Λ refit
  (Λ 354.6 nm, δ 0.29, N 5, n2 − n1 = 0.137) loss 0.046, ΔE00 0.33 from the fit's render over
  the lit pixels: indistinguishable (flagged);
* its 3Λ refit (Λ 525.7 nm, δ 0.49, N 6) has loss 0.090, ΔE00 0.71 from the fit's render:
  below the just-noticeable difference (flagged); the search's own third-order optimum
  (Λ 530.4 nm, N 10) had loss 0.074;
* 2Λ/3 and 3Λ/2 of a first-order fit are no Bragg harmonic (no integer order lands on the
  peak): loss above 10, ΔE00 above 10 — excluded; Λ/2 and Λ/3 would put the first order in
  the ultraviolet;
* N: with n2 − n1 free, N = 7 … 12 all fit within 7 % of the noise floor (N = 6: 2.6 times it);
* identified: the Bragg wavelength 2 n̄ Λ / m of the visible peak and its shift with
  incidence, the roughness α (the width of each beam's lobe: 0.0301 for 0.03) and the
  exposure; n1 only weakly (``fit_n1``: the period absorbs it).

Only a prior decides between the harmonics: a ``period_range`` from another measurement
(an electron micrograph of the cross-section, an infrared or ultraviolet spectrum, which see
the other orders), or ranges on δ and n2 − n1 that exclude the harmonic's layer (on the same
target at 12 px, ``dn_range=(0.02, 0.1)`` leaves the 2Λ refit at loss 4.3 and ΔE00 1.7 from
the fit, ``delta_range=(0.4, 0.6)`` at loss 12.8 and ΔE00 3.0: no longer ambiguous).

Reading and writing measured scatterograms (PNG, OpenEXR) is in :mod:`torchirid.fitting.measured`.
"""

from __future__ import annotations

import itertools
import math
import numbers
import time
from dataclasses import dataclass, field
from fractions import Fraction

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
    "ScatterogramAlternative",
    "ScatterogramFit",
    "bragg_structure",
    "match_scatterogram",
    "render_targets",
    "scatterogram_loss",
]

#: the candidate numbers of cells N enumerated by default
DEFAULT_CELLS = tuple(range(4, 13))
#: the period factors k refitted as alternatives by default: Λ/2, 2Λ, 2Λ/3, 3Λ/2, Λ/3, 3Λ
DEFAULT_HARMONICS = (0.5, 2.0, 2.0 / 3.0, 1.5, 1.0 / 3.0, 3.0)
#: the generic start (Λ is replaced by the grid search): δ, n1, n2 − n1, α
DEFAULT_INIT = {"period": 200.0, "delta": 0.5, "n1": 1.6, "dn": 0.06, "alpha": 0.1}
#: default wavelengths of the fit: 380–780 nm in 10 nm steps
DEFAULT_FIT_WAVELENGTHS = (380.0, 780.0, 41)
_LOSSES = ("lab", "de2000")


# ----------------------------------------------------------------------------------------
# the model
# ----------------------------------------------------------------------------------------
def bragg_structure(n1, n2, period, delta, cells: int, alpha, *, n_incident: float = 1.0,
                    base_albedo: float = 0.0) -> LayeredBragg:
    """One rough Bragg layer ``d2 = δΛ``, ``d1 = (1 − δ)Λ`` (the preset convention) as a
    :class:`~torchirid.layered.structure.LayeredBragg`; tensor parameters keep their graph.

    >>> s = bragg_structure(1.59, 1.67, 160.0, 0.51, 8, 0.05)
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
    ``(K, H, W, 3)`` XYZ (differentiable, see :func:`~torchirid.layered.scatterograms.scatterogram`).

    Args:
        structure: a :class:`~torchirid.layered.structure.LayeredBragg` (or one rough layer).
        incident_deg: one illumination — ``None`` (the white environment) or ``(θ, φ)`` in
            degrees (a narrow beam) — or a list of them (K).
        resolution, wavelength, projection, lut: as
            :func:`~torchirid.layered.scatterograms.scatterogram` (wavelength in nm).

    Example (a green jewel beetle under two beams, 12 × 12 pixels each):
        >>> import torch
        >>> from torchirid.layered.presets import jewel_beetle
        >>> t = render_targets(jewel_beetle("green"), [(0.0, 0.0), (40.0, 0.0)], resolution=12,
        ...                    wavelength=torch.linspace(380.0, 780.0, 41, dtype=torch.float64))
        >>> tuple(t.shape), bool(t[..., 1].max() > 0)  # (K, H, W, XYZ)
        ((2, 12, 12, 3), True)
    """
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
    _checks.check_choice(loss, "loss", _LOSSES)
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
class ScatterogramAlternative:
    """One near-degenerate alternative of a :class:`ScatterogramFit`: the fit refitted at a
    harmonic ``k·Λ`` of its period (listed in :attr:`ScatterogramFit.alternatives`).

    Attributes:
        label: the harmonic, e.g. ``"2Λ"``, ``"Λ/2"``, ``"3Λ/2"``.
        factor: ``k`` (the alternative's period over the fit's, before the refit).
        period: the refitted Λ (nm); ``k·Λ`` when not refitted.
        refitted: False when ``k·Λ`` lies outside ``period_range`` (then every field below is None).
        note: ``"refitted"`` or why not (``"outside period_range (a, b) nm"``).
        delta, n1, n2, cells, alpha, exposure: the refitted layer, as in :class:`ScatterogramFit`.
        loss: its loss (same units as :attr:`ScatterogramFit.loss`).
        delta_e2000: mean CIEDE2000 between its render and the target over the disc
            (compare with :attr:`ScatterogramFit.delta_e2000`).
        delta_e2000_lit: the same over the target's lit pixels (L* > 5).
        delta_e2000_vs_fit: mean CIEDE2000 between its render and the best fit's render over the
            target's lit pixels (the whole mask if none is lit): how far apart the two
            explanations look.
        near_degenerate: ``delta_e2000_vs_fit < ambiguity_de2000`` (see :func:`match_scatterogram`).

    Example (the 2Λ refit of a quick fit to an 8-pixel render of a 160 nm layer; a short fit, for speed):
        >>> from torchirid.layered.presets import jewel_beetle
        >>> t = render_targets(jewel_beetle("green"), [(20.0, 0.0)], resolution=8)  # Λ = 160 nm, N = 8
        >>> fit = match_scatterogram(t, incident_deg=[(20.0, 0.0)], n1=1.59, cells=(8,), period_range=None,
        ...                          init={"period": 164.0, "delta": 0.51, "dn": 0.08, "alpha": 0.05},
        ...                          short_iter=2, max_iter=3, harmonics=(2.0,))
        >>> alt = fit.alternatives[0]
        >>> alt.label, alt.refitted, round(alt.period / fit.period, 1), alt.loss > fit.loss
        ('2Λ', True, 2.0, True)
    """

    label: str
    factor: float
    period: float
    refitted: bool
    note: str
    delta: float | None = None
    n1: float | None = None
    n2: float | None = None
    cells: int | None = None
    alpha: float | None = None
    exposure: float | None = None
    loss: float | None = None
    delta_e2000: float | None = None
    delta_e2000_lit: float | None = None
    delta_e2000_vs_fit: float | None = None
    near_degenerate: bool = False

    def numbers(self) -> dict:
        """JSON-ready fields (None where not refitted)."""
        return {f: getattr(self, f) for f in self.__dataclass_fields__}


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
        alternatives: the harmonics ``k·Λ`` of the period refitted (one
            :class:`ScatterogramAlternative` per factor of ``harmonics``, in that order; those
            outside ``period_range`` listed as not refitted).
        ambiguous: True when an alternative is near-degenerate (its render within
            ``ambiguity_de2000`` mean CIEDE2000 of the fit's): the target does not decide
            between them (see "What a visible-only scatterogram identifies" in the module docstring).
        stages: a JSON-ready log of the stages: ``ranges``; ``grid`` (the Λ grid and its minima,
            ``[Λ, loss]``); ``starts`` (``[Λ, loss]`` per refined start, best first); ``cells``
            (``{N: loss}`` of the N enumeration; ``cells_after_swap_<i>`` after a harmonic
            replaced the fit); ``polish`` (``{"cells", "loss"}`` per polish, in order);
            ``harmonics`` (the swaps and the alternatives).

    Example (a quick fit to an 8-pixel render of a 160 nm layer, from 164 nm, N known, no harmonics):
        >>> from torchirid.layered.presets import jewel_beetle
        >>> t = render_targets(jewel_beetle("green"), [(20.0, 0.0)], resolution=8)  # Λ = 160 nm, N = 8
        >>> fit = match_scatterogram(2.5 * t, incident_deg=[(20.0, 0.0)], n1=1.59, cells=(8,), period_range=None,
        ...                          init={"period": 164.0, "delta": 0.51, "dn": 0.08, "alpha": 0.05},
        ...                          short_iter=3, max_iter=5, harmonics=())
        >>> abs(fit.period - 160.0) < 3, fit.cells, fit.alternatives  # Λ in nm
        (True, 8, ())
        >>> round(fit.structure().layers[0].d1 + fit.structure().layers[0].d2, 6) == round(fit.period, 6)
        True
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
    alternatives: tuple = field(default=(), repr=False)
    ambiguous: bool = False
    stages: dict = field(default_factory=dict, repr=False)

    def structure(self, *, n_incident: float = 1.0, base_albedo: float = 0.0) -> LayeredBragg:
        """The recovered layer as a structure (float parameters)."""
        return bragg_structure(self.n1, self.n2, self.period, self.delta, self.cells, self.alpha,
                               n_incident=n_incident, base_albedo=base_albedo)

    def numbers(self) -> dict:
        """JSON-ready parameters and figures, the alternatives included (no stage log)."""
        keys = ("period", "delta", "n1", "n2", "cells", "alpha", "exposure", "loss", "delta_e2000",
                "delta_e2000_lit", "iterations", "evaluations", "seconds", "ambiguous")
        out = {k: getattr(self, k) for k in keys}
        out["alternatives"] = [a.numbers() for a in self.alternatives]
        return out


def _harmonic_label(k: float) -> str:
    """``2`` → ``"2Λ"``, ``0.5`` → ``"Λ/2"``, ``1.5`` → ``"3Λ/2"``, ``0.37`` → ``"0.37Λ"``."""
    f = Fraction(k).limit_denominator(12)
    if abs(float(f) - k) > 1e-9 * k:
        return f"{k:g}Λ"
    return ("Λ" if f.numerator == 1 else f"{f.numerator}Λ") + ("" if f.denominator == 1 else f"/{f.denominator}")


class _Space:
    """The unconstrained coordinates ``x = [u_Λ, u_δ, u_Δn, u_α, log s, (u_n1)]`` of L-BFGS and
    the bounded parameters they map to.

    A parameter with a range ``(lo, hi)`` is ``lo + (hi − lo)·σ(u/c)`` (Λ, δ) or
    ``exp(log lo + (log hi − log lo)·σ(u/c))`` (Δn, α, n1): it cannot leave its range, whatever
    step the line search tries. Without a range Λ is ``10u`` (nm) and Δn, α, n1 are ``exp(u)``;
    δ always has one (by default (0, 1), the plain logistic). Encoding a value puts it at least
    ``_EDGE`` of the range (in σ) inside, where the gradient has not vanished.
    """

    _KIND = {"period": "lin", "delta": "lin", "dn": "log", "alpha": "log", "n1": "log"}

    def __init__(self, ranges: dict, fit_n1: bool):
        self.ranges = dict(ranges)
        self.fit_n1 = fit_n1

    def with_period(self, period_range):
        out = _Space(self.ranges, self.fit_n1)
        out.ranges["period"] = period_range
        return out

    def _bounds(self, name):
        """(kind, lo, hi, c) of a bounded parameter in its linear or logarithmic coordinate, c the
        scale of u (``σ(u / c)``) that keeps the slope at the middle of the range that of the
        unbounded form: 10 nm per unit for Λ, 1 for log Δn, log α and log n1; δ keeps the plain
        logistic (c = 1)."""
        kind, r = self._KIND[name], self.ranges[name]
        lo, hi = (r[0], r[1]) if kind == "lin" else (math.log(r[0]), math.log(r[1]))
        c = (hi - lo) / 40.0 if name == "period" else 1.0 if name == "delta" else (hi - lo) / 4.0
        return kind, lo, hi, c

    def forward(self, name, u):
        if self.ranges.get(name) is None:
            return 10.0 * u if self._KIND[name] == "lin" else torch.exp(u)
        kind, lo, hi, c = self._bounds(name)
        v = lo + (hi - lo) * torch.sigmoid(u / c)
        return v if kind == "lin" else torch.exp(v)

    def inverse(self, name, value: float) -> float:
        if self.ranges.get(name) is None:
            return value / 10.0 if self._KIND[name] == "lin" else math.log(value)
        kind, lo, hi, c = self._bounds(name)
        t = ((value if kind == "lin" else math.log(value)) - lo) / (hi - lo)
        t = min(max(t, _EDGE), 1.0 - _EDGE)
        return c * math.log(t / (1.0 - t))


#: how far inside its range (in σ) a bounded parameter is encoded
_EDGE = 0.005
#: a harmonic k·Λ is refitted with Λ in [k·Λ / _WINDOW, k·Λ · _WINDOW] (∩ period_range)
_WINDOW = 1.08
#: δ tried (no gradients) to start a harmonic's refit: the maxima of |sin(mπδ)| for orders m = 1, 2, 3
_HARMONIC_DELTAS = (1.0 / 6.0, 0.25, 0.5, 0.75, 5.0 / 6.0)
#: the most harmonic refits that may replace the fit (each then re-enumerates N and polishes)
_MAX_SWAPS = 2


class _Problem:
    """Target, renderer and the parametrisation shared by the stages."""

    def __init__(self, target, mask, incs, lam, projection, lut, n_incident, base_albedo, fit_n1, n1_fixed, loss):
        self.target, self.mask, self.incs, self.lam = target, mask, incs, lam
        self.projection, self.lut, self.n_incident, self.base_albedo = projection, lut, n_incident, base_albedo
        self.fit_n1, self.n1_fixed, self.loss_name = fit_n1, n1_fixed, loss
        self.resolution = target.shape[-2]
        self.full_mask = mask.expand(target.shape[:-1])
        self.evaluations = 0
        self.iterations = 0

    def params(self, x, space: _Space):
        """x → (Λ, δ, n1, n2, α, s) tensors (differentiable)."""
        period = space.forward("period", x[0])
        delta = space.forward("delta", x[1])
        dn = space.forward("dn", x[2])
        alpha = space.forward("alpha", x[3])
        n1 = space.forward("n1", x[5]) if self.fit_n1 else torch.as_tensor(self.n1_fixed, dtype=x.dtype)
        return period, delta, n1, n1 + dn, alpha, torch.exp(x[4])

    def values(self, x, space: _Space) -> dict:
        """x → the parameters as floats: period, delta, n1, dn, alpha, scale."""
        with torch.no_grad():
            period, delta, n1, n2, alpha, scale = self.params(x.detach(), space)
        return {"period": float(period), "delta": float(delta), "n1": float(n1), "dn": float(n2 - n1),
                "alpha": float(alpha), "scale": float(scale)}

    def encode(self, space: _Space, v: dict) -> torch.Tensor:
        u = [space.inverse("period", v["period"]), space.inverse("delta", v["delta"]), space.inverse("dn", v["dn"]),
             space.inverse("alpha", v["alpha"]), math.log(v["scale"])]
        if self.fit_n1:
            u.append(space.inverse("n1", v["n1"]))
        return torch.tensor(u, dtype=self.target.dtype)

    def render(self, period, delta, n1, n2, cells, alpha):
        self.evaluations += 1
        s = bragg_structure(n1, n2, period, delta, cells, alpha, n_incident=self.n_incident, base_albedo=self.base_albedo)
        return render_targets(s, self.incs, resolution=self.resolution, wavelength=self.lam,
                              projection=self.projection, lut=self.lut)

    def loss(self, model, scale=None):
        return scatterogram_loss(model, self.target, self.full_mask, scale=scale, loss=self.loss_name)

    def start(self, space: _Space, v: dict, cells: int):
        """Encode ``v`` (period, delta, n1, dn, alpha) with the closed-form exposure → (x, its loss)."""
        with torch.no_grad():
            model = self.render(v["period"], v["delta"], v["n1"], v["n1"] + v["dn"], cells, v["alpha"])
            s = float(_lsq_scale(model, self.target, self.full_mask))
            value = float(self.loss(model, s if s > 0 else 1.0))
        return self.encode(space, {**v, "scale": s if s > 0 else 1.0}), value

    def objective(self, x, cells, space):
        period, delta, n1, n2, alpha, scale = self.params(x, space)
        return self.loss(self.render(period, delta, n1, n2, cells, alpha), scale)

    def refine(self, x0, cells, space, iterations):
        """L-BFGS from ``x0`` for up to ``iterations`` iterations → (x, loss)."""
        x = x0.clone().requires_grad_(True)
        opt = torch.optim.LBFGS([x], lr=1.0, max_iter=iterations, history_size=20, line_search_fn="strong_wolfe",
                                tolerance_grad=1e-9, tolerance_change=1e-12)
        best = {"loss": math.inf, "x": x0.clone()}

        def closure():
            opt.zero_grad()
            value = self.objective(x, cells, space)
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
        if best["loss"] == math.inf:  # not one finite evaluation (0 iterations): the start's loss
            with torch.no_grad():
                best["loss"] = float(self.objective(x0, cells, space))
        return best["x"], best["loss"]

    def lab(self, x, cells, space):
        """Lab of the scaled render over the mask (no gradients)."""
        with torch.no_grad():
            period, delta, n1, n2, alpha, scale = self.params(x, space)
            model = self.render(period, delta, n1, n2, cells, alpha)
            return xyz_to_lab(scale * model[self.full_mask])


def _check_range(name, value, lo=0.0, hi=math.inf, closed=False):
    """``(low, high)`` with ``lo < low < high < hi`` (``lo <= low < high <= hi`` if ``closed``) → floats."""
    ok = (isinstance(value, (tuple, list)) and len(value) == 2
          and all(isinstance(v, numbers.Real) and not isinstance(v, bool) and math.isfinite(v) for v in value))
    if ok:
        a, b = float(value[0]), float(value[1])
        ok = a < b and ((lo <= a and b <= hi) if closed else (lo < a and b < hi))
    if not ok:
        sign = "<=" if closed else "<"
        upper = "" if hi == math.inf else f" {sign} {hi:g}"
        raise ValueError(f"{name} must be a pair (low, high) with {lo:g} {sign} low < high{upper}; got {value!r}")
    return a, b


def _check_cells(cells):
    cells = tuple(cells) if isinstance(cells, (tuple, list, range)) else cells
    if not isinstance(cells, tuple) or not cells or not all(
            isinstance(c, numbers.Integral) and not isinstance(c, bool) and c >= 1 for c in cells):
        raise ValueError(f"cells must be a non-empty sequence of integers >= 1; got {cells!r}")
    return tuple(sorted({int(c) for c in cells}))


def _check_harmonics(harmonics):
    if harmonics is None:
        return ()
    h = tuple(harmonics) if isinstance(harmonics, (tuple, list)) else None
    if h is None or not all(isinstance(k, numbers.Real) and not isinstance(k, bool) and math.isfinite(k) and k > 0
                            and abs(k - 1.0) > 1e-9 for k in h):
        raise ValueError(f"harmonics must be a sequence of period factors > 0 other than 1 (e.g. (0.5, 2)); "
                         f"got {harmonics!r}")
    return tuple(float(k) for k in h)


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
    delta_range=(0.0, 1.0),
    dn_range=None,
    alpha_range=None,
    n1_range=None,
    period_step: float = 2.0,
    starts: int = 3,
    short_iter: int = 15,
    max_iter: int = 60,
    harmonics=DEFAULT_HARMONICS,
    ambiguity_de2000: float = 1.0,
    wavelength=None,
    projection: str = "equidistant",
    lut: bool = False,
    n_incident: float = 1.0,
    base_albedo: float = 0.0,
    loss: str = "lab",
    progress=None,
) -> ScatterogramFit:
    r"""Recover (Λ, δ, n2 − n1, N, α) of one rough Bragg layer from a target scatterogram.

    The target is what :func:`~torchirid.layered.scatterograms.scatterogram` renders (or
    :func:`read_scatterogram` reads) for each illumination of ``incident_deg``, at any unknown
    exposure; the strategy (Λ grid → multi-start L-BFGS → N enumeration → polish → harmonic
    refits) and the loss are described in the module docstring. Every parameter stays inside
    the range it is given (a bounded parametrisation), and the result lists the period
    harmonics refitted (:attr:`ScatterogramFit.alternatives`) and flags the fit
    :attr:`~ScatterogramFit.ambiguous` when one of them looks the same.

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
            ``period_range`` is None: no grid search); defaults ``DEFAULT_INIT`` (a default
            outside a range given below is replaced by the range's middle; a given value
            outside its range is an error).
        period_range: ``(low, high)`` nm: the Λ grid and the bounds of Λ in every stage; ``None``
            to start from ``init["period"]`` with Λ unbounded.
        delta_range: ``(low, high)`` with 0 ≤ low < high ≤ 1: the bounds of δ (default: (0, 1)).
        dn_range, alpha_range: ``(low, high)``, 0 < low < high: the bounds of n2 − n1 and of the
            GGX α; None (default): unbounded (positive).
        n1_range: ``(low, high)`` bounds of n1 when ``fit_n1``; the fixed ``n1`` must lie inside
            it otherwise.
        period_step: grid step in nm (> 0).
        starts: how many grid minima are refined (≥ 1).
        short_iter: L-BFGS iterations per start, per N candidate and per harmonic refit.
        max_iter: L-BFGS iterations of the final polish.
        harmonics: the period factors k whose refits are listed as alternatives (default
            ``DEFAULT_HARMONICS``: Λ/2, 2Λ, 2Λ/3, 3Λ/2, Λ/3, 3Λ); ``()`` lists none. Each
            ``k·Λ`` inside ``period_range`` is refitted (Λ within ``k·Λ`` ÷× 1.08; N among up to
            three candidates near N/k, N/√k and N, each from its best start δ among the maxima of
            the harmonic's order and refined ``short_iter // 3`` iterations, the best one
            ``short_iter`` in all: its loss is an upper bound);
            one outside is listed as not refitted — the caller's range excludes it (widen
            ``period_range`` to test it). A refit with a lower loss than the fit replaces it
            (then N within ±2 of the refit's is enumerated and polished again; at most twice).
        ambiguity_de2000: an alternative is near-degenerate, and the fit ambiguous, when the mean
            CIEDE2000 between its render and the fit's over the target's lit pixels is below
            this (≥ 0; default 1, about the just-noticeable difference; the lit pixels of a
            target with 1 % noise lie 0.59 from the noiseless image).
        wavelength: ``(W,)`` nm of the model's spectra (default 380–780 nm, 41 values).
        projection: the scatterogram's angular mapping (see
            :data:`~torchirid.layered.scatterograms.PROJECTIONS`).
        lut: render the mirrors' reflectance from a per-call angle table.
        n_incident, base_albedo: the medium above the layer and the base (the jewel-beetle
            presets: air, black).
        loss: ``"lab"`` (mean ΔE*ab², default) or ``"de2000"`` (mean ΔE00).
        progress: ``None`` or a callable ``progress(done, total)``: ``done`` stages out of
            ``total`` = the grid (1, with ``period_range``) + the starts (``starts``; 1 without
            ``period_range``) + one per N candidate refit (``len(cells) − 1``) + the polish (1)
            + one per harmonic; a harmonic that replaces the fit adds its round (N candidates,
            polish, harmonics) to ``total``. Called after each stage; the last call has
            ``done == total``. What each stage found (losses, periods, N) is in
            :attr:`ScatterogramFit.stages`.

    Returns:
        a :class:`ScatterogramFit`.

    Raises:
        ValueError: a bad argument, named, before any work.

    Cost: the grid (one render per step), ``starts + len(cells) − 1`` refits of ``short_iter``
    iterations, the polish, and per harmonic inside ``period_range`` up to 16 renders without
    gradients plus up to ``5/3 · short_iter`` iterations (about two N candidates). A harmonic
    that replaces the fit adds up to 4 N candidates and a polish.

    Example (a tiny 12-pixel image, from a start 6 nm away; no grid, N known):
        >>> from torchirid.layered.presets import jewel_beetle
        >>> t = render_targets(jewel_beetle("green"), [(0.0, 0.0), (40.0, 0.0)], resolution=12,
        ...                    wavelength=torch.linspace(380.0, 780.0, 41, dtype=torch.float64))
        >>> fit = match_scatterogram(2.5 * t, incident_deg=[(0.0, 0.0), (40.0, 0.0)], n1=1.59, cells=(8,),
        ...                          period_range=None, init={"period": 166.0, "delta": 0.51, "dn": 0.08,
        ...                          "alpha": 0.05}, short_iter=5, max_iter=20)
        >>> abs(fit.period - 160.0) < 0.5
        True
        >>> [a.label for a in fit.alternatives]
        ['Λ/2', '2Λ', '2Λ/3', '3Λ/2', 'Λ/3', '3Λ']
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
    _checks.check_choice(projection, "projection", PROJECTIONS)
    _checks.check_choice(loss, "loss", _LOSSES)
    if isinstance(n1, bool) or not isinstance(n1, numbers.Real) or not n1 > 0:
        raise ValueError(f"n1 must be a real number > 0; got {n1!r}")
    cells = _check_cells(cells)
    ranges = {
        "period": None if period_range is None else _check_range("period_range", period_range),
        "delta": _check_range("delta_range", delta_range, 0.0, 1.0, closed=True),
        "dn": None if dn_range is None else _check_range("dn_range", dn_range),
        "alpha": None if alpha_range is None else _check_range("alpha_range", alpha_range),
        "n1": None if n1_range is None else _check_range("n1_range", n1_range),
    }
    if ranges["n1"] is not None and not ranges["n1"][0] <= n1 <= ranges["n1"][1]:
        raise ValueError(f"n1 must lie inside n1_range {ranges['n1']}; got {n1!r}")
    start = dict(DEFAULT_INIT)
    given = {}
    if init is not None:
        if not isinstance(init, dict) or not set(init) <= {"period", "delta", "dn", "alpha"}:
            raise ValueError(f"init must be a dict with keys among period, delta, dn, alpha; got {init!r}")
        given = {k: float(v) for k, v in init.items()}
        start.update(given)
    if not (0.0 < start["delta"] < 1.0 and start["dn"] > 0 and start["alpha"] > 0 and start["period"] > 0):
        raise ValueError(f"init needs 0 < delta < 1 and period, dn, alpha > 0; got {start!r}")
    for key in ("delta", "dn", "alpha"):  # (init["period"] is bounded by no range: it is used without one)
        r = ranges[key]
        if r is None or r[0] <= start[key] <= r[1]:
            continue
        if key in given:
            raise ValueError(f"init[{key!r}] = {start[key]:g} lies outside {key}_range {r}")
        start[key] = 0.5 * (r[0] + r[1]) if key == "delta" else math.sqrt(r[0] * r[1])  # a default: the middle
    if isinstance(period_step, bool) or not isinstance(period_step, numbers.Real) or not period_step > 0:
        raise ValueError(f"period_step must be a number > 0 (nm); got {period_step!r}")
    starts = _checks.check_int(starts, "starts")
    short_iter = _checks.check_int(short_iter, "short_iter")
    max_iter = _checks.check_int(max_iter, "max_iter", 0)
    harmonics = _check_harmonics(harmonics)
    if (isinstance(ambiguity_de2000, bool) or not isinstance(ambiguity_de2000, numbers.Real)
            or not ambiguity_de2000 >= 0):
        raise ValueError(f"ambiguity_de2000 must be a number >= 0 (CIEDE2000); got {ambiguity_de2000!r}")
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
    if progress is not None and not callable(progress):
        raise ValueError(f"progress must be None or a callable progress(done, total); got {progress!r}")
    start_units = starts if period_range is not None else 1
    count = {"done": 0, "total": (period_range is not None) + start_units + len(cells) + len(harmonics)}

    def tick(units: int = 1):
        """``units`` more stages done → ``progress(done, total)``."""
        count["done"] += units
        if progress is not None and units > 0:
            progress(count["done"], count["total"])

    norm = float(peak)
    target_n = target.detach() / norm
    prob = _Problem(target_n, mask, incs, lam, projection, lut, float(n_incident), float(base_albedo), bool(fit_n1),
                    float(n1), loss)
    space = _Space(ranges, bool(fit_n1))
    stages: dict = {"ranges": {k: (None if v is None else list(v)) for k, v in ranges.items()}}
    n_mid = cells[len(cells) // 2]
    base = {"delta": start["delta"], "dn": start["dn"], "alpha": start["alpha"], "n1": float(n1)}

    # 1. grid in Λ (no gradients; exposure in closed form)
    if period_range is None:
        seeds = [start["period"]]
    else:
        lo, hi = ranges["period"]
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
        tick()

    # 2. refine each start at the middle N
    results = []
    for p in seeds:
        x, value = prob.refine(prob.start(space, {**base, "period": p}, n_mid)[0], n_mid, space, short_iter)
        results.append((value, x, n_mid))
        tick()
    tick(start_units - len(seeds))  # (the grid had fewer minima than starts)
    results.sort(key=lambda r: r[0])
    stages["starts"] = [[prob.values(x, space)["period"], v] for v, x, _ in results]

    def cells_and_polish(value, x, n, log_key, spread=None):
        """3. enumerate N (warm start, N·Δn kept; only |N' − N| <= spread if given) and 4. polish
        the best N → (loss, x, N)."""
        tried = {n: (value, x)}
        for c in cells:
            if c in tried or (spread is not None and abs(c - n) > spread):
                continue
            v = prob.values(x, space)
            xc, vc = prob.refine(prob.encode(space, {**v, "dn": v["dn"] * n / c}), c, space, short_iter)
            tried[c] = (vc, xc)
            tick()
        stages[log_key] = {str(c): v for c, (v, _) in sorted(tried.items())}
        n = min(tried, key=lambda c: tried[c][0])
        value, x = tried[n]
        if max_iter > 0:
            xp, vp = prob.refine(x, n, space, max_iter)
            if vp <= value:
                value, x = vp, xp
        stages.setdefault("polish", []).append({"cells": n, "loss": value})
        tick()
        return value, x, n

    best_value, best_x, best_n = cells_and_polish(*results[0], "cells")

    # 5. harmonics k·Λ: refit each inside period_range; a better one replaces the fit
    lab_t = xyz_to_lab(target_n[prob.full_mask])
    lit = lab_t[:, 0] > 5.0
    sel = lit if bool(lit.any()) else torch.ones_like(lit)
    lam_c = 0.5 * (float(lam.min()) + float(lam.max()))

    def refit_harmonic(k, fit_v, fit_n, fit_lab):
        label = _harmonic_label(k)
        p_k = k * fit_v["period"]
        pr = ranges["period"]
        if pr is not None and not pr[0] <= p_k <= pr[1]:
            note = f"outside period_range ({pr[0]:g}, {pr[1]:g}) nm"
            tick()
            return ScatterogramAlternative(label, k, p_k, False, note), None
        window = (p_k / _WINDOW, p_k * _WINDOW)
        if pr is not None:
            window = (max(window[0], pr[0]), min(window[1], pr[1]))
        sub = space.with_period(window)
        # the order m of the fit's visible Bragg peak, and m' = k·m of the harmonic's; the starts keep the
        # peak's strength N·Δn·|sin(mπδ)| (weak-contrast coupled-mode estimate), over δ among the maxima
        # of |sin(m'πδ)| and N nearest N/k, N/√k and N (no gradients)
        n_bar = fit_v["n1"] + fit_v["delta"] * fit_v["dn"]
        m = max(1, round(2.0 * n_bar * fit_v["period"] / lam_c))
        strength = max(abs(math.sin(math.pi * m * fit_v["delta"])), 0.1)
        wants = (fit_n / k, fit_n / math.sqrt(k), fit_n)
        n_ks = sorted({min(cells, key=lambda c: (abs(c - want), c)) for want in wants})
        d_lo, d_hi = ranges["delta"]
        deltas = sorted({min(max(d, d_lo + 0.01 * (d_hi - d_lo)), d_hi - 0.01 * (d_hi - d_lo))
                         for d in _HARMONIC_DELTAS})
        found = {}  # N → (loss, x) of its best δ start
        for n_k, d in itertools.product(n_ks, deltas):
            dn_k = fit_v["dn"] * (fit_n / n_k) * strength / max(abs(math.sin(math.pi * k * m * d)), 0.1)
            if ranges["dn"] is not None:
                dn_k = min(max(dn_k, ranges["dn"][0]), ranges["dn"][1])
            v = {"period": p_k, "delta": d, "dn": dn_k, "alpha": fit_v["alpha"], "n1": fit_v["n1"]}
            x0, value0 = prob.start(sub, v, n_k)
            if n_k not in found or value0 < found[n_k][0]:
                found[n_k] = (value0, x0)
        # each N's best start gets a third of the iterations (a start's loss does not rank the
        # optima); the best one gets the rest
        scout = max(1, short_iter // 3)
        tried = [prob.refine(x0, n_k, sub, scout) + (n_k,) for n_k, (_, x0) in sorted(found.items())]
        x, value, n_k = min(tried, key=lambda r: r[1])
        if short_iter > scout:
            x2, value2 = prob.refine(x, n_k, sub, short_iter - scout)
            if value2 <= value:
                x, value = x2, value2
        v = prob.values(x, sub)
        lab_k = prob.lab(x, n_k, sub)
        de_t = delta_e_2000(lab_k, lab_t)
        de_f = float(delta_e_2000(lab_k[sel], fit_lab[sel]).mean())
        alt = ScatterogramAlternative(
            label, k, v["period"], True, "refitted", delta=v["delta"], n1=v["n1"], n2=v["n1"] + v["dn"],
            cells=int(n_k), alpha=v["alpha"], exposure=v["scale"] * norm, loss=float(value),
            delta_e2000=float(de_t.mean()), delta_e2000_lit=float(de_t[lit].mean()) if bool(lit.any()) else math.nan,
            delta_e2000_vs_fit=de_f, near_degenerate=de_f < ambiguity_de2000)
        tick()
        return alt, (value, prob.encode(space, v), n_k)

    swaps = []
    while True:
        fit_v = prob.values(best_x, space)
        fit_lab = prob.lab(best_x, best_n, space)
        alts = [refit_harmonic(k, fit_v, best_n, fit_lab) for k in harmonics]
        better = [(a, r) for a, r in alts if r is not None and r[0] < best_value]
        if not better or len(swaps) == _MAX_SWAPS:
            break
        a, (value, x, n) = min(better, key=lambda ar: ar[1][0])
        swaps.append({"from_period": fit_v["period"], "label": a.label, "loss": value})
        count["total"] += sum(c != n and abs(c - n) <= 2 for c in cells) + 1 + len(harmonics)  # another round
        best_value, best_x, best_n = cells_and_polish(value, x, n, f"cells_after_swap_{len(swaps)}", spread=2)
    alternatives = tuple(a for a, _ in alts)
    stages["harmonics"] = {"ambiguity_de2000": float(ambiguity_de2000), "swaps": swaps,
                           "alternatives": [a.numbers() for a in alternatives]}

    with torch.no_grad():
        period, delta, n1v, n2v, alpha, scale = prob.params(best_x, space)
        de = delta_e_2000(fit_lab, lab_t)
        de_lit = float(de[lit].mean()) if bool(lit.any()) else float("nan")
    return ScatterogramFit(
        period=float(period), delta=float(delta), n1=float(n1v), n2=float(n2v), cells=int(best_n),
        alpha=float(alpha), exposure=float(scale) * norm, loss=float(best_value), delta_e2000=float(de.mean()),
        delta_e2000_lit=de_lit, iterations=prob.iterations, evaluations=prob.evaluations,
        seconds=time.perf_counter() - t_start, alternatives=alternatives,
        ambiguous=any(a.near_degenerate for a in alternatives), stages=stages,
    )
