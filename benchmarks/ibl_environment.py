#!/usr/bin/env python
"""The IBL thin-film methods under environment maps, against the library's texel-sum reference.

The gallery's rough soap-film sphere (docs/examples/plot_thin_film_environment.py: η₂ = 1.33 on
air, d = 100 nm at the top → 800 nm at the bottom, GGX α = 0.25, the same orthographic view) under
four generated maps (``ibl.synthetic_environment``; nothing downloaded):

- ``sky`` — the gallery's synthetic sky (gradient, grey ground, a broad sun: radius 0.12 rad,
  radiance 40);
- ``sun_sky`` — a CIE clear sky with a small bright sun (radius 0.03 rad, radiance 2000, its
  power kept on any map size);
- ``indoor`` — a room lit by four bright rectangular sources;
- ``uniform`` — a constant white map (uniform light; a check of the uniform-light ranking).

Reference: ``shade_thin_film_environment(env, ..., method="reference")`` — eq. 11 summed over every
texel with the exact BRDF (GGX, separable Smith G, the film's spectral reflectance at the half
vector). Methods: ``fitted`` (the default: the light-mixture table moved into the light the lobe
gathers), ``kneiphof``, ``belcour_barla`` on the map prefiltered to half its size at α ∈ {0.25,
0.5}, and, as the state before issue 37, the fitted table fitted to uniform light as it was
(``fitted, uniform-light table``: thin_film_xyz_fitted × albedo × prefiltered radiance). ΔE2000
per sphere pixel after one exposure per map (0.8 / the reference's 98th-percentile Y), mean / p95
/ max over the sphere.

    PYTHONPATH=src .venv/bin/python benchmarks/ibl_environment.py [--size 48] [--map-height 32] [--write-docs]

Writes benchmarks/results/ibl_environment.{json,md}; with --write-docs also the section between
the ``ibl-environment`` markers of docs/performance.md. ≈ 30 s on 2 cores at the defaults.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import time
from pathlib import Path

import torch

from torchirid.color import delta_e_2000, linear_srgb_to_xyz, xyz_to_lab, xyz_to_linear_srgb
from torchirid.ibl import (prefilter_environment, shade_thin_film_environment, shipped_dfg_lut,
                           synthetic_environment, thin_film_xyz_fitted)
from torchirid.ibl.shading import SPLIT_SUM_METHODS, _lookup

ROOT = Path(__file__).resolve().parents[1]
F64 = torch.float64
ALPHA, N_FILM, N_BASE = 0.25, 1.33, 1.0
LEVELS = (0.25, 0.5)
MAPS = {
    "sky": ("synthetic sky (gallery: gradient, ground, sun r 0.12 rad × 40)", dict(sun_radius=0.12, sun_radiance=40.0)),
    "sun_sky": ("sun and sky (CIE clear sky, sun r 0.03 rad × 2000)",
                dict(scene="sun_sky", sun_radius=0.03, sun_radiance=2000.0)),
    "indoor": ("indoor (room, 4 bright area sources)", dict(scene="indoor")),
    "uniform": ("uniform (constant white)", None),
}
LABELS = {"fitted": "fitted (default)", "kneiphof": "Kneiphof", "belcour_barla": "Belcour–Barla",
          "fitted_uniform": "fitted, uniform-light table (before)"}
MARK = "ibl-environment"


def gallery_frame():
    """The gallery's view (unit, constant: orthographic), and the image plane's right and up."""
    view = torch.tensor([0.8, 0.48, 0.36], dtype=F64)
    view = view / view.norm()
    right = torch.linalg.cross(torch.tensor([0.0, 0.0, 1.0], dtype=F64), view)
    right = right / right.norm()
    return view, right, torch.linalg.cross(view, right)


def write_docs_section(mark: str, text: str) -> None:
    """Replace the section between ``<!-- mark:start -->`` and ``<!-- mark:end -->`` of docs/performance.md."""
    perf = ROOT / "docs/performance.md"
    doc = perf.read_text()
    start, end = f"<!-- {mark}:start -->", f"<!-- {mark}:end -->"
    if start not in doc:
        raise SystemExit(f"docs/performance.md has no {start} marker")
    perf.write_text(re.sub(re.escape(start) + ".*?" + re.escape(end), lambda m: f"{start}\n{text}\n{end}", doc,
                           flags=re.S))
    print(f"updated {perf}")


def gallery_sphere(size: int):
    """Normals, view and thickness of the gallery's sphere pixels (size × size image, rim left out)."""
    view, right, up = gallery_frame()
    s = (torch.arange(size, dtype=F64) + 0.5) / size * 2.0 - 1.0
    x, y = s[None, :].expand(size, size), -s[:, None].expand(size, size)
    inside = x * x + y * y < 0.97
    z = torch.sqrt((1.0 - x * x - y * y).clamp_min(0.0))
    normal = (x[..., None] * right + y[..., None] * up + z[..., None] * view)[inside]
    return normal, view, 100.0 + 700.0 * (1.0 - y[inside]) / 2.0


def environment(name: str, height: int) -> torch.Tensor:
    kwargs = MAPS[name][1]
    if kwargs is None:
        return torch.ones(height, 2 * height, 3, dtype=F64)
    return synthetic_environment(height, 2 * height, **kwargs)


def fitted_uniform(pre, normal, view, thickness):
    """The fitted method before issue 37: the uniform-light table × albedo × prefiltered radiance."""
    cos_o = (normal * view).sum(-1)
    r = 2.0 * cos_o[:, None] * normal - view
    a = torch.full_like(cos_o, ALPHA)
    radiance = _lookup(pre, r, a)[:, :3]
    ab = shipped_dfg_lut()(cos_theta_o=cos_o, alpha=a)
    xyz = thin_film_xyz_fitted(cos_o, a, N_FILM, thickness, N_BASE)
    return xyz_to_linear_srgb(xyz) * radiance * (ab[:, 0] + ab[:, 1])[:, None]


def measure(size: int, map_height: int) -> dict:
    normal, view, thickness = gallery_sphere(size)
    out = {}
    for name in MAPS:
        env = environment(name, map_height)
        t0 = time.perf_counter()
        ref = shade_thin_film_environment(env, normal, view, ALPHA, N_FILM, thickness, N_BASE, method="reference")
        t_ref = time.perf_counter() - t0
        exposure = 0.8 / float(linear_srgb_to_xyz(ref)[:, 1].quantile(0.98))
        lab_ref = xyz_to_lab(exposure * linear_srgb_to_xyz(ref))
        pre = prefilter_environment(env, list(LEVELS), resolution=(map_height // 2, map_height))
        rows = {}
        for m in (*SPLIT_SUM_METHODS, "fitted_uniform"):
            if m == "fitted_uniform":
                rgb = fitted_uniform(pre, normal, view, thickness)
            else:
                rgb = shade_thin_film_environment(pre, normal, view, ALPHA, N_FILM, thickness, N_BASE, method=m)
            de = delta_e_2000(xyz_to_lab(exposure * linear_srgb_to_xyz(rgb)), lab_ref)
            rows[m] = {"mean": float(de.mean()), "p95": float(de.quantile(0.95)), "max": float(de.max())}
        best = min(SPLIT_SUM_METHODS, key=lambda m: rows[m]["mean"])
        out[name] = {"label": MAPS[name][0], "methods": rows, "best_mean": best,
                     "reference_seconds": t_ref, "pixels": int(normal.shape[0]), "texels": int(env.shape[0] * env.shape[1])}
        print(f"{name}: best {best}; " + ", ".join(f"{m} {r['mean']:.2f}" for m, r in rows.items()), flush=True)
    return out


def markdown(results: dict, cmd: str, size: int, map_height: int) -> str:
    some = next(iter(results.values()))
    lines = [f"`{cmd}` — the gallery's soap-film sphere (η₂ = 1.33 on air, d 100 → 800 nm, GGX α = 0.25; "
             f"{some['pixels']} pixels of a {size} × {size} image) under {map_height} × {2 * map_height} maps; "
             f"split-sum methods on the map prefiltered to {map_height // 2} × {map_height} at α ∈ {{0.25, 0.5}} "
             "(`sensitivity=\"lut\"`, M = 4). Reference: `shade_thin_film_environment(env, ..., "
             "method=\"reference\")`, the texel sum of the exact BRDF (≈ "
             f"{max(r['reference_seconds'] for r in results.values()):.1f} s per map on 2 cores). ΔE2000 per pixel after "
             "one exposure per map (0.8 / the reference's 98th-percentile Y); **bold**: the lowest mean.", "",
             "| map | method | ΔE2000 mean | p95 | max |", "|---|---|---|---|---|"]
    for name, r in results.items():
        for m, s in r["methods"].items():
            mean = f"**{s['mean']:.2f}**" if m == r["best_mean"] else f"{s['mean']:.2f}"
            lines.append(f"| {r['label']} | {LABELS[m]} | {mean} | {s['p95']:.2f} | {s['max']:.2f} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--size", type=int, default=48, help="sphere image size in pixels (default 48, the gallery's)")
    p.add_argument("--map-height", type=int, default=32, help="map height H (width 2H; default 32, the gallery's)")
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--write-docs", action="store_true", help="also rewrite the section of docs/performance.md")
    args = p.parse_args(argv)
    torch.set_num_threads(args.threads)
    results = measure(args.size, args.map_height)
    cmd = "PYTHONPATH=src .venv/bin/python benchmarks/ibl_environment.py " + " ".join(
        a for a in (argv if argv is not None else sys.argv[1:]) if a != "--write-docs")
    text = markdown(results, cmd.strip(), args.size, args.map_height)
    print(text)
    folder = ROOT / "benchmarks/results"
    (folder / "ibl_environment.json").write_text(json.dumps(
        {"command": cmd.strip(), "size": args.size, "map_height": args.map_height, "alpha": ALPHA,
         "n_film": N_FILM, "levels": list(LEVELS), "maps": results}, indent=1) + "\n")
    (folder / "ibl_environment.md").write_text("# Thin-film IBL under environment maps\n\n" + text + "\n")
    if args.write_docs:
        write_docs_section(MARK, text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
