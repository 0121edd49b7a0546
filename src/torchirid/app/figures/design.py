"""The figures of ``torchirid design``: an optimised stack's spectra, colours, tolerance and convergence.

- :func:`plot_spectra` — R and T (and A when a target asks for it) against wavelength at each
  spectral target's angles, the target's values marked (marker size ∝ weight); a design with
  colour targets only shows its visible reflectance at their angles;
- :func:`plot_colour` — per colour target, a strip of the reflected colour (sRGB) against the
  incidence angle 0–85°, the target colours beneath at their angles with ΔE2000 written above;
- :func:`plot_tolerance` — the merit of the draws of :func:`torchirid.design.tolerance` (and the
  worst ΔE2000 of each draw when there are colour targets), the limits and the yield;
- :func:`plot_convergence` — the best merit against the optimiser's wall time (log scale).

The stack's response is computed from scratch here, on fine grids, by :func:`torchirid.multilayer`
with :func:`torchirid.materials.refractive_index` (user tables interpolated linearly, as the
library's design module does). Every ``plot_*`` returns a ``matplotlib.figure.Figure`` built
without pyplot; :func:`save_figure` writes one atomically. Colours are sRGB for a D65 display,
clipped to [0, 1].
"""

from __future__ import annotations

import math
import os

import numpy as np
import torch

from ..._io import atomic_write
from ._format import figure_format

__all__ = [
    "COLOUR_ANGLES_DEG",
    "colour_differences",
    "plot_colour",
    "plot_convergence",
    "plot_spectra",
    "plot_tolerance",
    "save_figure",
    "stack_response",
]

#: the incidence angles of the colour strips, degrees
COLOUR_ANGLES_DEG = np.arange(0.0, 86.0, 1.0)
#: the least number of wavelengths drawn per spectral panel
SPECTRUM_SAMPLES = 301
#: the colours of the angles of a spectral panel
_ANGLE_COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown", "tab:pink",
                  "tab:olive", "tab:cyan", "tab:gray")
_STYLES = {"R": "-", "T": "--", "A": ":"}


# ----------------------------------------------------------------------------- the stack
def _media(problem):
    """(incident, exit) media of a checked problem."""
    return problem.n_incident, problem.n_substrate


def _is_table(material) -> bool:
    return isinstance(material, tuple) and len(material) == 4 and material[0] == "table"


def _index(material, lam: torch.Tensor) -> torch.Tensor:
    """Complex index of a checked material (number, name, database tuple or ``("table", λ, n, k)``)."""
    if _is_table(material):
        x = lam.numpy()
        n = np.interp(x, material[1], material[2]) + 1j * np.interp(x, material[1], material[3])
        return torch.as_tensor(n, dtype=torch.complex128)
    from ...materials import refractive_index

    return refractive_index(material, lam).to(torch.complex128)


def _range(material) -> tuple[float, float]:
    """Wavelength range (nm) of a checked material."""
    if isinstance(material, (int, float, complex)):
        return 0.0, math.inf
    if _is_table(material):
        return float(material[1][0]), float(material[1][-1])
    from ...materials import material_range

    return tuple(float(v) for v in material_range(material))


def stack_range(design) -> tuple[float, float]:
    """The wavelengths (nm) over which every medium of the design is defined."""
    lo, hi = 0.0, math.inf
    for m in (*_media(design.problem), *design.materials):
        a, b = _range(m)
        lo, hi = max(lo, a), min(hi, b)
    return lo, hi


def stack_response(design, wavelength, theta_deg, polarization: str = "unpolarized"):
    """``(R, T)`` ``[A, W]`` (numpy) of the design's stack at ``wavelength`` (nm, ``(W,)``) and
    incidence angles ``theta_deg`` (``(A,)``, in the incident medium)."""
    from ...optics import multilayer

    lam = torch.as_tensor(np.asarray(wavelength, dtype=float), dtype=torch.float64)
    c = torch.cos(torch.deg2rad(torch.as_tensor(np.asarray(theta_deg, dtype=float), dtype=torch.float64)))
    incident, exit_ = _media(design.problem)
    n = torch.stack([_index(m, lam) for m in (incident, *design.materials, exit_)], dim=-1)  # [W, L+2]
    d = torch.tensor([float(t) for t in design.thicknesses], dtype=torch.float64)
    A, W = c.shape[0], lam.shape[0]
    R, T = multilayer(lam[None, :].expand(A, W), c[:, None].expand(A, W), n[None].expand(A, W, -1),
                      d.expand(A, W, -1), polarization=polarization)
    return R.numpy(), T.numpy()


def _degrees(cos_theta) -> np.ndarray:
    return np.degrees(np.arccos(np.clip(np.asarray(cos_theta, dtype=float), -1.0, 1.0)))


def _angle_label(theta: float) -> str:
    return f"{theta:.0f}°" if abs(theta - round(theta)) < 1e-6 else f"{theta:.1f}°"


# ----------------------------------------------------------------------------- spectra
def _grid(lam: np.ndarray, limits: tuple[float, float]) -> np.ndarray:
    """A fine grid over the target's wavelengths with a margin (10 % of the span, at least 15 % of
    its middle wavelength: a narrow band is seen in its context), inside the stack's materials."""
    lo, hi = float(lam.min()), float(lam.max())
    pad = max(0.1 * (hi - lo), 0.075 * (lo + hi))
    lo, hi = max(lo - pad, limits[0]), min(hi + pad, limits[1])
    return np.linspace(lo, hi, max(SPECTRUM_SAMPLES, 4 * lam.size))


def _weights(target) -> np.ndarray:
    w = target.weight
    if isinstance(w, str):  # a named weighting (AM1.5G): the library's own
        from ...design.merit import named_weight

        return named_weight(w, np.asarray(target.wavelength, dtype=float))
    return np.broadcast_to(np.asarray(w, dtype=float), (len(target.wavelength),))


def plot_spectra(design):
    """R and T (and A = 1 − R − T when a target asks for A) against wavelength at each spectral
    target's angles, one panel per target; the target's values marked (size ∝ weight)."""
    from matplotlib.figure import Figure

    from ...design import ColourTarget, SpectralTarget

    targets = list(design.problem.targets)
    spectral = [(i, t) for i, t in enumerate(targets) if isinstance(t, SpectralTarget)]
    quantities = ("R", "T", "A") if any(t.quantity == "A" for _, t in spectral) else ("R", "T")
    limits = stack_range(design)
    panels = []
    for i, t in spectral:
        panels.append((f"target {i}: {t.quantity} ({t.polarization}, p = {t.p:g})", np.asarray(t.wavelength),
                       _degrees(t.cos_theta), t.polarization, t))
    if not panels:  # colour targets only: the visible reflectance at their angles
        colour = [t for t in targets if isinstance(t, ColourTarget)]
        angles = np.unique(np.concatenate([_degrees(t.cos_theta) for t in colour]))
        lam = np.asarray([max(380.0, limits[0]), min(780.0, limits[1])])
        panels.append(("visible spectrum at the colour targets' angles", lam, angles, colour[0].polarization, None))
    fig = Figure(figsize=(8, 3.2 * len(panels) + 0.6), layout="constrained")
    axes = np.atleast_1d(fig.subplots(len(panels), 1, squeeze=False)[:, 0])
    for ax, (title, lam, angles, pol, target) in zip(axes, panels):
        grid = _grid(lam, limits)
        R, T = stack_response(design, grid, angles, pol)
        values = {"R": R, "T": T, "A": np.clip(1.0 - R - T, 0.0, 1.0)}
        for k, theta in enumerate(angles):
            colour = _ANGLE_COLOURS[k % len(_ANGLE_COLOURS)]
            for q in quantities:
                ax.plot(grid, values[q][k], _STYLES[q], color=colour, lw=1.3,
                        label=f"{q}, θ = {_angle_label(theta)}")
        if target is not None:
            w = _weights(target)
            size = 8 + 40 * (w / w.max() if w.max() > 0 else np.ones_like(w))
            ax.scatter(lam, np.broadcast_to(np.asarray(target.value, dtype=float), lam.shape), s=size,
                       facecolors="none", edgecolors="black", lw=0.9, zorder=3,
                       label=f"target {target.quantity} (size ∝ weight)")
        ax.set_xlim(grid[0], grid[-1])
        ax.set_ylim(-0.02, 1.02)
        ax.set_xlabel("wavelength λ (nm)")
        ax.set_ylabel("R, T" + (", A" if "A" in quantities else ""))
        ax.set_title(title, fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(fontsize="x-small", ncol=2 if len(angles) * len(quantities) > 4 else 1, loc="best")
    fig.suptitle(_stack_title(design), fontsize=10)
    return fig


def _stack_title(design) -> str:
    name = design.problem.name or "design"
    return (f"{name}: {len(design.materials)} layers, {sum(design.thicknesses):.0f} nm, "
            f"merit {design.merit:.4g}")


# ----------------------------------------------------------------------------- colour
def _lab(design, target, theta_deg) -> torch.Tensor:
    """CIELAB ``[A, 3]`` of the design's reflected colour for a colour target's illuminant, observer,
    polarization and wavelength grid, at ``theta_deg``."""
    from ...color import spectrum_to_xyz, xyz_to_lab

    lam = np.asarray(target.wavelength, dtype=float)
    R, _ = stack_response(design, lam, theta_deg, target.polarization)
    xyz = spectrum_to_xyz(torch.as_tensor(R), torch.as_tensor(lam), observer=target.observer,
                          illuminant=target.illuminant)
    return xyz_to_lab(xyz, illuminant=target.illuminant, observer=target.observer)


def colour_differences(design, target) -> np.ndarray:
    """ΔE2000 ``(A,)`` between the design's reflected colour and a colour target at its angles."""
    from ...color import delta_e_2000

    lab = _lab(design, target, _degrees(target.cos_theta))
    return delta_e_2000(lab, torch.tensor(target.lab, dtype=torch.float64)).numpy()


def _srgb(lab: torch.Tensor, target) -> np.ndarray:
    from ...color import lab_to_xyz, xyz_to_srgb

    xyz = lab_to_xyz(lab, illuminant=target.illuminant, observer=target.observer)
    return xyz_to_srgb(xyz).clamp(0, 1).numpy()


def plot_colour(design):
    """Per colour target: the design's reflected colour (sRGB) against the incidence angle 0–85°,
    the target's colours beneath it at their angles, ΔE2000 above each."""
    from matplotlib.figure import Figure
    from matplotlib.patches import Rectangle

    from ...design import ColourTarget

    colour = [(i, t) for i, t in enumerate(design.problem.targets) if isinstance(t, ColourTarget)]
    if not colour:
        raise ValueError("the design has no colour target")
    fig = Figure(figsize=(9, 1.9 * len(colour) + 0.7), layout="constrained")
    axes = np.atleast_1d(fig.subplots(len(colour), 1, squeeze=False)[:, 0])
    theta = COLOUR_ANGLES_DEG
    step = float(theta[1] - theta[0])
    for ax, (i, t) in zip(axes, colour):
        strip = _srgb(_lab(design, t, theta), t)  # [A, 3]
        ax.imshow(strip[None], aspect="auto", interpolation="nearest",
                  extent=(theta[0] - step / 2, theta[-1] + step / 2, 0.55, 1.0))
        angles = _degrees(t.cos_theta)
        target_rgb = _srgb(torch.tensor(t.lab, dtype=torch.float64), t)
        de = colour_differences(design, t)
        width = max(2.0, 0.6 * step * 4)
        for a, rgb, e in zip(angles, target_rgb, de):
            ax.add_patch(Rectangle((a - width / 2, 0.0), width, 0.45, facecolor=rgb, edgecolor="black", lw=0.8))
            ax.annotate(f"ΔE00 {e:.2f}", (a, 1.0), xytext=(0, 3), textcoords="offset points", ha="center",
                        va="bottom", fontsize=8)
            ax.plot([a, a], [0.45, 0.55], color="black", lw=0.8)
        ax.set_xlim(min(theta[0] - step / 2, angles.min() - width), max(theta[-1] + step / 2, angles.max() + width))
        ax.set_ylim(0.0, 1.25)
        ax.set_yticks([0.225, 0.775], ["target", "design"])
        ax.set_xlabel("incidence angle θ (degrees)")
        ax.set_title(f"target {i}: reflected colour, {t.illuminant}, {t.observer}°, {t.polarization} "
                     f"(sRGB, clipped)", fontsize=10)
        for side in ("top", "right", "left"):
            ax.spines[side].set_visible(False)
    fig.suptitle(_stack_title(design), fontsize=10)
    return fig


# ----------------------------------------------------------------------------- tolerance
def plot_tolerance(tol, *, sigma, relative: bool = False):
    """Histograms of the merits of the draws (and of each draw's worst ΔE2000 when there are
    colour targets) with the nominal merit, the limits and the yield."""
    from matplotlib.figure import Figure

    colour = tol.delta_e is not None
    fig = Figure(figsize=(10 if colour else 6.5, 4), layout="constrained")
    axes = np.atleast_1d(fig.subplots(1, 2 if colour else 1))
    merits = np.asarray(tol.merits, dtype=float)
    ax = axes[0]
    ax.hist(merits[np.isfinite(merits)], bins=50, color="tab:blue", alpha=0.8)
    ax.axvline(tol.nominal, color="tab:green", lw=1.5, label=f"nominal {tol.nominal:.4g}")
    if tol.merit_limit is not None:
        ax.axvline(tol.merit_limit, color="tab:red", ls="--", lw=1.5, label=f"limit {tol.merit_limit:.4g}")
    ax.set_xlabel("merit")
    ax.set_ylabel("draws")
    ax.legend(fontsize="small")
    ax.grid(alpha=0.3)
    if colour:
        worst = np.asarray(tol.delta_e, dtype=float).max(axis=-1)
        ax = axes[1]
        ax.hist(worst[np.isfinite(worst)], bins=50, color="tab:purple", alpha=0.8)
        if tol.delta_e_limit is not None:
            ax.axvline(tol.delta_e_limit, color="tab:red", ls="--", lw=1.5, label=f"limit {tol.delta_e_limit:.3g}")
            ax.legend(fontsize="small")
        ax.set_xlabel("worst ΔE2000 over the colour targets' angles")
        ax.set_ylabel("draws")
        ax.grid(alpha=0.3)
    spread = np.asarray(sigma, dtype=float)
    spread = f"{float(spread.flat[0]):g}" if spread.size == 1 else "per layer"
    spread = f"σ = {spread}{' (relative)' if relative else ' nm'}"
    fig.suptitle(f"thickness errors {spread}, {merits.size} draws: yield {tol.yield_fraction:.1%} "
                 f"± {tol.standard_error:.1%}", fontsize=10)
    return fig


# ----------------------------------------------------------------------------- convergence
def plot_convergence(design):
    """The best merit against the optimiser's wall time (log merit), from ``design.history``."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.5, 4), layout="constrained")
    ax = fig.add_subplot()
    history = np.asarray(design.history, dtype=float).reshape(-1, 3)
    if history.size:
        s, m = history[:, 0], history[:, 2]
        positive = m > 0
        floor = m[positive].min() / 10 if positive.any() else 1e-12
        m = np.where(positive, m, floor)  # a merit of 0 (a target met exactly) on the log axis
        s = np.append(s, max(design.seconds, s[-1]))
        m = np.append(m, m[-1])
        ax.step(s, m, where="post", color="tab:blue", label="best merit found")
        ax.plot(s[:-1], m[:-1], ".", color="tab:blue", ms=3)
        if design.merit > 0 and not np.isclose(design.merit, m[-1], rtol=1e-6):
            # the returned stack differs from the best one met (layers under min_thickness removed)
            ax.axhline(design.merit, color="tab:red", ls="--", lw=1.2, label="the design returned")
            ax.legend(fontsize="small")
        ax.set_yscale("log")
    else:
        ax.text(0.5, 0.5, "no history", ha="center", va="center", transform=ax.transAxes)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("best merit")
    ax.grid(alpha=0.3, which="both")
    ax.set_title(f"{design.method}: {design.evaluations:,} stacks evaluated in {design.seconds:.2f} s, "
                 f"merit {design.merit:.4g}", fontsize=10)
    return fig


def save_figure(fig, path: str | os.PathLike, *, dpi: int = 120):
    """Write a figure atomically to ``path`` (PNG, PDF or SVG from the suffix); returns the ``Path``.

    The directory must exist; ``OSError`` propagates."""
    return atomic_write(path, lambda f: fig.savefig(f, format=figure_format(path), dpi=dpi))
