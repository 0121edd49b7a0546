r"""Thin ``nn.Module`` wrappers with learnable parameters, for fitting by gradient descent.

Each module stores its physical parameters as ``nn.Parameter`` (float64 by default) and calls
the functional core in ``forward(wavelength, cos_theta)``; options it does not set are left
to the function's own defaults.

**Every optimiser step gives a valid structure.** The learnable quantities are parametrised
(:mod:`torch.nn.utils.parametrize`) so that any real value of the underlying raw parameter maps
to a valid one:

.. math:: d = \operatorname{softplus}(r) \ge 0 , \qquad n = n_{min} + \operatorname{softplus}(r) \ge n_{min}

(thicknesses in nm; indices at least ``min_index``, default 1; softplus reaches the bound only
by underflow, for raw values below about −745). ``module.d1`` reads the physical
value; the raw one the optimiser moves is ``module.parametrizations.d1.original``
(:func:`raw_parameters` lists them). Initial values exactly on a bound (d = 0, n = 1) start a
hair inside it (10⁻¹² above), where the gradient is ~10⁻¹²: such a parameter effectively
stays put — set ``requires_grad_(False)`` on it or start inside. ``cells`` (the number of
Bragg cells) is a fixed integer, not learned: it is checked when set (ValueError), and a fit
over N scans integers (one module per N, or ``cells`` set between fits).

Example:
    >>> import torch, torchirid
    >>> mirror = torchirid.BraggMirror(n2=1.5, d1=125.0, d2=375.0, cells=20)
    >>> R = mirror(torch.linspace(400, 700, 4, dtype=torch.float64), torch.tensor(1.0, dtype=torch.float64))
    >>> R.sum().backward()
    >>> mirror.parametrizations.d2.original.grad is not None
    True
    >>> round(mirror.d2.item(), 9)
    375.0
"""

from __future__ import annotations

import torch
from torch import nn
from torch.nn.utils import parametrize

from .. import _checks
from .bragg import bragg_reflectance
from .transfer import multilayer
from .thin_film import thin_film_reflectance

__all__ = ["BraggMirror", "ThinFilm", "Multilayer", "raw_parameters"]

_EDGE = 1e-12  # how far inside its bound a value given exactly on it starts


class _AtLeast(nn.Module):
    """``lower + softplus(raw)``: every real raw value is a value > ``lower``."""

    def __init__(self, lower: float):
        super().__init__()
        self.lower = float(lower)

    def forward(self, raw: torch.Tensor) -> torch.Tensor:
        return self.lower + nn.functional.softplus(raw)

    def right_inverse(self, value: torch.Tensor) -> torch.Tensor:
        y = (value - self.lower).clamp(min=_EDGE)
        return y + torch.log(-torch.expm1(-y))  # log(expm1(y)), without overflow for large y

    def extra_repr(self) -> str:
        return f"lower={self.lower:g}"


def _bounded(module: nn.Module, name: str, value, lower: float, dtype, what: str) -> None:
    """Register ``name`` as a learnable value > ``lower`` (ValueError naming it if not finite and ≥ lower)."""
    t = torch.as_tensor(value, dtype=dtype).clone()
    if not bool(torch.isfinite(t).all()) or bool((t < lower).any()):
        raise ValueError(f"{name} must be a finite {what} >= {lower:g}; got {value!r}")
    setattr(module, name, nn.Parameter(t))
    parametrize.register_parametrization(module, name, _AtLeast(lower))


def raw_parameters(module: nn.Module) -> dict[str, torch.Tensor]:
    """The unconstrained tensors an optimiser moves, by the name of the value they parametrise.

    >>> sorted(raw_parameters(ThinFilm()))
    ['n_film', 'thickness']
    """
    if not parametrize.is_parametrized(module):
        return {}
    return {name: p.original for name, p in module.parametrizations.items()}


def _options(**kw):
    """Keyword options that were set (None means: use the function's default)."""
    return {k: v for k, v in kw.items() if v is not None}


class BraggMirror(nn.Module):
    """Learnable Bragg mirror ``n_incident | (n2, d2), (n1, d1) × cells | n1`` (see :func:`bragg_reflectance`).

    Learnable (parametrised, module docstring): ``n1``, ``n2`` (real indices > ``min_index``)
    and ``d1``, ``d2`` (nm, > 0). Fixed: ``cells`` (an integer ≥ 1, checked when set),
    ``n_incident`` (None: n1) and ``polarization``. ``forward(wavelength, cos_theta)`` (nm, cos θ;
    broadcast together) returns R of their broadcast shape.

    Example:
        >>> import torch, torchirid
        >>> mirror = torchirid.BraggMirror(n1=1.0, n2=1.5, d1=125.0, d2=375.0, cells=20)
        >>> wavelength = torch.linspace(400.0, 700.0, 4, dtype=torch.float64)  # nm
        >>> R = mirror(wavelength, torch.tensor(1.0, dtype=torch.float64))  # cos θ = 1: normal incidence
        >>> R.shape
        torch.Size([4])
        >>> torch.allclose(R, torchirid.bragg_reflectance(wavelength, 1.0, 1.0, 1.5, 125.0, 375.0, 20))
        True
        >>> R.sum().backward()  # the raw (unconstrained) thickness gets the gradient
        >>> mirror.parametrizations.d1.original.grad is not None
        True
    """

    def __init__(self, n1=1.0, n2=1.5, d1=125.0, d2=375.0, cells=20, *, n_incident=None, polarization=None,
                 min_index: float = 1.0, dtype=torch.float64):
        super().__init__()
        _bounded(self, "n1", n1, min_index, dtype, "index")
        _bounded(self, "n2", n2, min_index, dtype, "index")
        _bounded(self, "d1", d1, 0.0, dtype, "thickness in nm")
        _bounded(self, "d2", d2, 0.0, dtype, "thickness in nm")
        self.cells = cells
        self.n_incident = n_incident
        self.polarization = polarization

    @property
    def cells(self) -> int:
        """Number of Bragg cells N: a fixed integer ≥ 1 (not learned; scan it between fits)."""
        return self._cells

    @cells.setter
    def cells(self, value) -> None:
        self._cells = _checks.check_int(value, "cells", 1)

    def forward(self, wavelength, cos_theta):
        return bragg_reflectance(wavelength, cos_theta, self.n1, self.n2, self.d1, self.d2, self.cells,
                                 **_options(n_incident=self.n_incident, polarization=self.polarization))

    def extra_repr(self):
        return f"cells={self.cells}, n_incident={self.n_incident}, polarization={self.polarization or 'default'}"


class ThinFilm(nn.Module):
    """Learnable thin film on a substrate (see :func:`thin_film_reflectance`).

    Learnable (parametrised, module docstring): the real film index ``n_film`` (> ``min_index``)
    and ``thickness`` (nm, > 0). Fixed (a buffer, complex allowed): ``n_substrate``; fixed
    ``n_incident`` and ``polarization``. ``forward(wavelength, cos_theta)`` (nm, cos θ; broadcast
    together) returns R of their broadcast shape.

    Example (a soap film in air; even a wild step on the raw parameter keeps d > 0):
        >>> import torch, torchirid
        >>> film = torchirid.ThinFilm(n_film=1.33, thickness=300.0, n_substrate=1.0)
        >>> wavelength = torch.tensor([450.0, 550.0, 650.0], dtype=torch.float64)  # nm
        >>> R = film(wavelength, torch.tensor(1.0, dtype=torch.float64))  # cos θ = 1
        >>> [round(v, 4) for v in R.tolist()]
        [0.0344, 0.0754, 0.0347]
        >>> raw = film.parametrizations.thickness.original  # what an optimiser moves
        >>> R.sum().backward()
        >>> raw.grad is not None
        True
        >>> with torch.no_grad():
        ...     _ = raw.sub_(310.0)  # a wild step: 300 − 310 = −10 nm without the parametrisation
        >>> f"{film.thickness.item():.3g}"  # softplus(−10) nm: still a valid thickness
        '4.54e-05'
    """

    def __init__(self, n_film=1.33, thickness=300.0, n_substrate=1.0, *, n_incident=None, polarization=None,
                 min_index: float = 1.0, dtype=torch.float64):
        super().__init__()
        _bounded(self, "n_film", n_film, min_index, dtype, "index")
        _bounded(self, "thickness", thickness, 0.0, dtype, "thickness in nm")
        sub = torch.as_tensor(n_substrate)
        self.register_buffer("n_substrate", sub.to(_checks.complex_dtype(dtype) if sub.is_complex() else dtype))
        self.n_incident = n_incident
        self.polarization = polarization

    def forward(self, wavelength, cos_theta):
        return thin_film_reflectance(wavelength, cos_theta, self.n_film, self.thickness, self.n_substrate,
                                     **_options(n_incident=self.n_incident, polarization=self.polarization))


class Multilayer(nn.Module):
    """Learnable film thicknesses of a fixed stack (see :func:`multilayer`); returns ``(R, T)``.

    ``indices[..., L+2]`` (a buffer, complex allowed: incident medium first) stay fixed;
    ``thicknesses[..., L]`` (nm, > 0; parametrised, module docstring) are learnable.
    ``forward(wavelength, cos_theta)`` (nm, cos θ) returns the reflectance and transmittance.

    Example (a two-film coating on glass):
        >>> import torch, torchirid
        >>> stack = torchirid.Multilayer([1.0, 1.45, 2.3, 1.52], [90.0, 60.0])  # air | films | glass; nm
        >>> R, T = stack(torch.tensor([450.0, 550.0], dtype=torch.float64), torch.tensor(1.0, dtype=torch.float64))
        >>> [round(v, 4) for v in R.tolist()]
        [0.0961, 0.0629]
        >>> torch.allclose(R + T, torch.ones(2, dtype=torch.float64))  # lossless films
        True
        >>> R.sum().backward()
        >>> stack.parametrizations.thicknesses.original.grad.shape  # one per film
        torch.Size([2])
    """

    def __init__(self, indices, thicknesses, *, polarization=None, dtype=torch.float64):
        super().__init__()
        idx = torch.as_tensor(indices)
        self.register_buffer("indices", idx.to(_checks.complex_dtype(dtype) if idx.is_complex() else dtype))
        _bounded(self, "thicknesses", thicknesses, 0.0, dtype, "thickness in nm")
        self.polarization = polarization

    def forward(self, wavelength, cos_theta):
        return multilayer(wavelength, cos_theta, self.indices, self.thicknesses,
                          **_options(polarization=self.polarization))
