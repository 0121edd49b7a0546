r"""Scenes and renders for the plugins: a sphere under an environment map, rendered in passes
with a progress callback, written to EXR or PNG. Used by ``torchirid render-mitsuba``, the
gallery and the environment-lit cross-check of :func:`torchirid.ibl.shade_thin_film_environment`;
not part of the package's public names (``torchirid.mitsuba.register`` is).

Frame: the scene is built in **torchirid's z-up frame** (that of
:mod:`torchirid.ibl.prefilter`: +z up, a map's row 0 the zenith, column j at azimuth
φ = (j + ½)2π/W from +x towards +y). Mitsuba's ``envmap`` reads its bitmap y-up and clockwise,
so :func:`environment_emitter` hands it the map with its columns reversed and the rotation
``[[0, 0, −1], [−1, 0, 0], [0, 1, 0]]`` (checked in tests/ibl/test_shading.py).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

#: the rotation that maps Mitsuba's envmap frame (y up, its bitmap's columns reversed) onto
#: torchirid's z-up frame
ENVMAP_TO_WORLD = [[0, 0, -1, 0], [-1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 1]]


def find_libllvm() -> str | None:
    """Point Dr.Jit at libLLVM 19 (``DRJIT_LIBLLVM_PATH``) when it is installed and nothing is
    set: Debian 12's default libLLVM 15 crashes Dr.Jit's LLVM backend. Call before Dr.Jit
    starts its LLVM backend; returns the path used (or ``None``)."""
    import glob
    import os

    if "DRJIT_LIBLLVM_PATH" in os.environ:
        return os.environ["DRJIT_LIBLLVM_PATH"]
    for path in sorted(glob.glob("/usr/lib/*/libLLVM-19.so*") + glob.glob("/usr/lib/*/libLLVM.so.19*")):
        os.environ["DRJIT_LIBLLVM_PATH"] = path
        return path
    return None


def default_variant(spectral: bool = True) -> str:
    """The variant to render in here: ``llvm_ad_spectral`` (or ``llvm_ad_rgb``) when Dr.Jit has
    its LLVM backend (after :func:`find_libllvm`), else ``scalar_spectral`` (``scalar_rgb``): the
    scalar variants call the Python BSDF once per sample — minutes instead of seconds."""
    find_libllvm()
    import drjit as dr

    kind = "spectral" if spectral else "rgb"
    return f"llvm_ad_{kind}" if dr.has_backend(dr.JitBackend.LLVM) else f"scalar_{kind}"


def _mitsuba():
    import drjit as dr
    import mitsuba as mi

    return mi, dr


def environment_emitter(env, *, scale: float = 1.0) -> dict:
    """An ``envmap`` emitter dict of an ``(H, W, 3)`` linear-RGB map in torchirid's frame."""
    mi, _ = _mitsuba()
    data = np.ascontiguousarray(np.asarray(env, dtype=np.float32)[:, ::-1, :])
    return {"type": "envmap", "bitmap": mi.Bitmap(data), "scale": float(scale),
            "to_world": mi.ScalarTransform4f(ENVMAP_TO_WORLD)}


def sphere_scene(bsdf, *, environment=None, size: int = 64, spp: int = 64, integrator: str = "path",
                 max_depth: int = 3, elevation_deg: float = 30.0, azimuth_deg: float = 0.0, distance: float = 4.0,
                 fov_deg: float = 30.0, extra: dict | None = None):
    """A unit sphere at the origin with ``bsdf`` (a dict or a loaded BSDF), seen from
    ``elevation_deg`` above the horizon at ``azimuth_deg`` (from +x towards +y), lit by
    ``environment`` (an ``(H, W, 3)`` linear-RGB map in torchirid's frame, or an emitter dict;
    default: the library's synthetic sky, :func:`torchirid.ibl.synthetic_environment`)."""
    mi, _ = _mitsuba()
    if environment is None:
        from ..ibl import synthetic_environment

        environment = synthetic_environment().numpy()
    emitter = environment if isinstance(environment, dict) else environment_emitter(environment)
    el, az = math.radians(elevation_deg), math.radians(azimuth_deg)
    eye = [distance * math.cos(el) * math.cos(az), distance * math.cos(el) * math.sin(az), distance * math.sin(el)]
    scene = {
        "type": "scene",
        "integrator": {"type": integrator, "max_depth": int(max_depth)},
        "sensor": {"type": "perspective", "fov": float(fov_deg),
                   "to_world": mi.ScalarTransform4f().look_at(origin=eye, target=[0, 0, 0], up=[0, 0, 1]),
                   "film": {"type": "hdrfilm", "width": int(size), "height": int(size), "rfilter": {"type": "box"},
                            "pixel_format": "rgb"},
                   "sampler": {"type": "independent", "sample_count": int(spp)}},
        "sphere": {"type": "sphere", "bsdf": bsdf},
        "environment": emitter,
    }
    scene.update(extra or {})
    return mi.load_dict(scene)


def render(scene, *, spp: int, seed: int = 0, passes: int | None = None, exact: bool = False, progress=None):
    """Render ``scene`` with ``spp`` samples per pixel in ``passes`` passes (each its own seed,
    averaged: the same estimator, with a progress report between passes), as an ``(H, W, 3)``
    float32 array of linear RGB.

    ``exact``: the scene holds BSDFs with ``evaluator = "torch"``: Dr.Jit's symbolic loops and
    calls are switched off for the render (torch runs on evaluated arrays) and restored after.
    ``progress(done, total)`` is called after each pass."""
    mi, dr = _mitsuba()
    passes = passes or max(1, min(spp // 16, 64))
    per = [spp // passes + (1 if k < spp % passes else 0) for k in range(passes)]
    flags = (dr.flag(dr.JitFlag.SymbolicLoops), dr.flag(dr.JitFlag.SymbolicCalls))
    if exact:
        dr.set_flag(dr.JitFlag.SymbolicLoops, False)
        dr.set_flag(dr.JitFlag.SymbolicCalls, False)
    try:
        total = None
        for k, n in enumerate(per):
            if n == 0:
                continue
            img = np.array(mi.render(scene, spp=n, seed=seed * 1_000_003 + k), dtype=np.float64)
            total = img * n if total is None else total + img * n
            if progress is not None:
                progress(k + 1, passes)
    finally:
        dr.set_flag(dr.JitFlag.SymbolicLoops, flags[0])
        dr.set_flag(dr.JitFlag.SymbolicCalls, flags[1])
    return (total / spp).astype(np.float32)


def write_image(image, path) -> Path:
    """Write ``(H, W, 3)`` linear RGB to ``path``: ``.exr`` as is (float32), ``.png`` in sRGB
    (clipped to [0, 1], 8 bit)."""
    mi, _ = _mitsuba()
    path = Path(path)
    bitmap = mi.Bitmap(np.ascontiguousarray(image, dtype=np.float32), mi.Bitmap.PixelFormat.RGB)
    if path.suffix.lower() == ".exr":
        bitmap.write(str(path))
    elif path.suffix.lower() == ".png":
        bitmap.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, srgb_gamma=True).write(str(path))
    else:
        raise ValueError(f"{path}: write .exr or .png")
    return path
