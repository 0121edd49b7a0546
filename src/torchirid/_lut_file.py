"""The on-disk side of :class:`torchirid.lut.LUT`: the format constants, the canonical JSON
metadata and content hash inputs, and reading a file back with every check (the layout is
described in :mod:`torchirid.lut`)."""

from __future__ import annotations

import json
from collections.abc import Iterable
from pathlib import Path

import numpy as np
import torch

from ._version import __version__

#: Version of the on-disk layout described in the module docstring.
FORMAT_VERSION = 1
#: Out-of-range policies of :meth:`LUT.interp`.
EXTRAPOLATE_MODES = ("clamp", "error", "linear")
#: Keys accepted by the ``expect=`` argument of :meth:`LUT.read`.
EXPECT_KEYS = ("axes", "channels", "units")

_FORMAT_TAG = "torchirid.lut"
_RESERVED_AXIS_NAMES = frozenset({"extrapolate"})  # keyword of interp(); cannot be an axis
_FLOAT_DTYPES = (torch.float16, torch.bfloat16, torch.float32, torch.float64)
_SAVABLE = {torch.float16: np.float16, torch.float32: np.float32, torch.float64: np.float64}
_FROM_NUMPY = {np.dtype(np.float16): torch.float16, np.dtype(np.float32): torch.float32,
               np.dtype(np.float64): torch.float64}
_ZIP_MAGIC = (b"PK\x03\x04", b"PK\x05\x06")  # an .npz is a zip: a local file header, or an empty archive
_META_KEYS = ("format", "format_version", "builder", "parameters", "units",
              "torchirid_version", "axes", "shape", "dtype", "hash")


# ----------------------------------------------------------------------------- helpers
def _current_version() -> str:
    """torchirid's version (recorded in every LUT written)."""
    return __version__


def _json_default(o):
    if isinstance(o, np.generic):  # numpy scalars → plain Python numbers
        return o.item()
    raise TypeError(f"object of type {type(o).__name__} is not JSON serialisable")


def _canonical_json(obj) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), ensure_ascii=True,
                      allow_nan=False, default=_json_default)


def _normalise_json(obj, name: str):
    """``obj`` as it will come back from a JSON round trip (tuples → lists, ...)."""
    try:
        return json.loads(_canonical_json(obj))
    except (TypeError, ValueError) as e:
        raise ValueError(
            f"{name} must be JSON-serialisable (str keys; numbers finite; lists, dicts, str, "
            f"bool, None; convert tensors with .tolist()): {e}"
        ) from None


def _dtype_name(dtype: torch.dtype) -> str:
    return str(dtype).removeprefix("torch.")


def _le_bytes(t: torch.Tensor) -> bytes:
    """Little-endian C-order bytes of a tensor (bfloat16 hashed through its bit pattern)."""
    t = t.detach().to("cpu").contiguous()
    if t.dtype == torch.bfloat16:
        t = t.view(torch.int16)
    a = t.numpy()
    return np.ascontiguousarray(a, dtype=a.dtype.newbyteorder("<")).tobytes()


class _LUTFileError(ValueError):
    """A ValueError raised by the loader itself (kept apart from numpy's own ValueErrors)."""


def read_verified(cls, path: Path):
    """The LUT stored at ``path`` (an existing file), rebuilt with ``cls`` and verified: a
    damaged or foreign file, an unsupported format version, metadata that disagree with the
    arrays and a content-hash mismatch raise ValueError naming the path."""

    def corrupt(why: str) -> ValueError:
        return _LUTFileError(
            f"LUT file {str(path)!r} is corrupt or not a torchirid LUT: {why}"
        )

    # Read everything inside one guard: zip/npy/JSON errors all mean a damaged file.
    try:
        if not path.is_file():
            raise corrupt("not a regular file")
        with open(path, "rb") as fh:
            head = fh.read(16)
        if not head:
            raise corrupt("the file is empty (0 bytes)")
        if not head.startswith(_ZIP_MAGIC):
            raise corrupt(f"not an .npz (zip) archive (it starts with {head!r})")
        # open the file ourselves: np.load leaks its handle when the zip is unreadable
        with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as z:
            if not isinstance(z, np.lib.npyio.NpzFile):
                raise corrupt("not an .npz archive")
            if "meta" not in z.files or "values" not in z.files:
                raise corrupt(f"members 'meta' and 'values' expected, found {z.files}")
            meta_arr = z["meta"]
            if meta_arr.dtype != np.uint8 or meta_arr.ndim != 1:
                raise corrupt("'meta' is not a 1-D uint8 array")
            meta = json.loads(meta_arr.tobytes().decode("utf-8"))
            if not isinstance(meta, dict) or meta.get("format") != _FORMAT_TAG:
                raise corrupt("metadata lacks format 'torchirid.lut'")
            missing = [key for key in _META_KEYS if key not in meta]
            if missing:
                raise corrupt(f"metadata lacks key(s) {missing}")
            if meta["format_version"] != FORMAT_VERSION:
                raise _LUTFileError(
                    f"LUT file {str(path)!r}: unsupported format_version: expected "
                    f"{FORMAT_VERSION}, found {meta['format_version']!r} (rebuild the table "
                    f"or upgrade torchirid)"
                )
            names = meta["axes"]
            if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
                raise corrupt("metadata 'axes' is not a list of names")
            values = z["values"]
            grids = [z[f"axis_{j}"] for j in range(len(names))]
    except _LUTFileError:
        raise
    except Exception as e:  # zipfile.BadZipFile (CRC), EOFError, OSError, JSON, Unicode...
        raise corrupt(f"{type(e).__name__}: {e}") from e

    def to_torch(a: np.ndarray, what: str) -> torch.Tensor:
        native = a.dtype.newbyteorder("=")
        if native not in _FROM_NUMPY:
            raise corrupt(f"{what} has dtype {a.dtype}, expected float16/32/64")
        return torch.from_numpy(np.ascontiguousarray(a, dtype=native))

    vt = to_torch(values, "values")
    axes = {n: to_torch(g, f"axis {n!r}") for n, g in zip(names, grids)}
    try:
        lut = cls(vt, axes, builder=meta["builder"], parameters=meta["parameters"],
                  units=meta["units"], torchirid_version=meta["torchirid_version"])
    except ValueError as e:
        raise corrupt(str(e)) from e
    stored = {k: v for k, v in meta.items() if k != "hash"}
    found = lut._meta_without_hash()
    for key in found:
        if stored.get(key) != found[key]:
            raise ValueError(
                f"LUT file {str(path)!r} is corrupted: metadata {key!r} = "
                f"{stored.get(key)!r} disagrees with the stored arrays ({found[key]!r})"
            )
    extra = sorted(set(stored) - set(found))
    if extra:
        raise corrupt(f"unknown metadata key(s) {extra}")
    if lut.hash != meta["hash"]:
        raise ValueError(
            f"LUT file {str(path)!r} is corrupted: content hash mismatch (stored "
            f"{str(meta['hash'])[:16]}…, recomputed {lut.hash[:16]}…)"
        )
    return lut


def check_expected(lut, path: Path, builder, parameters, expect) -> None:
    """ValueError naming the field, the expected and the found value unless ``lut`` (read from
    ``path``) has the ``builder``, ``parameters`` (subset) and ``expect`` entries asked for."""

    def mismatch(field: str, expected, got) -> ValueError:
        return ValueError(
            f"LUT file {str(path)!r} does not match: {field} expected {expected!r}, "
            f"found {got!r}"
        )

    if builder is not None and lut.builder != builder:
        raise mismatch("builder", builder, lut.builder)
    if parameters is not None:
        want = _normalise_json(dict(parameters), "parameters")
        for key, val in want.items():
            got = lut._parameters.get(key, "<missing>")
            if key not in lut._parameters or got != val:
                raise mismatch(f"parameters[{key!r}]", val, got)
    if expect:
        if "axes" in expect:
            want_axes = (expect["axes"],) if isinstance(expect["axes"], str) \
                else tuple(expect["axes"])
            if want_axes != lut.axis_names:
                raise mismatch("axes", want_axes, lut.axis_names)
        if "channels" in expect:
            want_ch = tuple(expect["channels"]) if isinstance(expect["channels"], Iterable) \
                else (expect["channels"],)
            if want_ch != lut.channel_shape:
                raise mismatch("channels", want_ch, lut.channel_shape)
        if "units" in expect:
            for key, unit in dict(expect["units"]).items():
                got = lut._units.get(key, "<missing>")
                if got != unit:
                    raise mismatch(f"units[{key!r}]", unit, got)
