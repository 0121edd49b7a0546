"""Build the shipped shader textures of torchirid.realtime (issue 25): node values fitted by autograd.

    PYTHONPATH=src python luts/build_shader_textures.py [--out DIR] [--iterations 80] [--only NAME,...]
    PYTHONPATH=src python luts/build_shader_textures.py --scan-only     # restate the dense scans, values unchanged

Writes into src/torchirid/data/textures/ (float32 LUT files, ~10–400 KiB each):

* ``thin_film_soap.npz``: a soap film (n = 1.33 in air), 16 × 64 texels over
  (sqrt cos θ ∈ [0, 1], d ∈ [100, 800] nm);
* ``thin_film_on_glass.npz``: an n = 1.45 film on glass (n = 1.52), the same grid;
* ``bragg_n{6,8,10}.npz``: jewel-beetle mirrors (n1 = 1.59, n2 = 1.67, lit from air as Fourneau
  et al.'s presets) of N = 6, 8, 10 cells, 8 × 64 × 4 texels over (sqrt cos θ ∈ [0, 1] in air,
  λ_B ∈ [300, 1100] nm, δ ∈ [0.3, 0.7]).

* ``thin_film_path_{air,glass,absorbing}.npz``: films of index n_f ∈ [1.2, 2.4] on air (a soap
  bubble), on glass (n = 1.52) and on Kneiphof et al.'s absorbing base (2 + 0.5i), lit from air,
  16 × 128 × 16 texels over (sqrt cos θ ∈ [0, 1], path difference 2 n_f d cos θ_f ∈ [0, 3000] nm,
  n_f), fitted to 200 000 samples — what the explorer page's d, n and base sliders read (96
  texels along the path difference and 60 000 samples, before issue 37, left films on air at
  d 80–140 nm, n 2.2–2.4 and d 280–380 nm, n ≈ 1.25–1.3 above the page's ΔE2000 bar near grazing);
* ``rough_thin_film.npz``: a rough film (n = 1.3 on 2 + 0.5i, Kneiphof et al.'s example) under
  uniform light, 16 × 8 × 32 texels over (sqrt cos θ_o ∈ [√0.02, 1], α ∈ [0.05, 0.5],
  d ∈ [100, 800] nm); the reference is :func:`torchirid.ibl.thin_film_xyz_uniform` with 256 bins
  and 24 nodes (within ΔE2000 0.07 of its converged defaults, 10× faster).

Each file's parameters hold the family, its ranges and its measured ΔE2000
(``errors_de2000``): ``fitted`` and ``sampled`` on independent uniform samples (20 000 for films,
10 000 otherwise), and ``dense``, the stated error over the whole domain: the dense scan of
``torchirid.realtime.textures.scan_texture`` (a regular grid with 2 points per texel step along
every axis — nodes and midpoints — except the rough film's α and d axes, at their nodes: its
reference costs ~7 ms a point), with the point of the max. tests/realtime/test_textures.py
repeats each scan and holds the stated figures. Export one for a shader with
``torchirid.export.export_lut(LUT.read(path), "bragg_n8", format="exr")``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import torch

from torchirid.lut import LUT
from torchirid.realtime import fit_texture
from torchirid.realtime.textures import scan_texture

ROOT = Path(__file__).resolve().parents[1]

FILM_RANGES = ((0.0, 1.0), (100.0, 800.0))
BRAGG_RANGES = ((0.0, 1.0), (300.0, 1100.0), (0.3, 0.7))
PATH_RANGES = ((0.0, 1.0), (0.0, 3000.0), (1.2, 2.4))
ROUGH_RANGES = ((0.02, 1.0), (0.05, 0.5), (100.0, 800.0))
TEXTURES = {
    "thin_film_soap": ("thin_film", (16, 64), FILM_RANGES, {"n_film": 1.33, "n_substrate": 1.0}),
    "thin_film_on_glass": ("thin_film", (16, 64), FILM_RANGES, {"n_film": 1.45, "n_substrate": 1.52}),
    **{f"thin_film_path_{name}": ("thin_film_path", (16, 128, 16), PATH_RANGES, {"n_substrate": base, "n_incident": 1.0})
       for name, base in (("air", 1.0), ("glass", 1.52), ("absorbing", [2.0, 0.5]))},
    "rough_thin_film": ("rough_thin_film", (16, 8, 32), ROUGH_RANGES,
                        {"n_film": 1.3, "n_substrate": [2.0, 0.5], "n_incident": 1.0, "bins": 256, "nodes": 24}),
    **{f"bragg_n{n}": ("bragg", (8, 64, 4), BRAGG_RANGES, {"cells": n, "n1": 1.59, "n2": 1.67, "n_incident": 1.0})
       for n in (6, 8, 10)},
}


#: points per texel step of each texture's dense scan (per axis where a tuple)
SCAN = {name: (2, 1, 1) if family == "rough_thin_film" else 2 for name, (family, *_) in TEXTURES.items()}


def _with_scan(lut: LUT, name: str, builder: str) -> LUT:
    """``lut`` with its dense scan stated in ``errors_de2000["dense"]`` (values unchanged)."""
    dense = scan_texture(lut, SCAN[name])
    errors = {**lut.parameters["errors_de2000"], "dense": dense}
    return LUT(lut.values, lut.axes, builder=builder, parameters={**lut.parameters, "errors_de2000": errors},
               units=lut.units)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=ROOT / "src/torchirid/data/textures")
    ap.add_argument("--iterations", type=int, default=80)
    ap.add_argument("--only", default=None, help="comma-separated names (default: all)")
    ap.add_argument("--samples", type=int, default=None,
                    help="training samples (default 40 000 for smooth films and Bragg mirrors, 200 000 over the path difference, "
                         "20 000 for the rough film)")
    ap.add_argument("--validation", type=int, default=None,
                    help="validation samples (default 20 000 for smooth films, 10 000 otherwise)")
    ap.add_argument("--scan-only", action="store_true",
                    help="re-read the textures in --out and restate their dense scans (node values unchanged)")
    args = ap.parse_args(argv)
    names = args.only.split(",") if args.only else list(TEXTURES)
    unknown = [n for n in names if n not in TEXTURES]
    if unknown:
        ap.error(f"--only: unknown texture(s) {unknown}; choose from {', '.join(TEXTURES)}")
    args.out.mkdir(parents=True, exist_ok=True)
    for name in names:
        family, sizes, ranges, parameters = TEXTURES[name]
        builder = f"luts/build_shader_textures.py {name}"
        if args.scan_only:
            t = time.perf_counter()
            path = _with_scan(LUT.read(args.out / f"{name}.npz", builder=builder), name, builder).write(
                args.out / f"{name}.npz")
            d = LUT.read(path).parameters["errors_de2000"]["dense"]
            print(f"{path.name}: dense scan of {d['points']} points, ΔE2000 mean {d['mean']:.2f} / p95 {d['p95']:.2f} / "
                  f"max {d['max']:.2f} at {d['at']}, {time.perf_counter() - t:.0f} s")
            continue
        t = time.perf_counter()
        many = family.startswith("thin_film")  # (a Bragg mirror's spectral colour costs ~1 ms per sample, a rough film's ~7)
        # (Bragg mirrors: 40 000 since issue 37; 20 000 left N = 10 at max 2.48 on the explorer's sliders, 40 000: 2.27)
        samples = args.samples or (200_000 if family == "thin_film_path" else 20_000 if family == "rough_thin_film"
                                   else 40_000)
        validation = args.validation or (20_000 if many else 10_000)
        fit = fit_texture(family, sizes, ranges, parameters, samples=samples, validation=validation,
                          iterations=args.iterations)
        lut = LUT(fit.lut.values.to(torch.float32), fit.lut.axes, builder=builder,
                  parameters={**fit.lut.parameters, "errors_de2000": fit.errors, "iterations": args.iterations,
                              "samples": samples, "validation": validation},
                  units=fit.lut.units)
        lut = _with_scan(lut, name, builder)
        path = lut.write(args.out / f"{name}.npz")
        e, d = fit.errors, lut.parameters["errors_de2000"]["dense"]
        print(f"{path.name}: {fit.texels} texels, ΔE2000 fitted mean {e['fitted']['mean']:.2f} / p95 "
              f"{e['fitted']['p95']:.2f} / max {e['fitted']['max']:.2f} (sampled {e['sampled']['mean']:.2f} / "
              f"{e['sampled']['p95']:.2f} / {e['sampled']['max']:.2f}); dense scan ({d['points']} points) mean "
              f"{d['mean']:.2f} / p95 {d['p95']:.2f} / max {d['max']:.2f} at {d['at']}; {path.stat().st_size / 1024:.0f} KiB, "
              f"{time.perf_counter() - t:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
