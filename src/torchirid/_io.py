"""Atomic file writes: every file torchirid writes (LUTs, figures, ``.npz`` products, fitted
coefficients, JSON reports) goes through :func:`atomic_write`; JSON is strict (:func:`write_json`)."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import IO, Callable

import numpy as np


def atomic_write(path: str | os.PathLike, write: Callable[[IO[bytes]], object]) -> Path:
    """Call ``write(f)`` on a temporary file in ``path``'s directory, then rename it over ``path``.

    A reader never sees a half-written file, and a failed write leaves ``path`` as it was;
    the data are flushed and fsynced before the rename.
    The file gets the usual permissions (0666 minus the umask), not ``mkstemp``'s 0600.
    The directory must exist; ``OSError`` propagates. Returns ``path`` as a ``Path``.
    """
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600 files; give the usual permissions
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    return path


def json_ready(value):
    """``value`` as plain JSON data: every float that is not finite becomes ``None`` (JSON
    ``null``: strict readers refuse ``NaN`` and ``Infinity``), tensors, numpy arrays and numpy
    scalars become Python numbers or lists, tuples become lists and keys strings.

    >>> json_ready({"a": float("nan"), "b": (1.5, np.float32(2.0)), 3: np.array([1, 2])})
    {'a': None, 'b': [1.5, 2.0], '3': [1, 2]}
    """
    if isinstance(value, dict):
        return {str(k): json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_ready(v) for v in value]
    if hasattr(value, "tolist") and callable(value.tolist):  # torch.Tensor, np.ndarray, np.generic
        return json_ready(value.tolist())
    if isinstance(value, float):
        return value if np.isfinite(value) else None
    return value


def write_json(path: str | os.PathLike, obj, *, indent: int | None = 1) -> Path:
    """Write ``obj`` as strict JSON (:func:`json_ready`; ``allow_nan=False``, UTF-8, trailing
    newline) atomically (:func:`atomic_write`), creating the parent folder. Returns the path."""
    import json

    text = json.dumps(json_ready(obj), indent=indent, allow_nan=False, ensure_ascii=False) + "\n"
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    return atomic_write(path, lambda f: f.write(text.encode("utf-8")))


# ----------------------------------------------------------------------------------------
# OpenEXR (optional dependency): one reader for scatterograms, environments and exports
# ----------------------------------------------------------------------------------------
_EXR_MAGIC = b"\x76\x2f\x31\x01"


def import_openexr():
    try:
        import OpenEXR
    except ImportError as exc:
        raise ImportError("reading or writing OpenEXR (.exr) files needs the optional 'openexr' package: "
                          "pip install openexr (or pip install 'torchirid[exr]')") from exc
    return OpenEXR


def read_exr(path, saturation=None) -> tuple[np.ndarray, np.ndarray]:
    """An OpenEXR file's first part as (linear RGB (H, W, 3) float64, valid (H, W) bool).

    Channels R, G, B (or Y alone, as grey) in half or float, with an optional A; the values
    are scene-linear and are not decoded. ``valid`` is False where a colour channel is not
    finite, where A is not finite or ≤ 0, and (with ``saturation``) where a channel is ≥
    ``saturation``."""
    with open(path, "rb") as f:  # FileNotFoundError / OSError as for a PNG
        magic = f.read(4)
    if magic != _EXR_MAGIC:
        raise ValueError(f"path {os.fspath(path)!r} is not an OpenEXR file")
    OpenEXR = import_openexr()
    try:
        exr = OpenEXR.File(os.fspath(path), separate_channels=True)
    except Exception as exc:  # the binding raises RuntimeError for a corrupt file
        raise ValueError(f"path {os.fspath(path)!r}: cannot read the OpenEXR file ({exc})") from exc
    channels = {name: np.asarray(ch.pixels) for name, ch in exr.parts[0].channels.items()}
    if all(k in channels for k in "RGB"):
        names = ["R", "G", "B"]
    elif "Y" in channels:
        names = ["Y"] * 3
    else:
        raise ValueError(f"path {os.fspath(path)!r}: the OpenEXR file has no R, G, B (or Y) channels; "
                         f"it has {sorted(channels)}")
    for name in set(names) | ({"A"} & set(channels)):
        if channels[name].dtype.kind != "f" or channels[name].ndim != 2:
            raise ValueError(f"path {os.fspath(path)!r}: OpenEXR channel {name!r} must be a 2-D half or float "
                             f"image; got {channels[name].dtype} {channels[name].shape}")
    rgb = np.stack([channels[n].astype(np.float64) for n in names], -1)
    valid = np.isfinite(rgb).all(-1)
    if "A" in channels:
        alpha = channels["A"].astype(np.float64)
        valid &= np.isfinite(alpha) & (alpha > 0)
    if saturation is not None:
        valid &= (rgb < saturation).all(-1)
    rgb = np.where(valid[..., None], rgb, 0.0)  # NaN/inf would poison the bilinear neighbours
    return rgb, valid
