r"""Colour of a Bragg mirror: the exact Yeh spectrum integrated against the CMFs.

``bragg_xyz`` integrates :func:`torchirid.bragg_reflectance` over wavelength against the
colour matching functions and an illuminant (:func:`torchirid.color.xyz_weights`), with
the normalisation of :func:`torchirid.color.spectrum_to_xyz` (a perfect reflector has
Y = 1). Methods (one registry, :data:`BRAGG_XYZ_METHODS`):

``"spectral"`` — converged. The spectrum of N cells oscillates ~N times per photonic band
    in ω = 2π/λ: its phase is the Bloch phase KΛ ≈ ω·(n1 d1 cos θ1 + n2 d2 cos θ2), so the
    number of fringes over the visible range is at most

    .. math:: F = N \,(n_1 d_1 + n_2 d_2)\,(\omega_{max} - \omega_{min}) / \pi .

    Samples are uniform in ω, ``samples_per_fringe`` (default 192) per fringe, at least 401,
    and at most ``max_samples`` (262 144). How we know it converged: quadrupling the
    sampling moves no colour by more than ~0.03 ΔE2000 for the N ≤ 50, Λ ≤ 1 µm mirrors
    tested (``tests/spectral/test_bragg_color.py``, asserted ≤ 0.05).
    Grazing angles converge slowest (fringes sharpen there): half the default sampling leaves
    errors above that bound at θ = 89°, hence the default of 192.

``"sampled"`` — ``samples`` wavelengths uniform in λ over ``wavelength_range`` (the cheap
    fixed-sampling variants of the speed-against-error study; 1–5 nm grids alias the
    sub-nm fringes of large-N mirrors).

``"piecewise"`` — the paper's fast approximation (§3.2): boxes between spectral
    landmarks weighted by the envelope, integrated with cumulative CMF tables
    (:mod:`torchirid.spectral.piecewise`).

``"envelope"`` — the piecewise method's fringe-averaged spectrum sampled at ``samples``
    (default 64) nodes uniform in ω and integrated exactly as a piecewise-linear function (no
    landmarks: :mod:`torchirid.spectral.envelope`); same scope as ``"piecewise"``.

``"auto"`` — the cheapest of the above that meets ``tolerance`` (ΔE2000, 95th percentile)
    at this call's batch size, chosen from measured error/cost tables
    (:mod:`torchirid.spectral.auto`).

Domains of validity (the measured errors per fringe count: docs/performance.md, "Bragg mirror
colour: the method choice", ``benchmarks/bragg_color_domain.py``):

* ``"spectral"``: every mirror (absorbing layers, any incident medium, total internal
  reflection); within ~0.03 ΔE2000 of 2× its sampling; it warns when ``max_samples`` caps it.
* ``"sampled"``: every mirror; its error grows with the fringes per sample (K ≥ ~10 samples per
  fringe for p95 ≤ 1), so large-N mirrors alias.
* ``"piecewise"``, ``"envelope"``: lossless mirrors embedded in n1 without total internal
  reflection, with at least ``MIN_FRINGES`` = 8 fringes in the
  range (:func:`~torchirid.spectral.sampling.fringe_count`): there their p95 error is a few
  ΔE2000 at most; below it (short periods, or few cells) they are far off and emit a
  RuntimeWarning (``tests/spectral/test_domain.py`` checks both sides).
  ``"envelope"`` is the library's fast default: on the speed-vs-error Pareto front at every Λ of
  Fourneau's Fig. 4 grid, where the paper's landmark method is not everywhere (the front:
  docs/performance.md).
"""

from __future__ import annotations

import math
import warnings

import torch

from .. import _autograd, _checks, _chunks, _threads
from ..color.colorimetry import check_illuminant, check_observer
from ..color.convert import xyz_weights_kernel
from ..optics.bragg import bragg_reflectance_kernel, prepare_bragg_mirror
from .envelope import bragg_xyz_envelope
from .piecewise import bragg_xyz_piecewise
from .sampling import spectral_samples

__all__ = ["BRAGG_XYZ_METHODS", "bragg_xyz"]

#: method names accepted by :func:`bragg_xyz`
BRAGG_XYZ_METHODS = ("spectral", "sampled", "piecewise", "envelope", "auto")


def _wavelengths(method, K, wavelength_range, dtype, device):
    lo, hi = wavelength_range
    if method == "sampled":
        return torch.linspace(lo, hi, K, dtype=dtype, device=device)
    omega = torch.linspace(2 * math.pi / hi, 2 * math.pi / lo, K, dtype=dtype, device=device)
    return torch.flip(2 * math.pi / omega, dims=(0,))  # uniform in ω, increasing in λ


def _colours(*args, **kwargs) -> int:
    """The work of a ``bragg_xyz`` call for the thread policy: colours × 256 (1 colour if the
    mirror arguments are missing or do not broadcast — the call then reports them)."""
    names = ("cos_theta", "n1", "n2", "d1", "d2")
    values = list(args[:5]) + [kwargs.get(n) for n in names[len(args[:5]):]]
    try:
        return math.prod(_checks.broadcast_shapes(*(tuple(getattr(x, "shape", ())) for x in values))) * 256
    except Exception:
        return 256


# a few colours are many small ops: one torch thread (torchirid._threads; measured there)
@_autograd.inference_when_no_grad  # (no gradient wanted: every method runs in inference mode)
@_threads.limited_by(_colours)
def bragg_xyz(
    cos_theta,
    n1,
    n2,
    d1,
    d2,
    cells,
    *,
    n_incident=None,
    polarization: str = "unpolarized",
    method: str = "spectral",
    observer: str = "CIE 1931 2",
    illuminant: str = "D65",
    samples: int | None = None,
    samples_per_fringe: float = 192.0,
    max_samples: int = 262144,
    wavelength_range=(380.0, 780.0),
    subdivisions: int = 8,
    weights: str = "averaged",
    correction="fitted",
    tolerance: float = 1.0,
) -> torch.Tensor:
    r"""CIE XYZ of a Bragg mirror (Fourneau et al. 2024, §3.1–3.2), Y = 1 for a perfect reflector.

    Args:
        cos_theta, n1, n2, d1, d2, cells, n_incident, polarization: as in
            :func:`torchirid.bragg_reflectance` (nm, cosines; broadcast together).
        method: ``"spectral"`` (converged, default), ``"sampled"`` (``samples``
            wavelengths uniform in λ), ``"piecewise"``, ``"envelope"`` or ``"auto"``; see the
            module docstring.
        observer, illuminant: names from :mod:`torchirid.color` (``"CIE 1931 2"``,
            ``"CIE 1964 10"``, ``"Stiles & Burch 1959 10"``; ``"D65"``, ``"D50"``, ``"A"``, ``"E"``).
        samples: number of wavelengths for ``"sampled"`` (required there); for
            ``"spectral"`` it overrides the automatic count; for ``"envelope"`` the ω nodes
            (default 64).
        samples_per_fringe, max_samples: the ``"spectral"`` sampling rule.
        wavelength_range: ``(λ_min, λ_max)`` in nm integrated over (default 380–780 nm).
        tolerance: ΔE2000 (95th percentile) that ``method="auto"`` must meet; it picks the
            cheapest of the other methods from measured tables
            (``torchirid.spectral.auto.choose_bragg_method``).
        subdivisions, correction: options of ``"piecewise"`` (see
            :func:`torchirid.spectral.piecewise.bragg_xyz_piecewise`); ``cells`` is not used
            there beyond validation (the approximation models large N).

    Returns:
        XYZ ``(*, 3)``: the broadcast batch of the mirror parameters, dtype/device from them.

    Example (Fourneau Fig. 1's mirror at normal incidence: a saturated colour):
        >>> import torch, torchirid
        >>> xyz = torchirid.bragg_xyz(torch.tensor(1.0, dtype=torch.float64), 1.0, 1.5, 125.0, 375.0, 20)
        >>> [round(v, 3) for v in xyz.tolist()]
        [0.203, 0.074, 0.772]
    """
    _checks.check_polarization(polarization)
    _checks.check_choice(method, "method", BRAGG_XYZ_METHODS)
    _checks.check_numbers(cos_theta=cos_theta, n1=n1, n2=n2, d1=d1, d2=d2, n_incident=n_incident)
    lo, hi = _checks.check_wavelength_range(wavelength_range)
    if method == "auto":
        from .auto import choose_bragg_method

        choice = choose_bragg_method(cos_theta, n1, n2, d1, d2, cells, n_incident=n_incident, tolerance=tolerance,
                                     wavelength_range=(lo, hi))
        options = dict(observer=observer, illuminant=illuminant, wavelength_range=(lo, hi))
        return bragg_xyz(cos_theta, n1, n2, d1, d2, cells, n_incident=n_incident, polarization=polarization,
                         **options, **choice["config"])
    if method in ("piecewise", "envelope"):
        if n_incident is not None:
            with torch.no_grad():
                same = bool((torch.as_tensor(n_incident) == torch.as_tensor(n1)).all())
            if not same:
                raise ValueError(f"method={method!r} models a mirror embedded in n1: n_incident must be None or n1")
        if isinstance(n1, complex) or isinstance(n2, complex) or any(
                torch.is_tensor(t) and t.is_complex() for t in (n1, n2)):
            raise ValueError(f"method={method!r} needs real n1 and n2 (lossless layers)")
        if method == "envelope":  # (bragg_xyz_envelope validates samples)
            return bragg_xyz_envelope(cos_theta, n1, n2, d1, d2, cells, polarization=polarization,
                                      samples=64 if samples is None else samples, observer=observer,
                                      illuminant=illuminant, wavelength_range=(lo, hi))
        return bragg_xyz_piecewise(cos_theta, n1, n2, d1, d2, cells, polarization=polarization, subdivisions=subdivisions,
                                   weights=weights,
                                   correction=correction, observer=observer, illuminant=illuminant,
                                   wavelength_range=(lo, hi))
    if method == "sampled" and samples is None:
        raise ValueError("samples (number of wavelengths) is required for method='sampled'")
    if samples is not None:
        _checks.check_int(samples, "samples", 2)
    if not samples_per_fringe > 0:
        raise ValueError(f"samples_per_fringe must be > 0; got {samples_per_fringe!r}")
    check_observer(observer)
    check_illuminant(illuminant)
    # the mirror checked once here (its values too), then the unchecked reflectance kernel per block
    dtype, c, n1t, n2t, d1t, d2t, nh, N = prepare_bragg_mirror(cos_theta, n1, n2, d1, d2, cells, n_incident)
    device = c.device
    if samples is None:
        samples = spectral_samples(n1, n2, d1, d2, N, wavelength_range=(lo, hi),
                                   samples_per_fringe=samples_per_fringe, max_samples=max_samples)
        if samples == max_samples:
            warnings.warn(f"bragg_xyz: the spectrum needs more than max_samples={max_samples} samples to "
                          "converge (very many cells); the colour is not converged", RuntimeWarning, stacklevel=2)
    lam = _wavelengths(method, samples, (lo, hi), dtype, device)
    W = xyz_weights_kernel(lam, observer, illuminant)  # (K, 3), Y column sums to 1 (the grid is ours)

    def trailing(t):  # mirror parameters gain a wavelength axis
        return t.unsqueeze(-1) if t.ndim else t

    args = [trailing(t) for t in (c, n1t, n2t, d1t, d2t)]
    host = None if nh is None else trailing(nh)
    Nw = trailing(N)
    batch = _checks.broadcast_shapes(*(a.shape[:-1] if a.ndim else () for a in args + [Nw]),
                                     *(() if host is None or host.ndim == 0 else (host.shape[:-1],)))
    # wavelengths per block: batch × wavelengths ≤ the block size (torchirid._chunks; None: all at once)
    chunk = _chunks.get_chunk_size(device)
    step = samples if chunk is None else max(1, chunk // max(1, math.prod(batch)))
    n_max = int(cells) if isinstance(cells, int) and not isinstance(cells, bool) else None
    xyz = None
    for k in range(0, samples, step):  # chunks over wavelength bound the memory, not a loop over samples
        R = bragg_reflectance_kernel(lam[k:k + step], *args, host, Nw, polarization=polarization, n_max=n_max)
        part = R @ W[k:k + step]
        xyz = part if xyz is None else xyz + part
    return xyz
