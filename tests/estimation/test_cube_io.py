
import numpy as np
import pytest
import torch

from torchirid.estimation import synthetic_cube
from torchirid.estimation.cube_io import read_cube, write_envi, write_npz

pytest.importorskip("spectral")


def test_npz_round_trip(tmp_path):
    c = synthetic_cube("mgf2_400", height=3, width=4, seed=0)
    p = tmp_path / "c.npz"
    write_npz(p, c.cube, c.wavelength, c.angles_deg, bandwidth=4.0, thickness=c.thickness, meta={"n_true": 1.37})
    r = read_cube(p)
    assert torch.equal(r.cube, c.cube) and torch.equal(r.thickness, c.thickness)
    assert r.bandwidth == 4.0 and r.meta["n_true"] == 1.37
    assert torch.allclose(r.cos_theta, c.cos_theta)


def test_envi_round_trip_sorts_angles(tmp_path):
    c = synthetic_cube("zns_500", height=3, width=2, seed=0, angles_deg=(30.0, 10.0, 20.0))
    write_envi(tmp_path / "c.hdr", c.cube, c.wavelength, c.angles_deg, bandwidth=4.0)
    r = read_cube(tmp_path / "c.hdr")
    assert r.angles_deg.tolist() == [10.0, 20.0, 30.0]
    assert (r.cube - c.cube[:, :, [1, 2, 0]]).abs().max() < 1e-7  # float32 on disk
    assert r.bandwidth == 4.0 and torch.allclose(r.wavelength, c.wavelength)


def test_envi_one_file_per_angle(tmp_path):
    from spectral.io import envi

    c = synthetic_cube("mgf2_600", height=2, width=2, seed=0, angles_deg=(10.0, 20.0))
    paths = []
    for a in range(2):
        p = str(tmp_path / f"a{a}.hdr")
        envi.save_image(p, c.cube[:, :, a].numpy().astype(np.float32), force=True, ext=".img",
                        metadata={"wavelength": [str(v) for v in c.wavelength.tolist()]})
        paths.append(p)
    r = read_cube(paths, angles_deg=[10.0, 20.0])
    assert r.cube.shape == (2, 2, 2, 81) and (r.cube - c.cube).abs().max() < 1e-7


def test_bad_files(tmp_path):
    with pytest.raises(ValueError, match="npz"):
        read_cube(tmp_path / "x.txt")
    np.savez(tmp_path / "bad.npz", cube=np.zeros((2, 2, 1, 3)))
    with pytest.raises(ValueError, match="wavelength_nm"):
        read_cube(tmp_path / "bad.npz")
    with pytest.raises(ValueError, match="shape"):
        write_npz(tmp_path / "y.npz", np.zeros((2, 2, 2, 3)), [1, 2, 3], [10])
    with pytest.raises(ValueError, match="angle"):
        read_cube([str(tmp_path / "a.hdr"), str(tmp_path / "b.hdr")])


def test_envi_single_file_angles_from_the_caller(tmp_path):
    from spectral.io import envi

    c = synthetic_cube("zns_500", height=2, width=3, seed=0, angles_deg=(10.0, 40.0))
    H, W, A, B = c.cube.shape
    md = {"wavelength": [f"{v / 1000:.7g}" for v in c.wavelength.repeat(A).tolist()], "wavelength units": "Micrometers",
          "data ignore value": "-1"}
    data = c.cube.reshape(H, W, A * B).numpy().astype(np.float32)
    data[0, 0, :] = -1  # a dead pixel
    envi.save_image(str(tmp_path / "s.hdr"), data, metadata=md, force=True, ext=".img")
    r = read_cube(tmp_path / "s.hdr", angles_deg=[10.0, 40.0])
    assert r.cube.shape == (2, 3, 2, 81) and torch.allclose(r.wavelength, c.wavelength, atol=1e-3)
    assert r.cube[0, 0].isnan().all() and (r.cube[1:] - c.cube[1:]).abs().max() < 1e-7
    with pytest.raises(ValueError, match="do not divide"):
        read_cube(tmp_path / "s.hdr", angles_deg=[10.0, 20.0, 30.0, 40.0])
    with pytest.raises(ValueError, match="repeat the same 54 wavelengths"):
        read_cube(tmp_path / "s.hdr", angles_deg=[10.0, 20.0, 30.0])
    with pytest.raises(ValueError, match="incidence angle"):
        read_cube(tmp_path / "s.hdr")
    # with the field in the header, given angles must agree
    write_envi(tmp_path / "f.hdr", c.cube, c.wavelength, c.angles_deg)
    assert read_cube(tmp_path / "f.hdr", angles_deg=[10.0, 40.0]).angles_deg.tolist() == [10.0, 40.0]
    with pytest.raises(ValueError, match="disagrees"):
        read_cube(tmp_path / "f.hdr", angles_deg=[10.0, 45.0])
    p = tmp_path / "c.npz"
    write_npz(p, c.cube, c.wavelength, c.angles_deg)
    with pytest.raises(ValueError, match="disagrees"):
        read_cube(p, angles_deg=[20.0, 40.0])


def test_envi_per_angle_mismatches(tmp_path):
    from spectral.io import envi

    c = synthetic_cube("mgf2_600", height=2, width=2, seed=0, angles_deg=(10.0, 20.0))
    wl = [str(v) for v in c.wavelength.tolist()]
    envi.save_image(str(tmp_path / "a.hdr"), c.cube[:, :, 0].numpy().astype(np.float32), force=True, ext=".img",
                    metadata={"wavelength": wl})
    envi.save_image(str(tmp_path / "b.hdr"), c.cube[:, :1, 1].numpy().astype(np.float32), force=True, ext=".img",
                    metadata={"wavelength": wl})
    envi.save_image(str(tmp_path / "w.hdr"), c.cube[:, :, 1].numpy().astype(np.float32), force=True, ext=".img",
                    metadata={"wavelength": [str(v + 1) for v in c.wavelength.tolist()]})
    with pytest.raises(ValueError, match="lines x samples"):
        read_cube([tmp_path / "a.hdr", tmp_path / "b.hdr"], angles_deg=[10, 20])
    with pytest.raises(ValueError, match="same wavelengths"):
        read_cube([tmp_path / "a.hdr", tmp_path / "w.hdr"], angles_deg=[10, 20])
    with pytest.raises(ValueError, match="does not exist"):
        read_cube([tmp_path / "a.hdr", tmp_path / "missing.hdr"], angles_deg=[10, 20])
    with pytest.raises(ValueError, match="ENVI .hdr"):
        read_cube([tmp_path / "a.hdr", tmp_path / "c.npz"], angles_deg=[10, 20])


def test_envi_in_micrometres_converts_wavelengths_and_fwhm(tmp_path):
    """A header in micrometres: both the wavelengths and the band widths (fwhm) become nm."""
    import re

    c = synthetic_cube("zns_500", height=3, width=2, seed=0, angles_deg=(10.0, 20.0))
    write_envi(tmp_path / "c.hdr", c.cube, c.wavelength, c.angles_deg, bandwidth=4.0)
    hdr = (tmp_path / "c.hdr").read_text()

    def to_um(m):
        values = ", ".join(f"{float(v) / 1000.0:.9g}" for v in m.group(2).split(","))
        return f"{m.group(1)}{{{values}}}"

    hdr = re.sub(r"(wavelength = )\{([^}]*)\}", to_um, hdr)
    hdr = re.sub(r"(fwhm = )\{([^}]*)\}", to_um, hdr)
    hdr = re.sub(r"wavelength units = \w+", "wavelength units = micrometers", hdr)
    (tmp_path / "c.hdr").write_text(hdr)
    r = read_cube(tmp_path / "c.hdr")
    assert abs(r.bandwidth - 4.0) < 1e-9  # not 0.004 nm
    assert torch.allclose(r.wavelength, c.wavelength, atol=1e-6)
