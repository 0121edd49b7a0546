
import pytest
import torch

from torchirid.estimation import synthetic_cube
from torchirid.presets import KOBAYASHI_SAMPLES as SAMPLES
from torchirid.estimation.measurement import band_reflectance

F64 = torch.float64


def test_seeded_and_documented_ranges():
    a = synthetic_cube("mgf2_600", height=6, width=7, seed=3, polarization="s")
    b = synthetic_cube("mgf2_600", height=6, width=7, seed=3, polarization="s")
    c = synthetic_cube("mgf2_600", height=6, width=7, seed=4, polarization="s")
    assert torch.equal(a.cube, b.cube) and not torch.equal(a.cube, c.cube)
    assert a.cube.shape == (6, 7, 5, 81)
    assert abs(float(a.thickness.min()) - 540.0) < 1e-9 and abs(float(a.thickness.max()) - 660.0) < 1e-9


@pytest.mark.parametrize("name", list(SAMPLES))
def test_clean_cube_matches_thin_film_reflectance(name):
    cube = synthetic_cube(name, height=2, width=3, seed=1, polarization="s")
    s = cube.sample
    i, j = 1, 2
    ref = band_reflectance(cube.wavelength, cube.cos_theta[:, None], s.n_film, cube.thickness[i, j], s.n_substrate,
                           nodes=8, polarization="s")
    assert (cube.clean[i, j] - ref).abs().max() < 1e-13


def test_noise_levels():
    cube = synthetic_cube("zns_500", height=24, width=24, gaussian_noise=0.01, shot_noise=0.0, seed=0, polarization="s")
    r_max = float(cube.clean.max())
    std = float((cube.cube - cube.clean).std())
    assert abs(std / (0.01 * r_max) - 1) < 0.05
    shot = synthetic_cube("zns_500", height=24, width=24, gaussian_noise=0.0, shot_noise=0.02, seed=0, polarization="s")
    z = (shot.cube - shot.clean) / (0.02 * (shot.clean * float(shot.clean.max())).sqrt())
    assert abs(float(z.std()) - 1) < 0.05


def test_zns_is_dispersive_and_named():
    s = SAMPLES["zns_500"]
    assert abs(s.n_reference - 2.37) < 0.005
    assert float(s.n_at(400.0)) - float(s.n_at(720.0)) > 0.2


@pytest.mark.parametrize("kw,match", [
    (dict(sample="gold"), "sample"), (dict(height=0), "height"), (dict(shot_noise=-1), "shot_noise"),
    (dict(angles_deg=[10, 95]), "angles_deg"), (dict(thickness_variation=1.5), "thickness_variation"),
])
def test_bad_arguments(kw, match):
    kw = {"sample": "mgf2_400", **kw}
    with pytest.raises(ValueError, match=match):
        synthetic_cube(**kw)


def test_pixel_blocks_follow_the_chunk_knob():
    """Pixels are rendered in blocks of torchirid.options(chunk_size=...) // (pol × A × B × nodes)
    pixels (torchirid._chunks); None: in one piece. Pixels are independent: the same cube."""
    import torchirid as ti
    from block_sizes import largest_tensor

    call = lambda: synthetic_cube("mgf2_400", height=16, width=16, seed=1)  # noqa: E731
    ref, whole = largest_tensor(call, None)
    got, block = largest_tensor(call, 20000)
    torch.testing.assert_close(got.cube, ref.cube, rtol=1e-15, atol=1e-17)
    per_pixel = 2 * 5 * 81  # pol × angles × bands (× passband nodes)
    assert whole >= 256 * per_pixel * 2  # one piece: every pixel's samples at once
    assert block < whole / 3  # blocks of 64 pixels (the least a block holds)
    assert ti.options("chunk_size") == "auto"
