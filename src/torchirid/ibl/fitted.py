r"""A fitted light-distribution table for rough thin films: past Kneiphof's single Gaussian.

Kneiphof et al. 2019 replace the distribution of the path difference D over a GGX lobe by
one Gaussian (eq. 18–29), with C*_m and φ₂* taken at the mean direction. Under uniform light
(their Fig. 7) the true distribution of :math:`\cos θ_1 = ⟨h, ω_i⟩` is skewed, with GGX's long
tail towards smaller cos θ1, and C_m, φ₂ vary across it (most at grazing): one Gaussian leaves
a mean ΔE2000 of ≈ 4 against the ground truth (docs/performance.md, "Thin-film IBL").

This module fits, per (cos θo, √α), a **K-component Gaussian mixture to the distribution of
cos θ1** under :math:`p_R ∝ \tilde ρ⟨n,ω_i⟩` (``cos_theta1_distribution()``):
the distribution is cut at fixed quantiles (default 5 %, 30 %, 70 %, 95 %) and each piece is
replaced by a Gaussian with its mass :math:`w_k`, mean :math:`\bar c_k` and variance
:math:`s_k^2` (a method-of-moments fit per piece; the pieces' masses, means and second
moments add up to the distribution's). At run time each component is one eq. 29 evaluation:

.. math:: \mathbf{XYZ} ≈ \sum_k w_k\,\mathrm{eq.\,29}\Big(C^*_m, φ_2^* \text{ at } \bar c_k;\;
          μ_D = 2η_2 d\,c_2(\bar c_k),\; σ_D = 2η_2 d\,\Big|\frac{dc_2}{dc_1}\Big|_{\bar c_k} s_k\Big),
          \qquad c_2(c_1) = \sqrt{1 - \tfrac{η_1^2}{η_2^2}(1 - c_1^2)},

the linearisation of eq. 25–26 applied per component (narrow pieces: small error). The table
depends only on the geometry, not on the film: one table serves every thickness, film index
and base (dielectric or conductor) — 15 numbers per node for K = 5. The table is stored in the
LUT container (axes ``cos_theta_o`` (nodes uniform in θo) and ``sqrt_alpha``; channels
``(K, 3)`` = (w, c̄, s²)) and interpolated multilinearly; the shipped ones are
``data/thin_film_ibl/light_mixture.npz`` (separable Smith G, the default) and
``data/thin_film_ibl/light_mixture_height_correlated.npz`` (``masking="height_correlated"``:
Kneiphof's Smith-joint G, :math:`G_2 = 1/(1 + Λ(ω_i) + Λ(ω_o))`; see :mod:`torchirid.ibl.uniform`),
both built by ``luts/build_light_mixture.py`` (140 KB each). Use the table of the G that
the BRDF being matched uses: the two distributions of cos θ1 differ most at grazing and
high roughness.

It models uniform light (Fig. 7, or an environment that is smooth over the lobe); for a
structured environment Kneiphof's moment channels remain the way to see the light.
"""

from __future__ import annotations

import importlib.resources
import math

import torch

from .. import _autograd, _checks, _chunks
from ..lut import LUT
from .filtered import _ARGS, _series_xyz
from .fourier import check_film_above_incident, fourier_terms
from .sensitivity import _sensitivity_width
from .uniform import _LOBE, MASKING_MODES, _check_masking, _distribution
from .._cache import cached

__all__ = [
    "light_mixture_lut",
    "shipped_light_mixture_lut",
    "light_mixture",
    "thin_film_xyz_fitted",
]

LIGHT_MIXTURE_BUILDER = "torchirid.ibl.fitted:light_mixture_lut"
DEFAULT_QUANTILES = (0.05, 0.3, 0.7, 0.95)
_ALPHA_MIN = 1e-4  # the √α = 0 node is evaluated here (GGX needs α > 0; a mirror to ≲ 1e-5)
_THETA_MAX_DEG = 89.5  # the θo = 90° node is evaluated here (a view above the horizon)
_DATA = {"separable": ("data", "thin_film_ibl", "light_mixture.npz"),
         "height_correlated": ("data", "thin_film_ibl", "light_mixture_height_correlated.npz")}
_SHIPPED = {"quantiles": list(DEFAULT_QUANTILES), "theta_nodes": 48, "alpha_nodes": 48,
            "bins": 2048, "nodes": 64}


def _quantile_pieces(grid, w, quantiles):
    """Masses, means and variances of the pieces of a binned distribution cut at quantiles."""
    # each bin goes to the piece holding its mid-CDF (bins are 1/2048 wide: the cut is that sharp)
    mid = w.cumsum(-1) - 0.5 * w
    edges = [0.0, *quantiles, math.inf]
    out = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        m = w * ((mid >= lo) & (mid < hi))
        wk = m.sum(-1)
        safe = torch.where(wk > 0, wk, torch.ones_like(wk))
        mk = (m * grid).sum(-1) / safe
        vk = ((m * grid * grid).sum(-1) / safe - mk * mk).clamp_min(0.0)
        # an empty piece (a near-mirror: all mass in one bin) sits at the mean with no weight
        mean = (w * grid).sum(-1)
        out.append(torch.stack([wk, torch.where(wk > 0, mk, mean), vk], -1))
    return torch.stack(out, -2)  # (*, K, 3)


@_checks.arguments(bins=_checks.integer(1), **_LOBE)
def light_mixture(cos_theta_o, alpha, *, quantiles=DEFAULT_QUANTILES, bins: int = 2048, nodes: int = 64,
                  masking: str = "separable"):
    r"""The K-component mixture of cos θ1 for given geometry, computed directly (no table).

    Args:
        cos_theta_o: cos θo in (0, 1]; alpha: GGX roughness > 0 (broadcast).
        quantiles: increasing cut points in (0, 1); K = len(quantiles) + 1 components.
        bins, nodes: resolution of ``cos_theta1_distribution()``.
        masking: the lobe's G: ``"separable"`` (default) or ``"height_correlated"`` (Kneiphof's
            Smith-joint G; ``uniform_lobe_quadrature()``).

    Returns:
        ``(*, K, 3)``: per component (mass w_k, mean c̄_k, variance s_k²); Σ w_k = 1.

    Example:
        >>> import torch
        >>> mix = light_mixture(torch.tensor(0.8, dtype=torch.float64), 0.25)
        >>> [round(v, 3) for v in mix[..., 0].tolist()], round(float(mix[..., 0].sum()), 6)
        ([0.05, 0.25, 0.399, 0.251, 0.05], 1.0)
    """
    q = [float(x) for x in quantiles]
    if not q or any(not (0.0 < x < 1.0) for x in q) or any(b <= a for a, b in zip(q[:-1], q[1:])):
        raise ValueError(f"quantiles must be increasing values in (0, 1); got {quantiles!r}")
    grid, w, _ = _distribution(cos_theta_o, alpha, bins=bins, nodes=nodes, masking=masking)
    return _quantile_pieces(grid, w, q)


def light_mixture_lut(*, quantiles=DEFAULT_QUANTILES, theta_nodes: int = 48, alpha_nodes: int = 48,
                      bins: int = 2048, nodes: int = 64, masking: str = "separable",
                      dtype: torch.dtype = torch.float32) -> LUT:
    r"""Tabulate :func:`light_mixture` over (cos θo, √α) (module docstring).

    Args:
        quantiles, bins, nodes, masking: as :func:`light_mixture` (``masking`` is stored in
            ``parameters["masking"]``).
        theta_nodes: nodes uniform in θo ∈ [0°, 90°] (90° evaluated at 89.5°), stored as an
            increasing ``cos_theta_o`` axis.
        alpha_nodes: nodes uniform in √α ∈ [0, 1] (α = 0 evaluated at 1e-4).
        dtype: stored dtype (computed in float64).

    Returns:
        :class:`~torchirid.lut.LUT` with axes ``cos_theta_o``, ``sqrt_alpha`` and channels ``(K, 3)``.

    Example (a coarse table, quick to build; the shipped one is 48 × 48):
        >>> import torch
        >>> lut = light_mixture_lut(theta_nodes=4, alpha_nodes=3, bins=256, nodes=16, dtype=torch.float64)
        >>> lut.axis_names, lut.values.shape  # K = 5 components of (mass, mean cos θ1, variance)
        (('cos_theta_o', 'sqrt_alpha'), torch.Size([4, 3, 5, 3]))
        >>> mix = lut.interp(cos_theta_o=torch.tensor(0.8, dtype=torch.float64),
        ...                  sqrt_alpha=torch.tensor(0.5, dtype=torch.float64))  # α = 0.25
        >>> round(float(mix[:, 0].sum()), 6)  # the masses sum to 1
        1.0
        >>> thin_film_xyz_fitted(torch.tensor(0.8, dtype=torch.float64), 0.25, 1.3, 600.0, 1.5, table=lut).shape
        torch.Size([3])
    """
    for name, v in (("theta_nodes", theta_nodes), ("alpha_nodes", alpha_nodes)):
        _checks.check_int(v, name, 2)
    _check_masking(masking)
    f64 = torch.float64
    theta = torch.linspace(90.0, 0.0, theta_nodes, dtype=f64)  # decreasing θ = increasing cos
    cos_axis = torch.cos(torch.deg2rad(theta))
    cos_axis[0] = 0.0
    cos_eval = torch.cos(torch.deg2rad(theta.clamp(max=_THETA_MAX_DEG)))
    sa = torch.linspace(0.0, 1.0, alpha_nodes, dtype=f64)
    alpha = (sa * sa).clamp_min(_ALPHA_MIN)
    mix = light_mixture(cos_eval[:, None], alpha[None, :], quantiles=quantiles, bins=bins, nodes=nodes,
                        masking=masking)
    params = {"quantiles": [float(x) for x in quantiles], "theta_nodes": theta_nodes,
              "alpha_nodes": alpha_nodes, "bins": bins, "nodes": nodes, "masking": masking}
    return LUT(mix.to(dtype), {"cos_theta_o": cos_axis.to(dtype), "sqrt_alpha": sa.to(dtype)},
               builder=LIGHT_MIXTURE_BUILDER, parameters=params,
               units={"cos_theta_o": "1", "sqrt_alpha": "1", "values": "1 (mass, mean cos θ1, variance)"})


def light_mixture_path(masking: str = "separable"):
    """Path of the shipped table: ``src/torchirid/data/thin_film_ibl/light_mixture.npz`` (separable
    Smith G) or ``light_mixture_height_correlated.npz`` (``masking="height_correlated"``).

    Example:
        >>> from torchirid.lut import LUT
        >>> path = light_mixture_path()
        >>> path.name, light_mixture_path("height_correlated").name
        ('light_mixture.npz', 'light_mixture_height_correlated.npz')
        >>> LUT.read(path).axis_names  # what shipped_light_mixture_lut reads
        ('cos_theta_o', 'sqrt_alpha')
    """
    return importlib.resources.files("torchirid").joinpath(*_DATA[_check_masking(masking)])


def _table_masking(lut: LUT) -> str:
    """The G a mixture table was built with (tables from before the option: separable)."""
    return lut.parameters.get("masking", "separable")


@cached(maxsize=None)
@_autograd.normal_tensors  # (a first call in inference mode must not cache inference tensors)
def _shipped(masking, dtype, device) -> LUT:
    path = light_mixture_path(masking)
    with importlib.resources.as_file(path) as p:
        if p.exists():
            lut = LUT.read(p, builder=LIGHT_MIXTURE_BUILDER, parameters=_SHIPPED)
            if _table_masking(lut) != masking:
                raise ValueError(f"{p} holds a masking={_table_masking(lut)!r} table, not {masking!r}; "
                                 "rebuild it with luts/build_light_mixture.py")
        else:  # a source tree without the data file: build it (≈ 10 s) rather than fail
            lut = light_mixture_lut(**_SHIPPED, masking=masking)
    return lut.to(dtype=dtype, device=device)


def shipped_light_mixture_lut(*, masking: str = "separable", dtype: torch.dtype = torch.float64,
                              device=None) -> LUT:
    """The shipped K = 5 mixture table (48 θo × 48 √α nodes) for ``masking`` (``"separable"``, the
    default, or ``"height_correlated"``), cached per masking/dtype/device.

    Example:
        >>> import torch
        >>> lut = shipped_light_mixture_lut()  # float64, CPU
        >>> lut.values.shape  # (cos θo, √α, K, (mass, mean cos θ1, variance))
        torch.Size([48, 48, 5, 3])
        >>> lut is shipped_light_mixture_lut()  # cached: treat it as read-only
        True
        >>> shipped_light_mixture_lut(dtype=torch.float32).dtype
        torch.float32
    """
    _check_masking(masking)
    return _shipped(masking, dtype, torch.device("cpu") if device is None else torch.device(device))


@_checks.arguments(cos_theta_o=_checks.COSINE, alpha=_checks.nonnegative("(GGX roughness)"),
                   masking=_checks.choice(MASKING_MODES), **_ARGS)
def thin_film_xyz_fitted(cos_theta_o, alpha, n_film, thickness, n_substrate, *, n_incident=1.0, table=None,
                         terms: int = 4, observer: str = "CIE 1931 2", illuminant: str = "D65",
                         polarization: str = "unpolarized", sensitivity: str = "lut",
                         masking: str = "separable") -> torch.Tensor:
    r"""Thin-film XYZ over a GGX lobe under uniform light from the fitted mixture table.

    Args:
        cos_theta_o: cos θo in [0, 1]; alpha: GGX roughness in [0, 1] (the table's range; α > 1
            raises, where :func:`~torchirid.ibl.thin_film_xyz_uniform` computes any α).
        n_film: real film index η₂ ≥ ``n_incident``; thickness: nm ≥ 0; n_substrate: η₃ + iκ₃.
        n_incident: real outer index η₁ (default 1).
        table: a :class:`~torchirid.lut.LUT` from :func:`light_mixture_lut` built with the same
            ``masking``; default the shipped one for ``masking``.
        terms: M ≥ 0 Fourier terms per component (default 4). More terms approach
            :func:`~torchirid.ibl.thin_film_xyz_uniform`, slowest for near-mirrors at grazing views;
            each term costs one Ŝ evaluation per component. The error against the uniform-light
            reference per M (``benchmarks/fitted_terms_error.py``) and the cost are in
            docs/performance.md, "Thin-film colour on rough surfaces under uniform light: Kneiphof
            Fig. 7"; at the default, a base 1.5 + 2i, d = 171 nm, θo = 70°, α = 0.056 stays within
            ΔE2000 0.6 of the reference (tests/ibl/test_fitted_terms.py).
        observer, illuminant, polarization, sensitivity: as
            :func:`~torchirid.ibl.thin_film_xyz_filtered` (``sensitivity="lut"``: Kneiphof's 2-D Ŝ table,
            what a shader reads).
        masking: the lobe's G, ``"separable"`` (default; the library's microfacet BRDF and DFG
            table) or ``"height_correlated"`` (Kneiphof's Smith-joint G) — module docstring.

    Returns:
        ``(*, 3)`` XYZ of the reflectance term (white Y = 1); multiply by the albedo (DFG) for
        the reflected radiance. Differentiable w.r.t. every input.

    Example:
        >>> import torch
        >>> xyz = thin_film_xyz_fitted(torch.tensor(0.8, dtype=torch.float64), 0.25, 1.3, 600.0, complex(2.0, 0.5))
        >>> [round(v, 4) for v in xyz.tolist()]  # reference (thin_film_xyz_uniform): [0.0647, 0.067, 0.1077]
        [0.0645, 0.0668, 0.1076]
    """
    c, a, nf, d, n0, ns = cos_theta_o, alpha, n_film, thickness, n_incident, n_substrate
    dtype, device = c.dtype, c.device
    with torch.no_grad():  # the table covers α ≤ 1: refuse rather than clamp (thin_film_xyz_uniform takes any α)
        if _checks.value_checks_enabled() and bool((a > 1).any()):
            raise ValueError(f"alpha must be <= 1 (GGX roughness covered by the fitted table); got max "
                             f"{a.max().item():g} — use thin_film_xyz_uniform for rougher surfaces")
    check_film_above_incident(nf, n0)
    if table is None:
        table = shipped_light_mixture_lut(masking=masking, dtype=dtype, device=device)
    elif not isinstance(table, LUT) or table.builder != LIGHT_MIXTURE_BUILDER:
        raise ValueError("table must be a LUT built by light_mixture_lut")
    elif _table_masking(table) != masking:
        raise ValueError(f"table was built with masking={_table_masking(table)!r}; got masking={masking!r} "
                         "(pass the same masking, or table=None for the shipped one)")
    else:
        table = table.to(dtype=dtype, device=device)
    # the mixture axis K goes in front below: the lobe arguments carry the film's batch axes first
    # (else K meets the film axes: a scalar cos θo with a batch of thicknesses did not broadcast)
    full = _checks.broadcast_shapes(c.shape, a.shape, nf.shape, d.shape, n0.shape, ns.shape, names=_ARGUMENTS)
    # block by block over large batches (torchirid._chunks): per colour, K components × P × M
    # sensitivity values (× the quadrature's nodes with sensitivity="exact")
    K = table.values.shape[-2]
    nodes = _sensitivity_width(sensitivity, observer, illuminant, dtype, device)
    return _chunks.evaluate(_fitted_xyz, (c, a, nf, d, n0, ns), full, out_core=1,
                            width=K * 2 * max(terms, 1) * nodes, grad_inputs=(table.values,), table=table,
                            terms=terms, observer=observer, illuminant=illuminant, polarization=polarization,
                            sensitivity=sensitivity)


_ARGUMENTS = ("cos_theta_o", "alpha", "n_film", "thickness", "n_incident", "n_substrate")


def _fitted_xyz(c, a, nf, d, n0, ns, m_light=None, spread=None, m_lobe=None, *, table, terms, observer, illuminant,
                polarization, sensitivity):
    """The body of :func:`thin_film_xyz_fitted` on one block of colours; with ``m_light``, ``spread``
    and ``m_lobe`` (an environment's light inside the lobe, :func:`fitted_xyz_in_light`) each
    component is moved to c̄' = m_light + spread·(c̄ − m_lobe) and narrowed to spread·s_k."""
    dtype = c.dtype
    full = _checks.broadcast_shapes(c.shape, a.shape, nf.shape, d.shape, n0.shape, ns.shape)
    c, a = c.expand(full), a.expand(full)
    mix = table(cos_theta_o=c, sqrt_alpha=torch.sqrt(a))  # (*, K, 3)
    w, c1, v1 = mix.unbind(-1)
    c1 = c1.clamp(0.0, 1.0).movedim(-1, 0)  # (K, *)
    w, v1 = (t.clamp_min(0.0).movedim(-1, 0) for t in (w, v1))
    if m_light is not None:
        c1 = (m_light + spread * (c1 - m_lobe)).clamp(0.0, 1.0)
        v1 = spread * spread * v1
    # per component: C*, φ2* at c̄_k; D ~ N(2η2 d c2(c̄_k), (2η2 d c2'(c̄_k) s_k)²) (eq. 25–28 per piece)
    k = (n0 / nf) ** 2
    c2 = torch.sqrt((1.0 - k * (1.0 - c1 * c1)).clamp_min(torch.finfo(dtype).tiny))
    slope = k * c1 / c2
    scale = 2.0 * nf * d
    C0, amp, K, _ = fourier_terms(c1, nf, d, ns, n0, polarization)
    shape = C0.shape[1:]
    xyz = _series_xyz(C0, amp, K, (scale * c2).expand(shape), (scale * scale * slope * slope * v1).expand(shape),
                      terms, observer, illuminant, sensitivity)  # (K, *, 3)
    return (w.expand(shape)[..., None] * xyz).sum(0)


#: the most a light can widen the fitted components (spread = σ_light / σ_lobe): bounds the
#: extrapolation where the lobe's own spread is tiny (a near-mirror)
MAX_SPREAD = 3.0


def fitted_xyz_in_light(cos_theta_o, alpha, n_film, thickness, n_substrate, m_light, sd_light, m_lobe, sd_lobe, *,
                        n_incident, terms, observer, illuminant, polarization, sensitivity, table=None):
    r"""The fitted mixture moved into an environment's light (on checked inputs; the body of
    ``shade_thin_film_environment(method="fitted")``).

    The table's components describe cos θ1 under *uniform* light in the GGX lobe. Given the mean
    and spread of cos θ1 under the environment's light inside the lobe (``m_light``,
    ``sd_light``) and under uniform light in the same lobe model (``m_lobe``, ``sd_lobe``), each
    component is mapped by c̄' = m_light + s·(c̄ − m_lobe), s_k' = s·s_k with
    s = sd_light / sd_lobe (at most :data:`MAX_SPREAD`): the identity under uniform light, the
    film at the light's own half vector (s = 0, c̄' = m_light) under a point light.
    """
    c, a, nf, d, n0, ns = cos_theta_o, alpha, n_film, thickness, n_incident, n_substrate
    dtype, device = c.dtype, c.device
    check_film_above_incident(nf, n0)
    if table is None:
        table = shipped_light_mixture_lut(dtype=dtype, device=device)
    spread = torch.where(sd_lobe > 0, sd_light / torch.where(sd_lobe > 0, sd_lobe, torch.ones_like(sd_lobe)),
                         torch.zeros_like(sd_lobe)).clamp(max=MAX_SPREAD)
    full = _checks.broadcast_shapes(c.shape, a.shape, nf.shape, d.shape, n0.shape, ns.shape, m_light.shape,
                                    spread.shape, m_lobe.shape)
    K = table.values.shape[-2]
    nodes = _sensitivity_width(sensitivity, observer, illuminant, dtype, device)
    return _chunks.evaluate(_fitted_xyz, (c, a, nf, d, n0, ns, m_light, spread, m_lobe), full, out_core=1,
                            width=K * 2 * max(terms, 1) * nodes, grad_inputs=(table.values,), table=table,
                            terms=terms, observer=observer, illuminant=illuminant, polarization=polarization,
                            sensitivity=sensitivity)
