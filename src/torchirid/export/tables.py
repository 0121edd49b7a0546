r"""LUT exports for renderers: raw float32 / OpenEXR files with a JSON sidecar.

LUT exports (:func:`export_lut`, read back with :func:`read_exported_lut`)
--------------------------------------------------------------------------
``export_lut(lut, "out/dfg", format="raw")`` writes

* ``out/dfg.bin``: the values as little-endian float32, C order, shape
  ``(n_1, ..., n_k, *channels)`` (the :class:`~torchirid.lut.LUT` layout, no header);
* ``out/dfg.bin.json``: the sidecar (below).

``format="exr"`` writes ``out/dfg.exr`` (float32 pixels, ZIP compression, lossless) plus its
sidecar ``out/dfg.exr.json``.  The sidecar of a data file is always its name plus ``.json``, so a
raw and an EXR export to the same stem live side by side.  The channels (flattened in C order) are the EXR channels ``R, G, B, A`` for up
to four of them, ``ch00, ch01, ...`` beyond.  The image is an *atlas* of 2-D tiles: each tile
spans the last two axes (rows = axis ``k-2``, columns = axis ``k-1``; a 1-D LUT is one
``1 × n_1`` tile); the leading axes (flattened in C order into a tile index ``t``) pick the
tile, placed at tile row ``t // tiles_x`` and tile column ``t % tiles_x`` with
``tiles_x = ceil(sqrt(T))``; unused tiles are zero.  Pixel ``(y, x)`` (``y = 0`` the first
scanline) of LUT index ``(i_1, ..., i_k)`` is ``y = (t // tiles_x) * n_{k-1} + i_{k-1}``,
``x = (t % tiles_x) * n_k + i_k``.  A 2-D LUT is therefore a plain ``n_1 × n_2`` image.

Sidecar keys: ``format`` (``"torchirid.lut-export"``), ``format_version``, ``container``
(``"raw"``/``"exr"``), ``data_file`` (name, same directory), ``dtype`` (``"float32"``),
``byte_order`` (``"little"``), ``shape``, ``channel_shape``, ``axes`` (list of ``{name,
size, unit, values}``, the node values in the source dtype written as exact decimal
doubles), ``channels`` (``names``, ``unit``), ``builder``, ``parameters``, ``units``,
``torchirid_version`` (that built the LUT), ``exported_by`` (exporting torchirid version),
``source_hash`` / ``source_dtype`` / ``source_format_version`` (the LUT's content hash,
see :mod:`torchirid.lut`), ``data_sha256`` (SHA-256 of the float32 values in the LUT layout,
little-endian C order, independent of the container) and, for EXR, ``exr_layout``.
Both files are written atomically (data first, then the sidecar).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
import torch

from .. import _checks
from .._io import atomic_write, check_readable, file_error, read_exr_channels
from ..lut import LUT
from .._version import __version__

__all__ = ["EXPORT_FORMATS", "export_lut", "read_exported_lut"]

#: Containers of :func:`export_lut`.
EXPORT_FORMATS = ("raw", "exr")
_TAG = "torchirid.lut-export"
_VERSION = 1
_SUFFIX = {"raw": ".bin", "exr": ".exr"}
_DTYPES = {"float16": torch.float16, "bfloat16": torch.bfloat16, "float32": torch.float32,
           "float64": torch.float64}




_WHAT_SIDE, _WHAT_DATA = "LUT export sidecar", "LUT data file"
#: sidecar keys every export has (``exr_layout`` too for EXR)
_SIDECAR_KEYS = ("format", "format_version", "container", "data_file", "shape", "channel_shape", "axes",
                 "builder", "parameters", "units", "torchirid_version", "source_hash", "source_dtype",
                 "data_sha256")
_LAYOUT_INTS = ("tile_rows", "tile_cols", "n_tiles", "tiles_x", "tiles_y", "width", "height")


def _stem(path) -> Path:
    """``path`` without a trailing ``.bin.json`` / ``.exr.json`` / ``.bin`` / ``.exr`` / ``.json``."""
    p = Path(path)
    low = p.name.lower()
    for suffix in (".bin.json", ".exr.json", ".bin", ".exr", ".json"):
        if low.endswith(suffix) and len(low) > len(suffix):
            return p.with_name(p.name[:-len(suffix)])
    return p


def _sidecar_of(data_path: Path) -> Path:
    """The sidecar of a data file: its name plus ``.json`` (``dfg.bin`` → ``dfg.bin.json``)."""
    return data_path.with_name(data_path.name + ".json")


def _find_sidecar(path) -> tuple[Path, str | None]:
    """(the sidecar of ``path``, the data file name asked for or None) for :func:`read_exported_lut`."""
    p = Path(path)
    low = p.name.lower()
    if low.endswith(".json"):  # the sidecar itself
        return p, None
    if low.endswith((".bin", ".exr")):
        side = _sidecar_of(p)
        if not side.exists():
            raise FileNotFoundError(f"no export sidecar for {str(p)!r}: {str(side)!r} does not exist")
        return side, p.name
    candidates = [_sidecar_of(p.with_name(p.name + ext)) for ext in (".bin", ".exr")]
    found = [side for side in candidates if side.exists()]
    if len(found) > 1:
        raise ValueError(f"path {str(p)!r} is ambiguous: a raw and an EXR export share this stem "
                         f"({found[0].name}, {found[1].name}); pass the .bin or .exr file, or its sidecar")
    if not found:
        raise FileNotFoundError(f"no LUT export at {str(p)!r}: neither {str(candidates[0])!r} nor "
                                f"{str(candidates[1])!r} exists")
    return found[0], None


def _openexr():
    from .._io import import_openexr  # noqa: PLC0415  (optional dependency)

    try:
        return import_openexr()
    except ImportError as exc:
        raise ImportError("exporting LUTs as OpenEXR needs the optional 'openexr' package: "
                          "pip install openexr (or pip install 'torchirid[exr]')") from exc


def _channel_names(n: int) -> list[str]:
    if n <= 4:
        return list("RGBA"[:n])
    width = len(str(n - 1))
    return [f"ch{i:0{max(width, 2)}d}" for i in range(n)]


def _atlas_layout(axis_sizes: list[int]) -> dict:
    if len(axis_sizes) == 1:
        rows, cols, lead = 1, axis_sizes[0], []
    else:
        rows, cols, lead = axis_sizes[-2], axis_sizes[-1], axis_sizes[:-2]
    n_tiles = math.prod(lead)
    tiles_x = math.isqrt(n_tiles - 1) + 1 if n_tiles > 1 else 1
    tiles_y = -(-n_tiles // tiles_x)
    return {"tile_rows": rows, "tile_cols": cols, "n_tiles": n_tiles, "tiles_x": tiles_x,
            "tiles_y": tiles_y, "width": tiles_x * cols, "height": tiles_y * rows}


def _to_atlas(a: np.ndarray, lay: dict) -> np.ndarray:
    """(n_1..n_k, C) float32 → (H, W, C) atlas."""
    T, r, c, tx, ty = lay["n_tiles"], lay["tile_rows"], lay["tile_cols"], lay["tiles_x"], lay["tiles_y"]
    t = a.reshape(T, r, c, a.shape[-1])
    if tx * ty > T:
        t = np.concatenate([t, np.zeros((tx * ty - T, r, c, a.shape[-1]), t.dtype)])
    return t.reshape(ty, tx, r, c, -1).transpose(0, 2, 1, 3, 4).reshape(ty * r, tx * c, -1)


def _from_atlas(img: np.ndarray, lay: dict) -> np.ndarray:
    """(H, W, C) atlas → (T, rows, cols, C)."""
    T, r, c, tx, ty = lay["n_tiles"], lay["tile_rows"], lay["tile_cols"], lay["tiles_x"], lay["tiles_y"]
    t = img.reshape(ty, r, tx, c, -1).transpose(0, 2, 1, 3, 4).reshape(ty * tx, r, c, -1)
    return t[:T]


def _float32_values(lut: LUT) -> np.ndarray:
    v = lut.values.detach().to("cpu")
    finite = torch.isfinite(v)
    v32 = v.to(torch.float32)
    if bool((finite & ~torch.isfinite(v32)).any()):
        raise ValueError("the LUT has finite values beyond the float32 range (|v| > 3.4e38); "
                         "they would become infinite in the export: rescale the table first")
    return np.ascontiguousarray(v32.numpy(), dtype="<f4")


def export_lut(lut: LUT, path, *, format: str = "raw", channel_names=None) -> tuple[Path, Path]:
    """Write ``lut`` for a renderer: a float32 data file plus a JSON sidecar (layout above).

    Args:
        lut: a :class:`~torchirid.lut.LUT` (any float dtype; values are written as float32).
        path: the output stem; ``<path>.bin`` and its sidecar ``<path>.bin.json`` (raw), or
            ``<path>.exr`` and ``<path>.exr.json`` (EXR), are written (a trailing ``.bin``,
            ``.exr``, ``.json``, ``.bin.json`` or ``.exr.json`` on ``path`` is dropped), so the
            two containers of one stem never overwrite each other.  The directory must exist.
        format: ``"raw"`` (little-endian float32 ``.bin``) or ``"exr"`` (OpenEXR float32
            atlas; needs the optional ``openexr`` package).
        channel_names: optional names of the flattened channels, recorded in the sidecar
            (default: ``lut.parameters["channels"]`` when it is a list of that many strings).

    Returns:
        ``(data_path, sidecar_path)``.

    Raises:
        ValueError: unknown format, values overflowing float32, bad ``channel_names``.
        ImportError: ``format="exr"`` without ``openexr``.

    Example (the shipped DFG table, 64 × 64 × 2, for a shader):
        >>> import json, os, tempfile
        >>> from torchirid.ibl import shipped_dfg_lut
        >>> with tempfile.TemporaryDirectory() as folder:
        ...     data, sidecar = export_lut(shipped_dfg_lut(), os.path.join(folder, "dfg"))
        ...     size, side = data.stat().st_size, json.loads(sidecar.read_text())
        >>> data.name, sidecar.name, size  # 64 · 64 · 2 float32 values
        ('dfg.bin', 'dfg.bin.json', 32768)
        >>> side["shape"], [axis["name"] for axis in side["axes"]]
        ([64, 64, 2], ['cos_theta_o', 'alpha'])
    """
    if not isinstance(lut, LUT):
        raise ValueError(f"lut must be a torchirid.lut.LUT, got {type(lut).__name__}")
    _checks.check_choice(format, "format", EXPORT_FORMATS)
    stem = _stem(path)
    data_path = stem.with_name(stem.name + _SUFFIX[format])
    side_path = _sidecar_of(data_path)
    values = _float32_values(lut)
    sizes = [int(g.numel()) for g in lut.axes.values()]
    n_ch = math.prod(lut.channel_shape)
    if channel_names is None:
        cand = lut.parameters.get("channels")
        if isinstance(cand, list) and len(cand) == n_ch and all(isinstance(s, str) for s in cand):
            channel_names = cand
    elif (isinstance(channel_names, str) or len(list(channel_names)) != n_ch
          or not all(isinstance(s, str) for s in channel_names)):
        raise ValueError(f"channel_names must be {n_ch} strings (one per flattened channel of "
                         f"channel shape {lut.channel_shape}), got {channel_names!r}")
    units = lut.units
    side = {
        "format": _TAG, "format_version": _VERSION, "container": format,
        "data_file": data_path.name, "dtype": "float32", "byte_order": "little",
        "order": "C", "shape": list(values.shape), "channel_shape": list(lut.channel_shape),
        "axes": [{"name": n, "size": int(g.numel()), "unit": units.get(n),
                  "values": [float(x) for x in g.detach().to("cpu", torch.float64).tolist()]}
                 for n, g in lut.axes.items()],
        "channels": {"count": n_ch, "names": list(channel_names) if channel_names else None,
                     "unit": units.get("values")},
        "builder": lut.builder, "parameters": lut.parameters, "units": units,
        "torchirid_version": lut.torchirid_version, "exported_by": __version__,
        "source_hash": lut.hash, "source_dtype": str(lut.dtype).removeprefix("torch."),
        "source_format_version": lut.meta["format_version"],
        "data_sha256": hashlib.sha256(values.tobytes()).hexdigest(),
    }
    if format == "raw":
        def write(f):
            f.write(values.tobytes())
    else:
        OpenEXR = _openexr()
        lay = _atlas_layout(sizes)
        img = _to_atlas(values.reshape(*sizes, n_ch).astype(np.float32), lay)
        names = _channel_names(n_ch)
        side["exr_layout"] = dict(lay, channel_names=names, pixel_type="FLOAT",
                                  compression="ZIP", tile_axes=list(lut.axis_names)[-2:],
                                  tile_index_axes=list(lut.axis_names)[:-2], padding=0.0,
                                  description="tile t (leading axes flattened in C order) at "
                                  "tile row t // tiles_x, tile column t % tiles_x; rows of a "
                                  "tile = axis k-1, columns = axis k (a 1-D LUT: one row); "
                                  "y = 0 is the first scanline; channels flattened in C order")
        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
        exr = OpenEXR.File(header, {c: np.ascontiguousarray(img[..., i]) for i, c in enumerate(names)})

        def write(f):  # the binding writes to a name: encode privately, copy into atomic_write's file
            with tempfile.TemporaryDirectory() as tmp:
                name = os.path.join(tmp, "lut.exr")
                exr.write(name)
                with open(name, "rb") as src:
                    shutil.copyfileobj(src, f)
    atomic_write(data_path, write)
    text = json.dumps(side, indent=1, allow_nan=False) + "\n"
    atomic_write(side_path, lambda f: f.write(text.encode("utf-8")))
    return data_path, side_path


def _is_int(v, lo: int = 0) -> bool:
    return isinstance(v, int) and not isinstance(v, bool) and v >= lo


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _read_sidecar(side_path: Path) -> dict:
    """The sidecar at ``side_path``, checked key by key (ValueError naming it otherwise)."""
    check_readable(side_path, _WHAT_SIDE)

    def bad(why):
        return file_error(_WHAT_SIDE, side_path, why)

    try:
        side = json.loads(side_path.read_bytes().decode("utf-8"))
    except ValueError as e:  # JSONDecodeError and UnicodeDecodeError are ValueErrors
        raise bad(f"is not JSON ({e})") from e
    if not isinstance(side, dict) or side.get("format") != _TAG:
        raise bad(f"is not a torchirid LUT export (no \"format\": \"{_TAG}\")")
    if side.get("format_version") != _VERSION:
        raise bad(f"has an unsupported format_version {side.get('format_version')!r} (expected {_VERSION})")
    missing = [k for k in _SIDECAR_KEYS if k not in side]
    if missing:
        raise bad(f"lacks key(s) {missing}")
    if side["container"] not in EXPORT_FORMATS:
        raise bad(f"has an unknown container {side['container']!r} (expected one of {EXPORT_FORMATS})")
    name = side["data_file"]
    if not isinstance(name, str) or not name or Path(name).name != name:
        raise bad(f"data_file must be a bare file name; got {name!r}")
    axes = side["axes"]
    if (not isinstance(axes, list) or not axes
            or not all(isinstance(a, dict) and isinstance(a.get("name"), str) and _is_int(a.get("size"), 2)
                       and isinstance(a.get("values"), list) and len(a["values"]) == a["size"]
                       and all(_is_number(v) for v in a["values"]) for a in axes)):
        raise bad("axes must be a non-empty list of {name, size >= 2, values: size numbers}")
    shape, channel_shape = side["shape"], side["channel_shape"]
    for key, v in (("shape", shape), ("channel_shape", channel_shape)):
        if not isinstance(v, list) or not all(_is_int(n, 1) for n in v):
            raise bad(f"{key} must be a list of whole numbers >= 1; got {v!r}")
    sizes = [a["size"] for a in axes]
    if shape != sizes + channel_shape:
        raise bad(f"shape {shape} disagrees with the axis sizes {sizes} and channel_shape {channel_shape}")
    for key in ("builder", "torchirid_version", "source_hash", "data_sha256"):
        if not isinstance(side[key], str):
            raise bad(f"{key} must be a string; got {side[key]!r}")
    for key in ("parameters", "units"):
        if not isinstance(side[key], dict):
            raise bad(f"{key} must be a JSON object; got {side[key]!r}")
    if not isinstance(side["source_dtype"], str) or side["source_dtype"] not in _DTYPES:
        raise bad(f"source_dtype must be one of {sorted(_DTYPES)}; got {side['source_dtype']!r}")
    if side["container"] == "exr":
        lay = side.get("exr_layout")
        if not isinstance(lay, dict) or not all(_is_int(lay.get(k), 1) for k in _LAYOUT_INTS):
            raise bad(f"exr_layout must give {', '.join(_LAYOUT_INTS)} (whole numbers >= 1)")
        expected = _atlas_layout(sizes)
        if any(lay[k] != expected[k] for k in _LAYOUT_INTS):
            raise bad(f"exr_layout { {k: lay[k] for k in _LAYOUT_INTS} } disagrees with the axis sizes {sizes}")
        names = lay.get("channel_names")
        if (not isinstance(names, list) or len(names) != math.prod(channel_shape)
                or not all(isinstance(c, str) for c in names)):
            raise bad(f"exr_layout channel_names must be {math.prod(channel_shape)} channel names; got {names!r}")
    return side


def read_exported_lut(path, *, dtype: torch.dtype | None = None) -> LUT:
    """Rebuild the :class:`~torchirid.lut.LUT` written by :func:`export_lut` (for checks).

    ``path`` is the stem, the data file (``.bin``/``.exr``) or its sidecar; a stem with both a
    raw and an EXR export is ambiguous (ValueError: pass a file).  Values come back as the
    float32 data converted to ``dtype`` (default: the source dtype; axes are exact).  The
    float32 data are checked against the sidecar's ``data_sha256``; for a
    float16/bfloat16/float32 source the rebuilt LUT's hash must also equal ``source_hash``.

    Raises:
        FileNotFoundError: no sidecar, or no data file beside it (the message names it).
        ValueError: an empty, truncated, damaged or foreign sidecar or data file, a sidecar
            with a missing key or a value of the wrong type, data of the wrong size, or a hash
            mismatch (the message names the file).

    Example (a round trip through a raw export):
        >>> import os, tempfile, torch
        >>> from torchirid.ibl import shipped_dfg_lut
        >>> dfg = shipped_dfg_lut()  # float64
        >>> with tempfile.TemporaryDirectory() as folder:
        ...     data, _ = export_lut(dfg, os.path.join(folder, "dfg"))
        ...     back = read_exported_lut(data)  # or the stem, or the sidecar
        >>> back.axis_names, back.dtype, back.builder == dfg.builder
        (('cos_theta_o', 'alpha'), torch.float64, True)
        >>> torch.allclose(back.values, dfg.values, atol=1e-6)  # the values went through float32
        True
    """
    side_path, asked = _find_sidecar(path)
    side = _read_sidecar(side_path)
    name = side["data_file"]
    if asked is not None and name != asked:
        raise file_error(_WHAT_SIDE, side_path, f"describes the data file {name!r}, not {asked!r}")
    data_path = side_path.with_name(name)
    shape = side["shape"]
    if side["container"] == "raw":
        raw = check_readable(data_path, _WHAT_DATA).read_bytes()
        if len(raw) != 4 * math.prod(shape):
            raise file_error(_WHAT_DATA, data_path, f"has {len(raw)} bytes; its sidecar {str(side_path)!r} gives "
                                                    f"float32 shape {shape}, {4 * math.prod(shape)} bytes")
        values = np.frombuffer(raw, dtype="<f4").reshape(shape)
    else:
        lay = side["exr_layout"]
        chans = read_exr_channels(data_path, _WHAT_DATA)
        absent = [c for c in lay["channel_names"] if c not in chans]
        if absent:
            raise file_error(_WHAT_DATA, data_path, f"lacks the channel(s) {absent} of its sidecar; it has "
                                                    f"{sorted(chans)}")
        img = np.stack([np.asarray(chans[c], dtype=np.float32) for c in lay["channel_names"]], -1)
        if img.shape[:2] != (lay["height"], lay["width"]):
            raise file_error(_WHAT_DATA, data_path, f"is {img.shape[1]} x {img.shape[0]} pixels; its sidecar "
                                                    f"{str(side_path)!r} gives {lay['width']} x {lay['height']}")
        values = _from_atlas(img, lay).reshape(shape)
    values = np.ascontiguousarray(values, dtype="<f4")
    if hashlib.sha256(values.tobytes()).hexdigest() != side["data_sha256"]:
        raise file_error(_WHAT_DATA, data_path, "is corrupted: data_sha256 mismatch")
    src = _DTYPES[side["source_dtype"]]
    axes = {a["name"]: torch.tensor(a["values"], dtype=torch.float64) for a in side["axes"]}
    try:
        lut = LUT(torch.from_numpy(values.astype(np.float32)).to(src), axes, builder=side["builder"],
                  parameters=side["parameters"], units=side["units"],
                  torchirid_version=side["torchirid_version"])
    except ValueError as e:
        raise file_error(_WHAT_SIDE, side_path, f"does not describe a valid LUT ({e})") from e
    if src != torch.float64 and lut.hash != side["source_hash"]:
        raise file_error(_WHAT_DATA, data_path, "does not rebuild the exported LUT: its hash differs from the "
                                                "sidecar's source_hash")
    return lut.to(dtype=dtype) if dtype is not None else lut


# ----------------------------------------------------------------------------- thin film
