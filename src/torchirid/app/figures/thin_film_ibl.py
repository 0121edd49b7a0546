r"""Kneiphof et al. 2019, Fig. 7, measured: thin-film colour of a rough surface under uniform light.

Two panels of colours, each method against the ground truth:

- ``"roughness"``: rows θo ∈ [0°, 90°] × columns √α ∈ [0, 1], at a fixed thickness d;
- ``"thickness"``: rows θo × columns d ∈ [0, 1000] nm, at a fixed roughness α.

Grid points are cell centres (θo never reaches 90°, α never 0). Methods (all give the
*reflectance term* — the colour of the reflected light divided by the albedo A(θo, α), which
every method shares exactly; the images show A · term):

============== ==================================================================================
``original``   Belcour–Barla eq. 4 (M = 2) at the ideal reflection direction, cos θ1 = cos θo
               (:func:`~torchirid.ibl.thin_film_xyz_fourier`); independent of α
``kneiphof``   eq. 20–29 with the ground-truth light mean and covariance (Fig. 7 b, f;
               :func:`~torchirid.ibl.thin_film_xyz_filtered`, :func:`~torchirid.ibl.uniform_light_moments`)
``kneiphof_D`` eq. 29 with the ground-truth μ_D, σ²_D (Fig. 7 c, g;
               :func:`~torchirid.ibl.path_difference_moments`)
``fitted``     the fitted light-mixture table (:func:`~torchirid.ibl.thin_film_xyz_fitted`)
``reference``  converged integration of the spectral Airy microfacet BRDF
               (:func:`~torchirid.ibl.thin_film_xyz_uniform`)
============== ==================================================================================
"""

from __future__ import annotations

import json
import math
import os
import time
from dataclasses import dataclass, field

import numpy as np
import torch

from ... import _checks
from ..._io import atomic_write, json_ready
from ._format import figure_format
from ...color.convert import xyz_to_lab, xyz_to_linear_srgb, linear_srgb_to_srgb
from ...color.difference import delta_e_2000
from ...ibl.filtered import thin_film_xyz_filtered, thin_film_xyz_gaussian_path
from ...ibl.fitted import thin_film_xyz_fitted
from ...ibl.fourier import thin_film_xyz_fourier
from ...ibl.uniform import path_difference_moments, uniform_light_moments, thin_film_xyz_uniform
from ..._version import __version__

__all__ = [
    "THIN_FILM_IBL_METHODS",
    "THIN_FILM_IBL_PANELS",
    "ThinFilmIBLComparison",
    "thin_film_ibl_comparison",
    "plot_thin_film_ibl",
    "save_thin_film_ibl_png",
    "save_thin_film_ibl_npz",
]

#: (key, label) of the approximations, in plot order; the reference is drawn last.
THIN_FILM_IBL_METHODS = (
    ("original", "original (BB17 at ω_r)"),
    ("kneiphof", "Kneiphof (GT μ_ωi, Σ_ωi)"),
    ("kneiphof_D", "Kneiphof (GT μ_D, σ_D)"),
    ("fitted", "fitted mixture table"),
)
THIN_FILM_IBL_PANELS = ("roughness", "thickness")


@dataclass(frozen=True)
class ThinFilmIBLComparison:
    """One Fig. 7 panel: colours of every method and their ΔE2000 against the reference.

    Attributes:
        panel: ``"roughness"`` or ``"thickness"``.
        theta_deg: (A,) view angles θo (rows), degrees; cos_theta: their cosines.
        columns: (B,) the column variable: √α (roughness panel) or d in nm (thickness panel).
        alpha, thickness_nm: (A, B) the GGX roughness and film thickness of every cell.
        albedo: (A, B) A(θo, α) = ∫ρ̃⟨n,ωi⟩dωi (the shared BRDF integral).
        xyz: method key or ``"reference"`` → (A, B, 3) XYZ of the reflectance term (white Y = 1).
        delta_e: method key → (A, B) ΔE2000 against the reference.
        seconds: method key or ``"reference"`` → wall time of the batched evaluation.
        params: film, base, observer, resolution, version — JSON-ready.
    """

    panel: str
    theta_deg: np.ndarray
    cos_theta: np.ndarray
    columns: np.ndarray
    alpha: np.ndarray
    thickness_nm: np.ndarray
    albedo: np.ndarray
    xyz: dict = field(repr=False)
    delta_e: dict = field(repr=False)
    seconds: dict = field(repr=False)
    params: dict = field(repr=False)

    def stats(self, mask=None) -> dict:
        """Per method: mean, median, 95th percentile and max ΔE2000 (optionally over a boolean mask)."""
        out = {}
        for key, de in self.delta_e.items():
            v = de if mask is None else de[mask]
            out[key] = {"mean": float(v.mean()), "median": float(np.median(v)),
                        "p95": float(np.quantile(v, 0.95)), "max": float(v.max())}
        return out

    def arrays(self) -> dict[str, np.ndarray]:
        arrays = dict(theta_deg=self.theta_deg, cos_theta=self.cos_theta, columns=self.columns,
                      alpha=self.alpha, thickness_nm=self.thickness_nm, albedo=self.albedo,
                      params=np.array(json.dumps(json_ready(self.params), sort_keys=True, allow_nan=False)))
        arrays.update({f"xyz_{k}": v for k, v in self.xyz.items()})
        arrays.update({f"delta_e_{k}": v for k, v in self.delta_e.items()})
        return arrays


def _centres(n, lo, hi):
    return lo + (hi - lo) * (torch.arange(n, dtype=torch.float64) + 0.5) / n


def _timed(fn):
    t = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t


def thin_film_ibl_comparison(panel: str = "roughness", *, resolution: int = 32, n_film: float = 1.3,
                             thickness: float = 600.0, alpha: float = 0.25, n_substrate=complex(2.0, 0.5),
                             max_thickness: float = 1000.0, observer: str = "CIE 1931 2",
                             illuminant: str = "D65") -> ThinFilmIBLComparison:
    """Compute one Fig. 7 panel (module docstring) on a ``resolution`` × ``resolution`` grid.

    Args:
        panel: ``"roughness"`` (θo × √α at ``thickness``) or ``"thickness"`` (θo × d at ``alpha``).
        resolution: cells per axis (≥ 2).
        n_film: film index η₂ (Kneiphof's Fig. 2: 1.3); n_substrate: base η₃ + iκ₃ (2 + 0.5i).
        thickness: d in nm for the roughness panel; alpha: GGX α for the thickness panel.
        max_thickness: upper end of the thickness panel's d axis (nm).
        observer, illuminant: colour space of the XYZ and ΔE2000.

    Returns:
        :class:`ThinFilmIBLComparison` (float64 computations; numpy arrays).
    """
    if panel not in THIN_FILM_IBL_PANELS:
        raise ValueError(f"panel must be one of {', '.join(map(repr, THIN_FILM_IBL_PANELS))}; got {panel!r}")
    resolution = _checks.check_int(resolution, "resolution", 2)
    for name, v in (("thickness", thickness), ("alpha", alpha), ("max_thickness", max_thickness)):
        if not (isinstance(v, (int, float)) and v > 0 and math.isfinite(v)):
            raise ValueError(f"{name} must be a positive number; got {v!r}")
    if not (isinstance(n_film, (int, float)) and n_film >= 1.0):
        raise ValueError(f"n_film must be a real index >= 1 (the outer medium is air); got {n_film!r}")
    f64 = torch.float64
    theta = _centres(resolution, 0.0, 90.0)
    c = torch.cos(torch.deg2rad(theta))[:, None]
    # keep the constant parameter unexpanded: the reference evaluates the film once per distinct
    # (η2, d, base), so a (1, B) or scalar thickness costs B or 1 spectral sweeps, not A·B
    if panel == "roughness":
        columns = _centres(resolution, 0.0, 1.0)
        a = (columns * columns)[None, :]
        d = torch.tensor(float(thickness), dtype=f64)
    else:
        columns = _centres(resolution, 0.0, float(max_thickness))
        a = torch.tensor(float(alpha), dtype=f64)
        d = columns[None, :]
    full = (resolution, resolution)
    kw = dict(observer=observer, illuminant=illuminant)
    ns = n_substrate
    xyz, secs = {}, {}
    xyz["reference"], secs["reference"] = _timed(lambda: thin_film_xyz_uniform(c, a, n_film, d, ns, **kw))
    xyz["original"], secs["original"] = _timed(
        lambda: thin_film_xyz_fourier(c, n_film, d, ns, terms=2, sensitivity="exact", **kw))
    (albedo, mu, cov), t_mom = _timed(lambda: uniform_light_moments(c, a))
    wo = torch.stack([torch.sqrt(1.0 - c * c), torch.zeros_like(c), c], -1).expand(*full, 3)
    # Fig. 7 is the paper's setting: M = 2 Fourier terms in every method (the library's default is 4)
    xyz["kneiphof"], secs["kneiphof"] = _timed(lambda: thin_film_xyz_filtered(wo, mu, cov, n_film, d, ns, terms=2, **kw))

    def via_D():
        mD, vD, _, _ = path_difference_moments(c, a, n_film, d)
        c1 = torch.sqrt(0.5 * (1.0 + (wo * mu).sum(-1)))  # eq. 22 at the mean, as the chain uses
        return thin_film_xyz_gaussian_path(c1, n_film, d, ns, mD, vD, terms=2, **kw)

    xyz["kneiphof_D"], secs["kneiphof_D"] = _timed(via_D)
    xyz["fitted"], secs["fitted"] = _timed(lambda: thin_film_xyz_fitted(c, a, n_film, d, ns, terms=2, **kw))
    xyz = {k: v.expand(*full, 3) for k, v in xyz.items()}
    lab_ref = xyz_to_lab(xyz["reference"], illuminant=illuminant, observer=observer)
    de = {k: delta_e_2000(xyz_to_lab(xyz[k], illuminant=illuminant, observer=observer), lab_ref).numpy()
          for k, _ in THIN_FILM_IBL_METHODS}
    params = {"panel": panel, "resolution": resolution, "n_film": n_film, "n_incident": 1.0,
              "n_substrate": [float(complex(ns).real), float(complex(ns).imag)],
              "thickness_nm": None if panel == "thickness" else float(thickness),
              "alpha": None if panel == "roughness" else float(alpha), "max_thickness_nm": float(max_thickness),
              "observer": observer, "illuminant": illuminant, "terms": 2, "polarization": "unpolarized",
              "moments_seconds": t_mom, "torchirid_version": __version__}
    return ThinFilmIBLComparison(
        panel=panel, theta_deg=theta.numpy(), cos_theta=c[:, 0].numpy(), columns=columns.numpy(),
        alpha=a.expand(full).numpy(), thickness_nm=d.expand(full).numpy(), albedo=albedo.expand(full).numpy(),
        xyz={k: v.detach().numpy() for k, v in xyz.items()}, delta_e=de, seconds=secs, params=params)


def _srgb(xyz: np.ndarray, exposure: float) -> np.ndarray:
    rgb = linear_srgb_to_srgb(xyz_to_linear_srgb(torch.as_tensor(xyz * exposure)).clamp(0.0, 1.0))
    return rgb.numpy()


def plot_thin_film_ibl(panels):
    """Draw Fig. 7: one row per panel, columns original / Kneiphof / Kneiphof-D / fitted / reference.

    Each image shows the reflected light A · term in sRGB (exposure set per panel so the
    reference's 99th-percentile luminance maps to 0.9), θo downwards, the column variable to
    the right; the ΔE2000 mean / p95 against the reference are printed under each image.
    Returns a ``matplotlib.figure.Figure`` (no pyplot).
    """
    from matplotlib.figure import Figure
    from matplotlib.ticker import MaxNLocator

    panels = list(panels)
    keys = [k for k, _ in THIN_FILM_IBL_METHODS] + ["reference"]
    labels = [lab for _, lab in THIN_FILM_IBL_METHODS] + ["reference (ground truth)"]
    fig = Figure(figsize=(2.3 * len(keys) + 0.6, 2.9 * len(panels) + 0.9))
    gs = fig.add_gridspec(len(panels), len(keys), left=0.06, right=0.99, top=0.9, bottom=0.13,
                          wspace=0.08, hspace=0.55)
    for i, p in enumerate(panels):
        light = {k: p.xyz[k] * p.albedo[..., None] for k in keys}
        exposure = 0.9 / max(float(np.quantile(light["reference"][..., 1], 0.99)), 1e-12)
        stats = p.stats()
        if p.panel == "roughness":
            xlab, ext = "√α", (0.0, 1.0, 90.0, 0.0)
            title = f"d = {p.params['thickness_nm']:g} nm"
        else:
            xlab, ext = "d (nm)", (0.0, p.params["max_thickness_nm"], 90.0, 0.0)
            title = f"α = {p.params['alpha']:g}"
        for j, (k, lab) in enumerate(zip(keys, labels)):
            ax = fig.add_subplot(gs[i, j])
            ax.imshow(_srgb(light[k], exposure), extent=ext, aspect="auto", interpolation="nearest")
            ax.set_title(lab, fontsize=7)
            ax.set_xlabel(xlab, fontsize=7, labelpad=1)
            ax.tick_params(labelsize=6, length=2, pad=1)
            ax.xaxis.set_major_locator(MaxNLocator(nbins=3))  # 2.3-inch panels: few ticks, no overlap
            ax.yaxis.set_major_locator(MaxNLocator(nbins=4))
            if j == 0:
                ax.set_ylabel(f"{title}\nθo (degrees)", fontsize=7)
            else:
                ax.set_yticklabels([])
            if k in stats:
                s = stats[k]
                ax.text(0.5, -0.3, f"ΔE00 mean {s['mean']:.2f}, p95 {s['p95']:.2f}", transform=ax.transAxes,
                        ha="center", va="top", fontsize=6.5)
    pr = panels[0].params
    ns = complex(*pr["n_substrate"])
    fig.suptitle("Thin film on a rough GGX base under uniform light (after Kneiphof et al. 2019, Fig. 7): "
                 f"η₂ = {pr['n_film']:g}, base {ns.real:g} + {ns.imag:g}i, M = 2", fontsize=9)
    return fig


def save_thin_film_ibl_png(panels, path: str | os.PathLike, *, dpi: int = 150):
    """Draw :func:`plot_thin_film_ibl` and write it atomically as a PNG. Returns the path."""
    fig = plot_thin_film_ibl(panels)
    return atomic_write(path, lambda f: fig.savefig(f, format=figure_format(path), dpi=dpi))


def save_thin_film_ibl_npz(panel: ThinFilmIBLComparison, path: str | os.PathLike):
    """Write :meth:`ThinFilmIBLComparison.arrays` atomically (readable with ``allow_pickle=False``)."""
    arrays = panel.arrays()
    return atomic_write(path, lambda f: np.savez(f, **arrays))
