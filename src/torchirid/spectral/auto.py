r"""``method="auto"``: the cheapest Bragg-colour method that meets a ΔE2000 tolerance, from measured tables.

The tables are ``src/torchirid/data/bragg_color_errors.json``, built by
``luts/build_bragg_color_errors.py`` from the measurement of
``benchmarks/bragg_color_speed_vs_error.py`` (p95 ΔE2000 against the converged spectral colour
and µs per colour, on Fourneau Fig. 4's grid and a denser one). The rule:

1. **sampled K** — its error is governed by the samples per fringe. Every measured
   (grid, Λ, K) gives a point (K / F, p95) with F = N (n1 d1 + n2 d2)_max Δω / π fringes;
   the smallest samples-per-fringe ρ(τ) above which *every* measured point has p95 ≤ τ is
   scaled to the query: K = max(64, ⌈ρ(τ) · F_query⌉). Its cost is the measured µs per
   colour interpolated in K.
2. **piecewise** and **envelope** (only for mirrors in n1, real indices, no total internal
   reflection, and every colour inside their measured domain: at least
   ``MIN_FRINGES`` fringes in the range,
   :func:`~torchirid.spectral.sampling.fringe_count`; below it they are off by ΔE2000 7–30): a
   configuration qualifies when its p95 on *both* measured grids is ≤ τ.
3. **spectral** always qualifies for τ ≥ its measured p95; below that nothing is
   guaranteed and spectral is used anyway. Its cost scales with its sample count.

The qualifying configuration with the lowest estimated cost **for this call's batch size**
wins. Costs are per colour at the benchmark's 810 colours per call, and the table's
``batch_size_check`` (810, 2430, 8100 colours per call) gives each method a fixed cost per
call ``a`` (the median over its checked configurations of a least-squares fit ``a + b·B`` of
the time per call; milliseconds for ``piecewise``, less for ``envelope``, about none for
``sampled``). A configuration's cost per colour at B colours is then ``a/B + (us_810 − a/810)``.
So on a few colours per call the short ``sampled`` integrations win, on hundreds and more the
envelope method does, and on thousands the landmark method can (the measured figures:
docs/performance.md, "Bragg mirror colour: the method choice").
``choose_bragg_method`` returns the choice with its estimated p95 and cost, for inspection.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import torch

from .sampling import fringe_count, max_fringes, spectral_samples
from .._cache import cached
from .piecewise import MIN_FRINGES

__all__ = []

_TABLE = Path(__file__).resolve().parent.parent / "data" / "bragg_color_errors.json"


@cached(maxsize=1)
def _table():
    data = json.loads(_TABLE.read_text())
    if data.get("format") != "torchirid.bragg_color_errors" or data.get("format_version") != 1:
        raise ValueError(f"{_TABLE} is not a torchirid.bragg_color_errors table (format version 1)")
    return data


def _grid_fringes(g):
    lo, hi = g["wavelength_range_nm"]
    out = {}
    for lam in g["periods_nm"]:
        opl = max(lam * (g["n1"] * f + g["n2"] * (1 - f)) for f in g["d1_over_period"])
        out[str(int(lam)) if float(lam).is_integer() else str(lam)] = g["cells"] * opl * 2 * (1 / lo - 1 / hi)
    return out


_REFERENCE_BATCH = 810  # colours per call of the benchmark's error/cost entries


@cached(maxsize=1)
def _fixed_costs() -> dict:
    """Per method: the fixed cost per call (µs), the median over its checked configurations of
    ``a`` in a least-squares fit of the per-call time ``a + b·B`` over B and the periods."""
    check = _table().get("batch_size_check", {"entries": []})
    fits: dict = {}
    for e in check["entries"]:
        xs, ys = [], []
        for per_period in e["us_per_colour"].values():
            for batch, us in per_period.items():
                xs.append(float(batch))
                ys.append(float(us) * float(batch))
        mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
        sxx = sum((x - mx) ** 2 for x in xs)
        b = sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sxx if sxx > 0 else my / mx
        fits.setdefault(e["config"]["method"], []).append(max(0.0, my - b * mx))  # a ≥ 0
    return {m: sorted(a)[len(a) // 2] for m, a in fits.items()}


def _cost_per_colour(cfg: dict, us_at_reference: float, batch: int) -> float:
    """µs per colour of ``cfg`` at ``batch`` colours per call: its method's fixed cost per call
    spread over the batch, plus the rest of its measured cost at 810 colours per call."""
    a = min(_fixed_costs().get(cfg.get("method"), 0.0), us_at_reference * _REFERENCE_BATCH)
    return a / batch + (us_at_reference - a / _REFERENCE_BATCH)


def choose_bragg_method(cos_theta, n1, n2, d1, d2, cells, *, n_incident=None, tolerance: float = 1.0,
                        wavelength_range=(380.0, 780.0), batch_size: int | None = None) -> dict:
    """The configuration ``method="auto"`` uses: ``{"config": {...}, "p95": float, "us_per_colour": float}``.

    ``config`` holds keyword arguments of :func:`torchirid.bragg_xyz`; ``p95`` is the
    measured 95th-percentile ΔE2000 it is expected to stay under, ``us_per_colour`` its
    estimated cost per colour on this machine class at ``batch_size`` colours per call
    (default: the broadcast batch of the mirror parameters); see the module docstring.

    >>> import torch
    >>> choose_bragg_method(1.0, 1.0, 1.5, 125.0, 375.0, 20)["config"]["method"]   # one colour
    'sampled'
    >>> c = torch.linspace(0.05, 1.0, 4000, dtype=torch.float64)
    >>> choose_bragg_method(c, 1.0, 1.5, 125.0, 375.0, 20)["config"]["method"]     # 4000 colours
    'envelope'
    """
    if not (isinstance(tolerance, (int, float)) and tolerance > 0):
        raise ValueError(f"tolerance must be a ΔE2000 > 0; got {tolerance!r}")
    if batch_size is None:
        with torch.no_grad():
            shape = torch.broadcast_shapes(*(torch.as_tensor(x).shape for x in (cos_theta, n1, n2, d1, d2, cells)
                                             if x is not None))
        batch_size = max(1, math.prod(shape))
    else:
        if isinstance(batch_size, bool) or not isinstance(batch_size, int) or batch_size < 1:
            raise ValueError(f"batch_size must be an int >= 1 (colours per call); got {batch_size!r}")
    data = _table()
    lo, hi = wavelength_range

    F_q = max_fringes(n1, n2, d1, d2, cells, lo, hi)
    entries = data["entries"]
    candidates = []

    # 1. sampled: samples-per-fringe envelope over every measured grid and period
    points, costs = [], []
    for e in entries:
        if e["config"].get("method") != "sampled":
            continue
        K = e["config"]["samples"]
        for gname, g in data["grids"].items():
            fr = _grid_fringes(g)
            for lam, stats in e["grids"][gname]["per_period"].items():
                points.append((K / fr[lam], stats["p95"]))
            costs.append((K, e["grids"][gname]["us_per_colour"]))
    points.sort()
    rho = None
    for i, (spf, _) in enumerate(points):
        if all(p <= tolerance for _, p in points[i:]):
            rho = spf
            break
    if rho is not None:
        K = max(64, math.ceil(rho * F_q))
        Ks = sorted(costs)
        per_sample = max(c / k for k, c in Ks if k >= 256) if any(k >= 256 for k, _ in Ks) else Ks[-1][1] / Ks[-1][0]
        fixed = min(c for _, c in Ks)
        us_ref = fixed + per_sample * K
        candidates.append({"config": {"method": "sampled", "samples": K},
                           "p95": max(p for s, p in points if s >= rho),
                           "us_per_colour": _cost_per_colour({"method": "sampled", "samples": K}, us_ref, batch_size)})

    # 2. piecewise, in the setting it was measured in
    real = not any(torch.is_tensor(t) and t.is_complex() or isinstance(t, complex) for t in (n1, n2))
    with torch.no_grad():
        in_n1 = n_incident is None or bool((torch.as_tensor(n_incident) == torch.as_tensor(n1)).all())
        c = torch.as_tensor(cos_theta, dtype=torch.float64)
        tir = real and bool((torch.as_tensor(n2).real ** 2 < torch.as_tensor(n1).real ** 2 * (1 - c * c)).any())
        inside = not tir and bool((fringe_count(cos_theta, n1, n2, d1, d2, cells, n_incident=n_incident,
                                                wavelength_range=wavelength_range) >= MIN_FRINGES).all())
    if real and in_n1 and not tir and inside:
        for e in entries:
            if e["config"].get("method") not in ("piecewise", "envelope"):
                continue
            p95 = max(e["grids"][g]["p95"] for g in data["grids"])
            if p95 <= tolerance:
                us = max(e["grids"][g]["us_per_colour"] for g in data["grids"])
                candidates.append({"config": dict(e["config"]), "p95": p95,
                                   "us_per_colour": _cost_per_colour(e["config"], us, batch_size)})

    # 3. spectral: the converged reference
    spec = next(e for e in entries if e["config"].get("method") == "spectral")
    g0 = data["grids"]["fig4"]
    k_ref = max(g0["spectral_samples"].values())
    us_ref = spec["grids"]["fig4"]["us_per_colour"]
    k_q = spectral_samples(n1, n2, d1, d2, cells, wavelength_range=wavelength_range)
    spectral = {"config": {"method": "spectral"}, "p95": max(spec["grids"][g]["p95"] for g in data["grids"]),
                "us_per_colour": us_ref * k_q / k_ref}
    if spectral["p95"] <= tolerance or not candidates:
        candidates.append(spectral)
    return min(candidates, key=lambda c: c["us_per_colour"])
