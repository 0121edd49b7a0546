"""Tests of torchirid.spectral.sampling: the fringe count of a Bragg mirror's spectrum and the
number of ω samples the ``"spectral"`` colour method takes from it.

Reference for the fringe count: the fringes themselves — the local minima of the mirror's exact
reflectance (``bragg_reflectance``, s-polarized) on a dense grid uniform in ω = 2π/λ, counted;
they agree within the fringes the band gaps take (≤ 3 here; a wrong angle or
incident medium, or a factor 2, moves the count by 15 or more). The sample count is checked against
its rule written out, ``ceil(samples_per_fringe · N (n1 d1 + n2 d2) · 2 (1/λ_min − 1/λ_max)) + 1``
for the batch's longest mirror, clipped.
"""

from __future__ import annotations

import math

import pytest
import torch

from torchirid.optics import bragg_reflectance
from torchirid.spectral.sampling import fringe_count, max_fringes, spectral_samples

F64 = torch.float64


def counted_fringes(cos_theta, n1, n2, d1, d2, cells, n_incident=None, lo=380.0, hi=780.0, samples=40001):
    """Local minima of R(ω) over [λ_lo, λ_hi]: one per fringe."""
    lam = 1 / torch.linspace(1 / hi, 1 / lo, samples, dtype=F64)
    R = bragg_reflectance(lam, torch.tensor(cos_theta, dtype=F64), n1, n2, d1, d2, cells, n_incident=n_incident,
                          polarization="s")
    return int(((R[1:-1] < R[:-2]) & (R[1:-1] < R[2:])).sum())


@pytest.mark.parametrize("mirror", [
    (1.0, 1.5, 1.52, 300.0, 300.0, 30, None),  # low contrast: narrow gaps, ~73 fringes
    (0.6, 1.5, 1.52, 300.0, 300.0, 30, None),  # oblique in the host: cos θ_j from Snell
    (0.6, 1.5, 1.52, 300.0, 300.0, 30, 1.0),  # lit from air: n0 sin θ0, not n1 sin θ0
    (1.0, 1.0, 1.5, 125.0, 375.0, 20, None),  # Fourneau's Fig. 1 mirror
    (0.9, 1.33, 1.56, 150.0, 120.0, 40, None),  # 40 cells, higher contrast
], ids=["low-contrast", "oblique", "from-air", "fig1", "40-cells"])
def test_fringe_count_is_the_number_of_fringes_of_the_spectrum(mirror):
    *args, n0 = mirror
    F = float(fringe_count(*args, n_incident=n0))
    assert abs(counted_fringes(*args, n_incident=n0) - F) <= 3.0, F


def test_fringe_count_over_a_narrower_range_scales_with_the_frequency_span():
    args = (0.8, 1.5, 1.52, 300.0, 300.0, 30)
    F = float(fringe_count(*args, wavelength_range=(450.0, 650.0)))
    assert abs(counted_fringes(*args, lo=450.0, hi=650.0) - F) <= 2.0
    ratio = (1 / 450.0 - 1 / 650.0) / (1 / 380.0 - 1 / 780.0)
    assert F == pytest.approx(ratio * float(fringe_count(*args)), rel=1e-14)


def test_a_layer_in_total_internal_reflection_contributes_no_fringes():
    # lit from n0 = 1.6 at grazing: n0 sin θ0 > n1 = 1.5, so layer 1 is evanescent; layer 2 (1.7) is not
    c = 0.05
    full = float(fringe_count(c, 1.5, 1.7, 300.0, 300.0, 30, n_incident=1.6))
    layer2 = 30 * math.sqrt(1.7**2 - 1.6**2 * (1 - c * c)) * 300.0 * 2 * (1 / 380.0 - 1 / 780.0)
    assert full == pytest.approx(layer2, rel=1e-13)
    assert float(fringe_count(c, 1.5, 1.7, 1e6, 300.0, 30, n_incident=1.6)) == pytest.approx(full, rel=1e-13)


def test_fringe_count_broadcasts_and_keeps_float32():
    c = torch.tensor([1.0, 0.5], dtype=torch.float32)
    F = fringe_count(c[:, None], 1.0, 1.5, torch.tensor([125.0, 250.0], dtype=torch.float32), 375.0, 20)
    assert F.shape == (2, 2) and F.dtype == torch.float32
    assert float(F[0, 1]) > float(F[0, 0]) > float(F[1, 0])  # longer mirror: more; oblique: fewer


def test_max_fringes_is_the_longest_mirror_at_normal_incidence_ignoring_non_finite():
    d1 = torch.tensor([125.0, 250.0, math.nan, 100.0], dtype=F64)
    got = max_fringes(1.0, 1.5, d1, 375.0, torch.tensor([20, 20, 20, 60]), 380.0, 780.0)
    lengths = [20 * (1.0 * 125.0 + 1.5 * 375.0), 20 * (250.0 + 562.5), 60 * (100.0 + 562.5)]
    assert got == pytest.approx(max(lengths) * 2 * (1 / 380.0 - 1 / 780.0), rel=1e-14)
    # normal incidence lit from the host: the fringe count itself
    assert max_fringes(1.0, 1.5, 125.0, 375.0, 20, 380.0, 780.0) == pytest.approx(
        float(fringe_count(1.0, 1.0, 1.5, 125.0, 375.0, 20)), rel=1e-14)
    assert max_fringes(1.0, 1.5, math.nan, 375.0, 20, 380.0, 780.0) == 0.0


@pytest.mark.parametrize("d1, cells, per_fringe", [(125.0, 20, 192.0), (300.0, 30, 192.0), (125.0, 20, 16.0)])
def test_spectral_samples_follow_the_rule(d1, cells, per_fringe):
    fringes = cells * (1.0 * d1 + 1.5 * 375.0) * 2 * (1 / 380.0 - 1 / 780.0)
    want = max(math.ceil(per_fringe * fringes) + 1, 401)
    assert spectral_samples(1.0, 1.5, d1, 375.0, cells, samples_per_fringe=per_fringe) == want


def test_spectral_samples_clip():
    assert spectral_samples(1.0, 1.5, 10.0, 10.0, 1) == 401  # a thin mirror: min_samples
    assert spectral_samples(1.0, 1.5, 10.0, 10.0, 1, min_samples=2) == 14  # 192 × 0.0675 fringes → 13, + 1
    assert spectral_samples(1.0, 1.5, 125.0, 375.0, 10_000) == 262144  # max_samples
    assert spectral_samples(1.0, 1.5, 125.0, 375.0, 20, max_samples=1000) == 1000
    assert spectral_samples(1.0, 1.5, math.inf, 375.0, 20) == 401  # an infinite mirror does not count
