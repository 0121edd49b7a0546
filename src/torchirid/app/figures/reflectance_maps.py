"""Reflectance maps R(θ, λ) of a Bragg mirror or a thin film → ``.npz`` arrays and a PNG.

The products of ``torchirid spectrum`` (:mod:`torchirid.app.commands.spectrum`): a grid of incidence angles θ evenly spaced from 0°
to 90° (inclusive, in the incident medium) × evenly spaced wavelengths, the reflectance on
it, and a figure (a colour map of R(θ, λ) beside a few spectra at fixed angles).

Wavelengths and thicknesses are in nm; the grid's angles are in degrees (``theta_deg``) and,
as the library takes them, cosines (``cos_theta``).
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field

import numpy as np
import torch

from ... import _checks
from ..._io import atomic_write, json_ready
from ._format import figure_format
from ...optics import bragg_reflectance, thin_film_reflectance
from ..._version import __version__

__all__ = [
    "DTYPES",
    "ReflectanceMap",
    "bragg_reflectance_map",
    "plot_reflectance_map",
    "save_reflectance_map_npz",
    "save_reflectance_map_png",
    "thin_film_reflectance_map",
]

#: precisions of the computation, by name
DTYPES = ("float64", "float32")


@dataclass(frozen=True)
class ReflectanceMap:
    """The reflectance R(θ, λ) of one structure on an angle × wavelength grid.

    Attributes:
        wavelength_nm: (W,) wavelengths in nm, float64.
        theta_deg: (A,) incidence angles θ in degrees, evenly spaced over [0, 90], float64.
        cos_theta: (A,) cos θ in the computation's precision (the values the library saw).
        reflectance: (A, W) reflectance R in [0, 1], in the computation's precision.
        polarization: "s", "p" or "unpolarized".
        title: one line describing the structure (the figure's title).
        params: every parameter, JSON-ready (complex indices as [re, im]), with the
            torchirid version.
    """

    wavelength_nm: np.ndarray
    theta_deg: np.ndarray
    cos_theta: np.ndarray
    reflectance: np.ndarray
    polarization: str
    title: str
    params: dict = field(repr=False)


def _json_index(n):
    """Refractive indices in the JSON params: a number, or [re, im] when complex."""
    return [n.real, n.imag] if isinstance(n, complex) else n


def _fmt_index(n) -> str:
    if isinstance(n, complex):
        return f"{n.real:g}{n.imag:+g}i"
    return f"{n:g}"


def _grid(wavelengths, angles: int, dtype: str):
    """Check the grid and build it: numpy axes and the broadcasting tensors (1, W), (A, 1)."""
    lo, hi, count = wavelengths
    lo, hi = float(lo), float(hi)
    count = _checks.check_int(count, "wavelengths COUNT", 1)
    if not (math.isfinite(lo) and math.isfinite(hi)) or lo <= 0 or hi < lo:
        raise ValueError(f"wavelengths: need 0 < MIN <= MAX (nm); got MIN={lo:g} MAX={hi:g}")
    if count > 1 and hi == lo:
        raise ValueError("wavelengths: MIN == MAX needs COUNT 1")
    angles = _checks.check_int(angles, "angles", 1)
    if dtype not in DTYPES:
        raise ValueError(f"dtype must be one of {', '.join(DTYPES)}; got {dtype!r}")

    real = getattr(torch, dtype)
    wavelength_nm = np.linspace(lo, hi, count)
    theta_deg = np.linspace(0.0, 90.0, angles)
    # cos 90° is 6e-17, not 0; clip guards against any rounding outside [0, 1]
    cos_theta = np.clip(np.cos(np.radians(theta_deg)), 0.0, 1.0)
    wavelength = torch.as_tensor(wavelength_nm, dtype=real)[None, :]  # (1, W)
    cos_t = torch.as_tensor(cos_theta, dtype=real)[:, None]  # (A, 1)
    grid_params = dict(
        wavelength_min_nm=lo,
        wavelength_max_nm=hi,
        wavelength_count=count,
        angle_count=angles,
        angle_min_deg=0.0,
        angle_max_deg=90.0,
        dtype=dtype,
    )
    return wavelength_nm, theta_deg, wavelength, cos_t, grid_params


def _constants(dtype: str):
    """Builders of real and index constants directly in the target precision."""
    real = getattr(torch, dtype)
    cplx = torch.complex128 if real == torch.float64 else torch.complex64

    def as_real(x):
        return torch.tensor(x, dtype=real)

    def as_index(n):
        # build complex constants directly in the target precision (never float32 cast up)
        return torch.tensor(n, dtype=cplx if isinstance(n, complex) else real)

    return as_real, as_index


def _finish(R, wavelength_nm, theta_deg, cos_t, polarization, title, params) -> ReflectanceMap:

    params = dict(params, polarization=polarization, torchirid_version=__version__)
    shape = (theta_deg.size, wavelength_nm.size)
    return ReflectanceMap(
        wavelength_nm=wavelength_nm,
        theta_deg=theta_deg,
        cos_theta=np.asarray(cos_t.squeeze(-1).cpu().numpy()),
        reflectance=torch.broadcast_to(R, shape).detach().cpu().numpy(),
        polarization=polarization,
        title=title,
        params=params,
    )


def bragg_reflectance_map(
    n1: float | complex,
    n2: float | complex,
    d1: float,
    d2: float,
    cells: int,
    *,
    n_incident: float | None = None,
    wavelengths: tuple[float, float, int] = (380.0, 780.0, 401),
    angles: int = 90,
    polarization: str = "unpolarized",
    dtype: str = "float64",
) -> ReflectanceMap:
    """R(θ, λ) of a Bragg mirror n_incident | (n2, d2), (n1, d1) × cells | n1 (Fourneau et al. 2024).

    Args:
        n1, n2: refractive indices of the two layers, n + iκ with κ >= 0 (n1 is also the
            medium below the mirror).
        d1, d2: layer thicknesses in nm.
        cells: number N >= 1 of cells (layer pairs).
        n_incident: real index of the incident medium above the mirror; default n1.
        wavelengths: (MIN, MAX, COUNT): COUNT wavelengths in nm evenly spaced from MIN to
            MAX inclusive, 0 < MIN <= MAX.
        angles: number A >= 1 of incidence angles, evenly spaced from 0° to 90° inclusive.
        polarization: "s", "p" or "unpolarized" (mean of the s and p reflectances).
        dtype: precision of the computation, "float64" or "float32".

    Returns:
        A :class:`ReflectanceMap` with ``reflectance`` of shape (A, COUNT).

    Raises:
        ValueError: a parameter out of range (the message names it).

    >>> m = bragg_reflectance_map(1.0, 1.5, 125.0, 375.0, 20, wavelengths=(400.0, 700.0, 31), angles=5)
    >>> m.reflectance.shape
    (5, 31)
    >>> bool(m.reflectance.max() > 0.99)  # a stop band in the visible
    True
    """
    wavelength_nm, theta_deg, wavelength, cos_t, grid_params = _grid(wavelengths, angles, dtype)
    as_real, as_index = _constants(dtype)
    n_incident = n1 if n_incident is None else n_incident
    params = dict(
        kind="bragg",
        n1=_json_index(n1),
        n2=_json_index(n2),
        d1_nm=d1,
        d2_nm=d2,
        cells=cells,
        n_incident=_json_index(n_incident),
        **grid_params,
    )
    title = (
        f"Bragg mirror: n1={_fmt_index(n1)}, n2={_fmt_index(n2)}, "
        f"d1={d1:g} nm, d2={d2:g} nm, N={cells}, host n={_fmt_index(n_incident)}"
    )
    with torch.no_grad():
        R = bragg_reflectance(
            wavelength,
            cos_t,
            as_index(n1),
            as_index(n2),
            as_real(d1),
            as_real(d2),
            cells,
            n_incident=as_index(n_incident),
            polarization=polarization,
        )
    return _finish(R, wavelength_nm, theta_deg, cos_t, polarization, title, params)


def thin_film_reflectance_map(
    n_film: float | complex,
    thickness: float,
    n_substrate: float | complex,
    *,
    n_incident: float = 1.0,
    wavelengths: tuple[float, float, int] = (380.0, 780.0, 401),
    angles: int = 90,
    polarization: str = "unpolarized",
    dtype: str = "float64",
) -> ReflectanceMap:
    """R(θ, λ) of a thin film n_incident | (n_film, thickness) | n_substrate (the Airy sum).

    Args:
        n_film: refractive index of the film, n + iκ with κ >= 0.
        thickness: film thickness in nm.
        n_substrate: refractive index of the medium below the film, n + iκ with κ >= 0.
        n_incident: real index of the incident medium above the film.
        wavelengths, angles, polarization, dtype: the grid and precision, as in
            :func:`bragg_reflectance_map`.

    Returns:
        A :class:`ReflectanceMap` with ``reflectance`` of shape (A, COUNT).

    Raises:
        ValueError: a parameter out of range (the message names it).

    >>> m = thin_film_reflectance_map(1.33, 300.0, 1.0, wavelengths=(500.0, 600.0, 3), angles=2)
    >>> m.reflectance.shape
    (2, 3)
    >>> m.reflectance[1].round(6).tolist()  # grazing incidence reflects everything
    [1.0, 1.0, 1.0]
    """
    wavelength_nm, theta_deg, wavelength, cos_t, grid_params = _grid(wavelengths, angles, dtype)
    as_real, as_index = _constants(dtype)
    params = dict(
        kind="thin-film",
        n_film=_json_index(n_film),
        thickness_nm=thickness,
        n_substrate=_json_index(n_substrate),
        n_incident=_json_index(n_incident),
        **grid_params,
    )
    title = (
        f"Thin film: n={_fmt_index(n_film)}, d={thickness:g} nm, "
        f"substrate n={_fmt_index(n_substrate)}, outer n={_fmt_index(n_incident)}"
    )
    with torch.no_grad():
        R = thin_film_reflectance(
            wavelength,
            cos_t,
            as_index(n_film),
            as_real(thickness),
            as_index(n_substrate),
            n_incident=as_index(n_incident),
            polarization=polarization,
        )
    return _finish(R, wavelength_nm, theta_deg, cos_t, polarization, title, params)


def plot_reflectance_map(rmap: ReflectanceMap):
    """The figure of a :class:`ReflectanceMap`: R(θ, λ) as a colour map, and spectra at θ ≈ 0, 30, 60, 80°.

    Returns a ``matplotlib.figure.Figure`` (12 × 5 inches) built without pyplot, so it
    changes no backend and needs no closing.
    """
    from matplotlib.figure import Figure

    wavelength_nm, theta_deg, R = rmap.wavelength_nm, rmap.theta_deg, rmap.reflectance
    fig = Figure(figsize=(12, 5), layout="constrained")
    ax_map, ax_lines = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.35, 1]})
    finite = R[np.isfinite(R)]
    vmax = float(finite.max()) if finite.size and finite.max() > 0 else 1.0
    # an image of the even grid, resampled with antialiasing (pcolormesh draws every cell and aliases
    # the fringes of a thick film or a many-cell mirror into moiré at screen resolution)
    half_w = 0.5 * (wavelength_nm[-1] - wavelength_nm[0]) / max(len(wavelength_nm) - 1, 1)
    half_t = 0.5 * (theta_deg[-1] - theta_deg[0]) / max(len(theta_deg) - 1, 1)
    mesh = ax_map.imshow(R, origin="lower", aspect="auto", cmap="magma", vmin=0.0, vmax=vmax,
                         interpolation="antialiased", interpolation_stage="data",
                         extent=(wavelength_nm[0] - half_w, wavelength_nm[-1] + half_w,
                                 theta_deg[0] - half_t, theta_deg[-1] + half_t))
    fig.colorbar(mesh, ax=ax_map, label="reflectance R")
    ax_map.set_xlabel("wavelength λ (nm)")
    ax_map.set_ylabel("incidence angle θ (degrees)")
    ax_map.set_title(f"R(θ, λ), {rmap.polarization}")

    # a few spectra at fixed angles (the grid angles nearest to these; the default grid has every degree)
    picks = sorted({int(np.abs(theta_deg - t).argmin()) for t in (0.0, 30.0, 60.0, 80.0)})
    for i in picks:
        t = float(theta_deg[i])
        ax_lines.plot(wavelength_nm, R[i], label=f"θ = {t:.0f}°" if abs(t - round(t)) < 1e-9 else f"θ = {t:.1f}°")
    ax_lines.set_xlabel("wavelength λ (nm)")
    ax_lines.set_ylabel("reflectance R")
    ax_lines.set_ylim(0.0, max(1.0, vmax) * 1.02)
    if len(wavelength_nm) > 1:
        ax_lines.set_xlim(wavelength_nm[0], wavelength_nm[-1])
    ax_lines.grid(alpha=0.3)
    ax_lines.legend(loc="lower center", bbox_to_anchor=(0.5, 1.0), ncol=len(picks), fontsize="small", frameon=False)
    fig.suptitle(rmap.title)
    return fig


def save_reflectance_map_png(rmap: ReflectanceMap, path: str | os.PathLike, *, dpi: int = 120):
    """Draw :func:`plot_reflectance_map` and write it atomically to ``path`` as a PNG of ``dpi`` dots per inch.

    The directory must exist; ``OSError`` propagates. Returns ``path`` as a ``Path``.
    """
    fig = plot_reflectance_map(rmap)
    return atomic_write(path, lambda f: fig.savefig(f, format=figure_format(path), dpi=dpi))


def save_reflectance_map_npz(rmap: ReflectanceMap, path: str | os.PathLike):
    """Write ``rmap`` atomically to ``path`` as an ``.npz`` (readable with ``allow_pickle=False``).

    Arrays: wavelength_nm (W,), theta_deg (A,), cos_theta (A,), reflectance (A, W), and params
    (a JSON string, keys sorted). The directory must exist; ``OSError`` propagates.
    Returns ``path`` as a ``Path``.
    """
    return atomic_write(
        path,
        lambda f: np.savez(
            f,
            wavelength_nm=rmap.wavelength_nm,
            theta_deg=rmap.theta_deg,
            cos_theta=rmap.cos_theta,
            reflectance=rmap.reflectance,
            params=np.array(json.dumps(json_ready(rmap.params), sort_keys=True, allow_nan=False)),
        ),
    )
