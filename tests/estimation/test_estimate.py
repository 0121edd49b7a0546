"""Tests of torchirid.estimation.noise's noise estimate, ``noise_level``, against closed forms, and of
the flags ``estimate_film`` reports.

The 4th difference Δ⁴y = y₋₂ − 4y₋₁ + 6y₀ − 4y₁ + y₂ annihilates every cubic exactly, multiplies
white noise of standard deviation σ by √(1 + 16 + 36 + 16 + 1) = √70, and the median absolute
value of a zero-mean Gaussian is σ Φ⁻¹(3/4). (``estimate_film`` itself — the bars on the paper's
samples, the index-model choice, progress, dead pixels — is tested in tests/estimation/test_refine.py
and test_invalid_pixels.py; its defaults against the command line's and the batch tool's in
tests/app/test_defaults.py.)
"""

from __future__ import annotations

import math
import statistics

import pytest
import torch

import torchirid.estimation as E
from torchirid.estimation import noise_level

F64 = torch.float64


def test_a_cubic_spectrum_has_no_noise():
    x = torch.linspace(-1.0, 1.0, 81, dtype=F64)
    y = 0.1 + 0.3 * x - 0.2 * x**2 + 0.05 * x**3  # Δ⁴ of a cubic is 0 (to rounding)
    assert noise_level(y.expand(4, 81)) < 1e-15


def test_gaussian_noise_gives_its_sigma():
    g = torch.Generator().manual_seed(1)
    sigma = 0.004
    y = 0.2 + sigma * torch.randn(400, 121, generator=g, dtype=F64)
    # 400 × 117 differences: the MAD's relative standard error is ~1/√(0.37 n) ≈ 0.8 %
    assert noise_level(y) == pytest.approx(sigma, rel=0.04)


def test_the_estimate_is_the_scaled_median_of_the_fourth_differences():
    g = torch.Generator().manual_seed(2)
    y = torch.rand(3, 9, generator=g, dtype=F64)
    d4 = [abs(r[b - 2] - 4 * r[b - 1] + 6 * r[b] - 4 * r[b + 1] + r[b + 2]) for r in y.tolist() for b in range(2, 7)]
    mad_to_sigma = 1 / statistics.NormalDist().inv_cdf(0.75)
    # torch's median of an even count is the lower middle value
    lower_median = sorted(d4)[(len(d4) - 1) // 2]
    assert noise_level(y) == pytest.approx(mad_to_sigma * lower_median / math.sqrt(70), rel=1e-12)


def test_outliers_and_missing_samples_barely_move_it():
    g = torch.Generator().manual_seed(4)
    sigma = 0.01
    y = 0.3 + sigma * torch.randn(200, 81, generator=g, dtype=F64)
    clean = noise_level(y)
    spiky = y.clone()
    spiky[::10, 40] = 5.0  # a spike in every 10th spectrum
    spiky[3, 7] = math.nan  # a missing sample: the 5 differences that contain it are skipped
    assert noise_level(spiky) == pytest.approx(clean, rel=0.03)
    assert math.isnan(noise_level(torch.full((2, 9), math.nan, dtype=F64)))


def test_fewer_than_five_bands_raise():
    with pytest.raises(ValueError, match="5 bands"):
        noise_level(torch.zeros(3, 4))


def test_the_index_search_reports_its_fallback(monkeypatch):
    """estimate_film's own ``settings["flags"]`` names the fallback when the grid overrules the peaks."""
    import torchirid.estimation.index_search as search
    from torchirid.estimation.estimate import RESTART_FLAG

    c = E.synthetic_cube("mgf2_400", height=2, width=2, seed=1)
    quick = dict(index_model_name="constant", thickness_range=(300.0, 500.0), iterations=2, final_iterations=0)
    clean = E.estimate_film(c.cube, c.wavelength, c.cos_theta, 1.64, **quick)
    assert clean.settings["index_start"] == "peaks" and clean.settings["flags"] == []
    monkeypatch.setattr(search, "RESTART_RATIO", 1e9)  # the grid always "clearly better": a forced restart
    est = E.estimate_film(c.cube, c.wavelength, c.cos_theta, 1.64, **quick)
    assert est.settings["index_start"] == "grid" and est.settings["flags"] == [RESTART_FLAG]


def test_no_track_error_names_estimate_films_own_remedies():
    """Issue 35.4: estimate_film takes no n_film — its error names what it does take (cos_theta,
    n_range) and the route for a known index, and says when the angles look like radians."""
    import inspect

    c = E.synthetic_cube("mgf2_400", height=2, width=2, seed=0)
    radians_as_degrees = torch.cos(torch.deg2rad(torch.deg2rad(c.angles_deg)))  # angles 0.17–0.87 rad read as °
    with pytest.raises(ValueError, match="look like radians, and must be degrees") as e:
        E.estimate_film(c.cube, c.wavelength, radians_as_degrees, 1.64)
    text = str(e.value)
    assert "pass n_film" not in text and "n_film" not in inspect.signature(E.estimate_film).parameters
    assert "widen n_range" in text and "torch.deg2rad" in text and "refine_film(" in text
    for named in ("cos_theta", "n_range"):
        assert named in text and named in inspect.signature(E.estimate_film).parameters
    with pytest.raises(ValueError, match="widen n_range") as e:  # the index outside n_range: no radians
        E.estimate_film(c.cube, c.wavelength, c.cos_theta, 1.64, n_range=(2.0, 3.5))
    assert "radians" not in str(e.value)


def test_radians_hint():
    from torchirid.estimation.peaks import radians_hint

    assert "look like radians" in radians_hint([0.17, 0.35, 0.52, 0.70, 0.87])
    assert radians_hint([10.0, 20.0, 30.0]) == "" and radians_hint([0.0, 0.0]) == "" and radians_hint([1.0]) == ""
    assert radians_hint([0.5, 1.6]) == ""  # 1.6 > π/2: not radians of an incidence angle

