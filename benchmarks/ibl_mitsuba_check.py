#!/usr/bin/env python
"""The texel-sum reference of environment-lit thin-film shading against converged Mitsuba 3 renders.

Issue 37, part 3: the gallery's rough soap-film sphere (docs/examples/plot_thin_film_environment.py,
benchmarks/ibl_environment.py: η₂ = 1.33 on air, d = 100 nm at the top → 800 nm at the bottom,
GGX α = 0.25, the same orthographic view) under the three generated maps (``sky``, ``sun_sky``,
``indoor``), rendered twice:

- **the library's reference**, ``shade_thin_film_environment(env, ..., method="reference")``: eq. 11
  summed over every texel with the exact BRDF (GGX, separable Smith G, the film's reflectance at
  the half vector on 360–830 nm, the RGB product with the map), averaged over ``--supersample``²
  stratified points of each pixel (the box filter of the render: a pixel is its footprint's mean,
  not its centre);
- **Mitsuba 3** (``llvm_ad_rgb``, ``direct`` integrator: a convex sphere has no interreflection)
  with the ``torchirid_thin_film`` plugin (the same model; its RGB weight is the linear sRGB of R(λ)
  under D65 on 81 nodes, 380–780 nm), an orthographic sensor whose film is the gallery's image
  plane ([−1, 1]² across the unit sphere, so the view direction is the gallery's constant one),
  a box pixel filter, the thickness a texture of the hit point (d = 100 + 350 (1 − ⟨p, up⟩)), and
  the map through ``torchirid.mitsuba.scenes.environment_emitter`` (columns reversed, the
  documented to_world) upsampled by repetition (each texel ``--upsample``² times: Mitsuba's
  envmap interpolates bilinearly, the reference holds each texel constant). Two independent
  renders of ``--spp`` samples each (seeds 1 and 2); the comparison takes their mean.

ΔE2000 per interior pixel (the whole footprint inside the gallery's rim cut x² + y² < 0.97)
after one exposure per map (0.8 / the reference's 98th-percentile Y, as benchmarks/ibl_environment.py),
mean / p95 / max: Mitsuba (mean of both renders) against the reference, and render A against
render B (the Monte Carlo noise: the noise of their mean against the truth is about half of it).
Also the ratio of the summed radiance, Mitsuba / reference, per channel over the interior pixels
(a normalisation or colour-rule error shows there, where the per-pixel noise averages out), the
reference at pixel centres against its footprint mean (what comparing centres would have added),
and the film's colour table of the plugin (380–780 nm, 81 nodes, rows normalised to white (1, 1, 1))
against the reference's (360–830 nm at 5 nm) over d ∈ [100, 800] nm × cos θd ∈ [0, 1].

    PYTHONPATH=src .venv/bin/python benchmarks/ibl_mitsuba_check.py [--size 48] [--map-height 32] [--spp 8192] [--write-docs]

Writes benchmarks/results/ibl_mitsuba_check.{json,md}; with --write-docs also the section between
the ``ibl-mitsuba-check`` markers of docs/performance.md. Needs Mitsuba 3 with Dr.Jit's LLVM backend
(libLLVM >= 16). ≈ 6 min on 2 cores at the defaults.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import torch

from torchirid.color import (
    delta_e_2000,
    linear_srgb_to_xyz,
    xyz_to_lab,
    xyz_to_linear_srgb,
)
from torchirid.color.convert import xyz_weights_kernel
from torchirid.ibl import shade_thin_film_environment, synthetic_environment
from torchirid.ibl.shading import REFERENCE_WAVELENGTH
from torchirid.mitsuba.scenes import environment_emitter, find_libllvm, render
from torchirid.optics import thin_film_reflectance

sys.path.insert(0, str(Path(__file__).resolve().parent))
from ibl_environment import ALPHA, N_BASE, N_FILM, gallery_frame, write_docs_section  # noqa: E402
from ibl_environment import MAPS as ENVIRONMENT_MAPS  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
F64 = torch.float64
D_TOP, D_BOTTOM = 100.0, 800.0
#: the gallery's maps (benchmarks/ibl_environment.py's, less the constant one)
MAPS = {name: entry for name, entry in ENVIRONMENT_MAPS.items() if entry[1] is not None}
#: the gallery's rim cut (pixel centres with x² + y² below it are shaded)
RIM = 0.97
MARK = "ibl-mitsuba-check"


def thickness_of(y):
    """The film thickness (nm) at image-plane height y ∈ [−1, 1] (= ⟨p, up⟩ on the unit sphere)."""
    return D_TOP + (D_BOTTOM - D_TOP) * (1.0 - y) / 2.0


def interior_pixels(size: int) -> torch.Tensor:
    """``(size, size)`` bool: pixels whose whole footprint lies inside the rim cut (rows top → bottom)."""
    edge = torch.arange(size + 1, dtype=F64) / size * 2.0 - 1.0  # pixel edges
    far = torch.maximum(edge[:-1].abs(), edge[1:].abs())  # the farthest edge of each pixel from 0
    return far[None, :] ** 2 + far[:, None] ** 2 < RIM


def reference_image(env, size: int, supersample: int, mask: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """The reference on the masked pixels: ``(footprint mean (P, 3), pixel centre (P, 3))``, linear sRGB."""
    view, right, up = gallery_frame()
    s = supersample

    def shade(offsets):  # offsets (k,) in [0, 1) of a pixel's side → (P, 3), the mean over k × k points
        edge = torch.arange(size, dtype=F64) / size * 2.0 - 1.0
        pos = edge[:, None] + offsets[None, :] * (2.0 / size)  # (size, k)
        k = offsets.shape[0]
        x = pos[None, :, None, :].expand(size, size, k, k)[mask]  # (P, k, k): columns
        y = -pos[:, None, :, None].expand(size, size, k, k)[mask]  # rows top → bottom
        z = torch.sqrt((1.0 - x * x - y * y).clamp_min(0.0))
        normal = x[..., None] * right + y[..., None] * up + z[..., None] * view
        rgb = shade_thin_film_environment(env, normal, view, ALPHA, N_FILM, thickness_of(y), N_BASE,
                                          method="reference")
        return rgb.mean((1, 2))

    footprint = shade((torch.arange(s, dtype=F64) + 0.5) / s)
    centre = shade(torch.tensor([0.5], dtype=F64))
    return footprint, centre


def mitsuba_scene(env: torch.Tensor, size: int, upsample: int):
    """The gallery's sphere in Mitsuba (llvm_ad_rgb must be active and the plugins registered)."""
    import mitsuba as mi

    view, _, up = gallery_frame()
    up_ = [float(c) for c in up]
    register_thickness_texture(up_)
    big = env.repeat_interleave(upsample, 0).repeat_interleave(upsample, 1)
    eye = [4.0 * float(c) for c in view]
    return mi.load_dict({
        "type": "scene",
        "integrator": {"type": "direct"},
        # the film [−1, 1]² across the unit sphere: the gallery's image plane (look_at: film x → right, y → up)
        "sensor": {"type": "orthographic",
                   "to_world": mi.ScalarTransform4f().look_at(origin=eye, target=[0, 0, 0], up=[0, 0, 1]),
                   "film": {"type": "hdrfilm", "width": size, "height": size, "rfilter": {"type": "box"},
                            "pixel_format": "rgb"},
                   "sampler": {"type": "independent", "sample_count": 1}},
        "sphere": {"type": "sphere", "bsdf": {"type": "torchirid_thin_film", "n_film": N_FILM, "n_substrate": N_BASE,
                                              "n_incident": 1.0, "alpha": ALPHA,
                                              "thickness": {"type": "gallery_thickness"}}},
        "environment": environment_emitter(big.numpy()),
    })


def register_thickness_texture(up):
    """``gallery_thickness``: a texture of the hit point, d = 100 + 350 (1 − ⟨p, up⟩) nm."""
    import mitsuba as mi

    class GalleryThickness(mi.Texture):
        def __init__(self, props):
            mi.Texture.__init__(self, props)

        def eval_1(self, si, active=True):
            y = si.p.x * up[0] + si.p.y * up[1] + si.p.z * up[2]
            return D_TOP + (D_BOTTOM - D_TOP) * (1.0 - y) / 2.0

        def eval(self, si, active=True):
            return mi.Color3f(self.eval_1(si, active))

        def mean(self):
            return 0.5 * (D_TOP + D_BOTTOM)

        def traverse(self, callback):
            pass

        def parameters_changed(self, keys):
            pass

        def to_string(self):
            return "GalleryThickness[]"

    mi.register_texture("gallery_thickness", lambda props: GalleryThickness(props))


def stats(de: torch.Tensor) -> dict:
    return {"mean": float(de.mean()), "p95": float(de.quantile(0.95)), "max": float(de.max())}


def film_table_difference() -> dict:
    """ΔE2000 between the plugin's RGB film colour (81 nodes 380–780 nm, rows normalised) and the
    reference's (360–830 nm at 5 nm, XYZ under D65 → linear sRGB) over d × cos θd."""
    from torchirid.mitsuba._spectra import RGB_NODES, rgb_weights

    d = torch.linspace(D_TOP, D_BOTTOM, 141, dtype=F64)[:, None, None]
    c = torch.linspace(0.0, 1.0, 101, dtype=F64)[None, :, None]
    first, last, step = REFERENCE_WAVELENGTH
    lam = torch.arange(first, last + 0.5 * step, step, dtype=F64)
    ref = xyz_to_linear_srgb(thin_film_reflectance(lam, c, N_FILM, d, N_BASE) @ xyz_weights_kernel(lam, "CIE 1931 2", "D65"))
    lam_p = torch.tensor(RGB_NODES, dtype=F64)
    plug = thin_film_reflectance(lam_p, c, N_FILM, d, N_BASE) @ torch.tensor(rgb_weights().T)
    de = delta_e_2000(xyz_to_lab(linear_srgb_to_xyz(plug)), xyz_to_lab(linear_srgb_to_xyz(ref)))
    return stats(de.reshape(-1))


def measure(size: int, map_height: int, spp: int, upsample: int, supersample: int) -> dict:
    import drjit as dr

    import torchirid.mitsuba as tm

    if not dr.has_backend(dr.JitBackend.LLVM):
        raise SystemExit("Dr.Jit's LLVM backend is unavailable (needs libLLVM >= 16: apt-get install libllvm19)")
    tm.register("llvm_ad_rgb")
    mask = interior_pixels(size)
    out = {}
    for name, (label, kwargs) in MAPS.items():
        env = synthetic_environment(map_height, 2 * map_height, **kwargs)
        t0 = time.perf_counter()
        ref, centre = reference_image(env, size, supersample, mask)
        t_ref = time.perf_counter() - t0
        scene = mitsuba_scene(env, size, upsample)
        t0 = time.perf_counter()
        renders = [torch.tensor(render(scene, spp=spp, seed=seed), dtype=F64)[mask] for seed in (1, 2)]
        t_mi = (time.perf_counter() - t0) / 2
        mits = 0.5 * (renders[0] + renders[1])
        exposure = 0.8 / float(linear_srgb_to_xyz(ref)[:, 1].quantile(0.98))

        def lab(rgb, exposure=exposure):
            return xyz_to_lab(exposure * linear_srgb_to_xyz(rgb))

        row = {
            "label": label,
            "pixels": int(mask.sum()),
            "mitsuba_vs_reference": stats(delta_e_2000(lab(mits), lab(ref))),
            "noise_a_vs_b": stats(delta_e_2000(lab(renders[0]), lab(renders[1]))),
            "sum_ratio_rgb": (mits.sum(0) / ref.sum(0)).tolist(),
            "sum_ratio_rgb_a_vs_b": (renders[0].sum(0) / renders[1].sum(0)).tolist(),
            "centre_vs_footprint": stats(delta_e_2000(lab(centre), lab(ref))),
            "reference_seconds": t_ref,
            "mitsuba_seconds_per_render": t_mi,
        }
        out[name] = row
        m, nz = row["mitsuba_vs_reference"], row["noise_a_vs_b"]
        print(f"{name}: Mitsuba vs reference {m['mean']:.3f} / {m['p95']:.3f} / {m['max']:.3f}; A vs B "
              f"{nz['mean']:.3f} / {nz['p95']:.3f} / {nz['max']:.3f}; sums {np.round(row['sum_ratio_rgb'], 4)}; "
              f"reference {t_ref:.0f} s, render {t_mi:.0f} s", flush=True)
    return out


def markdown(results: dict, film: dict, cmd: str, args) -> str:
    some = next(iter(results.values()))
    lines = [f"`{cmd}` — the gallery's soap-film sphere ({some['pixels']} interior pixels of a {args.size} × {args.size} "
             f"image) under {args.map_height} × {2 * args.map_height} maps: Mitsuba 3 (`llvm_ad_rgb`, `direct`, "
             f"the `torchirid_thin_film` plugin, orthographic sensor, box filter, the map upsampled "
             f"{args.upsample} × {args.upsample} by repetition; two renders of {args.spp} spp, their mean) against "
             f"the texel-sum reference averaged over {args.supersample} × {args.supersample} points per pixel. "
             "ΔE2000 per pixel after one exposure per map (0.8 / the reference's 98th-percentile Y); noise: render "
             "A against render B (the noise of their mean is about half); Σ ratio: the summed radiance, Mitsuba / "
             "reference, R / G / B.", "",
             "| map | Mitsuba vs reference: mean / p95 / max | noise, A vs B: mean / p95 / max | Σ ratio R / G / B "
             "| pixel centre vs footprint: mean / max |",
             "|---|---|---|---|---|"]
    for r in results.values():
        m, nz, c = r["mitsuba_vs_reference"], r["noise_a_vs_b"], r["centre_vs_footprint"]
        lines.append(f"| {r['label']} | {m['mean']:.2f} / {m['p95']:.2f} / {m['max']:.2f} | "
                     f"{nz['mean']:.2f} / {nz['p95']:.2f} / {nz['max']:.2f} | "
                     + " / ".join(f"{x:.4f}" for x in r["sum_ratio_rgb"])
                     + f" | {c['mean']:.2f} / {c['max']:.2f} |")
    lines += ["", f"The plugin's film colour (81 nodes, 380–780 nm) against the reference's (360–830 nm, 5 nm) over "
              f"d 100–800 nm × cos θd 0–1: ΔE2000 mean {film['mean']:.3f}, max {film['max']:.3f}."]
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--size", type=int, default=48, help="sphere image size in pixels (default 48, the gallery's)")
    p.add_argument("--map-height", type=int, default=32, help="map height H (width 2H; default 32, the gallery's)")
    p.add_argument("--spp", type=int, default=8192, help="samples per pixel of each of the two renders")
    p.add_argument("--upsample", type=int, default=8, help="each texel repeated k × k for Mitsuba (default 8)")
    p.add_argument("--supersample", type=int, default=4, help="reference points per pixel side (default 4)")
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--write-docs", action="store_true", help="also rewrite the section of docs/performance.md")
    args = p.parse_args(argv)
    torch.set_num_threads(args.threads)
    find_libllvm()  # before Dr.Jit starts its LLVM backend (Debian 12's libLLVM 15 crashes it)
    import drjit as dr

    dr.set_thread_count(args.threads)
    film = film_table_difference()
    results = measure(args.size, args.map_height, args.spp, args.upsample, args.supersample)
    cmd = "PYTHONPATH=src .venv/bin/python benchmarks/ibl_mitsuba_check.py " + " ".join(
        a for a in (argv if argv is not None else sys.argv[1:]) if a != "--write-docs")
    text = markdown(results, film, cmd.strip(), args)
    print(text)
    folder = ROOT / "benchmarks/results"
    (folder / "ibl_mitsuba_check.json").write_text(json.dumps(
        {"command": cmd.strip(), "size": args.size, "map_height": args.map_height, "spp": args.spp,
         "upsample": args.upsample, "supersample": args.supersample, "alpha": ALPHA, "n_film": N_FILM,
         "film_table_difference": film, "maps": results}, indent=1) + "\n")
    (folder / "ibl_mitsuba_check.md").write_text(
        "# The environment-lit texel-sum reference against Mitsuba 3\n\n" + text + "\n")
    if args.write_docs:
        write_docs_section(MARK, text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
