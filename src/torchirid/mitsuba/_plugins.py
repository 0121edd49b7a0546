r"""The three BSDF plugins, defined for the Mitsuba variant that is active when
:func:`torchirid.mitsuba.register` runs (a Python BSDF class belongs to the variant it was
defined in).

Every plugin is a structure (film, stack or Bragg mirror) that gives a reflectance
:math:`R(\lambda, \cos\theta)` — and for a smooth structure over a transparent base a
transmittance :math:`T` — and one of two geometries:

* **smooth** (no ``alpha``): a Dirac delta in the mirror direction of weight :math:`R`;
  over a transparent base (real index, lossless) also a delta in the refracted direction of
  weight :math:`T` (straight through for a free-standing film, ``n_substrate = n_incident``:
  a soap bubble). Two-sided when it transmits (light from inside sees the stack reversed),
  front-side only otherwise.
* **rough** (``alpha`` > 0): the GGX microfacet BRDF with the structure's reflectance at the
  microfacet, :math:`f_r = D(\mathbf h)\,G_1(\mathbf i)\,G_1(\mathbf o)\,R(\lambda,
  \mathbf i\cdot\mathbf h)/(4\cos\theta_i\cos\theta_o)` — :func:`torchirid.microfacet.microfacet_brdf`
  with the separable Smith masking of Fourneau et al. eq. 19 (Mitsuba's own GGX: the same
  :math:`D` and :math:`G_1`). Reflection only: light transmitted into the base is absorbed.
  Sampled with Mitsuba's visible-normal sampling; the weight is ``eval / pdf``.

``torchirid_bragg`` with ``alpha`` is Fourneau et al.'s single-reflection model of one rough
Bragg layer (eq. 34): the microfacet lobe of the mirrors in the host ``n1``, a Lambertian base
``base_albedo`` seen through the layer's integrated transmissivity :math:`\tau` (eq. 28, the
library's :func:`~torchirid.layered.transmissivity_lut`, tabulated here in θ and λ) and, when
the host is not air, the smooth air | ``n1`` coating (a delta of weight :math:`F`, the
refraction of both directions and :math:`T_c(i)T_c(o)/n_1^2`).

Two evaluators compute the structure's :math:`R`, :math:`T` (``evaluator`` parameter):
``"drjit"`` (default) in Dr.Jit float64 arithmetic (:mod:`torchirid.mitsuba._optics`): the
kernel is traced into Mitsuba's own, runs at the speed of its BSDFs and is differentiable by
Dr.Jit; ``"torch"`` calls the library (``multilayer`` for films and stacks, ``bragg_reflectance``)
through ``dr.wrap`` — the exact reference, for tests and reference
renders (needs ``dr.JitFlag.SymbolicLoops`` and ``SymbolicCalls`` off in the JIT variants,
which ``torchirid.mitsuba.scenes.render(..., exact=True)`` sets). The Bragg plugin and its
tables are in :mod:`torchirid.mitsuba._bragg`; reading the properties in ``_properties``.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import torch

from . import _optics as optics
from ._properties import (_choice, _float_arg, _index_arg, _list_arg, _number_or_name, _real_constant, _warn_symbolic,
                          read_design)
from ._spectra import RGB_NODES, Index, rgb_weights


EVALUATORS = ("drjit", "torch")


def define(mi, dr):
    """The plugin classes for the active variant: ``{plugin name: class}``."""
    jit = dr.is_jit_v(mi.Float)
    spectral = mi.is_spectral
    F64 = mi.Float64 if jit else float
    # films and stacks: roots and phases in float64, the recursion in float32 (the JIT variants;
    # Python floats are doubles in the scalar ones). Bragg mirrors stay float64 throughout.
    NARROW = mi.Float32 if jit else None

    def f64(x):
        return F64(x) if jit else float(x)

    def to_float(x):
        return mi.Float(x) if jit else float(x)

    def mask(x):
        """A mask argument as the variant's mask (scalar variants may pass an int)."""
        return x if jit else bool(x)

    class _Plugin(mi.BSDF):
        """What every plugin shares: the geometry (smooth or GGX-rough), the channels, the two
        evaluators. A subclass defines ``_read(props)``, ``_point(si)`` (its per-point data),
        ``_kernel(lam, s2, side, point)`` → ``(R, T or None)`` in Dr.Jit, ``_torch(lam, cos,
        side)`` → ``(R, T or None)`` and, if light reaches the base side, ``_n_exit()``."""

        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            self.n_incident = _float_arg(props, "n_incident", 1.0, positive=True)
            self.evaluator = _choice(props, "evaluator", EVALUATORS, "drjit")
            alpha = props.get("alpha", 0.0)
            self.rough = float(alpha) > 0
            self.alpha = mi.Float(float(alpha)) if jit else float(alpha)
            self._read(props)
            self.transmits = (not self.rough) and self._transparent_base()
            self._set_flags()

        #: a Lambertian base under the structure, seen through τ (the rough Bragg layer)
        base_albedo = 0.0

        # -- structure hooks ------------------------------------------------------------
        def _transparent_base(self) -> bool:
            return False

        @property
        def coated(self) -> bool:
            """A smooth air | ``n_incident`` coating over a rough structure (the rough Bragg layer's host)."""
            return False

        def _point(self, si):
            """What a structure needs at this point, for every channel (its thicknesses)."""
            return None

        def _set_flags(self):
            if self.rough:
                lobe = mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.FrontSide
                if self.base_albedo > 0:
                    lobe = lobe | mi.BSDFFlags.DiffuseReflection
                components = [lobe]
                flags = lobe
                if self.coated:  # the coating's specular delta (assigned whole: m_components is a copy)
                    components.append(mi.BSDFFlags.DeltaReflection | mi.BSDFFlags.FrontSide)
                    flags = flags | components[1]
                self.m_components = components
            elif self.transmits:
                both = mi.BSDFFlags.FrontSide | mi.BSDFFlags.BackSide
                self.m_components = [mi.BSDFFlags.DeltaReflection | both, mi.BSDFFlags.DeltaTransmission | both]
                flags = self.m_components[0] | self.m_components[1]
            else:
                flags = mi.BSDFFlags.DeltaReflection | mi.BSDFFlags.FrontSide
                self.m_components = [flags]
            self.m_flags = flags

        # -- channels -------------------------------------------------------------------
        def _values(self, si, cos_i, side):
            """``(R, T)`` spectra at the interaction's wavelengths (spectral variants) or in
            linear sRGB (RGB variants), ``cos_i`` the cosine of incidence on the stack (> 0),
            ``side`` 0 (from the incident medium) or 1 (from the base)."""
            if spectral:
                lams = [si.wavelengths[j] for j in range(len(si.wavelengths))]
            else:
                lams = list(RGB_NODES)
            if self.evaluator == "torch":
                rs, ts = self._torch_values(lams, cos_i, side)
            else:
                n0 = self.n_incident if side == 0 else self._n_exit()
                c = f64(cos_i)
                s2 = (n0 * n0) * (1.0 - c * c)
                point = self._point(si)  # once per evaluation, not per channel
                rs, ts = [], []
                for lam in lams:
                    r, t = self._kernel(f64(lam) if spectral else lam, s2, side, point)
                    rs.append(r)
                    ts.append(t)
            return self._spectrum(rs), (self._spectrum(ts) if ts[0] is not None else None)

        def _spectrum(self, values):
            if spectral:
                return mi.Spectrum(*[to_float(v) for v in values])
            w = rgb_weights()
            out = []
            for c in range(3):
                acc = 0.0
                for k, v in enumerate(values):
                    acc = acc + float(w[c, k]) * v
                out.append(to_float(acc))
            return mi.Spectrum(*out)

        def _torch_values(self, lams, cos_i, side):
            """The library's values for every channel (the exact path)."""
            if not jit:
                lam = torch.tensor([float(x) for x in lams], dtype=torch.float64)
                c = torch.tensor([float(cos_i)], dtype=torch.float64)
                r, t = self._torch(lam[None, :], c[:, None], side)
                rs = [float(x) for x in r[0]]
                ts = [float(x) for x in t[0]] if t is not None else [None] * len(rs)
                return rs, ts
            nl = len(lams)
            transmits = self.transmits
            if dr.flag(dr.JitFlag.SymbolicScope):
                # torch needs evaluated arrays. A symbolic call traces every live instance of a
                # BSDF, also those of other scenes: give zeros here, warn once for the user
                # whose scene this is (renders with evaluator="torch" need SymbolicLoops and
                # SymbolicCalls off; torchirid.mitsuba's render helpers set them).
                _warn_symbolic()
                zero = dr.zeros(mi.Float64, dr.width(cos_i))
                return [zero] * nl, ([zero] * nl if transmits else [None] * nl)

            @dr.wrap(source="drjit", target="torch")
            def run(c, *lam_cols):
                if spectral:
                    lam = torch.stack(lam_cols, -1)
                else:
                    lam = torch.tensor(lams, dtype=torch.float64)[None, :]
                r, t = self._torch(lam, c[:, None], side)
                cols = [r[:, j].contiguous() for j in range(nl)]
                if transmits:
                    cols += [t[:, j].contiguous() for j in range(nl)]
                return tuple(cols)

            width = dr.width(cos_i)
            c = dr.detach(mi.Float64(cos_i))
            lam_cols = [dr.detach(mi.Float64(x)) for x in lams] if spectral else []
            if width > 1:
                lam_cols = [x + dr.zeros(mi.Float64, width) for x in lam_cols]
            out = run(c, *lam_cols)
            rs = list(out[:nl])
            ts = list(out[nl:]) if transmits else [None] * nl
            return rs, ts

        # -- BSDF interface -------------------------------------------------------------
        def _microfacets(self):
            return mi.MicrofacetDistribution(mi.MicrofacetType.GGX, self.alpha, True)

        def sample(self, ctx, si, sample1, sample2, active=True):
            if self.rough:
                return self._sample_rough(ctx, si, sample1, sample2, active)
            return self._sample_smooth(ctx, si, sample1, sample2, active)

        def eval(self, ctx, si, wo, active=True):
            if not self.rough:
                return dr.zeros(mi.Spectrum)
            return self._lobe(ctx, si, wo, active, pdf=False)[0]

        def pdf(self, ctx, si, wo, active=True):
            if not self.rough:
                return dr.zeros(mi.Float)
            return self._lobe(ctx, si, wo, active, value=False)[1]

        def eval_pdf(self, ctx, si, wo, active=True):
            if not self.rough:
                return dr.zeros(mi.Spectrum), dr.zeros(mi.Float)
            return self._lobe(ctx, si, wo, active)

        # smooth -------------------------------------------------------------------------
        def _sample_smooth(self, ctx, si, sample1, sample2, active):
            active = mask(active)
            bs = dr.zeros(mi.BSDFSample3f)
            cos_i = mi.Frame3f.cos_theta(si.wi)
            if not self.transmits:
                active = active & (cos_i > 0) & ctx.is_enabled(mi.BSDFFlags.DeltaReflection, 0)
                r, _ = self._values(si, dr.maximum(cos_i, 1e-12), 0)
                bs.wo = mi.reflect(si.wi)
                bs.pdf = 1.0
                bs.eta = 1.0
                bs.sampled_component = 0
                bs.sampled_type = mi.UInt32(+mi.BSDFFlags.DeltaReflection)
                return bs, dr.select(active, r, 0.0)
            # a transparent base: reflect or transmit, both sides
            front = cos_i > 0
            if jit:
                r_f, t_f = self._values(si, dr.maximum(dr.abs(cos_i), 1e-12), 0)
                r_b, t_b = self._values(si, dr.maximum(dr.abs(cos_i), 1e-12), 1)
                r = dr.select(front, r_f, r_b)
                t = dr.select(front, t_f, t_b)
            else:
                r, t = self._values(si, max(abs(cos_i), 1e-12), 0 if front else 1)
            has_r = ctx.is_enabled(mi.BSDFFlags.DeltaReflection, 0)
            has_t = ctx.is_enabled(mi.BSDFFlags.DeltaTransmission, 1)
            pr = dr.mean(r)  # over the channels: one choice for every wavelength of the sample
            pt = dr.mean(t)
            p_reflect = dr.clip(pr / dr.maximum(pr + pt, 1e-30), 0.0, 1.0)
            if has_r and not has_t:
                p_reflect = dr.ones(mi.Float) if jit else 1.0
            elif has_t and not has_r:
                p_reflect = dr.zeros(mi.Float) if jit else 0.0
            choose_r = sample1 <= p_reflect
            # the refracted direction: exit medium over incident medium on this side
            n_top, n_bot = self.n_incident, self._n_exit()
            eta_it = dr.select(front, n_bot / n_top, n_top / n_bot)  # n_t / n_i
            sin2_t = (1.0 - cos_i * cos_i) / (eta_it * eta_it)
            cos_t = dr.safe_sqrt(1.0 - sin2_t)
            cos_t = dr.select(front, -cos_t, cos_t)
            wo_t = mi.refract(si.wi, cos_t, 1.0 / eta_it)
            bs.wo = dr.select(choose_r, mi.reflect(si.wi), wo_t)
            bs.pdf = dr.select(choose_r, p_reflect, 1.0 - p_reflect)
            bs.eta = dr.select(choose_r, 1.0, eta_it)
            bs.sampled_component = dr.select(choose_r, mi.UInt32(0), mi.UInt32(1))
            bs.sampled_type = dr.select(choose_r, mi.UInt32(+mi.BSDFFlags.DeltaReflection),
                                        mi.UInt32(+mi.BSDFFlags.DeltaTransmission))
            # radiance is compressed by (n_i / n_t)² on the way through (Mitsuba's dielectric)
            scale = 1.0 / (eta_it * eta_it) if ctx.mode == mi.TransportMode.Radiance else 1.0
            weight = dr.select(choose_r, r / dr.maximum(bs.pdf, 1e-30), t * scale / dr.maximum(bs.pdf, 1e-30))
            active = active & (bs.pdf > 0) & (has_r | has_t)
            return bs, dr.select(active, weight, 0.0)

        # rough: the GGX lobe of the structure in its host, a base seen through τ, a coating --
        # Films and stacks: no coating, no base (the lobe alone, in the incident medium). The
        # rough Bragg layer (Fourneau et al. eq. 34, one layer) adds both.
        def _coat_reflectance(self, cos):
            """Unpolarized Fresnel reflectance of the smooth air | n_incident coating."""
            return mi.fresnel(cos, self.n_incident)[0]

        def _into_host(self, w):
            """``(w', ok)``: ``w`` refracted into the host under the coating (Snell: tangent / n)."""
            if not self.coated:
                return w, True
            n = self.n_incident
            x, y = w.x / n, w.y / n
            z2 = 1.0 - x * x - y * y
            return mi.Vector3f(x, y, dr.safe_sqrt(z2)), z2 > 0

        def _out_of_host(self, w):
            if not self.coated:
                return w, True
            n = self.n_incident
            x, y = w.x * n, w.y * n
            z2 = 1.0 - x * x - y * y
            # trapped by total internal reflection (not ok): a unit vector all the same
            return dr.normalize(mi.Vector3f(x, y, dr.safe_sqrt(z2))), (z2 > 0) & (w.z > 0)

        def _lobe_probability(self):
            return 0.5 if self.base_albedo > 0 else 1.0

        def _coat_probability(self, ctx, cos_i):
            if not self.coated:
                return 0.0
            has_delta = ctx.is_enabled(mi.BSDFFlags.DeltaReflection, 1)
            has_lobe = ctx.is_enabled(mi.BSDFFlags.GlossyReflection, 0)
            if has_delta and not has_lobe:
                return 1.0
            if has_lobe and not has_delta:
                return 0.0
            return self._coat_reflectance(cos_i)

        def _lobe(self, ctx, si, wo, active, value=True, pdf=True):
            """``(eval, pdf)`` of the rough component, one geometry for both (``None`` where not asked)."""
            active = mask(active)
            cos_i = mi.Frame3f.cos_theta(si.wi)
            cos_o = mi.Frame3f.cos_theta(wo)
            active = active & (cos_i > 0) & (cos_o > 0) & ctx.is_enabled(mi.BSDFFlags.GlossyReflection, 0)
            wi_h, ok_i = self._into_host(si.wi)
            wo_h, ok_o = self._into_host(wo)
            active = active & ok_i & ok_o
            h = dr.normalize(wi_h + wo_h)
            distr = self._microfacets()
            f = p = None
            if value:
                zi, zo = dr.maximum(wi_h.z, 1e-12), dr.maximum(wo_h.z, 1e-12)
                shading = distr.eval(h) * distr.G(wi_h, wo_h, h) / (4.0 * zi * zo)
                r, _ = self._values(si, dr.clip(dr.dot(wi_h, h), 1e-12, 1.0), 0)
                f = r * shading
                if self.base_albedo > 0:
                    ti, to = self._tau_values(si, zi), self._tau_values(si, zo)
                    f = f + (self.base_albedo / math.pi) * self._spectrum([a * b for a, b in zip(ti, to)])
                if self.coated:
                    n = self.n_incident
                    f = f * ((1.0 - self._coat_reflectance(cos_i)) * (1.0 - self._coat_reflectance(cos_o)) / (n * n))
                f = dr.select(active, f * cos_o, 0.0)
            if pdf:
                q = self._lobe_probability()
                p = q * distr.pdf(wi_h, h) / (4.0 * dr.abs(dr.dot(wo_h, h)))
                if q < 1.0:
                    p = p + (1.0 - q) * dr.maximum(wo_h.z, 0.0) / math.pi
                if self.coated:  # solid angles refract: n² cos θ' dω' = cos θ dω
                    p = p * cos_o / (self.n_incident ** 2 * dr.maximum(wo_h.z, 1e-12))
                    p = p * (1.0 - self._coat_probability(ctx, cos_i))
                p = dr.select(active, p, 0.0)
            return f, p

        def _sample_rough(self, ctx, si, sample1, sample2, active):
            active = mask(active)
            bs = dr.zeros(mi.BSDFSample3f)
            cos_i = mi.Frame3f.cos_theta(si.wi)
            active = active & (cos_i > 0)
            p_coat = self._coat_probability(ctx, cos_i)
            coat = sample1 < p_coat
            u = (sample1 - p_coat) / dr.maximum(1.0 - p_coat, 1e-12)  # reuse the uniform below the coat
            wi_h, _ = self._into_host(si.wi)
            q = self._lobe_probability()
            m, _ = self._microfacets().sample(wi_h, sample2)
            wo_h = mi.reflect(wi_h, m)
            if q < 1.0:
                wo_h = dr.select(u < q, wo_h, mi.warp.square_to_cosine_hemisphere(sample2))
            wo, ok = self._out_of_host(wo_h)
            ok = ok & dr.isfinite(wo.z)  # Mitsuba's VNDF sampler gives NaN at u = (·, 0) and normal incidence
            bs.wo = dr.select(coat, mi.reflect(si.wi), dr.select(ok, wo, mi.Vector3f(0.0, 0.0, 1.0)))
            bs.eta = 1.0
            bs.sampled_component = dr.select(coat, mi.UInt32(1), mi.UInt32(0))
            bs.sampled_type = dr.select(coat, mi.UInt32(+mi.BSDFFlags.DeltaReflection),
                                        mi.UInt32(+mi.BSDFFlags.GlossyReflection))
            lobe_active = active & ~coat & ok & (mi.Frame3f.cos_theta(bs.wo) > 0)
            value, pdf = self._lobe(ctx, si, bs.wo, lobe_active)
            weight = value / dr.maximum(pdf, 1e-30)
            if self.coated:
                weight = dr.select(coat, self._coat_reflectance(cos_i) / dr.maximum(p_coat, 1e-30), weight)
                pdf = dr.select(coat, p_coat, pdf)
            bs.pdf = pdf
            return bs, dr.select(active & (coat | (lobe_active & (pdf > 0))), weight, 0.0)

        # parameters ---------------------------------------------------------------------
        def traverse(self, callback):
            if self.rough:
                callback.put("alpha", self.alpha, mi.ParamFlags.Differentiable)
            self._traverse(callback)

        def _traverse(self, callback):
            pass

        def parameters_changed(self, keys):
            pass

        def to_string(self):
            return f"{type(self).__name__}[{self._describe()}, {'alpha=' + str(self.alpha) if self.rough else 'smooth'}]"

    # ----------------------------------------------------------------------------------
    class _Stack(_Plugin):
        """Films on a base: ``self.films`` (indices, top first), ``self.n_substrate`` and the
        thicknesses at a point (``_point``), by the Airy recursion (:func:`~._optics.stack_amplitudes`;
        the library's :func:`~torchirid.optics.multilayer` on the exact path)."""

        def __init__(self, props):
            _Plugin.__init__(self, props)
            # which media have a real root q at every angle, seen from either side: fixed by the indices
            self._real = [_real_roots(self.films + [self.n_substrate], self.n_incident, side) for side in (0, 1)]

        def _transparent_base(self):
            return (self.n_substrate.material is None and self.n_substrate.lossless
                    and all(film.lossless for film in self.films))

        def _n_exit(self):
            return self.n_substrate.constant.real

        def _kernel(self, lam, s2, side, d):
            looked_up = {}  # a material repeated in the stack is looked up once per wavelength
            for x in self.films:
                if id(x) not in looked_up:
                    looked_up[id(x)] = x.permittivity(lam, dr, F64)
            eps = ([optics.Complex(self.n_incident ** 2)] + [looked_up[id(x)] for x in self.films]
                   + [self.n_substrate.permittivity(lam, dr, F64)])
            if side:
                eps, d = eps[::-1], d[::-1]
            if self.transmits:
                return optics.stack_reflectance_transmittance(lam, s2, eps, d, self._real[side], NARROW)
            return optics.stack_reflectance(lam, s2, eps, d, self._real[side], NARROW), None

        def _torch(self, lam, c, side):
            from ..optics import multilayer

            shape = torch.broadcast_shapes(lam.shape, c.shape)
            lam_b = lam.expand(shape)
            n = torch.stack([torch.full(shape, self.n_incident, dtype=torch.complex128)]
                            + [x.torch(lam_b) for x in self.films] + [self.n_substrate.torch(lam_b)], -1)
            d = torch.tensor(self._torch_thicknesses(), dtype=torch.float64).expand(*shape, len(self.films))
            if side:
                n, d = n.flip(-1), d.flip(-1)
            r, t = multilayer(lam_b, c.expand(shape), n, d)
            return r, (t if self.transmits else None)

    # ----------------------------------------------------------------------------------
    class ThinFilm(_Stack):
        """``torchirid_thin_film``: a film on a base in a medium (thin_film_reflectance)."""

        def _read(self, props):
            self.n_film = _index_arg(props, "n_film", required=True)
            self.films = [self.n_film]
            self.n_substrate = _index_arg(props, "n_substrate", 1.5)
            if "thickness" in props and props.type("thickness") == mi.Properties.Type.Object:
                self.thickness_texture = props.get("thickness")
                self.thickness = None
                if self.evaluator == "torch":
                    raise ValueError("evaluator='torch' takes a constant thickness, not a texture")
            else:
                self.thickness_texture = None
                d = _float_arg(props, "thickness", low=0.0)
                self.thickness = mi.Float(d) if jit else d

        def _point(self, si):
            if self.thickness_texture is not None:
                return [f64(self.thickness_texture.eval_1(si))]
            return [f64(self.thickness)]

        def _torch_thicknesses(self):
            return [float(self.thickness[0] if jit else self.thickness)]

        def _traverse(self, callback):
            if self.thickness is not None:
                callback.put("thickness", self.thickness, mi.ParamFlags.Differentiable)
            else:
                callback.put("thickness", self.thickness_texture, mi.ParamFlags.Differentiable)

        def _describe(self):
            d = "texture" if self.thickness is None else f"{self._torch_thicknesses()[0]:g} nm"
            return (f"n_film={self.n_film.describe()}, thickness={d}, n_substrate={self.n_substrate.describe()}, "
                    f"n_incident={self.n_incident:g}")

    # ----------------------------------------------------------------------------------
    class Multilayer(_Stack):
        """``torchirid_multilayer``: any stack (multilayer), or a design file."""

        def _read(self, props):
            design = props.get("design", None)
            if design is not None:
                materials, thicknesses, n_inc, n_sub = read_design(design)
                if "n_incident" not in props:
                    self.n_incident = _real_constant(Index(_number_or_name(n_inc), name="incident"), "incident")
                substrate = props.get("n_substrate", n_sub)
            else:
                materials = _list_arg(props, "materials")
                thicknesses = [float(x) for x in _list_arg(props, "thicknesses")]
                substrate = props.get("n_substrate", 1.5)
                if len(materials) != len(thicknesses):
                    raise ValueError(f"materials has {len(materials)} entries and thicknesses {len(thicknesses)}")
            if not materials:
                raise ValueError("the stack needs at least one layer")
            distinct = {}  # one Index (one table, one lookup per wavelength) per distinct material
            self.films = [distinct.setdefault(repr(_number_or_name(m)), Index(_number_or_name(m), name=f"materials[{i}]"))
                          for i, m in enumerate(materials)]
            if any(not (math.isfinite(t) and t >= 0) for t in thicknesses):
                raise ValueError(f"thicknesses must be finite and >= 0 nm, got {thicknesses}")
            if any(0 < t < 1e-3 for t in thicknesses):
                raise ValueError(f"thicknesses {thicknesses} nm look like metres: give nanometres")
            self.n_substrate = Index(_number_or_name(substrate), props.get("k_substrate", 0.0), name="n_substrate")
            self.thicknesses = mi.Float(thicknesses) if jit else list(thicknesses)

        def _point(self, si):
            if not jit:
                return list(self.thicknesses)
            d = mi.Float64(self.thicknesses)
            return [dr.gather(mi.Float64, d, j) for j in range(len(self.films))]

        def _torch_thicknesses(self):
            return self.thicknesses.numpy().tolist() if jit else list(self.thicknesses)

        def _traverse(self, callback):
            if jit:
                callback.put("thicknesses", self.thicknesses, mi.ParamFlags.Differentiable)

        def _describe(self):
            layers = ", ".join(f"{x.describe()}:{t:g}" for x, t in zip(self.films, self._torch_thicknesses()))
            return f"[{layers}] on {self.n_substrate.describe()}, n_incident={self.n_incident:g}"

    from ._bragg import define as define_bragg

    variant = SimpleNamespace(mi=mi, dr=dr, jit=jit, spectral=spectral, f64=f64, to_float=to_float)
    return {"torchirid_thin_film": ThinFilm, "torchirid_multilayer": Multilayer,
            "torchirid_bragg": define_bragg(variant, _Plugin)}


def _real_roots(below, n_incident: float, side: int) -> list:
    """Which media of ``[incident] + below`` (from the incident side; ``side`` 1: the stack seen
    from its base, reversed) have a real root q at every angle: :func:`~._optics.real_root`."""
    media = [Index(n_incident)] + list(below)
    if side:
        media = media[::-1]
    n0 = media[0]
    n0 = n0.constant.real if n0.material is None else None
    if n0 is None:
        return [False] * len(media)
    return [True] + [m.real_root(n0) for m in media[1:]]
