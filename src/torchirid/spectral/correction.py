r"""Angular correction term w̃(θ₁) of the piecewise Bragg spectra (Fourneau et al. 2024, appendix B).

Outside the band gaps the Yeh spectrum R (eq. 2) oscillates *below* its envelope R^e
(eq. 11), so boxes weighted by the envelope alone overestimate the reflectance. Appendix B
corrects the box weights by the mean ratio of the two over one period of the Bloch phase
x = KΛ (pass band, K real):

.. math::

    w(θ_1) = \frac{1}{2π}\int_0^{2π} \frac{R}{R^e}\,dx, \qquad
    R = \frac{|C|^2}{|C|^2 + \sin^2 x / \sin^2 Nx}, \qquad
    R^e = \frac{|C|^2}{|C|^2 + \sin^2 x},

with :math:`|C|^2 ≈ R_1/(1 − R_1)` and :math:`R_1 = R_{12} + R_{12}(1 − R_{12})^2/(1 − R_{12}^2)`
the reflectance of a thick (incoherent) slab of n₂ in n₁. Then
:math:`R_1 = 2R_{12}/(1 + R_{12})` and :math:`|C|^2 = 2R_{12}/(1 − R_{12})`: w depends on
the indices and the angle only through R₁₂, and not on the thicknesses.

**How the angle enters (torchirid's reading).** The paper writes R₁₂ as the reflectance at
normal incidence, yet plots w against θ₁ (its Fig. 13). Here R₁₂ = R₁₂(θ₁) is the Fresnel
reflectance of the n₁ | n₂ interface at the incidence angle θ₁ in n₁ (unpolarized by
default; ``polarization="s"`` or ``"p"`` for one polarization). This reading reproduces
the paper's statements: w is then a function of θ₁ that rises to 1 at grazing incidence
(R₁₂ → 1, R → R^e), it is flat near normal incidence like Schlick's curve, and fitting the
Schlick form over n₂ ∈ [1.25, 1.75] (n₁ = 1) gives (a, b) ≈ (0.724, 0.534), next to the
paper's (0.735, 0.532) (see ``training/fit_angular_correction.py``). With R₁₂ at normal
incidence, w would not depend on θ₁ at all.

Properties of the reference (exact statements, tested):

* R₁₂ = 0 (n₁ = n₂, or Brewster's angle in p): R/R^e → sin²Nx, w = 1/2.
* R₁₂ = 1 (grazing incidence, total internal reflection): w = 1. Close to it,
  1 − w ≈ cot(π/2N) / (N |C|) ∝ √(1 − R₁₂) ∝ √cos θ₁: w reaches 1 with an infinite slope
  in cos θ₁, which the Schlick form (slope 5(1 − w̃₀) at θ₁ = 90°) cannot follow; its
  largest errors are therefore in the last degrees before grazing.
* Large N: w → w_∞ = 1/2 + ((1 + c) arctan √c − √c)/(πc) with c = |C|² (the average over
  the fast phase Nx, :func:`angular_correction_limit`), hence w → 1/2 + (2/3π)√c for small
  R₁₂. w is "roughly invariant to N" once N√c ≳ 1: over n₂/n₁ ∈ [1.1, 2.5] and θ₁ ≤ 89°,
  N = 10, 50, 100 and ∞ differ from N = 20 (the default) by at most 0.008.

The library's approximation is Schlick's form

.. math::

    \tilde w(θ_1) = \tilde w_0 + (1 − \tilde w_0)(1 − \cos θ_1)^5, \qquad
    \tilde w_0 = a\,R_{12}(0) + b,

with R₁₂(0) = |n₁ − n₂|²/|n₁ + n₂|² the reflectance at normal incidence. The coefficients
(a, b) are fitted by autograd to the reference on a grid of angles and index pairs
(``training/fit_angular_correction.py``) and shipped in
``torchirid/data/angular_correction.json``; ``PAPER_COEFFICIENTS`` are the paper's.
"""

from __future__ import annotations

import json
import math
import numbers
import os

import torch

from .. import _checks, _chunks
from ..optics.fresnel import fresnel_reflectance
from .._cache import cached

__all__ = [
    "angular_correction",
    "fitted_coefficients",
]

#: (a, b) of Fourneau et al. 2024, appendix B: w̃₀ = 0.735 R₁₂ + 0.532
PAPER_COEFFICIENTS = (0.735, 0.532)

#: named coefficient sets accepted by :func:`angular_correction` (besides a pair ``(a, b)``)
ANGULAR_CORRECTION_COEFFICIENTS = ("fitted", "paper")

#: the shipped fit, written by training/fit_angular_correction.py
DATA_FILE = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "data",
                         "angular_correction.json")
FILE_FORMAT = "torchirid.angular_correction"
FILE_FORMAT_VERSION = 1

# ---------------------------------------------------------------------------------------------
# coefficients


@cached(maxsize=8)
def _load(path: str) -> dict:
    try:
        with open(path, encoding="utf-8") as fh:
            data = json.load(fh)
    except FileNotFoundError as exc:
        raise FileNotFoundError(
            f"angular-correction coefficients not found at {path}; run training/fit_angular_correction.py "
            "or pass coefficients='paper' / (a, b)"
        ) from exc
    except (OSError, ValueError) as exc:
        raise ValueError(f"angular-correction file {path} is not readable JSON: {exc}") from exc
    if not isinstance(data, dict) or data.get("format") != FILE_FORMAT:
        raise ValueError(f"angular-correction file {path}: format is not {FILE_FORMAT!r}")
    if data.get("format_version") != FILE_FORMAT_VERSION:
        raise ValueError(f"angular-correction file {path}: format_version {data.get('format_version')!r} "
                         f"is not {FILE_FORMAT_VERSION}")
    coeffs = data.get("coefficients")
    if not isinstance(coeffs, dict) or set(coeffs) < {"a", "b"}:
        raise ValueError(f"angular-correction file {path}: 'coefficients' must hold 'a' and 'b'")
    for key in ("a", "b"):
        v = coeffs[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ValueError(f"angular-correction file {path}: coefficient {key} must be a finite number; got {v!r}")
    return data


def fitted_coefficients(path: str | os.PathLike | None = None) -> tuple[float, float]:
    """The fitted Schlick coefficients ``(a, b)`` of w̃₀ = a R₁₂ + b shipped with torchirid.

    Read once (cached) from ``torchirid/data/angular_correction.json``, or from ``path``;
    the file's ``provenance`` records the data grid, N, the R₁₂ reading and the fit errors.
    Raises ``ValueError`` for a malformed file and ``FileNotFoundError`` if it is missing.

    Example (the coefficients ``angular_correction`` uses by default):
        >>> import torch
        >>> a, b = fitted_coefficients()
        >>> round(a, 3), round(b, 3)  # the paper's are (0.735, 0.532)
        (0.568, 0.534)
        >>> c = torch.tensor([1.0, 0.5], dtype=torch.float64)  # cos θ
        >>> torch.equal(angular_correction(c, 1.0, 1.5, coefficients=(a, b)), angular_correction(c, 1.0, 1.5))
        True
    """
    data = _load(os.fspath(path) if path is not None else DATA_FILE)
    return float(data["coefficients"]["a"]), float(data["coefficients"]["b"])


def _resolve_coefficients(coefficients):
    """(a, b) as Python floats or real tensors; ValueError naming ``coefficients`` otherwise."""
    if coefficients is None or (isinstance(coefficients, str) and coefficients == "fitted"):
        return fitted_coefficients()
    if isinstance(coefficients, str):
        if coefficients == "paper":
            return PAPER_COEFFICIENTS
        raise ValueError(f"coefficients must be one of {_checks.names(ANGULAR_CORRECTION_COEFFICIENTS)}, "
                         f"None or a pair (a, b); got {coefficients!r}")
    if isinstance(coefficients, torch.Tensor):
        if coefficients.shape[:1] != (2,):
            raise ValueError(f"coefficients as a tensor must have 2 entries on its first axis (a, b); "
                             f"got shape {tuple(coefficients.shape)}")
        coefficients = (coefficients[0], coefficients[1])
    try:
        a, b = coefficients
    except (TypeError, ValueError) as exc:
        raise ValueError(f"coefficients must be None, a name ({_checks.names(ANGULAR_CORRECTION_COEFFICIENTS)}) "
                         f"or a pair (a, b); got {coefficients!r}") from exc
    for name, v in (("a", a), ("b", b)):
        if isinstance(v, bool) or isinstance(v, complex):
            raise ValueError(f"coefficients: {name} must be a real number; got {v!r}")
        if isinstance(v, numbers.Real) and not math.isfinite(v):
            raise ValueError(f"coefficients: {name} must be finite; got {v!r}")
        if isinstance(v, torch.Tensor) and (v.is_complex() or v.dtype == torch.bool):
            raise ValueError(f"coefficients: {name} must be a real tensor; got dtype {v.dtype}")
    return a, b


def _normal_reflectance(n1: torch.Tensor, n2: torch.Tensor) -> torch.Tensor:
    """R₁₂(0) = |n₁ − n₂|² / |n₁ + n₂|² (real dtype; complex n₂ allowed)."""
    r = (n1 - n2) / (n1 + n2)  # n1, n2 have positive real parts: the denominator never vanishes
    return r.abs().square() if r.is_complex() else r * r


def _coefficients(value, name, dtype, device):
    a, b = _resolve_coefficients(value)
    return _checks.as_real(a, f"{name} (a)", dtype, device), _checks.as_real(b, f"{name} (b)", dtype, device)


@_checks.arguments(cos_theta=_checks.COSINE, n1=_checks.INCIDENT_INDEX, n2=_checks.INDEX,
                   coefficients=_checks.Arg(_coefficients))
def angular_correction(cos_theta, n1, n2, *, coefficients=None) -> torch.Tensor:
    r"""Schlick approximation w̃(θ₁) of the angular correction term (Fourneau et al. 2024, app. B).

    .. math::

        \tilde w(θ_1) = \tilde w_0 + (1 − \tilde w_0)(1 − \cos θ_1)^5, \qquad
        \tilde w_0 = a\,R_{12} + b, \qquad R_{12} = \left|\frac{n_1 − n_2}{n_1 + n_2}\right|^2 .

    The piecewise Bragg spectra weight each box outside the band gaps by w̃ · R^e (§3.2.2):
    w̃ compensates the envelope's excess over the oscillating spectrum. Dimensionless;
    w̃ = 1 at grazing incidence for any (a, b), and w̃ = a R₁₂ + b at normal incidence.

    Args:
        cos_theta: cosine of the incidence angle θ₁ in n₁, in [0, 1]. Shape ``(*)``.
        n1: real refractive index (> 0) of the incident medium (the mirror's first layer).
        n2: refractive index ``n + iκ`` (κ ≥ 0) of the second layer.
        coefficients: ``None`` or ``"fitted"`` — the library's fit (see
            :func:`fitted_coefficients`); ``"paper"`` — ``PAPER_COEFFICIENTS``
            (0.735, 0.532); or a pair ``(a, b)`` of numbers or real tensors (which broadcast
            with the other arguments, and may require grad).

    Returns:
        w̃, broadcast shape of the inputs, real dtype of the inputs; differentiable with
        respect to every tensor argument.

    Example (n₂ = 1.5 in air, R₁₂ = 0.04):
        >>> import torch
        >>> from torchirid.spectral.correction import angular_correction
        >>> c = torch.tensor([1.0, 0.5, 0.0], dtype=torch.float64)
        >>> [round(v, 6) for v in angular_correction(c, 1.0, 1.5, coefficients="paper").tolist()]
        [0.5614, 0.575106, 1.0]
    """
    c, (a, b) = cos_theta, coefficients
    if n1.is_complex():
        n1 = n1.real
    w0 = a * _normal_reflectance(n1, n2) + b
    schlick = (1 - c) ** 5
    return w0 + (1 - w0) * schlick


# ---------------------------------------------------------------------------------------------
# the reference integral


def _validated_r12(cos_theta, n1, n2, polarization):
    """R₁₂(θ₁) (Fresnel, n₁ | n₂) and the mask where it is exactly 1, after validating the inputs."""
    _checks.check_polarization(polarization)
    dtype, device = _checks.resolve_dtype_device(cos_theta, n1, n2)
    c = _checks.as_real(cos_theta, "cos_theta", dtype, device)
    n1 = _checks.as_index(n1, "n1", dtype, device)
    n2 = _checks.as_index(n2, "n2", dtype, device)
    _checks.check_cosine(c)
    _checks.check_real_index(n1, "n1")
    _checks.check_index(n2, "n2")
    r12 = fresnel_reflectance.__wrapped__(c, n1, n2, polarization=polarization)  # (checked above)
    # R₁₂ = 1 exactly at grazing incidence and under total internal reflection (real n₂), where
    # the Fresnel value may round an ulp below 1 (and 1 − w ∝ √(1 − R₁₂) would magnify that to 1e-8)
    n1r = n1.real if n1.is_complex() else n1
    one = c == 0
    if not n2.is_complex():
        one = one | (n1r * n1r * (1 - c * c) >= n2 * n2)
    return r12, one.expand(r12.shape)


def _bloch_average_limit(r12: torch.Tensor) -> torch.Tensor:
    r"""w for N → ∞: 1/2 + ((1 + c) arctan √c − √c)/(πc), c = 2R₁₂/(1 − R₁₂), R₁₂ in [0, 1].

    Averaging R/R^e over the fast phase Nx at fixed x (∫ dφ/(p sin²φ + q) = π/√(q(p + q)))
    gives (c + s² − |s|√(c + s²))/c with s = sin x, and ∫₀^π |s|√(c + s²) dx =
    √c + (1 + c) arcsin(1/√(1 + c)). Evaluated without cancellation: a series for small
    c, and u = 1/√c = √((1 − R₁₂)/(2R₁₂)) for c > 1 (no infinity at R₁₂ = 1).
    """
    small = r12 <= 1.0 / 3.0  # c <= 1
    # c ≤ 1 branch (guard: the unused branch sees R₁₂ = 0.1)
    rs = torch.where(small, r12, torch.full_like(r12, 0.1))
    c = 2 * rs / (1 - rs)
    # guard: √c has an infinite slope at c = 0 (R₁₂ = 0, Brewster for p, where w has a |r₁₂| kink):
    # the subgradient 0 there
    s = _checks.safe_sqrt(c)
    tiny = s < 0.05
    sd = torch.where(tiny, torch.full_like(s, 0.5), s)  # guard: no 0/0 at c = 0 in the unused branch
    cd = sd * sd
    direct = ((1 + cd) * torch.atan(sd) - sd) / (math.pi * cd)
    c2 = c * c
    # (2/π)(s/3 − s³/15 + s⁵/35 − s⁷/63 + s⁹/99): the Taylor series of the same expression
    series = (2 / math.pi) * s * (1 / 3 - c / 15 + c2 / 35 - c2 * c / 63 + c2 * c2 / 99)
    w_small = 0.5 + torch.where(tiny, series, direct)
    # c > 1 branch: u = 1/√c, arctan √c = π/2 − arctan u (guard: the unused branch sees R₁₂ = 0.5)
    rl = torch.where(small, torch.full_like(r12, 0.5), r12)
    u = torch.sqrt((1 - rl) / (2 * rl))
    w_large = 0.5 + ((1 + rl) / (2 * rl) * (math.pi / 2 - torch.atan(u)) - u) / math.pi
    return torch.where(small, w_small, w_large)


def angular_correction_limit(cos_theta, n1, n2, *, polarization: str = "unpolarized") -> torch.Tensor:
    r"""The reference w(θ₁) of appendix B in the limit of many cells N → ∞, in closed form.

    .. math::

        w_\infty(θ_1) = \frac12 + \frac{(1 + c)\arctan\sqrt c - \sqrt c}{π c},
        \qquad c = |C|^2 = \frac{2R_{12}(θ_1)}{1 − R_{12}(θ_1)},

    the average of R/R^e over the fast phase Nx and then over x (derived here, not in the
    paper). It is the N-independent core of :func:`angular_correction_reference`: over
    n₂/n₁ ∈ [1.1, 2.5] and θ₁ ≤ 89° it differs from the N = 20 reference by at most 0.0064,
    and it follows the steep rise of w near grazing incidence that the Schlick form of
    :func:`angular_correction` misses. w_∞ = 1/2 at R₁₂ = 0, 1 at R₁₂ = 1; dimensionless.

    Args:
        cos_theta: cosine of the incidence angle θ₁ in n₁, in [0, 1]. Shape ``(*)``.
        n1: real refractive index (> 0) of the incident medium.
        n2: refractive index ``n + iκ`` (κ ≥ 0) of the second layer.
        polarization: ``"unpolarized"`` (default), ``"s"`` or ``"p"``: the Fresnel R₁₂(θ₁) used.

    Returns:
        w_∞, broadcast shape, real dtype of the inputs; differentiable (the gradient is
        reported as 0 where R₁₂ = 1 exactly, where the true one is infinite).

    Example (n₂ = 1.5 in air):
        >>> import torch
        >>> from torchirid.spectral.correction import angular_correction_limit
        >>> c = torch.tensor([1.0, 0.5, 0.0], dtype=torch.float64)
        >>> [round(v, 6) for v in angular_correction_limit(c, 1.0, 1.5).tolist()]
        [0.560273, 0.59051, 1.0]
    """
    r12, one = _validated_r12(cos_theta, n1, n2, polarization)
    r12 = torch.where(one, torch.full_like(r12, 0.5), r12)  # guard: √(1 − R₁₂) has an infinite slope at 1
    w = _bloch_average_limit(r12)
    return torch.where(one, torch.ones_like(w), w)


def _check_count(value, name: str, minimum: int) -> int:
    if isinstance(value, bool):
        raise ValueError(f"{name} must be an integer >= {minimum}, got a bool")
    if isinstance(value, torch.Tensor):
        if value.numel() != 1 or value.is_complex() or value.is_floating_point() and value != torch.round(value):
            raise ValueError(f"{name} must be one integer >= {minimum}; got a tensor of shape {tuple(value.shape)}")
        value = int(value.item())
    if isinstance(value, numbers.Real) and not isinstance(value, numbers.Integral):
        if not math.isfinite(value) or value != int(value):
            raise ValueError(f"{name} must be an integer >= {minimum}; got {value!r}")
        value = int(value)
    if not isinstance(value, numbers.Integral):
        raise ValueError(f"{name} must be an integer >= {minimum}; got {type(value).__name__}")
    if value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}; got {value}")
    return int(value)


def _bloch_average(r12: torch.Tensor, cells: int, samples: int) -> torch.Tensor:
    r"""w = (1/π) ∫₀^π R/R^e dx for |C|² = 2R₁₂/(1 − R₁₂), batched over ``r12`` in [0, 1].

    With a = 2R₁₂, b = 1 − R₁₂, U = sin Nx / sin x (the Chebyshev U_{N−1}(cos x)):

        R/R^e = (aU² + b sin²Nx)/(aU² + b) = 1 − b cos²Nx / (aU² + b),

    a smooth π-periodic function of x (U is a polynomial in cos x: no singularity at x = 0, π;
    the zeros of sin Nx are its dips to 0). The integrand has N − 1 dips of width
    ~ sin(x_j)/(N|C|) at x_j = jπ/N, narrow for R₁₂ → 1. They are resolved by the periodic
    change of variable x = X(v) with X'(v) = (8/3) sin⁴(Nv) (a Sidi-type map: X − x_j ∝ (v − v_j)⁵
    near the dips), then the midpoint rule in v, which stays spectrally accurate because
    X'·(R/R^e)∘X is smooth and π-periodic. ``samples`` nodes per dip interval π/N; 64 give
    errors ≤ 1e-13 for R₁₂ ≤ 0.9, ≤ 2e-11 at R₁₂ = 0.99 and ≤ 3e-9 up to 1 − R₁₂ = 1e-6 at
    N = 20 (against mpmath; ≤ 3e-10 at R₁₂ = 0.99 for N = 100).
    Normalising by Σ X' (= M exactly in exact arithmetic) makes R₁₂ = 1 give exactly 1.
    """
    dtype, device = r12.dtype, r12.device
    m = samples
    # one dip interval: t = 2π(k + ½)/m ∈ (−π, π) (shifted by −2π past the middle, so that the
    # phase φ = Nx − Lπ stays in (−π/2, π/2) and sin φ is accurate near the dips)
    k = torch.arange(m, dtype=dtype, device=device)
    t = 2 * math.pi * (k + 0.5) / m
    upper = k >= m / 2
    t = torch.where(upper, t - 2 * math.pi, t)
    phi = t / 2 - (2.0 / 3.0) * torch.sin(t) + torch.sin(2 * t) / 12  # N·X(v) − Lπ, ≈ t⁵/60 near 0
    jac = (8.0 / 3.0) * torch.sin(t / 2) ** 4  # X'(v) ≥ 0, mean exactly 1 over the m nodes
    sin2_phi = torch.sin(phi) ** 2  # sin² Nx (the Lπ drops out)
    cos2_phi = torch.cos(phi) ** 2
    shift = upper.to(torch.int64)

    a = (2 * r12).reshape(-1, 1)
    b = (1 - r12).reshape(-1, 1)
    deficit = torch.zeros(a.shape[0], dtype=dtype, device=device)
    # blocks of whole dip intervals: batch × nodes × intervals ≤ the block size (torchirid._chunks; None: one)
    chunk = _chunks.get_chunk_size(device)
    cells_per_chunk = cells if chunk is None else max(1, chunk // max(1, a.shape[0] * m))
    for j0 in range(0, cells, cells_per_chunk):
        j = torch.arange(j0, min(cells, j0 + cells_per_chunk), device=device)
        L = (j[:, None] + shift[None, :]).reshape(-1)  # x = (Lπ + φ)/N, L ∈ [0, N]
        ph = phi.repeat(j.numel())
        # sin x from the nearer end of [0, π] (x and π − x are both formed without rounding to π)
        mirror = 2 * L > cells
        arg = torch.where(mirror, ((cells - L).to(dtype) * math.pi - ph) / cells, (L.to(dtype) * math.pi + ph) / cells)
        sin2_x = torch.sin(arg) ** 2  # > 0: x never reaches 0 or π at a midpoint node
        s2N = sin2_phi.repeat(j.numel())
        safe = sin2_x > 0
        # guard: an underflowed sin x (only for absurd samples) takes U² = N², its limit at x → 0
        U2 = torch.where(safe, s2N / torch.where(safe, sin2_x, torch.ones_like(sin2_x)),
                         torch.full_like(sin2_x, float(cells) ** 2))
        den = a * U2 + b  # > 0 except R₁₂ = 1 exactly at an exact zero of U
        zero = den <= 0  # (not ``den > 0``: a NaN den stays NaN)
        term = b * cos2_phi.repeat(j.numel()) / torch.where(zero, torch.ones_like(den), den)  # guard: 0/0 → 0 (b = 0)
        term = torch.where(zero, torch.zeros_like(term), term)
        deficit = deficit + (term * jac.repeat(j.numel())).sum(-1)
    total = jac.sum() * cells
    return (1 - deficit / total).reshape(r12.shape)


def angular_correction_reference(cos_theta, n1, n2, *, cells=20, samples: int = 64,
                                 polarization: str = "unpolarized") -> torch.Tensor:
    r"""Reference angular correction w(θ₁) of Fourneau et al. 2024, appendix B (the integral).

    .. math::

        w(θ_1) = \frac{1}{2π}\int_0^{2π} \frac{|C|^2 + \sin^2 x}{|C|^2 + \sin^2 x/\sin^2 Nx}\,dx,
        \qquad |C|^2 = \frac{R_1}{1 − R_1} = \frac{2R_{12}}{1 − R_{12}},

    the mean ratio of Yeh's spectrum (eq. 2) to its envelope (eq. 11) over one period of the
    Bloch phase x = KΛ, with R₁ = R₁₂ + R₁₂(1 − R₁₂)²/(1 − R₁₂²) the thick-slab reflectance.
    R₁₂ = R₁₂(θ₁) is the Fresnel reflectance of n₁ | n₂ at the incidence angle θ₁ (see the
    module docstring for this reading of the paper). w ∈ [0, 1], dimensionless; w = 1/2
    where R₁₂ = 0 and w = 1 where R₁₂ = 1 (grazing incidence, total internal reflection).

    The integrand is smooth and periodic (the 0/0 points x = 0, π are removable); it is
    integrated by the midpoint rule after a periodic change of variable that resolves its
    N − 1 narrow dips (``_bloch_average``): cost O(batch · N · samples). Accuracy in
    float64 with the defaults (N = 20, against mpmath): ≤ 1e-13 up to R₁₂ = 0.9 (θ₁ ≈ 85°
    for n₂ = 1.5 in air), ≤ 2e-11 at R₁₂ = 0.99, ≤ 3e-9 up to 1 − R₁₂ = 1e-6; exact (1) at
    grazing incidence. float32 inputs agree with float64 to ~1e-5.

    Args:
        cos_theta: cosine of the incidence angle θ₁ in n₁, in [0, 1]. Shape ``(*)``.
        n1: real refractive index (> 0) of the incident medium.
        n2: refractive index ``n + iκ`` (κ ≥ 0) of the second layer.
        cells: number N ≥ 1 of cells (one integer; default 20, as in the paper's examples).
        samples: quadrature nodes per interval π/N (integer ≥ 4; default 64).
        polarization: ``"unpolarized"`` (R₁₂ the mean of the s and p reflectances, the
            default), ``"s"`` or ``"p"``.

    Returns:
        w, broadcast shape of the inputs, real dtype of the inputs; differentiable (through
        R₁₂) with respect to ``cos_theta``, ``n1`` and ``n2``.

    Example (n₂ = 1.5 in air, N = 20: normal incidence, 60°, grazing):
        >>> import torch
        >>> from torchirid.spectral.correction import angular_correction_reference
        >>> c = torch.tensor([1.0, 0.5, 0.0], dtype=torch.float64)
        >>> [round(v, 6) for v in angular_correction_reference(c, 1.0, 1.5).tolist()]
        [0.564358, 0.59334, 1.0]
    """
    N = _check_count(cells, "cells", 1)
    m = _check_count(samples, "samples", 4)
    r12, one = _validated_r12(cos_theta, n1, n2, polarization)
    w = _bloch_average(r12, N, m)
    return torch.where(one, torch.ones_like(w), w)
