r"""Small colour textures for real-time renderers, their node values fitted by autograd.

A fragment shader that samples a float texture with hardware (bi/tri)linear filtering sees the
multilinear interpolation of the texel values, with texel ``i`` of an axis of ``n`` texels at
the texture coordinate ``u = (i + ½) / n``. A texture over ``[lo, hi]`` per axis (of the warped
coordinate, :data:`AXIS_WARPS`: ``sqrt(cos θ)`` for the cosines) therefore
reproduces :meth:`torchirid.lut.LUT.interp` of a :class:`~torchirid.lut.LUT` whose axis grids
are ``n`` uniform nodes from ``lo`` to ``hi``, when the shader maps a coordinate ``x`` to
``u = ((x − lo) / (hi − lo) · (n − 1) + ½) / n`` (``texture_coordinate()``; clamped at the
edges like ``CLAMP_TO_EDGE``).

*Sampled* textures store the exact colour at the nodes. Between nodes their error is that of
linear interpolation of a function that, for iridescent colours, oscillates: fringes narrower
than two texels alias. *Fitted* textures store the node values that minimise the colour error
of the **interpolated** texture against the exact colour over dense samples of the domain:

.. math::

    \min_V \; \frac{1}{M}\sum_{m=1}^{M} \Delta E_{00}\!\left(\mathrm{Lab}(\mathcal{I}_V(x_m)),\,
    \mathrm{Lab}(c(x_m))\right)^2

with :math:`\mathcal{I}_V` the multilinear interpolation of node values :math:`V` (linear sRGB,
D65, white Y = 1), :math:`c` the exact colour (spectral integration) and :math:`x_m` uniform
random samples (a fixed seed). L-BFGS from the sampled values; autograd through
:meth:`LUT.interp <torchirid.lut.LUT.interp>` and :func:`~torchirid.color.delta_e_2000`. The
errors are reported on a second, independent sample set (:class:`TextureFit`).

Families (:data:`FAMILIES`): ``"thin_film"`` RGB over (cos θ, d) of one film on one base,
``"thin_film_path"`` RGB over (cos θ, p, n_f) of films of any index n_f on one base, p the
optical path difference 2 n_f d cos θ_f (:func:`path_difference`),
``"bragg"`` RGB over (cos θ, λ_B, δ) of a Bragg mirror of N cells, ``"rough_thin_film"`` RGB over
(cos θ_o, α, d) under uniform light (Kneiphof et al.'s setting). The Bragg texture's second axis
is the Bragg wavelength λ_B (:func:`bragg_wavelength`) rather than the period: an axis warp
that follows the colour (measured: docs/performance.md, "Shader textures: fitted against
sampled node values").
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Mapping

import torch

from .. import _checks, _threads
from ..color import delta_e_2000, spectrum_to_xyz, xyz_to_lab
from ..color.convert import linear_srgb_to_xyz, xyz_to_linear_srgb
from ..lut import LUT

__all__ = ["AXIS_WARPS", "FAMILIES", "SHIPPED_TEXTURES", "TextureFit", "bragg_wavelength", "exact_colour", "fit_texture",
           "glsl_source", "lookup", "path_difference", "shipped_texture", "texture_lut"]

F64 = torch.float64


def texture_coordinate(x, lo: float, hi: float, n: int):
    """The texture coordinate ``u`` in [½/n, 1 − ½/n] of ``x`` on an axis of ``n`` texels over
    ``[lo, hi]`` (``x`` clamped to the range): what the shaders compute before ``texture()``.

    Example (thicknesses in nm on a 16-texel axis over 100–400 nm):
        >>> import torch
        >>> u = texture_coordinate(torch.tensor([100.0, 250.0, 400.0, 900.0]), 100.0, 400.0, 16)
        >>> [round(v, 4) for v in u.tolist()]  # the end texels' centres; 900 nm is clamped
        [0.0312, 0.5, 0.9688, 0.9688]
    """
    t = ((torch.as_tensor(x) - lo) / (hi - lo)).clamp(0.0, 1.0)
    return (t * (n - 1) + 0.5) / n


# --- the exact colours of the families ----------------------------------------------------------

def _wavelengths(device=None):
    return torch.linspace(380.0, 780.0, 401, dtype=F64, device=device)


def _thin_film(x, *, n_film: float, n_substrate, n_incident: float = 1.0):
    from ..optics import thin_film_reflectance

    cos_theta, d = x[..., 0], x[..., 1]
    lam = _wavelengths(x.device)
    R = thin_film_reflectance(lam, cos_theta[..., None], n_film, d[..., None], _index(n_substrate), n_incident=n_incident)
    return spectrum_to_xyz(R, lam)


def _index(n):
    """A refractive index given as a number or as a ``[re, im]`` pair (a LUT's JSON parameters
    cannot hold complex numbers)."""
    return complex(*n) if isinstance(n, (list, tuple)) else n


def path_difference(cos_theta, n_film, thickness, *, n_incident: float = 1.0):
    r"""The optical path difference (nm) of a film's two first reflections,
    :math:`p = 2 n_f d \cos\theta_f = 2d\sqrt{n_f^2 - n_0^2(1 - \cos^2\theta)}`.

    The ``"thin_film_path"`` texture's second axis (an axis warp, as λ_B for Bragg mirrors): a
    film's colour depends on d, n_f and θ mostly through p (the fringe order at λ is p/λ), so
    texels spent along p follow the colour and few are needed along n_f. The shaders compute it
    the same way before the lookup (``tirid_path_difference``).

    Args:
        cos_theta: cos θ in the incident medium; n_film: real film index; thickness: d (nm);
            n_incident: real index of the incident medium — broadcasting; dtype/device from them.

    Returns:
        p in nm (0 where the film would totally reflect, n_f < n_0 sin θ).

    Example:
        >>> round(float(path_difference(1.0, 1.33, 300.0)), 6)
        798.0
    """
    dtype, device = _checks.resolve_dtype_device(cos_theta, thickness, n_film, n_incident)
    c, d, n, n0 = (_checks.as_real(v, name, dtype, device) for v, name in
                   ((cos_theta, "cos_theta"), (thickness, "thickness"), (n_film, "n_film"), (n_incident, "n_incident")))
    return 2 * d * torch.sqrt(torch.clamp(n * n - n0 * n0 * (1 - c * c), min=0.0))


def _thin_film_path(x, *, n_substrate, n_incident: float = 1.0):
    from ..optics import thin_film_reflectance

    cos_theta, path, n_film = x[..., 0], x[..., 1], x[..., 2]
    d = path / path_difference(cos_theta, n_film, 1.0, n_incident=n_incident)
    lam = _wavelengths(x.device)
    R = thin_film_reflectance(lam, cos_theta[..., None], n_film[..., None], d[..., None], _index(n_substrate),
                              n_incident=n_incident)
    return spectrum_to_xyz(R, lam)


def bragg_wavelength(cos_theta, n1: float, n2: float, period, delta, *, n_incident: float | None = None):
    r"""The first-order Bragg wavelength (nm) of a mirror of period Λ, δ the fraction in n2:

    .. math:: \lambda_B = 2\Lambda\left[(1-\delta)\, n_1\cos\theta_1 + \delta\, n_2\cos\theta_2\right],
        \quad n_i \cos\theta_i = \sqrt{n_i^2 - n_0^2 (1 - \cos^2\theta)},

    with θ the angle in the incident medium n_0 (``n_incident``; default n1, the mirror
    embedded in n1 as :func:`~torchirid.bragg_xyz` has it).

    The Bragg texture's second axis (an axis warp): a mirror's colour depends on Λ and cos θ
    mostly through λ_B, so texels spent along λ_B follow the colour; the shaders compute it the
    same way before the lookup.

    ``cos_theta``, ``period`` (nm) and ``delta``: numbers or tensors that broadcast together
    (dtype/device from them); ``n1``, ``n2``, ``n_incident``: real numbers.

    Example (Λ = 160 nm, δ = ½, n1 = 1.56, n2 = 1.68, at normal incidence and at cos θ = 0.5):
        >>> import torch
        >>> lam = bragg_wavelength(torch.tensor([1.0, 0.5]), 1.56, 1.68, 160.0, 0.5)
        >>> [round(v, 1) for v in lam.tolist()]  # nm; at normal incidence 2Λ(n1 + n2)/2
        [518.4, 284.6]
        >>> round(float(bragg_wavelength(1.0, 1.56, 1.68, 160.0, 0.5)), 1)  # numbers work too
        518.4
    """
    dtype, device = _checks.resolve_dtype_device(cos_theta, period, delta)
    cos_theta, period, delta = (_checks.as_real(v, name, dtype, device) for v, name in
                                ((cos_theta, "cos_theta"), (period, "period"), (delta, "delta")))
    n0 = n1 if n_incident is None else n_incident
    s2 = n0 * n0 * (1 - cos_theta * cos_theta)
    q1 = torch.sqrt(torch.clamp(n1 * n1 - s2, min=0.0))
    q2 = torch.sqrt(torch.clamp(n2 * n2 - s2, min=0.0))
    return 2 * period * ((1 - delta) * q1 + delta * q2)


def _bragg(x, *, cells: int, n1: float, n2: float, n_incident: float | None = None):
    from ..spectral import bragg_xyz

    cos_theta, lam_b, delta = x[..., 0], x[..., 1], x[..., 2]
    period = lam_b / bragg_wavelength(cos_theta, n1, n2, 1.0, delta, n_incident=n_incident)
    # δ: the fraction of the period in the n2 layer (Fourneau et al. Table 3)
    return bragg_xyz(cos_theta, n1, n2, period * (1 - delta), period * delta, cells, n_incident=n_incident,
                     method="spectral")


def _rough_thin_film(x, *, n_film: float, n_substrate, n_incident: float = 1.0, bins: int = 2048, nodes: int = 64):
    from ..ibl import thin_film_xyz_uniform

    return thin_film_xyz_uniform(x[..., 0], x[..., 1], n_film, x[..., 2], _index(n_substrate), n_incident=n_incident,
                                 bins=bins, nodes=nodes)


#: family → (axis names, units, exact XYZ function of points ``(*, k)`` and the family's parameters)
FAMILIES: dict[str, tuple[tuple[str, ...], tuple[str, ...], Callable]] = {
    "thin_film": (("cos_theta", "thickness"), ("1", "nm"), _thin_film),
    "thin_film_path": (("cos_theta", "path_difference", "n_film"), ("1", "nm", "1"), _thin_film_path),
    "bragg": (("cos_theta", "bragg_wavelength", "delta"), ("1", "nm", "1"), _bragg),
    "rough_thin_film": (("cos_theta_o", "alpha", "thickness"), ("1", "1", "nm"), _rough_thin_film),
}

#: axis warps: the texture is uniform in ``warp(x)``, not in ``x`` (its axis is named
#: ``<warp>_<axis>``). Cosines get ``sqrt``: near grazing the colour of a film changes over a
#: range of cos θ as narrow as |1 + e^{iδ}| (measured on a 16 × 64 soap-film texture: max ΔE2000
#: 12 below cos θ = 0.005 with texels uniform in cos θ).
WARPS: dict[str, tuple[Callable, Callable]] = {"sqrt": (torch.sqrt, torch.square)}
AXIS_WARPS = {"cos_theta": "sqrt", "cos_theta_o": "sqrt"}


def _warp(name, x, inverse=False):
    w = AXIS_WARPS.get(name)
    return x if w is None else WARPS[w][1 if inverse else 0](x)


def texture_axes(family: str) -> tuple[str, ...]:
    """The texture's axis names: the family's axes, warped ones prefixed (``sqrt_cos_theta``).

    Example:
        >>> texture_axes("thin_film"), texture_axes("bragg")
        (('sqrt_cos_theta', 'thickness'), ('sqrt_cos_theta', 'bragg_wavelength', 'delta'))
    """
    return tuple(f"{AXIS_WARPS[n]}_{n}" if n in AXIS_WARPS else n for n in FAMILIES[family][0])


def to_texture(family: str, points: torch.Tensor) -> torch.Tensor:
    """Points ``(*, k)`` in the family's coordinates (cos θ, nm, …) → the texture's (warped) coordinates.

    Example (thin film: (cos θ, d in nm) → (√cos θ, d)):
        >>> import torch
        >>> to_texture("thin_film", torch.tensor([[0.25, 300.0], [1.0, 120.0]])).tolist()
        [[0.5, 300.0], [1.0, 120.0]]
    """
    return torch.stack([_warp(n, points[..., j]) for j, n in enumerate(FAMILIES[family][0])], -1)


def lookup(lut: LUT, family: str, points: torch.Tensor) -> torch.Tensor:
    """The texture's colour at ``points`` (family coordinates): warp, then multilinear (clamped)
    interpolation — what the shaders do with hardware filtering (``texture_coordinate()``).

    Returns linear sRGB ``(*, 3)`` in the texture's dtype.

    Example (the shipped soap-film texture against the exact colour):
        >>> import torch
        >>> lut = shipped_texture("thin_film_soap")  # a film of n 1.33 in air, over (cos θ, d)
        >>> pts = torch.tensor([[1.0, 300.0], [0.5, 500.0]], dtype=torch.float64)  # (cos θ, d in nm)
        >>> rgb = lookup(lut, "thin_film", pts)
        >>> exact = exact_colour("thin_film", pts, {k: lut.parameters[k] for k in ("n_film", "n_substrate")})
        >>> tuple(rgb.shape), bool((rgb.double() - exact).abs().max() < 0.005)
        ((2, 3), True)
    """
    return lut.interp(*to_texture(family, points).unbind(-1))


def exact_colour(family: str, points: torch.Tensor, parameters: Mapping) -> torch.Tensor:
    """Linear sRGB (D65, white Y = 1) of ``family`` at ``points`` (``(*, k)``, the family's axes
    in order), evaluated spectrally — the reference the textures are fitted to.

    ``parameters``: the family's fixed parameters, as in :func:`fit_texture`. Returns ``(*, 3)``.

    Example (a 300 nm soap film, n 1.33, in air, at normal incidence and at cos θ = 0.5):
        >>> import torch
        >>> pts = torch.tensor([[1.0, 300.0], [0.5, 300.0]], dtype=torch.float64)  # (cos θ, d in nm)
        >>> rgb = exact_colour("thin_film", pts, {"n_film": 1.33, "n_substrate": 1.0})
        >>> tuple(rgb.shape), [round(v, 3) for v in rgb[0].tolist()]
        ((2, 3), [0.043, 0.078, 0.033])
    """
    _checks.check_choice(family, "family", FAMILIES)
    xyz = FAMILIES[family][2](points, **dict(parameters))
    return xyz_to_linear_srgb(xyz)


# --- the shipped textures -----------------------------------------------------------------------

#: the textures shipped in torchirid/data/textures (built by luts/build_shader_textures.py)
SHIPPED_TEXTURES = ("thin_film_soap", "thin_film_on_glass", "thin_film_path_air", "thin_film_path_glass",
                    "thin_film_path_absorbing", "rough_thin_film", "bragg_n6", "bragg_n8", "bragg_n10")


def shipped_texture(name: str) -> LUT:
    """A shipped fitted texture (float32 linear sRGB) by name (:data:`SHIPPED_TEXTURES`); its
    ``parameters`` hold the family, the ranges and the measured ΔE2000 (``errors_de2000``).

    Example:
        >>> lut = shipped_texture("bragg_n8")
        >>> list(lut.axes), lut.parameters["cells"], lut.values.shape
        (['sqrt_cos_theta', 'bragg_wavelength', 'delta'], 8, torch.Size([8, 64, 4, 3]))
    """
    from importlib import resources

    _checks.check_choice(name, "name", SHIPPED_TEXTURES)
    path = resources.files("torchirid") / "data" / "textures" / f"{name}.npz"
    with resources.as_file(path) as p:
        return LUT.read(p, builder=f"luts/build_shader_textures.py {name}")


def _parameters(lut: LUT) -> dict:
    """The family parameters stored in a texture (what :func:`exact_colour` takes)."""
    keys = ("n_film", "n_substrate", "n_incident", "cells", "n1", "n2", "bins", "nodes")
    return {k: lut.parameters[k] for k in keys if k in lut.parameters}


def scan_grid(lut: LUT, per_texel=2) -> torch.Tensor:
    """The dense scan's points of a texture, in family coordinates ``(M, k)``: a regular grid over
    the texture's whole domain with ``per_texel`` points per texel step along each axis (an int,
    or one per axis), uniform in the warped coordinates — every node and ``per_texel − 1`` points
    between each pair of neighbours (the midpoints for 2), where linear interpolation is worst.

    Example (a 16 × 64 film texture, 2 per texel: 31 × 127 points, corners included):
        >>> pts = scan_grid(shipped_texture("thin_film_soap"))
        >>> tuple(pts.shape), pts[:, 1].min().item(), pts[:, 1].max().item()
        ((3937, 2), 100.0, 800.0)
    """
    family = lut.parameters["family"]
    names = FAMILIES[family][0]
    per = [per_texel] * len(names) if isinstance(per_texel, int) else list(per_texel)
    axes = []
    for name, g, m in zip(names, lut.axes.values(), per):
        g = g.to(F64)
        axes.append(_warp(name, torch.linspace(float(g[0]), float(g[-1]), (g.numel() - 1) * int(m) + 1, dtype=F64),
                          inverse=True))
    return torch.stack(torch.meshgrid(*axes, indexing="ij"), -1).reshape(-1, len(names))


def scan_texture(lut: LUT, per_texel=2, *, points: torch.Tensor | None = None, block: int = 20_000) -> dict:
    """ΔE2000 of a texture (:func:`lookup`) against :func:`exact_colour` over the dense scan of its
    whole domain (``scan_grid()``, or the given ``points``): ``{"mean", "p95", "max", "at",
    "points", "per_texel"}``, ``at`` the point of the max (family coordinates). What
    ``luts/build_shader_textures.py`` stores as a texture's ``errors_de2000["dense"]`` and the
    tests hold.

    Example (the soap-film texture at its nodes and midpoints):
        >>> scan = scan_texture(shipped_texture("thin_film_soap"))
        >>> scan["points"], scan["mean"] < 0.5
        (3937, True)
    """
    family = lut.parameters["family"]
    params = _parameters(lut)
    pts = scan_grid(lut, per_texel) if points is None else points.to(F64)
    lut64 = lut.to(F64)
    de = []
    with torch.no_grad():
        for i in range(0, pts.shape[0], block):
            x = pts[i:i + block]
            de.append(delta_e_2000(_lab(lookup(lut64, family, x)), _lab(exact_colour(family, x, params))))
    de = torch.cat(de)
    return {**_stats(de), "at": [round(float(v), 6) for v in pts[int(de.argmax())]], "points": int(pts.shape[0]),
            "per_texel": per_texel if isinstance(per_texel, int) else list(per_texel)}


def glsl_source() -> str:
    """The shader functions (GLSL ES 3.00) that evaluate these textures inside the GGX BRDF:
    ``torchirid/realtime/glsl/torchirid.glsl`` (no ``#version`` line: prepend your own).

    Example:
        >>> src = glsl_source()
        >>> "#version" in src, "tirid_thin_film_rgb" in src, "tirid_bragg_rgb" in src
        (False, True, True)
    """
    from importlib import resources

    return (resources.files("torchirid") / "realtime" / "glsl" / "torchirid.glsl").read_text(encoding="utf-8")


# --- fitting ------------------------------------------------------------------------------------

@dataclass
class TextureFit:
    """A fitted texture and its measured colour errors.

    Attributes:
        lut: the fitted texture: a :class:`~torchirid.lut.LUT` of linear sRGB (``(*sizes, 3)``)
            on grids uniform in the warped coordinates (``texture_axes()``; query it with
            :func:`lookup`); export it with :func:`torchirid.export.export_lut`.
        sampled: the same grid holding the exact colour at the nodes (the baseline).
        errors: ΔE2000 on the validation samples: ``{"fitted": {"mean", "p95", "max"},
            "sampled": {…}}``.
        texels: the number of texels (RGB each).
        seconds: wall time of the fit.
        history: the training loss (mean ΔE00²) per L-BFGS loss evaluation.

    Example (what :func:`fit_texture` returns, for a tiny 4 × 8 texture and a short fit):
        >>> fit = fit_texture("thin_film", (4, 8), ((0.5, 1.0), (100.0, 300.0)), {"n_film": 1.33, "n_substrate": 1.5},
        ...                   samples=200, validation=200, iterations=5)
        >>> tuple(fit.lut.values.shape), tuple(fit.sampled.values.shape), fit.texels
        ((4, 8, 3), (4, 8, 3), 32)
        >>> fit.errors["fitted"]["mean"] < fit.errors["sampled"]["mean"]  # ΔE2000 on the validation samples
        True
    """

    lut: LUT
    sampled: LUT
    errors: dict
    texels: int
    seconds: float
    history: list = field(default_factory=list, repr=False)


def _lab(rgb):
    return xyz_to_lab(linear_srgb_to_xyz(rgb))


def _stats(de: torch.Tensor) -> dict:
    de = de.detach().double()
    return {"mean": float(de.mean()), "p95": float(torch.quantile(de, 0.95)), "max": float(de.max())}


def _samples(ranges, count, seed):
    u = torch.rand(count, len(ranges), generator=torch.Generator().manual_seed(seed), dtype=F64)
    lo, hi = torch.tensor(ranges, dtype=F64).unbind(-1)
    return lo + u * (hi - lo)


@dataclass
class TextureSamples:
    """Training and validation samples of a family's exact colour over a domain (reusable
    across texture sizes: the exact colour is the expensive part). Attributes: ``train_x``
    ``(M, k)``, ``train_rgb`` ``(M, 3)``, ``valid_x``, ``valid_rgb``, ``ranges``.

    Example (samples drawn once by ``texture_samples()``, then two texture sizes fitted to them):
        >>> params = {"n_film": 1.33, "n_substrate": 1.5}
        >>> s = texture_samples("thin_film", ((0.5, 1.0), (100.0, 300.0)), params, samples=200, validation=100)
        >>> tuple(s.train_x.shape), tuple(s.valid_rgb.shape), s.ranges
        ((200, 2), (100, 3), ((0.5, 1.0), (100.0, 300.0)))
        >>> [fit_texture("thin_film", n, s.ranges, params, samples=s, iterations=3).texels for n in ((2, 4), (4, 8))]
        [8, 32]
    """

    train_x: torch.Tensor
    train_rgb: torch.Tensor
    valid_x: torch.Tensor
    valid_rgb: torch.Tensor
    ranges: tuple


def texture_samples(family: str, ranges, parameters: Mapping, *, samples: int = 20_000, validation: int = 20_000,
                    seed: int = 0, exact: Callable | None = None) -> TextureSamples:
    """Uniform random samples of the domain (seeds ``seed`` and ``seed + 1``) and their exact colours.

    Arguments as :func:`fit_texture`; ``samples`` training and ``validation`` validation points.
    Returns a :class:`TextureSamples` (points in the family's coordinates, linear sRGB colours).

    Example (a thin film over cos θ ∈ [0.2, 1] and d ∈ [100, 400] nm):
        >>> s = texture_samples("thin_film", ((0.2, 1.0), (100.0, 400.0)), {"n_film": 1.33, "n_substrate": 1.5},
        ...                     samples=64, validation=32)
        >>> tuple(s.train_x.shape), tuple(s.train_rgb.shape), tuple(s.valid_rgb.shape)
        ((64, 2), (64, 3), (32, 3))
        >>> bool((s.train_x[:, 1] >= 100.0).all() and (s.train_x[:, 1] <= 400.0).all())  # nm
        True
    """
    ranges = _check_ranges(family, ranges)
    for count, name in ((samples, "samples"), (validation, "validation")):
        if isinstance(count, bool) or not isinstance(count, int) or count < 1:
            raise ValueError(f"{name} must be an int >= 1; got {count!r}")
    exact = exact or (lambda p: exact_colour(family, p, parameters))
    with torch.no_grad():
        tx, vx = _samples(ranges, samples, seed), _samples(ranges, validation, seed + 1)
        return TextureSamples(tx, exact(tx), vx, exact(vx), ranges)


def _check_ranges(family, ranges):
    _checks.check_choice(family, "family", FAMILIES)
    names = FAMILIES[family][0]
    try:
        ranges = tuple((float(lo), float(hi)) for lo, hi in ranges)
    except (TypeError, ValueError):
        raise ValueError(f"ranges must give {len(names)} (lo, hi) pairs; got {ranges!r}") from None
    if len(ranges) != len(names) or any(not (math.isfinite(lo) and math.isfinite(hi) and lo < hi) for lo, hi in ranges):
        raise ValueError(f"ranges must give {len(names)} (lo, hi) pairs with lo < hi ({', '.join(names)}); "
                         f"got {ranges!r}")
    return ranges


def texture_lut(family: str, values: torch.Tensor, ranges, parameters: Mapping, *, builder: str) -> LUT:
    """A LUT of ``values`` (``(*sizes, 3)`` linear sRGB) on the family's axes, uniform over ``ranges``.

    The grids are uniform in the warped coordinates (``texture_axes()``); ``parameters`` and
    ``ranges`` are stored in the LUT's ``parameters``, ``builder`` names what made it.

    Example (a 4 × 8 thin-film texture over cos θ ∈ [0.25, 1], d ∈ [100, 400] nm):
        >>> import torch
        >>> lut = texture_lut("thin_film", torch.zeros(4, 8, 3, dtype=torch.float64), ((0.25, 1.0), (100.0, 400.0)),
        ...                   {"n_film": 1.33, "n_substrate": 1.5}, builder="my texture")
        >>> list(lut.axes), [round(float(x), 3) for x in lut.axes["sqrt_cos_theta"]]  # uniform in √cos θ
        (['sqrt_cos_theta', 'thickness'], [0.5, 0.667, 0.833, 1.0])
        >>> lut.parameters["family"], lut.units["thickness"]
        ('thin_film', 'nm')
    """
    names, units, _ = FAMILIES[family]
    sizes = values.shape[:-1]
    axes = {}
    for n, t, (lo, hi), size in zip(names, texture_axes(family), ranges, sizes):
        lo_hi = _warp(n, torch.tensor([float(lo), float(hi)], dtype=F64))
        axes[t] = torch.linspace(float(lo_hi[0]), float(lo_hi[1]), int(size), dtype=values.dtype, device=values.device)
    units = {t: (f"{AXIS_WARPS[n]}({u})" if n in AXIS_WARPS else u) for n, t, u in zip(names, texture_axes(family), units)}
    return LUT(values, axes, builder=builder, parameters={"family": family, "ranges": [list(r) for r in ranges],
                                                          **dict(parameters)},
               units={**units, "values": "linear sRGB (D65, white Y = 1)"})


@_threads.large_work  # (the free cores on a shared machine: torchirid._threads)
def fit_texture(family: str, sizes, ranges, parameters: Mapping, *, samples: int | TextureSamples = 20_000,
                validation: int = 20_000, iterations: int = 60, seed: int = 0, exact: Callable | None = None,
                progress=None) -> TextureFit:
    r"""Fit the node values of a ``family`` texture of ``sizes`` texels over ``ranges``.

    Args:
        family: one of :data:`FAMILIES`.
        sizes: texels per axis, in the family's axis order (each ≥ 2).
        ranges: ``(lo, hi)`` per axis, in the axis' units (cos θ in [0, 1], nm, …).
        parameters: the family's fixed parameters: ``thin_film`` and ``rough_thin_film``:
            ``n_film``, ``n_substrate`` (complex for a metal, or ``[re, im]``), ``n_incident``
            (``rough_thin_film`` also ``bins``, ``nodes`` of :func:`~torchirid.ibl.thin_film_xyz_uniform`);
            ``thin_film_path``: ``n_substrate``, ``n_incident``; ``bragg``:
            ``cells``, ``n1``, ``n2``, ``n_incident`` (the axes: cos θ, λ_B in nm, δ).
        samples: training samples (uniform in the domain, seed ``seed``), or the samples of
            ``texture_samples()`` (then ``validation`` and ``seed`` are theirs).
        validation: independent validation samples (seed ``seed + 1``) for :attr:`TextureFit.errors`.
        iterations: L-BFGS iterations (strong-Wolfe line search).
        seed: the sample seed.
        exact: the reference ``points (*, k) → linear sRGB`` (default :func:`exact_colour`).
        progress: ``None`` or a callable ``progress(done, total)``: ``done`` loss evaluations
            (one loss and gradient over the training samples each; L-BFGS evaluates more than
            once per iteration in its line search) out of its budget ``total =
            iterations * 5 // 4 + 1``, after each evaluation; a fit that converges early ends
            with ``(total, total)``. The losses are :attr:`TextureFit.history`.

    Returns:
        :class:`TextureFit`: the fitted and the sampled textures and their ΔE2000 statistics.

    Example:
        >>> fit = fit_texture("thin_film", (8, 16), ((0.2, 1.0), (100.0, 400.0)),
        ...                   {"n_film": 1.33, "n_substrate": 1.5}, samples=2000, validation=2000,
        ...                   iterations=10)
        >>> fit.lut.values.shape, fit.texels
        (torch.Size([8, 16, 3]), 128)
        >>> fit.errors["fitted"]["mean"] < fit.errors["sampled"]["mean"]
        True
    """
    import time

    ranges = _check_ranges(family, ranges)
    names = FAMILIES[family][0]
    sizes = tuple(sizes)
    if len(sizes) != len(names) or any(isinstance(s, bool) or not isinstance(s, int) or s < 2 for s in sizes):
        raise ValueError(f"sizes must give {len(names)} ints >= 2 (texels along {', '.join(names)}); got {sizes!r}")
    if isinstance(iterations, bool) or not isinstance(iterations, int) or iterations < 1:
        raise ValueError(f"iterations must be an int >= 1; got {iterations!r}")
    if progress is not None and not callable(progress):
        raise ValueError(f"progress must be None or a callable progress(done, total); got {progress!r}")
    exact = exact or (lambda p: exact_colour(family, p, parameters))
    start = time.perf_counter()
    if not isinstance(samples, TextureSamples):
        samples = texture_samples(family, ranges, parameters, samples=samples, validation=validation, seed=seed,
                                  exact=exact)
    elif samples.ranges != ranges:
        raise ValueError(f"samples were drawn over {samples.ranges}, not over ranges={ranges}")
    builder = f"torchirid.realtime.fit_texture({family!r})"
    shell = texture_lut(family, torch.zeros(*sizes, 3, dtype=F64), ranges, parameters, builder=builder)
    grid = torch.stack(torch.meshgrid(*[_warp(n, g, inverse=True) for n, g in zip(names, shell.axes.values())],
                                      indexing="ij"), -1)  # the nodes in family coordinates
    with torch.no_grad():
        node_rgb = exact(grid.reshape(-1, len(names))).reshape(*sizes, 3)
        train_x, valid_x = samples.train_x, samples.valid_x
        train_lab, valid_lab = _lab(samples.train_rgb), _lab(samples.valid_rgb)
    sampled = texture_lut(family, node_rgb.clone(), ranges, parameters, builder=builder + " sampled")
    values = node_rgb.clone().requires_grad_(True)
    coords = to_texture(family, train_x).unbind(-1)

    def loss_fn():
        lut = texture_lut(family, values, ranges, parameters, builder=builder)
        de = delta_e_2000(_lab(lut.interp(*coords)), train_lab)
        return (de * de).mean()

    opt = torch.optim.LBFGS([values], lr=1.0, max_iter=iterations, history_size=20, line_search_fn="strong_wolfe",
                            tolerance_grad=1e-10, tolerance_change=1e-12)
    history = []
    budget = opt.param_groups[0]["max_eval"] + 1  # evaluations: max_eval, + 1 from the last line search

    def closure():
        opt.zero_grad()
        loss = loss_fn()
        loss.backward()
        history.append(float(loss.detach()))
        if progress is not None:
            progress(min(len(history), budget), budget)
        return loss

    opt.step(closure)
    if progress is not None and len(history) < budget:
        progress(budget, budget)  # converged before the budget
    fitted = texture_lut(family, values.detach().clone(), ranges, parameters, builder=builder)
    vc = to_texture(family, valid_x).unbind(-1)
    with torch.no_grad():
        errors = {"fitted": _stats(delta_e_2000(_lab(fitted.interp(*vc)), valid_lab)),
                  "sampled": _stats(delta_e_2000(_lab(sampled.interp(*vc)), valid_lab))}
    return TextureFit(fitted, sampled, errors, math.prod(sizes), time.perf_counter() - start, history)
