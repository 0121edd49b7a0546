r"""``torchirid_bragg``: a Bragg mirror (Yeh; :func:`~torchirid.optics.bragg_reflectance`),
smooth, or Fourneau et al.'s rough Bragg layer over a Lambertian base under its coating — the
structure's tables: the layer's integrated transmissivity τ(θ, λ) (eq. 28, with slope tables
for the parameters Dr.Jit differentiates) and, in the RGB variants, the mirror's exact 1 nm
colour over the angle."""

from __future__ import annotations

import math

import numpy as np
import torch

from . import _optics as optics
from ._properties import _float_arg, _gather, _warn_symbolic
from ._spectra import FINE_NODES, RGB_NODES, SPECTRAL_RANGE, Index, rgb_weights

#: θ nodes (uniform in θ over [0, π/2]) and λ spacing (nm) of the τ table of a rough Bragg layer
TAU_ANGLES = 1024
TAU_STEP = 1.0
#: θ nodes (uniform in θ) of a Bragg mirror's linear-sRGB table in the RGB variants
RGB_ANGLES = 8192


def define(variant, Plugin):
    """The ``torchirid_bragg`` class of the active variant, on the plugins' base class."""
    mi, dr, jit, spectral = variant.mi, variant.dr, variant.jit, variant.spectral
    f64, to_float = variant.f64, variant.to_float

    class Bragg(Plugin):
        """``torchirid_bragg``: a Bragg mirror (bragg_reflectance), smooth or a rough Bragg layer."""

        def _read(self, props):
            self.n1 = _float_arg(props, "n1", positive=True)
            if props.get("n2", None) is None:
                raise ValueError("n2 is required")
            self.n2 = Index(props.get("n2"), props.get("k2", 0.0), name="n2")
            if self.n2.material is not None:
                raise ValueError("n2 must be a number (with k2 for absorption): the Bragg layer's closed form "
                                 "takes constant indices")
            d1 = _float_arg(props, "d1", positive=True)
            d2 = _float_arg(props, "d2", positive=True)
            self.d1 = mi.Float(d1) if jit else d1
            self.d2 = mi.Float(d2) if jit else d2
            cells = props.get("cells", None)
            if cells is None or int(cells) != cells or int(cells) < 1:
                raise ValueError(f"cells must be an integer >= 1, got {cells}")
            self.cells = int(cells)
            if "n_incident" not in props:
                self.n_incident = self.n1
            self.base_albedo = _float_arg(props, "base_albedo", 0.0, low=0.0)
            if self.base_albedo > 1:
                raise ValueError(f"base_albedo must be in [0, 1], got {self.base_albedo}")
            self._tau = None

        def _n_exit(self):  # the smooth mirror's exit medium (bragg_reflectance)
            return self.n1

        # -- RGB variants: a table of the exact 1 nm colour over the angle ------------------
        # The fringes of a mirror of many cells alias on the 5 nm nodes of the film plugins
        # (ΔE2000 up to 4 at 100 cells): the mirror's linear sRGB is tabulated instead, from
        # the library's R on a 1 nm grid, over RGB_ANGLES angles (rebuilt when d1, d2 change;
        # not differentiable in the RGB variants — the spectral ones are).
        def _values(self, si, cos_i, side):
            if spectral:
                return Plugin._values(self, si, cos_i, side)
            if self.evaluator == "torch":
                return self._rgb_exact(cos_i), None
            table = self._rgb_table()
            theta = dr.acos(dr.clip(f64(cos_i), 0.0, 1.0))
            x = dr.clip(theta * ((RGB_ANGLES - 1) / (math.pi / 2)), 0.0, RGB_ANGLES - 1 - 1e-9)
            i0 = dr.floor(x)
            fx = x - i0
            out = []
            for c in range(3):
                base = i0 * 3 + c
                out.append(to_float((1.0 - fx) * _gather(table, base) + fx * _gather(table, base + 3)))
            return mi.Spectrum(*out), None

        def _rgb_of(self, cos: torch.Tensor) -> torch.Tensor:
            """``(*, 3)`` linear sRGB of the mirror at cosines ``cos`` (float64), 1 nm integral."""
            lam = torch.tensor(FINE_NODES, dtype=torch.float64)
            r, _ = self._torch(lam, cos[..., None], 0)
            return r @ torch.tensor(rgb_weights(FINE_NODES).T)

        def _rgb_table(self):
            if getattr(self, "_rgb", None) is None:
                theta = torch.linspace(0.0, math.pi / 2, RGB_ANGLES, dtype=torch.float64)
                flat = self._rgb_of(torch.cos(theta)).reshape(-1).numpy()
                self._rgb = mi.Float64(flat) if jit else flat.tolist()
            return self._rgb

        def _rgb_exact(self, cos_i):
            if not jit:
                rgb = self._rgb_of(torch.tensor([float(cos_i)], dtype=torch.float64))[0]
                return mi.Spectrum(*[float(v) for v in rgb])
            if dr.flag(dr.JitFlag.SymbolicScope):
                _warn_symbolic()
                return dr.zeros(mi.Spectrum, dr.width(cos_i))

            @dr.wrap(source="drjit", target="torch")
            def run(c):
                rgb = self._rgb_of(c)
                return rgb[:, 0].contiguous(), rgb[:, 1].contiguous(), rgb[:, 2].contiguous()

            cols = run(dr.detach(mi.Float64(cos_i)))
            return mi.Spectrum(*[mi.Float(x) for x in cols])

        def parameters_changed(self, keys):
            self._rgb = None  # the tables follow d1, d2 (not differentiably)
            self._tau = None

        # -- the rough Bragg layer (Fourneau et al. eq. 34, one layer) -----------------------
        @property
        def coated(self):
            return self.rough and self.n_incident != 1.0

        def _tau_grid(self, d1, d2, alpha):
            """τ(θ, λ) of eq. 28 from the library's :func:`~torchirid.layered.transmissivity_lut`,
            resampled to TAU_ANGLES nodes uniform in θ; λ on a TAU_STEP grid (spectral) or the
            RGB nodes. Returns ``(λ grid, (TAU_ANGLES, Λ) array)``."""
            from ..layered import RoughBraggLayer, transmissivity_lut

            if spectral:
                lam = np.arange(SPECTRAL_RANGE[0], SPECTRAL_RANGE[1] + 0.5 * TAU_STEP, TAU_STEP)
            else:
                lam = np.array(RGB_NODES)
            n2 = self.n2.constant
            layer = RoughBraggLayer(self.n1, n2 if n2.imag else n2.real, d1, d2, self.cells, alpha,
                                    n_incident=self.n_incident)
            lut = transmissivity_lut(torch.tensor(lam, dtype=torch.float64), layer)
            theta = torch.linspace(0.0, math.pi / 2, TAU_ANGLES, dtype=torch.float64)
            return lam, lut.interp(torch.cos(theta)).clamp(0.0, 1.0).numpy()

        def _tau_table(self):
            """The τ table at the current parameters and, for each of d1, d2, alpha that Dr.Jit
            differentiates, its derivative by a central difference: τ is evaluated as
            ``τ0 + Σ (p − p0) ∂τ/∂p``, exact in value (p = p0: the table is rebuilt when the
            parameters change) with the table's derivative as its gradient."""
            point = {k: float(getattr(self, k)[0] if jit else getattr(self, k)) for k in ("d1", "d2", "alpha")}
            wanted = tuple(k for k in ("d1", "d2", "alpha") if jit and dr.grad_enabled(getattr(self, k)))
            if self._tau is None or self._tau["point"] != point or not set(wanted) <= set(self._tau["slopes"]):
                lam, value = self._tau_grid(**point)
                slopes = {}
                for k in wanted:
                    h = 1e-3 * point[k] if k == "alpha" else 0.02  # nm for d1, d2
                    up = self._tau_grid(**{**point, k: point[k] + h})[1]
                    down = self._tau_grid(**{**point, k: point[k] - h})[1]
                    slopes[k] = (up - down) / (2 * h)
                pack = (lambda a: mi.Float64(a.reshape(-1))) if jit else (lambda a: a.reshape(-1).tolist())
                self._tau = {"point": point, "lam": lam, "width": value.shape[1], "value": pack(value),
                             "slopes": {k: pack(v) for k, v in slopes.items()}}
            return self._tau

        def _tau_values(self, si, cos_theta):
            """τ at the host cosine ``cos_theta`` for every channel (a list, like ``_values``)."""
            tab = self._tau_table()
            lam_grid, width = tab["lam"], tab["width"]
            tables = [(tab["value"], None)] + [(t, k) for k, t in tab["slopes"].items()]
            theta = dr.acos(dr.clip(f64(cos_theta), 0.0, 1.0))
            x = dr.clip(theta * ((TAU_ANGLES - 1) / (math.pi / 2)), 0.0, TAU_ANGLES - 1 - 1e-9)
            i0 = dr.floor(x)
            fx = x - i0
            offsets = [(tab["point"][k], f64(getattr(self, k))) for _, k in tables[1:]]

            def combine(lookup):
                v = lookup(tables[0][0])
                for (table, _), (p0, p) in zip(tables[1:], offsets):
                    v = v + (p - p0) * lookup(table)
                return v

            out = []
            if spectral:
                for j in range(len(si.wavelengths)):
                    y = dr.clip((f64(si.wavelengths[j]) - lam_grid[0]) / TAU_STEP, 0.0, width - 1 - 1e-9)
                    j0 = dr.floor(y)
                    fy = y - j0
                    base = i0 * width + j0
                    corners = [(di * width + dj, wi_ * wj) for di, wi_ in ((0, 1.0 - fx), (1, fx))
                               for dj, wj in ((0, 1.0 - fy), (1, fy))]
                    out.append(combine(lambda t: sum((w * _gather(t, base + o) for o, w in corners), 0.0)))
            else:
                for k in range(width):
                    base = i0 * width + k
                    out.append(combine(lambda t: (1.0 - fx) * _gather(t, base) + fx * _gather(t, base + width)))
            return out

        def _point(self, si):
            return f64(self.d1), f64(self.d2)

        def _kernel(self, lam, s2, side, point):
            d1, d2 = point
            n2 = complex(self.n2.constant)
            eps2 = optics.Complex(n2.real, n2.imag)
            n0 = self.n_incident
            real = (True, self.n1 >= n0, n2.imag == 0 and n2.real >= n0, self.n1 >= n0)
            eps2 = eps2 * eps2 if n2.imag else optics.Complex(n2.real ** 2, 0.0)
            return optics.bragg_reflectance(lam, s2, optics.Complex(n0 ** 2), optics.Complex(self.n1 ** 2),
                                            eps2, optics.Complex(self.n1 ** 2), d1, d2, self.cells, real), None

        def _torch(self, lam, c, side):
            from ..optics import bragg_reflectance

            d1 = float(self.d1[0] if jit else self.d1)
            d2 = float(self.d2[0] if jit else self.d2)
            return bragg_reflectance(lam, c, self.n1, complex(self.n2.constant), d1, d2, self.cells,
                                     n_incident=self.n_incident), None

        def _traverse(self, callback):
            flag = mi.ParamFlags.Differentiable if spectral else mi.ParamFlags.NonDifferentiable
            callback.put("d1", self.d1, flag)
            callback.put("d2", self.d2, flag)

        def _describe(self):
            d1 = float(self.d1[0] if jit else self.d1)
            d2 = float(self.d2[0] if jit else self.d2)
            return (f"n1={self.n1:g}, n2={self.n2.describe()}, d1={d1:g} nm, d2={d2:g} nm, cells={self.cells}, "
                    f"n_incident={self.n_incident:g}, base_albedo={self.base_albedo:g}")

    return Bragg
