r"""Position-free Monte Carlo reference for a layered rough Bragg structure (Fourneau et al. 2024 §4.2).

:func:`montecarlo_brdf` estimates the BRDF :math:`f_r(\mathbf i,\mathbf o)` of a
:class:`~torchirid.layered.LayeredBragg` at given pairs of directions, for all wavelengths at
once, with a standard error. It is the "reference simulation" of the paper's §4.2 (full
light transport between the layers) and, with ``single_reflection=True``, its "SR sim."
(only paths that reflect exactly once), which converges to the single-reflection BRDF of
eq. 34.

**Model.** From top to bottom: an optional smooth coating air | n1 (when ``n1 ≠ 1``), the
rough Bragg layers (GGX microfacets with the Yeh reflectance :math:`R_\lambda`, eq. 17;
ballistic transmission :math:`\tau(\theta)=\int T_\lambda F_\alpha\,d\theta_d`, eq. 28), and a
Lambertian base of albedo ρd. The host is lossless and non-dispersive, layers do not
interfere, polarization is not tracked between interfaces (unpolarized R, T and Fresnel).
A layer hit from below is the same layer with its normal flipped.

**Estimator.** Light enters along :math:`-\mathbf i'` (``i`` refracted into the host) with
weight :math:`T_c(\mathbf i)` (the coating's Fresnel transmittance). Every path carries a
spectral throughput β of shape ``(W,)`` (wavelength multiplexing: one geometric path for
all wavelengths). Next-event estimation: whenever the path travels **down** onto layer
``l`` (or the base), the way out towards ``o`` is added,

.. math::

    \beta\; f_{r,l}(-\mathbf d, \mathbf o')\,\prod_{k<l}\tau_k(\mathbf o')\;\frac{T_c(\mathbf o)}{n_1^2},

with :math:`f_{r,l}` eq. 17 (``ρd/π`` for the base). Every path to ``o`` ends with such a
vertex (only a layer hit from above or the base sends light up; a layer crossing and the
coating are deltas), so the sum over vertices is unbiased for the whole BRDF. The coating's
own specular reflection :math:`f_{r,0}` is a Dirac delta in the mirror direction and is not
part of the estimate (no finite value at a pair of directions). The factor
:math:`T_c(\mathbf i)T_c(\mathbf o)/n_1^2` is eq. 34's :math:`f_{t,0}(i)f_{t,0}(o)/n_1^2`:
radiance entering the host is multiplied by :math:`n_1^2 T_c`, leaving it by
:math:`T_c/n_1^2`, and the irradiance of a collimated beam by :math:`T_c` (power per area).

The path then continues by sampling the event at the layer it meets (incident direction
``d``, local frame flipped so that ``-d`` points up):

* ``transmission="filter"`` (the paper's optimized simulation): transmit with
  :math:`p_\mathrm{trans}=2\langle\tau\rangle_\lambda/(1+G_1)` (eq. 31, multiplexed), weight
  :math:`\tfrac{1+G_1}{2}\tau_\lambda/\langle\tau\rangle_\lambda` (eq. 33 = τ/p_trans); else
  reflect: sample ``m`` from the GGX visible normals of ``-d``, ``o = reflect(-d, m)``,
  weight :math:`R_\lambda(-\mathbf d\cdot\mathbf m)G_1(\mathbf o)/(1-p_\mathrm{trans})`
  (the path dies if ``o`` points through the layer). τ comes from the per-layer 1-D
  table of :func:`~torchirid.layered.transmission.transmissivity_lut` (the paper's
  optimized simulation does the same), also for the way out of the next-event estimate.
* ``transmission="microfacet"`` (independent of F_α): sample ``m`` first; reflect with
  probability :math:`P=\langle R\rangle_\lambda/(\langle R\rangle_\lambda+\langle T\rangle_\lambda)`
  (weight :math:`R_\lambda G_1(\mathbf o)/P`), else transmit ballistically with weight
  :math:`G_1(\mathbf d)T_\lambda(-\mathbf d\cdot\mathbf m)/(1-P)`. The way out of the
  next-event estimate is sampled the same way: one :math:`G_1(\mathbf o')T_k(\mathbf o'\cdot
  \mathbf m_k)`, :math:`\mathbf m_k` from the visible normals of ``o'``, per crossed layer
  instead of :math:`\tau_k(\mathbf o')`. This mode uses neither F_α nor any quadrature:
  it is the independent reference for eq. 28 and eq. 34. Both modes have the same
  expectation because :math:`\tau(\theta)=G_1(\theta)\,E_{\mathbf m\sim D_{\mathbf d}}[T_\lambda]`
  (eq. 22 with the visible-normal density :math:`D_{\mathbf d}=G_1|\mathbf d\cdot\mathbf m|D/\cos\theta`).

As in :mod:`~torchirid.layered.transmission`, the mirror's transmittance is
:math:`T_\lambda = 1 - R_\lambda` (exact for lossless layers; an absorbing ``n2`` is
treated the same way there and here).

**The Lambertian base.** Under the last layer, in the host, the base reflects the same
radiance into every upward direction, whatever the downward light,

.. math::

    L_\uparrow(\boldsymbol\omega) = \frac{\rho_d}{\pi}\,E,\qquad
    E = \int_{\Omega_\downarrow} L_\downarrow(\boldsymbol\omega')\,|\cos\theta'|\,d\omega'

(a BRDF :math:`\rho_d/\pi`). A path that reaches it with throughput β (travelling down
below the last layer) therefore

1. adds the base's next-event term :math:`\beta\,\frac{\rho_d}{\pi}\prod_{k=1}^{L}\tau_k(\mathbf o')
   \frac{T_c(\mathbf o)}{n_1^2}` — eq. 34's base term: straight out through every layer
   (eq. 28) and the coating (a reflection on the way out is another path's vertex);
2. continues upwards along a cosine-weighted direction, :math:`p(\boldsymbol\omega) =
   \cos\theta/\pi`, with throughput :math:`\beta\,\frac{\rho_d}{\pi}\cos\theta/p =
   \beta\rho_d` (the same for every direction and wavelength);
3. meets the layers from below: a layer seen from below is the same rough layer with its
   normal flipped (same host on both sides; a lossless mirror reflects the same from both
   sides), so it transmits ballistically (τ) or reflects back down (eq. 17) onto the layers
   below or the base, which sends it up again. At the top the path escapes (``n1 = 1``:
   already counted by next-event estimation) or the coating reflects it down with weight
   :math:`F(\theta', n_1\to 1)` (1 under total internal reflection; the transmitted part is
   counted by next-event estimation).

Summed over the bounces this is the base's geometric series :math:`B = \rho_d(E_0 + R_d B)`,
with :math:`E_0` the irradiance that reaches the base straight from the light and
:math:`R_d` the fraction of the base's upward light that the structure returns to it
(``single_reflection_brdf(..., base_interreflection=True)`` sums this series in closed form);
the estimator also has every path between the layers. A layer lit from a host
``n_incident ≠ n1`` (the jewel-beetle presets: mirrors in air) is treated alike from below:
the host is taken to be the same on both sides (the paper's assumption, §4.1 and §5).

**Energy.** With lossless mirrors (:math:`T_\lambda = 1 - R_\lambda`) and :math:`\rho_d = 1`
nothing is absorbed but by the microfacet model itself: a layer event keeps
:math:`E_{\mathbf m}[R\,G_1(\mathbf o)] + G_1(\mathbf d)\,E_{\mathbf m}[T] \le 1` of the
light, the loss :math:`A = 1 - G_1` of eq. 30 (no scattering between the microfacets of a
layer): about 1 % per crossing of cosine-distributed light at α = 0.1, 0.08 % at α = 0.02.
tests/layered/test_montecarlo.py integrates the estimate over ``wo`` (white furnace,
:math:`\int f_r\cos\theta_o\,d\omega_o` by multiple importance sampling) and checks it
against an analog walk that counts the light leaving the structure, and that it is 1 within
its standard error at α = 0.02.

Russian roulette (survival ``min(1, max_λ β)``) starts after ``rr_depth`` events;
``max_depth`` truncates.

``single_reflection=True`` keeps only the paths with exactly one reflection: next-event
estimation on the way down, transmission sampled as above, and any reflection ends the
path. Its expectation is eq. 34 (including the base term ``ρd/π``).

Everything is batched in torch: the paths of a chunk are tensors, the only Python loops run
over the bounce depth and the layers; dead paths are compacted away each bounce. A seeded
:class:`torch.Generator` drives all random numbers: the same arguments and ``seed`` give an
identical result.
"""

from __future__ import annotations

import math
from typing import Callable

import torch

from .. import _autograd, _checks
from .._cache import cache_dict
from . import _geometry
from ..microfacet.brdf import microfacet_brdf
from ..microfacet.ggx import reflect_kernel, sample_ggx_vndf, smith_g1_kernel
from .structure import LayeredBragg, RoughBraggLayer
from .transmission import (
    DEFAULT_ANGLES,
    DEFAULT_THETA_D_CELLS,
    probability_kernel,
    transmissivity_lut,
    weight_kernel,
)

__all__ = ["montecarlo_brdf"]

# the bodies of the GGX functions: the transport hands them checked tensors of the call's dtype
# (directions it built, the layer's α converted once), so nothing is checked again per bounce
_brdf = microfacet_brdf.__wrapped__
_vndf = sample_ggx_vndf.__wrapped__

#: registry of the transmission sampling strategies of :func:`montecarlo_brdf`
TRANSMISSION_MODES = ("filter", "microfacet")


# ----------------------------------------------------------------------------------------
# coating geometry (a smooth air | n1 interface; shared parts in _geometry)
# ----------------------------------------------------------------------------------------
def _coating_r_inside(cos_inner: torch.Tensor, n1: float) -> torch.Tensor:
    """Unpolarized Fresnel reflectance of the coating seen from the host, F(θ', n1 → 1)
    (1 beyond the critical angle: total internal reflection)."""
    return _geometry.fresnel(cos_inner.clamp(0.0, 1.0), n1, 1.0)


# ----------------------------------------------------------------------------------------
# per-layer optics
# ----------------------------------------------------------------------------------------
#: τ tables of recent calls, keyed by (layer, wavelengths, dtype, device, angles, cells):
#: repeated calls on the same structure (image loops, tests) skip the table build
_TABLES: dict = cache_dict()
_TABLES_MAX = 32


class _Layer:
    """Per-layer optics of one call: R_λ, T_λ = 1 − R_λ (as eq. 28 in
    :mod:`~torchirid.layered.transmission`) and the τ table (eq. 28); ``alpha``: the layer's α
    as a tensor of the call's dtype."""

    def __init__(self, layer: RoughBraggLayer, lam: torch.Tensor, tau_angles: int, tau_cells: int):
        self.layer = layer
        self.alpha = _geometry.layer_alpha(layer, lam.dtype, lam.device)
        self.lam = lam
        self.tau_kw = {"angles": tau_angles, "theta_d_cells": tau_cells}
        self._key = (layer, tuple(lam.tolist()), lam.dtype, str(lam.device), tau_angles, tau_cells)

    def reflectance(self, cos_d: torch.Tensor) -> torch.Tensor:
        """R_λ at host cosines ``cos_d`` (*) → (*, W)."""
        return self.layer._reflectance_kernel(self.lam, cos_d.clamp(0.0, 1.0).unsqueeze(-1))

    def transmittance(self, cos_d: torch.Tensor) -> torch.Tensor:
        """T_λ = 1 − R_λ of the Bragg mirror (the host is lossless) at ``cos_d`` (*) → (*, W)."""
        return 1.0 - self.reflectance(cos_d)

    def tau(self, cos_theta: torch.Tensor) -> torch.Tensor:
        """Integrated transmissivity τ (eq. 28) at host cosines (n,) → (n, W), interpolated in
        :func:`~torchirid.layered.transmission.transmissivity_lut` (product integration over
        θd: robust to the fringes of R; nodes every 0.25° plus extra ones near grazing)."""
        lut = _TABLES.get(self._key)
        if lut is None:
            # (outside inference mode: a table cached by a call in inference mode must serve autograd calls)
            lut = _autograd.normal_tensors(transmissivity_lut.__wrapped__)(self.lam, self.layer, **self.tau_kw)
            while len(_TABLES) >= _TABLES_MAX:
                _TABLES.pop(next(iter(_TABLES)))
            _TABLES[self._key] = lut
        return lut(cos_theta.clamp(0.0, 1.0))


# ----------------------------------------------------------------------------------------
# the transport
# ----------------------------------------------------------------------------------------
class _Transport:
    """One call's precomputation (per pair: refracted directions, entry weight, the way out
    of every layer towards ``o``) and the batched path tracer."""

    def __init__(self, structure: LayeredBragg, wi, wo, lam, *, single, mode, tau_angles, tau_cells,
                 max_depth, rr_depth, multiple=False):
        self.n1 = float(structure.n_coating)
        self.rho = float(structure.base_albedo)
        self.layers = [_Layer(layer, lam, tau_angles, tau_cells) for layer in structure.layers]
        self.L = len(self.layers)
        self.lam = lam
        self.W = lam.numel()
        self.single = single
        self.multiple = multiple
        self.mode = mode
        self.max_depth = max_depth
        self.rr_depth = rr_depth
        dtype, device = lam.dtype, lam.device
        self.dtype, self.device = dtype, device

        wi_in, ok_i = _geometry.refract_in(wi, self.n1)
        wo_in, ok_o = _geometry.refract_in(wo, self.n1)
        self.d0 = -wi_in  # light travels down along −i'
        self.beta0 = torch.where(ok_i, _geometry.coating_transmittance(wi[:, 2], self.n1), torch.zeros_like(wi[:, 2]))
        self.wo_in = wo_in
        exit_ = torch.where(ok_o, _geometry.coating_transmittance(wo[:, 2], self.n1), torch.zeros_like(wo[:, 2])) / (self.n1 * self.n1)
        # chain[p, l]: the way out from layer l (l = L: the base) towards o, T_c(o)/n1² times
        #   "filter":     Π_{k<l} τ_k(o')            (eq. 28, deterministic)
        #   "microfacet": Π_{k<l} G1_k(o')           (× T_k(o'·m_k), m_k ~ VNDF, sampled at each NEE)
        chain = [exit_.unsqueeze(-1).expand(-1, self.W)]
        for l, lay in enumerate(self.layers):
            if l == self.L - 1 and self.rho == 0:  # nothing comes back from a black base
                chain.append(torch.zeros_like(chain[-1]))
            elif mode == "filter":
                chain.append(chain[-1] * lay.tau(wo_in[:, 2]))
            else:
                chain.append(chain[-1] * smith_g1_kernel(wo_in[:, 2].abs(), lay.alpha).unsqueeze(-1))
        self.chain = torch.stack(chain, 1)  # (P, L+1, W)

    # -- one chunk of paths ---------------------------------------------------------------
    def trace(self, pair: torch.Tensor, gen: torch.Generator) -> torch.Tensor:
        """Trace one path per entry of ``pair`` (indices of the direction pairs); returns the
        per-path estimates (n, W)."""
        n0 = pair.numel()
        W, L = self.W, self.L
        dtype, device = self.dtype, self.device
        acc = torch.zeros(n0, W, dtype=dtype, device=device)
        beta = self.beta0[pair].unsqueeze(-1).expand(n0, W).clone()
        d = self.d0[pair].clone()
        gap = torch.zeros(n0, dtype=torch.long, device=device)  # host gap: 0 under the coating, L above the base
        pid = torch.arange(n0, device=device)
        keep = self.beta0[pair] > 0
        reflected = torch.zeros(n0, dtype=torch.bool, device=device)  # any layer/base reflection yet
        state = [t[keep] for t in (beta, d, gap, pid, pair, reflected)]
        for depth in range(self.max_depth):
            beta, d, gap, pid, pair, reflected = state
            n = pid.numel()
            if n == 0:
                break
            # u[:, 0] event, u[:, 1:3] direction, u[:, 3] roulette, u[:, 4 + 2k:6 + 2k] NEE through layer k
            u = torch.rand(n, 4 + 2 * L, generator=gen, dtype=dtype, device=device)
            down = d[:, 2] < 0
            at_base = down & (gap == L)
            at_top = ~down & (gap == 0)
            layer_of = torch.where(down, gap, gap - 1)  # the layer met (valid unless base / top)
            alive = torch.ones(n, dtype=torch.bool, device=device)
            new_beta, new_d, new_gap = beta.clone(), d.clone(), gap.clone()
            was_down = down.clone()

            # next-event estimation on every downward hit
            nee = down & (gap < L) if self.rho == 0 else down
            if self.multiple:  # only paths that already reflected: their NEE adds a 2nd reflection
                nee = nee & reflected
            out = self._way_out(torch.nonzero(nee).squeeze(-1), gap, pair, u)
            for l, lay in enumerate(self.layers):
                idx = torch.nonzero(nee & (gap == l)).squeeze(-1)
                if idx.numel():
                    p = pair[idx]
                    f = _brdf(-d[idx], self.wo_in[p], lay.alpha, lay.reflectance)
                    acc.index_add_(0, pid[idx], beta[idx] * f * out[idx])
            if self.rho > 0:
                idx = torch.nonzero(at_base & nee).squeeze(-1)
                if idx.numel():
                    acc.index_add_(0, pid[idx], beta[idx] * (self.rho / math.pi) * out[idx])

            # scattering at the layers
            for l, lay in enumerate(self.layers):
                idx = torch.nonzero((layer_of == l) & ~at_base & ~at_top).squeeze(-1)
                if idx.numel():
                    self._layer_event(lay, idx, u, beta, d, down, new_beta, new_d, new_gap, alive)
            # the Lambertian base: cosine-weighted sampling, weight ρd
            if self.single or self.rho == 0:
                alive &= ~at_base
            else:
                idx = torch.nonzero(at_base).squeeze(-1)
                if idx.numel():
                    r = torch.sqrt(u[idx, 1])
                    phi = (2 * math.pi) * u[idx, 2]
                    z = torch.sqrt(1.0 - u[idx, 1])  # > 0: torch.rand < 1
                    new_d[idx] = torch.stack([r * torch.cos(phi), r * torch.sin(phi), z], -1)
                    new_beta[idx] = beta[idx] * self.rho
            # the top: escape (its contribution was counted by NEE) or internal reflection
            if self.n1 == 1.0 or self.single:
                alive &= ~at_top
            else:
                idx = torch.nonzero(at_top).squeeze(-1)
                if idx.numel():
                    new_beta[idx] = beta[idx] * _coating_r_inside(d[idx, 2], self.n1).unsqueeze(-1)
                    new_d[idx, 2] = -d[idx, 2]

            # Russian roulette
            if depth + 1 >= self.rr_depth:
                q = new_beta.amax(-1).clamp(max=1.0)
                survive = u[:, 3] < q
                alive &= survive
                new_beta = new_beta / torch.where(survive, q, torch.ones_like(q)).unsqueeze(-1)
            alive &= new_beta.amax(-1) > 0
            # a reflection (layer or base) turned a downward path up, or an upward one down at a layer
            turned = (new_d[:, 2] < 0) != was_down
            new_reflected = reflected | (turned & ~at_top)
            state = [t[alive] for t in (new_beta, new_d, new_gap, pid, pair, new_reflected)]
        return acc

    def _way_out(self, idx, gap, pair, u) -> torch.Tensor:
        """Transmission factor from the gap above layer ``gap`` out towards ``o`` (n, W), filled
        at ``idx``: the table ``chain`` ("filter"), times one sampled ``T_k(o'·m_k)`` per
        crossed layer ("microfacet": unbiased for τ_k(o')/G1_k(o'), no quadrature)."""
        out = torch.zeros(gap.numel(), self.W, dtype=self.dtype, device=self.device)
        if not idx.numel():
            return out
        p, g = pair[idx], gap[idx]
        vals = self.chain[p, g]
        if self.mode == "microfacet":
            wo = self.wo_in[p]
            for k, lay in enumerate(self.layers[: self.L - (self.rho == 0)]):
                j = torch.nonzero(g > k).squeeze(-1)  # paths below layer k
                if not j.numel():
                    break
                m = _vndf(wo[j], lay.alpha, u[idx[j], 4 + 2 * k:6 + 2 * k])
                vals[j] = vals[j] * lay.transmittance((wo[j] * m).sum(-1))
        out[idx] = vals
        return out

    def _layer_event(self, lay, idx, u, beta, d, down, new_beta, new_d, new_gap, alive):
        """Reflection or ballistic transmission at layer ``l`` for the paths ``idx``."""
        dl = d[idx]
        c = dl[:, 2].abs().clamp(max=1.0)  # a unit vector's z can be 1 + ulp
        wi = torch.cat([-dl[:, :2], c.unsqueeze(-1)], -1)  # −d in the frame whose normal faces it
        sgn = torch.where(down[idx], 1.0, -1.0).to(dl.dtype)  # +1: hit from above
        b = beta[idx]
        u0 = u[idx, 0]
        g1 = smith_g1_kernel(c, lay.alpha)  # (c = |d_z| ≥ 0)
        if self.mode == "filter":
            tau = lay.tau(c)
            c1, a1 = c.unsqueeze(-1), lay.alpha.unsqueeze(-1)
            p_t = probability_kernel(tau, c1, a1, True).squeeze(-1)  # eq. 31, multiplexed
            trans = u0 < p_t
            w_t = weight_kernel(tau, c1, a1, True)  # eq. 33 (= τ / p_trans)
            refl = ~trans
            p_r = 1.0 - p_t
            m = r_d = None
        else:
            m = _vndf(wi, lay.alpha, u[idx, 1:3])
            cos_d = (wi * m).sum(-1).clamp(0.0, 1.0)
            r_d = lay.reflectance(cos_d)
            t_d = lay.transmittance(cos_d)
            rm, tm = r_d.mean(-1), t_d.mean(-1)
            tot = rm + tm
            p_r = rm / torch.where(tot > 0, tot, torch.ones_like(tot))
            refl = u0 < p_r
            trans = ~refl & (tot > 0)
            q = torch.where(trans, 1.0 - p_r, torch.ones_like(p_r))
            w_t = g1.unsqueeze(-1) * t_d / q.unsqueeze(-1)
        # ballistic transmission: direction unchanged, one gap further
        jt = torch.nonzero(trans).squeeze(-1)
        if jt.numel():
            it = idx[jt]
            new_beta[it] = b[jt] * w_t[jt]
            new_gap[it] = torch.where(down[it], new_gap[it] + 1, new_gap[it] - 1)
        jr = torch.nonzero(refl).squeeze(-1)
        if not jr.numel():
            alive[idx[~trans]] = False
            return
        if self.single:  # single-reflection estimator: the reflection was the NEE; stop
            alive[idx[~trans]] = False
            return
        ir = idx[jr]
        wr = wi[jr]
        if m is None:
            m = _vndf(wr, lay.alpha, u[ir, 1:3])
            r = lay.reflectance((wr * m).sum(-1).clamp(0.0, 1.0))
        else:
            m, r = m[jr], r_d[jr]
        o = reflect_kernel(wr, m)
        o = o / torch.linalg.vector_norm(o, dim=-1, keepdim=True)  # no drift of |d| over many bounces
        ok = o[:, 2] > 0  # reflected through the layer: masked (G1 χ⁺), the path dies
        pr = p_r[jr]
        w_r = r * (smith_g1_kernel(o[:, 2].clamp(min=0.0).abs(), lay.alpha) / torch.where(pr > 0, pr, torch.ones_like(pr))).unsqueeze(-1)
        new_beta[ir] = b[jr] * w_r
        new_d[ir] = torch.cat([o[:, :2], (o[:, 2] * sgn[jr]).unsqueeze(-1)], -1)
        alive[ir] &= ok
        # neither reflected nor transmitted (microfacet mode, R = T = 0 everywhere): absorbed
        alive[idx[~trans & ~refl]] = False


# ----------------------------------------------------------------------------------------
# public API
# ----------------------------------------------------------------------------------------
@_checks.arguments(
    structure=_geometry.STRUCTURE, transmission=_checks.choice(TRANSMISSION_MODES), samples=_checks.integer(2),
    seed=_checks.integer(0), max_depth=_checks.integer(1), rr_depth=_checks.integer(0),
    batch_size=_checks.integer(1), transmissivity_angles=_checks.integer(2), theta_d_cells=_checks.integer(2),
    progress=_checks.PROGRESS, single_reflection=_checks.FLAG, multiple_reflection=_checks.FLAG,
    wi=_geometry.DIRECTIONS, wo=_geometry.DIRECTIONS, wavelength=_geometry.WAVELENGTHS, broadcast=("wi", "wo"))
def montecarlo_brdf(
    wavelength,
    wi,
    wo,
    structure,
    *,
    samples: int = 1024,
    seed: int = 0,
    single_reflection: bool = False,
    multiple_reflection: bool = False,
    transmission: str = "filter",
    max_depth: int = 100,
    rr_depth: int = 3,
    batch_size: int = 32768,
    transmissivity_angles: int = DEFAULT_ANGLES,
    theta_d_cells: int = DEFAULT_THETA_D_CELLS,
    progress: Callable[[int, int], None] | None = None,
) -> tuple[torch.Tensor, torch.Tensor]:
    r"""Monte Carlo estimate of the BRDF of a layered rough Bragg structure (Fourneau et al. 2024 §4.2).

    Position-free light transport (see the module docstring): per-layer reflection or
    ballistic transmission (eq. 17, 28–33), the Lambertian base, the coating (Fresnel,
    total internal reflection, eq. 34's ``T_c(i)T_c(o)/n1²``), all wavelengths multiplexed
    in one path, next-event estimation towards ``wo``. The coating's own specular reflection
    (a Dirac delta) is not included.

    Args:
        structure: a :class:`~torchirid.layered.LayeredBragg` (or one
            :class:`~torchirid.layered.RoughBraggLayer`, with a black base).
        wi, wo: unit directions above the surface (local frame, normal = +z, ``z > 0``),
            shape ``(*, 3)`` broadcasting together; ``wi`` points towards the light.
        wavelength: vacuum wavelengths in nm, shape ``(W,)``.
        samples: paths per direction pair (≥ 2; the standard error needs two).
        seed: seed of the :class:`torch.Generator` driving every random number.
        single_reflection: only paths with exactly one reflection (the paper's "SR sim.");
            converges to the single-reflection BRDF of eq. 34.
        multiple_reflection: only paths with two or more reflections (on layers or the base):
            everything eq. 34 leaves out. Full transport = single + multiple, so a low-noise
            full reference is ``single_reflection_brdf`` (exact eq. 34) plus this estimate
            (its noise is that of the multiple-reflection part only).
        transmission: ``"filter"`` — p_trans and weight of eq. 31/33 with the integrated
            transmissivity τ (eq. 28; the paper's optimized simulation); or
            ``"microfacet"`` — sample the microfacet normal first, then reflect or transmit,
            and sample the transmissions of the way out too (no F_α, no quadrature: the
            independent reference; same expectation, slightly more variance).
        max_depth: maximum number of scattering events (layer, base or coating) per path.
        rr_depth: Russian roulette from the ``rr_depth``-th scattering event on (survival
            probability ``min(1, max_λ β)``, β divided by it).
        batch_size: paths traced at once (memory ≈ ``batch_size · W · 8`` bytes per array).
        transmissivity_angles, theta_d_cells: resolution of the per-layer τ tables of the
            ``"filter"`` mode (:func:`~torchirid.layered.transmission.transmissivity_lut`:
            incidence angles uniform in θ, and θd cells of its product integration; raise
            ``theta_d_cells`` for very long stacks, its error grows as cells²).
        progress: ``None`` or a callable ``progress(done, total)``, called after each batch:
            ``done`` paths traced so far out of ``total = samples ×`` the number of direction
            pairs (the last call has ``done == total``). The library draws nothing itself: the
            caller wraps its own progress bar around it.

    Returns:
        ``(mean, stderr)``, each of shape ``(*, W)`` (sr⁻¹), dtype of the inputs: the BRDF
        estimate and its standard error (sample standard deviation / √samples). With the
        same arguments and ``seed`` the result is identical.

    Raises:
        ValueError: a bad structure, direction (not ``(*, 3)``, not unit, ``z <= 0``, ``wi`` and
            ``wo`` not broadcasting), wavelength, sample count, depth or an unknown ``transmission``.

    Example (one rough layer in air over a black base: only single reflections exist, so
    the estimate is eq. 17 exactly and its standard error is 0):
        >>> import torch
        >>> from torchirid.layered import LayeredBragg, RoughBraggLayer
        >>> s = LayeredBragg([RoughBraggLayer(1.0, 1.5, 100.0, 100.0, 5, 0.2)])
        >>> w = torch.tensor([0.0, 0.0, 1.0], dtype=torch.float64)
        >>> lam = torch.tensor([400.0, 600.0], dtype=torch.float64)
        >>> f, err = montecarlo_brdf(lam, w, w, s, samples=16, transmission="microfacet")
        >>> [round(v, 6) for v in f.tolist()], bool(err.max() < 1e-12)
        ([0.047742, 1.158475], True)
    """
    if single_reflection and multiple_reflection:
        raise ValueError("single_reflection and multiple_reflection exclude each other "
                         "(full transport = single + multiple: leave both False)")
    lam = wavelength
    dtype, device = lam.dtype, lam.device
    i, o = torch.broadcast_tensors(wi, wo)
    batch = i.shape[:-1]
    i, o = i.reshape(-1, 3), o.reshape(-1, 3)
    P, W = i.shape[0], lam.numel()

    with torch.no_grad():
        tr = _Transport(structure, i, o, lam, single=single_reflection, mode=transmission,
                        tau_angles=transmissivity_angles, tau_cells=theta_d_cells,
                        max_depth=max_depth, rr_depth=rr_depth, multiple=multiple_reflection)
        gen = torch.Generator(device=device)
        gen.manual_seed(seed)
        total = P * samples
        # running per-pair count, mean and sum of squared deviations (Chan et al.'s pairwise
        # update: no cancellation, a zero-variance estimate gets exactly stderr = 0)
        count = torch.zeros(P, 1, dtype=torch.float64, device=device)
        mean = torch.zeros(P, W, dtype=torch.float64, device=device)
        m2 = torch.zeros(P, W, dtype=torch.float64, device=device)
        for start in range(0, total, batch_size):
            k = torch.arange(start, min(start + batch_size, total), device=device)
            pair = k % P  # sample-major: every chunk spreads over the pairs
            x = tr.trace(pair, gen).to(torch.float64)
            n_c = torch.zeros_like(count).index_add_(0, pair, torch.ones_like(x[:, :1]))
            mean_c = torch.zeros_like(mean).index_add_(0, pair, x) / n_c.clamp_min(1.0)
            m2_c = torch.zeros_like(m2).index_add_(0, pair, (x - mean_c[pair]) ** 2)
            n_ab = count + n_c
            delta = mean_c - mean
            frac = n_c / n_ab.clamp_min(1.0)
            mean = mean + delta * frac
            m2 = m2 + m2_c + delta * delta * count * frac
            count = n_ab
            if progress is not None:
                progress(start + k.numel(), total)
        err = torch.sqrt(m2 / ((samples - 1) * samples))
        bad = _geometry.nan_rows(i, o).unsqueeze(-1)  # NaN directions: NaN estimates, not 0 (docs/conventions.md)
        mean, err = torch.where(bad, torch.nan, mean), torch.where(bad, torch.nan, err)
    return mean.to(dtype).reshape(*batch, W), err.to(dtype).reshape(*batch, W)

