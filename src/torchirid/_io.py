"""File I/O shared by every subpackage.

Writing: every file torchirid writes (LUTs, figures, ``.npz`` products, fitted coefficients,
JSON reports) goes through :func:`atomic_write`; JSON is strict (:func:`write_json`).

Reading: every reader of a user's file (cubes, scatterograms, environment maps, LUTs, exports)
meets one standard. A missing file raises ``FileNotFoundError`` naming it (some readers, whose
docstrings say so, raise ``ValueError`` instead); anything wrong with a file that exists — a
directory, an empty file, another format's bytes, a truncated or damaged file, content of the
wrong shape or type — raises ``ValueError`` naming the file and saying what is wrong, never a
low-level exception. :func:`check_readable` does the first checks (exists, regular file, not
empty, signature), :func:`reading` turns the low-level errors of a parser into that
``ValueError`` (the cause chained) and :func:`file_error` builds the readers' own.
"""

from __future__ import annotations

import os
import struct
import tempfile
import zipfile
import zlib
from contextlib import contextmanager
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
# reading: one error standard for every reader of a user's file
# ----------------------------------------------------------------------------------------
#: signatures of a zip archive (``.npz``): a local file header, or the end record of an empty archive
ZIP_MAGIC = (b"PK\x03\x04", b"PK\x05\x06")


class FileContentError(ValueError):
    """A ``ValueError`` about a file's content, raised by a reader (its message names the file);
    :func:`reading` lets it through unchanged."""


def file_error(what: str, path, why: str) -> FileContentError:
    """The error ``<what> '<path>': <why>`` (``what`` says which file: "cube file", "ENVI header"...;
    a ``why`` that starts with a verb, "is truncated", follows without the colon)."""
    sep = " " if why.startswith(("is ", "has ", "lacks ", "does ", "must ", "holds ")) else ": "
    return FileContentError(f"{what} {os.fspath(path)!r}{sep}{why}")


def check_readable(path, what: str, *, magic: bytes | tuple[bytes, ...] = (), kind: str = "",
                   missing: type[Exception] = FileNotFoundError) -> Path:
    """``path`` as a ``Path`` once it is known to be an existing, non-empty regular file that
    starts with one of the signatures ``magic`` (none: any content).

    Raises ``missing`` (``FileNotFoundError`` by default) when nothing is at ``path``, and
    :class:`FileContentError` (a ``ValueError``) naming the file when it is a directory, empty,
    or does not start with ``magic`` (``kind`` names the expected format, e.g. "an OpenEXR
    file"). ``what`` says which file it is, e.g. "cube file".

    >>> import tempfile; p = Path(tempfile.mkdtemp()) / "c.npz"; _ = p.write_bytes(b"hello")
    >>> try:
    ...     check_readable(p, "cube file", magic=ZIP_MAGIC, kind="an .npz (zip) archive")
    ... except ValueError as e:
    ...     print(str(e).split("c.npz' ")[1])
    is not an .npz (zip) archive (it starts with b'hello')
    """
    p = Path(path)
    name = os.fspath(p)
    if not p.exists():
        raise missing(f"{what} {name!r} does not exist")
    if not p.is_file():
        raise FileContentError(f"{what} {name!r} is not a regular file")
    size = p.stat().st_size
    if size == 0:
        raise FileContentError(f"{what} {name!r} is empty (0 bytes)")
    magics = (magic,) if isinstance(magic, bytes) else tuple(magic)
    if magics:
        with open(p, "rb") as f:
            head = f.read(max(16, *(len(m) for m in magics)))
        if not any(head.startswith(m) for m in magics):
            if any(m.startswith(head) for m in magics):  # the signature itself is cut short
                raise FileContentError(f"{what} {name!r} is truncated ({size} bytes: not even the signature of "
                                       f"{kind})")
            raise FileContentError(f"{what} {name!r} is not {kind} (it starts with {head!r})")
    return p


#: low-level errors of parsers that mean a truncated or damaged file
_TRUNCATED = (EOFError, zipfile.BadZipFile, zlib.error, struct.error, IndexError, RuntimeError, OSError)
#: every error :func:`reading` turns into a ValueError naming the file
_LOW_LEVEL = _TRUNCATED + (KeyError, TypeError, ValueError, OverflowError, AttributeError,
                          SyntaxError)  # (Pillow raises SyntaxError for a broken PNG)


def describe_read_error(exc: BaseException) -> str:
    """What a low-level parser error says about a file, as the end of a sentence."""
    kind = type(exc).__name__
    if kind == "error":  # zlib.error, struct.error
        kind = f"{type(exc).__module__}.error"
    text = f"{kind}: {exc}".rstrip(": ")
    if isinstance(exc, ValueError) and "pickled" in str(exc):  # numpy's take on a non-zip .npz
        return "is not an .npz (zip) archive (numpy read it as pickled data)"
    if isinstance(exc, _TRUNCATED) or "truncated" in str(exc).lower():
        return f"is truncated or damaged ({text})"
    return f"cannot be read ({text})"


@contextmanager
def reading(path, what: str):
    """Run a parser on ``path``: its low-level errors (``EOFError``, ``zipfile.BadZipFile``,
    ``zlib.error``, ``struct.error``, ``IndexError``, ``KeyError``, ``TypeError``, the OpenEXR
    binding's ``RuntimeError``, ``OSError``, numpy's and ``json``'s ``ValueError``...) become
    a :class:`FileContentError` ``<what> '<path>' is truncated or damaged (...)`` /
    ``... cannot be read (...)`` with the cause chained. A :class:`FileContentError` (the
    reader's own, already naming a file), ``FileNotFoundError``, ``PermissionError`` and
    ``ImportError`` pass through unchanged."""
    try:
        yield
    except (FileContentError, FileNotFoundError, PermissionError):
        raise
    except _LOW_LEVEL as exc:
        raise FileContentError(f"{what} {os.fspath(path)!r} {describe_read_error(exc)}") from exc


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


def read_exr_channels(path, what: str = "OpenEXR file") -> dict[str, np.ndarray]:
    """The channels of an OpenEXR file's first part, ``{name: (H, W) array}`` as stored.

    ``what`` names the file in errors ("environment map", "LUT data file"...). Raises
    ``FileNotFoundError`` for a missing file, ``ImportError`` without the ``openexr`` package,
    and ``ValueError`` naming the file when it is empty, not an OpenEXR file, truncated or
    damaged, or has no channels of one common 2-D size."""
    p = check_readable(path, what, magic=_EXR_MAGIC, kind="an OpenEXR file")
    OpenEXR = import_openexr()
    with reading(p, what):
        exr = OpenEXR.File(os.fspath(p), separate_channels=True)
        if not exr.parts:  # the binding reports a damaged chunk on stderr and returns no part
            raise file_error(what, p, "is truncated or damaged (the OpenEXR library read no image part)")
        channels = {name: np.asarray(ch.pixels) for name, ch in exr.parts[0].channels.items()}
    if not channels:
        raise file_error(what, p, "the OpenEXR file has no channels")
    shapes = {name: a.shape for name, a in channels.items()}
    first = next(iter(shapes.values()))
    if len(first) != 2 or min(first) < 1 or any(s != first for s in shapes.values()):
        raise file_error(what, p, f"OpenEXR channels must be 2-D images of one size; got {shapes}")
    return channels


def read_exr(path, saturation=None, *, what: str = "OpenEXR file") -> tuple[np.ndarray, np.ndarray]:
    """An OpenEXR file's first part as (linear RGB (H, W, 3) float64, valid (H, W) bool).

    Channels R, G, B (or Y alone, as grey) in half or float, with an optional A; the values
    are scene-linear and are not decoded. ``valid`` is False where a colour channel is not
    finite, where A is not finite or ≤ 0, and (with ``saturation``) where a channel is ≥
    ``saturation``. Errors as :func:`read_exr_channels` (``what`` names the file), and a
    ``ValueError`` naming it for a file without R, G, B (or Y) float channels."""
    channels = read_exr_channels(path, what)
    if all(k in channels for k in "RGB"):
        names = ["R", "G", "B"]
    elif "Y" in channels:
        names = ["Y"] * 3
    else:
        raise file_error(what, path, f"the OpenEXR file has no R, G, B (or Y) channels; it has {sorted(channels)}")
    for name in set(names) | ({"A"} & set(channels)):
        if channels[name].dtype.kind != "f":
            raise file_error(what, path, f"OpenEXR channel {name!r} must be a half or float image; got "
                             f"{channels[name].dtype}")
    rgb = np.stack([channels[n].astype(np.float64) for n in names], -1)
    valid = np.isfinite(rgb).all(-1)
    if "A" in channels:
        alpha = channels["A"].astype(np.float64)
        valid &= np.isfinite(alpha) & (alpha > 0)
    if saturation is not None:
        valid &= (rgb < saturation).all(-1)
    rgb = np.where(valid[..., None], rgb, 0.0)  # NaN/inf would poison the bilinear neighbours
    return rgb, valid
