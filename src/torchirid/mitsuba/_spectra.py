"""Indices and spectral bookkeeping of the plugins: an index given as a number, ``n`` and ``k``
or a material of :mod:`torchirid.materials` (tabulated for Dr.Jit on a 0.1 nm grid), and the
quadrature that turns a spectral value into linear sRGB in Mitsuba's RGB variants."""

from __future__ import annotations

import sys

import numpy as np
import torch

from ..color import xyz_to_linear_srgb, xyz_weights
from ..materials import material_range, refractive_index
from ._optics import Complex

#: the wavelength range of Mitsuba's spectral variants (``mi.MI_CIE_MIN`` – ``mi.MI_CIE_MAX``), nm
SPECTRAL_RANGE = (360.0, 830.0)
#: spacing of the tables of named materials, nm
TABLE_STEP = 0.1
#: the RGB variants' wavelength nodes: 380–780 nm every 5 nm (81 nodes; the error of this
#: quadrature against a 1 nm sum is in docs/guide/mitsuba.md)
RGB_NODES = tuple(float(x) for x in np.arange(380.0, 780.0 + 1e-9, 5.0))


class Index:
    """A complex refractive index ``n + iκ``: constant, or a named material tabulated in λ.

    ``permittivity(lam)`` returns ``N²`` as a :class:`~torchirid.mitsuba._optics.Complex`
    over the type of ``lam`` (a Python float, or a Dr.Jit ``Float64`` array in the JIT
    variants; ``gather`` is then the variant's gather of ``Float64`` tables)."""

    def __init__(self, value, k: float = 0.0, *, name: str = "index"):
        self.name = name
        self.material = None
        if isinstance(value, (str, tuple)):  # a name, or a (shelf, book, page) of the database
            self.material = value
            lo, hi = _covered(value)
            self.grid = np.arange(lo, hi + 0.5 * TABLE_STEP, TABLE_STEP)
            n = refractive_index(value, torch.tensor(self.grid, dtype=torch.float64))
            self.n_table = n.real.numpy().copy()
            self.k_table = n.imag.numpy().copy()
            self.lossless = bool(np.all(self.k_table == 0))
            self.n_min = float(self.n_table.min())
            if k:
                raise ValueError(f"{name}: give either a material name or k, not both (got {value!r} and k = {k})")
        else:
            value = complex(value) + 1j * float(k)
            if not value.real > 0 or value.imag < 0:
                raise ValueError(f"{name}: an index needs n > 0 and k >= 0, got {value}")
            self.constant = value
            self.lossless = value.imag == 0
            self.n_min = value.real
        self._jit = None

    def real_root(self, n_incident: float) -> bool:
        """Whether :math:`q = N\\cos\\theta` is real for every angle of light from a medium of
        real index ``n_incident``: lossless and never below it (no total internal reflection)."""
        return self.lossless and self.n_min >= n_incident

    def value(self, lam: float) -> complex:
        """The index at one wavelength (Python number)."""
        if self.material is None:
            return self.constant
        return complex(np.interp(lam, self.grid, self.n_table), np.interp(lam, self.grid, self.k_table))

    def describe(self) -> str:
        if isinstance(self.material, tuple):
            return "/".join(self.material)
        return self.material if self.material is not None else f"{self.constant.real:g}" + (
            f"+{self.constant.imag:g}i" if self.constant.imag else "")

    def torch(self, lam: torch.Tensor) -> torch.Tensor:
        """The index at wavelengths ``lam`` (float64 tensor), as the library computes it."""
        if self.material is None:
            return torch.full_like(lam, 0, dtype=torch.complex128) + self.constant
        lo, hi = float(self.grid[0]), float(self.grid[-1])
        return refractive_index(self.material, lam.clamp(lo, hi))

    def permittivity(self, lam, dr=None, float64=None) -> Complex:
        if self.material is None:
            n = Complex(self.constant.real, self.constant.imag if self.constant.imag else 0.0)
            return n * n
        if isinstance(lam, (float, int)):
            v = self.value(float(lam))
            n = Complex(v.real, v.imag if not self.lossless else 0.0)
            return n * n
        if self._jit is None or self._jit[0] is not float64:
            # n and κ interpolated linearly, as the library does between the database's samples:
            # on a 0.1 nm grid the only error is at the database's own nodes (slope kinks
            # inside a grid cell). (n, κ) interleaved: one gather of a pair per node.
            pair = sys.modules[float64.__module__].Array2f64
            flat = np.stack([self.n_table, self.k_table], -1).reshape(-1)
            self._jit = (float64, pair, float64(flat), float64(self.n_table))
        _, pair, nk_tab, n_tab = self._jit
        x = dr.clip((lam - float(self.grid[0])) / TABLE_STEP, 0.0, float(len(self.grid) - 1) - 1e-9)
        i0 = dr.floor(x)
        f = x - i0
        idx = dr.uint32_array_t(float64)(i0)
        if self.lossless:
            n = dr.gather(float64, n_tab, idx) * (1.0 - f) + dr.gather(float64, n_tab, idx + 1) * f
            return Complex(n * n, 0.0)
        a = dr.gather(pair, nk_tab, idx)
        b = dr.gather(pair, nk_tab, idx + 1)
        c = Complex(a[0] * (1.0 - f) + b[0] * f, a[1] * (1.0 - f) + b[1] * f)
        return c * c


def _covered(material: str) -> tuple[float, float]:
    """The part of Mitsuba's spectral range the material's table covers (beyond it: held)."""
    lo, hi = material_range(material)
    lo = max(float(lo), SPECTRAL_RANGE[0])
    hi = min(float(hi), SPECTRAL_RANGE[1])
    if hi - lo < 2 * TABLE_STEP:
        raise ValueError(f"material {material!r} has no data in the visible range {SPECTRAL_RANGE} nm")
    return lo, hi


#: wavelengths (nm) of the exact RGB integral of tabulated structures (1 nm, the CIE range)
FINE_NODES = tuple(float(x) for x in np.arange(360.0, 830.0 + 1e-9, 1.0))

_RGB_WEIGHTS: dict = {}


def rgb_weights(nodes=RGB_NODES) -> np.ndarray:
    """``(3, K)`` weights at ``nodes``: linear sRGB of a reflectance under D65 (CIE 1931 2°),
    each row scaled to sum to 1 so that a white reflector is exactly (1, 1, 1)."""
    nodes = tuple(nodes)
    if nodes not in _RGB_WEIGHTS:
        lam = torch.tensor(nodes, dtype=torch.float64)
        w_xyz = xyz_weights(lam)  # (K, 3)
        m = xyz_to_linear_srgb(torch.eye(3, dtype=torch.float64))  # rows: images of X, Y, Z
        w = (w_xyz @ m).T.numpy()  # (3, K)
        _RGB_WEIGHTS[nodes] = w / w.sum(axis=1, keepdims=True)
    return _RGB_WEIGHTS[nodes]
