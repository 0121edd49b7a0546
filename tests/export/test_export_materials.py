"""torchirid.export.materials: thin-film glTF / OpenPBR materials."""

import json

import pytest
import torch

from torchirid.export import (thin_film_material,
                              write_thin_film_material)
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


def test_thin_film_material_values():
    m = thin_film_material(1.33, (250.0, 400.0), n_substrate=1.5, roughness=0.2)
    ir = m["gltf_material"]["extensions"]["KHR_materials_iridescence"]
    assert ir == {"iridescenceFactor": 1.0, "iridescenceIor": 1.33,
                  "iridescenceThicknessMinimum": 250.0, "iridescenceThicknessMaximum": 400.0}
    assert m["gltf_material"]["extensions"]["KHR_materials_ior"] == {"ior": 1.5}
    op = m["openpbr"]
    assert op["thin_film_weight"] == 1.0 and op["thin_film_ior"] == 1.33
    assert op["thin_film_thickness"] == pytest.approx(0.4)  # µm
    assert any("non-absorbing" in s for s in m["approximations"]["gltf"])
    assert any("texture" in s.lower() for s in m["approximations"]["gltf"])
    assert any("single film" in s for s in m["approximations"]["openpbr"])
    metal = thin_film_material(1.5, 300, n_substrate=complex(0.2, 3.0))
    pbr = metal["gltf_material"]["pbrMetallicRoughness"]
    f0 = abs((complex(0.2, 3.0) - 1) / (complex(0.2, 3.0) + 1)) ** 2
    assert pbr["metallicFactor"] == 1.0 and pbr["baseColorFactor"][:3] == pytest.approx([f0] * 3)
    assert "KHR_materials_ior" not in metal["gltf_material"]["extensions"]
    assert metal["openpbr"]["base_metalness"] == 1.0


@pytest.mark.parametrize("args,kw,match", [
    ((0.9, 300.0), {}, "n_film"), ((complex(1.5, 0.1), 300.0), {}, "real"),
    ((1.4, -1.0), {}, "thickness"), ((1.4, (400.0, 100.0)), {}, "min <= max"),
    ((1.4, (1.0, 2.0, 3.0)), {}, "min, max"), ((1.4, float("nan")), {}, "thickness"),
    ((1.4, 300.0), {"n_substrate": [1.5, 1.6]}, "3 numbers"), ((1.4, 300.0), {"roughness": 2.0}, "roughness"),
    ((1.4, 300.0), {"n_substrate": -1.0}, "positive"),
])
def test_thin_film_material_errors(args, kw, match):
    with pytest.raises(ValueError, match=match):
        thin_film_material(*args, **kw)


def test_write_gltf_and_openpbr(tmp_path):
    paths = write_thin_film_material(tmp_path / "film", 1.33, (100.0, 700.0), format="both")
    assert [p.name for p in paths] == ["film.gltf", "film.openpbr.json"]
    doc = json.loads(paths[0].read_text())
    assert doc["asset"]["version"] == "2.0"
    assert set(doc["extensionsUsed"]) == {"KHR_materials_iridescence", "KHR_materials_ior"}
    (mat,) = doc["materials"]
    assert set(mat["extensions"]) <= set(doc["extensionsUsed"])
    assert mat["extensions"]["KHR_materials_iridescence"]["iridescenceIor"] == 1.33
    assert mat["extras"]["torchirid"]["approximations"]
    op = json.loads(paths[1].read_text())
    assert op["openpbr"]["thin_film_thickness"] == pytest.approx(0.7) and op["approximations"]
    only = write_thin_film_material(tmp_path / "m.gltf", 1.4, 250.0)
    assert [p.name for p in only] == ["m.gltf"]
    with pytest.raises(ValueError, match="infer"):
        write_thin_film_material(tmp_path / "m.txt", 1.4, 250.0)
    with pytest.raises(ValueError, match="format must be"):
        write_thin_film_material(tmp_path / "m", 1.4, 250.0, format="usd")
    pygltflib = pytest.importorskip("pygltflib")
    g = pygltflib.GLTF2().load(str(paths[0]))
    assert g.asset.version == "2.0" and len(g.materials) == 1
    assert g.materials[0].extensions["KHR_materials_iridescence"]["iridescenceThicknessMaximum"] == 700.0

