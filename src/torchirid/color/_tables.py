r"""The CIE tables the library reads, shipped as data (``data/cie_tables.npz``), with
colour-science as their source.

``data/cie_tables.npz`` holds, as float64 arrays copied from colour-science (Mansencal et al.,
colour-science 0.4) by ``luts/build_cie_tables.py``, every registered observer's colour
matching functions and every registered illuminant's spectral power distribution: the numbers
that :mod:`torchirid.color.colorimetry` would otherwise read from ``colour.MSDS_CMFS`` and
``colour.SDS_ILLUMINANTS``. Reading them from the file spares the first colour the import of
colour-science (which imports matplotlib and scipy, seconds on a cold start). A table that is
not in the file (a name added to a registry before the file is rebuilt, or a checkout
without the file) comes from colour-science itself, imported lazily at that call.

File format (an ``.npz`` read with ``allow_pickle=False``: plain arrays, nothing pickled):

=================================== ==========================================================
member                              content
=================================== ==========================================================
``cmfs_<observer>_<space>_wl``      wavelengths in nm, ``(K,)`` float64 (``<observer>``: the
                                    short name in lower case, runs of other characters as
                                    ``_``; ``<space>``: ``xyz`` or ``rgb``)
``cmfs_<observer>_<space>_values``  :math:`\bar x, \bar y, \bar z` (or :math:`\bar r, \bar g,
                                    \bar b`), ``(K, 3)`` float64
``illuminant_<name>_wl``            wavelengths in nm, ``(K,)`` float64
``illuminant_<name>_values``        relative spectral power, ``(K,)`` float64
``meta``                            UTF-8 JSON as a ``uint8`` array: ``format``, ``builder``,
                                    ``colour_science`` (the version it was built with),
                                    ``sources`` (member → the colour-science expression it
                                    holds), ``hash``
=================================== ==========================================================

``hash`` is the SHA-256 of the canonical JSON of ``meta`` without ``hash``, then, for every
array member in sorted order, its name and its little-endian float64 bytes. The loader
recomputes it and refuses a file that does not match (ValueError naming the path), so the
numbers are those colour-science gave at build time or nothing.
"""

from __future__ import annotations

import hashlib
import json
import re
from pathlib import Path

import numpy as np

from .._cache import cached

PATH = Path(__file__).resolve().parent.parent / "data" / "cie_tables.npz"
FORMAT = "torchirid.cie_tables"
BUILDER = "luts/build_cie_tables.py"


def _slug(name: str) -> str:
    return re.sub(r"[^0-9a-z]+", "_", name.lower()).strip("_")


def cmfs_member(observer: str, space: str) -> str:
    """Member-name stem of an observer's CMFs in ``space`` (``"XYZ"`` or ``"RGB"``)."""
    return f"cmfs_{_slug(observer)}_{space.lower()}"


def illuminant_member(name: str) -> str:
    """Member-name stem of an illuminant's SPD."""
    return f"illuminant_{_slug(name)}"


# ---------------------------------------------------------------------------------------
# the source: colour-science (imported here only, lazily)
# ---------------------------------------------------------------------------------------


def colour_cmfs(key: str, rgb_to_xyz: bool) -> tuple[np.ndarray, np.ndarray, str]:
    """``(wavelength_nm, values (K, 3), source)`` of ``colour.MSDS_CMFS[key]``, float64.

    ``rgb_to_xyz``: the XYZ functions of RGB CMFs, colour's own CIE 1964 transformation
    (``colour.colorimetry.RGB_10_degree_cmfs_to_XYZ_10_degree_cmfs``, a 3x3 matrix) at the
    tabulated wavelengths, no interpolation.
    """
    import colour  # noqa: PLC0415  (lazy: colour-science imports matplotlib and scipy)

    data = colour.MSDS_CMFS[key]
    wavelength = np.array(data.wavelengths, dtype=np.float64)
    if rgb_to_xyz:
        values = colour.colorimetry.RGB_10_degree_cmfs_to_XYZ_10_degree_cmfs(wavelength)
        source = f"colour.colorimetry.RGB_10_degree_cmfs_to_XYZ_10_degree_cmfs(colour.MSDS_CMFS[{key!r}].wavelengths)"
    else:
        values = data.values
        source = f"colour.MSDS_CMFS[{key!r}]"
    return wavelength, np.array(values, dtype=np.float64), source


def colour_illuminant(key: str) -> tuple[np.ndarray, np.ndarray, str]:
    """``(wavelength_nm, values (K,), source)`` of ``colour.SDS_ILLUMINANTS[key]``, float64."""
    import colour  # noqa: PLC0415  (lazy, as above)

    sd = colour.SDS_ILLUMINANTS[key]
    return (np.array(sd.wavelengths, dtype=np.float64), np.array(sd.values, dtype=np.float64),
            f"colour.SDS_ILLUMINANTS[{key!r}]")


# ---------------------------------------------------------------------------------------
# the file
# ---------------------------------------------------------------------------------------


def content_hash(arrays: dict[str, np.ndarray], meta: dict) -> str:
    """SHA-256 of ``meta`` (without ``hash``, canonical JSON) and the arrays, by sorted name."""
    h = hashlib.sha256()
    body = {k: v for k, v in meta.items() if k != "hash"}
    h.update(json.dumps(body, sort_keys=True, separators=(",", ":"), ensure_ascii=True).encode("ascii"))
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name], dtype="<f8")
        h.update(name.encode("ascii") + b"\0" + repr(a.shape).encode("ascii") + b"\0" + a.tobytes())
    return h.hexdigest()


def write(path, arrays: dict[str, np.ndarray], meta: dict) -> Path:
    """Write the tables atomically (``meta["hash"]`` is set here); returns the path."""
    from .._io import atomic_write  # noqa: PLC0415  (only the build script writes)

    meta = dict(meta, hash=content_hash(arrays, meta))
    members = {k: np.ascontiguousarray(v, dtype="<f8") for k, v in arrays.items()}
    members["meta"] = np.frombuffer(json.dumps(meta, sort_keys=True).encode("utf-8"), dtype=np.uint8)
    return atomic_write(path, lambda f: np.savez(f, **members))


def read(path) -> tuple[dict[str, np.ndarray], dict]:
    """``(arrays, meta)`` of a tables file, verified (ValueError naming the path if not)."""
    path = Path(path)
    try:
        with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as z:
            meta = json.loads(z["meta"].tobytes().decode("utf-8"))
            arrays = {k: z[k] for k in z.files if k != "meta"}
    except Exception as e:  # zip, npy, JSON or Unicode errors: a damaged file
        raise ValueError(f"CIE tables file {str(path)!r} is corrupt: {type(e).__name__}: {e}") from e
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise ValueError(f"CIE tables file {str(path)!r} is not a {FORMAT} file")
    if any(a.dtype != np.float64 for a in arrays.values()) or meta.get("hash") != content_hash(arrays, meta):
        raise ValueError(f"CIE tables file {str(path)!r} is corrupted: content hash mismatch "
                         f"(rebuild it with {BUILDER})")
    return arrays, meta


@cached(maxsize=None)
def _shipped() -> dict[str, np.ndarray]:
    """The shipped arrays (empty if the file is absent: every table then comes from colour)."""
    if not PATH.exists():
        return {}
    return read(PATH)[0]


def shipped(stem: str) -> tuple[np.ndarray, np.ndarray] | None:
    """``(wavelength, values)`` of a shipped table (fresh float64 arrays), or None if not shipped."""
    arrays = _shipped()
    wl, values = arrays.get(stem + "_wl"), arrays.get(stem + "_values")
    if wl is None or values is None:
        return None
    return wl.copy(), values.copy()
