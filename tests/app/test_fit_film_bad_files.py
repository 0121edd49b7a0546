"""``torchirid fit-film`` on a cube it cannot read, and on a reversed ``--thickness-range``
(issue 22, item 1): exit status 2 and exactly one line on stderr that names the file, never a
traceback."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from torchirid.app import cli
from torchirid.estimation.cube_io import write_envi, write_npz

_WL, _ANG = [400.0, 404.0, 408.0, 412.0], [10.0, 20.0]
_CUBE = torch.full((2, 2, 2, 4), 0.3, dtype=torch.float64)


def _run(capsys, argv):
    with pytest.raises(SystemExit) as exc:
        cli.main(argv)
    captured = capsys.readouterr()
    return exc.value.code, captured.err


def _good_npz(path):
    write_npz(path, _CUBE, _WL, _ANG)
    return path


def _truncated(path):
    data = _good_npz(path).read_bytes()
    path.write_bytes(data[: len(data) // 2])


def _wrong_shape(path):
    np.savez(path, cube=np.zeros((2, 4)), wavelength_nm=np.asarray(_WL), angle_deg=np.asarray(_ANG))


def _envi_without_data(path):
    pytest.importorskip("spectral")
    write_envi(path, _CUBE, _WL, _ANG)
    path.with_suffix(".img").unlink()


BAD_CUBES = {
    "empty.npz": lambda p: p.write_bytes(b""),
    "text.npz": lambda p: p.write_text("not a cube at all\n"),
    "truncated.npz": _truncated,
    "few-bytes.npz": lambda p: p.write_bytes(b"PK\x03"),
    "wrong-shape.npz": _wrong_shape,
    "a-folder.npz": lambda p: p.mkdir(),
    "missing.npz": lambda p: None,
    "no-data-file.hdr": _envi_without_data,
}


@pytest.mark.parametrize("name", sorted(BAD_CUBES))
def test_unreadable_cube_is_one_line_and_status_2(tmp_path, capsys, name):
    path = tmp_path / name
    BAD_CUBES[name](path)
    code, err = _run(capsys, ["fit-film", str(path), "--out", str(tmp_path / "out")])
    assert code == 2
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("torchirid fit-film: error: ") and name in lines[0], err
    assert "Traceback" not in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("bounds", [("500", "100"), ("300", "300")])
def test_reversed_thickness_range_is_one_line_and_status_2(tmp_path, capsys, bounds):
    cube = _good_npz(tmp_path / "cube.npz")
    code, err = _run(capsys, ["fit-film", str(cube), "--out", str(tmp_path / "out"),
                              "--thickness-range", *bounds])
    assert code == 2
    assert err.splitlines() == [
        f"torchirid fit-film: error: --thickness-range: MIN must be < MAX (nm); got {bounds[0]} {bounds[1]}"]
    assert not (tmp_path / "out").exists()


def test_angles_in_radians_say_so(tmp_path, capsys):
    """Issue 35.4: a cube whose angles are in radians (0.17–0.87) fails with one line that says the
    angles look like radians and where to give them in degrees (the library's n_film is no
    option of fit-film)."""
    from torchirid.estimation import synthetic_cube

    c = synthetic_cube("mgf2_400", height=2, width=2, seed=0)
    path = tmp_path / "radians.npz"
    write_npz(path, c.cube, c.wavelength, torch.deg2rad(c.angles_deg))
    code, err = _run(capsys, ["fit-film", str(path), "--out", str(tmp_path / "out"), "--quiet"])
    assert code == 2 and len(err.splitlines()) == 1, err
    assert err.startswith("torchirid fit-film: error: no extremum of the cube could be followed over the angles")
    assert "look like radians, and must be degrees" in err and "180/π" in err and "--angles" in err
    assert "n_film" not in err and "n_range" not in err  # (library arguments the command does not take)
    assert not (tmp_path / "out").exists()

