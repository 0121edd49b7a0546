#!/usr/bin/env python
"""Hirayama 2000 §5 tables: interpolation error and speed of tabulated k_r, k_t vs the exact recursion.

For each of Hirayama's Table 1 coatings (teapot, cylinder, sphere; and the teapot's coating
on glass, whose k_t is not identically 0) and each table size
(angles × wavelengths, uniform in cos θ over [0, 1] and in λ over 380–780 nm) this prints

* max / mean |Δk_r| and |Δk_t| at 20 000 random (cos θ, λ) points (cos θ ∈ [0, 1], and
  cos θ ∈ [0.2, 1] away from the grazing resonances), against the exact recursion
  (``film_reflectance``, float64);
* ΔE2000 (median / 95th percentile / max) of the colour of k_r under D65 (CIE 1931 2°,
  1 nm sampling 380–780 nm) at 500 random cos θ, table vs exact;
* the time to build the table, and ns per (cos θ, λ) point to look up vs to evaluate
  exactly (medians of --repeats runs, 1 thread, CPU, float64).

    PYTHONPATH=src python benchmarks/hirayama_table.py [--stacks teapot,cylinder,sphere,teapot_on_glass] [--axis cos_theta|theta]

It ends with a markdown table proposed for docs/performance.md.
"""

from __future__ import annotations

import argparse
import platform
import time

import torch

from torchirid.color.convert import spectrum_to_xyz, xyz_to_lab
from torchirid.color.difference import delta_e_2000
from torchirid.optics.film_stack import FilmStack, film_reflectance
from torchirid.presets import hirayama_stacks
from torchirid.optics.film_tables import interpolation_error, film_reflectance_lut, lookup_film_reflectance

ANGLES = (16, 64, 128, 512)
WAVELENGTHS = (8, 41, 101, 401)
RANGE = (380.0, 780.0)


def colour_errors(stack, sizes, axis, n_colours=500, seed=1):
    """ΔE2000 quantiles of the k_r colour, table vs exact, per size."""
    f64 = torch.float64
    g = torch.Generator().manual_seed(seed)
    c = torch.rand(n_colours, generator=g, dtype=f64)
    wl = torch.arange(RANGE[0], RANGE[1] + 0.5, 1.0, dtype=f64)
    kr, _ = film_reflectance(wl, c[:, None], stack)
    lab_ref = xyz_to_lab(spectrum_to_xyz(kr, wl))
    out = []
    for A, W in sizes:
        lut = film_reflectance_lut(stack, angles=A, wavelengths=W, wavelength_range=RANGE, angle_axis=axis)
        kr_t, _ = lookup_film_reflectance(lut, wl, c[:, None])
        de = delta_e_2000(xyz_to_lab(spectrum_to_xyz(kr_t, wl)), lab_ref)
        q = torch.quantile(de, torch.tensor([0.5, 0.95], dtype=f64))
        out.append((float(q[0]), float(q[1]), float(de.max())))
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--stacks", default="teapot,cylinder,sphere,teapot_on_glass")
    p.add_argument("--axis", default="cos_theta", choices=("cos_theta", "theta"))
    p.add_argument("--points", type=int, default=20000)
    p.add_argument("--repeats", type=int, default=5)
    args = p.parse_args(argv)
    torch.set_num_threads(1)
    sizes = [(a, w) for a in ANGLES for w in WAVELENGTHS]
    presets = hirayama_stacks()
    # Table 1's substrates absorb (k_t = 0, eq. 6): the same coating on glass shows k_t's error
    presets["teapot_on_glass"] = FilmStack(presets["teapot"].layers, "SiO2", name="teapot_on_glass")
    t_start = time.perf_counter()
    md = []
    for name in args.stacks.split(","):
        stack = presets[name]
        print(f"\n## {name}: {stack.describe()}  (axis {args.axis})")
        full = interpolation_error(stack, sizes, points=args.points, wavelength_range=RANGE,
                                   angle_axis=args.axis, repeats=args.repeats)
        away = interpolation_error(stack, sizes, points=args.points, wavelength_range=RANGE,
                                   angle_axis=args.axis, repeats=1, cos_range=(0.2, 1.0))
        de = colour_errors(stack, sizes, args.axis)
        print("| angles × λ | max/mean Δk_r (cos∈[0,1]) | max/mean Δk_t | max/mean Δk_r (cos≥0.2) "
              "| ΔE00 median / p95 / max | build ms | lookup ns/pt | exact ns/pt |")
        print("|---|---|---|---|---|---|---|---|")
        for r, ra, (d50, d95, dmax) in zip(full, away, de):
            line = (f"| {r['angles']} × {r['wavelengths']} | {r['max_dkr']:.2g} / {r['mean_dkr']:.2g} "
                    f"| {r['max_dkt']:.2g} / {r['mean_dkt']:.2g} | {ra['max_dkr']:.2g} / {ra['mean_dkr']:.2g} "
                    f"| {d50:.2g} / {d95:.2g} / {dmax:.2g} | {1e3 * r['build_s']:.1f} "
                    f"| {r['lookup_ns']:.0f} | {r['exact_ns']:.0f} |")
            print(line, flush=True)
            md.append((name, line))
    print(f"\n# proposed docs/performance.md section (run {time.perf_counter() - t_start:.0f} s, "
          f"torch {torch.__version__}, {platform.processor() or platform.machine()}, 1 thread)\n")
    print("### Hirayama 2000 §5: tabulated k_r, k_t (bilinear) vs exact recursion\n")
    print("`PYTHONPATH=src python benchmarks/hirayama_table.py` — uniform cos θ ∈ [0, 1] × λ ∈ "
          "380–780 nm tables of Hirayama's Table 1 coatings; errors at 20 000 random points; ΔE2000 "
          "of the k_r colour (D65, CIE 1931 2°, 1 nm) at 500 random angles; 1 thread, float64.\n")
    print("| coating | angles × λ | max/mean Δk_r (cos∈[0,1]) | max/mean Δk_t | max/mean Δk_r (cos≥0.2) "
          "| ΔE00 median / p95 / max | build ms | lookup ns/pt | exact ns/pt |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, line in md:
        print(f"| {name} " + line)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
