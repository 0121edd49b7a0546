"""Shader textures: texture size against ΔE2000, fitted node values against sampled ones (issue 25.1).

Families (torchirid.realtime.fit_texture): a soap film (n = 1.33 in air) over cos θ ∈ [0, 1] ×
d ∈ [100, 800] nm, and a jewel-beetle Bragg mirror (n1 = 1.59, n2 = 1.67, N = 8, lit from air)
over cos θ ∈ [0, 1] × λ_B ∈ [300, 1100] nm × δ ∈ [0.3, 0.7]; texels uniform in sqrt(cos θ)
(torchirid.realtime.AXIS_WARPS), samples uniform in cos θ. For each texture size: the
sampled texture (exact colour at the nodes) and the fitted one (L-BFGS on the mean ΔE00² of
the interpolated texture over max(20 000, 8 × texels) uniform samples), both scored on 20 000
independent samples: mean / p95 / max ΔE2000, and the fitted texture's mean after rounding its
values to float16 (an RGBA16F texture).

Output: a markdown table (stdout; ``--write`` → benchmarks/results/texture_pareto.md) and with
``--plot FILE`` the Pareto plot (texels against ΔE2000, log-log). Run:
``.venv/bin/python benchmarks/texture_pareto.py --write --plot docs/figures/texture_pareto.png``
(~10 min on 2 cores).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import torch

from torchirid.color import delta_e_2000, linear_srgb_to_xyz, xyz_to_lab
from torchirid.realtime import fit_texture, lookup
from torchirid.realtime.textures import texture_samples

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results" / "texture_pareto.md"
#: every family's rows (a run of some families replaces theirs and keeps the others')
STORE = ROOT / "benchmarks" / "results" / "texture_pareto.json"

FAMILIES = {
    "thin_film": dict(parameters={"n_film": 1.33, "n_substrate": 1.0}, ranges=((0.0, 1.0), (100.0, 800.0)),
                      sizes=[(4, 16), (8, 32), (16, 64), (32, 128), (64, 256)],
                      label="soap film, (cos θ, d)"),
    "bragg": dict(parameters={"cells": 8, "n1": 1.59, "n2": 1.67, "n_incident": 1.0}, ranges=((0.0, 1.0), (300.0, 1100.0), (0.3, 0.7)),
                  sizes=[(4, 16, 2), (4, 32, 4), (8, 64, 4), (8, 128, 8), (16, 256, 8)],
                  label="Bragg N = 8 from air, (cos θ, λ_B, δ)"),
    "thin_film_path": dict(parameters={"n_substrate": 1.52, "n_incident": 1.0},
                           ranges=((0.0, 1.0), (0.0, 3000.0), (1.2, 2.4)),
                           sizes=[(4, 16, 2), (8, 32, 4), (8, 64, 4), (16, 96, 8), (16, 96, 16), (32, 192, 16)],
                           label="films n_f ∈ [1.2, 2.4] on glass, (cos θ, p, n_f)"),
    # the reference costs ~7 ms per sample (256 bins, 24 nodes): fewer samples, smaller textures
    "rough_thin_film": dict(parameters={"n_film": 1.3, "n_substrate": [2.0, 0.5], "n_incident": 1.0, "bins": 256,
                                        "nodes": 24},
                            ranges=((0.02, 1.0), (0.05, 0.5), (100.0, 800.0)),
                            sizes=[(4, 4, 16), (8, 8, 32), (8, 8, 64), (16, 8, 32), (16, 16, 32)], samples=24_000,
                            validation=10_000,
                            label="rough film 1.3 on 2 + 0.5i, uniform light, (cos θo, α, d)"),
}


HEADER = ["| family | texels | sizes | fitted mean | fitted p95 | fitted max | sampled mean | sampled p95 "
          "| sampled max | fitted mean, float16 | fit s |", "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|"]


def _line(family, row):
    f, s = row["fitted"], row["sampled"]
    return (f"| {family} | {row['texels']:,} | {'×'.join(map(str, row['sizes']))} | {f['mean']:.2f} | {f['p95']:.2f} "
            f"| {f['max']:.2f} | {s['mean']:.2f} | {s['p95']:.2f} | {s['max']:.2f} | {row['f16']:.2f} "
            f"| {row['seconds']:.0f} |")


def _f16_mean(fit, family, samples):
    lut = fit.lut
    rounded = type(lut)(lut.values.half().double(), lut.axes, builder="f16")
    lab = xyz_to_lab(linear_srgb_to_xyz(lookup(rounded, family, samples.valid_x)))
    return float(delta_e_2000(lab, xyz_to_lab(linear_srgb_to_xyz(samples.valid_rgb))).mean())


def plot(results, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    cols = min(len(results), 2)
    nrows = -(-len(results) // cols)
    fig, axes = plt.subplots(nrows, cols, figsize=(max(6.5, 5.2 * cols), 4.0 * nrows), squeeze=False)
    for ax, (family, rows) in zip(axes.flat, results.items()):
        texels = [r["texels"] for r in rows]
        for kind, style in (("fitted", "-"), ("sampled", "--")):
            for stat, colour in (("mean", "tab:blue"), ("p95", "tab:orange"), ("max", "tab:red")):
                ax.plot(texels, [r[kind][stat] for r in rows], style, color=colour, marker="o", ms=3,
                        label=f"{kind} {stat}")
        ax.axhline(1.0, color="grey", lw=0.6)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_xlabel("texels (RGB each)")
        ax.set_ylabel("ΔE2000 on independent samples")
        ax.set_title(FAMILIES[family]["label"])
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].legend(fontsize=7, ncol=2)
    fig.suptitle("Shader textures: fitted node values (solid) vs sampled (dashed)", fontsize=10)
    fig.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=130)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--families", default=",".join(FAMILIES))
    ap.add_argument("--iterations", type=int, default=80)
    ap.add_argument("--write", action="store_true")
    ap.add_argument("--plot", default=None, metavar="FILE")
    args = ap.parse_args(argv)
    results = {}
    print("\n".join(HEADER), flush=True)
    for family in args.families.split(","):
        spec = FAMILIES[family]
        most = max(math.prod(s) for s in spec["sizes"])
        samples = texture_samples(family, spec["ranges"], spec["parameters"],
                                  samples=spec.get("samples", max(20_000, 8 * most)),
                                  validation=spec.get("validation", 20_000))
        rows = []
        for sizes in spec["sizes"]:
            n = spec.get("samples", max(20_000, 8 * math.prod(sizes)))
            sub = type(samples)(samples.train_x[:n], samples.train_rgb[:n], samples.valid_x, samples.valid_rgb,
                                samples.ranges)
            fit = fit_texture(family, sizes, spec["ranges"], spec["parameters"], samples=sub,
                              iterations=args.iterations)
            row = {"texels": fit.texels, "sizes": sizes, **fit.errors, "f16": _f16_mean(fit, family, samples),
                   "seconds": fit.seconds}
            rows.append(row)
            print(_line(family, row), flush=True)
        results[family] = rows
    if args.write:
        import json

        stored = json.loads(STORE.read_text()) if STORE.exists() else {}
        stored.update(results)
        results = {f: stored[f] for f in FAMILIES if f in stored}
        STORE.write_text(json.dumps(results, indent=1) + "\n")
        RESULTS.write_text("# Shader textures: size against ΔE2000\n\nCommand: `.venv/bin/python "
                           "benchmarks/texture_pareto.py --write --plot docs/figures/texture_pareto.png "
                           "[--families NAME,...]` (2 cores: thin films ~1 min each, Bragg ~25 min and the rough "
                           "film ~10 min: their references cost ~1 and ~7 ms per sample). Rows are kept per family "
                           "in texture_pareto.json, so a run of some families keeps the others'. Texels uniform in "
                           "sqrt(cos θ); ΔE2000 on independent samples uniform in the family's coordinates (20 000; "
                           "10 000 for the rough film); the float16 column rounds the fitted texels to half floats "
                           "(an RGB16F texture).\n\n" + "\n".join(HEADER) + "\n"
                           + "\n".join(_line(f, r) for f, rows in results.items() for r in rows) + "\n")
    if args.plot:
        plot(results, args.plot)


if __name__ == "__main__":
    torch.set_num_threads(2)
    main()
