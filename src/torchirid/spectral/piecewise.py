r"""Fast Bragg colour: piecewise-constant spectra on spectral landmarks (Fourneau et al. 2024, §3.2.2).

The reflectance spectrum is replaced by boxes between the landmarks of
:mod:`torchirid.spectral.landmarks` (band-gap edges, Airy points, zero points and the ends
of the range), :math:`\tilde R_\omega = \sum_j w_j B_j(\omega)` (eq. 14), with

* :math:`w_j = 1` inside band gaps (the envelope is 1 there);
* :math:`w_j = \tilde w(\theta)\, R^e_\omega\big((\omega_j + \omega_{j+1})/2\big)` outside,
  the envelope (eq. 11) at the box centre times the angular correction (appendix B,
  :func:`torchirid.spectral.correction.angular_correction`);

and its colour is a sum of differences of the cumulative CMF tables in ω (eq. 15–16,
:func:`torchirid.spectral.cumulative.shipped_cumulative_cmf_lut`): one table lookup per landmark.
With ``subdivisions = s`` a box outside the gaps that belongs to mode m (the nearest mode
below it) is cut into max(1, s − m) equal sub-boxes in ω, each with its own envelope
value ("sub." in the paper; ``s = 1`` is the basic "app."). Each polarization has its own
landmarks; ``"unpolarized"`` averages the two XYZ.

Scope: the mirror embedded in n1 (``n_incident`` = None or n1) with real indices and light
propagating in n2 (the paper's setting); other mirrors raise ``ValueError`` — use
``method="spectral"``. The approximation does not depend on the number of cells: it
models large N (the paper assumes ≥ 95 % reflectance in the gaps). Gradients flow through
the box weights, the correction and the landmark positions (implicit-function theorem).

Cost: the landmarks of both polarizations are found in one batch (4 Newton steps
in a-priori brackets, one sine per step, :mod:`torchirid.spectral.landmarks`; ~80 small
elementwise ops), clamped into the range (no padding masks), sorted once with the gap weights
riding along, and the sub-boxes are laid out compactly (only the non-empty ones, padded to the
largest count in the batch with zero-width ones; each finds its box by a running count of the
box starts) and integrated against the cumulative table in one gather and one batched matrix
product: ~370 ops per call in all, run in inference mode when no gradient is wanted.
With ``torchirid.options(compile=True)`` the two stages around the one host sync (the compact
length) are two compiled kernels (landmarks + box layout; sub-boxes + table lookup, its final
sum as one fused reduction): worth it for repeated calls on large grids only, since a one-off
compile precedes the first call (not yet measured in docs/performance.md).
"""

from __future__ import annotations

import math

import torch

from .. import _autograd, _checks, _chunks, _compile
from .correction import angular_correction
from .cumulative import shipped_cumulative_cmf_lut
from .landmarks import HALVINGS, _counts, clamped_landmarks, dispersion_parts
from .._cache import cache_dict

__all__ = ["bragg_xyz_piecewise"]

#: Newton steps for the landmarks of a colour (one fewer than :mod:`~torchirid.spectral.landmarks`'
#: default, which converges the positions to ~1e-14): 4 steps leave the landmarks within ~1e-7
#: (relative) and the colour within 1e-6 ΔE2000 of the converged one (measured at
#: s = 8: 6e-7 on Fourneau's Fig. 4 grid, 3.5e-9 on grazing high-contrast mirrors with n2 up to
#: 10 and N = 50; 3 steps: 2.9e-3), ~5 % of the cost of a call (tests/spectral/test_bragg_color.py)
NEWTON_STEPS = 4


@_autograd.inference_when_no_grad  # (no gradient wanted: the ~370 small ops ~10 % faster)
def bragg_xyz_piecewise(cos_theta, n1, n2, d1, d2, cells, *, polarization="unpolarized", subdivisions: int = 8,
                        weights="averaged", correction="fitted", observer="CIE 1931 2", illuminant="D65",
                        wavelength_range=(380.0, 780.0)) -> torch.Tensor:
    r"""XYZ of a Bragg mirror embedded in n1 from its piecewise-constant spectrum (Fourneau eq. 14–16).

    Args:
        cos_theta: cosine of the incidence angle in n1, in [0, 1].
        n1, n2: real refractive indices (n2 must be reached: n2 ≥ n1 sin θ).
        d1, d2: layer thicknesses (nm).
        polarization: ``"s"``, ``"p"`` or ``"unpolarized"``.
        subdivisions: s ≥ 1 (1 = the basic approximation; the paper uses 3).
        correction: ``"fitted"`` (the library's fit of appendix B), ``"paper"`` (0.735, 0.532),
            ``"none"`` (w̃ = 1) or a pair ``(a, b)``.
        observer, illuminant, wavelength_range: as :func:`torchirid.spectral.bragg_xyz`.

    Returns:
        XYZ ``(*, 3)``, Y = 1 for a perfect reflector.

    Example (Fourneau's Fig. 1 mirror at 0° and 60°; a gradient with respect to d1):
        >>> import torch
        >>> cos_theta = torch.tensor([1.0, 0.5], dtype=torch.float64)
        >>> d1 = torch.tensor(125.0, dtype=torch.float64, requires_grad=True)  # nm
        >>> xyz = bragg_xyz_piecewise(cos_theta, 1.0, 1.5, d1, 375.0, 20)
        >>> xyz.shape
        torch.Size([2, 3])
        >>> [round(v, 3) for v in xyz[0].tolist()]  # the full spectrum gives (0.203, 0.074, 0.772)
        [0.199, 0.072, 0.754]
        >>> xyz[:, 1].sum().backward()
        >>> d1.grad is not None
        True
    """
    _checks.check_polarization(polarization)
    _checks.check_int(subdivisions, "subdivisions", 1)
    if isinstance(correction, str):
        if correction not in ("fitted", "paper", "none"):
            raise ValueError(f"correction must be 'fitted', 'paper', 'none' or a pair (a, b); got {correction!r}")
    if weights not in ("averaged", "paper"):
        raise ValueError(f"weights must be 'averaged' or 'paper'; got {weights!r}")
    mirror = _embedded_mirror(cos_theta, n1, n2, d1, d2, cells, polarization, wavelength_range, "piecewise")
    _check_domain(mirror, "piecewise")
    invalid = _non_finite_mirrors(mirror)  # NaN in, NaN out (the landmark counts need finite mirrors)
    lo, hi = mirror["range"]
    omega_min, omega_max = 2 * math.pi / hi, 2 * math.pi / lo
    dtype, device = mirror["A"].dtype, mirror["A"].device
    table = shipped_cumulative_cmf_lut(observer, illuminant, (lo, hi), dtype=dtype, device=device)
    white = _packed(table)[3]  # XYZ of R ≡ 1: C̄(ω_max), the table's last node
    if weights == "paper":
        w_corr = angular_correction(mirror["cos"], mirror["n1"], mirror["n2"], coefficients=_coefficients(correction))
    else:  # the fringe-averaged weights do not use the correction
        w_corr = torch.ones((), dtype=dtype, device=device)
    # block by block over large batches (torchirid._chunks): per colour P × (landmark boxes) values;
    # the polarization axis moves last to ride along as a core axis
    A, B, N = mirror["A"], mirror["B"], mirror["N"]
    delta, C_coef = mirror["delta"], mirror["C_coef"]
    batch = _checks.broadcast_shapes(A.shape, B.shape, N.shape, delta.shape[1:], C_coef.shape[1:], w_corr.shape)
    xyz = _chunks.evaluate(_piecewise_block, (A, B, delta.movedim(0, -1), C_coef.movedim(0, -1), w_corr, N), batch,
                           core=(0, 0, 1, 1, 0, 0), out_core=2, width=delta.shape[0] * 64, omega_min=omega_min,
                           omega_max=omega_max, subdivisions=subdivisions, table=table,
                           weights=weights).movedim(-2, 0)
    out = xyz[0] if xyz.shape[0] == 1 else 0.5 * (xyz[0] + xyz[1])
    if invalid is not None:
        out = torch.where(invalid.unsqueeze(-1), float("nan"), out)
    grazing = mirror["grazing"]
    if not bool(grazing.any()):
        return out
    return torch.where(grazing.unsqueeze(-1), white.expand_as(out), out)


#: Fewest fringes in the integration range (:func:`torchirid.spectral.sampling.fringe_count`) for which the
#: fringe-averaging methods (``piecewise``, ``envelope``) are inside their measured domain:
#: p95 ΔE2000 ≤ 2.2 from 8 fringes up, 7–27 below (``benchmarks/bragg_color_domain.py``, 14 625
#: colours: n2 1.5–2.4, N 5–100, Λ 10–988 nm, θ 0–84°). Short periods (Λ ≲ 80 nm: the first
#: band in the UV) and few cells (N = 5) fall below it.
MIN_FRINGES = 8.0


def _check_domain(mirror, method: str) -> None:
    """RuntimeWarning when some colours have fewer than ``MIN_FRINGES`` fringes in the range
    (the fringe average is then not what the CMFs see; measured ΔE2000 up to ~30). A value check:
    off under ``torchirid.options(value_checks=False)``, like the others (it reads the values back to the host)."""
    if not _checks.value_checks_enabled():
        return
    lo, hi = mirror["range"]
    with torch.no_grad():
        F = mirror["N"] * (mirror["A"] + mirror["B"]) * (2 * (1 / lo - 1 / hi))
        few = (F < MIN_FRINGES) & ~mirror["grazing"]  # (NaN compares False: NaN mirrors give NaN anyway)
        if not bool(few.any()):
            return
        count, total = int(few.sum()), few.numel()
        fmin = float(torch.where(few, F, torch.full_like(F, math.inf)).min())
    _checks.warn_caller(
        f"bragg_xyz(method={method!r}): {count} of {total} colours have fewer than {MIN_FRINGES:g} fringes in "
        f"{lo:g}–{hi:g} nm (fewest {fmin:.3g}: short periods or few cells), outside the method's measured "
        "domain (ΔE2000 up to ~30 there); use method='auto' or 'spectral' for them "
        "(torchirid.spectral.sampling.fringe_count tells which)")


def _non_finite_mirrors(mirror):
    """Mask ``(*)`` of the mirrors with a non-finite parameter (NaN or ∞ inputs), or None when all
    are finite (one check). Where set, ``mirror``'s A, B, δ, C_coef are replaced in place by a
    harmless finite mirror (no landmarks, R = 0), whose colour the caller replaces by NaN."""
    A, B, delta, C_coef = mirror["A"], mirror["B"], mirror["delta"], mirror["C_coef"]
    bad = ~torch.isfinite(A + B + delta.sum(0) + C_coef.sum(0))
    if not bool(bad.any()):
        return None
    one = torch.ones((), dtype=A.dtype, device=A.device)
    mirror["A"] = torch.where(bad, one, A)
    mirror["B"] = torch.where(bad, one, B)
    mirror["delta"] = torch.where(bad, 0 * one, delta)
    mirror["C_coef"] = torch.where(bad, 0 * one, C_coef)
    return bad


def _embedded_mirror(cos_theta, n1, n2, d1, d2, cells, polarization, wavelength_range, method):
    """Validated parameters of a lossless mirror embedded in n1, in the ω form of
    :mod:`torchirid.spectral.landmarks` (shared by the piecewise and envelope methods).

    Returns a dict: ``cos`` (cos θ1 with grazing entries set to 1), ``grazing`` (cos θ1 = 0,
    where R ≡ 1), ``n1``, ``n2``, ``N``, optical thicknesses ``A``, ``B`` (*,), and
    ``delta`` = Ω/2 − 1, ``C_coef`` (|C|² = C_coef sin² ωB) with the polarizations as a
    leading axis (P, *); ``range`` = (λ_min, λ_max)."""
    dtype, device = _checks.resolve_dtype_device(cos_theta, n1, n2, d1, d2)
    N = _checks.as_cells(cells, device)
    c = _checks.as_real(cos_theta, "cos_theta", dtype, device)
    n1 = _checks.as_real(n1, "n1", dtype, device)
    n2 = _checks.as_real(n2, "n2", dtype, device)
    d1 = _checks.as_real(d1, "d1", dtype, device)
    d2 = _checks.as_real(d2, "d2", dtype, device)
    _checks.check_cosine(c)
    _checks.check_index(n1, "n1")
    _checks.check_index(n2, "n2")
    _checks.check_nonnegative(d1, "d1")
    _checks.check_nonnegative(d2, "d2")
    lo, hi = _checks.check_wavelength_range(wavelength_range)
    s2 = n1 * n1 * (1 - c * c)
    if _checks.value_checks_enabled() and bool((n2 * n2 - s2 < 0).any()):
        raise ValueError(f"the {method} method needs light propagating in n2 (no total internal reflection); "
                         "use method='spectral'")
    grazing = c == 0  # R = 1 at every wavelength: the colour of the perfect reflector
    cs = torch.where(grazing, torch.ones_like(c), c)  # guard: the branch used at grazing is the white
    q1 = n1 * cs
    q2 = torch.sqrt(torch.clamp(n2 * n2 - n1 * n1 * (1 - cs * cs), min=0))
    A, B = q1 * d1, q2 * d2
    # the polarizations are one leading batch dimension P: one pass for both
    etas = [(q1, q2) if pol == "s" else (q1 / (n1 * n1), q2 / (n2 * n2)) for pol in _checks.polarization_terms(polarization)]
    batch = _checks.broadcast_shapes(A.shape, B.shape, N.shape, *(e.shape for pair in etas for e in pair))
    eta1 = torch.stack([e[0].expand(batch) for e in etas])
    eta2 = torch.stack([e[1].expand(batch) for e in etas])
    safe2 = torch.where(eta2 > 0, eta2, torch.ones_like(eta2))
    delta = (eta1 - eta2) ** 2 / (2 * eta1 * safe2)  # Ω/2 − 1
    C_coef = ((eta1 * eta1 - eta2 * eta2) / (2 * eta1 * safe2)) ** 2  # |C|² = C_coef sin²(ωB)
    return {"cos": cs, "grazing": grazing, "n1": n1, "n2": n2, "N": N, "A": A, "B": B, "delta": delta,
            "C_coef": C_coef, "range": (lo, hi)}


def _coefficients(correction):
    if isinstance(correction, str):
        return {"fitted": None, "paper": "paper", "none": (0.0, 1.0)}[correction]
    return correction


def _attach(landmarks, m, A, B, delta, omega_min, omega_max):
    """Landmarks with gradients: the implicit-function theorem on their defining equations.

    For a root ω* of f(ω; θ) found numerically, ω* − (f(ω*; θ) − f(ω*; θ̄)) / ∂_ω f(ω*; θ̄)
    (θ̄ detached) has the value ω* and the derivative −∂_θ f / ∂_ω f. Landmarks on the range
    ends (clipped there by :func:`~torchirid.spectral.landmarks.clamped_landmarks`), and
    touching (closed) gaps where ∂_ω f = 0, keep no gradient.
    """
    Ax, Bx, dx = (t.unsqueeze(-1) for t in (A, B, delta))
    even = torch.remainder(m, 2) == 0
    airy, e_lo, e_hi, zeros = landmarks

    def x_half(w, a, b_, d):  # x = ((1 + x) − (1 − x)) / 2, from the product forms
        omx, opx = dispersion_parts(w, a, b_, d)
        return 0.5 * (opx - omx)

    def edge_f(w, a, b_, d):  # 1 − |x| near the mode of the gap
        omx, opx = dispersion_parts(w, a, b_, d)
        return torch.where(even, omx, opx)

    def attach(w, f):
        ok = (w > omega_min) & (w < omega_max)  # clipped to the range: constant
        w0 = torch.where(ok, w, torch.zeros_like(w)).detach().requires_grad_(True)
        with torch.enable_grad():
            fw = f(w0, Ax.detach(), Bx.detach(), dx.detach())
            (slope,) = torch.autograd.grad(fw.sum(), w0)
        w0 = w0.detach()
        usable = ok & (slope.abs() > 0)
        safe = torch.where(usable, slope, torch.ones_like(slope))
        f_live = f(w0, Ax, Bx, dx)
        moved = w0 - (f_live - f_live.detach()) / safe
        return torch.where(usable, moved, w)

    airy = attach(airy, x_half)
    e_lo = attach(e_lo, edge_f)
    e_hi = attach(e_hi, edge_f)
    # zero points ω_z = zπ/B (eq. 12) are explicit in B
    inside = (zeros > omega_min) & (zeros < omega_max)
    zeros = torch.where(inside, zeros * (Bx.detach() / Bx), zeros)
    return airy, e_lo, e_hi, zeros


_PACKED: dict = cache_dict()


@_autograd.normal_tensors
def _packed(table):
    """``(P, ω₀, h, C̄(ω_n))``: the cumulative table uniform in ω (first node ω₀, step h) as rows
    P[i] = (C̄(ω_i), C̄(ω_{i+1}) − C̄(ω_i)) of its n − 1 cells (one gather per lookup), and its
    value at the last node."""
    key = id(table)
    hit = _PACKED.get(key)
    if hit is None or hit[0] is not table:
        grid, v = table.axes["omega"], table.values
        if bool((v[0] != 0).any()):  # :func:`_fill` drops the C̄(ω_min) term
            raise ValueError("a cumulative CMF table must start at 0 (C̄(ω_min) = 0)")
        packed = torch.cat([v[:-1], v[1:] - v[:-1]], dim=-1).contiguous()
        hit = (table, (packed, float(grid[0]), float(grid[-1] - grid[0]) / (grid.numel() - 1), v[-1].clone()))
        _PACKED[key] = hit
    return hit[1]


def _lookup_rows(packed, omega0, step, x):
    """The packed rows (P₀, P₁) of :func:`_packed` under ``x`` (``x.shape + (6,)``) and the
    fractions f, so that C̄(x) = P₀ + f P₁ (linear interpolation, clamped to the table)."""
    cells = packed.shape[0]
    pos = (x - omega0) / step
    i = pos.clamp(0, cells - 1).to(torch.int64)  # floor (≥ 0); x at (or by rounding just past) the ends: f = 1 or ~0
    rows = packed.index_select(0, i.reshape(-1)).reshape(x.shape + (packed.shape[-1],))
    return rows, pos - i


def _piecewise_block(A, B, delta, C_coef, w_corr, N, *, omega_min, omega_max, subdivisions, table, weights):
    """XYZ ``(*, P, 3)`` of one block of mirrors (polarizations last in ``delta``, ``C_coef``)."""
    xyz = _piecewise_xyz(A, B, delta.movedim(-1, 0), C_coef.movedim(-1, 0), w_corr, omega_min, omega_max,
                         subdivisions, table, weights, N)
    return xyz.movedim(0, -2)


def _piecewise_xyz(A, B, delta, C_coef, w_corr, omega_min, omega_max, s, table, weights="averaged", N=None):
    """XYZ ``(P, *, 3)`` of the boxes; ``delta``, ``C_coef`` carry the polarizations in front."""
    A, B, delta, C_coef, w_corr, N = torch.broadcast_tensors(A, B, delta, C_coef, w_corr, N.to(A.dtype))
    with torch.no_grad():
        m, z, _ = _counts(omega_min, omega_max, A, B)  # data-dependent sizes: eager, one sync
    tab = _packed(table)[:3]
    averaged = weights == "averaged"
    if torch.is_grad_enabled() and any(t.requires_grad for t in (A, B, delta, C_coef, w_corr)):
        with torch.no_grad():  # landmark positions by Newton steps
            landmarks = clamped_landmarks(omega_min, omega_max, A.detach(), B.detach(), delta.detach(), m, z,
                                          HALVINGS, NEWTON_STEPS)
        landmarks = _attach(landmarks, m, A, B, delta, omega_min, omega_max)
        boxes = _layout(A, B, delta, C_coef, N, w_corr, landmarks, omega_min, omega_max, s, averaged)
        return _fill(A, B, delta, C_coef, w_corr, *boxes, _compact_length(boxes[0]), *tab, averaged)
    with torch.no_grad():
        # two stages around one host sync (the compact sub-box count T); each ~100–200 small
        # elementwise ops: one fused kernel each when compiled (opt-in, torchirid.options(compile=True))
        front = _compile.kernel("piecewise_landmarks", _front, _front_static, m.numel())
        boxes = front(A, B, delta, C_coef, N, w_corr, m, z, omega_min, omega_max, s, averaged, HALVINGS, NEWTON_STEPS)
        T = _compact_length(boxes[0])
        fill = _compile.kernel("piecewise_boxes", _fill, _fill_static, m.numel())
        return fill(A, B, delta, C_coef, w_corr, *boxes, T, *tab, averaged)


def _front(A, B, delta, C_coef, N, w_corr, m, z, omega_min, omega_max, s, averaged, halvings, steps,
           static=False):
    """Landmarks (:func:`~torchirid.spectral.landmarks.clamped_landmarks`) and the box layout
    (:func:`_layout`)."""
    landmarks = clamped_landmarks(omega_min, omega_max, A, B, delta, m, z, halvings, steps)
    return _layout(A, B, delta, C_coef, N, w_corr, landmarks, omega_min, omega_max, s, averaged, static)


def _front_static(*args):
    """:func:`_front` without data-dependent branches (for ``torch.compile``)."""
    return _front(*args, static=True)


def _compact_length(start):
    """T = the largest sub-box count of the batch (one host sync): the start of the last box
    (the empty sentinel of :func:`_layout`)."""
    return int(start[..., -1].max()) if start.numel() else 0


def _parts(omega, A, B, delta):
    """(1 − x, 1 + x, sin ωB) at ω (:func:`~torchirid.spectral.landmarks.dispersion_parts`,
    sharing sin ωB with |C|² = C_coef sin² ωB)."""
    half = (0.5 * omega) * (A + B)
    sin_b = torch.sin(omega * B)
    prod = delta * torch.sin(omega * A) * sin_b
    sh, ch = torch.sin(half), torch.cos(half)
    return torch.addcmul(prod, sh, sh, value=2), torch.addcmul(-prod, ch, ch, value=2), sin_b


def _envelope(C2, sin2):
    """R^e = |C|² / (|C|² + sin² KΛ) (eq. 11); 0 where both vanish (a closed gap's mode); NaN propagates."""
    den = C2 + sin2
    zero = den <= 0
    return torch.where(zero, torch.zeros_like(den), C2 / torch.where(zero, torch.ones_like(den), den))


def _fringe_mean(envelope):
    """Yeh's R averaged over its fast fringes (phase NKΛ uniform) at fixed |C|², KΛ:
    ⟨C² sin²φ / (C² sin²φ + sin²KΛ)⟩_φ = 1 − √(sin²KΛ / (C² + sin²KΛ)) = 1 − √(1 − R^e)."""
    # guard: √ has an infinite slope at 0 (R^e = 1: gap edges and inside); NaN propagates
    return 1 - _checks.safe_sqrt(1 - envelope)


def _gap_reflectance(C2, eps, N):
    r"""Yeh's finite-N R inside a band gap (ε = 1 − |cos KΛ| ≤ 0, the gap branch of
    :func:`torchirid.optics.bragg.yeh_reflectance_kernel` with Q = 1): with e = −ε, |W| = e(2 + e),
    t = log1p(√|W| + e) (|cos KΛ| = cosh t) and m = expm1(−2Nt),
    R = |C|² m² / (|C|² m² + 4|W|(1 + m)) — no overflow for any N; both terms are O(e) as
    e → 0, where R → |C|²N²/(|C|²N² + 1) (e ≥ 1e-30 keeps 0/0 away: a closed gap's box is empty)."""
    e = torch.clamp(-eps, min=1e-30)
    W = e * (2 + e)
    m = torch.expm1((-2 * N) * torch.log1p(torch.sqrt(W) + e))
    num = C2 * (m * m)
    return num / torch.addcmul(num, 4 * W, 1 + m)


def _layout(A, B, delta, C_coef, N, w_corr, landmarks, omega_min, omega_max, s, averaged, static=False):
    """The boxes between the sorted landmarks, as the recipe of their sub-boxes (*, J):
    ``(start, base, step, gap_weight, band)``.

    Box j has n_j sub-boxes (1 in a gap, max(1, s − m) outside, m the mode just below the box;
    0 for empty boxes) numbered from ``start`` = n_0 + … + n_{j−1} on; sub-box t of the colour
    (t ≥ start_j) has its left end at ``base`` + t · ``step`` (step = width / n_j). Its weight
    is ``gap_weight`` + ``band`` · (the pass-band weight at its centre): in a gap (band = 0) the
    box's weight (1, or with ``averaged`` the exact finite-N reflectance at the gap centre),
    outside (gap_weight = 0, band = 1 or the angular correction w̃ for the paper's weights)
    the envelope or its fringe mean; empty boxes have both 0. The last box is an empty
    sentinel at ω_max, so sub-box numbers past a colour's own count land on it (zero width,
    zero weight).

    ``landmarks`` = (airy, edges_lo, edges_hi, zeros), clamped into [ω_min, ω_max]. A
    gap is the box that starts at its lower edge (its weight rides along through the sort):
    no other landmark lies inside a gap.
    """
    airy, e_lo, e_hi, zeros = landmarks
    Ax, Bx, dx, Cx = (t.unsqueeze(-1) for t in (A, B, delta, C_coef))
    one = torch.ones_like(e_lo[..., :1])
    if averaged:
        # inside the gaps the exact finite-N reflectance at the gap centre (never subdivided)
        omx, opx, sin_b = _parts(0.5 * (e_lo + e_hi), Ax, Bx, dx)
        gap_weight = _gap_reflectance(Cx * (sin_b * sin_b), torch.minimum(omx, opx), N[..., None])
    else:
        gap_weight = torch.ones_like(e_lo)
    # tag of each landmark as the left end of a box: the gap weight (≥ 0) for a lower gap edge, else −1
    tag_lo = torch.where(e_hi > e_lo, gap_weight, -1.0)
    before = 1 + e_hi.shape[-1] + airy.shape[-1] + zeros.shape[-1]
    b = torch.cat([one * omega_min, e_hi, airy, zeros, e_lo, one * omega_max, one * omega_max], dim=-1)
    tags = torch.cat([(-one).expand(one.shape[:-1] + (before,)), tag_lo, -one, -one], dim=-1)
    # stable: of equal landmarks a lower gap edge comes last (the box it starts is the gap, not
    # an empty one; e.g. a gap clipped at ω_min), the two ω_max ends after all (the sentinel)
    b, order = torch.sort(b, dim=-1, stable=True)
    tag = torch.gather(tags, -1, order[..., :-1])
    lo, width = b[..., :-1], b[..., 1:] - b[..., :-1]  # (*, J) boxes, the last one the sentinel
    m_box = torch.floor(torch.addcmul(lo, width, one, value=0.5) * ((Ax + Bx) / math.pi))
    in_gap = tag >= 0
    filled = width > 0
    n_sub = torch.where(in_gap, one, torch.clamp(s - m_box, min=1)) * filled
    cum = torch.cumsum(n_sub, dim=-1)
    start = cum - n_sub  # sub-boxes of boxes 0..j−1 (exact: small integers)
    step = width / torch.clamp(n_sub, min=1)
    base = lo - start * step
    band = torch.where(in_gap, 0.0, w_corr.unsqueeze(-1) if not averaged else one) * filled
    return start, base, step, torch.clamp(tag, min=0), band


def _fill_static(*args):
    """:func:`_fill` for ``torch.compile``: the final sum as one fused reduction (no batched product)."""
    return _fill(*args, static=True)


def _fill(A, B, delta, C_coef, w_corr, start, base, step, gap_weight, band, T, packed, omega0, h, averaged,
          static=False):
    """XYZ of the boxes of :func:`_layout`, each cut into its sub-boxes.

    The sub-boxes are laid out compactly, T per colour (T = the largest count in the batch,
    :func:`_compact_length`; shorter lists end with empty sub-boxes at ω_max). The box of each
    sub-box is found without a search: a running count of the box starts (one scatter-add and
    one cumulative sum; empty boxes share their start with the next box, which wins)."""
    # the box of sub-box t is the last box starting at or before it: (the number of box starts ≤ t) − 1
    starts = torch.zeros(start.shape[:-1] + (T + 1,), dtype=start.dtype, device=start.device)
    starts.scatter_add_(-1, start.to(torch.int64), torch.ones_like(start))  # (every start ≤ T: the sentinel's is)
    box = (torch.cumsum(starts, dim=-1) - 1).to(torch.int64).unsqueeze(-2)  # (*, 1, T + 1)
    recipe = torch.stack([step, base, gap_weight, band], dim=-2)  # (*, 4, J)
    step_t, base_t, gap_t, band_t = torch.gather(recipe, -1, box.expand(box.shape[:-2] + (4, T + 1))).unbind(-2)
    t = torch.arange(T + 1, dtype=start.dtype, device=start.device)
    left = torch.addcmul(base_t, t, step_t)  # (*, T + 1): left ends (t = T: ω_max)
    mid = torch.add(left, step_t, alpha=0.5)
    Ax, Bx, dx, Cx = (t_.unsqueeze(-1) for t_ in (A, B, delta, C_coef))
    # x = cos KΛ = cos φ − δ sin ωA sin ωB (φ = ω(A + B); eq. 8) and |C|² = C_coef sin² ωB at the centres
    sin_b = torch.sin(mid * Bx)
    x = torch.addcmul(torch.cos(mid * (Ax + Bx)), dx * torch.sin(mid * Ax), sin_b, value=-1)
    C2 = Cx * sin_b.square()
    tiny = torch.finfo(C2.dtype).tiny  # guard: R^e = 0 where |C|² and sin² KΛ vanish (a closed gap's mode)
    sin2 = torch.clamp(1 - x.square(), min=tiny)  # sin² KΛ outside the gaps (tiny inside: weight 1 there)
    # the fringe mean 1 − √(1 − R^e) of :func:`_fringe_mean` (and R^e of :func:`_envelope`) without
    # their where-guards: sub-box centres never sit on a gap edge, and sin² ≥ tiny keeps 0/0 away
    if averaged:
        inner = 1 - torch.rsqrt(1 + C2 / sin2)  # 1 − √(sin²/(|C|² + sin²))
    else:  # the envelope R^e (eq. 11, :func:`_envelope`)
        inner = C2 / (C2 + sin2)
    weight = torch.addcmul(gap_t, band_t, inner)  # (*, T + 1); 0 on the sentinel (t = T among them)
    # Σ_t w_t (C̄(e_{t+1}) − C̄(e_t)) = Σ_{t ≥ 1} (w_{t−1} − w_t) C̄(e_t) over the edges e_t (w_T = 0, and
    # C̄(e_0) = C̄(ω_min) = 0), with C̄(e_t) = P₀[i_t] + f_t P₁[i_t] read from the packed table: one batched product
    dw = weight[..., :-1] - weight[..., 1:]  # (*, T)
    rows, f = _lookup_rows(packed, omega0, h, left[..., 1:])  # (*, T, 6), (*, T)
    coef = torch.stack([dw, dw * f], dim=-1)  # (*, T, 2)
    rows = rows.reshape(rows.shape[:-1] + (2, rows.shape[-1] // 2))  # (*, T, 2, 3)
    if static:
        return (coef.unsqueeze(-1) * rows).sum(dim=(-3, -2))
    n = math.prod(coef.shape[:-2])  # (not −1: T = 0 for an empty batch)
    xyz = torch.bmm(coef.reshape(n, 1, 2 * T), rows.reshape(n, 2 * T, rows.shape[-1]))
    return xyz.reshape(left.shape[:-1] + (3,))
