r"""Composite reflectance and transmittance of a smooth multilayer (Hirayama et al. 2000, §3.2).

The stack is ``indices[..., 0] | layer 1 | … | layer L | indices[..., L+1]``: a real
incident medium (medium A), ``L`` films of thickness ``thicknesses[..., j-1]`` and an exit
medium (medium B), any of the films or the exit medium possibly absorbing (``n + iκ``).

Hirayama's recursion (eq. 1–4, appendix A) runs from the last interface to the first:

.. math::

    γ_0 = r_{L+1},\quad τ_0 = t_{L+1}, \qquad
    γ_{L-j+1} = \frac{r_j + γ_{L-j}\, e^{2iφ_j}}{1 + r_j γ_{L-j}\, e^{2iφ_j}}, \qquad
    τ_{L-j+1} = \frac{t_j τ_{L-j}\, e^{iφ_j}}{1 + r_j γ_{L-j}\, e^{2iφ_j}},

with :math:`φ_j = 2π q_j d_j / λ` and ``q = n cos θ`` on the branch ``Im q ≥ 0``.  Only the
decaying factors :math:`|e^{iφ}| = e^{-\mathrm{Im}\,φ} ≤ 1` are ever formed, never
:math:`e^{+\mathrm{Im}\,φ}`: a micrometre of metal underflows to exactly zero transmission
and the reflectance of the bulk metal, with no clamping of the phase.

:func:`multilayer` runs the recursion as a fraction ``γ = N / D`` (three complex multiply-adds
per film, both polarizations in one pass, ``|τ|²`` telescoped; ``_transfer_fast``), with
``t_j = 2η_{j-1}/(η_{j-1} + η_j)`` (no cancellation where ``r → −1``). :func:`recursion` below is
the division form, used by the thin film and as the tests' reference. Exactly at grazing
incidence R is the limit ``cos θ → 0``: 1, or 0 for a stack invisible there.
"""

from __future__ import annotations

import math

import torch

from .. import _checks, _chunks
from ._transfer_fast import reflect_transmit
from ._transfer_scan import fits, reflect_transmit_scan
from .fresnel import admittance, interface, normal_wavenumber, nudge_critical

__all__ = ["multilayer"]


def stack_admittances(q: torch.Tensor, n: torch.Tensor, polarization: str) -> torch.Tensor:
    """Admittances η of every medium, stacked on a new leading polarization axis."""
    return torch.stack([admittance(q, n, pol) for pol in _checks.polarization_terms(polarization)])


def align_polarization_axis(eta: torch.Tensor, other_batch) -> torch.Tensor:
    """Insert singleton axes after the leading polarization axis of ``eta[P, *B, M]`` so that
    its batch broadcasts against ``other_batch`` without meeting the polarization axis."""
    batch = _checks.broadcast_shapes(eta.shape[1:-1], other_batch)
    pad = len(batch) - (eta.ndim - 2)
    return eta.reshape(eta.shape[0], *([1] * pad), *eta.shape[1:])


def recursion(eta: torch.Tensor, e1: torch.Tensor, e2: torch.Tensor, with_transmission: bool = True):
    r"""Hirayama's recursion (eq. 1–4) on admittances ``eta[..., L+2]``.

    ``e1 = exp(iφ_j)`` and ``e2 = exp(2iφ_j)`` for the ``L`` inner layers (``[..., L]``).
    Returns the composite amplitudes (γ, τ); τ is built from ``t_ij = 1 + r_ij``
    (admittance-normalised, see :mod:`torchirid.optics.fresnel`) and is ``None`` when
    ``with_transmission`` is False.
    """
    eta = align_polarization_axis(eta, e2.shape[:-1])
    e1, e2 = e1[None], e2[None]
    r = interface(eta[..., :-1], eta[..., 1:])  # r_j between media j-1 and j, [..., L+1]
    L = e2.shape[-1]
    gamma = r[..., L]
    tau = 1 + gamma if with_transmission else None
    for j in range(L - 1, -1, -1):
        rj = r[..., j]
        ge2 = gamma * e2[..., j]
        den = 1 + rj * ge2
        if _checks.traceable() or bool((den == 0).any()):
            # guard: with critical films nudged, 0/0 remains only at grazing incidence, where a
            # zero- or half-wave film sits between media that both look like the incident one
            # (η = 0): the film is invisible and nothing is reflected (nor transmitted at grazing)
            degenerate = den == 0
            safe = torch.where(degenerate, torch.ones_like(den), den)
            gamma = torch.where(degenerate, torch.zeros_like(den), (rj + ge2) / safe)
            if with_transmission:
                tau = torch.where(degenerate, torch.zeros_like(den), (1 + rj) * tau * e1[..., j] / safe)
            continue
        gamma = (rj + ge2) / den
        if with_transmission:
            tau = (1 + rj) * tau * e1[..., j] / den
    return gamma, tau


def interface_amplitudes(eta_i: torch.Tensor, eta_j: torch.Tensor):
    """``r = (η_i − η_j)/(η_i + η_j)`` and ``|t|² = |2η_i / (η_i + η_j)|²`` (``t = 1 + r`` without
    its cancellation where r → −1: near a film's critical angle, near grazing); ``|t|² = 1``
    where the two media are the same (r = 0, also at grazing where η_i = η_j = 0)."""
    r = interface(eta_i, eta_j)
    den = eta_i + eta_j
    same = den == 0
    den2 = torch.where(same, torch.ones_like(den.real), den.real * den.real + den.imag * den.imag)
    num2 = 4 * (eta_i.real * eta_i.real + eta_i.imag * eta_i.imag)
    return r, torch.where(same, torch.ones_like(den2), num2 / den2)


def stack_normal_wavenumbers(c, n, cdt):
    """Normal wavenumbers ``q = n cos θ`` of every medium ``[..., L+2]`` (Im q ≥ 0; critical
    films nudged) and the indices broadcast to ``q``'s shape, for a validated cosine ``c``
    (grazing flushed) and indices ``n``, in the complex dtype ``cdt``. ``q`` has the batch of
    ``c`` and ``n`` only (no wavelength axis)."""
    n0 = n[..., 0].real if n.is_complex() else n[..., 0]
    s2 = n0 * n0 * (1 - c * c)  # Snell invariant (n0 sin θ0)^2
    nc = n.to(cdt)
    q0 = (n0 * c).to(cdt)  # incident medium: exact, no sqrt (gradient-safe at grazing)
    q_inner = normal_wavenumber(nc[..., 1:], s2[..., None], n0[..., None], q0[..., None])
    q0, q_inner = torch.broadcast_tensors(q0[..., None], q_inner)
    films = nudge_critical(q_inner[..., :-1], nc[..., 1:-1], (c > 0)[..., None])
    q = torch.cat([q0[..., :1], films, q_inner[..., -1:]], dim=-1)
    nc_b = nc.expand(q.shape) if nc.shape != q.shape else nc
    return q, nc_b


def stack_wavenumbers(lam, c, n, d):
    """Normal wavenumbers ``q = n cos θ`` of every medium ``[..., L+2]`` (Im q ≥ 0; critical
    films nudged), the film phase factors ``e1 = exp(iφ_j)``, ``e2 = e1²`` ``[..., L]`` and the
    indices broadcast to ``q``'s shape, for validated real ``lam``, cosine ``c`` (grazing
    flushed), indices ``n`` and thicknesses ``d``. Used by the rough multilayer."""
    q, nc_b = stack_normal_wavenumbers(c, n, _checks.complex_dtype(lam.dtype))
    # phase φ_j = 2π q_j d_j / λ of the films; only decaying exponentials are formed
    phi = (2 * math.pi) * q[..., 1:-1] * d / lam[..., None]
    e1 = torch.exp(1j * phi)
    return q, e1, e1 * e1, nc_b


def stack_pieces(c: torch.Tensor, n: torch.Tensor, polarization: str):
    """What a stack of fixed indices contributes before its thicknesses: the interface amplitudes
    ``r`` and ``|t|²`` ``[P, *batch, L+1]`` (the last scaled by ``Re η_B / η_A``, so that
    ``stack_response`` returns T) and ``2π q`` of the films ``[*batch, L]``, for checked
    cosines ``c`` (0 < c ≤ 1) and indices ``n [..., L+2]`` broadcasting against ``c``.

    The design optimisers compute these once per problem and call ``stack_response`` for
    every population of thicknesses."""
    q, nc = stack_normal_wavenumbers(c, n, _checks.complex_dtype(c.dtype))
    eta = stack_admittances(q, nc, polarization)
    r, t2 = interface_amplitudes(eta[..., :-1], eta[..., 1:])
    flux = eta[..., -1].real / eta[..., 0].real  # eq. 6: T = Re(η_B)/η_A |τ|² (c > 0: η_A > 0)
    t2 = torch.cat([t2[..., :-1], t2[..., -1:] * flux[..., None]], dim=-1)
    return r, t2, (2 * math.pi) * q[..., 1:-1]


def stack_response(r: torch.Tensor, t2: torch.Tensor, kq: torch.Tensor, d: torch.Tensor, u: torch.Tensor, batch):
    """(R, T) ``[*batch]`` (mean over the polarizations of ``r``) of the pieces of
    ``stack_pieces``, thicknesses ``d [..., L]`` and ``u = 1/λ``; ``batch`` is the broadcast
    shape of ``kq[..., 0] * d[..., 0]``, ``u`` and the pieces' batch.

    Small batches (≤ ``_transfer_scan.MAX_POINTS`` points) take the tree of 2×2 products, larger
    ones (and any point where that leaves the normal range) the film loop of :func:`multilayer`."""
    r = align_polarization_axis(r, batch)
    t2 = align_polarization_axis(t2, batch)
    k = kq * d
    out = reflect_transmit_scan(r, t2, k, u, batch) if fits(k.shape[-1], r.shape[0], batch) else None
    R, T = reflect_transmit(r, t2, k, u, batch) if out is None else out
    return _polarization_mean(R).clamp(0, 1), _polarization_mean(T).clamp(0, 1)


def stack_fluxes(c: torch.Tensor, n: torch.Tensor, d: torch.Tensor, u: torch.Tensor, polarization: str) -> torch.Tensor:
    r"""Net power crossing each interface downwards, as a fraction of the incident power:
    ``F [*batch, L+1]`` (mean over the polarizations), ``F_0 = 1 − R``, ``F_L = T``; film ``j``
    absorbs ``F_j − F_{j+1}``. For checked cosines ``c`` (0 < c ≤ 1), indices ``n [..., L+2]``,
    thicknesses ``d [..., L]`` and ``u = 1/λ``, broadcasting together.

    The tangential fields ``(E, H)`` (``H = ±ηE`` for the down- and up-going waves) are carried
    from a unit transmitted wave in the exit medium up through each film's characteristic matrix

    .. math:: \begin{pmatrix} E \\ H \end{pmatrix}_{top} = \begin{pmatrix} \cos δ & -i \sin δ / η \\
              -i η \sin δ & \cos δ \end{pmatrix} \begin{pmatrix} E \\ H \end{pmatrix}_{bottom},
              \qquad δ = 2π q d / λ,

    the growing direction for absorbing films (no cancellation), rescaled after every film (the
    scales kept as logarithms); then :math:`F_j = \mathrm{Re}(E_j H_j^*) / (η_0 |a|^2)` with the
    incident amplitude :math:`a = (E_0 + H_0/η_0)/2`."""
    q, nc = stack_normal_wavenumbers(c, n, _checks.complex_dtype(c.dtype))
    L = q.shape[-1] - 2
    phase = (2 * math.pi) * q[..., 1:-1] * d * u[..., None]  # δ_j [..., L]
    out = 0
    terms = _checks.polarization_terms(polarization)
    for pol in terms:
        eta = admittance(q, nc, pol)
        E = torch.ones_like(eta[..., -1])
        H = eta[..., -1]
        log_scale = [torch.zeros_like(E.real)]
        fields = [(E, H)]
        for j in range(L - 1, -1, -1):
            cs, sn, e = torch.cos(phase[..., j]), torch.sin(phase[..., j]), eta[..., j + 1]
            E, H = cs * E - 1j * sn / e * H, -1j * e * sn * E + cs * H
            m = torch.maximum(E.abs(), H.abs())
            E, H = E / m, H / m
            log_scale.append(log_scale[-1] + torch.log(m))
            fields.append((E, H))
        eta0 = eta[..., 0].real
        a2 = ((E + H / eta0) * 0.5).abs() ** 2
        top = log_scale[-1]
        flux = [(Ej * Hj.conj()).real * torch.exp(2 * (s - top)) / (eta0 * a2)
                for (Ej, Hj), s in zip(fields, log_scale)]
        out = out + torch.stack(flux[::-1], dim=-1)
    return out / len(terms)


def _polarization_mean(x: torch.Tensor) -> torch.Tensor:
    """Mean over the leading polarization axis (1 or 2 entries): ``(x_s + x_p) / 2``, one add on
    the batch instead of a reduction."""
    return x[0] if x.shape[0] == 1 else (x[0] + x[1]) * 0.5


def check_stack_shape(n: torch.Tensor, d: torch.Tensor) -> None:
    """ValueError unless ``indices`` (``n``) has ``len(thicknesses) + 2`` entries on its last axis."""
    _checks.check_last_dim(n, "indices", at_least=2)
    _checks.check_last_dim(d, "thicknesses")
    if n.shape[-1] != d.shape[-1] + 2:
        raise ValueError(
            f"indices must have len(thicknesses) + 2 entries on the last axis (incident medium, "
            f"{d.shape[-1]} films, exit medium); got {n.shape[-1]}"
        )


@_checks.arguments(wavelength=_checks.WAVELENGTH, cos_theta=_checks.COSINE, indices=_checks.INDEX,
                   thicknesses=_checks.THICKNESS, polarization=_checks.POLARIZATION)
def multilayer(wavelength, cos_theta, indices, thicknesses, *, polarization: str = "unpolarized"):
    r"""Reflectance and transmittance of a smooth multilayer film (Hirayama 2000, eq. 1–6).

    Args:
        wavelength: vacuum wavelength λ in nm (> 0). Shape ``(*)``.
        cos_theta: cosine of the incidence angle in the incident medium, in [0, 1]. Shape ``(*)``.
        indices: refractive indices ``n + iκ`` (κ ≥ 0) of all media, ``(*, L+2)``: the
            incident medium first (must be real), then the L films, then the exit medium.
        thicknesses: film thicknesses in nm (≥ 0), ``(*, L)``.
        polarization: ``"s"``, ``"p"`` or ``"unpolarized"`` (mean of s and p).

    Returns:
        ``(R, T)``: reflectance and transmittance, broadcast batch shape, real dtype of the
        inputs. ``T`` is the power that crosses the last interface into the exit medium (the
        Poynting flux just inside it, :math:`T = \mathrm{Re}(η_B)\,|τ|^2/η_A`, eq. 6), as the
        ``tmm`` package and colour-science define it — also when the exit medium absorbs
        (κ > 0), where that power is then absorbed in the substrate. ``1 − R − T`` is the power
        absorbed in the films; ``R + T = 1`` when the films are lossless. ``T = 0`` for an
        evanescent exit wave (total internal reflection) and at grazing incidence. (Models that
        need the light coming back *out* of an opaque base, Hirayama's ``k_t``, use
        :func:`~torchirid.optics.film_stack.film_reflectance`.)

    Example (quarter-wave layer of index 1.5 on glass 2.25: R = 0 at 600 nm):
        >>> import torch, torchirid
        >>> R, T = torchirid.multilayer(torch.tensor(600.0, dtype=torch.float64), 1.0,
        ...                             torch.tensor([1.0, 1.5, 2.25]), torch.tensor([100.0]))
        >>> round(float(R), 12), round(float(T), 12)
        (0.0, 1.0)
    """
    check_stack_shape(indices, thicknesses)
    _checks.check_real_index(indices[..., 0], "indices[..., 0] (incident medium)")
    return multilayer_kernel(wavelength, cos_theta, indices, thicknesses, polarization)


def multilayer_kernel(lam, c, n, d, polarization: str):
    """:func:`multilayer` on checked tensors (same dtype and device, broadcastable, a valid stack):
    block by block over large batches without a gradient (torchirid._chunks)."""
    batch = _checks.broadcast_shapes(lam.shape, c.shape, n.shape[:-1], d.shape[:-1], names=_ARGUMENTS)
    # block by block over large batches (torchirid._chunks); n and d carry one trailing stack axis
    return _chunks.evaluate(_multilayer_core, (lam, c, n, d), batch, core=(0, 0, 1, 1),
                            polarization=polarization)


#: the arguments whose shapes broadcast (named in the error of those that do not)
_ARGUMENTS = ("wavelength", "cos_theta", "indices[..., 0]", "thicknesses[..., 0]")


def _multilayer_core(lam, c, n, d, *, polarization):
    """(R, T) of validated inputs (the body of :func:`multilayer`, one block of the batch)."""
    batch = _checks.broadcast_shapes(lam.shape, c.shape, n.shape[:-1], d.shape[:-1])
    dtype = lam.dtype
    q, nc_b = stack_normal_wavenumbers(_checks.flush_grazing(c), n, _checks.complex_dtype(dtype))
    eta = align_polarization_axis(stack_admittances(q, nc_b, polarization), batch)  # [P, *Bq, L+2]
    r, t2 = interface_amplitudes(eta[..., :-1], eta[..., 1:])  # [P, *Bq, L+1]
    # eq. 6: T = Re(η_B)/η_A |τ|^2, the Poynting flux just inside the exit medium (τ is the
    # tangential-field amplitude of the admittance form, so this holds for complex η_B too);
    # the factor rides on the exit interface's |t|², so that the kernel returns T directly
    eta0 = eta[..., 0].real
    grazing = eta0 == 0  # grazing incidence carries no power in (a NaN input is not grazing)
    safe0 = torch.where(grazing, torch.ones_like(eta0), eta0)
    flux = torch.where(grazing, torch.zeros_like(eta0), eta[..., -1].real / safe0)
    t2 = torch.cat([t2[..., :-1], t2[..., -1:] * flux[..., None]], dim=-1)
    k = (2 * math.pi) * q[..., 1:-1] * d  # film phases φ_j = k_j / λ
    R, T = reflect_transmit(r, t2, k, 1 / lam, batch)  # |γ|², T per polarization: [P, *batch]
    if _checks.traceable() or bool(grazing.any()):
        # exactly at grazing (η = 0 in every medium of the incident index) the recursion holds only
        # rounding where the stack meets 0/0 (zero-thickness films between such media): R is the
        # limit cos θ → 0 there, 1 unless nothing is visible (every film of another index has
        # d = 0 and the exit medium has the incident index), then 0 (a NaN input stays NaN)
        visible = ((eta[..., 1:-1] != 0) & (d > 0)).any(-1) | (eta[..., -1] != 0)
        R = torch.where(grazing & ~R.isnan(), visible.to(R.dtype), R)
    R = _polarization_mean(R).clamp(0, 1)  # |γ|² ≤ 1 up to an ulp
    T = _polarization_mean(T).clamp(0, 1)
    return R.expand(batch), T.expand(batch)
