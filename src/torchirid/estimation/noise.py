r"""The noise level of a cube, and the check of a fit's residual against it.

:func:`noise_level` estimates the noise standard deviation of the data from its spectra alone
(the MAD of the 4th difference along the bands). After a fit, :func:`noise_check` compares the
median per-pixel RMS residual with it: a ratio above ``NOISE_WARNING_RATIO`` warns
(``RuntimeWarning``) — the model does not explain the data (wrong index model, absorbing film,
wrong substrate or angles) — with the advice of :func:`noise_advice`.
"""

from __future__ import annotations

import math
import warnings

import torch

from .. import _checks
from ._validation import tensor
from .dispersion import INDEX_MODELS

__all__ = ["noise_level"]

NOISE_WARNING_RATIO = 3.0  # median RMS residual / noise level above which estimate_film warns
MAD_TO_SIGMA = 1.482602218505602  # σ of a Gaussian per unit median absolute deviation, 1/Φ⁻¹(3/4)
DIFF4_NOISE_GAIN = 70.0  # the 4th difference multiplies white-noise variance by 1² + 4² + 6² + 4² + 1² = 70


def noise_level(cube) -> float:
    r"""Noise standard deviation of a cube ``(*, B)`` estimated from its spectra (reflectance units).

    The 4th difference along the bands, Δ⁴y_b = y_{b−2} − 4y_{b−1} + 6y_b − 4y_{b+1} + y_{b+2},
    multiplies white noise of standard deviation σ by √70 and a smooth spectrum of fringe
    period T bands by (2 sin(π/T))⁴ (≈ 0.01 at T = 20 bands): so σ̂ = 1.4826 · median|Δ⁴y| / √70
    (the MAD, robust to outliers and peaks). An upper bound when the fringes are only a few
    bands wide. Non-finite samples (NaN, ±inf: missing data) are skipped; NaN when no 5
    consecutive finite bands exist.

    Example (white noise of σ = 0.01 on a smooth spectrum):
        >>> import torch
        >>> g = torch.Generator().manual_seed(0)
        >>> lam = torch.linspace(400, 720, 81, dtype=torch.float64)
        >>> y = 0.1 + 0.05 * torch.cos(lam / 30) + 0.01 * torch.randn(200, 81, generator=g, dtype=torch.float64)
        >>> round(noise_level(y), 3)
        0.01
    """
    y = tensor(cube)
    if y.ndim < 1 or y.shape[-1] < 5:
        raise ValueError(f"cube must have at least 5 bands on its last axis; got shape {tuple(y.shape)}")
    y = y.to(torch.float64) if not y.is_floating_point() else y
    d4 = y[..., :-4] - 4 * y[..., 1:-3] + 6 * y[..., 2:-2] - 4 * y[..., 3:-1] + y[..., 4:]
    d4 = d4[d4.isfinite()]  # (a missing sample spoils the five differences that contain it)
    if d4.numel() == 0:
        return math.nan
    return float(MAD_TO_SIGMA * d4.abs().median() / math.sqrt(DIFF4_NOISE_GAIN))


def noise_advice(model: str, requested: str) -> str:
    """What the noise warning suggests: a richer index model only when one was not tried already
    (``"auto"`` tried them all; nothing is richer than the richest, the Cauchy models are nested)."""
    check = "check the substrate index, the angles and the polarization (an absorbing film is not modelled)"
    if requested == "auto":
        return (f"none of the index models {_checks.names(tuple(INDEX_MODELS))} explains the cube "
                f"({model!r} has the least BIC) — {check}")
    richer = [m for m in INDEX_MODELS if INDEX_MODELS[m] > INDEX_MODELS[model]]
    if not richer:
        return f"the {model!r} index model, the richest, does not explain the cube — {check}"
    return (f"the {model!r} index model does not explain the cube — try index_model_name='auto' (or "
            f"{richer[-1]!r} for a dispersive film), or {check}")


def noise_check(Y, rms, model: str, requested: str):
    """Compare the median RMS residual ``rms`` (of the valid pixels ``Y``) with the data's noise
    level; warn (``RuntimeWarning``, advice by :func:`noise_advice`) above
    ``NOISE_WARNING_RATIO`` → ``(noise level, ratio, the warning's text or None)``. The warning
    points at the caller of ``estimate_film`` (which calls this)."""
    sigma = noise_level(Y)
    ratio = float(rms[rms.isfinite()].median()) / sigma if sigma > 0 else math.inf
    if not ratio > NOISE_WARNING_RATIO:
        return sigma, ratio, None
    text = (f"estimate_film: the median RMS residual is {ratio:.1f}x the noise level of the data ({sigma:.2g}); "
            f"{noise_advice(model, requested)}")
    warnings.warn(text, RuntimeWarning, stacklevel=4)
    return sigma, ratio, text
