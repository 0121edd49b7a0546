r"""The Fourier-transformed spectral sensitivity Ŝ of Belcour & Barla's thin-film colour: exact, tabulated and prefiltered.

Belcour & Barla 2017, summarised by Kneiphof et al. 2019, §3.1 (eq. 2–5, 18).

Sensitivity. With wavenumber ν = 1/λ (nm⁻¹), the sensitivity of channel j ∈ {X, Y, Z} is the
illuminant × CMF product normalised so that the perfect reflector has Y = 1 — exactly the
integrand of :func:`torchirid.color.spectrum_to_xyz` (the paper's eq. 2 with ``S_j`` =
this; ``illuminant="E"`` gives the plain CMFs that Belcour & Barla use):

.. math::
    S_j(ν)\,dν = \frac{S(λ)\,\bar x_j(λ)\,dλ}{\int S\bar y\,dλ},\qquad
    \hat S_j(D) = \int S_j(ν)\, e^{-2\pi i ν D}\, dν
               = \int \frac{S\bar x_j}{\int S\bar y}\, e^{-2\pi i D/λ}\, dλ,

so :math:`\hat S(0)` is the white's XYZ (Y = 1) and :math:`\hat S(-D) = \overline{\hat S(D)}`.
``S x̄_j`` is linear between the observer's tabulated wavelengths (what ``spectrum_to_xyz``
integrates); ``fourier_sensitivity_exact()`` integrates it with 8-point Gauss–Legendre on
every ≤ 1 nm sub-cell (3,760 nodes for CIE 1931 2°; changing to 10 nodes on 0.5 nm cells moves
Ŝ by < 1e-14 for D ≤ 40 µm).

Tabulation (:func:`fourier_sensitivity`). The shipped LUT stores, on D = 0, 5, …, 20,000 nm,
the magnitude and the **unwrapped** phase of each channel (channels ``(3, 2)``): Ŝ is a slowly
varying envelope times a carrier of period ≈ 550 nm, which (real, imag) would interpolate far
worse; the table is within 1e-5 of the quadrature (tested). The layouts compared, per step:
docs/performance.md, "Thin-film colour: Belcour–Barla Fourier series vs exact integration"
(``benchmarks/thin_film_fig7.py --sensitivity-accuracy``). Beyond 20 µm the LUT returns 0:
there |Ŝ| ≤ 2.1e-3 (CIE 1931 2°) / 1.6e-3 (Stiles & Burch), and the eq. 4 terms that reach it
(m·D > 20 µm, e.g. m = 4 on a 1.25 µm-thick n = 2 film at normal incidence) are
attenuated further by :math:`|r_{21} r_{23}|^m`.

Prefiltering (eq. 18). For D ~ N(μ, σ²), :math:`E[e^{-2\pi iνD}] = e^{-2\pi iνμ - 2\pi^2ν^2σ^2}`
(the Gaussian characteristic function), hence

.. math:: \hat S(μ, σ^2) = \int S(ν)\, e^{-2\pi^2 σ^2 ν^2}\, e^{-2\pi i ν μ}\, dν
          = (\hat S * \mathcal N(0, σ^2))(μ),

i.e. in angular wavenumber k = 2πν each spectral component is damped by exp(−σ²k²/2); the
damping is not a single factor per channel (k spans a band), so
``prefiltered_fourier_sensitivity()`` integrates it exactly.
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

__all__ = [
    "fourier_sensitivity",
    "shipped_fourier_sensitivity_lut",
    "fourier_sensitivity_lut",
    "prefiltered_sensitivity_lut",
    "shipped_prefiltered_sensitivity_lut",
    "lookup_prefiltered_sensitivity",
]

#: ``builder`` string stored in the Ŝ tables (checked when a shipped file is loaded): a label that
#: names the module the tables were first built in, kept so that the shipped files stay valid.
FOURIER_SENSITIVITY_BUILDER = "torchirid.ibl.fourier:fourier_sensitivity_lut"
PREFILTERED_SENSITIVITY_BUILDER = "torchirid.ibl.fourier:prefiltered_sensitivity_lut"
#: How :func:`~torchirid.ibl.thin_film_xyz_fourier` evaluates Ŝ.
SENSITIVITY_MODES = ("lut", "exact")
_D_MAX = 20000.0  # nm: covers m·D for M = 4 terms on films up to 1 µm of index 2 (16 µm)
_D_STEP = 5.0  # nm
_REPRESENTATION = "magnitude_phase"
_GL_NODES = 8
_SUB_CELL = 1.0  # nm
_DATA_DIR = "data/fourier_sensitivity"
_PREFILTERED_DATA_DIR = "data/prefiltered_sensitivity"
#: the grid of the shipped 2-D tables (:func:`prefiltered_sensitivity_lut`'s defaults), written by
#: ``luts/build_prefiltered_sensitivity.py`` with float32 values
PREFILTERED_SHIPPED = {"d_max": _D_MAX, "step": 10.0, "sigma_max": 1000.0, "sigma_nodes": 41}
_TWO_PI = 2.0 * math.pi


# ---------------------------------------------------------------------------------------
# exact Ŝ by quadrature
# ---------------------------------------------------------------------------------------


@cached(maxsize=None)
def _quadrature_numpy(observer: str, illuminant: str) -> tuple[np.ndarray, np.ndarray]:
    """Nodes λ (N,) and weights (N, 3) with Σ_k w_k f(λ_k) = ∫ f S x̄ dλ / ∫ S ȳ dλ.

    Gauss–Legendre (8 nodes) on every ≤ 1 nm sub-cell of the observer's grid, on which the
    integrand's S x̄ factor is linear; the Y weights sum to 1.
    """
    wl, prod = weighted_cmfs_numpy(observer, illuminant)
    x, w = np.polynomial.legendre.leggauss(_GL_NODES)
    lams, ws = [], []
    for i in range(wl.size - 1):
        a, b = wl[i], wl[i + 1]
        edges = np.linspace(a, b, max(1, math.ceil((b - a) / _SUB_CELL)) + 1)
        lo, hi = edges[:-1, None], edges[1:, None]
        lam = (0.5 * (lo + hi) + 0.5 * (hi - lo) * x).reshape(-1)
        t = ((lam - a) / (b - a))[:, None]
        p = prod[i] * (1.0 - t) + prod[i + 1] * t
        lams.append(lam)
        ws.append(p * (0.5 * (hi - lo) * w).reshape(-1, 1))
    lam = np.concatenate(lams)
    weights = np.concatenate(ws)
    return lam, weights / weights[:, 1].sum()


@cached(maxsize=None)
@_autograd.normal_tensors  # (a first call in inference mode must not cache inference tensors)
def _quadrature(observer, illuminant, dtype, device):
    lam, w = _quadrature_numpy(observer, illuminant)
    return (torch.as_tensor(1.0 / lam, dtype=dtype, device=device),
            torch.as_tensor(w, dtype=dtype, device=device))


def _sensitivity_width(sensitivity: str, observer: str, illuminant: str, dtype, device) -> int:
    """Work per Ŝ value for the block evaluation (:mod:`torchirid._chunks`): 3 (X, Y, Z) from a
    table, the quadrature's node count (3 760 for CIE 1931 2° / D65) by quadrature."""
    return 3 if sensitivity == "lut" else _quadrature(observer, illuminant, dtype, device)[0].numel()


def _check_names(observer, illuminant):
    check_observer(observer)
    check_illuminant(illuminant)


#: the colour-matching arguments of every function here and of the thin-film colours built on them
OBSERVER = _checks.Arg(None, check_observer)
ILLUMINANT = _checks.Arg(None, check_illuminant)
#: the arguments every thin-film colour function shares (``@_checks.arguments(..., **FILM_COLOUR_ARGS)``):
#: a real film above the outer index on a substrate n + iκ, and the series' options
FILM_COLOUR_ARGS = dict(
    n_film=_checks.positive(""), thickness=_checks.THICKNESS, n_substrate=_checks.INDEX,
    n_incident=_checks.positive(""), terms=_checks.integer(0), observer=OBSERVER, illuminant=ILLUMINANT,
    polarization=_checks.POLARIZATION, sensitivity=_checks.choice(SENSITIVITY_MODES),
)


def sensitivity_kernel(sensitivity: str):
    """Ŝ(D) on checked tensors, from the shipped table (``"lut"``) or by quadrature (``"exact"``):
    ``fn(D, observer, illuminant) -> complex (*, 3)`` (what the colour kernels call per block)."""
    return _lut_sensitivity if sensitivity == "lut" else _exact_sensitivity


def _lut_sensitivity(D, observer, illuminant):
    return _from_lut(_cached(observer, illuminant, D.dtype, D.device), D)

@_checks.arguments(D=_checks.REAL, observer=OBSERVER, illuminant=ILLUMINANT)
def fourier_sensitivity_exact(D, *, observer: str = "CIE 1931 2", illuminant: str = "D65") -> torch.Tensor:
    r"""Ŝ(D) by quadrature (reference; O(3,760) work per value), complex ``(*, 3)``.

    Args:
        D: optical path difference in nm (any real, negative gives the conjugate). Shape ``(*)``.
        observer: one of :data:`torchirid.color.OBSERVERS`.
        illuminant: one of :data:`torchirid.color.ILLUMINANTS`.

    Returns:
        complex ``(*, 3)`` (X, Y, Z), differentiable w.r.t. ``D``; ``Ŝ(0)`` is the white (Y = 1).
        ``D = ±∞`` gives the limit 0 (Riemann–Lebesgue: an infinitely thick film is incoherent),
        as the table of :func:`fourier_sensitivity` does beyond its range; NaN stays NaN.

    Example:
        >>> import torch
        >>> s = fourier_sensitivity_exact(torch.tensor([0.0, 1000.0], dtype=torch.float64))
        >>> round(s[0, 1].real.item(), 12), round(abs(s[1, 1]).item(), 4)
        (1.0, 0.7013)
    """
    return _exact_sensitivity(D, observer, illuminant)


def _exact_sensitivity(d, observer, illuminant):
    """:func:`fourier_sensitivity_exact` on a checked tensor."""
    nu, w = _quadrature(observer, illuminant, d.dtype, d.device)
    infinite = d.isinf()
    d = torch.where(infinite, torch.zeros_like(d), d)  # cos(±∞) is NaN; the limit is 0 (below)
    phase = (-_TWO_PI) * d[..., None] * nu
    s = torch.complex(torch.cos(phase) @ w, torch.sin(phase) @ w)
    return torch.where(infinite[..., None], torch.zeros_like(s), s)


@_checks.arguments(mu=_checks.REAL, sigma2=_checks.nonnegative("nm^2"), observer=OBSERVER, illuminant=ILLUMINANT)
def prefiltered_fourier_sensitivity(mu, sigma2, *, observer: str = "CIE 1931 2",
                                    illuminant: str = "D65") -> torch.Tensor:
    r"""Kneiphof's eq. 18: :math:`\hat S(μ, σ^2) = E_{D\sim N(μ,σ^2)}[\hat S(D)]`, exactly.

    :math:`= \int S(ν) e^{-2\pi^2σ^2ν^2} e^{-2\pi iνμ} dν` (see the module docstring),
    by the quadrature of ``fourier_sensitivity_exact()``.

    Args:
        mu: mean optical path difference μ_D in nm. Shape ``(*)``.
        sigma2: its variance σ²_D in nm² (≥ 0); ``0`` gives Ŝ(μ).

    Returns:
        complex ``(*, 3)``, differentiable w.r.t. ``mu`` and ``sigma2``; 0 for ``mu = ±∞``
        or ``sigma2 = ∞`` (the limits).

    Example:
        >>> import torch
        >>> s = prefiltered_fourier_sensitivity(torch.tensor(1000.0, dtype=torch.float64), 100.0**2)
        >>> round(abs(s[1]).item(), 4)  # |Ŝ_Y(1000)| = 0.7013 damped by the blur
        0.3742
    """
    return _exact_prefiltered(mu, sigma2, observer, illuminant)


def prefiltered_kernel(sensitivity: str):
    """Ŝ(μ, σ²) on checked tensors, by quadrature (``"exact"``) or from the shipped 2-D table
    (``"lut"``): ``fn(mu, sigma2, observer, illuminant) -> complex (*, 3)``."""
    return _exact_prefiltered if sensitivity == "exact" else _lut_prefiltered


def _lut_prefiltered(m, s2, observer, illuminant):
    return _from_prefiltered_lut(_prefiltered_cached(observer, illuminant, m.dtype, m.device), m, s2)


def _exact_prefiltered(m, s2, observer, illuminant):
    """:func:`prefiltered_fourier_sensitivity` on checked tensors."""
    nu, w = _quadrature(observer, illuminant, m.dtype, m.device)
    infinite = m.isinf()
    m = torch.where(infinite, torch.zeros_like(m), m)  # the limit μ → ±∞ is 0, as in fourier_sensitivity_exact
    phase = (-_TWO_PI) * m[..., None] * nu
    damp = torch.exp((-2.0 * math.pi**2) * s2[..., None] * nu * nu)
    s = torch.complex((damp * torch.cos(phase)) @ w, (damp * torch.sin(phase)) @ w)
    return torch.where(infinite.expand(s.shape[:-1])[..., None], torch.zeros_like(s), s)


# ---------------------------------------------------------------------------------------
# the LUT
# ---------------------------------------------------------------------------------------


def fourier_sensitivity_lut(observer: str = "CIE 1931 2", illuminant: str = "D65", *,
                              d_max: float = _D_MAX, step: float = _D_STEP) -> LUT:
    r"""Tabulate Ŝ(D), D ∈ [0, d_max] nm every ``step`` nm, as (magnitude, unwrapped phase).

    Returns:
        float64 CPU :class:`~torchirid.lut.LUT`, axis ``"D"`` (nm), channels ``(3, 2)``:
        ``[..., j, 0] = |Ŝ_j(D)|``, ``[..., j, 1] = arg Ŝ_j(D)`` unwrapped along D (rad);
        ``parameters["max_interp_error"]``: measured max |Ŝ_interp − Ŝ| per channel at the
        cell midpoints and quarter points.

    Example:
        >>> lut = fourier_sensitivity_lut(d_max=1000.0)
        >>> lut.values.shape, max(lut.parameters["max_interp_error"]) < 1e-5
        (torch.Size([201, 3, 2]), True)
    """
    _check_names(observer, illuminant)
    for name, v in (("d_max", d_max), ("step", step)):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be a finite number > 0 nm; got {v!r}")
    n = int(round(d_max / step)) + 1
    D = torch.linspace(0.0, (n - 1) * step, n, dtype=torch.float64)
    s = fourier_sensitivity_exact(D, observer=observer, illuminant=illuminant).numpy()
    phase = np.unwrap(np.angle(s), axis=0)
    values = torch.from_numpy(np.stack([np.abs(s), phase], axis=-1))
    parameters = {"observer": observer, "illuminant": illuminant, "d_max": float((n - 1) * step),
                  "step": float(step), "representation": _REPRESENTATION,
                  "quadrature": f"gauss-legendre {_GL_NODES} per <= {_SUB_CELL:g} nm cell",
                  "max_interp_error": None}
    lut = LUT(values, {"D": D}, builder=FOURIER_SENSITIVITY_BUILDER, parameters=parameters,
              units={"D": "nm", "values": "magnitude 1, phase rad"})
    t = torch.tensor([0.25, 0.5, 0.75], dtype=torch.float64)
    Dc = (D[:-1, None] + step * t).reshape(-1)
    err = (_from_lut(lut, Dc) - fourier_sensitivity_exact(Dc, observer=observer,
                                                          illuminant=illuminant)).abs().amax(0)
    parameters["max_interp_error"] = [float(f"{e:.3g}") for e in err.tolist()]
    return LUT(values, {"D": D}, builder=FOURIER_SENSITIVITY_BUILDER, parameters=parameters,
               units=lut.units)


def _from_lut(lut: LUT, D: torch.Tensor) -> torch.Tensor:
    """Ŝ(D) from a (magnitude, phase) LUT: conjugate for D < 0, 0 beyond the table."""
    a = D.abs()
    v = lut(D=a)
    mag, ph = v[..., 0], v[..., 1]
    inside = (a <= lut.axes["D"][-1])[..., None]
    mag = torch.where(inside, mag, torch.zeros_like(mag))
    ph = torch.where((D < 0)[..., None], -ph, ph)
    return torch.polar(mag, ph)


def _slug(observer: str, illuminant: str) -> str:
    def part(s: str) -> str:
        return re.sub(r"[^a-z0-9]+", "_", s.lower()).strip("_")

    return f"{part(observer)}_{part(illuminant)}"


def fourier_sensitivity_path(observer: str = "CIE 1931 2", illuminant: str = "D65"):
    """Where the shipped Ŝ table lives: ``torchirid/data/fourier_sensitivity/<slug>.npz``.

    Example:
        >>> from torchirid.lut import LUT
        >>> path = fourier_sensitivity_path()  # CIE 1931 2°, D65
        >>> path.name, path.is_file()
        ('cie_1931_2_d65.npz', True)
        >>> fourier_sensitivity_path("CIE 1964 10", "E").name
        'cie_1964_10_e.npz'
        >>> LUT.read(path).axis_names  # the path difference D, in nm
        ('D',)
    """
    _check_names(observer, illuminant)
    return importlib.resources.files("torchirid").joinpath(_DATA_DIR, _slug(observer, illuminant) + ".npz")


@cached(maxsize=None)
@_autograd.normal_tensors  # (a first call in inference mode must not cache inference tensors)
def _cached(observer, illuminant, dtype, device) -> LUT:
    if dtype != torch.float64 or device != torch.device("cpu"):
        return _cached(observer, illuminant, torch.float64, torch.device("cpu")).to(dtype=dtype, device=device)
    resource = fourier_sensitivity_path(observer, illuminant)
    expected = {"observer": observer, "illuminant": illuminant, "d_max": _D_MAX, "step": _D_STEP,
                "representation": _REPRESENTATION}
    return read_or_build(resource, lambda: fourier_sensitivity_lut(observer, illuminant),
                         what="fourier_sensitivity", script="luts/build_fourier_sensitivity.py",
                         builder=FOURIER_SENSITIVITY_BUILDER, parameters=expected,
                         expect={"axes": ("D",), "channels": (3, 2), "units": {"D": "nm"}})


def shipped_fourier_sensitivity_lut(observer: str = "CIE 1931 2", illuminant: str = "D65", *,
                            dtype: torch.dtype = torch.float64, device=None) -> LUT:
    """The Ŝ(D) table (shipped for CIE 1931 2° and Stiles & Burch 1959 10° under D65; any
    other observer/illuminant is built in memory on first use, in seconds), cached; treat it as
    read-only.

    Example:
        >>> shipped_fourier_sensitivity_lut().values.shape
        torch.Size([4001, 3, 2])
    """
    _check_names(observer, illuminant)
    if dtype not in (torch.float64, torch.float32):
        raise ValueError(f"dtype must be torch.float64 or torch.float32; got {dtype!r}")
    return _cached(observer, illuminant, dtype, torch.device(device) if device is not None else torch.device("cpu"))


@_checks.arguments(D=_checks.REAL, observer=OBSERVER, illuminant=ILLUMINANT)
def fourier_sensitivity(D, *, observer: str = "CIE 1931 2", illuminant: str = "D65") -> torch.Tensor:
    r"""Ŝ(D) from the table (linear in magnitude and unwrapped phase), complex ``(*, 3)``.

    Within 1e-5 of ``fourier_sensitivity_exact()`` for |D| ≤ 20,000 nm (float64); 0 beyond.
    ``D < 0`` gives the conjugate. dtype/device follow ``D``; differentiable w.r.t. ``D``.

    Example:
        >>> import torch
        >>> round(abs(fourier_sensitivity(torch.tensor(1000.0, dtype=torch.float64))[1]).item(), 4)
        0.7013
    """
    return _lut_sensitivity(D, observer, illuminant)


_PREFILTERED_REPRESENTATION = "demodulated_real_imag"
_WARP_LAMBDA = 700.0  # nm: the σ axis is w = 1 − exp(−2π²σ²/λw²), the damping of wavenumber 1/λw
_WARP_FLOOR = 1e-3  # all but the last σ node are uniform in w on [0, 1 − this]; the last is σ_max


def _carriers(observer, illuminant, dtype, device) -> torch.Tensor:
    """Centroid wavenumber ν̄_j = ∫ν S_j dν / ∫S_j dν per channel (nm⁻¹), the carrier removed in the 2-D table."""
    nu, w = _quadrature(observer, illuminant, torch.float64, torch.device("cpu"))
    return ((nu[:, None] * w).sum(0) / w.sum(0)).to(dtype=dtype, device=device)


def _sigma_warp(sigma2: torch.Tensor, lam_w: float) -> torch.Tensor:
    """w = 1 − exp(−2π²σ²/λw²) from σ² directly (no √: smooth, and finite gradients at σ² = 0)."""
    return -torch.expm1(sigma2 * (-2.0 * math.pi**2 / lam_w**2))


def prefiltered_sensitivity_lut(observer: str = "CIE 1931 2", illuminant: str = "D65", *,
                                  d_max: float = _D_MAX, step: float = 10.0,
                                  sigma_max: float = 1000.0, sigma_nodes: int = 41) -> LUT:
    r"""Kneiphof's 2-D table Ŝ(μ_D, σ²_D) (eq. 18); the default grid is shipped
    (:func:`shipped_prefiltered_sensitivity_lut`, rebuilt by ``luts/build_prefiltered_sensitivity.py``).

    Layout (chosen by measurement: docs/performance.md). Axis ``"mu"``: μ in nm, 0 … d_max every ``step``.
    Axis ``"w"``: :math:`w = 1 - e^{-2π^2σ^2/λ_w^2}` with λw = 700 nm — the damping of a
    700 nm component, so Ŝ is close to linear in w (exactly, for a single wavenumber at
    1/λw); ``sigma_nodes − 1`` nodes uniform in w on [0, 0.999] (σ ≈ 0 … 416 nm) and a last
    node at ``sigma_max``. Channels ``(3, 2)`` = real and imaginary part of the
    **demodulated** :math:`\hat S_j(μ, σ^2)\,e^{+2πiar ν_j μ}` (ν̄_j = the channel's centroid
    wavenumber, ``parameters["carrier_nm"]`` = 1/ν̄_j): the slowly varying envelope, which
    interpolates without the 2π branch cuts that per-σ unwrapped phases have where |Ŝ_X|
    passes near 0. Read it with :func:`lookup_prefiltered_sensitivity`.

    Accuracy: within 5e-4 of the exact eq. 18 on the default grid (max over channels of
    ``|Ŝ_lut − Ŝ|``; ``parameters["max_interp_error"]`` records the build's own measure on a fixed
    3,000-point sample; tests/ibl/test_fourier.py asserts < 6e-4 on random points). The measured
    error of this layout, of finer grids and of the layouts it replaced, with the command that
    reproduces them: docs/performance.md, "Thin-film colour on rough surfaces under uniform
    light: Kneiphof Fig. 7".

    Example:
        >>> lut = prefiltered_sensitivity_lut(d_max=500.0, sigma_max=100.0, sigma_nodes=3)
        >>> lut.values.shape, lut.axis_names
        (torch.Size([51, 3, 3, 2]), ('mu', 'w'))
    """
    _check_names(observer, illuminant)
    _checks.check_int(sigma_nodes, "sigma_nodes", 3)
    for name, v in (("d_max", d_max), ("step", step), ("sigma_max", sigma_max)):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be a finite number > 0 nm; got {v!r}")
    n = int(round(d_max / step)) + 1
    mu = torch.linspace(0.0, (n - 1) * step, n, dtype=torch.float64)
    w_max = float(_sigma_warp(torch.tensor(float(sigma_max) ** 2, dtype=torch.float64), _WARP_LAMBDA))
    w_top = min(1.0 - _WARP_FLOOR, w_max)
    w = torch.cat([torch.linspace(0.0, w_top, sigma_nodes - 1, dtype=torch.float64),
                   torch.tensor([w_max], dtype=torch.float64)])
    if not bool((w[1:] > w[:-1]).all()):  # a small sigma_max: uniform in w up to it
        w = torch.linspace(0.0, w_max, sigma_nodes, dtype=torch.float64)
    sigma2 = -torch.log1p(-w) * (_WARP_LAMBDA**2 / (2.0 * math.pi**2))
    sigma2[-1] = float(sigma_max) ** 2
    nu0 = _carriers(observer, illuminant, torch.float64, torch.device("cpu"))
    s = prefiltered_fourier_sensitivity(mu[:, None], sigma2[None], observer=observer, illuminant=illuminant)
    s = s * torch.polar(torch.ones_like(nu0), _TWO_PI * nu0 * mu[:, None, None])  # demodulate
    values = torch.stack([s.real, s.imag], -1)
    parameters = {"observer": observer, "illuminant": illuminant, "d_max": float(mu[-1]),
                  "step": float(step), "sigma_max": float(sigma_max), "sigma_nodes": sigma_nodes,
                  "representation": _PREFILTERED_REPRESENTATION, "warp_lambda": _WARP_LAMBDA,
                  "carrier_nm": [float(1.0 / v) for v in nu0.tolist()],
                  "sigma_nm": [float(f"{v:.6g}") for v in sigma2.sqrt().tolist()],
                  "max_interp_error": None}
    units = {"mu": "nm", "w": "1 (1 - exp(-2 pi^2 sigma^2 / warp_lambda^2))",
             "values": "real, imag of S(mu, sigma^2) exp(+2 pi i carrier mu)"}
    lut = LUT(values, {"mu": mu, "w": w}, builder=PREFILTERED_SENSITIVITY_BUILDER, parameters=parameters,
              units=units)
    g = torch.Generator().manual_seed(0)  # a fixed sample: cell interiors of every region
    k = 3000
    mt = torch.rand(k, generator=g, dtype=torch.float64) * float(mu[-1])
    st = torch.rand(k, generator=g, dtype=torch.float64) * float(sigma_max)
    st[: k // 3] *= min(1.0, 50.0 / float(sigma_max))
    err = (_from_prefiltered_lut(lut, mt, st * st)
           - prefiltered_fourier_sensitivity(mt, st * st, observer=observer, illuminant=illuminant)).abs()
    parameters["max_interp_error"] = [float(f"{e:.3g}") for e in err.amax(0).tolist()]
    return LUT(values, {"mu": mu, "w": w}, builder=PREFILTERED_SENSITIVITY_BUILDER, parameters=parameters,
               units=units)


def _from_prefiltered_lut(lut: LUT, m: torch.Tensor, s2: torch.Tensor) -> torch.Tensor:
    """Ŝ(μ, σ²) from a demodulated 2-D table: conjugate for μ < 0, 0 beyond μ = d_max, σ clamped at σ_max."""
    p = lut.parameters
    a = m.abs()
    v = lut(mu=a, w=_sigma_warp(s2, float(p["warp_lambda"])))
    nu0 = torch.as_tensor([1.0 / c for c in p["carrier_nm"]], dtype=v.dtype, device=v.device)
    s = torch.complex(v[..., 0], v[..., 1]) * torch.polar(torch.ones_like(nu0), (-_TWO_PI) * a[..., None] * nu0)
    s = torch.where((a > lut.axes["mu"][-1])[..., None], torch.zeros_like(s), s)  # (NaN μ stays NaN)
    return torch.where((m < 0)[..., None], s.conj(), s)


def prefiltered_sensitivity_path(observer: str = "CIE 1931 2", illuminant: str = "D65"):
    """Where the shipped 2-D Ŝ(μ, σ²) table lives: ``torchirid/data/prefiltered_sensitivity/<slug>.npz``.

    Example:
        >>> path = prefiltered_sensitivity_path()  # CIE 1931 2°, D65
        >>> path.name, path.is_file()
        ('cie_1931_2_d65.npz', True)
    """
    _check_names(observer, illuminant)
    return importlib.resources.files("torchirid").joinpath(_PREFILTERED_DATA_DIR, _slug(observer, illuminant) + ".npz")


@cached(maxsize=None)
@_autograd.normal_tensors  # (a first call in inference mode must not cache inference tensors)
def _prefiltered_cached(observer, illuminant, dtype, device) -> LUT:
    if dtype != torch.float64 or device != torch.device("cpu"):
        return _prefiltered_cached(observer, illuminant, torch.float64, torch.device("cpu")).to(dtype=dtype,
                                                                                                device=device)
    resource = prefiltered_sensitivity_path(observer, illuminant)
    expected = {"observer": observer, "illuminant": illuminant, **PREFILTERED_SHIPPED,
                "representation": _PREFILTERED_REPRESENTATION, "warp_lambda": _WARP_LAMBDA}
    return read_or_build(resource, lambda: prefiltered_sensitivity_lut(observer, illuminant, **PREFILTERED_SHIPPED),
                         what="prefiltered_sensitivity", script="luts/build_prefiltered_sensitivity.py",
                         builder=PREFILTERED_SENSITIVITY_BUILDER, parameters=expected,
                         expect={"axes": ("mu", "w"), "channels": (3, 2), "units": {"mu": "nm"}},
                         dtype=torch.float64)


def shipped_prefiltered_sensitivity_lut(observer: str = "CIE 1931 2", illuminant: str = "D65", *,
                                dtype: torch.dtype = torch.float64, device=None) -> LUT:
    """Kneiphof's 2-D Ŝ(μ_D, σ²_D) table with the default grid (μ 0–20 µm every 10 nm, 41 σ nodes
    to 1000 nm, see :func:`prefiltered_sensitivity_lut`), cached per observer/illuminant/dtype/device;
    treat it as read-only. Shipped for CIE 1931 2° under D65 (float32 values on disk, the float64
    build rounded: within 1e-7); any other observer/illuminant is built in memory on first use
    (seconds).

    Example (the table :func:`lookup_prefiltered_sensitivity` reads by default):
        >>> import torch
        >>> lut = shipped_prefiltered_sensitivity_lut()  # read once, then cached
        >>> lut.axis_names, lut.values.shape  # (μ, warped σ, XYZ, (re, im))
        (('mu', 'w'), torch.Size([2001, 41, 3, 2]))
        >>> mu = torch.tensor(1000.0, dtype=torch.float64)  # nm
        >>> torch.equal(lookup_prefiltered_sensitivity(mu, 100.0**2, lut=lut), lookup_prefiltered_sensitivity(mu, 100.0**2))
        True
    """
    _check_names(observer, illuminant)
    return _prefiltered_cached(observer, illuminant, dtype,
                               torch.device(device) if device is not None else torch.device("cpu"))


@_checks.arguments(mu=_checks.REAL, sigma2=_checks.nonnegative("nm^2"), observer=OBSERVER, illuminant=ILLUMINANT,
                   lut=_checks.instance(LUT, "LUT from prefiltered_sensitivity_lut") | None)
def lookup_prefiltered_sensitivity(mu, sigma2, *, observer: str = "CIE 1931 2",
                                        illuminant: str = "D65", lut: LUT | None = None) -> torch.Tensor:
    r"""Ŝ(μ, σ²) read from Kneiphof's 2-D table (:func:`shipped_prefiltered_sensitivity_lut`, or ``lut`` from
    :func:`prefiltered_sensitivity_lut`): bilinear in (|μ|, w(σ²)) on the demodulated real and
    imaginary parts, then remodulated; conjugate for μ < 0, 0 beyond μ = 20 µm, σ clamped at
    1000 nm (where |Ŝ| < 1e-20). Within 5e-4 of ``prefiltered_fourier_sensitivity()`` (exact)
    on the default grid (measured, see :func:`prefiltered_sensitivity_lut`). What a shader does
    with Kneiphof's texture.

    Example:
        >>> import torch
        >>> s = lookup_prefiltered_sensitivity(torch.tensor(1000.0, dtype=torch.float64), 100.0**2)
        >>> round(abs(s[1]).item(), 4)
        0.3742
    """
    m, s2 = mu, sigma2
    dtype, device = m.dtype, m.device
    if lut is None:
        lut = _prefiltered_cached(observer, illuminant, dtype, device)
    elif lut.builder != PREFILTERED_SENSITIVITY_BUILDER \
            or lut.parameters.get("representation") != _PREFILTERED_REPRESENTATION:
        raise ValueError("lut must be a table from prefiltered_sensitivity_lut")
    else:
        lut = lut.to(dtype=dtype, device=device)
    return _from_prefiltered_lut(lut, m, s2)
