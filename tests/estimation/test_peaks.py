import math

import pytest
import torch

import torchirid
from torchirid.estimation import synthetic_cube
from torchirid.estimation.peaks import (
    detect_extrema,
    index_from_peak_pair,
    index_from_tracks,
    peak_method,
    thickness_candidates,
    track_extrema,
)

F64 = torch.float64


def _true_peak(nf, d, deg, lo, hi):
    """The maximum of R(λ) by a dense golden-ratio-free grid + parabola (independent of the band model)."""
    lam = torch.linspace(lo, hi, 200001, dtype=F64)
    R = torchirid.thin_film_reflectance(lam, math.cos(math.radians(deg)), nf, d, 1.64, polarization="s")
    return float(lam[R.argmax()])


def test_eq12_and_regression_agree():
    c = torch.cos(torch.deg2rad(torch.tensor([10.0, 40.0], dtype=F64)))
    lam = 2 * 600 * torch.sqrt(1.37 ** 2 - (1 - c * c)) / 3
    s = (1 - c * c).sqrt()
    n12 = index_from_peak_pair(lam[0], lam[1], s[0], s[1])
    nreg, cnt = index_from_tracks(lam, c, min_angles=2)
    assert abs(float(n12) - 1.37) < 1e-12 and abs(float(nreg) - 1.37) < 1e-12 and int(cnt) == 2
    assert math.isnan(float(index_from_peak_pair(lam[0], lam[0], s[0], s[1])))


def test_sub_band_peak_precision():
    # 4 nm bands: the band argmax is up to 2 nm off; the parabola vertex must do much better
    cube = synthetic_cube("mgf2_400", height=1, width=1, gaussian_noise=0.0, shot_noise=0.0, thickness_variation=0.0,
                          polarization="s")
    pos, kind, W = detect_extrema(cube.clean[0, 0], cube.wavelength)
    for a, deg in enumerate((10, 20, 30, 40, 50)):
        p = pos[a][kind[a] == 1]
        assert p.numel() == 1
        truth = _true_peak(1.37, 400.0, deg, 450, 600)
        assert abs(float(p[0]) - truth) < 0.5
        band_argmax = float(cube.wavelength[cube.clean[0, 0, a].argmax()])
        assert abs(float(p[0]) - truth) <= abs(band_argmax - truth) + 0.05


def test_tracks_and_half_orders_for_dense_film():
    # ZnS (n > n_substrate): r01 r12 < 0, maxima at half-integer orders (the paper's eq. 9 assumes integers)
    cube = synthetic_cube("zns_500", height=1, width=2, gaussian_noise=0.0, shot_noise=0.0, thickness_variation=0.0,
                          polarization="s")
    Y = cube.clean.reshape(-1, 5, 81)
    pos, kind, _ = detect_extrema(Y, cube.wavelength)
    tracks, kinds = track_extrema(pos, kind, cube.cos_theta)
    full = (~tracks.isnan()).all(-1)
    assert bool(full.any())
    cand = thickness_candidates(tracks, kinds, cube.cos_theta, 2.37, 1.64, polarization="s")
    row = cand[0][~cand[0].isnan()]
    spacing = float(row.diff().median())
    assert abs(float(row[0]) - spacing / 2) < 1e-9 * spacing or abs(float(row[0]) - spacing * 1.5) < 1e-9 * spacing
    assert float((row - 500).abs().min()) < 0.06 * 500  # n(λ) of ZnS is not 2.37 at the peaks: a few % off


def test_peak_method_mgf2_and_the_papers_zns_bias():
    mg = synthetic_cube("mgf2_600", height=12, width=12, seed=2, polarization="s")
    r = peak_method(mg.cube, mg.wavelength, mg.cos_theta, 1.64, polarization="s")
    assert abs(r.n - 1.37) < 0.01
    assert float((r.thickness - mg.thickness).abs().mean()) < 5
    zn = synthetic_cube("zns_500", height=12, width=12, seed=2, polarization="s")
    rz = peak_method(zn.cube, zn.wavelength, zn.cos_theta, 1.64, polarization="s")
    # eq. 12 over a dispersive film lands far above n(589 nm) = 2.37, as the paper's 2.674 did
    assert rz.n - 2.37 > 0.15


def test_errors():
    with pytest.raises(ValueError, match="wavelength"):
        detect_extrema(torch.zeros(3, 10), torch.linspace(400, 500, 9))
    with pytest.raises(ValueError, match="uniformly"):
        detect_extrema(torch.zeros(10), torch.tensor([1.0, 2, 3, 4, 5, 6, 7, 8, 9, 11]))
    with pytest.raises(ValueError, match="sorted"):
        track_extrema(torch.zeros(1, 2, 3), torch.zeros(1, 2, 3, dtype=torch.int8), torch.tensor([0.5, 0.9]))
    flat = torch.full((2, 2, 5, 81), 0.04, dtype=F64)
    with pytest.raises(ValueError, match="n_film"):
        peak_method(flat, torch.arange(400.0, 721, 4, dtype=F64), torch.linspace(0.98, 0.64, 5, dtype=F64), 1.64)


def test_no_track_error_names_the_fix():
    """Issue 35.4: when eq. 12 finds no extremum followed over the angles, the error names what
    fixes it — for peak_method its n_film and n_range; angles in radians taken for degrees
    (cos of 0.17–0.87°) are called out as such."""
    from torchirid.estimation.peaks import NoTrackError

    c = synthetic_cube("mgf2_400", height=2, width=2, seed=0)
    radians_as_degrees = torch.cos(torch.deg2rad(torch.deg2rad(c.angles_deg)))  # 0.17–0.87 "degrees"
    with pytest.raises(NoTrackError, match="pass n_film") as e:
        peak_method(c.cube, c.wavelength, radians_as_degrees, 1.64)
    assert isinstance(e.value, ValueError) and "look like radians, and must be degrees" in str(e.value)
    assert e.value.angles_deg[0] == pytest.approx(0.1745, abs=1e-4) and e.value.n_range == (1.2, 3.5)
    # a film whose index lies outside n_range: no radians in the message, n_range named
    with pytest.raises(NoTrackError, match=r"widen n_range") as e:
        peak_method(c.cube, c.wavelength, c.cos_theta, 1.64, n_range=(2.0, 3.5))
    assert "radians" not in str(e.value) and "(2.0, 3.5)" in str(e.value)
    assert float(peak_method(c.cube, c.wavelength, radians_as_degrees, 1.64, n_film=1.37).thickness.mean()) > 0

