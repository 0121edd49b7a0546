"""Hyperspectral cubes in and out: ENVI (.hdr + raw, through the ``spectral`` package) and .npz.

A cube is ``(H, W, A, B)`` band reflectance with ``wavelength`` ``(B,)`` in nm and incidence
``angles_deg`` ``(A,)``. On disk:

* ``.npz`` (``allow_pickle=False``): arrays ``cube`` (H, W, A, B), ``wavelength_nm`` (B,),
  ``angle_deg`` (A,), optional ``bandwidth_nm`` (scalar), ``thickness_nm`` (H, W, a
  ground truth for synthetic cubes) and ``meta`` (a JSON string, e.g. polarization,
  n_substrate).
* ENVI: one image of H lines × W samples × A·B bands (angle-major: band index a·B + b), with
  the standard ``wavelength`` and ``fwhm`` header fields per band and a ``incidence angle``
  field per band (degrees). A list of ENVI files, one per angle, with ``angles_deg`` given,
  is read as well.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field

import numpy as np
import torch


__all__ = ["Cube", "read_cube", "write_npz", "write_envi"]


@dataclass
class Cube:
    """cube ``(H, W, A, B)`` float64, wavelength ``(B,)`` nm, angles_deg ``(A,)``, bandwidth (nm or None),
    thickness (optional ground truth ``(H, W)``), meta (dict)."""

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
    """Write a cube as .npz (module docstring)."""
    cube, wl, ang = (torch.as_tensor(x, dtype=torch.float64) for x in (cube, wavelength, angles_deg))
    _check_shapes(cube, wl, ang)
    arrays = dict(cube=cube.numpy(), wavelength_nm=wl.numpy(), angle_deg=ang.numpy(),
                  meta=np.array(json.dumps(meta or {})))
    if bandwidth is not None:
        arrays["bandwidth_nm"] = np.array(float(bandwidth))
    if thickness is not None:
        arrays["thickness_nm"] = torch.as_tensor(thickness, dtype=torch.float64).numpy()
    tmp = os.fspath(path) + ".tmp.npz"
    np.savez_compressed(tmp, **arrays)
    os.replace(tmp, path)


def write_envi(path_hdr, cube, wavelength, angles_deg, *, bandwidth=None) -> None:
    """Write a cube as ENVI .hdr + .img (float32 data, angle-major bands, module docstring)."""
    from spectral.io import envi

    cube, wl, ang = (torch.as_tensor(x, dtype=torch.float64) for x in (cube, wavelength, angles_deg))
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


def _read_envi_one(path):
    from spectral.io import envi

    img = envi.open(os.fspath(path))
    data = np.asarray(img.load(), dtype=np.float64)
    md = img.metadata
    wl = np.asarray([float(v) for v in md.get("wavelength", [])])
    if wl.size != data.shape[-1]:
        raise ValueError(f"ENVI file {os.fspath(path)!r} must give one 'wavelength' per band")
    ang = md.get("incidence angle")
    fwhm = md.get("fwhm")
    return data, wl, (None if ang is None else np.asarray([float(v) for v in ang])), (
        None if not fwhm else float(np.median([float(v) for v in fwhm])))


def read_cube(path, *, angles_deg=None) -> Cube:
    """Read a cube from .npz, an ENVI header, or a list of ENVI headers (one per angle, ``angles_deg`` given).

    Example:
        >>> import tempfile, os, torch
        >>> d = tempfile.mkdtemp(); p = os.path.join(d, "c.npz")
        >>> write_npz(p, torch.zeros(2, 3, 2, 4), [400, 404, 408, 412], [10, 20])
        >>> tuple(read_cube(p).cube.shape)
        (2, 3, 2, 4)
    """
    if isinstance(path, (list, tuple)):
        if angles_deg is None or len(angles_deg) != len(path):
            raise ValueError("angles_deg must give one angle per ENVI file")
        parts = [_read_envi_one(p) for p in path]
        wl = parts[0][1]
        if any(p[1].shape != wl.shape or not np.allclose(p[1], wl) for p in parts):
            raise ValueError("every ENVI file must have the same wavelengths")
        cube = np.stack([p[0] for p in parts], axis=2)
        return Cube(torch.from_numpy(cube), torch.from_numpy(wl), torch.as_tensor(angles_deg, dtype=torch.float64),
                    parts[0][3]).sorted()
    p = os.fspath(path)
    if p.endswith(".npz"):
        with np.load(p, allow_pickle=False) as z:
            for key in ("cube", "wavelength_nm", "angle_deg"):
                if key not in z:
                    raise ValueError(f"{p!r} must hold arrays cube, wavelength_nm, angle_deg; missing {key!r}")
            cube = torch.from_numpy(z["cube"].astype(np.float64))
            wl = torch.from_numpy(z["wavelength_nm"].astype(np.float64))
            ang = torch.from_numpy(z["angle_deg"].astype(np.float64))
            bw = float(z["bandwidth_nm"]) if "bandwidth_nm" in z else None
            th = torch.from_numpy(z["thickness_nm"].astype(np.float64)) if "thickness_nm" in z else None
            meta = json.loads(str(z["meta"])) if "meta" in z else {}
        _check_shapes(cube, wl, ang)
        return Cube(cube, wl, ang, bw, th, meta).sorted()
    if p.endswith(".hdr"):
        data, wl_all, ang_all, bw = _read_envi_one(p)
        if ang_all is None:
            if angles_deg is None or len(angles_deg) != 1:
                raise ValueError("an ENVI file without an 'incidence angle' field needs angles_deg=[one angle]")
            ang_all = np.full(wl_all.shape, float(angles_deg[0]))
        angles = list(dict.fromkeys(ang_all.tolist()))
        A = len(angles)
        B = wl_all.size // A
        if A * B != wl_all.size or not np.allclose(ang_all, np.repeat(angles, B)):
            raise ValueError("ENVI bands must be angle-major: all bands of one angle, then the next")
        cube = data.reshape(data.shape[0], data.shape[1], A, B)
        return Cube(torch.from_numpy(cube), torch.from_numpy(wl_all[:B].copy()), torch.tensor(angles, dtype=torch.float64),
                    bw).sorted()
    raise ValueError(f"path must be a .npz file, an ENVI .hdr file or a list of .hdr files; got {p!r}")
