import math

import numpy as np
import pytest
import torch

from torchirid.ibl import read_environment, prefilter_environment, synthetic_environment
from torchirid.ibl.prefilter import MOMENT_CHANNELS, equirect_directions, light_moments_to_mean_cov

F64 = torch.float64
SUN = torch.tensor([0.5, 0.3, 0.8124], dtype=F64)
SUN = SUN / SUN.norm()


def test_equirect_directions_convention():
    d, w = equirect_directions(6, 12)
    assert d.shape == (6, 12, 3) and w.shape == (6, 12)
    assert torch.allclose(d.norm(dim=-1), torch.ones(6, 12, dtype=F64), atol=1e-15)
    assert abs(float(w.sum()) - 4 * math.pi) < 1e-12
    assert float(d[0, :, 2].min()) > 0.9 and float(d[-1, :, 2].max()) < -0.9  # row 0 = zenith
    phi = torch.atan2(d[3, :, 1], d[3, :, 0]) % (2 * math.pi)
    assert torch.allclose(phi, (torch.arange(12, dtype=F64) + 0.5) * 2 * math.pi / 12, atol=1e-12)


def test_synthetic_environment():
    env = synthetic_environment(32, 64)
    assert env.shape == (32, 64, 3) and env.dtype == F64 and bool((env >= 0).all())
    d, _ = equirect_directions(32, 64)
    brightest = d.reshape(-1, 3)[env[..., 1].reshape(-1).argmax()]
    assert float(brightest @ SUN) > math.cos(0.06)
    assert synthetic_environment(8, 16, dtype=torch.float32).dtype == torch.float32
    assert int((synthetic_environment(4, 8, sky=False).sum(-1) > 0).sum()) >= 1  # sun survives coarse maps


def test_constant_environment():
    env = torch.full((32, 64, 3), 2.5, dtype=F64)
    pre = prefilter_environment(env, [0.05, 0.3, 1.0], resolution=(8, 16))
    assert pre.radiance.shape == (3, 8, 16, 3) and pre.moments.shape == (3, 8, 16, 9)
    assert len(MOMENT_CHANNELS) == 9
    assert float((pre.radiance - 2.5).abs().max()) < 1e-12
    mu, cov = pre.mean_cov()
    R = pre.directions.expand_as(mu)
    assert float(torch.cross(mu, R, dim=-1).norm(dim=-1).max()) < 2e-3  # mean ∥ R (texel-grid asymmetry)
    assert float((mu * R).sum(-1).min()) > 0
    norms = mu.norm(dim=-1).amax(dim=(1, 2))
    assert float(norms.max()) <= 1.0 and bool((norms[1:] < norms[:-1]).all())  # wider lobe, shorter mean
    assert float(torch.linalg.eigvalsh(cov).min()) > -1e-12
    assert torch.allclose(cov, cov.transpose(-1, -2))


def test_sun_mean_points_to_sun():
    env = synthetic_environment(32, 64, sky=False)
    pre = prefilter_environment(env, [0.05, 0.5], resolution=(8, 16))
    mu, cov = pre.mean_cov()
    d, w = equirect_directions(32, 64)
    lit = env[..., 1] > 0
    centroid = (d[lit] * w[lit][:, None]).sum(0)
    centroid = centroid / centroid.norm()  # the discretised disc's direction (2 texels at 32 × 64)
    assert float(centroid @ SUN) > math.cos(math.radians(2.0))
    front = (pre.directions * SUN).sum(-1) > 0.2
    cos_to_sun = (mu / mu.norm(dim=-1, keepdim=True) * centroid).sum(-1)
    assert float(cos_to_sun[0][front].min()) > math.cos(math.radians(1.0))  # within the disc (texel spacing 5.6°)
    assert float(mu[0][front].norm(dim=-1).min()) > 0.99  # a near-delta light: |μ| ≈ 1, Σ ≈ 0
    assert float(torch.linalg.eigvalsh(cov[0][front]).max()) < 5e-3
    # radiance tracks the sun: the output direction nearest the sun is the brightest at α = 0.05
    k = int((pre.directions.reshape(-1, 3) @ SUN).argmax())
    assert k == int(pre.radiance[0, ..., 1].reshape(-1).argmax())


def test_dark_lobe_falls_back_to_lobe_moments():
    env = torch.zeros(16, 32, 3, dtype=F64)
    pre = prefilter_environment(env, 0.3, resolution=(4, 8))
    assert bool(torch.isfinite(pre.moments).all()) and float(pre.radiance.abs().max()) == 0.0
    mu, _ = pre.mean_cov()
    assert float((mu * pre.directions).sum(-1).min()) > 0.5


def test_float32_and_grad():
    env = synthetic_environment(16, 32, dtype=torch.float32).requires_grad_()
    pre = prefilter_environment(env, torch.tensor([0.2, 0.6]), resolution=4)
    assert pre.radiance.dtype == torch.float32 and pre.radiance.shape == (2, 4, 8, 3)
    assert bool(torch.isfinite(pre.moments).all())
    (pre.radiance.sum() + pre.moments.sum()).backward()
    assert bool(torch.isfinite(env.grad).all())


def test_moments_to_mean_cov():
    m = torch.tensor([0.1, 0.2, 0.3, 0.5, 0.4, 0.2, 0.05, 0.06, 0.07], dtype=F64).expand(2, 3, 9)
    mu, cov = light_moments_to_mean_cov(m)
    assert mu.shape == (2, 3, 3) and cov.shape == (2, 3, 3, 3)
    assert abs(float(cov[0, 0, 0, 1]) - (0.05 - 0.02)) < 1e-15
    assert abs(float(cov[0, 0, 2, 0]) - (0.07 - 0.03)) < 1e-15
    with pytest.raises(ValueError, match="m must have shape"):
        light_moments_to_mean_cov(torch.zeros(3, 8))


@pytest.mark.parametrize("kwargs, match", [
    (dict(env=torch.ones(4, 8)), "env must have shape"),
    (dict(env=-torch.ones(4, 8, 3)), "env must be >= 0"),
    (dict(alphas=0.0), "alphas"),
    (dict(alphas=torch.ones(2, 2)), "alphas must be a scalar or 1-D"),
    (dict(resolution=(0, 4)), "resolution"),
    (dict(resolution=2.5), "resolution"),
])
def test_prefilter_bad_input(kwargs, match):
    args = dict(env=torch.ones(4, 8, 3, dtype=F64), alphas=0.5, resolution=2) | kwargs
    with pytest.raises(ValueError, match=match):
        prefilter_environment(args.pop("env"), args.pop("alphas"), **args)


def test_bad_synthetic_and_directions():
    with pytest.raises(ValueError, match="height"):
        equirect_directions(0, 4)
    with pytest.raises(ValueError, match="sun_direction"):
        synthetic_environment(4, 8, sun_direction=(0, 0, 0))
    with pytest.raises(ValueError, match="dtype"):
        synthetic_environment(4, 8, dtype=torch.int32)


def test_load_environment_exr_round_trip(tmp_path):
    OpenEXR = pytest.importorskip("OpenEXR")
    rgb = np.random.default_rng(0).uniform(0, 50, (6, 10, 3)).astype(np.float32)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    OpenEXR.File(header, {c: np.ascontiguousarray(rgb[..., i]) for i, c in enumerate("RGB")}).write(
        str(tmp_path / "env.exr"))
    env = read_environment(tmp_path / "env.exr")
    assert env.shape == (6, 10, 3) and env.dtype == F64
    assert np.array_equal(env.numpy(), rgb.astype(np.float64))
    pre = prefilter_environment(env, 0.5, resolution=2)
    assert bool(torch.isfinite(pre.radiance).all())


def _rgbe(height, width, rng):
    px = rng.integers(0, 256, (height, width, 4), dtype=np.uint8)
    px[..., 3] = rng.integers(120, 140, (height, width))
    px[0, 0, 3] = 0  # a black texel
    px[1, 2:7, :] = px[1, 2, :]  # a run for the RLE encoder
    e = px[..., 3].astype(np.int32)
    expected = np.where(e[..., None] == 0, 0.0, (px[..., :3] + 0.5) * np.ldexp(1.0, e - 136)[..., None])
    return px, expected


def _rle_line(px):
    out = bytearray([2, 2, px.shape[0] >> 8, px.shape[0] & 255])
    for ch in range(4):
        v, x = px[:, ch], 0
        while x < len(v):
            run = 1
            while x + run < len(v) and run < 127 and v[x + run] == v[x]:
                run += 1
            if run >= 3:
                out += bytes([128 + run, v[x]])
                x += run
            else:
                n = min(128, len(v) - x)
                out += bytes([n]) + bytes(v[x:x + n])
                x += n
    return bytes(out)


@pytest.mark.parametrize("rle", [False, True])
def test_load_environment_hdr(tmp_path, rle):
    px, expected = _rgbe(5, 12, np.random.default_rng(1))
    body = b"".join(_rle_line(px[r]) for r in range(5)) if rle else px.tobytes()
    path = tmp_path / "env.hdr"
    path.write_bytes(b"#?RADIANCE\n# made by a test\nFORMAT=32-bit_rle_rgbe\n\n-Y 5 +X 12\n" + body)
    env = read_environment(path)
    assert env.shape == (5, 12, 3)
    assert np.array_equal(env.numpy(), expected)
    assert read_environment(path, dtype=torch.float32).dtype == torch.float32


def test_load_environment_errors(tmp_path):
    with pytest.raises(ValueError, match=r"\.exr, \.hdr"):
        read_environment(tmp_path / "env.png")
    bad = tmp_path / "bad.hdr"
    bad.write_bytes(b"P6\n")
    with pytest.raises(ValueError, match="not a Radiance"):
        read_environment(bad)
    bad.write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 1\n\x00\x00\x00\x00")
    with pytest.raises(ValueError, match="FORMAT"):
        read_environment(bad)
    bad.write_bytes(b"#?RADIANCE\n\n+Y 1 +X 1\n\x00\x00\x00\x00")
    with pytest.raises(ValueError, match="orientation"):
        read_environment(bad)
    bad.write_bytes(b"#?RADIANCE\n\n-Y 2 +X 2\n\x00\x00\x00\x00")
    with pytest.raises(ValueError, match="truncated"):
        read_environment(bad)
    notexr = tmp_path / "x.exr"
    notexr.write_bytes(b"abcd")
    with pytest.raises(ValueError, match="not an OpenEXR"):
        read_environment(notexr)


def test_constant_environment_mean_length_matches_1d_quadrature():
    # for a constant map the lobe is symmetric about R: |μ| = ∫ w c dc / ∫ w dc, c = ⟨R, l⟩ ∈ [0, 1]
    from torchirid.microfacet import ggx_d

    x, wq = np.polynomial.legendre.leggauss(400)
    c = torch.tensor((x + 1) / 2, dtype=F64)
    pre = prefilter_environment(torch.ones(64, 128, 3, dtype=F64), [0.3, 0.7], resolution=(4, 8))
    got = pre.mean_cov()[0].norm(dim=-1)
    for k, a in enumerate((0.3, 0.7)):
        w = torch.tensor(wq, dtype=F64) * ggx_d(torch.sqrt((1 + c) / 2), a) * c
        ref = float((w * c).sum() / w.sum())
        assert float((got[k] - ref).abs().max()) < 2e-4, (a, ref)  # measured 2.9e-5 / 4.0e-5


def test_feeds_filtered_thin_film_xyz():
    """Sun-only map: the prefiltered moments at ω_r = reflect(ω_o, n) make eq. 20–29 use the sun's direction.

    An output texel ≈ 15° off the sun, α = 0.3: the lobe sees only the sun, so μ_ωi ≈ sun and
    Σ ≈ 0, and the filtered colour equals Belcour–Barla's eq. 4 at cos θ1 = ⟨h, sun⟩ for the
    view — not at the mirror value ⟨n, ω_o⟩ of the lobe's axis.
    """
    from torchirid.ibl import thin_film_xyz_filtered, thin_film_xyz_fourier

    env = synthetic_environment(32, 64, sky=False)
    pre = prefilter_environment(env, [0.05, 0.3], resolution=(16, 32))
    mu, cov = pre.mean_cov()
    R = pre.directions.reshape(-1, 3)
    off = torch.rad2deg(torch.acos((R @ SUN).clamp(-1, 1)))
    k = int((off - 15.0).abs().argmin())
    r, m, C = R[k], mu[1].reshape(-1, 3)[k], cov[1].reshape(-1, 3, 3)[k]
    n = torch.nn.functional.normalize(torch.tensor([0.1, 0.0, 1.0], dtype=F64), dim=-1)
    v = 2.0 * (r @ n) * n - r  # the view whose ideal reflection about n is r
    assert float(v @ n) > 0.3 and 10.0 < float(off[k]) < 20.0
    sun_hat = m / m.norm()
    assert float(sun_hat @ SUN) > math.cos(math.radians(2.0)) and float(torch.linalg.eigvalsh(C).max()) < 1e-3
    film = (1.3, 600.0, complex(2.0, 0.5))
    xyz = thin_film_xyz_filtered(v, m, C, *film, sensitivity="exact")
    cos1_sun = torch.sqrt(0.5 * (1.0 + sun_hat @ v))
    at_sun = thin_film_xyz_fourier(cos1_sun, *film, terms=2, sensitivity="exact")
    at_mirror = thin_film_xyz_fourier(v @ n, *film, terms=2, sensitivity="exact")
    err_sun, err_mirror = float((xyz - at_sun).abs().max()), float((xyz - at_mirror).abs().max())
    assert err_sun < 1e-4 and err_mirror > 100 * err_sun  # measured 1.0e-5 vs 3.0e-2


def test_prefiltered_maps_round_trip_as_lut_and_exr(tmp_path):
    from torchirid.export import export_lut, read_exported_lut
    from torchirid.ibl import PrefilteredEnvironment, prefilter_environment, synthetic_environment
    from torchirid.lut import LUT

    env = synthetic_environment(16, 32)
    pre = prefilter_environment(env, torch.tensor([0.5, 0.1], dtype=torch.float64), resolution=4)
    lut = pre.to_lut(parameters={"env": "synthetic 16x32"})
    assert lut.axis_names == ("alpha", "theta", "phi") and lut.channel_shape == (12,)
    path = lut.write(tmp_path / "pre.npz")
    back = PrefilteredEnvironment.from_lut(LUT.read(path))
    assert torch.equal(back.alphas, torch.tensor([0.1, 0.5], dtype=torch.float64))  # sorted by roughness
    assert torch.equal(back.radiance[1], pre.radiance[0]) and torch.equal(back.moments[0], pre.moments[1])
    assert torch.allclose(back.directions, pre.directions)
    pytest.importorskip("OpenEXR")
    files = export_lut(lut, tmp_path / "pre", format="exr")
    exr = read_exported_lut(files[0])
    assert torch.allclose(exr.values.double(), lut.values, rtol=1e-6, atol=1e-6)
    with pytest.raises(ValueError, match="2 roughness levels"):
        prefilter_environment(env, 0.5, resolution=2).to_lut()
    with pytest.raises(ValueError, match="to_lut"):
        PrefilteredEnvironment.from_lut(LUT(torch.zeros(2), {"x": torch.tensor([0.0, 1.0])}, builder="other"))


@pytest.mark.slow
def test_shipped_dfg_matches_builder():
    from torchirid.ibl import dfg_lut, shipped_dfg_lut
    from torchirid.ibl.dfg import DFG_SHIPPED

    lut = shipped_dfg_lut()
    assert lut.parameters["resolution"] == DFG_SHIPPED["resolution"]
    small = dfg_lut(DFG_SHIPPED["resolution"], samples=DFG_SHIPPED["samples"])
    assert (lut.values - small.values).abs().max() < 1e-6  # float32 on disk


def test_output_blocks_follow_the_chunk_knob():
    """Output directions are evaluated in blocks of torchirid.options(chunk_size=...) // texels
    (torchirid._chunks); None: every (output, texel) pair at once. Outputs are independent: the
    same values."""
    from block_sizes import largest_tensor

    env = torch.rand(16, 32, 3, dtype=F64, generator=torch.Generator().manual_seed(0))
    call = lambda: prefilter_environment(env, [0.2, 0.5], resolution=16)  # noqa: E731
    ref, whole = largest_tensor(call, None)
    got, block = largest_tensor(call, 8192)
    torch.testing.assert_close(got.radiance, ref.radiance, rtol=1e-15, atol=1e-17)
    torch.testing.assert_close(got.moments, ref.moments, rtol=1e-15, atol=1e-17)
    assert whole >= (16 * 32) ** 2  # one piece: outputs × texels
    assert block <= 64 * 512 < whole  # blocks of 64 outputs (8192 // 512 = 16, at least 64) × 512 texels


def test_synthetic_scenes():
    """sun_sky: a CIE clear sky whose sun keeps its power on any map size; indoor: a room with bright sources."""
    from torchirid.ibl.prefilter import equirect_directions

    irradiance = []
    for h in (16, 32, 64):
        sun = synthetic_environment(h, 2 * h, scene="sun_sky", sky=False, sun_radius=0.03, sun_radiance=2000.0)
        _, omega = equirect_directions(h, 2 * h)
        irradiance.append(float((sun[..., 0] * omega).sum()))
    disc = 2000.0 * 2.0 * math.pi * (1.0 - math.cos(0.03))
    assert all(abs(e / disc - 1.0) < 1e-12 for e in irradiance)
    sky = synthetic_environment(32, 64, scene="sun_sky", sun_radius=0.03, sun_radiance=2000.0)
    d, _ = equirect_directions(32, 64)
    up = d[..., 2] > 0.05
    assert float(sky[up].min()) > 0 and float(sky[~up].max()) < float(sky[up].max())
    room = synthetic_environment(32, 64, scene="indoor")
    bright = room.sum(-1) > 10.0
    assert 0.01 < float(bright.double().mean()) < 0.1  # a few bright sources
    assert float(room[~bright].max()) < 0.5 and float(room.min()) > 0
    with pytest.raises(ValueError, match="scene"):
        synthetic_environment(8, 16, scene="studio")
