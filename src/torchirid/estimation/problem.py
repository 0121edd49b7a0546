r"""The film-estimation problem: ``estimate_film``'s arguments checked and prepared once.

:func:`prepare_problem` checks every argument of
:func:`~torchirid.estimation.estimate_film` (``ValueError`` naming it) before any work and returns
a :class:`FilmProblem`: the cube with its missing samples as NaN, the valid pixels (those with at
least one finite sample: a dead pixel enters no sum), the axes, the band model and the
decimation (``DECIMATION_STRIDE``) that the index stages work on, and the progress counter that
every stage reports to. The stages (``index_search``, ``thickness_map``) take the problem.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch

from .. import _checks
from ._validation import band_settings, cube_axes, real_index, sorted_angles, uniform_bands, value_range, weight
from .dispersion import INDEX_MODELS
from .gauss_newton import model_terms
from .measurement import band_terms
from .residuals import decimation

__all__ = []

INDEX_CHOICES = ("auto",) + tuple(INDEX_MODELS)  # what estimate_film / fit-film accept
#: estimate_film's index model by default (fit-film and fit-batch film take it from there): "auto" — the
#: model of least BIC — is right on a dispersive film (the ZnS sample), where "constant" misfits it
DEFAULT_INDEX_MODEL = "auto"
DECIMATION_STRIDE = 3  # index stages: every 3rd band of the first, middle, last angles (~8x cheaper, orders distinct)


@dataclass
class FilmProblem:
    """A validated estimate_film problem: the cube ``y`` ``(*, A, B)`` (non-finite samples → NaN),
    its valid-pixel mask ``valid`` ``(P,)`` over all P pixels, the valid pixels ``Y`` ``(V, A, B)``
    (missing samples NaN) and their finite-sample counts ``count`` ``(V,)``, the axes, the band model
    ``band`` and the decimation ``a_sel``/``b_sel``. Every stage works on ``Y``: the invalid pixels
    enter no sum."""

    y: torch.Tensor
    valid: torch.Tensor
    Y: torch.Tensor
    count: torch.Tensor
    lam: torch.Tensor
    c: torch.Tensor
    ns: float
    band: dict
    n_range: tuple
    thickness_range: tuple
    a_sel: list
    b_sel: list
    progress: object  # the caller's progress(done, total), or None
    total: int = 0  # the units of work that progress counts (estimate_film's docstring; set by it)
    done: int = 0

    def step(self, units: int = 1) -> None:
        """Report ``units`` more units of work done to ``progress``."""
        self.done += units
        if self.progress is not None:
            self.progress(self.done, self.total)

    @property
    def s2(self) -> torch.Tensor:
        """n₀² sin²θ per angle."""
        return (self.band["n_incident"] ** 2) * (1 - self.c * self.c)

    @property
    def lam_mid(self) -> float:
        """The median band centre (nm)."""
        return float(self.lam.median())

    @property
    def batch(self) -> torch.Size:
        """The pixel axes ``(*)`` of the cube."""
        return self.y.shape[:-2]

    def scatter(self, x) -> torch.Tensor:
        """Per-valid-pixel values ``(V,)`` on the whole image ``(*)``, NaN at the invalid pixels."""
        out = torch.full((self.valid.numel(),), math.nan, dtype=x.dtype, device=x.device)
        return out.masked_scatter(self.valid, x).reshape(self.batch)

    def scalar(self, value) -> torch.Tensor:
        """A 0-d tensor of ``value`` in the problem's dtype and device."""
        return torch.as_tensor(value, dtype=self.Y.dtype, device=self.Y.device)

    def decimated(self, Y) -> torch.Tensor:
        """Pixels ``(p, A, B)`` reduced to the decimated angles and bands."""
        return Y[:, self.a_sel][:, :, self.b_sel]

    def terms(self, n, full_bands=False, all_angles=False):
        """Band terms of a constant index ``n`` on the decimated (or full) bands and angles."""
        lam = self.lam if full_bands else self.lam[self.b_sel]
        c = self.c if all_angles else self.c[self.a_sel]
        return band_terms(lam, c[:, None], n, self.ns, **self.band)

    def model_terms(self, theta, model, full_bands=False, all_angles=False):
        """Terms of the index model ``theta`` on the decimated (or full) bands and angles."""
        lam = self.lam if full_bands else self.lam[self.b_sel]
        c = self.c if all_angles else self.c[self.a_sel]
        return model_terms(theta, model, lam, c, self.ns, **self.band)

    def period(self, n: float) -> float:
        """Interference-order period T = λ_mid / (2 mean√(n² − n₀² sin²θ)) in nm."""
        return self.lam_mid / (2 * float(torch.sqrt(n * n - self.s2).mean()))


def prepare_problem(cube, wavelength, cos_theta, n_substrate, index_model_name, band, n_range, thickness_range,
                    smoothness, sample, iterations, final_iterations, seed, progress) -> FilmProblem:
    """Check every argument of ``estimate_film`` (ValueError naming it) before any work → the
    :class:`FilmProblem` (its progress ``total`` is left to the caller, which knows the stages)."""
    _checks.check_choice(index_model_name, "index_model_name", INDEX_CHOICES)
    y, lam, c = cube_axes(cube, wavelength, cos_theta, pixel_axes=1)
    if lam.numel() < 7:
        raise ValueError(f"wavelength must have at least 7 bands; got {lam.numel()}")
    uniform_bands(lam)
    sorted_angles(c)
    band_settings(band["bandwidth"], band["passband"], band["polarization"])
    band = dict(band, n_incident=real_index(band["n_incident"], "n_incident", y, incident=True))
    ns = real_index(n_substrate, "n_substrate", y)
    n_range = value_range(n_range, "n_range", positive=True)
    thickness_range = value_range(thickness_range, "thickness_range", positive=False, nm=True)
    weight(smoothness, "smoothness")
    _checks.check_int(sample, "sample")
    _checks.check_int(iterations, "iterations", minimum=0)
    _checks.check_int(final_iterations, "final_iterations", minimum=0)
    _checks.check_int(seed, "seed", minimum=0)
    if progress is not None and not callable(progress):
        raise ValueError(f"progress must be None or a callable progress(done, total); got {progress!r}")
    y = torch.where(y.isfinite(), y, math.nan)  # ±inf samples are missing data, like NaN (a new tensor)
    pixels = y.reshape(-1, *y.shape[-2:])
    finite = ~pixels.isnan()
    valid = finite.any(-1).any(-1)
    if not bool(valid.any()):
        raise ValueError(f"cube must have at least one pixel with a finite sample; all {valid.numel()} pixels are "
                         "NaN or infinite (dead pixels, e.g. an ENVI 'data ignore value')")
    a_sel, b_sel = decimation(*y.shape[-2:], DECIMATION_STRIDE)
    return FilmProblem(y=y, valid=valid, Y=pixels[valid], count=finite[valid].sum((-1, -2)).to(y.dtype), lam=lam,
                       c=c, ns=ns, band=band, n_range=n_range, thickness_range=thickness_range, a_sel=a_sel,
                       b_sel=b_sel, progress=progress)
