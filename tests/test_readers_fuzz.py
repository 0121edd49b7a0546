"""Every reader of a user's file meets one standard (issue 22, item 1): a damaged file raises a
``ValueError`` naming it and saying what is wrong — never a low-level exception (EOFError,
BadZipFile, IndexError, KeyError, TypeError, zlib/struct errors, the OpenEXR binding's
RuntimeError...). A missing data file beside a header or sidecar may raise FileNotFoundError
(which names it).

Each reader gets a valid file written by the library's own writer (checked to read back), then
bad variants of one of its files: empty, truncated to half and to a few bytes, text under the
right suffix, another format's bytes, and content of the wrong shape or type. One test id per
(reader, variant).
"""

from __future__ import annotations

import json
import shutil
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
import pytest
import torch

from torchirid.estimation.cube_io import read_cube, write_envi, write_npz
from torchirid.export import export_lut, read_exported_lut
from torchirid.fitting.measured import read_scatterogram, write_scatterogram, write_scatterogram
from torchirid.ibl.prefilter import read_environment
from torchirid.layered.filter_lut import FilterLUT, transmission_filter_lut
from torchirid.lut import LUT
from torchirid.spectral.correction import fitted_coefficients

# ----------------------------------------------------------------------------- valid files
_WL, _ANG = [400.0, 404.0, 408.0, 412.0], [10.0, 20.0]
_CUBE = torch.linspace(0.05, 0.6, 3 * 3 * 2 * 4, dtype=torch.float64).reshape(3, 3, 2, 4)
_PNG_BYTES = b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(40)  # another format's bytes (a PNG start)
_ZIP_BYTES = b"PK\x03\x04" + bytes(60)  # a zip (.npz) start


def _lut(builder: str = "tests/test_readers_fuzz.py") -> LUT:
    values = torch.rand(16, 24, generator=torch.Generator().manual_seed(0))  # noise: a half EXR cuts into pixels
    return LUT(values, {"x": torch.linspace(0.0, 1.0, 16), "y": torch.linspace(1.0, 2.0, 24)}, builder=builder)


def _xyz(n: int) -> torch.Tensor:
    return torch.full((n, n, 3), 0.2, dtype=torch.float64)


def _rgbe(height: int, width: int, *, orientation: bytes = b"-Y") -> bytes:
    """A Radiance .hdr written by hand: new-style RLE scanlines, one run per channel."""
    rows = b"".join(b"\x02\x02" + struct.pack(">H", width)
                    + b"".join(bytes([128 + width, v]) for v in (100, 120, 140, 129))
                    for _ in range(height))
    return (b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n" + orientation
            + b" %d +X %d\n" % (height, width) + rows)


def _write_exr(path: Path, channels: dict) -> None:
    OpenEXR = pytest.importorskip("OpenEXR")
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    OpenEXR.File(header, {k: np.ascontiguousarray(v, dtype=np.float32) for k, v in channels.items()}).write(str(path))


def _edit_json(path: Path, edit: Callable[[dict], None]) -> None:
    data = json.loads(path.read_text())
    edit(data)
    path.write_text(json.dumps(data))


def _resave_npz(path: Path, **changes) -> None:
    with np.load(path, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    arrays.update(changes)
    for k in [k for k, v in arrays.items() if v is None]:
        del arrays[k]
    with open(path, "wb") as f:
        np.savez(f, **arrays)


def _envi_header_edit(old: str, new: str) -> Callable[[Path], None]:
    def edit(p: Path) -> None:
        text = p.read_text()
        assert old in text, text
        p.write_text(text.replace(old, new))
    return edit


@dataclass
class Reader:
    """A reader, how to write a valid file set, which file of the set is damaged, how to read it."""

    build: Callable[[Path], Path]  # writes the valid files into a folder; returns the file to damage
    read: Callable[[Path], object]  # reads the set, given the file to damage
    needs: tuple[str, ...] = ()  # optional packages
    other: bytes = _PNG_BYTES  # another format's bytes under this suffix
    shapes: dict = field(default_factory=dict)  # wrong-shape/type variants: name → edit(target)
    data_file: bool = False  # the file is a data file beside a header/sidecar: "missing" applies
    generic: tuple[str, ...] = ("empty", "half", "few", "text", "other")


def _build_npz(d: Path) -> Path:
    write_npz(d / "cube.npz", _CUBE, _WL, _ANG, bandwidth=4.0, thickness=torch.ones(3, 3), meta={"n_true": 1.4})
    return d / "cube.npz"


def _build_envi(d: Path) -> Path:
    write_envi(d / "cube.hdr", _CUBE, _WL, _ANG, bandwidth=4.0)
    return d / "cube.hdr"


def _build_envi_data(d: Path) -> Path:
    _build_envi(d)
    return d / "cube.img"


def _build_png(d: Path) -> Path:
    return write_scatterogram(d / "scan.png", _xyz(8))


def _build_exr(d: Path) -> Path:
    pytest.importorskip("OpenEXR")
    return write_scatterogram(d / "scan.exr", torch.rand(16, 16, 3, generator=torch.Generator().manual_seed(0)) * 0.5)  # (noise: a half file cuts into the pixel chunks)


def _build_env_exr(d: Path) -> Path:
    rng = np.random.default_rng(0)
    _write_exr(d / "sky.exr", {c: rng.uniform(0.0, v, (16, 32)) for c, v in zip("RGB", (0.5, 1.0, 2.0))})
    return d / "sky.exr"


def _build_env_hdr(d: Path) -> Path:
    (d / "sky.hdr").write_bytes(_rgbe(4, 16))
    return d / "sky.hdr"


def _build_lut(d: Path) -> Path:
    return _lut().write(d / "table.npz")


def _build_filter_lut(d: Path) -> Path:
    table = transmission_filter_lut(0.3, theta_i_step_deg=10.0, u_nodes=9, rtol=0.5, max_theta_i_nodes=20,
                                    max_u_nodes=20)
    return table.write(d / "filter.npz")


def _build_export(fmt: str, target: int) -> Callable[[Path], Path]:
    def build(d: Path) -> Path:
        return export_lut(_lut(), d / "table", format=fmt)[target]
    return build


def _read_export(target: Path) -> LUT:
    return read_exported_lut(target.with_name("table"))  # from the stem: the reader finds the sidecar


def _build_correction(d: Path) -> Path:
    data = {"format": "torchirid.angular_correction", "format_version": 1, "coefficients": {"a": 0.1, "b": 0.9}}
    (d / "correction.json").write_text(json.dumps(data))
    return d / "correction.json"


def _sidecar_shapes() -> dict:
    return {
        "list": lambda p: p.write_text("[1, 2, 3]"),
        "missing-key": lambda p: _edit_json(p, lambda s: s.pop("shape")),
        "shape-type": lambda p: _edit_json(p, lambda s: s.update(shape="4x3")),
        "shape-size": lambda p: _edit_json(p, lambda s: s.update(shape=[16, 25])),
        "axes-type": lambda p: _edit_json(p, lambda s: s.update(axes=[1, 2])),
        "axis-values": lambda p: _edit_json(p, lambda s: s["axes"][0].update(values=["a"] * 16)),
        "dtype-type": lambda p: _edit_json(p, lambda s: s.update(source_dtype=[32])),
        "builder-type": lambda p: _edit_json(p, lambda s: s.update(builder=7)),
        "data-file": lambda p: _edit_json(p, lambda s: s.update(data_file="../elsewhere.bin")),
    }


READERS: dict[str, Reader] = {
    "cube-npz": Reader(_build_npz, read_cube, shapes={
        "cube-2d": lambda p: _resave_npz(p, cube=np.zeros((3, 4))),
        "cube-strings": lambda p: _resave_npz(p, cube=np.array(["a", "b"])),
        "cube-bands": lambda p: _resave_npz(p, cube=np.zeros((3, 3, 2, 5))),
        "no-wavelength": lambda p: _resave_npz(p, wavelength_nm=None),
        "thickness-shape": lambda p: _resave_npz(p, thickness_nm=np.zeros(4)),
        "bandwidth-array": lambda p: _resave_npz(p, bandwidth_nm=np.arange(3.0)),
        "meta-not-json": lambda p: _resave_npz(p, meta=np.array("{oops")),
        "angles-range": lambda p: _resave_npz(p, angle_deg=np.array([10.0, 95.0])),
        "a-lut": lambda p: _lut().write(p),
    }),
    "envi-header": Reader(_build_envi, read_cube, needs=("spectral",), other=_ZIP_BYTES, shapes={
        "wavelength-count": _envi_header_edit("wavelength = {", "wavelength = { 396 ,"),
        "wavelength-text": _envi_header_edit("wavelength = {", "wavelength = { abc"),
        "angle-text": _envi_header_edit("incidence angle = {", "incidence angle = { x"),
        "scale-zero": _envi_header_edit("wavelength units", "reflectance scale factor = 0\nwavelength units"),
    }),
    "envi-data": Reader(_build_envi_data, lambda p: read_cube(p.with_suffix(".hdr")), needs=("spectral",),
                        data_file=True, generic=("empty", "half", "few", "text")),
    "png": Reader(_build_png, read_scatterogram, other=_ZIP_BYTES, shapes={
        "one-pixel": lambda p: write_scatterogram(p, _xyz(1)),
        "no-image-data": lambda p: p.write_bytes(p.read_bytes()[:33] + p.read_bytes()[-12:]),  # IHDR + IEND
    }),
    "exr-scatterogram": Reader(_build_exr, read_scatterogram, needs=("OpenEXR",), shapes={
        "one-pixel": lambda p: write_scatterogram(p, _xyz(1)),
        "no-rgb": lambda p: _write_exr(p, {"Z": np.zeros((4, 4))}),
    }),
    "exr-environment": Reader(_build_env_exr, read_environment, needs=("OpenEXR",), shapes={
        "no-rgb": lambda p: _write_exr(p, {"Z": np.zeros((4, 8))}),
    }),
    "hdr-environment": Reader(_build_env_hdr, read_environment, shapes={
        "orientation": lambda p: p.write_bytes(_rgbe(4, 16, orientation=b"+Y")),
        "header-only": lambda p: p.write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n"),
        "too-many-rows": lambda p: p.write_bytes(_rgbe(4, 16).replace(b"-Y 4", b"-Y 9")),
        "huge-size": lambda p: p.write_bytes(_rgbe(4, 16).replace(b"-Y 4 +X 16", b"-Y 99999 +X 99999")),
    }),
    "lut": Reader(_build_lut, LUT.read, shapes={
        "a-cube": lambda p: write_npz(p, _CUBE, _WL, _ANG),
        "no-meta": lambda p: _resave_npz(p, meta=None),
    }),
    "filter-lut": Reader(_build_filter_lut, FilterLUT.read, shapes={
        "another-table": lambda p: _lut().write(p),
    }),
    "export-raw-data": Reader(_build_export("raw", 0), _read_export, data_file=True,
                              shapes={"too-long": lambda p: p.write_bytes(p.read_bytes() + bytes(4))}),
    "export-raw-sidecar": Reader(_build_export("raw", 1), _read_export, shapes=_sidecar_shapes()),
    "export-exr-data": Reader(_build_export("exr", 0), _read_export, needs=("OpenEXR",), data_file=True, shapes={
        "other-channels": lambda p: _write_exr(p, {"Z": np.zeros((16, 24))}),
        "other-size": lambda p: _write_exr(p, {"R": np.zeros((2, 2))}),
    }),
    "export-exr-sidecar": Reader(_build_export("exr", 1), _read_export, needs=("OpenEXR",), shapes={
        **_sidecar_shapes(),
        "no-layout": lambda p: _edit_json(p, lambda s: s.pop("exr_layout")),
        "layout-size": lambda p: _edit_json(p, lambda s: s["exr_layout"].update(width=9)),
    }),
    "correction-json": Reader(_build_correction, fitted_coefficients, shapes={
        "list": lambda p: p.write_text("[1, 2]"),
        "no-coefficients": lambda p: _edit_json(p, lambda s: s.pop("coefficients")),
        "coefficient-text": lambda p: _edit_json(p, lambda s: s["coefficients"].update(a="0.1")),
    }),
}


def _variant(reader: Reader, name: str) -> Callable[[Path], None]:
    if name in reader.shapes:
        return reader.shapes[name]
    return {
        "empty": lambda p: p.write_bytes(b""),
        "half": lambda p: p.write_bytes(p.read_bytes()[:p.stat().st_size // 2]),
        "few": lambda p: p.write_bytes(p.read_bytes()[:5]),
        "text": lambda p: p.write_text("this is not the file you are looking for\n"),
        "other": lambda p: p.write_bytes(reader.other),
        "missing": lambda p: p.unlink(),
    }[name]


CASES = [(r, v) for r, reader in READERS.items()
         for v in (*reader.generic, *reader.shapes, *(("missing",) if reader.data_file else ()))]


@pytest.fixture(scope="module")
def valid_sets(tmp_path_factory):
    """Valid file sets, each written once into its own folder (copied by every test)."""
    built: dict[str, tuple[Path, Path]] = {}

    def get(name: str) -> tuple[Path, Path]:
        reader = READERS[name]
        for module in reader.needs:
            pytest.importorskip(module)
        if name not in built:
            folder = tmp_path_factory.mktemp(name)
            built[name] = folder, reader.build(folder)
        return built[name]

    return get


def _copy(valid_sets, name: str, tmp_path: Path) -> Path:
    folder, target = valid_sets(name)
    dest = tmp_path / name
    shutil.copytree(folder, dest)
    return dest / target.name


@pytest.mark.parametrize("name", list(READERS))
def test_valid_file_reads(valid_sets, tmp_path, name):
    assert READERS[name].read(_copy(valid_sets, name, tmp_path)) is not None


@pytest.mark.parametrize("name,variant", CASES, ids=[f"{r}-{v}" for r, v in CASES])
def test_bad_file_raises_value_error_naming_it(valid_sets, tmp_path, name, variant):
    reader = READERS[name]
    target = _copy(valid_sets, name, tmp_path)
    _variant(reader, variant)(target)
    try:
        reader.read(target)
    except ValueError as exc:
        message = str(exc)
    except FileNotFoundError as exc:
        assert variant == "missing", f"{type(exc).__name__}: {exc}"
        message = str(exc)
    except Exception as exc:  # noqa: BLE001 - the point: no other exception type
        pytest.fail(f"{name}/{variant}: raised {type(exc).__name__}: {exc}")
    else:
        pytest.fail(f"{name}/{variant}: read a bad file without an error")
    assert target.name in message, message
    assert "\n" not in message.strip(), message


def test_the_cases_cover_every_kind_of_damage():
    variants = {v for _, v in CASES}
    assert {"empty", "half", "few", "text", "other", "missing"} <= variants
    for name, reader in READERS.items():
        assert reader.shapes or reader.data_file, f"{name}: no wrong-shape variant"
