"""Argument checks of the estimation pipeline, composed from :mod:`torchirid._checks`.

The public functions of :mod:`torchirid.estimation` call these at their boundary, before any
work; each raises ``ValueError`` naming the parameter. NaN passes the value checks (it
propagates), as everywhere in the library.
"""

from __future__ import annotations

import math
import numbers

import numpy as np
import torch

from .. import _checks
from .measurement import band_variance

__all__ = ["tensor", "real_index", "value_range", "weight", "band_settings", "cube_axes", "uniform_bands",
           "sorted_angles"]


def tensor(x) -> torch.Tensor:
    """``x`` itself if it is a tensor, else a CPU tensor of it — never a copy on the default device
    (``torch.as_tensor`` without ``device=`` moves even a tensor there)."""
    return x if isinstance(x, torch.Tensor) else torch.as_tensor(x, device=torch.device("cpu"))


def real_index(x, name: str, like: torch.Tensor, *, incident: bool = False) -> float:
    """A real refractive index > 0 given as one number (or a one-element real tensor or array).

    Checked as a tensor in the dtype and on the device of ``like`` (the problem's); returned as
    the exact Python float of the value given."""
    _checks.check_numbers(**{name: x})
    t = _checks.as_real(x, name, like.dtype, like.device)
    if t.numel() != 1:
        raise ValueError(f"{name} must be a single real index; got shape {tuple(t.shape)}")
    (_checks.check_real_index if incident else _checks.check_index)(t.reshape(()), name)
    if isinstance(x, numbers.Real):
        return float(x)
    if isinstance(x, torch.Tensor):
        return float(x.detach().reshape(()))
    return float(np.asarray(x).reshape(()))


def value_range(pair, name: str, *, positive: bool, nm: bool = False) -> tuple[float, float]:
    """``(min, max)`` of two real numbers with min < max and min > 0 (``positive``) or ≥ 0; with
    ``nm`` (a length range) no bound in (0, ``_checks.MIN_LENGTH_NM``) nm: a unit mistake."""
    lo, hi = _checks.check_range(pair, name, closed=not positive, unit="nm" if nm else "")
    if nm:
        _checks.check_length_unit((lo, hi), name, shown=pair)
    return lo, hi


def weight(x, name: str) -> float:
    """A finite real number ≥ 0 (a penalty weight), as a float."""
    if isinstance(x, bool) or not isinstance(x, numbers.Real) or not (x >= 0 and math.isfinite(x)):
        raise ValueError(f"{name} must be >= 0 and finite; got {x!r}")
    return float(x)


def band_settings(bandwidth, passband, polarization) -> None:
    """The camera band model: ``bandwidth`` ≥ 0 nm, ``passband`` and ``polarization`` known."""
    _checks.check_polarization(polarization)
    band_variance(bandwidth, passband)  # (raises ValueError naming bandwidth or passband)


def uniform_bands(lam: torch.Tensor) -> None:
    """Band centres ``(B,)`` strictly increasing and uniformly spaced (what the extremum fit assumes)."""
    step = lam[1] - lam[0]
    if not bool(step > 0) or bool(((lam.diff() - step).abs() > 1e-6 * step.abs()).any()):
        raise ValueError("wavelength must be strictly increasing and uniformly spaced")


def sorted_angles(c: torch.Tensor) -> None:
    """Incidence angles in increasing order of θ (decreasing cos θ), as extremum tracking needs."""
    if c.numel() > 1 and bool((c.diff() > 0).any()):
        raise ValueError("angles must be sorted by increasing incidence angle (decreasing cos_theta)")


def cube_axes(cube, wavelength, cos_theta, *, pixel_axes: int = 0):
    """A cube ``(*, A, B)`` with its ``wavelength`` ``(B,)`` and ``cos_theta`` ``(A,)``, validated.

    dtype and device follow the three inputs (:func:`torchirid._checks.resolve_dtype_device`);
    the cube must have at least ``pixel_axes`` axes before (A, B). Returns ``(y, lam, c)``.
    """
    _checks.check_numbers(cube=cube, wavelength=wavelength, cos_theta=cos_theta)
    dtype, device = _checks.resolve_dtype_device(cube, wavelength, cos_theta)
    y = _checks.as_real(cube, "cube", dtype, device)
    if y.ndim < 2 + pixel_axes:
        what = "(*, A, B) with at least one pixel axis" if pixel_axes else "(*, A, B)"
        raise ValueError(f"cube must have shape {what}; got {tuple(y.shape)}")
    A, B = y.shape[-2:]
    lam = _checks.as_real(wavelength, "wavelength", dtype, device)
    c = _checks.as_real(cos_theta, "cos_theta", dtype, device).reshape(-1)
    if lam.shape != (B,) or c.shape != (A,):
        raise ValueError(f"wavelength must have {B} values and cos_theta {A} for a cube of shape {tuple(y.shape)}")
    _checks.check_wavelength(lam)
    _checks.check_cosine(c)
    return y, lam, c
