r"""Scatterogram matching by autograd: recover a rough Bragg layer from its scatterogram.

:func:`match_scatterogram` recovers the parameters of one rough Bragg layer — the period
Λ (nm), δ (the fraction of Λ in the high-index layer, as in
:mod:`~torchirid.presets`), the index contrast n2 − n1 (n1 fixed, or fitted), the
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
harmonics, is not identified, and neither is N once N (n2 − n1) is. What the data do identify
are the Bragg wavelength 2 n̄ Λ / m of the visible peak and its shift with incidence, the
roughness α (the width of each beam's lobe) and the exposure; n1 only weakly (``fit_n1``: the
period absorbs it). 2Λ/3 and 3Λ/2 of a first-order fit are no Bragg harmonic (no integer order
lands on the peak), and Λ/2, Λ/3 would put the first order in the ultraviolet. Only a prior
decides between the harmonics: a ``period_range`` from another measurement (an electron
micrograph of the cross-section, an infrared or ultraviolet spectrum, which see the other
orders), or ranges on δ and n2 − n1 that exclude the harmonic's layer. The losses and ΔE00 of
the harmonic refits on a synthetic target, with and without such ranges: docs/performance.md,
"Scatterogram matching".

Reading and writing measured scatterograms (PNG, OpenEXR) is in :mod:`torchirid.fitting.measured`.
"""

from __future__ import annotations

import itertools
import math
import numbers
import time

import numpy as np
import torch

from .. import _autograd, _checks, _threads
from ..color import delta_e_2000, xyz_to_lab
from ..layered.scatterograms import (
    PROJECTIONS,
    scatterogram_directions,
)

from .results import ScatterogramAlternative, ScatterogramFit, _harmonic_label
from .search import _HARMONIC_DELTAS, _MAX_SWAPS, _WINDOW, _Problem, _Space
from .targets import DEFAULT_FIT_WAVELENGTHS, _LOSSES, _check_incident
__all__ = ["match_scatterogram"]

#: the candidate numbers of cells N enumerated by default
DEFAULT_CELLS = tuple(range(4, 13))
#: the period factors k refitted as alternatives by default: Λ/2, 2Λ, 2Λ/3, 3Λ/2, Λ/3, 3Λ
DEFAULT_HARMONICS = (0.5, 2.0, 2.0 / 3.0, 1.5, 1.0 / 3.0, 3.0)
#: the generic start (Λ is replaced by the grid search): δ, n1, n2 − n1, α
DEFAULT_INIT = {"period": 200.0, "delta": 0.5, "n1": 1.6, "dn": 0.06, "alpha": 0.1}


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


@_checks.arguments(projection=_checks.choice(PROJECTIONS), loss=_checks.choice(_LOSSES),
                   n1=_checks.number(low=0.0), period_range=_checks.pair() | None,
                   delta_range=_checks.pair(low=0.0, high=1.0, closed=True), dn_range=_checks.pair() | None,
                   alpha_range=_checks.pair() | None, n1_range=_checks.pair() | None,
                   period_step=_checks.number(low=0.0, unit="nm"), starts=_checks.integer(1),
                   short_iter=_checks.integer(1), max_iter=_checks.integer(0),
                   ambiguity_de2000=_checks.number(low=0.0, closed=True, unit="CIEDE2000"), progress=_checks.PROGRESS)
@_threads.large_work  # (the free cores on a shared machine: torchirid._threads)
@_autograd.fits_with_autograd  # (autograd inside: a caller's inference mode must not switch it off)
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
    reflectance: str = "exact",
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
            this (≥ 0; default 1, about the just-noticeable difference; a target's noise sets a
            floor: docs/performance.md, "Scatterogram matching").
        wavelength: ``(W,)`` nm of the model's spectra (default 380–780 nm, 41 values).
        projection: the scatterogram's angular mapping (see
            :data:`~torchirid.layered.scatterograms.PROJECTIONS`).
        reflectance: ``"exact"`` (default) or ``"lut"``: render the mirrors' reflectance from a
            per-call angle table (faster).
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
        >>> from torchirid.fitting import match_scatterogram, render_targets
        >>> from torchirid.presets import jewel_beetle
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
    cells = _check_cells(cells)
    ranges = {"period": period_range, "delta": delta_range, "dn": dn_range, "alpha": alpha_range, "n1": n1_range}
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
    harmonics = _check_harmonics(harmonics)
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
    start_units = starts if period_range is not None else 1
    count = {"done": 0, "total": (period_range is not None) + start_units + len(cells) + len(harmonics)}

    def tick(units: int = 1):
        """``units`` more stages done → ``progress(done, total)``."""
        count["done"] += units
        if progress is not None and units > 0:
            progress(count["done"], count["total"])

    norm = float(peak)
    target_n = target.detach() / norm
    prob = _Problem(target_n, mask, incs, lam, projection, reflectance, float(n_incident), float(base_albedo), bool(fit_n1),
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
