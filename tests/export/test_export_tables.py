"""torchirid.export.tables: LUT raw/EXR exports with their JSON sidecar, read back."""

import json

import numpy as np
import pytest
import torch

from torchirid.export import (export_lut, read_exported_lut)
from torchirid.lut import LUT


def _lut(sizes, channels=(), dtype=torch.float64, seed=0):
    g = torch.Generator().manual_seed(seed)
    axes = {f"a{i}": torch.linspace(0.0, 1.0 + i, n, dtype=torch.float64) ** 1.5
            for i, n in enumerate(sizes)}
    vals = torch.randn(*sizes, *channels, generator=g, dtype=torch.float64).to(dtype)
    units = {"a0": "nm", "values": "1"}
    return LUT(vals, axes, builder="tests/test_export.py", parameters={"n": 3, "tag": "x"},
               units=units)


def _check_round_trip(src, back):
    assert back.axis_names == src.axis_names
    for n in src.axis_names:
        assert torch.equal(back.axes[n], src.axes[n])
    assert back.dtype == src.dtype
    torch.testing.assert_close(back.values, src.values.to(torch.float32).to(src.dtype),
                               rtol=0, atol=0)
    assert (back.builder, back.parameters, back.units, back.torchirid_version) == \
        (src.builder, src.parameters, src.units, src.torchirid_version)


@pytest.mark.parametrize("sizes,channels", [((5,), ()), ((4, 3), (3,)), ((3, 4, 2), (2, 3)),
                                            ((2, 3, 4, 5), ())])
@pytest.mark.parametrize("dtype", [torch.float64, torch.float32])
def test_raw_round_trip(tmp_path, sizes, channels, dtype):
    src = _lut(sizes, channels, dtype)
    data, side = export_lut(src, tmp_path / "t", format="raw")
    assert (data.name, side.name) == ("t.bin", "t.bin.json")
    raw = np.fromfile(data, dtype="<f4").reshape(*sizes, *channels)
    np.testing.assert_array_equal(raw, src.values.to(torch.float32).numpy())
    back = read_exported_lut(tmp_path / "t.bin")
    _check_round_trip(src, back)
    if dtype == torch.float32:
        assert back.hash == src.hash


def test_sidecar_content(tmp_path):
    src = _lut((4, 3), (3,))
    _, side = export_lut(src, tmp_path / "s.bin", format="raw", channel_names=["X", "Y", "Z"])
    meta = json.loads(side.read_text())
    assert meta["format"] == "torchirid.lut-export" and meta["container"] == "raw"
    assert meta["data_file"] == "s.bin" and meta["dtype"] == "float32"
    assert meta["byte_order"] == "little" and meta["shape"] == [4, 3, 3]
    assert [a["name"] for a in meta["axes"]] == ["a0", "a1"]
    assert meta["axes"][0]["unit"] == "nm" and meta["axes"][1]["unit"] is None
    assert meta["axes"][1]["values"] == src.axes["a1"].tolist()
    assert meta["channels"] == {"count": 3, "names": ["X", "Y", "Z"], "unit": "1"}
    assert meta["builder"] == src.builder and meta["parameters"] == {"n": 3, "tag": "x"}
    assert meta["source_hash"] == src.hash and meta["source_dtype"] == "float64"
    assert meta["torchirid_version"] == src.torchirid_version and meta["exported_by"]


def test_corrupt_and_bad_args(tmp_path):
    src = _lut((4, 3))
    data, _ = export_lut(src, tmp_path / "c", format="raw")
    b = bytearray(data.read_bytes())
    b[5] ^= 0xFF
    data.write_bytes(bytes(b))
    with pytest.raises(ValueError, match="data_sha256"):
        read_exported_lut(tmp_path / "c")
    data.write_bytes(bytes(b[:-4]))
    with pytest.raises(ValueError, match="bytes"):
        read_exported_lut(tmp_path / "c")
    with pytest.raises(ValueError, match="format must be"):
        export_lut(src, tmp_path / "c", format="png")
    with pytest.raises(ValueError, match="channel_names"):
        export_lut(_lut((4, 3), (2,)), tmp_path / "c", channel_names=["a"])
    with pytest.raises(ValueError, match="float32 range"):
        export_lut(LUT(torch.full((2,), 1e300, dtype=torch.float64), {"x": [0.0, 1.0]},
                       builder="t"), tmp_path / "c")
    with pytest.raises(ValueError, match="LUT"):
        export_lut(np.zeros(3), tmp_path / "c")


def test_raw_and_exr_exports_to_one_stem_keep_their_own_sidecars(tmp_path):
    """Each container has its sidecar (``<data file>.json``): a raw and an EXR export to the same
    stem overwrite nothing of each other, each file reads back its own export, and the bare
    stem, now ambiguous, is refused."""
    pytest.importorskip("OpenEXR")
    raw_src, exr_src = _lut((4, 3), (2,), seed=1), _lut((5, 2), (3,), seed=2)
    raw_files = export_lut(raw_src, tmp_path / "t", format="raw")
    _check_round_trip(raw_src, read_exported_lut(tmp_path / "t"))  # the stem: the only export
    before = [f.read_bytes() for f in raw_files]
    exr_files = export_lut(exr_src, tmp_path / "t.exr", format="exr")  # a suffix on the stem is dropped
    assert [f.name for f in raw_files + exr_files] == ["t.bin", "t.bin.json", "t.exr", "t.exr.json"]
    assert [f.read_bytes() for f in raw_files] == before  # untouched
    assert json.loads(raw_files[1].read_text())["container"] == "raw"
    assert json.loads(exr_files[1].read_text())["container"] == "exr"
    for path, src in ((raw_files[0], raw_src), (raw_files[1], raw_src), (tmp_path / "t.bin", raw_src),
                      (exr_files[0], exr_src), (exr_files[1], exr_src)):
        _check_round_trip(src, read_exported_lut(path))
    with pytest.raises(ValueError, match="ambiguous") as info:
        read_exported_lut(tmp_path / "t")
    assert "t.bin.json" in str(info.value) and "t.exr.json" in str(info.value)
    with pytest.raises(FileNotFoundError, match="nope"):
        read_exported_lut(tmp_path / "nope")
    raw_files[1].unlink()
    with pytest.raises(FileNotFoundError, match=r"t\.bin\.json"):
        read_exported_lut(raw_files[0])  # a data file never borrows another container's sidecar
    _check_round_trip(exr_src, read_exported_lut(tmp_path / "t"))  # the stem: the EXR export is left


@pytest.mark.parametrize("sizes,channels", [((6, 5), ()), ((6, 5), (4,)), ((4, 3), (7,)),
                                            ((5,), (2,)), ((3, 4, 2), (3,)), ((2, 3, 4, 5), ())])
def test_exr_round_trip(tmp_path, sizes, channels):
    OpenEXR = pytest.importorskip("OpenEXR")
    src = _lut(sizes, channels)
    data, side = export_lut(src, tmp_path / "e", format="exr")
    assert (data.name, side.name) == ("e.exr", "e.exr.json")
    back = read_exported_lut(side)
    _check_round_trip(src, back)
    lay = json.loads(side.read_text())["exr_layout"]
    img = OpenEXR.File(str(data), separate_channels=True)
    chans = img.parts[0].channels
    assert sorted(chans) == sorted(lay["channel_names"])
    first = chans[lay["channel_names"][0]].pixels
    assert first.dtype == np.float32 and first.shape == (lay["height"], lay["width"])
    if len(sizes) == 2:  # a 2-D LUT is the plain image: rows = axis 0, columns = axis 1
        v = src.values.to(torch.float32).reshape(*sizes, -1).numpy()
        np.testing.assert_array_equal(first, v[..., 0])
        n = v.shape[-1]
        assert lay["channel_names"] == (list("RGBA"[:n]) if n <= 4 else [f"ch{i:02d}" for i in range(n)])


def test_exr_atlas_layout(tmp_path):
    OpenEXR = pytest.importorskip("OpenEXR")
    src = _lut((5, 3, 4))  # 5 tiles of 3x4 → 3 tiles per row, 2 tile rows
    data, side = export_lut(src, tmp_path / "a", format="exr")
    lay = json.loads(side.read_text())["exr_layout"]
    assert (lay["tiles_x"], lay["tiles_y"], lay["width"], lay["height"]) == (3, 2, 12, 6)
    px = OpenEXR.File(str(data), separate_channels=True).parts[0].channels["R"].pixels
    v = src.values.to(torch.float32).numpy()
    t = 4  # tile row 1, column 1
    np.testing.assert_array_equal(px[3:6, 4:8], v[t])
    assert (px[3:6, 8:12] == 0).all()  # padding tile

