r"""The peak-wavelength method of Kobayashi et al. (§4, eq. 8–14), batched over pixels.

At an extremum of the film's spectrum the optical path difference is a multiple of half the
wavelength:

.. math:: φ = 2d\sqrt{n^2 - \sin^2θ} = m λ \quad (\text{eq. } 8–9),

with m an integer at the maxima when r₀₁r₁₂ > 0 (film index between the outer medium's and
the substrate's: MgF₂ on PET) and a half-integer when r₀₁r₁₂ < 0 (a film denser than the
substrate: ZnS on PET) — the paper's eq. 9 takes the first case; the minima sit half an order
away. (The paper's eq. 10–11 write 4πd for 2d; eq. 12 is unaffected.)

Steps, each batched over every pixel of the cube:

1. ``detect_extrema()``: maxima and minima of each spectrum with sub-band precision — the
   spectrum is smoothed with a Gaussian of σ = W/2 bands to find candidates, then a
   least-squares parabola over ±W bands of the raw samples gives the vertex. W adapts to the
   spectra (≈ a fifth of the median distance between neighbouring extrema), so broad
   low-order peaks are located from many bands, not from the three around a 4 nm sample —
   the band-limited peak positions behind the paper's ZnS failure (§5.4).
2. ``track_extrema()``: follow each extremum from one incidence angle to the next (it moves
   to shorter λ as θ grows, by at most the factor allowed by the index range).
3. ``index_from_tracks()``: eq. 12 generalised to all angles of a track: λ² = (2d/m)²
   (n² − sin²θ) is linear in sin²θ, so n² = −intercept/slope of a least-squares line
   (with two angles this *is* eq. 12, ``index_from_peak_pair()``); the film's n is the
   median over all tracks of all pixels (robust to mismatched tracks).
4. ``thickness_candidates()``: eq. 13 for every admissible order m of the longest track.
5. ``select_candidates()``: eq. 14 — the candidate whose modelled cube (all angles and
   bands) is closest in least squares to the measured one
   (:func:`~torchirid.estimation.residuals.cube_sse`).

The tuning constants (``WINDOW_*``, ``PROBE_*``, ``MIN_TRACK_ANGLES``, ...) are module-level
names, each with the reason for its value.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch

from .. import _checks
from ._validation import band_settings, cube_axes, real_index, sorted_angles, tensor, uniform_bands, value_range
from .measurement import airy_terms, band_terms
from .residuals import THICKNESS_GRID_DIVISOR, cube_sse, decimation, thickness_grid

__all__ = ["PeakResult", "peak_method"]

# the adaptive window W of detect_extrema: a fraction of the spacing of the extrema, probed on a
# few smoothed spectra
WINDOW_PROBE_SPECTRA = 2048  # spectra probed for the extremum spacing: a spread over the image is enough
PROBE_SIGMA = 1.5  # bands: light smoothing of the probe, so that noise does not add spurious extrema
PROBE_EDGE = 2  # bands ignored at each end of a probe spectrum (a one-sided smoothing makes false extrema there)
WINDOW_FRACTION = 5  # W = spacing / 5: the parabola spans 2W+1 ≈ 0.4 of a fringe, where a peak is still parabolic
WINDOW_MIN = 2  # bands: at least 5 samples in the parabola fit (3 would leave no noise averaging)
WINDOW_MAX = 12  # bands: 25 samples already average the noise; wider only mixes in the fringe's asymmetry
HALF_WINDOW = 0.5  # W/2 bands (at least 1): the candidates' smoothing σ, and how far a vertex may sit from its band
MAX_EXTREMA = 16  # extrema kept per spectrum: all of a 2 µm MgF2 (~12) or 1.2 µm ZnS film (~15) in 400–720 nm
MIN_TRACK_ANGLES = 3  # eq. 12 over ≥ 3 angles: two points always fit the line, a third tests the pairing


class NoTrackError(ValueError):
    """No extremum of the cube could be followed over the angles with an index inside ``n_range``:
    eq. 12 has no index to give. A ``ValueError`` whose message names the remedy of the function
    that raised it (``peak_method``: ``n_film``; ``estimate_film`` and ``torchirid fit-film``
    re-raise it with theirs); ``angles_deg`` (the incidence angles, from cos θ) and ``n_range``
    let a caller word its own."""

    def __init__(self, message: str, angles_deg: tuple, n_range: tuple):
        super().__init__(message)
        self.angles_deg = tuple(angles_deg)
        self.n_range = tuple(n_range)


def radians_hint(angles_deg) -> str:
    """``""``, or — when every incidence angle (in degrees as given) lies within [0, π/2] and they
    are not all 0 — the sentence that they look like radians: angles of a few tenths of a degree
    to 1.57° cannot separate the extrema of a film, radians in [0, π/2] read as degrees do."""
    a = [float(v) for v in angles_deg]
    if len(a) < 2 or not all(0.0 <= v <= math.pi / 2 + 1e-9 for v in a) or max(a) == 0.0:
        return ""
    return (f"the incidence angles {min(a):.3g}–{max(a):.3g}° all lie within [0, π/2] = [0, 1.571]: they look like "
            "radians, and must be degrees")
PARITY_FALLBACK_WAVELENGTH = 550.0  # nm: where the sign of r01 r12 is taken for a pixel without a track (mid-visible)


def index_from_peak_pair(lambda1, lambda2, sin1, sin2) -> torch.Tensor:
    r"""Film index from one peak seen at two angles, eq. 12:
    :math:`n = \sqrt{(λ_2^2 \sin^2θ_1 - λ_1^2 \sin^2θ_2)/(λ_2^2 - λ_1^2)}`.

    NaN where λ₁ = λ₂ or the radicand is negative (no real solution).

    >>> import torch, math
    >>> n, d, m = 1.37, 400.0, 2
    >>> s1, s2 = math.sin(math.radians(10)), math.sin(math.radians(50))
    >>> l1, l2 = (2 * d * math.sqrt(n * n - s * s) / m for s in (s1, s2))
    >>> round(float(index_from_peak_pair(torch.tensor(l1, dtype=torch.float64), torch.tensor(l2, dtype=torch.float64), s1, s2)), 10)
    1.37
    """
    l1, l2 = tensor(lambda1), tensor(lambda2)
    num = l2 * l2 * sin1 * sin1 - l1 * l1 * sin2 * sin2
    den = l2 * l2 - l1 * l1
    q = num / den
    return torch.where(q > 0, q.clamp_min(0).sqrt(), torch.full_like(q, math.nan))


def _gauss_kernel(sigma: float, dtype, device):
    r = max(1, int(math.ceil(3 * sigma)))
    x = torch.arange(-r, r + 1, dtype=dtype, device=device)
    k = torch.exp(-0.5 * (x / sigma) ** 2)
    return k / k.sum()


def _smooth(y: torch.Tensor, sigma: float) -> torch.Tensor:
    """Gaussian smoothing along the last axis with reflected ends; y: (N, B).

    One (B, B) matrix product (BLAS) — several times faster than a conv1d over many short rows.
    """
    B = y.shape[-1]
    k = _gauss_kernel(sigma, y.dtype, y.device)
    r = min((k.numel() - 1) // 2, B - 1)
    k = k[(k.numel() - 1) // 2 - r:(k.numel() - 1) // 2 + r + 1]
    k = k / k.sum()
    # column j of M holds the weights of output j over the inputs, reflection folded in
    src = torch.arange(B, device=y.device)[:, None] + torch.arange(-r, r + 1, device=y.device)[None, :]
    src = src.abs()
    src = torch.where(src > B - 1, 2 * (B - 1) - src, src)
    M = torch.zeros(B, B, dtype=y.dtype, device=y.device)
    M.index_put_((src.reshape(-1), torch.arange(B, device=y.device).repeat_interleave(2 * r + 1)),
                 k.repeat(B), accumulate=True)
    return y @ M


def _raw_extrema(sm: torch.Tensor, edge: int):
    """Strict local extrema of (N, B) smoothed spectra, ignoring ``edge`` bands at each end."""
    left, mid, right = sm[:, :-2], sm[:, 1:-1], sm[:, 2:]
    kind = torch.zeros_like(sm, dtype=torch.int8)
    kind[:, 1:-1] = torch.where((mid > left) & (mid >= right), 1, 0).to(torch.int8)
    kind[:, 1:-1] -= torch.where((mid < left) & (mid <= right), 1, 0).to(torch.int8)
    if edge > 0:
        kind[:, :edge] = 0
        kind[:, -edge:] = 0
    return kind


def detect_extrema(spectra, wavelength, *, window=None, max_extrema: int = MAX_EXTREMA):
    r"""Maxima and minima of spectra with sub-band precision (step 1 of the module docstring).

    Args:
        spectra: ``(*, B)`` band values (wavelength on the last axis), B ≥ 7.
        wavelength: ``(B,)`` band centres in nm, strictly increasing and uniformly spaced.
        window: half-width W (bands) of the parabola fit; default: adaptive (a fifth of the
            median spacing of the extrema of the smoothed spectra, in [2, 12]: the ``WINDOW_*``
            constants).
        max_extrema: K, the most extrema kept per spectrum (in order of wavelength).

    Returns:
        ``(position, kind, window)``: position ``(*, K)`` in nm (NaN where none), kind
        ``(*, K)`` int8 (+1 maximum, −1 minimum, 0 none), and the W used.

    Example (an interference fringe cos(2π·2200 nm/λ): maxima at 2200/5 = 440 and 2200/4 = 550 nm,
    minima at 2200/4.5 = 488.9 and 2200/3.5 = 628.6 nm — between the 4 nm bands):
        >>> import torch, math
        >>> w = torch.arange(400.0, 701.0, 4.0, dtype=torch.float64)
        >>> pos, kind, W = detect_extrema(torch.cos(2 * math.pi * 2200 / w), w)
        >>> [(round(v, 1), k) for v, k in zip(pos.tolist(), kind.tolist()) if k != 0]
        [(440.0, 1), (488.9, -1), (550.0, 1), (628.6, -1)]
    """
    _checks.check_numbers(spectra=spectra, wavelength=wavelength)
    dtype, device = _checks.resolve_dtype_device(spectra, wavelength)
    y = _checks.as_real(spectra, "spectra", dtype, device)
    lam = _checks.as_real(wavelength, "wavelength", dtype, device)
    if y.ndim < 1 or lam.ndim != 1 or lam.numel() != y.shape[-1] or lam.numel() < 7:
        raise ValueError(f"wavelength must be 1-D with spectra.shape[-1] >= 7 samples; got {tuple(lam.shape)} for spectra {tuple(y.shape)}")
    uniform_bands(lam)
    max_extrema = _checks.check_int(max_extrema, "max_extrema")
    if window is not None:
        window = _checks.check_int(window, "window")
        if 2 * window + 1 > lam.numel():
            raise ValueError(f"window must be an integer >= 1 with 2*window+1 <= B; got {window!r}")
    step = lam[1] - lam[0]
    return _detect_extrema(y, lam, step, window, max_extrema)


def _adaptive_window(Yf: torch.Tensor) -> int:
    """W for ``detect_extrema()``: a ``WINDOW_FRACTION`` of the median spacing of the extrema of
    lightly smoothed probe spectra, clamped to [``WINDOW_MIN``, ``WINDOW_MAX``]."""
    N, B = Yf.shape
    # (float32 index ramp, whatever the default dtype: the same probe set everywhere)
    pick = torch.linspace(0, N - 1, min(N, WINDOW_PROBE_SPECTRA), dtype=torch.float32, device=Yf.device).long()
    kind0 = _raw_extrema(_smooth(Yf[pick], PROBE_SIGMA), PROBE_EDGE)
    idx = torch.arange(B, device=Yf.device).expand_as(kind0)
    posn = torch.where(kind0 != 0, idx, -1)
    # spacing between successive extrema, pooled over every spectrum
    srt = posn.sort(dim=-1).values
    gaps = srt.diff(dim=-1)
    valid = (srt[:, :-1] >= 0) & (gaps > 0)
    med = float(gaps[valid].to(Yf.dtype).median()) if bool(valid.any()) else float(B)
    return int(min(WINDOW_MAX, max(WINDOW_MIN, round(med / WINDOW_FRACTION))))


def _detect_extrema(y, lam, step, window, max_extrema):
    """``detect_extrema()`` on validated inputs."""
    batch = y.shape[:-1]
    B = y.shape[-1]
    Y = y.reshape(-1, B)
    Yf = torch.nan_to_num(Y, nan=0.0)
    W = _adaptive_window(Yf) if window is None else window
    if 2 * W + 1 > B:
        raise ValueError(f"window must be an integer >= 1 with 2*window+1 <= B; got {W!r}")
    kind = _raw_extrema(_smooth(Yf, _half_window(W)), W)
    # the first K candidate extrema by wavelength, then a parabola only there
    idx = torch.arange(B, device=y.device).expand_as(kind)
    key = torch.where(kind != 0, idx, B + idx)
    order = key.topk(min(max_extrema, B), dim=-1, largest=False, sorted=True).indices  # (N, K) band indices
    k_sel, p_sel = _vertices(Yf, lam, step, W, order, kind.gather(-1, order))
    # rejected candidates last, the rest in order of wavelength
    key2 = torch.where(k_sel != 0, order, B + order)
    o2 = key2.argsort(-1)
    k_sel, p_sel = k_sel.gather(-1, o2), p_sel.gather(-1, o2)
    K = order.shape[-1]
    return p_sel.reshape(*batch, K), k_sel.reshape(*batch, K), W


def _half_window(W: int) -> float:
    """``HALF_WINDOW`` × W bands, at least one band."""
    return max(HALF_WINDOW * W, 1.0)


def _vertices(Yf, lam, step, W, order, k_sel):
    """Parabola vertices of the candidate extrema at bands ``order`` ``(N, K)`` of kinds ``k_sel``
    → ``(kind, position nm)``, kind 0 and NaN where the fit has the wrong curvature or its vertex
    lies more than ``HALF_WINDOW``·W bands away."""
    B = Yf.shape[-1]
    centre = order.clamp(W, B - 1 - W)
    # least-squares parabola in the wavenumber ν = 1/λ over the 2W+1 bands around each extremum:
    # the film phase is linear in ν, so a fringe is symmetric in ν (not in λ) — no skew bias
    nu = 1000.0 / lam  # 1/µm
    nu_w = nu.unfold(-1, 2 * W + 1, 1)  # (B - 2W, 2W+1), window j centred at band W + j
    t = nu_w - nu[W:B - W, None]
    scale_t = t.abs().amax(-1, keepdim=True)
    ts = t / scale_t
    V = torch.stack([torch.ones_like(ts), ts, ts * ts], dim=-1)  # (B-2W, 2W+1, 3)
    Pm = torch.linalg.pinv(V)[:, 1:]  # rows for c1, c2: (B-2W, 2, 2W+1)
    offs = torch.arange(-W, W + 1, device=Yf.device)
    win = Yf.gather(-1, (centre[..., None] + offs).reshape(Yf.shape[0], -1)).reshape(*centre.shape, 2 * W + 1)
    Psel = Pm[centre - W]  # (N, K, 2, 2W+1)
    coef = (Psel * win[..., None, :]).sum(-1)  # (N, K, 2)
    c1, c2 = coef[..., 0], coef[..., 1]
    vertex = -c1 / (2 * c2) * scale_t[centre - W, 0]  # in ν, relative to the centre band
    nu_c = nu[centre]
    half = _half_window(W) * step / lam[centre] * nu_c  # W/2 bands, in ν
    good = (((k_sel == 1) & (c2 < 0)) | ((k_sel == -1) & (c2 > 0))) & (vertex.abs() <= half)
    k_sel = torch.where(good, k_sel, torch.zeros_like(k_sel))
    p_sel = torch.where(k_sel != 0, 1000.0 / (nu_c + torch.nan_to_num(vertex, nan=0.0)),
                        torch.full_like(nu_c, math.nan))
    return k_sel, p_sel


def track_extrema(position, kind, cos_theta, *, n_range=(1.2, 3.5), n_incident=1.0, tolerance=0.01):
    r"""Follow each extremum of the first angle through the following angles (step 2).

    Args:
        position, kind: ``(*, A, K)`` from ``detect_extrema()`` on a cube ``(*, A, B)``;
            angles must be in increasing order of θ (decreasing ``cos_theta``).
        cos_theta: ``(A,)`` cosines of the incidence angles.
        n_range: the film index range allowed; it bounds the shift of an extremum from one
            angle to the next, λ' / λ ∈ [√(n_min² − s'²)/√(n_min² − s²), 1 + tolerance].

    Returns:
        tracks ``(*, K, A)``: the wavelength of each first-angle extremum at every angle (NaN
        where lost), and their kinds ``(*, K)``.

    Example (one maximum moving 548 → 500 nm between two angles is followed):
        >>> import torch
        >>> pos = torch.tensor([[[548.0, 600.0], [500.0, 560.0]]]); kind = torch.tensor([[[1, -1], [1, -1]]], dtype=torch.int8)
        >>> tr, k = track_extrema(pos, kind, torch.tensor([0.98, 0.64]))
        >>> tr[0].tolist()
        [[548.0, 500.0], [600.0, 560.0]]
    """
    pos = tensor(position)
    c = torch.as_tensor(cos_theta, dtype=pos.dtype, device=pos.device).reshape(-1)
    A = pos.shape[-2]
    if c.numel() != A:
        raise ValueError(f"cos_theta must have one value per angle ({A}); got {c.numel()}")
    sorted_angles(c)
    n_min, _ = value_range(n_range, "n_range", positive=True)
    s2 = (float(n_incident) ** 2) * (1 - c * c)
    cur = pos[..., 0, :]  # (*, K)
    knd = kind[..., 0, :]
    out = [cur]
    for a in range(1, A):
        r_min = torch.sqrt((n_min ** 2 - s2[a]).clamp_min(1e-6) / (n_min ** 2 - s2[a - 1]).clamp_min(1e-6))
        nxt, nk = pos[..., a, :], kind[..., a, :]
        ratio = nxt[..., None, :] / cur[..., :, None]  # (*, K_cur, K_next)
        ok = (nk[..., None, :] == knd[..., :, None]) & (knd[..., :, None] != 0)
        ok = ok & (ratio >= r_min) & (ratio <= 1 + tolerance)
        score = torch.where(ok, ratio, torch.full_like(ratio, -math.inf))
        best, arg = score.max(dim=-1)
        cur = torch.where(torch.isfinite(best), nxt.gather(-1, arg), torch.full_like(best, math.nan))
        out.append(cur)
    return torch.stack(out, dim=-1), knd


def index_from_tracks(tracks, cos_theta, *, n_incident=1.0, min_angles: int = 3):
    r"""Per-track index from the least-squares line λ² = α − β sin²θ (eq. 12 over all angles).

    Args:
        tracks: ``(*, A)`` wavelengths (nm) of one extremum at each angle (NaN = missing).
        cos_theta: ``(A,)``.
        min_angles: tracks seen at fewer angles give NaN.

    Returns:
        ``(n, count)``: ``(*)`` index (NaN where undetermined) and the number of angles used.

    Example:
        >>> import torch, math
        >>> c = torch.cos(torch.deg2rad(torch.tensor([10.0, 30.0, 50.0], dtype=torch.float64)))
        >>> lam = 2 * 500 * torch.sqrt(2.37 ** 2 - (1 - c * c)) / 4.5
        >>> round(float(index_from_tracks(lam, c)[0]), 10)
        2.37
    """
    min_angles = _checks.check_int(min_angles, "min_angles")
    tr = tensor(tracks)
    c = torch.as_tensor(cos_theta, dtype=tr.dtype, device=tr.device)
    s2 = (float(n_incident) ** 2) * (1 - c * c)
    m = ~tr.isnan()
    cnt = m.sum(-1)
    y = torch.where(m, tr * tr, torch.zeros_like(tr))
    x = torch.where(m, s2.expand_as(tr), torch.zeros_like(tr))
    nz = cnt.clamp_min(1).to(tr.dtype)
    xm, ym = x.sum(-1) / nz, y.sum(-1) / nz
    dx = torch.where(m, x - xm[..., None], torch.zeros_like(x))
    dy = torch.where(m, y - ym[..., None], torch.zeros_like(y))
    slope = (dx * dy).sum(-1) / (dx * dx).sum(-1)
    alpha = ym - slope * xm
    n2 = -alpha / slope
    n = torch.where((cnt >= max(2, min_angles)) & (n2 > 0) & (slope < 0), n2.clamp_min(0).sqrt(), torch.full_like(n2, math.nan))
    return n, cnt


def thickness_candidates(tracks, kinds, cos_theta, n_film, n_substrate, *, thickness_range=(20.0, 2000.0),
                         n_incident=1.0, polarization="unpolarized", max_candidates: int = 24):
    r"""Thickness candidates of eq. 13, d = m λ / (2√(n² − sin²θ)), for every admissible order.

    Per pixel the track seen at the most angles is used; d is the mean over its angles of
    λ_a/(2√(n² − sin²θ_a)) times m, with m ∈ ℕ or ℕ − ½ as the extremum kind and the sign
    of r₀₁r₁₂ require (module docstring), restricted to ``thickness_range``.

    Args:
        tracks: ``(P, K, A)``, kinds ``(P, K)`` from ``track_extrema()``.
        n_film: scalar index estimate; n_substrate: real substrate index.

    Returns:
        ``(P, C)`` candidate thicknesses (NaN-padded; all NaN where a pixel has no track).

    Example (MgF₂ 400 nm: the 10° maximum at 544.6 nm gives 400 nm at order m = 2):
        >>> import torch, math
        >>> c = torch.tensor([math.cos(math.radians(10))], dtype=torch.float64)
        >>> lam = 2 * 400 * math.sqrt(1.37 ** 2 - (1 - float(c) ** 2)) / 2
        >>> cand = thickness_candidates(torch.tensor([[[lam]]], dtype=torch.float64), torch.tensor([[1]], dtype=torch.int8), c, 1.37, 1.64)
        >>> [round(v, 6) for v in cand[0, :3].tolist()]
        [200.0, 400.0, 600.0]
    """
    _checks.check_polarization(polarization)
    max_candidates = _checks.check_int(max_candidates, "max_candidates")
    lo, hi = value_range(thickness_range, "thickness_range", positive=False, nm=True)
    tr = tensor(tracks)
    nf = real_index(n_film, "n_film", tr)
    ns = real_index(n_substrate, "n_substrate", tr)
    c = torch.as_tensor(cos_theta, dtype=tr.dtype, device=tr.device).reshape(-1)
    s2 = (float(n_incident) ** 2) * (1 - c * c)
    cnt = (~tr.isnan()).sum(-1)  # (P, K)
    best = cnt.argmax(-1)  # (P,)
    P = tr.shape[0]
    rows = torch.arange(P, device=tr.device)
    sel = tr[rows, best]  # (P, A)
    kind = kinds[rows, best].to(tr.dtype)
    has = cnt[rows, best] > 0
    u = (sel / (2 * torch.sqrt(nf * nf - s2))).nanmean(-1)  # d per unit order
    # parity: maxima at integer orders iff r01 r12 > 0 (sign of b at the track's mean wavelength, first angle)
    lam_mean = sel.nanmean(-1).nan_to_num(PARITY_FALLBACK_WAVELENGTH)
    _, b, _, _ = airy_terms(lam_mean, c[0], nf, ns, n_incident=n_incident, polarization=polarization)
    bpos = b.mean(0) > 0
    half = ((kind > 0) != bpos).to(tr.dtype) * 0.5  # max & b>0 → integer order, etc.
    j = torch.arange(0, max_candidates + 1, dtype=tr.dtype, device=tr.device)
    m = j[None, :] + half[:, None]
    cand = m * u[:, None]
    ok = (m > 0) & (cand >= lo) & (cand <= hi) & has[:, None]
    cand = torch.where(ok, cand, torch.full_like(cand, math.nan))
    # compact: NaNs last (their keys after every valid one), keep max_candidates columns
    key = torch.where(ok, j.expand_as(cand), j.expand_as(cand) + j.numel())
    order = key.argsort(-1)[:, :max_candidates]
    out = cand.gather(-1, order)
    keep = (~out.isnan()).any(0)
    return out[:, keep] if bool(keep.any()) else out[:, :1]


def select_candidates(cube, candidates, terms):
    """Eq. 14: for each pixel the candidate with the least squared error → ``(d (P,), sse (P,))``.

    Args:
        cube: ``(P, A, B)`` band reflectance; candidates: ``(P, C)`` thicknesses (nm, NaN: none);
        terms: (a, b, e, k, h), each ``(pol, A, B)``, of ``band_terms()``
            or :func:`~torchirid.estimation.gauss_newton.model_terms` (the misfit is
            :func:`~torchirid.estimation.residuals.cube_sse`).

    Example (two noise-free pixels of MgF₂ on PET, 380 and 420 nm thick, three orders each):
        >>> import torch
        >>> from torchirid.estimation import model_cube
        >>> from torchirid.estimation.refine import model_terms
        >>> w = torch.arange(400.0, 721.0, 8.0, dtype=torch.float64)  # nm
        >>> cos_t = torch.tensor([0.98, 0.77, 0.64], dtype=torch.float64)
        >>> n = torch.tensor([1.37], dtype=torch.float64)  # a constant index
        >>> cube = model_cube(n, "constant", torch.tensor([380.0, 420.0], dtype=torch.float64), w, cos_t, 1.64)
        >>> cand = torch.tensor([[250.0, 380.0, 510.0], [290.0, 420.0, 550.0]], dtype=torch.float64)  # nm
        >>> d, sse = select_candidates(cube, cand, model_terms(n, "constant", w, cos_t, 1.64))
        >>> d.tolist(), [round(v, 12) for v in sse.tolist()]
        ([380.0, 420.0], [0.0, 0.0])
    """
    sse = cube_sse(cube, terms, candidates)
    best = sse.argmin(-1)
    return candidates.gather(-1, best[:, None])[:, 0], sse.gather(-1, best[:, None])[:, 0]


@dataclass
class PeakResult:
    """Output of :func:`peak_method`.

    n: robust film index (median over all tracks); thickness ``(*)`` (nm); sse ``(*)`` of
    eq. 14 at the chosen d; track_index ``(*, K)`` per-track n (NaN where undetermined);
    window: the W used for extremum location; fallback: pixels with no usable track
    (their d comes from a thickness grid instead of eq. 13).

    Example (the peak method on a 4 × 4 pixel synthetic MgF₂ cube, n = 1.37):
        >>> from torchirid.estimation import synthetic_cube
        >>> c = synthetic_cube("mgf2_400", height=4, width=4, seed=1)
        >>> pk = peak_method(c.cube, c.wavelength, c.cos_theta, 1.64)
        >>> round(pk.n, 2), tuple(pk.thickness.shape), tuple(pk.sse.shape), pk.fallback
        (1.37, (4, 4), (4, 4), 0)
    """

    n: float
    thickness: torch.Tensor
    sse: torch.Tensor
    track_index: torch.Tensor
    window: int
    fallback: int


def peak_method(cube, wavelength, cos_theta, n_substrate, *, bandwidth: float = 4.0, passband: str = "box",
                polarization: str = "unpolarized", n_incident=1.0, n_range=(1.2, 3.5),
                thickness_range=(20.0, 2000.0), n_film=None, window=None, score_stride: int = 3) -> PeakResult:
    r"""Kobayashi et al.'s estimate of n (eq. 12) and per-pixel d (eq. 13–14) from a cube ``(*, A, B)``.

    Args:
        cube: ``(*, A, B)`` band reflectance, angles sorted by increasing θ; non-finite samples
            (NaN, ±inf) are missing data, a pixel without a finite sample gets NaN d and sse.
        wavelength: ``(B,)`` band centres (nm), uniform, B ≥ 7; cos_theta ``(A,)``.
        n_substrate: real substrate index.
        bandwidth, passband, polarization, n_incident: the band model
            (``band_terms()``; Kobayashi et al.'s camera: ``polarization="s"``).
        n_range, thickness_range: the admissible film index and thickness (nm).
        n_film: if given, skip eq. 12 and use this index.
        window: the extremum fit's half-width (bands), default adaptive (``detect_extrema()``).
        score_stride: eq. 14 scores the orders on every ``score_stride``-th band of the first,
            middle and last angles (enough to tell orders apart; at the default 3 a fifth of the
            samples of a 5-angle cube; 1 with all angles = the full cube).

    Returns:
        :class:`PeakResult`; dtype and device follow the inputs.

    Example (a 4 × 4 pixel synthetic cube of MgF₂, n = 1.37, 360–440 nm thick on PET, n = 1.64;
    ``tests/estimation/test_peaks.py`` has more):
        >>> from torchirid.estimation import synthetic_cube
        >>> c = synthetic_cube("mgf2_400", height=4, width=4, seed=1)  # (4, 4, 5, 81): 5 angles, 400–720 nm
        >>> pk = peak_method(c.cube, c.wavelength, c.cos_theta, 1.64)
        >>> round(pk.n, 2), bool((pk.thickness - c.thickness).abs().max() < 2.0)  # d within 2 nm
        (1.37, True)
    """
    y, lam, c = cube_axes(cube, wavelength, cos_theta)
    if lam.numel() < 7:
        raise ValueError(f"wavelength must have at least 7 bands; got {lam.numel()}")
    uniform_bands(lam)
    sorted_angles(c)
    band_settings(bandwidth, passband, polarization)
    y = torch.where(y.isfinite(), y, math.nan)  # ±inf samples are missing data, like NaN (a new tensor)
    ns = real_index(n_substrate, "n_substrate", y)
    n0 = real_index(n_incident, "n_incident", y, incident=True)
    n_range = value_range(n_range, "n_range", positive=True)
    thickness_range = value_range(thickness_range, "thickness_range", positive=False, nm=True)
    n_film = None if n_film is None else real_index(n_film, "n_film", y)
    if window is not None and 2 * _checks.check_int(window, "window") + 1 > lam.numel():
        raise ValueError(f"window must be an integer >= 1 with 2*window+1 <= B; got {window!r}")
    score_stride = _checks.check_int(score_stride, "score_stride")
    band = dict(bandwidth=bandwidth, passband=passband, polarization=polarization, n_incident=n0)
    batch = y.shape[:-2]
    Y = y.reshape(-1, *y.shape[-2:])
    tracks, kinds, n_tr, W = _tracks(Y, lam, c, window, n_range, n0)
    n_est = _eq12_index(n_tr, n_range, c) if n_film is None else n_film
    d, sse, nofb = _eq14_thickness(Y, lam, c, ns, tracks, kinds, n_est, thickness_range, score_stride, band)
    return PeakResult(n=n_est, thickness=d.reshape(batch), sse=sse.reshape(batch),
                      track_index=n_tr.reshape(*batch, -1), window=W, fallback=nofb)


def _tracks(Y, lam, c, window, n_range, n_incident):
    """Steps 1–3 on pixels ``Y`` ``(P, A, B)``: extrema, their tracks over the angles and each
    track's index → ``(tracks (P, K, A), kinds (P, K), n per track (P, K), window W)``."""
    A = Y.shape[-2]
    pos, kind, W = _detect_extrema(Y, lam, lam[1] - lam[0], window, MAX_EXTREMA)
    tracks, kinds = track_extrema(pos, kind, c, n_range=n_range, n_incident=n_incident)  # (P, K, A), (P, K)
    n_tr, _ = index_from_tracks(tracks, c, n_incident=n_incident, min_angles=min(MIN_TRACK_ANGLES, A))
    return tracks, kinds, n_tr, W


def _eq12_index(n_tr, n_range, cos_theta) -> float:
    """The film's n: the median of the per-track indices inside ``n_range`` (robust to mismatched
    tracks); :class:`NoTrackError` when there is none."""
    vals = n_tr[(n_tr >= n_range[0]) & (n_tr <= n_range[1])]
    if vals.numel() == 0:
        angles = tuple(math.degrees(math.acos(min(1.0, max(-1.0, float(v))))) for v in cos_theta.reshape(-1))
        hint = radians_hint(angles)
        raise NoTrackError(
            f"no extremum could be followed over the angles with an index inside n_range {tuple(n_range)}: eq. 12 "
            f"cannot estimate the film's index; {hint + ' (cos_theta = torch.cos(torch.deg2rad(angles_deg))); ' if hint else ''}"
            "pass n_film (the film's index, if known), widen n_range if the index lies outside it, or check "
            "cos_theta", angles, n_range)
    return float(vals.median())


def _eq14_thickness(Y, lam, c, ns, tracks, kinds, n_est, thickness_range, score_stride, band):
    """Steps 4–5: per pixel the eq. 13 candidate of least misfit on the decimated cube (eq. 14);
    pixels without a track search a thickness grid instead. → ``(d (P,), sse (P,), fallback count)``."""
    P, A, B = Y.shape
    cand = thickness_candidates(tracks, kinds, c, n_est, ns, thickness_range=thickness_range,
                                n_incident=band["n_incident"], polarization=band["polarization"])
    a_sel, b_sel = decimation(A, B, score_stride)
    terms = band_terms(lam[b_sel], c[a_sel, None], n_est, ns, **band)
    Ys = Y[:, a_sel][:, :, b_sel]
    d = torch.full((P,), math.nan, dtype=Y.dtype, device=Y.device)
    sse = torch.full((P,), math.inf, dtype=Y.dtype, device=Y.device)
    has = ~cand.isnan().all(-1)
    if bool(has.any()):
        d[has], sse[has] = select_candidates(Ys[has], cand[has], terms)
    nofb = int((~has).sum())
    if nofb:
        # no usable extremum: a grid fine enough for the refinement's basin
        grid = thickness_grid(thickness_range, float(lam[0]) / (THICKNESS_GRID_DIVISOR * n_est), Y)
        d[~has], sse[~has] = select_candidates(Ys[~has], grid.expand(nofb, -1), terms)
    empty = Y.isnan().all(-1).all(-1)  # no finite sample: no estimate (not the range floor with SSE 0)
    d, sse = torch.where(empty, math.nan, d), torch.where(empty, math.nan, sse)
    return d, sse, nofb
