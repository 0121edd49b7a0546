r"""Cumulative colour-matching tables in angular wavenumber ω = 2π/λ (Fourneau et al. 2024, §3.2.2).

The piecewise-constant Bragg colour approximation writes a reflectance spectrum as boxes
between spectral landmarks, :math:`\tilde R(\omega) = \sum_j w_j B_j(\omega)` with
:math:`B_j = H(\omega - \omega_j) - H(\omega - \omega_{j+1})` (eq. 14), so that its
colour needs only one table lookup per landmark (eq. 15–16):

.. math::
    \tilde{\mathbf R} = \int \tilde R(\omega)\, \bar{\mathbf c}(\omega)\, d\omega
                      = \sum_j w_j \left(\bar{\mathbf C}(\omega_{j+1}) - \bar{\mathbf C}(\omega_j)\right),
    \qquad
    \bar{\mathbf C}(\omega) = \int_{\omega_{min}}^{\omega} \bar{\mathbf c}(\omega')\, d\omega'.

Here the CMFs in ω carry the illuminant, the Jacobian of λ = 2π/ω and the normalisation
of :func:`torchirid.color.spectrum_to_xyz` (a perfect reflector has ``Y = 1``):

.. math::
    \bar{\mathbf c}(\omega) = \frac{S(\lambda)\, \bar{\mathbf x}(\lambda)\, |d\lambda/d\omega|}
                                   {\int_{\lambda_{min}}^{\lambda_{max}} S \bar y \, d\lambda},
    \quad \lambda = \frac{2\pi}{\omega}, \quad \left|\frac{d\lambda}{d\omega}\right| = \frac{2\pi}{\omega^2},

so :math:`\bar{\mathbf C}(\omega) = \int_{2\pi/\omega}^{\lambda_{max}} S \bar{\mathbf x}\, d\lambda
\,/\, \int_{\lambda_{min}}^{\lambda_{max}} S \bar y\, d\lambda`, with
:math:`\omega_{min} = 2\pi/\lambda_{max}`, :math:`\omega_{max} = 2\pi/\lambda_{min}`;
:math:`\bar{\mathbf C}(\omega_{min}) = 0` and :math:`\bar{\mathbf C}(\omega_{max})` is the XYZ of
the perfect reflector over the range (``Y = 1`` exactly). Units: ω in nm⁻¹ (rad/nm);
:math:`\bar{\mathbf C}` dimensionless (XYZ with the white at ``Y = 1``); :math:`\bar{\mathbf c}` in nm.

The integrand is exactly the one :func:`~torchirid.color.spectrum_to_xyz` integrates: the
illuminant × CMF product tabulated on the observer's grid (1 nm for the CIE observers) and
linear between those knots, 0 outside the observer's range. :math:`\bar{\mathbf C}` is
integrated **exactly** (piecewise quadratic in λ), then tabulated on nodes uniform in ω, and
the table is read by linear interpolation (:class:`torchirid.lut.LUT`).

Accuracy (float64). The node count is chosen (``nodes=None``) so that the linear
interpolation error, measured on 31 points inside every cell against the exact
:math:`\bar{\mathbf C}`, is ≤ ``tolerance`` = 5e-7 for every channel; the measured maximum is
recorded in the table's ``parameters["max_interp_error"]``. The shipped tables (CIE 1931 2°
and CIE 1964 10°, D65 and E, 380–780 nm) need 3,480–3,643 nodes (113–118 kB each) and
measure ≤ 5e-7, i.e. :math:`|\bar{\mathbf C}_{interp}(\omega) - \bar{\mathbf C}(\omega)|
\le 10^{-6}` (of the white's ``Y = 1``) everywhere, with a 2× margin. A box colour ``Σ w_j ΔC̄`` therefore errs by at most
``1e-6 · Σ_j |w_j − w_{j−1}|`` (with ``w = 0`` outside the boxes). In float32 (table and ω)
the rounding of ω (≤ 9.3e-10 nm⁻¹ at ω ≈ 0.016, times a slope :math:`\bar{\mathbf c}` of up
to ≈ 650 nm) and of the values adds to it: measured ≤ 9e-7 in all against the exact
:math:`\bar{\mathbf C}` (CIE 1931 2°, D65, 2·10⁵ random ω), so ≤ 2e-6 per box.

Landmarks outside :math:`[\omega_{min}, \omega_{max}]` are clamped to it (the table's
``"clamp"`` mode), so boxes outside the range contribute 0, as in the paper, which only keeps
the landmarks overlapping the visible range.

The package ships tables in ``torchirid/data/cmf_cumulative/`` (built by
``luts/build_cumulative_cmf.py``); :func:`shipped_cumulative_cmf_lut` loads them, checks their hash and
metadata, and otherwise builds the table in memory (nothing is written).
"""

from __future__ import annotations

import importlib.resources
import math
import re

import numpy as np
import torch

from .. import _autograd, _checks
from ..color.colorimetry import weighted_cmfs_numpy, check_illuminant, check_observer
from ..lut import LUT
from .._shipped import read_or_build
from .._cache import cached

__all__ = ["cumulative_cmf_lut", "shipped_cumulative_cmf_lut"]

#: ``builder`` string stored in the tables (checked when a shipped file is loaded).
CUMULATIVE_CMF_BUILDER = "torchirid.spectral.cumulative:cumulative_cmf_lut"
#: Default bound on the measured linear-interpolation error of the automatic node count.
CUMULATIVE_CMF_TOLERANCE = 5e-7
#: The ω grid rule (stored in the parameters; a different rule means a different table).
_GRID = "uniform_omega"
#: Points checked inside every cell (t = k/32, k = 1..31, the midpoint included).
_CHECK_POINTS = 31
_DATA_DIR = "data/cmf_cumulative"
_TWO_PI = 2.0 * math.pi


# ---------------------------------------------------------------------------------------
# validation
# ---------------------------------------------------------------------------------------


def _check_range(wavelength_range) -> tuple[float, float]:
    return _checks.check_wavelength_range(wavelength_range)


def _check_nodes(nodes) -> None:
    if nodes is None:
        return
    if isinstance(nodes, bool) or not isinstance(nodes, (int, np.integer)) or nodes < 2:
        raise ValueError(f"nodes must be None (automatic) or an integer >= 2; got {nodes!r}")


def _check_tolerance(tolerance) -> None:
    if isinstance(tolerance, bool) or not isinstance(tolerance, (int, float)) \
            or not (math.isfinite(tolerance) and tolerance > 0):
        raise ValueError(f"tolerance must be a finite number > 0; got {tolerance!r}")


# ---------------------------------------------------------------------------------------
# the exact cumulative integral (numpy float64)
# ---------------------------------------------------------------------------------------


class _Exact:
    """Exact :math:`\\bar{\\mathbf C}(\\omega)` of the piecewise-linear integrand, and its slope."""

    def __init__(self, observer: str, illuminant: str, lo: float, hi: float):
        wl, prod = weighted_cmfs_numpy(observer, illuminant)  # (K,), (K, 3): S·x̄ on the observer grid
        a, b = max(lo, wl[0]), min(hi, wl[-1])  # the integrand is 0 outside the observer's range
        if not a < b:
            raise ValueError(
                f"wavelength_range ({lo:g}, {hi:g}) nm does not overlap the range of observer "
                f"{observer!r} ({wl[0]:g}–{wl[-1]:g} nm)")
        inner = (wl > a) & (wl < b)
        knots = np.concatenate(([a], wl[inner], [b]))
        values = np.stack([np.interp(knots, wl, prod[:, c]) for c in range(3)], axis=-1)
        # tail[k] = ∫_{knots[k]}^{b} S x̄ dλ (trapezoid = exact for a linear integrand)
        seg = 0.5 * np.diff(knots)[:, None] * (values[1:] + values[:-1])
        tail = np.concatenate((np.cumsum(seg[::-1], axis=0)[::-1], np.zeros((1, 3))), axis=0)
        self.knots, self.values, self.tail = knots, values, tail
        self.norm = tail[0, 1]  # ∫_λmin^λmax S ȳ dλ
        self.lo, self.hi = lo, hi

    def _locate(self, lam: np.ndarray):
        lam = np.clip(lam, self.knots[0], self.knots[-1])
        i = np.clip(np.searchsorted(self.knots, lam, side="right") - 1, 0, self.knots.size - 2)
        k0, k1 = self.knots[i], self.knots[i + 1]
        t = ((lam - k0) / (k1 - k0))[..., None]
        p = self.values[i] * (1.0 - t) + self.values[i + 1] * t  # S x̄ (λ), linear on the cell
        return lam, i, k1, p

    def cumulative(self, omega: np.ndarray) -> np.ndarray:
        """C̄(ω), shape ``omega.shape + (3,)``; ω outside the range is clamped."""
        lam, i, k1, p = self._locate(_TWO_PI / np.asarray(omega, dtype=np.float64))
        # ∫_λ^{k1} of the linear integrand = width × mean of its end values (exact)
        partial = 0.5 * (k1 - lam)[..., None] * (p + self.values[i + 1])
        return (self.tail[i + 1] + partial) / self.norm

    def density(self, omega: np.ndarray) -> np.ndarray:
        """c̄(ω) = dC̄/dω = S x̄(2π/ω) · 2π/ω² / ∫ S ȳ (nm), 0 outside the range."""
        omega = np.asarray(omega, dtype=np.float64)
        lam = _TWO_PI / omega
        _, _, _, p = self._locate(lam)
        inside = (lam >= self.knots[0]) & (lam <= self.knots[-1])
        return np.where(inside[..., None], p * (_TWO_PI / omega**2)[..., None] / self.norm, 0.0)

    def max_curvature(self, samples: int = 200_001) -> float:
        """max over ω and channels of |C̄''(ω)| (for the node-count estimate)."""
        lam = np.linspace(self.knots[0], self.knots[-1], samples)
        _, i, _, p = self._locate(lam)
        slope = (self.values[i + 1] - self.values[i]) / (self.knots[i + 1] - self.knots[i])[:, None]
        omega = _TWO_PI / lam
        dlam = -_TWO_PI / omega**2  # dλ/dω
        d2lam = 2.0 * _TWO_PI / omega**3  # d²λ/dω²
        # C̄(ω) = T(λ(ω))/norm with T' = −S x̄: C̄'' = (−(S x̄)' λ'² − S x̄ λ'') / norm
        c2 = (-slope * dlam[:, None] ** 2 - p * d2lam[:, None]) / self.norm
        return float(np.abs(c2).max())


@cached(maxsize=32)
def _exact(observer: str, illuminant: str, lo: float, hi: float) -> _Exact:
    return _Exact(observer, illuminant, lo, hi)


def _interp_error(lut: LUT, exact: _Exact) -> np.ndarray:
    """Max |linear interpolation − exact| per channel, on 31 points inside every cell."""
    g = lut.axes["omega"].detach().cpu().to(torch.float64)
    t = torch.arange(1, _CHECK_POINTS + 1, dtype=torch.float64) / (_CHECK_POINTS + 1)
    omega = (g[:-1, None] + (g[1:] - g[:-1])[:, None] * t).reshape(-1)
    with torch.no_grad():
        approx = lut(omega=omega).numpy()
    return np.abs(approx - exact.cumulative(omega.numpy())).max(axis=0)


# ---------------------------------------------------------------------------------------
# building
# ---------------------------------------------------------------------------------------


def _round_up(x: float, digits: int = 4) -> float:
    """``x`` ≥ 0 rounded *up* to ``digits`` significant digits (a stored bound never understates)."""
    if x <= 0.0:
        return 0.0
    scale = 10.0 ** (math.floor(math.log10(x)) - digits + 1)
    return float(f"{math.ceil(x / scale) * scale:.{digits}g}")


def _table(exact: _Exact, observer: str, illuminant: str, nodes: int, tolerance) -> LUT:
    lo, hi = exact.lo, exact.hi
    omega = np.linspace(_TWO_PI / hi, _TWO_PI / lo, nodes)
    values = exact.cumulative(omega)
    values[0] = 0.0  # C̄(ω_min) = 0 (exact already; written explicitly against rounding)
    values[-1] = exact.tail[0] / exact.norm  # the perfect reflector, Y = 1
    parameters = {
        "observer": observer,
        "illuminant": illuminant,
        "wavelength_range": [lo, hi],
        "nodes": int(nodes),
        "grid": _GRID,
        "tolerance": tolerance,
        "max_interp_error": None,
        "check_points_per_cell": _CHECK_POINTS,
    }
    units = {"omega": "nm^-1", "values": "1"}
    return LUT(torch.from_numpy(values), {"omega": torch.from_numpy(omega)},
               builder=CUMULATIVE_CMF_BUILDER, parameters=parameters, units=units)


def cumulative_cmf_lut(
    observer: str = "CIE 1931 2",
    illuminant: str = "D65",
    wavelength_range=(380.0, 780.0),
    nodes: int | None = None,
    *,
    tolerance: float = CUMULATIVE_CMF_TOLERANCE,
) -> LUT:
    r"""Build the cumulative CMF table :math:`\bar{\mathbf C}(\omega)` (Fourneau et al. 2024, eq. 15–16).

    .. math::
        \bar{\mathbf C}(\omega) = \int_{\omega_{min}}^{\omega} \bar{\mathbf c}(\omega')\,d\omega'
        = \frac{\int_{2\pi/\omega}^{\lambda_{max}} S(\lambda)\,\bar{\mathbf x}(\lambda)\,d\lambda}
               {\int_{\lambda_{min}}^{\lambda_{max}} S(\lambda)\,\bar y(\lambda)\,d\lambda}

    integrated exactly for the illuminant × CMF product linear between the observer's
    tabulated wavelengths (what :func:`~torchirid.color.spectrum_to_xyz` integrates), then
    sampled on ``nodes`` points uniform in ω from :math:`2\pi/\lambda_{max}` to
    :math:`2\pi/\lambda_{min}`.

    Args:
        observer: one of :data:`torchirid.color.OBSERVERS`.
        illuminant: one of :data:`torchirid.color.ILLUMINANTS`.
        wavelength_range: ``(λ_min, λ_max)`` in nm, ``0 < λ_min < λ_max``, overlapping the
            observer's range (the integrand is 0 outside it, as in ``spectrum_to_xyz``).
        nodes: number of ω nodes (≥ 2), or ``None`` (default): the count from the bound
            ``h² max|C̄''| / 8 ≤ tolerance``, increased until the measured error is
            ≤ ``tolerance`` (3,480–3,643 for 380–780 nm).
        tolerance: bound on the measured interpolation error for ``nodes=None``
            (default 5e-7, half the promised 1e-6); ignored (stored as ``None``) when
            ``nodes`` is given.

    Returns:
        a float64 CPU :class:`~torchirid.lut.LUT` with axis ``"omega"`` (nm⁻¹, increasing)
        and 3 channels (X, Y, Z); ``parameters``: ``observer``, ``illuminant``,
        ``wavelength_range``, ``nodes``, ``grid`` (``"uniform_omega"``), ``tolerance``,
        ``max_interp_error`` (measured, per channel: max over 31 points inside every cell of
        the difference between the linear interpolation and the exact C̄),
        ``check_points_per_cell``.

    Raises:
        ValueError: unknown ``observer``/``illuminant`` (listing the valid names), a bad
            ``wavelength_range``, ``nodes`` or ``tolerance``.

    Example:
        >>> lut = cumulative_cmf_lut("CIE 1931 2", "D65")
        >>> lut.parameters["nodes"], max(lut.parameters["max_interp_error"]) <= 5e-7
        (3643, True)
        >>> [round(v, 5) for v in lut.values[-1].tolist()]  # the perfect reflector, 380–780 nm
        [0.95042, 1.0, 1.08859]
    """
    check_observer(observer)
    check_illuminant(illuminant)
    lo, hi = _check_range(wavelength_range)
    _check_nodes(nodes)
    _check_tolerance(tolerance)
    exact = _exact(observer, illuminant, lo, hi)
    if nodes is not None:
        lut = _table(exact, observer, illuminant, int(nodes), None)
        err = _interp_error(lut, exact)
    else:
        # linear interpolation errs by ≤ h² max|C̄''| / 8 on a cell of width h
        span = _TWO_PI / lo - _TWO_PI / hi
        n = max(2, math.ceil(span * math.sqrt(exact.max_curvature() / (8.0 * tolerance))) + 1)
        while True:
            lut = _table(exact, observer, illuminant, n, float(tolerance))
            err = _interp_error(lut, exact)
            if err.max() <= tolerance:
                break
            n = math.ceil((n - 1) * math.sqrt(err.max() / tolerance) * 1.01) + 1  # error ∝ h²
    parameters = lut.parameters
    parameters["max_interp_error"] = [_round_up(float(e)) for e in err]
    return LUT(lut.values, lut.axes, builder=CUMULATIVE_CMF_BUILDER, parameters=parameters,
               units=lut.units)


# ---------------------------------------------------------------------------------------
# shipped tables and the in-memory cache
# ---------------------------------------------------------------------------------------


def _slug(observer: str, illuminant: str, lo: float, hi: float) -> str:
    def part(s: str) -> str:
        return re.sub(r"[^a-z0-9]+", "_", s.lower().replace(".", "p")).strip("_")

    return f"{part(observer)}_{part(illuminant)}_{part(f'{lo:g}')}_{part(f'{hi:g}')}nm"


def cumulative_cmf_path(observer: str = "CIE 1931 2", illuminant: str = "D65",
                        wavelength_range=(380.0, 780.0)):
    """Where the shipped table for these settings lives (whether or not it exists):
    ``torchirid/data/cmf_cumulative/<slug>.npz``, e.g. ``cie_1931_2_d65_380_780nm.npz``."""
    check_observer(observer)
    check_illuminant(illuminant)
    lo, hi = _check_range(wavelength_range)
    return importlib.resources.files("torchirid").joinpath(
        _DATA_DIR, _slug(observer, illuminant, lo, hi) + ".npz")


def _load_or_build(observer: str, illuminant: str, lo: float, hi: float) -> LUT:
    resource = cumulative_cmf_path(observer, illuminant, (lo, hi))
    expected = {"observer": observer, "illuminant": illuminant, "wavelength_range": [lo, hi],
                "grid": _GRID, "tolerance": CUMULATIVE_CMF_TOLERANCE}
    return read_or_build(resource, lambda: cumulative_cmf_lut(observer, illuminant, (lo, hi)),
                         what="shipped_cumulative_cmf_lut", script="luts/build_cumulative_cmf.py",
                         builder=CUMULATIVE_CMF_BUILDER, parameters=expected,
                         expect={"axes": ("omega",), "channels": (3,), "units": {"omega": "nm^-1"}})


@cached(maxsize=None)
@_autograd.normal_tensors
def _cached(observer: str, illuminant: str, lo: float, hi: float, dtype: torch.dtype,
            device: torch.device) -> LUT:
    if dtype == torch.float64 and device == torch.device("cpu"):
        return _load_or_build(observer, illuminant, lo, hi)
    return _cached(observer, illuminant, lo, hi, torch.float64, torch.device("cpu")).to(
        dtype=dtype, device=device)


def shipped_cumulative_cmf_lut(
    observer: str = "CIE 1931 2",
    illuminant: str = "D65",
    wavelength_range=(380.0, 780.0),
    *,
    dtype: torch.dtype = torch.float64,
    device=None,
) -> LUT:
    r"""The cumulative CMF table :math:`\bar{\mathbf C}(\omega)` (eq. 15–16), cached in memory.

    Loads the shipped ``torchirid/data/cmf_cumulative/<slug>.npz`` (see
    ``cumulative_cmf_path``) after checking its content hash, builder and parameters
    (observer, illuminant, wavelength range, grid rule, tolerance); if there is none, or it
    does not match (a ``RuntimeWarning`` says so), the table is built in memory with
    :func:`cumulative_cmf_lut` — nothing is written at run time. Cached per
    ``(observer, illuminant, wavelength_range, dtype, device)``: repeated calls return the
    same object; treat its tensors as read-only.

    This is a data getter with no input tensor to follow, so it takes ``dtype``/``device``
    keywords (as :func:`torchirid.color.cmfs` does).

    Args:
        observer: one of :data:`torchirid.color.OBSERVERS`.
        illuminant: one of :data:`torchirid.color.ILLUMINANTS`.
        wavelength_range: ``(λ_min, λ_max)`` in nm (default 380–780, as
            :func:`torchirid.bragg_xyz`).
        dtype: real floating dtype of the table (default float64; in float32 the
            lookups are within 9e-7, see the module docstring).
        device: device of the table (default CPU).

    Returns:
        :class:`~torchirid.lut.LUT`, axis ``"omega"`` (nm⁻¹), channels X, Y, Z; linear
        interpolation is within 1e-6 of the exact :math:`\bar{\mathbf C}` (float64).

    Raises:
        ValueError: unknown names, a bad ``wavelength_range`` or a non-floating ``dtype``.

    Example:
        >>> import math, torch
        >>> lut = shipped_cumulative_cmf_lut()
        >>> lut(omega=torch.tensor([2 * math.pi / 780, 2 * math.pi / 380], dtype=torch.float64))[:, 1]
        tensor([0., 1.], dtype=torch.float64)
    """
    check_observer(observer)
    check_illuminant(illuminant)
    lo, hi = _check_range(wavelength_range)
    if dtype not in (torch.float64, torch.float32):  # half precision cannot resolve the ω nodes
        raise ValueError(f"dtype must be torch.float64 or torch.float32; got {dtype!r}")
    dev = torch.device("cpu") if device is None else torch.device(device)
    if dev.type == "cuda" and dev.index is None:
        dev = torch.device("cuda", torch.cuda.current_device())
    return _cached(observer, illuminant, lo, hi, dtype, dev)


# ---------------------------------------------------------------------------------------
# the box integrals of eq. 15
# ---------------------------------------------------------------------------------------


def box_integrals(omega_edges, lut: LUT) -> torch.Tensor:
    r"""Colour of unit boxes between landmarks: :math:`\bar{\mathbf C}(\omega_{j+1}) - \bar{\mathbf C}(\omega_j)`.

    With these, the colour of a piecewise-constant spectrum
    :math:`\tilde R = \sum_j w_j B_j(\omega)` (Fourneau et al. 2024, eq. 14–15) is
    ``(w[..., None] * box_integrals(edges, lut)).sum(-2)``.

    Args:
        omega_edges: ``(*, J+1)`` box boundaries ω_j in nm⁻¹ (ω = 2π/λ), non-decreasing along
            the last axis (equal edges give empty boxes); values outside the table's range
            are clamped to it (those parts of a box contribute 0). NaN propagates.
        lut: the table, from :func:`shipped_cumulative_cmf_lut` or :func:`cumulative_cmf_lut` (axis
            ``"omega"``, 3 channels), on the device of ``omega_edges``.

    Returns:
        ``(*, J, 3)`` XYZ of each unit box (white at ``Y = 1``), in the dtype of
        ``omega_edges`` (computed in the table's precision). One batched interpolation;
        differentiable w.r.t. ``omega_edges``: :math:`\partial/\partial\omega_{j+1} =
        \bar{\mathbf c}`, the slope of the table's cell (the mean of the exact
        :math:`\bar{\mathbf c}` over that cell), and 0 outside the range.

    Raises:
        ValueError: ``omega_edges`` not real, with fewer than 2 entries on its last axis, or
            decreasing; a ``lut`` without an ``"omega"`` axis and 3 channels; a device mismatch.

    Example:
        >>> import math, torch
        >>> lut = shipped_cumulative_cmf_lut()
        >>> edges = 2 * math.pi / torch.tensor([780.0, 600.0, 500.0, 380.0], dtype=torch.float64)
        >>> boxes = box_integrals(edges, lut)             # red, green, blue thirds
        >>> [round(v, 4) for v in boxes[:, 1].tolist()]
        [0.1525, 0.7709, 0.0766]
        >>> [round(v, 5) for v in boxes.sum(0).tolist()]  # together: the perfect reflector
        [0.95042, 1.0, 1.08859]
    """
    if not isinstance(lut, LUT) or lut.axis_names != ("omega",) or lut.channel_shape != (3,):
        raise ValueError("lut must be a LUT with one axis 'omega' and 3 channels (X, Y, Z), "
                         "e.g. shipped_cumulative_cmf_lut(); got " + repr(lut))
    dtype, device = _checks.resolve_dtype_device(omega_edges)
    omega = _checks.as_real(omega_edges, "omega_edges", dtype, device)
    if omega.ndim == 0 or omega.shape[-1] < 2:
        raise ValueError(f"omega_edges must have shape (*, J+1) with J+1 >= 2 box boundaries on "
                         f"its last axis; got shape {tuple(omega.shape)}")
    if omega.device != lut.device:
        raise ValueError(f"omega_edges is on {omega.device} but lut is on {lut.device}; use "
                         f"shipped_cumulative_cmf_lut(..., device=omega_edges.device)")
    with torch.no_grad():
        if bool((omega[..., 1:] < omega[..., :-1]).any()):  # NaN compares False: it propagates
            raise ValueError("omega_edges must be non-decreasing along the last axis "
                             "(landmarks ω_0 ≤ ω_1 ≤ ... in nm⁻¹)")
    c = lut(omega=omega)  # (*, J+1, 3), one batched interpolation
    return (c[..., 1:, :] - c[..., :-1, :]).to(dtype)
