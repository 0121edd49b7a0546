r"""The He–Torrance model of one rough interface (He, Torrance, Sillion & Greenberg 1991):
the roughness factor g (eq. 79), the coherent (specular) attenuation e^{−g} (eq. 31), the
shadowing S(θ) (eq. 24–25, with errata), the effective roughness (eq. 80–83) and the
directional-diffuse BRDF (eq. 76–84).  :mod:`torchirid.optics.rough_surface` builds
Hirayama's films on a rough surface (Hirayama et al. 2000 §4.2) from these pieces.

The roughness factor (He eq. 79) inside a medium of real index ``n`` is

.. math:: g = \Big(\frac{2π σ}{λ/n}(\cos θ_i + \cos θ_r)\Big)^2
             = \Big(\frac{2π σ (q_i + q_r)}{λ}\Big)^2, \qquad q = n\cos θ .
"""

from __future__ import annotations

import math

import torch

from .. import _checks
from .fresnel import fresnel_reflectance

__all__ = ["he_directional_diffuse"]

_NEWTON_STEPS = 10  # He eq. 80: converges to machine precision in < 6 steps (monotone, convex)
_S_BIG = 30.0  # erfc(30) ≈ 1e-393 underflows: S = 1 to every digit beyond this argument


# ---------------------------------------------------------------------------------------
# validation helpers
# ---------------------------------------------------------------------------------------


def _check_cos_phi(t: torch.Tensor, name: str = "cos_phi") -> None:
    with torch.no_grad():
        if bool(((t < -1) | (t > 1)).any()):
            raise ValueError(
                "cos_phi must lie in [-1, 1] (cosine of the azimuth between light and view; "
                f"-1 is the mirror configuration); got {t[(t < -1) | (t > 1)].flatten()[0].item():g}"
            )


def _check_roughness(sigma: torch.Tensor, tau: torch.Tensor | None) -> None:
    _checks.check_nonnegative(sigma, "sigma")
    if tau is not None:
        _checks.check_positive(tau, "tau")


#: the arguments of this module's public functions (the rough-surface ones use them too)
SIGMA = _checks.nonnegative("nm")  # rms roughness σ₀
TAU = _checks.positive("nm")  # autocorrelation length τ
COS_PHI = _checks.real(_check_cos_phi)  # cosine of the azimuth between light and view, [-1, 1]
N_MEDIUM = _checks.positive("")  # a real medium index > 0


# ---------------------------------------------------------------------------------------
# He–Torrance building blocks
# ---------------------------------------------------------------------------------------


def _g(lam, q_in, q_out, sigma):
    x = (2 * math.pi) * sigma * (q_in + q_out) / lam
    return x * x


@_checks.arguments(wavelength=_checks.WAVELENGTH, cos_theta_i=_checks.COSINE, cos_theta_o=_checks.COSINE,
                   sigma=SIGMA, n_incident=N_MEDIUM)
def roughness_factor(wavelength, cos_theta_i, cos_theta_o, sigma, *, n_incident=1.0) -> torch.Tensor:
    r"""He's roughness factor g (He et al. 1991, eq. 79) in a lossless medium of index n.

    .. math:: g = \Big(\frac{2π σ n}{λ}(\cos θ_i + \cos θ_r)\Big)^2

    Args:
        wavelength: vacuum wavelength λ in nm (> 0).
        cos_theta_i, cos_theta_o: cosines of the incident and reflected directions in the medium, [0, 1].
        sigma: rms roughness σ in nm (≥ 0).
        n_incident: real index of the medium above the rough interface (> 0).

    Returns:
        g ≥ 0 (dimensionless), the broadcast shape, real dtype of the inputs.

    Example (σ = 25 nm, normal incidence, 550 nm, air: g = (4π·25/550)²):
        >>> import torch
        >>> round(float(roughness_factor(torch.tensor(550.0, dtype=torch.float64), 1.0, 1.0, 25.0)), 6)
        0.326268
    """
    return _g(wavelength, n_incident * cos_theta_i, n_incident * cos_theta_o, sigma)


@_checks.arguments(wavelength=_checks.WAVELENGTH, cos_theta=_checks.COSINE, sigma=SIGMA, n_incident=N_MEDIUM)
def coherent_attenuation(wavelength, cos_theta, sigma, *, n_incident=1.0) -> torch.Tensor:
    r"""Power factor :math:`e^{-g}` of the coherent (specular) reflection (He eq. 31, Hirayama eq. 9).

    ``g`` is ``roughness_factor()`` at ``θ_i = θ_r = θ``: :math:`e^{-g} = e^{-(4π σ n \cos θ/λ)^2}`,
    the Debye–Waller-like factor of a Gaussian height distribution (the amplitude factor is
    :math:`e^{-g/2}`).

    Args:
        wavelength: vacuum wavelength λ in nm (> 0).
        cos_theta: cosine of the incidence angle in the medium, [0, 1].
        sigma: rms roughness σ in nm (≥ 0).
        n_incident: real index of the medium above the rough interface.

    Returns:
        e^{-g} in (0, 1].

    Example:
        >>> import torch
        >>> round(float(coherent_attenuation(torch.tensor(550.0, dtype=torch.float64), 1.0, 25.0)), 6)
        0.721612
    """
    q = n_incident * cos_theta
    return torch.exp(-_g(wavelength, q, q, sigma))


def _shadowing(c: torch.Tensor, sigma: torch.Tensor, tau: torch.Tensor) -> torch.Tensor:
    """He eq. 24–25 (with the errata's exponential), unchecked."""
    sin = _checks.safe_sqrt(1 - c * c)  # guard: √0's infinite slope at normal incidence (reported 0)
    # a = τ cot θ / (2σ); guard each degenerate branch with a safe value (where evaluates both)
    smooth = (sigma == 0) | (c * tau >= _S_BIG * 2 * sigma * sin)  # also normal incidence (sin = 0)
    grazing = (c == 0) & ~smooth
    bad = smooth | grazing
    a = torch.where(bad, torch.ones_like(c * sigma), c * tau / (2 * torch.where(bad, torch.ones_like(sigma * sin), sigma * sin)))
    erfc = torch.special.erfc(a)
    lam = 0.5 * (torch.exp(-a * a) / (math.sqrt(math.pi) * a) - erfc)
    S = (1 - 0.5 * erfc) / (lam + 1)
    S = torch.where(grazing, torch.zeros_like(S), S)  # grazing: fully shadowed (limit a → 0)
    return torch.where(smooth, torch.ones_like(S), S)


@_checks.arguments(cos_theta=_checks.COSINE, sigma=SIGMA, tau=TAU)
def he_shadowing(cos_theta, sigma, tau) -> torch.Tensor:
    r"""He's (Smith's) shadowing factor S(θ) of a Gaussian surface (He 1991, eq. 24–25).

    .. math::
        S(θ) = \frac{1 - \tfrac12\,\mathrm{erfc}(a)}{Λ(a) + 1}, \quad
        Λ(a) = \tfrac12\Big(\frac{e^{-a^2}}{\sqrt{π}\,a} - \mathrm{erfc}(a)\Big), \quad
        a = \frac{τ \cot θ}{2σ}

    (the factor :math:`e^{-a^2}` is missing in the printed eq. 25 and restored by He's
    errata; the rms slope of a Gaussian correlation is √2 σ/τ).  S = 1 for σ = 0 and at normal
    incidence, S = 0 at grazing.

    Args:
        cos_theta: cosine of the direction, [0, 1].
        sigma: rms roughness σ in nm (≥ 0).
        tau: autocorrelation length τ in nm (> 0).

    Returns:
        S in [0, 1].

    Example (τ/σ = 6 at 80°):
        >>> import torch, math
        >>> round(float(he_shadowing(torch.tensor(math.cos(math.radians(80)), dtype=torch.float64), 50.0, 300.0)), 6)
        0.657189
    """
    return _shadowing(*torch.broadcast_tensors(cos_theta, sigma, tau))


def _effective_roughness(ci, co, sigma, tau):
    """He eq. 80–83, unchecked: σ / sqrt(1 + (z0/σ)²) with x = z0/σ solving x e^{x²/2} = f0."""

    def K(c):
        sin = _checks.safe_sqrt(1 - c * c)  # guard: √0's slope at normal incidence (K is flat there)
        # tan θ capped at 1e8: grazing directions are fully shadowed anyway (S = 0)
        tan = sin / torch.clamp(c, min=1e-8)
        arg_ok = ~(tan <= 0) & (sigma > 0)  # (a NaN direction keeps its NaN: not `tan > 0`)
        arg = tau / (2 * torch.where(arg_ok, sigma * tan, torch.ones_like(sigma * tan)))
        return torch.where(arg_ok, tan * torch.special.erfc(arg), torch.zeros_like(arg))

    f0 = (K(ci) + K(co)) / math.sqrt(8 * math.pi)
    # start on the right of the root where possible: Newton then decreases monotonically (h convex)
    big = f0 > 1
    x = torch.where(big, torch.sqrt(2 * torch.log(torch.where(big, f0, torch.ones_like(f0)))), f0)
    x = torch.where(big & (x < 1), torch.ones_like(x), x)
    for _ in range(_NEWTON_STEPS):
        e = torch.exp(0.5 * x * x)
        x = x - (x * e - f0) / ((1 + x * x) * e)
    return sigma / torch.sqrt(1 + x * x)


@_checks.arguments(cos_theta_i=_checks.COSINE, cos_theta_o=_checks.COSINE, sigma=SIGMA, tau=TAU)
def effective_roughness(cos_theta_i, cos_theta_o, sigma, tau) -> torch.Tensor:
    r"""He's effective roughness σ (He 1991, eq. 80–83): the rms height of the *lit and seen* part.

    .. math::
        σ = \frac{σ_0}{\sqrt{1 + z_0^2/σ_0^2}}, \qquad
        \sqrt{π/2}\,z_0 = \frac{σ_0}{4}(K_i + K_r)\,e^{-z_0^2/(2σ_0^2)}, \qquad
        K = \tan θ\,\mathrm{erfc}\Big(\frac{τ}{2σ_0 \tan θ}\Big),

    solved by Newton's method for ``x = z0/σ0`` (``x e^{x²/2} = (K_i+K_r)/\sqrt{8π}``, a
    convex increasing function: monotone convergence, differentiable through the iterations).
    σ → σ₀ at normal incidence and for τ ≫ σ₀ (K → 0).

    Args:
        cos_theta_i, cos_theta_o: cosines of the two directions, [0, 1].
        sigma: rms roughness σ₀ in nm (≥ 0).
        tau: autocorrelation length τ in nm (> 0).

    Returns:
        σ in nm, 0 ≤ σ ≤ σ₀.

    Example:
        >>> import torch, math
        >>> c = torch.tensor(math.cos(math.radians(85)), dtype=torch.float64)
        >>> round(float(effective_roughness(c, c, 50.0, 300.0)), 4)
        30.0072
    """
    return _effective_roughness(cos_theta_i, cos_theta_o, sigma, tau)


def _series_D(g: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    r"""Σ_{m≥1} g^m e^{-g}/(m!·m) · e^{-b/m} (He eq. 78 without its prefactor), a loop over
    series terms (not over samples); summed in log space, so large g cannot overflow."""
    pos = g > 0
    gs = torch.where(pos, g, torch.ones_like(g))  # guard: log 0 in the unused branch
    log_g = torch.log(gs)
    with torch.no_grad():
        fin = pos & torch.isfinite(gs)  # (g = ∞: its terms are exp(−∞) = 0 at any count)
        gmax = float(gs[fin].max()) if bool(fin.any()) else 0.0
    # the Poisson(g) weights beyond g + 12√g + 20 are below 1e-30 of the sum
    terms = int(min(2000, math.ceil(gmax + 12 * math.sqrt(gmax) + 20)))
    total = torch.zeros_like(g * b)
    for m in range(1, terms + 1):
        log_t = m * log_g - gs - math.lgamma(m + 1) - math.log(m) - b / m
        total = total + torch.exp(log_t)
    return torch.where(pos, total, torch.zeros_like(total))


def _he_dd(lam, n_med, n_sub, ci, co, cphi, sigma, tau, shadowing: bool):
    """He's directional-diffuse BRDF in a lossless medium n_med, unchecked (sr⁻¹).

    Directions point away from the surface: in = (sin θi, 0, cos θi),
    out = (sin θr cos φ, sin θr sin φ, cos θr); the mirror direction has cos φ = −1.
    """
    # guard: sin θ = √(1 − cos²θ) has an infinite slope in cos θ at normal incidence; its
    # derivative there is reported as 0 (as lookup_film_reflectance does), not 0·∞ = NaN
    si = _checks.safe_sqrt(1 - ci * ci)
    so = _checks.safe_sqrt(1 - co * co)
    # v = k_r − k_i = in + out (unit-free); v_xy² = |xy(in + out)|²
    vx = si + so * cphi
    vy2 = so * so * (1 - cphi * cphi)
    vxy2 = vx * vx + vy2
    vz = ci + co
    vv = vxy2 + vz * vz
    # He eq. 76; its polarization bracket [(ŝr·k̂i)²+(p̂r·k̂i)²][(ŝi·k̂r)²+(p̂i·k̂r)²]/|k̂i×k̂r|⁴ is
    # identically 1 ((ŝ, p̂, k̂) is orthonormal, so each bracket is 1 − (k̂i·k̂r)² = |k̂i×k̂r|²)
    vz_safe = torch.where(vz == 0, torch.ones_like(vz), vz)  # (not `vz > 0`: NaN must stay NaN)
    G = (vv / vz_safe) ** 2
    if shadowing:
        S = _shadowing(ci, sigma, tau) * _shadowing(co, sigma, tau)
        sig = _effective_roughness(ci, co, sigma, tau)
    else:
        S = torch.ones_like(ci)
        sig = sigma
    k_med = (2 * math.pi) * n_med / lam  # wavenumber in the medium, nm⁻¹
    g = _g(lam, n_med * ci, n_med * co, sig)
    b = (k_med * k_med) * vxy2 * (tau * tau) / 4
    D = (math.pi**2 / 4) * (tau * n_med / lam) ** 2 * _series_D(g, b)
    # Fresnel at the local (bisector) angle: cos θ_b = sqrt((1 + in·out)/2)
    cos_b = torch.sqrt(torch.clamp(0.5 * vv / 2, min=0, max=1))  # |in+out|² = 2(1 + in·out)
    F = fresnel_reflectance.__wrapped__(cos_b, n_med, n_sub)  # (the body: its arguments are checked)
    den = math.pi * ci * co
    grazing = den == 0  # (not `den > 0`: a NaN direction must give NaN, not 0)
    rho = F * G * S * D / torch.where(grazing, torch.ones_like(den), den)
    return torch.where(grazing, torch.zeros_like(rho), rho)  # grazing: S = 0, no light scattered


@_checks.arguments(wavelength=_checks.WAVELENGTH, cos_theta_i=_checks.COSINE, cos_theta_o=_checks.COSINE,
                   cos_phi=COS_PHI, sigma=SIGMA, tau=TAU, n_substrate=_checks.INDEX, n_incident=N_MEDIUM)
def he_directional_diffuse(
    wavelength, cos_theta_i, cos_theta_o, cos_phi, sigma, tau, n_substrate, *, n_incident=1.0, shadowing: bool = True
) -> torch.Tensor:
    r"""He–Torrance directional-diffuse BRDF of a rough interface (He et al. 1991, eq. 76–84).

    .. math::
        ρ_{dd} = \frac{|F(θ_b)|^2}{π}\,\frac{G\,S\,D}{\cos θ_i \cos θ_r}, \qquad
        D = \frac{π^2 τ^2}{4 λ_n^2} \sum_{m=1}^{∞} \frac{g^m e^{-g}}{m!\,m}
            \exp\Big(-\frac{v_{xy}^2 τ^2}{4m}\Big),

    with ``λ_n = λ/n`` the wavelength in the medium, :math:`\vec v = k_n(\hat k_r − \hat k_i)`,
    ``G = (v·v / v_z)²`` (unit-free v; the polarization bracket of eq. 76 is identically 1),
    ``S = S(θ_i) S(θ_r)`` (``he_shadowing()``), ``g`` (``roughness_factor()``) from the
    effective roughness (``effective_roughness()``), and F the unpolarized Fresnel
    reflectance at the bisector angle ``cos θ_b = √((1 + ω_i·ω_r)/2)``.  The exponent uses the
    dimensional :math:`v_{xy} = k_n |\hat k_r − \hat k_i|_{xy}` (Beckmann's form; some
    implementations drop the k²).  Symmetric in (light, view).  ``shadowing=False`` uses S = 1
    and σ₀ itself.

    Args:
        wavelength: vacuum wavelength in nm (> 0).
        cos_theta_i, cos_theta_o: cosines of the (outward) light and view directions, [0, 1].
        cos_phi: cosine of the azimuth between them, [-1, 1] (−1: mirror plane, same side as
            the mirror direction).
        sigma: rms roughness σ₀ in nm (≥ 0); tau: autocorrelation length τ in nm (> 0).
        n_substrate: index ``n + iκ`` below the interface; n_incident: real index above it.

    Returns:
        ρ_dd in sr⁻¹ (≥ 0), 0 when σ₀ = 0.

    Example (Al-like n = 1 + 6.6i, σ₀ = 25 nm, τ = 300 nm, normal light, view 10° off):
        >>> import torch, math
        >>> v = math.cos(math.radians(10))
        >>> rho = he_directional_diffuse(torch.tensor(550.0, dtype=torch.float64), 1.0, v, -1.0, 25.0, 300.0, 1 + 6.6j)
        >>> round(float(rho), 5)
        0.20217
    """
    return _he_dd(wavelength, n_incident, n_substrate, cos_theta_i, cos_theta_o, cos_phi, sigma, tau, shadowing)
