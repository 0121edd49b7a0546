r"""Seeded synthetic hyperspectral cubes of a film on a substrate (Kobayashi et al. §5).

:func:`synthetic_cube` renders a cube ``(H, W, A, B)`` — image rows × columns × incidence
angles × spectral bands — of the band-integrated reflectance
(:mod:`torchirid.estimation.measurement`) of a film whose thickness varies smoothly over the
image, then adds noise. Its ``polarization`` defaults to ``"unpolarized"``, like
:func:`~torchirid.estimation.estimate_film`'s (a cube and its fit agree by default); the paper's
camera sees the s wave: ``polarization="s"`` renders Kobayashi et al.'s setup.

.. math:: y = R + σ_g R_{max}\, ε_1 + σ_s \sqrt{R\, R_{max}}\, ε_2, \qquad ε_i \sim N(0, 1),

a Gaussian read-noise floor of σ_g and a shot (photon) noise whose standard deviation grows as
√R, both expressed as fractions of the brightest noise-free sample R_max (so "1 % noise" is
σ_g = σ_s = 0.01: 1 % of the peak from each source). The shot term is the Gaussian limit of a
Poisson count with R_max ↦ 1/σ_s² photons.

The three samples of the paper (:data:`~torchirid.presets.KOBAYASHI_SAMPLES`, §5.1, Table 1), all on PET (n = 1.64):

=============  ==========================================  =============
name           film                                        thickness
=============  ==========================================  =============
``mgf2_400``   MgF₂, n = 1.37 (non-dispersive)             400 nm
``mgf2_600``   MgF₂, n = 1.37                              600 nm
``zns_500``    ZnS, Debenham (1984) Sellmeier, 2.37 at D   500 nm
=============  ==========================================  =============

The thickness map is d(x, y) = d₀ (1 + v·f(x, y)), with f a seeded sum of four random
plane waves of at most 1.5 cycles across the image, rescaled to span [−1, 1] exactly, and
v = ``thickness_variation`` (default 0.1, i.e. ±10 %).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import torch

from .. import _checks, _chunks
from .dispersion import REFERENCE_WAVELENGTH, zns_index
from .measurement import airy_terms, band_nodes

__all__ = ["FilmSample", "SyntheticCube", "synthetic_cube"]

DEFAULT_ANGLES = (10.0, 20.0, 30.0, 40.0, 50.0)  # degrees, §5.1
_CPU = torch.device("cpu")


def default_wavelengths(dtype=torch.float64) -> torch.Tensor:
    """Band centres 400, 404, …, 720 nm (81 bands of 4 nm, the paper's LCTF sampling), on the CPU.

    >>> w = default_wavelengths(); (w.numel(), float(w[0]), float(w[-1]))
    (81, 400.0, 720.0)
    """
    return torch.arange(400.0, 720.0 + 1e-9, 4.0, dtype=dtype, device=_CPU)


@dataclass(frozen=True)
class FilmSample:
    """One of the paper's samples: film index (a number or a callable of λ in nm), d₀, substrate.

    Attributes:
        name, label: the key in :data:`~torchirid.presets.KOBAYASHI_SAMPLES` and a title.
        n_film: the film index, a number or a callable of λ (nm) → n.
        thickness: the mean thickness d₀ (nm); n_substrate: the substrate's real index (PET 1.64).
        paper: Kobayashi et al.'s Table-1 figures (empty for a sample of your own).

    Example (a sample of :data:`~torchirid.presets.KOBAYASHI_SAMPLES`, and one of your own rendered by :func:`synthetic_cube`):
        >>> from torchirid.presets import KOBAYASHI_SAMPLES
        >>> s = KOBAYASHI_SAMPLES["zns_500"]
        >>> s.thickness, s.n_substrate, round(s.n_reference, 3)  # nm; ZnS at 589.3 nm
        (500.0, 1.64, 2.367)
        >>> mine = FilmSample("sio2_300", "SiO2 300 nm", 1.46, 300.0)
        >>> tuple(synthetic_cube(mine, height=2, width=2).cube.shape)
        (2, 2, 5, 81)
    """

    name: str
    label: str
    n_film: object
    thickness: float
    n_substrate: float = 1.64
    paper: dict = field(default_factory=dict)

    def n_at(self, wavelength) -> torch.Tensor:
        """n at ``wavelength`` (nm), float64 on the device of ``wavelength`` (the CPU for a number)."""
        device = wavelength.device if isinstance(wavelength, torch.Tensor) else _CPU
        w = torch.as_tensor(wavelength, dtype=torch.float64, device=device)
        return self.n_film(w) if callable(self.n_film) else torch.full_like(w, float(self.n_film))

    @property
    def n_reference(self) -> float:
        """n at ``REFERENCE_WAVELENGTH`` (589.3 nm)."""
        return float(self.n_at(REFERENCE_WAVELENGTH))


# Table 1 of Kobayashi et al.: estimated n, mean estimated d, BRDF error (mean ΔE*ab), RMSE
SAMPLES = {
    "mgf2_400": FilmSample(
        "mgf2_400", "Sample 1: MgF2 400 nm", 1.37, 400.0,
        paper={"n_true": 1.370, "n_est": 1.374, "d_true": 400, "d_est": 370, "delta_e": 0.72, "rmse": 0.04},
    ),
    "mgf2_600": FilmSample(
        "mgf2_600", "Sample 2: MgF2 600 nm", 1.37, 600.0,
        paper={"n_true": 1.370, "n_est": 1.367, "d_true": 600, "d_est": 551, "delta_e": 1.21, "rmse": 0.07},
    ),
    "zns_500": FilmSample(
        "zns_500", "Sample 3: ZnS 500 nm", zns_index, 500.0,
        paper={"n_true": 2.370, "n_est": 2.674, "d_true": 500, "d_est": 541, "delta_e": 5.63, "rmse": 0.18},
    ),
}


@dataclass
class SyntheticCube:
    """A rendered cube and everything needed to score a fit of it.

    Attributes:
        cube: ``(H, W, A, B)`` noisy band reflectance.
        clean: ``(H, W, A, B)`` noise-free band reflectance.
        thickness: ``(H, W)`` true thickness (nm).
        wavelength: ``(B,)`` band centres (nm); angles_deg ``(A,)``; cos_theta ``(A,)``.
        sample: the :class:`FilmSample`; plus the rendering settings.

    Example (what :func:`synthetic_cube` returns: 4 × 4 pixels, 2 angles, 81 bands):
        >>> c = synthetic_cube("mgf2_600", height=4, width=4, angles_deg=(10.0, 40.0), seed=0)
        >>> tuple(c.cube.shape), tuple(c.thickness.shape), [round(v, 4) for v in c.cos_theta.tolist()]
        ((4, 4, 2, 81), (4, 4), [0.9848, 0.766])
        >>> c.sample.name, c.polarization, bool((c.cube - c.clean).abs().max() < 0.01)
        ('mgf2_600', 'unpolarized', True)
    """

    cube: torch.Tensor
    clean: torch.Tensor
    thickness: torch.Tensor
    wavelength: torch.Tensor
    angles_deg: torch.Tensor
    cos_theta: torch.Tensor
    sample: FilmSample
    bandwidth: float
    passband: str
    polarization: str
    gaussian_noise: float
    shot_noise: float
    seed: int


def smooth_field(height: int, width: int, generator: torch.Generator, *, waves: int = 4, dtype=torch.float64):
    """A smooth random field on ``(height, width)`` spanning exactly [−1, 1] (see module docstring),
    on the device of ``generator``.

    >>> g = torch.Generator().manual_seed(0)
    >>> f = smooth_field(8, 8, g); (round(float(f.min()), 12), round(float(f.max()), 12))
    (-1.0, 1.0)
    """
    height, width = _checks.check_int(height, "height"), _checks.check_int(width, "width")
    waves = _checks.check_int(waves, "waves")
    device = generator.device
    y = torch.linspace(0.0, 1.0, height, dtype=dtype, device=device)[:, None]
    x = torch.linspace(0.0, 1.0, width, dtype=dtype, device=device)[None, :]
    f = torch.zeros(height, width, dtype=dtype, device=device)
    scale = torch.tensor([3.0, 3.0, 2 * math.pi], dtype=dtype, device=device)
    for _ in range(waves):
        fx, fy, ph = (torch.rand(3, generator=generator, dtype=dtype, device=device) * scale).tolist()
        f = f + torch.cos(2 * math.pi * ((fx - 1.5) * x + (fy - 1.5) * y) * 0.5 + ph)
    if height * width == 1:
        return torch.zeros_like(f)
    lo, hi = f.min(), f.max()
    return 2 * (f - lo) / (hi - lo) - 1


def synthetic_cube(
    sample="mgf2_400",
    *,
    height: int = 64,
    width: int = 64,
    angles_deg=DEFAULT_ANGLES,
    wavelength=None,
    bandwidth: float = 4.0,
    passband: str = "box",
    polarization: str = "unpolarized",
    gaussian_noise: float = 0.01,
    shot_noise: float = 0.01,
    thickness_variation: float = 0.1,
    seed: int = 0,
    nodes: int = 8,
    dtype=torch.float64,
) -> SyntheticCube:
    """Render a seeded noisy cube ``(H, W, A, B)`` of one of :data:`~torchirid.presets.KOBAYASHI_SAMPLES` (or a :class:`FilmSample`).

    Args:
        sample: a key of :data:`~torchirid.presets.KOBAYASHI_SAMPLES` or a :class:`FilmSample`.
        height, width: image size in pixels (≥ 1).
        angles_deg: incidence angles in degrees, in [0, 90).
        wavelength: ``(B,)`` band centres in nm; default 400–720 nm every 4 nm. The cube is
            rendered on its device (the CPU by default); the noise is drawn on the CPU.
        bandwidth, passband, nodes: the band model of ``band_reflectance()``.
        polarization: ``"unpolarized"`` (default, as :func:`~torchirid.estimation.estimate_film`),
            ``"s"`` (Kobayashi et al.'s setup) or ``"p"``.
        gaussian_noise, shot_noise: σ_g, σ_s ≥ 0 as fractions of R_max (module docstring).
        thickness_variation: v ≥ 0, relative half-range of the thickness map (< 1).
        seed: seeds one ``torch.Generator`` for the map and the noise.

    Example:
        >>> c = synthetic_cube("mgf2_400", height=4, width=5, seed=1)
        >>> tuple(c.cube.shape), round(float(c.thickness.min()), 6), round(float(c.thickness.max()), 6)
        ((4, 5, 5, 81), 360.0, 440.0)
    """
    if isinstance(sample, str):
        if sample not in SAMPLES:
            raise ValueError(f"sample must be one of {_checks.names(tuple(SAMPLES))} or a FilmSample; got {sample!r}")
        sample = SAMPLES[sample]
    height, width = _checks.check_int(height, "height"), _checks.check_int(width, "width")
    nodes = _checks.check_int(nodes, "nodes")
    for name, v in (("gaussian_noise", gaussian_noise), ("shot_noise", shot_noise)):
        if not (v >= 0 and math.isfinite(v)):
            raise ValueError(f"{name} must be >= 0 (a fraction of R_max); got {v!r}")
    if not (0 <= thickness_variation < 1):
        raise ValueError(f"thickness_variation must be in [0, 1); got {thickness_variation!r}")
    _checks.check_polarization(polarization)
    _checks.check_int(seed, "seed", minimum=0)
    device = wavelength.device if isinstance(wavelength, torch.Tensor) else _CPU
    ang = torch.as_tensor(angles_deg, dtype=dtype, device=device).reshape(-1)
    if ang.numel() < 1 or bool(((ang < 0) | (ang >= 90) | ang.isnan()).any()):
        raise ValueError(f"angles_deg must be in [0, 90) degrees; got {ang.tolist()}")
    if wavelength is None:
        lam = default_wavelengths(dtype)
    else:
        lam = _checks.as_real(wavelength, "wavelength", dtype, device).reshape(-1)
    _checks.check_wavelength(lam)
    gen = torch.Generator(device=_CPU).manual_seed(int(seed))  # (the same cube on every device)
    d = sample.thickness * (1 + thickness_variation * smooth_field(height, width, gen, dtype=dtype).to(device))
    cos_t = torch.cos(torch.deg2rad(ang))
    off, wts = band_nodes(bandwidth, nodes, passband, dtype=dtype, device=device)
    lam_q = lam[:, None] + off  # (B, Q)
    n_f = sample.n_at(lam_q).to(dtype) if callable(sample.n_film) else float(sample.n_film)
    a, b, e, k = airy_terms(lam_q, cos_t[:, None, None], n_f, sample.n_substrate, polarization=polarization)
    flat = d.reshape(-1)
    # block by block over the pixels (torchirid._chunks): (pol, A, B, nodes) samples per pixel
    per_pixel = math.prod(torch.broadcast_shapes(a.shape, b.shape, e.shape, k.shape))
    clean = _chunks.evaluate(_render, (flat,), flat.shape, out_core=2, width=per_pixel, a=a, b=b, e=e, k=k, wts=wts)
    clean = clean.reshape(height, width, ang.numel(), lam.numel())
    r_max = clean.max()

    def randn():
        return torch.randn(clean.shape, generator=gen, dtype=dtype, device=_CPU).to(device)

    noise = gaussian_noise * r_max * randn()
    noise = noise + shot_noise * (clean * r_max).sqrt() * randn()
    return SyntheticCube(
        cube=clean + noise, clean=clean, thickness=d, wavelength=lam, angles_deg=ang, cos_theta=cos_t,
        sample=sample, bandwidth=float(bandwidth), passband=passband, polarization=polarization,
        gaussian_noise=float(gaussian_noise), shot_noise=float(shot_noise), seed=int(seed),
    )


def _render(d, *, a, b, e, k, wts):
    """Band reflectance ``(P, A, B)`` of the thicknesses ``d`` ``(P,)`` from the Airy terms (one block)."""
    cb = b * torch.cos(k * d[:, None, None, None, None])
    R = ((a + cb) / (e + cb)).mean(1)
    return (R * wts).sum(-1)
