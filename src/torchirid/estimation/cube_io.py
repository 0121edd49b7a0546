"""Hyperspectral cubes in and out: ENVI (.hdr + raw, through the ``spectral`` package) and .npz.

A cube is ``(H, W, A, B)`` band reflectance with ``wavelength`` ``(B,)`` in nm and incidence
``angles_deg`` ``(A,)``. On disk:

* ``.npz`` (``allow_pickle=False``): arrays ``cube`` (H, W, A, B), ``wavelength_nm`` (B,),
  ``angle_deg`` (A,), optional ``bandwidth_nm`` (scalar), ``thickness_nm`` (H, W, a
  ground truth for synthetic cubes) and ``meta`` (a JSON string, e.g. polarization,
  n_substrate).
* ENVI: one image of H lines × W samples × A·B bands (angle-major: band index a·B + b), with
  the standard ``wavelength`` (``wavelength units`` nanometers or micrometers) and ``fwhm``
  header fields per band. The angles come either from a per-band ``incidence angle`` field
  (degrees; written by :func:`write_envi`, not an ENVI standard field) or from ``angles_deg``
  (one value per angle block). A list of ENVI files, one per angle (each H × W × B), is read
  with ``angles_deg`` giving each file's angle. The standard ``reflectance scale factor``
  (stored value = reflectance × factor) and ``data ignore value`` (→ NaN) are honoured.
"""

from __future__ import annotations

import json
import logging
import os
from dataclasses import dataclass, field

import numpy as np
import torch

from .._io import ZIP_MAGIC, check_readable, file_error, reading

__all__ = ["Cube", "read_cube", "write_npz", "write_envi"]

_CPU = torch.device("cpu")


def _host(x) -> torch.Tensor:
    """``x`` as a float64 CPU tensor (files are written from host memory, whatever the device)."""
    return torch.as_tensor(x, dtype=torch.float64, device=_CPU)


@dataclass
class Cube:
    """cube ``(H, W, A, B)`` float64, wavelength ``(B,)`` nm, angles_deg ``(A,)``, bandwidth (nm or None),
    thickness (optional ground truth ``(H, W)``), meta (dict).

    Example (what :func:`read_cube` returns; the angles come back sorted, the cube with them):
        >>> import os, tempfile, torch
        >>> with tempfile.TemporaryDirectory() as d:
        ...     p = os.path.join(d, "cube.npz")
        ...     write_npz(p, torch.zeros(4, 4, 2, 3), [500.0, 550.0, 600.0], [40.0, 10.0])  # nm, degrees
        ...     c = read_cube(p)
        >>> tuple(c.cube.shape), c.angles_deg.tolist(), [round(v, 4) for v in c.cos_theta.tolist()]
        ((4, 4, 2, 3), [10.0, 40.0], [0.9848, 0.766])
    """

    cube: torch.Tensor
    wavelength: torch.Tensor
    angles_deg: torch.Tensor
    bandwidth: float | None = None
    thickness: torch.Tensor | None = None
    meta: dict = field(default_factory=dict)

    @property
    def cos_theta(self) -> torch.Tensor:
        return torch.cos(torch.deg2rad(self.angles_deg))

    def sorted(self) -> "Cube":
        """The same cube with the angles in increasing order (what the estimators expect)."""
        order = torch.argsort(self.angles_deg)
        return Cube(self.cube[:, :, order], self.wavelength, self.angles_deg[order], self.bandwidth, self.thickness,
                    self.meta)


def _check_shapes(cube, wavelength, angles):
    if cube.ndim != 4 or cube.shape[2] != angles.numel() or cube.shape[3] != wavelength.numel():
        raise ValueError(f"cube must have shape (H, W, A={angles.numel()}, B={wavelength.numel()}); got {tuple(cube.shape)}")


def write_npz(path, cube, wavelength, angles_deg, *, bandwidth=None, thickness=None, meta=None) -> None:
    """Write a cube as .npz (module docstring); tensors on any device.

    Args:
        path: the ``.npz`` file (written atomically).
        cube: ``(H, W, A, B)`` band reflectance; wavelength ``(B,)`` nm; angles_deg ``(A,)`` degrees.
        bandwidth: the bands' width (nm) or None; thickness: optional ``(H, W)`` ground truth (nm);
            meta: a JSON-ready dict (e.g. polarization, n_substrate).

    Example (a 4 × 4 pixel cube of 2 angles × 3 bands, read back with :func:`read_cube`):
        >>> import os, tempfile, torch
        >>> with tempfile.TemporaryDirectory() as d:
        ...     p = os.path.join(d, "cube.npz")
        ...     write_npz(p, torch.full((4, 4, 2, 3), 0.05), [500.0, 550.0, 600.0], [10.0, 40.0],
        ...               bandwidth=4.0, meta={"polarization": "s"})
        ...     c = read_cube(p)
        >>> tuple(c.cube.shape), c.bandwidth, c.meta
        ((4, 4, 2, 3), 4.0, {'polarization': 's'})
    """
    cube, wl, ang = (_host(x) for x in (cube, wavelength, angles_deg))
    _check_shapes(cube, wl, ang)
    arrays = dict(cube=cube.numpy(), wavelength_nm=wl.numpy(), angle_deg=ang.numpy(),
                  meta=np.array(json.dumps(meta or {})))
    if bandwidth is not None:
        arrays["bandwidth_nm"] = np.array(float(bandwidth))
    if thickness is not None:
        arrays["thickness_nm"] = _host(thickness).numpy()
    tmp = os.fspath(path) + ".tmp.npz"
    np.savez_compressed(tmp, **arrays)
    os.replace(tmp, path)


def write_envi(path_hdr, cube, wavelength, angles_deg, *, bandwidth=None) -> None:
    """Write a cube as ENVI .hdr + .img (float32 data, angle-major bands, module docstring).

    Arguments as :func:`write_npz` (``path_hdr``: the ``.hdr`` file, the ``.img`` data file
    written beside it); the angles go to the per-band ``incidence angle`` field, the bandwidth
    to ``fwhm``. Needs the optional ``spectral`` package.

    Example (read back with :func:`read_cube`, which takes the angles from the header):
        >>> import os, tempfile, torch
        >>> with tempfile.TemporaryDirectory() as d:
        ...     hdr = os.path.join(d, "cube.hdr")
        ...     write_envi(hdr, torch.full((4, 4, 2, 3), 0.25), [500.0, 550.0, 600.0], [10.0, 40.0], bandwidth=4.0)
        ...     c = read_cube(hdr)
        ...     files = sorted(os.listdir(d))
        >>> files, tuple(c.cube.shape), c.angles_deg.tolist(), c.bandwidth
        (['cube.hdr', 'cube.img'], (4, 4, 2, 3), [10.0, 40.0], 4.0)
    """
    from spectral.io import envi

    cube, wl, ang = (_host(x) for x in (cube, wavelength, angles_deg))
    _check_shapes(cube, wl, ang)
    H, W, A, B = cube.shape
    data = cube.reshape(H, W, A * B).numpy().astype(np.float32)
    md = {
        "wavelength": [f"{v:.6g}" for v in wl.repeat(A).tolist()],
        "wavelength units": "nm",
        "incidence angle": [f"{v:.6g}" for v in ang.repeat_interleave(B).tolist()],
    }
    if bandwidth is not None:
        md["fwhm"] = [f"{float(bandwidth):.6g}"] * (A * B)
    envi.save_image(os.fspath(path_hdr), data, metadata=md, force=True, ext=".img")


def _check_angles(angles_deg, count=None, what=""):
    """Validated incidence angles (degrees) as float64 numpy, or None."""
    if angles_deg is None:
        return None
    ang = np.asarray(angles_deg, dtype=np.float64).reshape(-1)
    if count is not None and ang.size != count:
        raise ValueError(f"angles_deg must give {count} angle(s){what}; got {ang.size}")
    if not np.all(np.isfinite(ang)) or np.any(ang < 0) or np.any(ang >= 90):
        raise ValueError(f"angles_deg must be incidence angles in [0, 90) degrees; got {ang.tolist()}")
    if np.unique(ang).size != ang.size:
        raise ValueError(f"angles_deg must be distinct; got {ang.tolist()}")
    return ang


_WAVELENGTH_UNITS = {"nm": 1.0, "nanometers": 1.0, "nanometer": 1.0, "um": 1000.0, "µm": 1000.0,
                     "micrometers": 1000.0, "micrometer": 1000.0, "microns": 1000.0}


def _read_envi_one(path):
    p = os.fspath(path)
    check_readable(p, "ENVI header", magic=b"ENVI", kind="an ENVI header (its first line must be 'ENVI')",
                   missing=ValueError)
    try:
        from spectral.io import envi
    except ImportError as exc:
        raise ImportError("reading ENVI cubes needs the optional 'spectral' package: pip install spectral") from exc

    log = logging.getLogger("spectral")  # spectral logs a warning on stderr before we raise the error
    level = log.level
    log.setLevel(logging.ERROR)
    try:
        img = envi.open(p)
    except envi.EnviDataFileNotFoundError as exc:
        stem = os.path.splitext(os.path.basename(p))[0]
        raise file_error("ENVI header", p, f"its data file is missing (looked for {stem}, {stem}.img, {stem}.dat, "
                                           f"{stem}.raw... beside it)") from exc
    except Exception as exc:  # spectral raises its own error types (and numpy's) for a bad header
        raise file_error("ENVI header", p, f"cannot be read ({type(exc).__name__}: {exc})") from exc
    finally:
        log.setLevel(level)
    data_file = os.fspath(img.filename)
    with reading(data_file, "ENVI data file"):
        need = int(img.offset) + int(img.nrows) * int(img.ncols) * int(img.nbands) * int(img.sample_size)
        have = os.path.getsize(data_file)
        if have < need:
            raise file_error("ENVI data file", data_file,
                             f"is truncated: {have} bytes, where its header {p!r} needs {need} (lines {img.nrows} "
                             f"x samples {img.ncols} x bands {img.nbands} x {img.sample_size} bytes + offset "
                             f"{img.offset})")
        data = np.asarray(img.load(scale=False), dtype=np.float64)  # raw values: the ignore value is in file units
    if data.ndim == 2:
        data = data[:, :, None]
    md = img.metadata

    def numbers(key):
        value = md.get(key)
        try:
            return np.asarray([float(v) for v in ([value] if isinstance(value, str) else value)], dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise file_error("ENVI header", p, f"field {key!r} must hold numbers; got {value!r}") from exc

    wl = numbers("wavelength") if "wavelength" in md else np.zeros(0)
    if wl.size != data.shape[-1]:
        raise file_error("ENVI header", p, f"must give one 'wavelength' per band ({data.shape[-1]}); got {wl.size}")
    units = str(md.get("wavelength units", "nm")).strip().lower()
    if units not in _WAVELENGTH_UNITS:
        raise file_error("ENVI header", p, f"wavelength units must be nanometers or micrometers; got {units!r}")
    wl = wl * _WAVELENGTH_UNITS[units]
    if "data ignore value" in md:
        data[data == numbers("data ignore value")[0]] = np.nan  # dead pixels → NaN (the fits skip them)
    if "reflectance scale factor" in md:
        factor = numbers("reflectance scale factor")[0]
        if not (np.isfinite(factor) and factor > 0):
            raise file_error("ENVI header", p, f"'reflectance scale factor' must be a number > 0; got {factor:g}")
        data = data / factor
    ang = numbers("incidence angle") if "incidence angle" in md else None
    if ang is not None and ang.size != data.shape[-1]:
        raise file_error("ENVI header", p, f"must give one 'incidence angle' per band ({data.shape[-1]}); "
                                           f"got {ang.size}")
    fwhm = numbers("fwhm") if md.get("fwhm") else None
    return data, wl, ang, (None if fwhm is None else float(np.median(fwhm)) * _WAVELENGTH_UNITS[units])
    # (fwhm is in the header's wavelength units too: micrometres → nm like the wavelengths)


_NPZ_WHAT = "cube file"


def _read_npz(p: str):
    """(cube, wavelength, angles, bandwidth, thickness, meta) of a cube ``.npz``; ValueError naming ``p``."""
    check_readable(p, _NPZ_WHAT, magic=ZIP_MAGIC, kind="an .npz (zip) archive", missing=ValueError)

    def bad(why):
        return file_error(_NPZ_WHAT, p, why)

    def numeric(z, key, ndim):
        a = z[key]
        if a.dtype.kind not in "biuf" or a.ndim != ndim:
            raise bad(f"array {key!r} must be {ndim}-D real numbers; got {a.dtype} with shape {a.shape}")
        return torch.from_numpy(a.astype(np.float64))

    # open the file ourselves: np.load leaks its handle when the zip is unreadable
    with reading(p, _NPZ_WHAT), open(p, "rb") as fh, np.load(fh, allow_pickle=False) as z:
        missing = [key for key in ("cube", "wavelength_nm", "angle_deg") if key not in z.files]
        if missing:
            raise bad(f"must hold arrays cube, wavelength_nm, angle_deg; missing {missing[0]!r} (it has {z.files})")
        cube, wl, ang = numeric(z, "cube", 4), numeric(z, "wavelength_nm", 1), numeric(z, "angle_deg", 1)
        bw = th = None
        if "bandwidth_nm" in z.files:
            a = z["bandwidth_nm"]
            if a.dtype.kind not in "biuf" or a.size != 1:
                raise bad(f"'bandwidth_nm' must be one number; got {a.dtype} with shape {a.shape}")
            bw = float(a.reshape(()))
        if "thickness_nm" in z.files:
            th = numeric(z, "thickness_nm", 2)
        meta = {}
        if "meta" in z.files:
            a = z["meta"]
            if a.dtype.kind != "U" or a.ndim != 0:
                raise bad(f"'meta' must be a JSON string; got {a.dtype} with shape {a.shape}")
            try:
                meta = json.loads(str(a))
            except ValueError as exc:
                raise bad(f"'meta' is not JSON ({exc})") from exc
            if not isinstance(meta, dict):
                raise bad(f"'meta' must be a JSON object; got {type(meta).__name__}")
    if cube.shape[2] != ang.numel() or cube.shape[3] != wl.numel():
        raise bad(f"'cube' must have shape (H, W, A={ang.numel()}, B={wl.numel()}) for its {ang.numel()} angle_deg "
                  f"and {wl.numel()} wavelength_nm; got {tuple(cube.shape)}")
    if not bool(torch.isfinite(wl).all() and (wl > 0).all()):
        raise bad(f"'wavelength_nm' must be finite wavelengths > 0 nm; got {wl.tolist()}")
    if not bool(torch.isfinite(ang).all() and (ang >= 0).all() and (ang < 90).all()) or ang.unique().numel() != ang.numel():
        raise bad(f"'angle_deg' must be distinct incidence angles in [0, 90) degrees; got {ang.tolist()}")
    if th is not None and tuple(th.shape) != tuple(cube.shape[:2]):
        raise bad(f"'thickness_nm' must have shape (H, W) = {tuple(cube.shape[:2])}; got {tuple(th.shape)}")
    return cube, wl, ang, bw, th, meta


def read_cube(path, *, angles_deg=None) -> Cube:
    """Read a cube from .npz, an ENVI header, or a list of ENVI headers (one per angle).

    Args:
        path: a ``.npz`` file, an ENVI ``.hdr`` file (its data file beside it), or a list of
            ``.hdr`` files, one per incidence angle (module docstring).
        angles_deg: incidence angles in degrees, [0, 90), distinct: one per file for a list;
            one per block of bands for an ENVI file without an ``incidence angle`` field;
            optional otherwise (then it must agree with the file).

    Returns:
        :class:`Cube` with the angles sorted increasingly.

    Raises:
        ValueError: a missing, empty, truncated, damaged or foreign file, content of the wrong
            shape or type, inconsistent files (the message names the file), missing or
            mismatched angles.
        ImportError: an ENVI file without the optional ``spectral`` package.

    Example:
        >>> import tempfile, os, torch
        >>> with tempfile.TemporaryDirectory() as d:
        ...     p = os.path.join(d, "c.npz")
        ...     write_npz(p, torch.zeros(2, 3, 2, 4), [400, 404, 408, 412], [10, 20])
        ...     print(tuple(read_cube(p).cube.shape))
        (2, 3, 2, 4)
    """
    if isinstance(path, (list, tuple)) and len(path) == 1:
        path = path[0]
    if isinstance(path, (list, tuple)):
        if any(not os.fspath(q).endswith(".hdr") for q in path):
            raise ValueError("several cube files must all be ENVI .hdr files, one per incidence angle")
        if angles_deg is None:
            raise ValueError(f"angles_deg must give the incidence angle of each of the {len(path)} ENVI files")
        ang = _check_angles(angles_deg, len(path), f", one per ENVI file ({len(path)} files)")
        parts = [_read_envi_one(q) for q in path]
        wl = parts[0][1]
        for i, (q, part) in enumerate(zip(path, parts)):
            if part[0].shape[:2] != parts[0][0].shape[:2]:
                raise ValueError(f"every ENVI file must have the same lines x samples; {os.fspath(q)!r} has "
                                 f"{part[0].shape[:2]}, {os.fspath(path[0])!r} {parts[0][0].shape[:2]}")
            if part[1].shape != wl.shape or not np.allclose(part[1], wl):
                raise ValueError(f"every ENVI file must have the same wavelengths; {os.fspath(q)!r} differs")
            if part[2] is not None and np.unique(part[2]).size > 1:
                raise ValueError(f"ENVI file {os.fspath(q)!r} holds several incidence angles; give one file per angle")
            if part[2] is not None and not np.isclose(part[2][0], ang[i]):
                raise ValueError(f"angles_deg disagrees with the 'incidence angle' of {os.fspath(q)!r} "
                                 f"({part[2][0]:g} deg)")
        cube = np.stack([part[0] for part in parts], axis=2)
        return Cube(torch.from_numpy(cube), torch.from_numpy(wl), torch.from_numpy(ang), parts[0][3]).sorted()
    p = os.fspath(path)
    if p.endswith(".npz"):
        cube, wl, ang, bw, th, meta = _read_npz(p)
        ang_arg = _check_angles(angles_deg)
        if ang_arg is not None and (ang_arg.size != ang.numel() or not np.allclose(ang_arg, ang.numpy())):
            raise ValueError(f"angles_deg {ang_arg.tolist()} disagrees with the angle_deg {ang.tolist()} stored in {p!r}")
        return Cube(cube, wl, ang, bw, th, meta).sorted()
    if p.endswith(".hdr"):
        data, wl_all, ang_all, bw = _read_envi_one(p)
        ang_arg = _check_angles(angles_deg)
        if ang_all is None:
            if ang_arg is None:
                raise ValueError(f"ENVI file {p!r} has no per-band 'incidence angle' field: give angles_deg "
                                 "(one angle per block of bands, angle-major)")
            A = ang_arg.size
            if wl_all.size % A:
                raise ValueError(f"angles_deg: {A} angles do not divide the {wl_all.size} bands of {p!r}")
            B = wl_all.size // A
            if not np.allclose(wl_all.reshape(A, B), wl_all[None, :B]):
                raise ValueError(f"ENVI file {p!r} with {A} angles must repeat the same {B} wavelengths per angle "
                                 "(angle-major bands)")
            angles = ang_arg.tolist()
        else:
            angles = list(dict.fromkeys(ang_all.tolist()))
            if not all(0 <= a < 90 for a in angles):
                raise file_error("ENVI header", p, f"'incidence angle' must be in [0, 90) degrees; got {angles}")
            A = len(angles)
            B = wl_all.size // A
            if A * B != wl_all.size or not np.allclose(ang_all, np.repeat(angles, B)):
                raise file_error("ENVI header", p, "bands must be angle-major: all bands of one angle, then the "
                                                   "next")
            if ang_arg is not None and (ang_arg.size != A or not np.allclose(ang_arg, angles)):
                raise ValueError(f"angles_deg {ang_arg.tolist()} disagrees with the 'incidence angle' field of "
                                 f"{p!r} ({angles})")
        cube = data.reshape(data.shape[0], data.shape[1], A, B)
        return Cube(torch.from_numpy(cube), torch.from_numpy(wl_all[:B].copy()), torch.tensor(angles, dtype=torch.float64, device=_CPU),
                    bw).sorted()
    raise ValueError(f"path must be a .npz file, an ENVI .hdr file or a list of .hdr files; got {p!r}")
