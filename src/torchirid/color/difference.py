r"""Colour differences ΔE*ab (CIE 1976) and ΔE00 (CIEDE2000), batched and differentiable.

Both take CIE L*a*b* on the last axis, ``(*, 3)``, broadcast ``lab1`` against ``lab2`` and
return ``(*)``. dtype/device follow the inputs (float64 if either is float64).

Gradient safety (the hard cases of a loss built on ΔE): identical colours (the distance
is a square root of 0), neutral colours (chroma 0, hue ``atan2(0, 0)``) and hue
differences of exactly 180°, and chromas so small that :math:`a'^2 + b^2` underflows.
Square roots are where-guarded (value 0 and gradient 0 at 0, the minimum-norm
subgradient); ``atan2`` gets its arguments scaled exactly by a power of two (its backward
divides by :math:`a'^2 + b^2`) and a safe argument where ``a' = b = 0``;
:math:`\sqrt{\bar C^7/(\bar C^7 + 25^7)}` is evaluated as
:math:`\bar C^{3.5}/\sqrt{\bar C^7 + 25^7}` (no square root of 0). Identical inputs give
exactly 0. Differences below √(smallest normal) (≈ 1.5e-154 in float64, 1.1e-19 in
float32) underflow to 0.

References:
    G. Sharma, W. Wu, E. N. Dalal, "The CIEDE2000 color-difference formula:
    implementation notes, supplementary test data, and mathematical observations",
    Color Res. Appl. 30(1), 21–30 (2005). CIE 15:2004 §8.3.
"""

from __future__ import annotations

import numbers

import torch

from .. import _checks

__all__ = ["DELTA_E_METHODS", "delta_e", "delta_e_1976", "delta_e_2000"]

DELTA_E_METHODS: tuple[str, ...] = ("CIE 1976", "CIE 2000")

_25_POW_7 = 25.0**7


def _labs(lab1, lab2) -> tuple[torch.Tensor, torch.Tensor]:
    dtype, device = _checks.resolve_dtype_device(lab1, lab2)
    lab1 = _checks.as_real(lab1, "lab1", dtype, device)
    lab2 = _checks.as_real(lab2, "lab2", dtype, device)
    for t, name in ((lab1, "lab1"), (lab2, "lab2")):
        if t.ndim == 0 or t.shape[-1] != 3:
            raise ValueError(
                f"{name} must have shape (*, 3) (L*, a*, b* on the last axis); got shape {tuple(t.shape)}"
            )
    try:
        _checks.broadcast_shapes(lab1.shape, lab2.shape)
    except RuntimeError as exc:
        raise ValueError(
            f"lab1 and lab2 must broadcast together; got shapes {tuple(lab1.shape)} and {tuple(lab2.shape)}"
        ) from exc
    return lab1, lab2


def _weight(k, name: str, dtype, device) -> torch.Tensor:
    if isinstance(k, numbers.Real) and not isinstance(k, bool):
        if not k > 0:  # also rejects NaN
            raise ValueError(f"{name} must be > 0 (a parametric weighting factor); got {k!r}")
        return torch.as_tensor(float(k), dtype=dtype, device=device)
    t = _checks.as_real(k, name, dtype, device)
    with torch.no_grad():
        if bool((~(t > 0)).any()):
            raise ValueError(f"{name} must be > 0 (a parametric weighting factor); got min {t.min().item():g}")
    return t


def delta_e_1976(lab1, lab2) -> torch.Tensor:
    r"""CIE 1976 colour difference ΔE*ab: the Euclidean distance in L*a*b*.

    .. math:: \Delta E^*_{ab} = \sqrt{(L_2^* - L_1^*)^2 + (a_2^* - a_1^*)^2 + (b_2^* - b_1^*)^2}

    (CIE 15:2004 eq. 8.4). Equals ``colour.delta_E(lab1, lab2, method="CIE 1976")``.
    Gradient finite (0) for identical colours.

    Args:
        lab1, lab2: ``(*, 3)`` CIE L*a*b*, broadcast together.

    Returns:
        ``(*)`` ΔE*ab ≥ 0.

    Example:
        >>> delta_e_1976(torch.tensor([50.0, 2.0, -3.0]), torch.tensor([53.0, 6.0, -3.0])).item()
        5.0
    """
    lab1, lab2 = _labs(lab1, lab2)
    return _checks.safe_sqrt(((lab2 - lab1) ** 2).sum(-1))


def delta_e_2000(lab1, lab2, *, kL=1.0, kC=1.0, kH=1.0) -> torch.Tensor:
    r"""CIEDE2000 colour difference ΔE00 (Sharma, Wu & Dalal 2005, eqs. 1–25).

    .. math::
        \Delta E_{00} = \sqrt{\Big(\frac{\Delta L'}{k_L S_L}\Big)^2
        + \Big(\frac{\Delta C'}{k_C S_C}\Big)^2 + \Big(\frac{\Delta H'}{k_H S_H}\Big)^2
        + R_T \frac{\Delta C'}{k_C S_C} \frac{\Delta H'}{k_H S_H}}

    with :math:`a' = (1 + G) a^*`, :math:`G = \tfrac12 (1 - \sqrt{\bar C^7/(\bar C^7 +
    25^7)})`, :math:`C' = \sqrt{a'^2 + b^{*2}}`, :math:`h' = \operatorname{atan2}(b^*, a')
    \in [0°, 360°)`. Sharma's conventions for the special cases: :math:`h' = 0` when
    :math:`a' = b^* = 0`; :math:`\Delta h' = 0` and :math:`\bar h' = h_1' + h_2'` when
    :math:`C_1' C_2' = 0`; :math:`\Delta h'` wraps into [−180°, 180°] (a difference of
    exactly ±180° is kept); :math:`\bar h'` is the mean on the shorter arc, with
    :math:`|h_1' - h_2'| = 180°` averaged directly (eq. 14).

    Equals ``colour.delta_E(lab1, lab2, method="CIE 2000")`` (which has ``textiles=True``
    for ``kL = 2``) to ≤ 1e-12 in float64 and the 34 pairs of Sharma's supplementary data
    to their 4 printed decimals. Gradients are finite for identical colours, neutral
    colours and hues 180° apart (see the module docstring); the value is exactly 0 for
    identical inputs. As a function, ΔE00 is discontinuous where :math:`|h_1' - h_2'|`
    crosses 180° (Sharma 2005, §"Discontinuities").

    Args:
        lab1, lab2: ``(*, 3)`` CIE L*a*b*, broadcast together.
        kL, kC, kH: parametric factors > 0 (1 for reference conditions; ``kL = 2`` for
            textiles), numbers or tensors broadcasting with the result.

    Returns:
        ``(*)`` ΔE00 ≥ 0.

    Raises:
        ValueError: ``lab1``/``lab2`` without 3 channels on the last axis or not
            broadcastable; a factor ≤ 0.

    Example:
        >>> lab1 = torch.tensor([50.0, 2.6772, -79.7751], dtype=torch.float64)
        >>> lab2 = torch.tensor([50.0, 0.0, -82.7485], dtype=torch.float64)
        >>> round(delta_e_2000(lab1, lab2).item(), 4)  # Sharma 2005, Table 1, pair 1
        2.0425
    """
    lab1, lab2 = _labs(lab1, lab2)
    kL = _weight(kL, "kL", lab1.dtype, lab1.device)
    kC = _weight(kC, "kC", lab1.dtype, lab1.device)
    kH = _weight(kH, "kH", lab1.dtype, lab1.device)

    L1, a1, b1 = lab1.unbind(-1)
    L2, a2, b2 = lab2.unbind(-1)

    # eqs. 2–5: chroma-dependent stretch of a*
    C_ab_bar = (_checks.safe_sqrt(a1 * a1 + b1 * b1) + _checks.safe_sqrt(a2 * a2 + b2 * b2)) / 2
    # sqrt(C^7 / (C^7 + 25^7)) written without sqrt(0): finite gradient at C = 0
    G = 0.5 * (1 - C_ab_bar**3.5 / torch.sqrt(C_ab_bar**7 + _25_POW_7))
    a1_p = (1 + G) * a1
    a2_p = (1 + G) * a2

    # eqs. 6–7: C', h' (h' = 0 for a' = b = 0)
    C1_p = _checks.safe_sqrt(a1_p * a1_p + b1 * b1)
    C2_p = _checks.safe_sqrt(a2_p * a2_p + b2 * b2)
    h1_p = _hue_degrees(a1_p, b1)
    h2_p = _hue_degrees(a2_p, b2)

    # eqs. 8–11: differences
    dL_p = L2 - L1
    dC_p = C2_p - C1_p
    C_prod = C1_p * C2_p
    neutral = C_prod == 0
    dh = h2_p - h1_p
    dh_p = torch.where(dh > 180, dh - 360, torch.where(dh < -180, dh + 360, dh))
    dh_p = torch.where(neutral, torch.zeros_like(dh_p), dh_p)
    dH_p = 2 * _checks.safe_sqrt(C_prod) * torch.sin(torch.deg2rad(dh_p / 2))

    # eqs. 12–14: means (the hue mean on the shorter arc)
    L_bar_p = (L1 + L2) / 2
    C_bar_p = (C1_p + C2_p) / 2
    h_sum = h1_p + h2_p
    far = (h1_p - h2_p).abs() > 180
    h_bar_p = torch.where(far, torch.where(h_sum < 360, (h_sum + 360) / 2, (h_sum - 360) / 2), h_sum / 2)
    h_bar_p = torch.where(neutral, h_sum, h_bar_p)

    # eqs. 15–22: weighting functions and rotation term
    T = (
        1
        - 0.17 * torch.cos(torch.deg2rad(h_bar_p - 30))
        + 0.24 * torch.cos(torch.deg2rad(2 * h_bar_p))
        + 0.32 * torch.cos(torch.deg2rad(3 * h_bar_p + 6))
        - 0.20 * torch.cos(torch.deg2rad(4 * h_bar_p - 63))
    )
    d_theta = 30 * torch.exp(-(((h_bar_p - 275) / 25) ** 2))
    R_C = 2 * C_bar_p**3.5 / torch.sqrt(C_bar_p**7 + _25_POW_7)
    L_50_sq = (L_bar_p - 50) ** 2
    S_L = 1 + 0.015 * L_50_sq / torch.sqrt(20 + L_50_sq)
    S_C = 1 + 0.045 * C_bar_p
    S_H = 1 + 0.015 * C_bar_p * T
    R_T = -torch.sin(torch.deg2rad(2 * d_theta)) * R_C

    # eq. 22
    l_term = dL_p / (kL * S_L)
    c_term = dC_p / (kC * S_C)
    h_term = dH_p / (kH * S_H)
    return _checks.safe_sqrt(l_term**2 + c_term**2 + h_term**2 + R_T * c_term * h_term)


def _hue_degrees(a_p: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """Hue angle atan2(b, a') in [0°, 360°); 0 where a' = b = 0 (gradient 0 there).

    atan2's backward divides by a'² + b², which overflows (inf·0 = NaN) once the chroma is
    below √(smallest normal) ≈ 1.5e-154 (float64) / 1.1e-19 (float32), although the hue of
    so small a chroma barely moves ΔE00. Its arguments are therefore scaled by the power of
    two that brings max(|a'|, |b|) into [0.5, 1): exact, so the value is unchanged. A
    chroma below the smallest normal number (≈ 2.2e-308 / 1.2e-38), where that power of
    two itself overflows, counts as neutral: hue 0, as for a' = b = 0.
    """
    m = torch.maximum(a_p.abs(), b.abs()).detach()
    origin = m < torch.finfo(m.dtype).tiny  # NaN compares False and propagates below
    # guard: the unused branch and infinite inputs see a scale of 1 (2**0)
    m_safe = torch.where(origin | torch.isinf(m), torch.ones_like(m), m)
    scale = torch.ldexp(torch.ones_like(m), -torch.frexp(m_safe).exponent)
    h = torch.rad2deg(torch.atan2(b * scale, a_p * scale))
    return torch.where(origin, torch.zeros_like(h), torch.remainder(h, 360))


def delta_e(lab1, lab2, *, method: str = "CIE 2000") -> torch.Tensor:
    r"""Colour difference by name: ``"CIE 1976"`` (:func:`delta_e_1976`) or ``"CIE 2000"``
    (:func:`delta_e_2000` with ``kL = kC = kH = 1``), as ``colour.delta_E``.

    Args:
        lab1, lab2: ``(*, 3)`` CIE L*a*b*, broadcast together.
        method: one of :data:`DELTA_E_METHODS`.

    Returns:
        ``(*)`` colour difference.

    Raises:
        ValueError: unknown ``method`` (listing the valid ones), or bad Lab shapes.

    Example:
        >>> lab1 = torch.tensor([50.0, 2.6772, -79.7751], dtype=torch.float64)
        >>> lab2 = torch.tensor([50.0, 0.0, -82.7485], dtype=torch.float64)
        >>> round(delta_e(lab1, lab2, method="CIE 1976").item(), 4)
        4.0011
    """
    _checks.check_choice(method, "method", DELTA_E_METHODS)
    return _METHODS[method](lab1, lab2)


_METHODS = {"CIE 1976": delta_e_1976, "CIE 2000": delta_e_2000}
