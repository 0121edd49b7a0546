r"""Multilayer films on a locally smooth *rough* surface (Hirayama et al. 2000, §4.2, eq. 8–17)
with the He–Torrance rough-interface model (He, Torrance, Sillion & Greenberg 1991).

Geometry (Hirayama §4.2): the films' own boundaries stay flat and parallel; only the
interface between the last film and the substrate (interface ``L+1`` of the stack
``indices[..., 0] | film 1 | … | film L | indices[..., L+1]``) is rough, a Gaussian random
height field of rms height σ₀ (nm) and Gaussian autocorrelation length τ (nm), the last
film's thickness being its *mean* thickness.  With no film (``L = 0``) the substrate itself
is rough and the model is He–Torrance in the incident medium.

Light reflected by such a surface splits into (He 1991, §4)

* a **coherent specular** part, the ensemble-averaged field: the rough interface reflects
  the amplitude :math:`r_{L+1}\,e^{-g/2}` (eq. 9, the paper's ``η(ω, ω)``), which then enters
  Hirayama's smooth recursion (eq. 10 = eq. 3) → :func:`rough_multilayer_reflectance`;
* an **incoherent directional-diffuse** part, scattered once by the rough interface into
  all directions, reaching the outside through the film stack → :func:`rough_multilayer_diffuse`
  (eq. 11–17, a BRDF in sr⁻¹).

The roughness factor g (He eq. 79), the shadowing and the directional-diffuse BRDF of the
rough interface are :mod:`torchirid.optics.he_torrance`.

Derivation of eq. 9 (the paper writes only "η is a ratio of amplitudes"): in the Kirchhoff
approximation the field reflected by a facet at height ``h`` carries the phase
:math:`e^{2ikqh}` (``k = 2π/λ``) relative to the mean plane; averaged over a Gaussian ``h``
of variance σ², :math:`⟨e^{i a h}⟩ = e^{-a^2σ^2/2}` gives the coherent amplitude
:math:`r\,e^{-2k^2q^2σ^2} = r\,e^{-g/2}` (g at ``θ_i = θ_r``), i.e. the specular *power*
:math:`|r|^2 e^{-g}` of He eq. 31.  He's shadowing ``S(θ)²`` (eq. 24–25) multiplies the
power, so the amplitude gets ``S(θ)``, and σ is He's effective roughness (eq. 80–83); both
are 1 and σ₀ at moderate angles for τ ≫ σ₀ and can be switched off (``shadowing=False``,
the plain ``g`` of Hirayama's text).  σ₀ = 0 gives ``η = r`` and the smooth eq. 1–5
*exactly*.

Derivation of eq. 11–17 (the printed equations are garbled: eq. 16 only has the multiple
reflections of the *incoming* direction, the ratio in eq. 13/17 lacks the direction labels,
and the intensity normalisation of η(ω_l, ω_i) is not given).  One diffuse scattering event
at the rough interface (the paper's "primary reflection of the diffuse component"), with any
number of coherent specular bounces before it (direction ``l``) and after it (direction
``i``).  Summing the bounces of a direction is eq. 4 with the seed ``γ₀ = η_s`` (the coherent
reflectivity above) and ``τ₀ = 1``: the amplitude of the downward wave at the bottom of film
L.  Its power flux per unit mean area, relative to the incident one, is

.. math:: T_{0→L}(θ) = \frac{\mathrm{Re}\,η_L}{η_0}\,|τ_L(θ)|^2

(the same normalisation as eq. 6; it *is* eq. 6 for the stack cut below film L when the
interface is removed).  The rough interface turns that irradiance in film L into radiance
``ρ_L(l_L → i_L)·T_{0→L}(l)·E`` (He's directional-diffuse BRDF in the medium of film L,
wavelength λ/n_L), and the upward radiance leaves the stack with the power transmittance
``T_{L→0}(i) = T_{0→L}(i)`` (reciprocity of the transmittance of any stack, absorbing films
included) and the radiance factor (n₀/n_L)² of refraction.  So

.. math:: k_d(ω_l, ω_i, λ) = \Big(\frac{n_0}{n_L}\Big)^2\,T_{0→L}(θ_l)\,
          ρ_L(ω_{l,L}, ω_{i,L})\,T_{0→L}(θ_i),

which is |γ_{d,L}|² of eq. 15–17 written per layer as
:math:`γ_{d,L-j+1} = t_j(l)\,t'_j(i)\,e^{i(φ_{l,j}+φ_{i,j})}\,γ_{d,L-j}
/[(1 + r_j γ_{s,L-j}(l) e^{2iφ_{l,j}})(1 + r_j γ_{s,L-j}(i) e^{2iφ_{i,j}})]` — eq. 16 with
the second denominator restored.  With it ``k_d`` is reciprocal, ``k_d(l, i) = k_d(i, l)``;
without it, it is not.  The phases cancel in the power (a single diffusely scattered wave
has no partner to interfere with); absorption in the films stays, through ``|e^{iφ}|``.
The uniform-diffuse (subsurface) term of He's model is 0: the substrates here are opaque.
Polarization: He's diffuse lobe is the unpolarized one; ``T`` is averaged over s and p on
each side (``polarization="s"``/``"p"`` uses that polarization's ``T``).

Energy: ``k_r(θ_l) + ∫ k_d(ω_l, ω_i) cos θ_i dω_i ≤ 1`` (tests integrate the hemisphere).
The medium directly above the rough interface (film L, or the incident medium when L = 0)
must be lossless: a diffuse radiance inside an absorbing medium is not defined.
"""

from __future__ import annotations

import math

import torch

from .. import _checks
from .fresnel import admittance, interface
from .transfer import check_stack_shape, stack_wavenumbers
from .he_torrance import _check_cos_phi, _check_roughness, _effective_roughness, _g, _he_dd, _shadowing
# the He–Torrance functions of one rough interface, also importable from here
from .he_torrance import (coherent_attenuation, effective_roughness, he_directional_diffuse,  # noqa: F401
                          he_shadowing, roughness_factor)

__all__ = [
    "rough_multilayer_reflectance",
    "rough_multilayer_diffuse",
]

# ---------------------------------------------------------------------------------------
# films on the rough surface (Hirayama eq. 9–17)
# ---------------------------------------------------------------------------------------


def _prepare(wavelength, cosines: dict, indices, thicknesses, sigma, tau, polarization, dtype, device):
    """Validate the stack and roughness (before any work); returns tensors."""
    _checks.check_polarization(polarization)
    lam = _checks.as_real(wavelength, "wavelength", dtype, device)
    cos = {k: _checks.as_real(v, k, dtype, device) for k, v in cosines.items()}
    n = _checks.as_index(indices, "indices", dtype, device)
    d = _checks.as_real(thicknesses, "thicknesses", dtype, device)
    s = _checks.as_real(sigma, "sigma", dtype, device)
    t = _checks.as_real(tau, "tau", dtype, device)
    check_stack_shape(n, d)
    _checks.check_wavelength(lam)
    for k, v in cos.items():
        _checks.check_cosine(v, k)
    _checks.check_nonnegative(d, "thicknesses")
    _checks.check_index(n, "indices")
    _checks.check_real_index(n[..., 0], "indices[..., 0] (incident medium)")
    _checks.check_real_index(n[..., -2], "indices[..., -2] (the medium above the rough interface)")
    _check_roughness(s, t)
    # the batch of the stack state includes the roughness axes: the rough seed η_s (P, *batch)
    # must not meet σ or τ's own axes at the polarization axis (a σ-only batch was averaged)
    lam = lam.expand(_checks.broadcast_shapes(lam.shape, s.shape, t.shape))
    return lam, cos, n, d, s, t


def _stack_state(lam, c, n, d, polarization):
    """Snell cosines, phases and admittances of the stack for incidence cosine ``c`` (as in
    :func:`torchirid.multilayer`): returns q [..., L+2], e1, e2 [..., L], eta [P, ..., L+2]."""
    q, e1, e2, nc_b = stack_wavenumbers(lam, _checks.flush_grazing(c), n, d)
    pols = _checks.polarization_terms(polarization)
    batch = _checks.broadcast_shapes(q.shape[:-1], e2.shape[:-1])

    def lead(x):  # (*b, K) → (P, *batch, K): the polarization axis never meets a batch axis
        x = x.expand(*batch, x.shape[-1])
        return x[None].expand(len(pols), *batch, x.shape[-1])

    q = q.expand(*batch, q.shape[-1])
    eta = torch.stack([admittance(q, nc_b.expand(q.shape), p) for p in pols])
    return q, lead(e1), lead(e2), eta


def _recurse(eta, e1, e2, seed):
    """Hirayama eq. 3–4 from the rough interface up, with γ₀ = ``seed`` and τ₀ = 1.

    Returns (γ, τ): the composite reflectivity and the amplitude of the downward wave at the
    bottom of the last film (admittance-normalised t = 1 + r, as in torchirid.multilayer)."""
    r = interface(eta[..., :-1], eta[..., 1:])
    L = e2.shape[-1]
    gamma = seed
    tau = torch.ones_like(seed)
    for j in range(L - 1, -1, -1):
        rj = r[..., j]
        ge2 = gamma * e2[..., j]
        den = 1 + rj * ge2
        degenerate = den == 0
        if _checks.traceable() or bool(degenerate.any()):
            # guard (as in multilayer): 0/0 only at grazing, where the film is invisible
            safe = torch.where(degenerate, torch.ones_like(den), den)
            gamma = torch.where(degenerate, torch.zeros_like(den), (rj + ge2) / safe)
            tau = torch.where(degenerate, torch.zeros_like(den), (1 + rj) * tau * e1[..., j] / safe)
            continue
        gamma = (rj + ge2) / den
        tau = (1 + rj) * tau * e1[..., j] / den
    return gamma, tau


def _rough_seed(lam, q, eta, c_last, sigma, tau, shadowing):
    """η_s of eq. 9: r_{L+1} e^{-g/2} (× S(θ_L) with shadowing), per polarization."""
    r_last = interface(eta[..., -2], eta[..., -1])
    qL = q[..., -2].real  # real part: an evanescent wave in film L (Re q = 0) sees no roughness
    if shadowing:
        sig = _effective_roughness(c_last, c_last, sigma, tau)
        S = _shadowing(c_last, sigma, tau)
    else:
        sig, S = sigma, torch.ones_like(c_last)
    g = _g(lam, qL, qL, sig)
    amp = torch.exp(-0.5 * g) * S
    # an evanescent wave in film L (Re q = 0 < Im q) is not a grazing ray: no roughness loss
    evanescent = (q[..., -2].real == 0) & (q[..., -2].imag > 0)
    amp = torch.where(evanescent, torch.ones_like(amp), amp)
    return r_last * amp.to(r_last.dtype)


def _last_cos(q, n):
    """cos θ in the last film (the medium above the rough interface): Re(q_L)/n_L in [0, 1]."""
    nL = n[..., -2].real if n.is_complex() else n[..., -2]
    return torch.clamp(q[..., -2].real / nL, 0, 1), nL


def rough_multilayer_reflectance(
    wavelength,
    cos_theta,
    indices,
    thicknesses,
    sigma,
    tau,
    *,
    polarization: str = "unpolarized",
    shadowing: bool = True,
) -> torch.Tensor:
    r"""Coherent specular reflectance k_r of films on a rough surface (Hirayama 2000, eq. 9, 10, 5).

    .. math::
        γ_{s,0} = η(ω_{i,L}, ω_{i,L}, λ) = r_{L+1}\,e^{-g/2}\,S(θ_L), \qquad
        γ_{s,L-j+1} = \frac{r_j + γ_{s,L-j} e^{2iφ_j}}{1 + r_j γ_{s,L-j} e^{2iφ_j}}, \qquad
        k_r = \tfrac12(|γ_{s,L}^{∥}|^2 + |γ_{s,L}^{⊥}|^2),

    with ``g = (4π σ q_L / λ)²`` (``q_L = n_L cos θ_L`` in the last film; see the module
    docstring for the derivation).  σ = 0 reproduces :func:`torchirid.multilayer`'s R exactly.

    Args:
        wavelength: vacuum wavelength λ in nm (> 0), ``(*)``.
        cos_theta: incidence cosine in the incident medium, [0, 1], ``(*)``.
        indices: ``(*, L+2)`` indices ``n + iκ``: incident medium (real), L films (the last one
            lossless), substrate.
        thicknesses: ``(*, L)`` film thicknesses in nm (the last one: the mean thickness).
        sigma: rms roughness σ₀ of the film/substrate interface in nm (≥ 0), ``(*)``.
        tau: its autocorrelation length τ in nm (> 0), ``(*)``; used by ``shadowing`` only.
        polarization: ``"s"``, ``"p"`` or ``"unpolarized"``.
        shadowing: He's shadowing S and effective roughness (True), or the plain e^{-g} (False).

    Returns:
        k_r in [0, 1], the broadcast batch shape.

    Example (Hirayama Fig. 8 stack dielectric/Ag/dielectric on Al at 550 nm, normal incidence):
        >>> import torch
        >>> n = torch.tensor([1.0, 1.4, 0.0596 + 3.5974j, 1.4, 1.0152 + 6.6273j], dtype=torch.complex128)
        >>> d = torch.tensor([1000.0, 5.0, 1000.0], dtype=torch.float64)
        >>> lam = torch.tensor(550.0, dtype=torch.float64)
        >>> [round(float(rough_multilayer_reflectance(lam, 1.0, n, d, s, 300.0)), 4) for s in (0.0, 25.0, 50.0)]
        [0.9247, 0.6487, 0.2563]
    """
    dtype, device = _checks.resolve_dtype_device(wavelength, cos_theta, indices, thicknesses, sigma, tau)
    lam, cos, n, d, s, t = _prepare(
        wavelength, {"cos_theta": cos_theta}, indices, thicknesses, sigma, tau, polarization, dtype, device
    )
    c = cos["cos_theta"]
    q, e1, e2, eta = _stack_state(lam, c, n, d, polarization)
    cL, _ = _last_cos(q, n)
    seed = _rough_seed(lam, q, eta, cL, s, t, shadowing)
    gamma, _ = _recurse(eta, e1, e2, seed)
    R = (gamma.real**2 + gamma.imag**2).mean(0).clamp(0, 1)  # |γ|² ≤ 1 up to an ulp
    batch = _checks.broadcast_shapes(lam.shape, c.shape, n.shape[:-1], d.shape[:-1], s.shape, t.shape)
    return R.expand(batch)


def _transmittance_to_last(lam, q, e1, e2, eta, seed):
    """T_{0→L} = Re(η_L)/η_0 |τ|² per polarization (eq. 6's normalisation)."""
    _, tau = _recurse(eta, e1, e2, seed)
    eta0 = eta[..., 0].real
    grazing = eta0 == 0
    safe0 = torch.where(grazing, torch.ones_like(eta0), eta0)
    T = (tau.real**2 + tau.imag**2) * eta[..., -2].real / safe0
    return torch.where(grazing, torch.zeros_like(T), T)  # grazing incidence carries no power in


def stack_transmittance_to_last_film(
    wavelength,
    cos_theta,
    indices,
    thicknesses,
    sigma,
    tau,
    *,
    polarization: str = "unpolarized",
    shadowing: bool = True,
) -> torch.Tensor:
    r"""Power reaching the rough interface: the flux :math:`T_{0→L}` of the downward wave at
    the bottom of the last film per unit incident flux (eq. 4 seeded with γ₀ = η_s, τ₀ = 1).

    .. math:: T_{0→L} = \frac{\mathrm{Re}\,η_L}{η_0} |τ_L|^2

    (η = q for s, q/n² for p; averaged over s and p for ``"unpolarized"``).  With no roughness
    *and no substrate contrast* (substrate = last film) it is :func:`torchirid.multilayer`'s
    T of the stack.  It is also the upward transmittance ``T_{L→0}`` (reciprocity), the factor
    of :func:`rough_multilayer_diffuse` on each side.  Arguments as in
    :func:`rough_multilayer_reflectance`.

    Example (no film: all the incident power reaches the interface):
        >>> import torch
        >>> float(stack_transmittance_to_last_film(torch.tensor(500.0, dtype=torch.float64), 0.5,
        ...       torch.tensor([1.0, 1.5 + 0.1j]), torch.zeros(0), 20.0, 300.0))
        1.0
    """
    dtype, device = _checks.resolve_dtype_device(wavelength, cos_theta, indices, thicknesses, sigma, tau)
    lam, cos, n, d, s, t = _prepare(
        wavelength, {"cos_theta": cos_theta}, indices, thicknesses, sigma, tau, polarization, dtype, device
    )
    c = cos["cos_theta"]
    q, e1, e2, eta = _stack_state(lam, c, n, d, polarization)
    cL, _ = _last_cos(q, n)
    seed = _rough_seed(lam, q, eta, cL, s, t, shadowing)
    T = _transmittance_to_last(lam, q, e1, e2, eta, seed).mean(0)
    batch = _checks.broadcast_shapes(lam.shape, c.shape, n.shape[:-1], d.shape[:-1], s.shape, t.shape)
    return T.expand(batch)


def rough_multilayer_diffuse(
    wavelength,
    cos_theta_i,
    cos_theta_o,
    cos_phi,
    indices,
    thicknesses,
    sigma,
    tau,
    *,
    polarization: str = "unpolarized",
    shadowing: bool = True,
) -> torch.Tensor:
    r"""Directional-diffuse BRDF k_d of films on a rough surface (Hirayama 2000, eq. 11–17, 8).

    .. math::
        k_d(ω_l, ω_i, λ) = \Big(\frac{n_0}{n_L}\Big)^2\,T_{0→L}(θ_l)\,
        ρ_{dd}(ω_{l,L}, ω_{i,L}; λ/n_L)\,T_{0→L}(θ_i)

    — one He–Torrance scattering (:func:`he_directional_diffuse`, in the last film, between the
    refracted directions ``cos θ_L = Re(q_L)/n_L``, same azimuth) between two passes through
    the stack with all the coherent specular bounces (``stack_transmittance_to_last_film()``).
    This is |γ_{d,L}|² of eq. 15–17 with the multiple-reflection denominator of the *outgoing*
    direction restored (derivation in the module docstring); it is reciprocal in (l, i).
    Used in eq. 8 as ``Σ_m k_d cos θ_l L_m``.

    Args:
        wavelength: vacuum wavelength λ in nm (> 0).
        cos_theta_i, cos_theta_o: cosines of the light and view directions in the incident medium, [0, 1].
        cos_phi: cosine of the azimuth between light and view, [-1, 1] (−1: mirror plane).
        indices, thicknesses, sigma, tau, polarization, shadowing: as in
            :func:`rough_multilayer_reflectance`.

    Returns:
        k_d in sr⁻¹ (≥ 0), 0 when σ = 0; the broadcast batch shape.

    Example (bare Al-like substrate, L = 0: He–Torrance itself):
        >>> import torch, math
        >>> v = math.cos(math.radians(10))
        >>> kd = rough_multilayer_diffuse(torch.tensor(550.0, dtype=torch.float64), 1.0, v, -1.0,
        ...                               torch.tensor([1.0, 1 + 6.6j]), torch.zeros(0), 25.0, 300.0)
        >>> round(float(kd), 5)
        0.20217
    """
    dtype, device = _checks.resolve_dtype_device(
        wavelength, cos_theta_i, cos_theta_o, cos_phi, indices, thicknesses, sigma, tau
    )
    cp = _checks.as_real(cos_phi, "cos_phi", dtype, device)
    lam, cos, n, d, s, t = _prepare(
        wavelength,
        {"cos_theta_i": cos_theta_i, "cos_theta_o": cos_theta_o},
        indices,
        thicknesses,
        sigma,
        tau,
        polarization,
        dtype,
        device,
    )
    _check_cos_phi(cp)
    cl, cv = cos["cos_theta_i"], cos["cos_theta_o"]
    ql, e1l, e2l, etal = _stack_state(lam, cl, n, d, polarization)
    qv, e1v, e2v, etav = _stack_state(lam, cv, n, d, polarization)
    clL, nL = _last_cos(ql, n)
    cvL, _ = _last_cos(qv, n)
    Tl = _transmittance_to_last(lam, ql, e1l, e2l, etal, _rough_seed(lam, ql, etal, clL, s, t, shadowing)).mean(0)
    Tv = _transmittance_to_last(lam, qv, e1v, e2v, etav, _rough_seed(lam, qv, etav, cvL, s, t, shadowing)).mean(0)
    n0 = n[..., 0].real if n.is_complex() else n[..., 0]
    rho = _he_dd(lam, nL, n[..., -1], clL, cvL, cp, s, t, shadowing)
    kd = (n0 / nL) ** 2 * Tl * rho * Tv
    batch = _checks.broadcast_shapes(
        lam.shape, cl.shape, cv.shape, cp.shape, n.shape[:-1], d.shape[:-1], s.shape, t.shape
    )
    return kd.expand(batch)
