r"""Measured scatterograms: reading and writing image files on the library's angular grid.

:func:`read_scatterogram` reads a measured scatterogram from a PNG file (8 or 16 bit,
sRGB-encoded, the disc's centre, radius and angular mapping given as parameters) and
resamples it onto the scatterogram grid of :func:`torchirid.layered.scatterogram`;
:func:`write_scatterogram` writes one (16 bit by default), so a rendered target
round-trips. OpenEXR (``.exr``) files — scene-linear R, G, B (optionally A) in half or
float, taken as linear sRGB primaries — go through the optional ``openexr`` package
(``pip install openexr``, or the ``torchirid[exr]`` extra); :func:`write_scatterogram`
writes linear float32 RGB, so an unclipped, unquantised round trip is possible.
"""

from __future__ import annotations

import math
import numbers
import os
import shutil
import struct
import tempfile
import zlib
from dataclasses import dataclass, field

import numpy as np
import torch

from .. import _checks
from .._io import atomic_write, check_readable, file_error, import_openexr, read_exr, reading  # noqa: F401
from ..color import linear_srgb_to_srgb, linear_srgb_to_xyz, xyz_to_linear_srgb
from ..layered.scatterograms import PROJECTIONS, projection_radius, scatterogram_directions

__all__ = ["ScatterogramImage", "read_scatterogram", "write_scatterogram"]


# ----------------------------------------------------------------------------------------
# measured scatterograms: PNG in, PNG out
# ----------------------------------------------------------------------------------------
_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_PNG_CHANNELS = {0: 1, 2: 3, 4: 2, 6: 4}  # colour type → samples per pixel (grey, RGB, grey+alpha, RGBA)


_PNG_WHAT = "scatterogram image"


def _png_chunks(data: bytes, path):
    if data[:8] != _PNG_SIGNATURE:
        raise file_error(_PNG_WHAT, path, "is not a PNG file (bad signature)")
    pos, chunks = 8, []
    while pos + 8 <= len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        chunks.append((kind, data[pos + 8:pos + 8 + length]))
        pos += 12 + length
        if kind == b"IEND":
            break
    return chunks


def _unfilter(raw: bytes, height: int, stride: int, bpp: int) -> np.ndarray:
    """Undo the PNG scanline filters (None, Sub, Up, Average, Paeth) → (height, stride) uint8."""
    rows = np.frombuffer(raw, np.uint8)
    if rows.size < height * (stride + 1):
        raise ValueError("PNG image data is truncated")
    rows = rows[:height * (stride + 1)].reshape(height, stride + 1)
    out = np.zeros((height, stride), np.uint8)
    prev = np.zeros(stride, np.int64)
    for y in range(height):
        kind, line = int(rows[y, 0]), rows[y, 1:].astype(np.int64)
        if kind == 0:
            cur = line
        elif kind == 1:  # Sub: a running sum along the row, per byte of the pixel
            cur = np.cumsum(line.reshape(-1, bpp), axis=0).reshape(-1) % 256
        elif kind == 2:
            cur = (line + prev) % 256
        elif kind in (3, 4):
            cur_l, up, ln = [0] * stride, prev.tolist(), line.tolist()
            for i in range(stride):
                a = cur_l[i - bpp] if i >= bpp else 0
                b = up[i]
                if kind == 3:
                    p = (a + b) // 2
                else:
                    c = up[i - bpp] if i >= bpp else 0
                    q = a + b - c
                    pa, pb, pc = abs(q - a), abs(q - b), abs(q - c)
                    p = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                cur_l[i] = (ln[i] + p) & 255
            cur = np.asarray(cur_l, np.int64)
        else:
            raise ValueError(f"PNG scanline {y} has an unknown filter type {kind}")
        out[y] = cur
        prev = cur
    return out


def _read_png(path) -> tuple[np.ndarray, np.ndarray, int]:
    """A PNG as (RGB in [0, 1] (H, W, 3) float64, valid (H, W) bool, bit depth).

    16-bit greyscale/RGB(A) (which Pillow reduces to 8 bits) are decoded here; 8-bit and
    palette images through Pillow. ``valid`` is False where a channel is at its maximum code
    (saturated) or alpha is 0."""
    path = check_readable(path, _PNG_WHAT, magic=_PNG_SIGNATURE, kind="a PNG file")
    with reading(path, _PNG_WHAT):
        data = path.read_bytes()
        chunks = _png_chunks(data, path)
        if not chunks or chunks[0][0] != b"IHDR" or len(chunks[0][1]) != 13:
            raise file_error(_PNG_WHAT, path, "is truncated or damaged (a PNG without a complete IHDR chunk)")
        width, height, depth, ctype, _, _, interlace = struct.unpack(">IIBBBBB", chunks[0][1])
        if width < 1 or height < 1:
            raise file_error(_PNG_WHAT, path, f"is damaged (PNG size {width} x {height})")
        if depth == 16:
            if interlace or ctype not in _PNG_CHANNELS:
                raise file_error(_PNG_WHAT, path, "is an interlaced 16-bit PNG (not supported)")
            channels = _PNG_CHANNELS[ctype]
            idat = b"".join(c for k, c in chunks if k == b"IDAT")
            if not idat:
                raise file_error(_PNG_WHAT, path, "is truncated (a PNG without image data)")
            raw = zlib.decompress(idat)
            rows = _unfilter(raw, height, width * channels * 2, channels * 2)
            pix = rows.view(">u2").reshape(height, width, channels).astype(np.float64) / 65535.0
        else:
            from PIL import Image

            with Image.open(path) as im:
                has_alpha = im.mode in ("RGBA", "LA", "PA") or (im.mode == "P" and "transparency" in im.info)
                mode = "RGBA" if has_alpha else ("L" if im.mode in ("1", "L", "I;16") else "RGB")
                pix = np.asarray(im.convert(mode), np.float64) / 255.0
        if pix.ndim == 2:
            pix = pix[..., None]
        channels = pix.shape[-1]
    colour = pix[..., :3] if channels >= 3 else np.repeat(pix[..., :1], 3, -1)
    valid = (colour < 1.0).all(-1)  # a channel at its maximum code is clipped: not a measurement
    if channels in (2, 4):
        valid &= pix[..., -1] > 0
    return colour, valid, depth


def _srgb_decode(v: torch.Tensor) -> torch.Tensor:
    """The inverse sRGB transfer function (IEC 61966-2-1)."""
    return torch.where(v <= 0.04045, v / 12.92, ((v.clamp_min(0.04045) + 0.055) / 1.055) ** 2.4)


@dataclass(frozen=True)
class ScatterogramImage:
    """A scatterogram read from an image file, on the library's grid.

    Attributes:
        xyz: ``(R, R, 3)`` float64 CIE XYZ (D65) × ``exposure``; 0 where ``mask`` is False.
        mask: ``(R, R)`` bool — on the disc, inside the image, not saturated, not transparent,
            finite (OpenEXR).
        directions: ``(R, R, 3)`` the reflected direction of each pixel (NaN off the disc).
        projection: the angular mapping of the grid.
        params: the reading parameters (JSON-ready).

    Example (what :func:`read_scatterogram` returns, for a 16-pixel render written as a PNG):
        >>> import os, tempfile
        >>> from torchirid.layered import scatterogram
        >>> from torchirid.presets import jewel_beetle
        >>> s = scatterogram(jewel_beetle("green"), incident_deg=(30.0, 0.0), resolution=16)  # a 30° beam
        >>> with tempfile.TemporaryDirectory() as d:
        ...     img = read_scatterogram(write_scatterogram(os.path.join(d, "beetle.png"), s))
        >>> tuple(img.xyz.shape), tuple(img.mask.shape), img.projection, bool((img.mask == s.mask).all())
        ((16, 16, 3), (16, 16), 'equidistant', True)
    """

    xyz: torch.Tensor
    mask: torch.Tensor
    directions: torch.Tensor
    projection: str
    params: dict = field(default_factory=dict, repr=False)


def read_scatterogram(path, *, projection: str = "equidistant", center=None, radius_px=None, resolution=None,
                      grid_projection: str | None = None, rotation_deg: float = 0.0,
                      exposure: float = 1.0, saturation: float | None = None) -> ScatterogramImage:
    r"""Read a measured scatterogram from a PNG or OpenEXR file and resample it onto the scatterogram grid.

    The file holds the disc of reflected directions as an imaging scatterometer records it:
    a PNG sRGB-encoded (8 or 16 bit; greyscale, RGB, with or without alpha, or palette), or
    an OpenEXR (``.exr``) file with scene-linear R, G, B (or Y) and optional A channels, with
    the polar angle θ mapped to the distance from ``center`` by ``projection`` (ρ(θ) ·
    ``radius_px`` pixels; ρ = 1 on the horizon) and the azimuth φ counter-clockwise from the
    image's +x (right) axis plus ``rotation_deg`` — the convention of
    :func:`~torchirid.layered.scatterograms.scatterogram` (row 0 at the top, +y up). Each grid
    pixel of :func:`~torchirid.layered.scatterograms.scatterogram_directions` is sampled
    bilinearly after decoding (sRGB → linear → XYZ, the exact inverse of the library's
    :func:`~torchirid.color.xyz_to_srgb`), so an image written by
    :func:`write_scatterogram` at the same resolution comes back unchanged up to
    quantisation and to the colours outside the sRGB gamut, which the PNG clips.

    **OpenEXR** (a path ending in ``.exr``) needs the optional ``openexr`` package
    (``pip install openexr``; ``ImportError`` saying so otherwise). Its values are linear
    sRGB primaries — no transfer function is decoded — converted to XYZ by the same matrix;
    the first part is read. A pixel is invalid (out of ``mask``) where a colour channel is
    NaN or infinite, where alpha is ≤ 0 or not finite, or, if ``saturation`` is given, where
    a channel reaches it. A file written by :func:`write_scatterogram` comes back
    unchanged up to float32 rounding (out-of-gamut colours included).

    Args:
        path: the PNG or ``.exr`` file.
        projection: the angular mapping of the file, one of
            :data:`~torchirid.layered.scatterograms.PROJECTIONS`.
        center: ``(x, y)`` of the disc's centre in pixels (x = column, y = row, pixel
            centres at integers); default the image centre ``((W − 1)/2, (H − 1)/2)``.
        radius_px: the horizon's radius in pixels (default ``min(W, H)/2``).
        resolution: pixels per side of the output grid (default ``round(2 · radius_px)``).
        grid_projection: the output grid's mapping (default ``projection``).
        rotation_deg: azimuth (degrees) of the file's +x axis in the scatterogram's frame.
        exposure: multiplies the decoded XYZ (e.g. 1 / the exposure used to write the file).
        saturation: OpenEXR only: the clipping level of the file's linear values (before
            ``exposure``); a pixel with a channel ≥ it is invalid. Default none. (A PNG's
            saturation is its maximum code; passing this for a PNG raises ``ValueError``.)

    Returns:
        a :class:`ScatterogramImage`; ``xyz`` and ``mask`` go to :func:`match_scatterogram`.

    Raises:
        ValueError: a bad argument; an empty, truncated, damaged, non-PNG / non-EXR or
            unsupported file, or an image smaller than 2 × 2 pixels (the message names the file).
        FileNotFoundError: no file at ``path``.
        ImportError: an ``.exr`` path without the ``openexr`` package.

    Example (a 16-pixel render written at half exposure, read back, and resampled onto 8 pixels):
        >>> import os, tempfile, torch
        >>> from torchirid.layered import scatterogram
        >>> from torchirid.presets import jewel_beetle
        >>> s = scatterogram(jewel_beetle("green"), incident_deg=(30.0, 0.0), resolution=16)
        >>> with tempfile.TemporaryDirectory() as d:
        ...     path = write_scatterogram(os.path.join(d, "beetle.png"), s, exposure=0.5)  # 16-bit sRGB
        ...     img = read_scatterogram(path, exposure=2.0)  # undo the exposure
        ...     small = read_scatterogram(path, resolution=8, exposure=2.0)
        >>> img.params["bits"], img.params["radius_px"], tuple(small.xyz.shape)  # radius in pixels
        (16, 8.0, (8, 8, 3))
        >>> bool((img.xyz - torch.where(s.mask[..., None], s.xyz, 0.0)).abs().max() < 0.01)  # XYZ
        True
    """
    is_exr = os.fspath(path).lower().endswith(".exr")
    if saturation is not None:
        if not is_exr:
            raise ValueError("saturation applies to OpenEXR files only (a PNG saturates at its maximum code)")
        if isinstance(saturation, bool) or not isinstance(saturation, numbers.Real) or not saturation > 0:
            raise ValueError(f"saturation must be None or a number > 0; got {saturation!r}")
    _checks.check_choice(projection, "projection", PROJECTIONS)
    grid_projection = projection if grid_projection is None else grid_projection
    _checks.check_choice(grid_projection, "grid_projection", PROJECTIONS)
    for name, v in (("exposure", exposure), ("radius_px", 1.0 if radius_px is None else radius_px)):
        if isinstance(v, bool) or not isinstance(v, numbers.Real) or not v > 0:
            raise ValueError(f"{name} must be a number > 0; got {v!r}")
    if isinstance(rotation_deg, bool) or not isinstance(rotation_deg, numbers.Real) or not math.isfinite(rotation_deg):
        raise ValueError(f"rotation_deg must be a finite number; got {rotation_deg!r}")
    if center is not None and not (isinstance(center, (tuple, list)) and len(center) == 2
                                   and all(isinstance(v, numbers.Real) and math.isfinite(v) for v in center)):
        raise ValueError(f"center must be None or (x, y) in pixels; got {center!r}")
    if resolution is not None:
        _checks.check_int(resolution, "resolution", 1)

    f64 = torch.float64
    if is_exr:
        rgb, valid = read_exr(path, saturation, what=_PNG_WHAT)
        linear, file_params = torch.as_tensor(rgb, dtype=f64), {"format": "exr"}
        if saturation is not None:
            file_params["saturation"] = float(saturation)
    else:
        rgb, valid, depth = _read_png(path)
        linear, file_params = _srgb_decode(torch.as_tensor(rgb, dtype=f64)), {"format": "png", "bits": depth}
    if min(valid.shape) < 2:
        raise file_error(_PNG_WHAT, path, f"is {valid.shape[1]} x {valid.shape[0]} pixels; a scatterogram image "
                                          "needs at least 2 x 2 (a disc to resample)")
    xyz_img = linear_srgb_to_xyz(linear) * float(exposure)  # (H, W, 3)
    return _resample(xyz_img, valid, path=path, projection=projection, center=center, radius_px=radius_px,
                     resolution=resolution, grid_projection=grid_projection, rotation_deg=rotation_deg,
                     exposure=exposure, file_params=file_params)


def _resample(xyz_img, valid, *, path, projection, center, radius_px, resolution, grid_projection, rotation_deg,
              exposure, file_params) -> ScatterogramImage:
    """Bilinearly resample an image's XYZ (H, W, 3) float64 and validity onto the scatterogram grid."""
    f64 = torch.float64
    h, w = valid.shape
    cx, cy = ((w - 1) / 2.0, (h - 1) / 2.0) if center is None else (float(center[0]), float(center[1]))
    radius = min(w, h) / 2.0 if radius_px is None else float(radius_px)
    res = max(1, int(round(2 * radius))) if resolution is None else resolution

    directions, disc = scatterogram_directions(res, projection=grid_projection, dtype=f64)
    d = torch.where(disc.unsqueeze(-1), directions, torch.zeros_like(directions))
    theta = torch.acos(d[..., 2].clamp(-1.0, 1.0))
    phi = torch.atan2(d[..., 1], d[..., 0]) - math.radians(rotation_deg)
    rho = projection_radius(theta, projection)
    u = cx + radius * rho * torch.cos(phi)  # column
    v = cy - radius * rho * torch.sin(phi)  # row (+y up)
    tol = 1e-6  # pixels: rounding of u, v on the image's border pixels
    inside = (u >= -tol) & (u <= w - 1 + tol) & (v >= -tol) & (v <= h - 1 + tol)
    u, v = u.clamp(0.0, w - 1), v.clamp(0.0, h - 1)
    grid = torch.stack([2.0 * u / max(w - 1, 1) - 1.0, 2.0 * v / max(h - 1, 1) - 1.0], -1)[None]
    stack = torch.cat([xyz_img, torch.as_tensor(valid, dtype=f64)[..., None]], -1).permute(2, 0, 1)[None]
    sampled = torch.nn.functional.grid_sample(stack, grid, mode="bilinear", padding_mode="zeros",
                                              align_corners=True)[0].permute(1, 2, 0)
    mask = disc & inside & (sampled[..., 3] > 1.0 - 1e-6)  # every contributing file pixel valid
    xyz = torch.where(mask.unsqueeze(-1), sampled[..., :3], torch.zeros_like(sampled[..., :3]))
    params = {"path": os.fspath(path), **file_params, "size": [w, h], "projection": projection,
              "grid_projection": grid_projection, "center": [cx, cy], "radius_px": radius, "resolution": res,
              "rotation_deg": float(rotation_deg), "exposure": float(exposure)}
    return ScatterogramImage(xyz, mask, directions, grid_projection, params)


def _write_png(path, pixels: np.ndarray):
    """Write ``pixels`` (H, W, 3) uint8 or uint16 as an RGB PNG (filter None), atomically."""
    h, w, _ = pixels.shape
    depth = 16 if pixels.dtype == np.uint16 else 8
    body = pixels.astype(">u2" if depth == 16 else np.uint8).reshape(h, -1).view(np.uint8)
    raw = np.concatenate([np.zeros((h, 1), np.uint8), body], 1).tobytes()

    def chunk(kind, payload):
        return struct.pack(">I", len(payload)) + kind + payload + struct.pack(">I", zlib.crc32(kind + payload))

    data = (_PNG_SIGNATURE + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, depth, 2, 0, 0, 0))
            + chunk(b"sRGB", b"\x00") + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))
    return atomic_write(path, lambda f: f.write(data))


def _linear_rgb_to_write(scatterogram_or_xyz, exposure, mask) -> torch.Tensor:
    """Linear sRGB (H, W, 3) float64 of a scatterogram (or an XYZ array) times ``exposure``,
    black off ``mask`` (default: the object's own mask, or none); shared by the PNG and EXR writers."""
    if isinstance(exposure, bool) or not isinstance(exposure, numbers.Real) or not exposure > 0:
        raise ValueError(f"exposure must be a number > 0; got {exposure!r}")
    obj = scatterogram_or_xyz
    xyz = obj.xyz if hasattr(obj, "xyz") else obj
    if mask is None and hasattr(obj, "mask"):
        mask = obj.mask
    xyz = torch.as_tensor(xyz).detach().to(torch.float64)
    if xyz.dim() != 3 or xyz.shape[-1] != 3:
        raise ValueError(f"xyz must have shape (H, W, 3); got {tuple(xyz.shape)}")
    rgb = xyz_to_linear_srgb(xyz * float(exposure))
    if mask is not None:
        rgb = torch.where(torch.as_tensor(mask, dtype=torch.bool).unsqueeze(-1), rgb, torch.zeros_like(rgb))
    return rgb


def write_scatterogram(path, scatterogram_or_xyz, *, format: str | None = None, exposure: float = 1.0,
                       bits: int = 16, mask=None):
    """Write a scatterogram as an image, the counterpart of :func:`read_scatterogram` (read it back
    with ``exposure=1/exposure``):

    - ``"png"``: sRGB, 8 or 16 bit (``bits``), black off the disc; values outside [0, 1] after
      encoding are clipped (and read back as saturated);
    - ``"exr"``: OpenEXR, scene-linear float32 R, G, B (linear sRGB primaries), black off the
      disc; nothing is clipped (negative components of out-of-gamut colours and values above 1
      are kept). Needs the optional ``openexr`` package (``pip install openexr``).

    Args:
        path: the file; its suffix (``.png``, ``.exr``) gives the format unless ``format`` is set.
        scatterogram_or_xyz: a :class:`~torchirid.layered.Scatterogram` (or
            :class:`ScatterogramImage`), or an ``(H, W, 3)`` XYZ array.
        format: ``"png"`` or ``"exr"``; default: from the suffix.
        exposure: multiplies the XYZ before encoding.
        bits: 8 or 16 (PNG only).
        mask: ``(H, W)`` bool, pixels written (default the object's mask, or all).

    Returns the path (a ``Path``); written atomically (a temporary file renamed over ``path``).

    Raises:
        ValueError: an unknown format or suffix, ``bits`` not 8 or 16, ``exposure`` not > 0, or
            an array that is not ``(H, W, 3)``.

    Example (an 8-bit PNG and an OpenEXR file of a 16-pixel render; the EXR round trip is exact
    to float32 rounding):
        >>> import os, tempfile, torch
        >>> from torchirid.layered import scatterogram
        >>> from torchirid.presets import jewel_beetle
        >>> s = scatterogram(jewel_beetle("green"), incident_deg=(30.0, 0.0), resolution=16)
        >>> with tempfile.TemporaryDirectory() as d:
        ...     png = read_scatterogram(write_scatterogram(os.path.join(d, "beetle.png"), s, bits=8))
        ...     exr = read_scatterogram(write_scatterogram(os.path.join(d, "beetle.exr"), s))
        >>> png.params["format"], png.params["bits"], tuple(png.xyz.shape)
        ('png', 8, (16, 16, 3))
        >>> err = (exr.xyz - torch.where(s.mask[..., None], s.xyz, 0.0)).abs().max()  # XYZ
        >>> exr.params["format"], bool(err < 1e-6)
        ('exr', True)
    """
    if format is None:
        format = os.path.splitext(os.fspath(path))[1].lower().lstrip(".")
        if format not in ("png", "exr"):
            raise ValueError(f"path must end in .png or .exr (or pass format='png' / 'exr'); got {os.fspath(path)!r}")
    else:
        _checks.check_choice(format, "format", ("png", "exr"))
    if format == "png":
        return _write_scatterogram_png(path, scatterogram_or_xyz, exposure, bits, mask)
    return _write_scatterogram_exr(path, scatterogram_or_xyz, exposure, mask)


def _write_scatterogram_png(path, scatterogram_or_xyz, exposure, bits, mask):
    """The PNG writer of :func:`write_scatterogram`."""
    if bits not in (8, 16):
        raise ValueError(f"bits must be 8 or 16; got {bits!r}")
    rgb = linear_srgb_to_srgb(_linear_rgb_to_write(scatterogram_or_xyz, exposure, mask)).clamp(0.0, 1.0)
    top = 65535 if bits == 16 else 255
    pixels = np.rint(rgb.numpy() * top).astype(np.uint16 if bits == 16 else np.uint8)
    return _write_png(path, pixels)


def _write_scatterogram_exr(path, scatterogram_or_xyz, exposure, mask):
    """The OpenEXR writer of :func:`write_scatterogram`."""
    rgb = _linear_rgb_to_write(scatterogram_or_xyz, exposure, mask)
    pixels = rgb.numpy().astype(np.float32)
    OpenEXR = import_openexr()
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    exr = OpenEXR.File(header, {c: np.ascontiguousarray(pixels[..., i]) for i, c in enumerate("RGB")})

    def write(f):
        # the binding writes to a file name: encode into a private temporary file, then copy its
        # bytes into atomic_write's (which is renamed over ``path`` once complete)
        with tempfile.TemporaryDirectory() as tmp:
            name = os.path.join(tmp, "scatterogram.exr")
            exr.write(name)
            with open(name, "rb") as src:
                shutil.copyfileobj(src, f)

    return atomic_write(path, write)
