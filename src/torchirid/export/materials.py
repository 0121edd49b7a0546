r"""Thin-film materials for renderers: glTF ``KHR_materials_iridescence`` and OpenPBR parameters.

A film of real index ``n_film`` and thickness ``d`` (nm, or a range) on a base, as glTF 2.0
``KHR_materials_iridescence`` (``iridescenceIor``, ``iridescenceThicknessMinimum/Maximum`` in
nm) and OpenPBR (``thin_film_thickness`` in µm, ``thin_film_ior``), with the list of the
approximations those formats impose (returned under ``"approximations"``).
"""

from __future__ import annotations

import json
import math
import numbers
from pathlib import Path

import numpy as np
import torch

from .._io import atomic_write
from .._version import __version__


__all__ = ["thin_film_material", "write_thin_film_material"]


def _real_number(x, name: str, lo: float) -> float:
    if isinstance(x, bool) or not isinstance(x, numbers.Real):
        if isinstance(x, numbers.Complex):
            raise ValueError(f"{name} must be real (glTF and OpenPBR films are non-absorbing); "
                             f"got {x!r}: pass its real part to drop the absorption knowingly")
        raise ValueError(f"{name} must be a real number, got {x!r}")
    x = float(x)
    if not math.isfinite(x) or x < lo:
        raise ValueError(f"{name} must be finite and >= {lo:g}, got {x!r}")
    return x


def _base(n_substrate):
    """(kind, glTF/OpenPBR base fields, F0 triple) for n_substrate None / real / complex, scalar or RGB."""
    vals = [1.5] if n_substrate is None else (list(n_substrate) if isinstance(n_substrate, (list, tuple, np.ndarray,
                                                                             torch.Tensor)) else [n_substrate])
    if isinstance(n_substrate, torch.Tensor):
        vals = n_substrate.detach().cpu().reshape(-1).tolist()
    if len(vals) not in (1, 3):
        raise ValueError(f"n_substrate must be a number or 3 numbers (R, G, B), got {len(vals)}")
    out = []
    for v in vals:
        if isinstance(v, bool) or not isinstance(v, numbers.Complex):
            raise ValueError(f"n_substrate entries must be numbers, got {v!r}")
        c = complex(v)
        if not (math.isfinite(c.real) and math.isfinite(c.imag)) or c.real <= 0 or c.imag < 0:
            raise ValueError(f"n_substrate must have a positive real part and k >= 0, got {v!r}")
        out.append(c)
    out = out * 3 if len(out) == 1 else out
    f0 = [abs((c - 1) / (c + 1)) ** 2 for c in out]
    metal = any(c.imag > 0 for c in out)
    if not metal and len({c.real for c in out}) > 1:
        raise ValueError("a dielectric n_substrate must be one real index (glTF/OpenPBR carry one ior)")
    return metal, out, f0


def thin_film_material(n_film, thickness, *, n_substrate=None, roughness: float = 0.0,
                       name: str = "torchirid_thin_film") -> dict:
    r"""glTF ``KHR_materials_iridescence`` and OpenPBR parameters of a thin film on a base.

    Args:
        n_film: the film's real refractive index, ``>= 1`` (glTF requires
            ``iridescenceIor >= 1``; a complex index is refused: both formats are non-absorbing).
        thickness: film thickness in nm (``>= 0``), or ``(min, max)`` for a thickness range
            (glTF maps it through ``iridescenceThicknessTexture``; untextured, glTF uses max).
        n_substrate: the base's index: ``None`` (glTF's default dielectric, 1.5), a real number
            (dielectric, via ``KHR_materials_ior`` / ``specular_ior``), or a complex
            ``n + ik`` (conductor, scalar or R, G, B), exported as a metal whose base colour is
            the normal-incidence reflectance ``F0 = |(n-1)/(n+1)|²``.
        roughness: the base's GGX roughness (glTF ``roughnessFactor``, OpenPBR
            ``specular_roughness``), in [0, 1].
        name: material name.

    Returns:
        ``{"gltf_material": {...}, "gltf_extensions_used": [...], "openpbr": {...},
        "approximations": {"gltf": [...], "openpbr": [...]}, "source": {...}}``.

    Example:
        >>> m = thin_film_material(1.33, (250.0, 400.0))
        >>> m["gltf_material"]["extensions"]["KHR_materials_iridescence"]["iridescenceThicknessMaximum"]
        400.0
        >>> m["openpbr"]["thin_film_thickness"]     # µm
        0.4
    """
    n_film = _real_number(n_film, "n_film", 1.0)
    if isinstance(thickness, (tuple, list)):
        if len(thickness) != 2:
            raise ValueError(f"thickness must be a number or (min, max), got {thickness!r}")
        d_min = _real_number(thickness[0], "thickness[0] (min)", 0.0)
        d_max = _real_number(thickness[1], "thickness[1] (max)", 0.0)
        if d_min > d_max:
            raise ValueError(f"thickness range must have min <= max, got {thickness!r}")
        ranged = True
    else:
        d_min = d_max = _real_number(thickness, "thickness", 0.0)
        ranged = False
    roughness = _real_number(roughness, "roughness", 0.0)
    if roughness > 1:
        raise ValueError(f"roughness must be in [0, 1], got {roughness}")
    if not isinstance(name, str) or not name:
        raise ValueError(f"name must be a non-empty string, got {name!r}")
    metal, nb, f0 = _base(n_substrate)

    irid = {"iridescenceFactor": 1.0, "iridescenceIor": n_film,
            "iridescenceThicknessMinimum": d_min, "iridescenceThicknessMaximum": d_max}
    pbr = {"metallicFactor": 1.0 if metal else 0.0, "roughnessFactor": roughness,
           "baseColorFactor": [*f0, 1.0] if metal else [0.0, 0.0, 0.0, 1.0]}
    ext = {"KHR_materials_iridescence": irid}
    if not metal:
        ext["KHR_materials_ior"] = {"ior": nb[0].real}
    gltf = {"name": name, "pbrMetallicRoughness": pbr, "extensions": ext}
    openpbr = {"base_weight": 1.0, "base_color": list(f0) if metal else [0.0, 0.0, 0.0],
               "base_metalness": 1.0 if metal else 0.0, "specular_weight": 1.0,
               "specular_color": [1.0, 1.0, 1.0], "specular_roughness": roughness,
               "specular_ior": 1.5 if metal else nb[0].real,
               "thin_film_weight": 1.0, "thin_film_thickness": d_max / 1000.0,
               "thin_film_ior": n_film}
    approx_gltf = [
        "film non-absorbing: iridescenceIor is real (no extinction coefficient)",
        "single film between air (n = 1) and the base; no film stacks",
        "iridescenceFactor = 1: the film covers the whole surface",
        "renderers evaluate the Airy reflectance in RGB (Belcour–Barla-style, polarisation "
        "averaged), not spectrally",
        ("thickness range mapped linearly through the G channel of iridescenceThicknessTexture "
         "between Minimum and Maximum; untextured, the thickness is iridescenceThicknessMaximum")
        if ranged else "single thickness: Minimum = Maximum, no thickness texture",
    ]
    approx_pbr = [
        "film non-absorbing: thin_film_ior is real",
        "single film; thin_film_thickness is one value in µm (texture it for variation)",
        "thin_film_weight = 1: the film covers the whole surface",
    ]
    if ranged:
        approx_pbr.append("thickness range has no OpenPBR parameter: thin_film_thickness holds the "
                          "maximum (as glTF's untextured value)")
    if metal:
        approx_gltf.append("conductor base reduced to F0 = |(n-1)/(n+1)|^2 as baseColorFactor "
                           "(metallic 1); its complex index (and the film/metal phase shift) is "
                           "re-derived from F0 by the renderer")
        approx_pbr.append("conductor base reduced to F0 = base_color with F82-tint Fresnel "
                          "(specular_color white); the complex index is not carried")
    else:
        approx_gltf.append("dielectric base: F0 from KHR_materials_ior "
                           + ("(n_substrate not given: glTF default 1.5)" if n_substrate is None else "")
                           + "; black diffuse base colour (specular reflection only)")
        approx_pbr.append("dielectric base: specular_ior = n_substrate"
                          + (" (not given: 1.5)" if n_substrate is None else "")
                          + "; black base colour (specular reflection only)")
    return {"gltf_material": gltf, "gltf_extensions_used": sorted(ext),
            "openpbr": openpbr,
            "approximations": {"gltf": approx_gltf, "openpbr": approx_pbr},
            "source": {"n_film": n_film, "thickness_nm": [d_min, d_max] if ranged else d_max,
                       "n_substrate": None if n_substrate is None else
                       [[c.real, c.imag] for c in nb], "roughness": roughness,
                       "torchirid_version": __version__}}


def write_thin_film_material(path, n_film, thickness, *, n_substrate=None, format: str | None = None,
                             roughness: float = 0.0, name: str = "torchirid_thin_film") -> list[Path]:
    """Write :func:`thin_film_material` as a minimal glTF 2.0 file and/or an OpenPBR JSON.

    ``format``: ``"gltf"`` (``<stem>.gltf``: ``asset.version "2.0"``, one material carrying
    the extensions, ``extensionsUsed``; the approximations under the material's ``extras``),
    ``"openpbr"`` (``<stem>.openpbr.json``: ``{"openpbr": {...}, "approximations": [...],
    "source": {...}}``), ``"both"``, or ``None`` to infer from the suffix (``.gltf`` → glTF,
    ``.json`` → OpenPBR).  Written atomically; returns the written paths.

    Example (a soap film 250–400 nm thick, n = 1.33, over glTF's default dielectric base):
        >>> import json, os, tempfile
        >>> with tempfile.TemporaryDirectory() as folder:
        ...     paths = write_thin_film_material(os.path.join(folder, "soap"), 1.33, (250.0, 400.0), format="both")
        ...     gltf = json.loads(paths[0].read_text())
        >>> [p.name for p in paths]
        ['soap.gltf', 'soap.openpbr.json']
        >>> gltf["asset"]["version"], gltf["materials"][0]["extensions"]["KHR_materials_iridescence"]["iridescenceIor"]
        ('2.0', 1.33)
    """
    p = Path(path)
    if format is None:
        format = {".gltf": "gltf", ".json": "openpbr"}.get(p.suffix.lower())
        if format is None:
            raise ValueError(f"cannot infer the format from {str(p)!r}: use a .gltf or .json "
                             f"suffix, or format='gltf'|'openpbr'|'both'")
    if format not in ("gltf", "openpbr", "both"):
        raise ValueError(f"format must be 'gltf', 'openpbr' or 'both', got {format!r}")
    m = thin_film_material(n_film, thickness, n_substrate=n_substrate, roughness=roughness, name=name)
    stem = p.with_suffix("") if p.suffix.lower() in (".gltf", ".json") else p
    if stem.suffix.lower() == ".openpbr":
        stem = stem.with_suffix("")
    out = []

    def dump(target: Path, obj) -> None:
        text = json.dumps(obj, indent=1, allow_nan=False, ensure_ascii=False) + "\n"
        out.append(atomic_write(target, lambda f: f.write(text.encode("utf-8"))))

    if format in ("gltf", "both"):
        mat = dict(m["gltf_material"], extras={"torchirid": {
            "approximations": m["approximations"]["gltf"], "source": m["source"]}})
        dump(stem.with_name(stem.name + ".gltf"), {
            "asset": {"version": "2.0", "generator": f"torchirid {__version__}"},
            "extensionsUsed": m["gltf_extensions_used"], "materials": [mat]})
    if format in ("openpbr", "both"):
        dump(stem.with_name(stem.name + ".openpbr.json"), {
            "openpbr": m["openpbr"], "approximations": m["approximations"]["openpbr"],
            "source": m["source"]})
    return out
