"""Thin ``nn.Module`` wrappers with learnable parameters, for fitting by gradient descent.

Each module stores its physical parameters as ``nn.Parameter`` (float64 by default) and calls
the functional core in ``forward(wavelength, cos_theta)``; options it does not set are left
to the function's own defaults.  Parameters are unconstrained: to keep a thickness ≥ 0 or
an index > 0 while fitting, register a parametrization
(``torch.nn.utils.parametrize.register_parametrization``) — the functions raise
``ValueError`` on out-of-range values rather than clipping them.

Example:
    >>> import torch, torchirid
    >>> mirror = torchirid.BraggMirror(n2=1.5, d1=125.0, d2=375.0, cells=20)
    >>> R = mirror(torch.linspace(400, 700, 4, dtype=torch.float64), torch.tensor(1.0, dtype=torch.float64))
    >>> R.sum().backward()
    >>> mirror.d2.grad is not None
    True
"""

from __future__ import annotations

import torch
from torch import nn

from .. import _checks
from .bragg import bragg_reflectance
from .transfer import multilayer
from .thin_film import thin_film_reflectance

__all__ = ["BraggMirror", "ThinFilm", "Multilayer"]


def _param(x, dtype):
    return nn.Parameter(torch.as_tensor(x, dtype=dtype).clone())


def _options(**kw):
    """Keyword options that were set (None means: use the function's default)."""
    return {k: v for k, v in kw.items() if v is not None}


class BraggMirror(nn.Module):
    """Learnable Bragg mirror ``n_incident | (n2, d2), (n1, d1) × cells | n1`` (see :func:`bragg_reflectance`).

    Learnable: ``n1``, ``n2`` (real indices) and ``d1``, ``d2`` (nm). Fixed: ``cells``,
    ``n_incident`` (None: n1) and ``polarization``.
    """

    def __init__(self, n1=1.0, n2=1.5, d1=125.0, d2=375.0, cells=20, *, n_incident=None, polarization=None,
                 dtype=torch.float64):
        super().__init__()
        self.n1, self.n2 = _param(n1, dtype), _param(n2, dtype)
        self.d1, self.d2 = _param(d1, dtype), _param(d2, dtype)
        self.cells = cells
        self.n_incident = n_incident
        self.polarization = polarization

    def forward(self, wavelength, cos_theta):
        return bragg_reflectance(wavelength, cos_theta, self.n1, self.n2, self.d1, self.d2, self.cells,
                                 **_options(n_incident=self.n_incident, polarization=self.polarization))

    def extra_repr(self):
        return f"cells={self.cells}, n_incident={self.n_incident}, polarization={self.polarization or 'default'}"


class ThinFilm(nn.Module):
    """Learnable thin film on a substrate (see :func:`thin_film_reflectance`).

    Learnable: the real film index ``n_film`` and ``thickness`` (nm). Fixed (a buffer,
    complex allowed): ``n_substrate``; fixed ``n_incident`` and ``polarization``.
    """

    def __init__(self, n_film=1.33, thickness=300.0, n_substrate=1.0, *, n_incident=None, polarization=None,
                 dtype=torch.float64):
        super().__init__()
        self.n_film = _param(n_film, dtype)
        self.thickness = _param(thickness, dtype)
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
    ``thicknesses[..., L]`` (nm) are learnable.
    """

    def __init__(self, indices, thicknesses, *, polarization=None, dtype=torch.float64):
        super().__init__()
        idx = torch.as_tensor(indices)
        self.register_buffer("indices", idx.to(_checks.complex_dtype(dtype) if idx.is_complex() else dtype))
        self.thicknesses = _param(thicknesses, dtype)
        self.polarization = polarization

    def forward(self, wavelength, cos_theta):
        return multilayer(wavelength, cos_theta, self.indices, self.thicknesses,
                          **_options(polarization=self.polarization))
