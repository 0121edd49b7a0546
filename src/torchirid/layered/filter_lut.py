r"""The transmission filter F_α as a 2-D lookup table (Fourneau et al. 2024 §4.2.2: "we
precompute, once and for all, a 2D lookup table for F_α(θi, θd)").

The closed form is :func:`torchirid.layered.filter.transmission_filter`; this module tabulates it
on a peak-following warped θd axis (see :func:`transmission_filter_lut`) in the project's LUT
container. Evaluating F_α itself is cheaper in closed form; the table is for export, renderers
and the paper's workflow.
"""

from __future__ import annotations

import math
from pathlib import Path

import torch

from .. import _checks
from ..lut import LUT
from .filter import _HALF_PI, _check_range, _cut_term, _filter, _half_pi_parts, _table_warp  # noqa: F401

__all__ = ["FilterLUT", "transmission_filter_lut"]


# ----------------------------------------------------------------------------------------
# the table
# ----------------------------------------------------------------------------------------
_LUT_BUILDER = "torchirid.layered.filter.transmission_filter_lut"
_LUT_LAYOUT = "theta_i x u(cauchy, c=sqrt(theta_i^2+alpha^2/3), w=alpha); values = F + S (kink term)"


def _table_values(ti: torch.Tensor, u: torch.Tensor, alpha: torch.Tensor):
    """``(F + S, F)`` at the table nodes ``θi`` (n, 1) × ``u`` (1, m)."""
    off, _ = _table_warp(ti, alpha).theta(u)
    hi, _ = _half_pi_parts(ti.dtype)
    td = off.clamp(0.0, hi)
    f = _filter(ti, td, alpha)
    return f + _cut_term(ti, td, alpha), f


def _bisect_axis(ti, u, g, alpha, tol, axis, budget):
    """Bisect the intervals of one axis (0: θi, 1: u) whose midpoint error of linear
    interpolation exceeds ``tol``; the midpoint values become the new nodes (each closed-form
    evaluation is used for both the check and the table). Returns the new grids, values and
    the largest midpoint error found in the first (full) check."""
    grid = ti if axis == 0 else u
    todo = torch.arange(grid.numel() - 1)  # left ends of the intervals to check
    first = None
    while todo.numel():
        mid = 0.5 * (grid[todo] + grid[todo + 1])
        if axis == 0:
            gm, _ = _table_values(mid[:, None], u[None, :], alpha)  # (m, n_u)
            err = (gm - 0.5 * (g[todo] + g[todo + 1])).abs().amax(1)
        else:
            gm, _ = _table_values(ti[:, None], mid[None, :], alpha)  # (n_i, m)
            err = (gm - 0.5 * (g[:, todo] + g[:, todo + 1])).abs().amax(0)
        if first is None:
            first = float(err.max()) if err.numel() else 0.0
        bad = err > tol
        if not bool(bad.any()) or grid.numel() + int(bad.sum()) > budget:
            break
        grid = torch.cat([grid, mid[bad]])
        g = torch.cat([g, gm[bad]] if axis == 0 else [g, gm[:, bad]], axis)
        order = torch.argsort(grid)
        grid = grid[order]
        g = g[order] if axis == 0 else g[:, order]
        rank = torch.empty_like(order)
        rank[order] = torch.arange(order.numel())
        new = rank[-int(bad.sum()):]  # positions of the new nodes: check both halves next
        todo = torch.unique(torch.cat([new - 1, new]))
        if axis == 0:
            ti = grid
        else:
            u = grid
    return (grid, u, g, first) if axis == 0 else (ti, grid, g, first)


def _refine(ti, u, alpha, rtol, max_rows, max_cols):
    """Bisect θi intervals and u intervals until the midpoint error of linear interpolation is
    below ``rtol × peak`` in each direction (a posteriori: the closed form is the judge).
    Returns the grids, the values and the final midpoint-error estimates (relative to the peak)."""
    g, f = _table_values(ti[:, None], u[None, :], alpha)
    peak = float(f.max())
    tol = rtol * peak
    est_i = est_u = float("inf")
    for _ in range(6):  # alternate until a full check of both axes finds nothing to refine
        n_before = (ti.numel(), u.numel())
        ti, u, g, est_i = _bisect_axis(ti, u, g, alpha, tol, 0, max_rows)
        ti, u, g, est_u = _bisect_axis(ti, u, g, alpha, tol, 1, max_cols)
        if (ti.numel(), u.numel()) == n_before:
            break
    return ti, u, g, est_i / peak, est_u / peak


class FilterLUT:
    r"""A table of :math:`F_\alpha(\theta_i, \theta_d)` for one α: a :class:`torchirid.lut.LUT`
    plus the coordinate map; call it as ``lut(theta_i, theta_d)`` (radians).

    Layout (see the module docstring): axes ``theta_i`` (rad, non-uniform: at least every
    0.25°, bisected where needed) and ``u ∈ [0, 1]`` (uniform, bisected where needed), with
    ``θd = c + w tan(g_0 + u (g_1 − g_0))``, ``c = √(θi² + α²/3)``, ``w = α`` — a θd grid
    centred on the filter's peak for every θi, so bilinear interpolation follows the peak as
    it moves. The stored values are ``F + S`` with the closed-form kink term
    ``S = 2α²/π · G1²/cos θi · cos θd sin θd · (π − ψ_dmax)`` (``_cut_term``), which removes
    the square root at ``θd = π/2 − θi``; the call subtracts it again.

    Attributes:
        lut: the underlying :class:`~torchirid.lut.LUT` (``values`` shape ``(n_θi, n_u)``).
        alpha: the roughness it was built for.

    Example (obtained from :func:`transmission_filter_lut`; coarse here, for speed):
        >>> import os, tempfile, torch
        >>> from torchirid.layered import transmission_filter
        >>> table = transmission_filter_lut(0.2, theta_i_step_deg=2.0, u_nodes=33, rtol=3e-3)
        >>> table.alpha, table.lut.axis_names
        (0.2, ('theta_i', 'u'))
        >>> ti = torch.tensor([0.3, 1.0], dtype=torch.float64)  # θi, radians
        >>> td = torch.tensor([0.35, 1.0], dtype=torch.float64)  # θd, radians
        >>> bool((table(ti, td) - transmission_filter(ti, td, 0.2)).abs().max() < 0.01)
        True
        >>> with tempfile.TemporaryDirectory() as folder:
        ...     back = FilterLUT.read(table.write(os.path.join(folder, "filter.npz")), alpha=0.2)
        >>> torch.equal(back(ti, td), table(ti, td))
        True
    """

    def __init__(self, lut: LUT):
        if not isinstance(lut, LUT):
            raise ValueError(f"lut must be a torchirid.lut.LUT; got {type(lut).__name__}")
        if lut.builder != _LUT_BUILDER or lut.axis_names != ("theta_i", "u") or lut.channel_shape != ():
            raise ValueError(f"lut was not built by {_LUT_BUILDER} (builder {lut.builder!r}, axes {lut.axis_names})")
        params = lut.parameters
        if params.get("layout") != _LUT_LAYOUT or "alpha" not in params:
            raise ValueError(f"lut has an unknown layout {params.get('layout')!r}; rebuild it")
        self.lut = lut
        self.alpha = float(params["alpha"])
        self._alpha_t = torch.as_tensor(self.alpha, dtype=lut.dtype, device=lut.device)

    def __repr__(self) -> str:
        n_i, n_u = self.lut.values.shape
        return f"FilterLUT(alpha={self.alpha:g}, theta_i={n_i}, u={n_u}, dtype={self.lut.dtype})"

    @property
    def dtype(self) -> torch.dtype:
        return self.lut.dtype

    @property
    def device(self) -> torch.device:
        return self.lut.device

    def __call__(self, theta_i_rad, theta_d_rad) -> torch.Tensor:
        """Interpolated ``F_α(θi, θd)`` (radians; broadcast; differentiable; the table's dtype
        and device). ValueError naming the argument outside ``[0, π/2]``."""
        ti = self.lut._as_coord(theta_i_rad, "theta_i_rad")
        td = self.lut._as_coord(theta_d_rad, "theta_d_rad")
        hi, _ = _half_pi_parts(self.dtype)
        _check_range(ti, "theta_i_rad", 0.0, hi, "radians, incidence angle")
        _check_range(td, "theta_d_rad", 0.0, hi, "radians, difference angle")
        ti, td = torch.broadcast_tensors(ti, td)
        a = self._alpha_t
        u = _table_warp(ti, a).s_of(td)
        return self.lut.interp(theta_i=ti, u=u) - _cut_term(ti, td, a)

    interp = __call__

    def to(self, dtype: torch.dtype | None = None, device=None) -> "FilterLUT":
        return FilterLUT(self.lut.to(dtype=dtype, device=device))

    def write(self, path) -> Path:
        """Write the table (``.npz``, atomically) through :meth:`torchirid.lut.LUT.write`."""
        return self.lut.write(path)

    @classmethod
    def read(cls, path, *, alpha: float | None = None, dtype: torch.dtype | None = None, device=None) -> "FilterLUT":
        """Read a table written by :meth:`write`; with ``alpha`` given, refuse a table built
        for another roughness. Errors as :meth:`torchirid.lut.LUT.read` (``FileNotFoundError``;
        ``ValueError`` naming the file for a damaged, foreign or mismatched table)."""
        params = None if alpha is None else {"alpha": float(alpha)}
        lut = LUT.read(path, builder=_LUT_BUILDER, parameters=params, expect={"axes": ("theta_i", "u")},
                       dtype=dtype, device=device)
        try:
            return cls(lut)
        except ValueError as exc:
            raise ValueError(f"LUT file {str(path)!r} is not a transmission-filter table: {exc}") from exc


def _number_check(ok, message: str):
    """A check of a Python number (not a bool): ``ok(v)`` or ValueError ``<name> must <message>; got v``."""
    def check(v, name):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not ok(v):
            raise ValueError(f"{name} must {message}; got {v!r}")
    return _checks.Arg(None, check)


def _check_table_dtype(dtype, name):
    if dtype not in (torch.float16, torch.float32, torch.float64):
        raise ValueError(f"{name} must be torch.float16, float32 or float64; got {dtype}")


@_checks.arguments(
    alpha=_number_check(lambda v: math.isfinite(v) and v > 0, "be a finite real number > 0 (GGX roughness)"),
    theta_i_step_deg=_number_check(lambda v: 0 < v <= 90, "lie in (0, 90] degrees"),
    u_nodes=_checks.integer(2), max_theta_i_nodes=_checks.integer(2), max_u_nodes=_checks.integer(2),
    rtol=_number_check(lambda v: v > 0, "be a real number > 0"), dtype=_checks.Arg(None, _check_table_dtype))
def transmission_filter_lut(alpha: float, *, theta_i_step_deg: float = 0.25, u_nodes: int = 129,
                            rtol: float = 3e-4, max_theta_i_nodes: int = 8193, max_u_nodes: int = 2049,
                            dtype: torch.dtype = torch.float64) -> FilterLUT:
    r"""Tabulate :math:`F_\alpha` (eq. 29) for one roughness: the paper's 2-D LUT (§4.2.2).

    Built from the closed form (no quadrature), on a base grid of ``theta_i_step_deg`` degrees ×
    ``u_nodes``; then every θi interval and u interval whose midpoint error of linear
    interpolation (checked against the closed form) exceeds ``rtol`` × the filter's peak is
    bisected, until none is (or the node budgets are reached). The estimates reached are
    stored in the metadata (``parameters["estimated_rtol"]``).

    Args:
        alpha: GGX roughness > 0 (a Python number).
        theta_i_step_deg: base θi spacing in degrees (0.25 = the paper's resolution).
        u_nodes: base number of nodes of the warped θd axis.
        rtol: target midpoint interpolation error in each direction, relative to the peak
            of F_α (the default keeps the maximum error below 1e-3 of the peak).
        max_theta_i_nodes, max_u_nodes: refinement budgets.
        dtype: dtype of the stored table (built in float64).

    Returns:
        :class:`FilterLUT`; ``lut(theta_i, theta_d)`` interpolates, ``lut.write(path)`` /
        ``FilterLUT.read(path, alpha=...)`` round-trip through :class:`torchirid.lut.LUT`.
        Metadata: builder ``torchirid.layered.filter.transmission_filter_lut``, parameters
        ``alpha``, ``resolution`` (base step, node counts), ``rtol``, ``estimated_rtol``.

    >>> from torchirid.layered.filter import transmission_filter
    >>> lut = transmission_filter_lut(0.1)
    >>> ti = torch.tensor([0.3, 1.0], dtype=torch.float64)
    >>> err = (lut(ti, ti) - transmission_filter(ti, ti, 0.1)).abs().max()
    >>> bool(err < 1e-3 * 6.52)   # the peak of F_0.1 is 6.52
    True
    """
    f64 = torch.float64
    a = torch.tensor(float(alpha), dtype=f64)
    n_i = max(2, int(math.ceil(90.0 / theta_i_step_deg - 1e-9)) + 1)
    ti = torch.linspace(0.0, _HALF_PI, n_i, dtype=f64)
    u = torch.linspace(0.0, 1.0, u_nodes, dtype=f64)
    ti, u, g, est_i, est_u = _refine(ti, u, a, float(rtol), max_theta_i_nodes, max_u_nodes)
    lut = LUT(
        g.to(dtype),
        {"theta_i": ti, "u": u},
        builder=_LUT_BUILDER,
        parameters={
            "alpha": float(alpha),
            "layout": _LUT_LAYOUT,
            "resolution": {"theta_i_step_deg": float(theta_i_step_deg), "theta_i_nodes": int(ti.numel()),
                           "u_nodes_base": int(u_nodes), "u_nodes": int(u.numel())},
            "rtol": float(rtol),
            "estimated_rtol": {"theta_i": est_i, "u": est_u},
        },
        units={"theta_i": "rad", "u": "1 (warped theta_d, see layout)", "values": "1/rad (F + S)"},
    )
    return FilterLUT(lut)


