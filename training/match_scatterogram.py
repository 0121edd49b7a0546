#!/usr/bin/env python
r"""Recover the jewel-beetle Bragg layers from their scatterograms by autograd (Fourneau et al. 2024 §5).

For each preset of :func:`torchirid.presets.jewel_beetle` (Fourneau et al. 2024,
Table 3): render the target — narrow D65 beams at several incidences (default 0°, 30°,
60°, all at φ = 0; a beam images the lobe, so α is identified, and the hue's shift with
incidence separates Λ from the mean index) at ``--resolution`` pixels and 41 wavelengths —
multiply it by 1 + 1 % Gaussian noise per pixel and channel and by a random exposure in
[0.2, 5] (log-uniform), and fit it with :func:`torchirid.fitting.match_scatterogram` from
the generic start (Λ grid 100–350 nm, δ = 0.5, n2 − n1 = 0.06, α = 0.1, N ∈ 4…12; n1 known).
Printed: recovered vs true (Λ, δ, n2, N, α), the exposure, mean CIEDE2000 (fit vs the
noisy target over the disc and over its lit pixels, fit vs the clean target, and the noise
floor: noisy vs clean), L-BFGS iterations, renders and seconds; then the issue's bars
(|ΔΛ| ≤ 2 nm, |Δα| ≤ 0.01, mean ΔE00 ≤ 1, ≤ 120 s per target). A JSON document and a
markdown table go to stdout (and ``--notes`` if given).

Run from the repository root (about 20 s per preset on one core)::

    PYTHONPATH=src python training/match_scatterogram.py
    PYTHONPATH=src python training/match_scatterogram.py --presets red --resolution 48 --notes /tmp/m.md
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time

import torch

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if os.path.join(ROOT, "src") not in sys.path:  # run from a checkout without installing
    sys.path.insert(0, os.path.join(ROOT, "src"))

from torchirid._io import atomic_write, json_ready  # noqa: E402
from torchirid.color import delta_e_2000, xyz_to_lab  # noqa: E402
from torchirid.fitting import match_scatterogram, render_targets  # noqa: E402
from torchirid.presets import JEWEL_BEETLE, JEWEL_BEETLE_ALPHA, JEWEL_BEETLE_NAMES, jewel_beetle  # noqa: E402
from torchirid.layered import scatterogram_directions  # noqa: E402

F64 = torch.float64
BARS = {"period_nm": 2.0, "alpha": 0.01, "delta_e2000": 1.0, "seconds": 120.0}


def parse_incidences(text: str) -> list[tuple[float, float]]:
    out = []
    for item in filter(None, (s.strip() for s in text.split(","))):
        theta, _, phi = item.partition(":")
        out.append((float(theta), float(phi or 0.0)))
    if not out:
        raise argparse.ArgumentTypeError("no incidence given")
    return out


def mean_de(a, b, mask):
    """Mean CIEDE2000 between two (K, H, W, 3) stacks over the mask (K, H, W) (Y_peak = 1 scale)."""
    return float(delta_e_2000(xyz_to_lab(a[mask]), xyz_to_lab(b[mask])).mean())


def run_preset(name, args, generator):
    row = JEWEL_BEETLE[name]
    incs = args.incidences
    lam = torch.linspace(380.0, 780.0, args.wavelengths, dtype=F64)
    clean = render_targets(jewel_beetle(name), incs, resolution=args.resolution, wavelength=lam)
    exposure = math.exp(math.log(0.2) + (math.log(5.0) - math.log(0.2)) * float(torch.rand((), generator=generator,
                                                                                            dtype=F64)))
    noise = 1.0 + args.noise * torch.randn(clean.shape, generator=generator, dtype=F64)
    target = exposure * clean * noise
    t0 = time.perf_counter()
    fit = match_scatterogram(target, incident_deg=incs, n1=row["n1"], wavelength=lam, max_iter=args.max_iter,
                             short_iter=args.short_iter, starts=args.starts,
                             progress=(lambda done, total: print(f"  [{name}] stage {done}/{total}", file=sys.stderr))
                             if args.verbose else None)
    seconds = time.perf_counter() - t0
    # figures on the target's own scale (peak Y = 1)
    _, disc = scatterogram_directions(args.resolution)
    mask = disc.expand(clean.shape[:-1])
    peak = float(target[..., 1][mask].max())
    with torch.no_grad():
        model = render_targets(fit.structure(), incs, resolution=args.resolution, wavelength=lam) * fit.exposure
    de_clean = mean_de(model / peak, exposure * clean / peak, mask)
    floor = mean_de(target / peak, exposure * clean / peak, mask)
    lit = mask & (xyz_to_lab(target / peak)[..., 0] > 5.0)  # as ScatterogramFit.delta_e2000_lit
    floor_lit = mean_de(target / peak, exposure * clean / peak, lit)
    true = {"period": row["period"], "delta": row["delta"], "n1": row["n1"], "n2": row["n2"], "cells": row["cells"],
            "alpha": JEWEL_BEETLE_ALPHA, "exposure": exposure}
    got = fit.numbers()
    result = {
        "preset": name, "true": true,
        "fit": {k: got[k] for k in ("period", "delta", "n1", "n2", "cells", "alpha", "exposure")},
        "errors": {"period_nm": got["period"] - true["period"], "delta": got["delta"] - true["delta"],
                   "n2": got["n2"] - true["n2"], "cells": got["cells"] - true["cells"],
                   "alpha": got["alpha"] - true["alpha"], "exposure_rel": got["exposure"] / exposure - 1.0},
        "delta_e2000": {"vs_noisy_disc": got["delta_e2000"], "vs_noisy_lit": got["delta_e2000_lit"],
                        "vs_clean_disc": de_clean, "noise_floor_disc": floor,
                        "noise_floor_lit": floor_lit, "lit_pixels": int(lit.sum())},
        "loss_lab_mse": got["loss"], "iterations": got["iterations"], "renders": got["evaluations"],
        "seconds": seconds, "stages": fit.stages,
    }
    result["bars"] = {
        "period_within_2nm": abs(result["errors"]["period_nm"]) <= BARS["period_nm"],
        "alpha_within_0.01": abs(result["errors"]["alpha"]) <= BARS["alpha"],
        "mean_de2000_le_1": got["delta_e2000"] <= BARS["delta_e2000"],
        "under_120s": seconds <= BARS["seconds"],
    }
    return result


def markdown(results, args) -> str:
    lines = [
        f"Targets: beams at {', '.join(f'{t:g}°' for t, _ in args.incidences)} (φ = 0), {args.resolution}×"
        f"{args.resolution} px equidistant, {args.wavelengths} wavelengths 380–780 nm, {100 * args.noise:g} % "
        f"Gaussian noise per pixel and channel, random exposure; fit from the generic start (n1 known), "
        f"{torch.get_num_threads()} thread(s).",
        "",
        "| preset | Λ true → fit (nm) | δ | n2 | N | α | exposure err | ΔE00 disc / lit / vs clean / noise floor disc, lit "
        "| iters | renders | s | bars (Λ, α, ΔE, time) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in results:
        t, f, d, b = r["true"], r["fit"], r["delta_e2000"], r["bars"]
        marks = " ".join("✓" if b[k] else "✗" for k in ("period_within_2nm", "alpha_within_0.01", "mean_de2000_le_1",
                                                         "under_120s"))
        lines.append(
            f"| {r['preset']} | {t['period']:g} → {f['period']:.2f} | {t['delta']:g} → {f['delta']:.3f} "
            f"| {t['n2']:g} → {f['n2']:.4f} | {t['cells']} → {f['cells']} | {t['alpha']:g} → {f['alpha']:.4f} "
            f"| {100 * r['errors']['exposure_rel']:+.2f} % | {d['vs_noisy_disc']:.3f} / {d['vs_noisy_lit']:.3f} / "
            f"{d['vs_clean_disc']:.3f} / {d['noise_floor_disc']:.3f}, {d['noise_floor_lit']:.3f} | {r['iterations']} | {r['renders']} "
            f"| {r['seconds']:.1f} | {marks} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--presets", default=",".join(JEWEL_BEETLE_NAMES), help="comma-separated preset names")
    p.add_argument("--incidences", type=parse_incidences, default=parse_incidences("0,30,60"),
                   help="beam incidences theta[:phi] in degrees, comma-separated (default 0,30,60)")
    p.add_argument("--resolution", type=int, default=32)
    p.add_argument("--wavelengths", type=int, default=41)
    p.add_argument("--noise", type=float, default=0.01, help="relative Gaussian noise (default 0.01)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--starts", type=int, default=3)
    p.add_argument("--short-iter", type=int, default=15)
    p.add_argument("--max-iter", type=int, default=60)
    p.add_argument("--threads", type=int, default=1,
                   help="torch threads (default 1: small renders gain nothing from intra-op threads)")
    p.add_argument("--notes", default=None, help="also write the markdown table and the JSON here")
    p.add_argument("--verbose", action="store_true",
                   help="print the stages done to stderr (their losses are in the JSON's stages)")
    args = p.parse_args(argv)
    torch.set_num_threads(args.threads)
    names = [s.strip() for s in args.presets.split(",") if s.strip()]
    for n in names:
        if n not in JEWEL_BEETLE:
            p.error(f"unknown preset {n!r}; valid: {', '.join(JEWEL_BEETLE_NAMES)}")
    generator = torch.Generator().manual_seed(args.seed)
    results = [run_preset(n, args, generator) for n in names]
    doc = {"command": "PYTHONPATH=src python training/match_scatterogram.py " + " ".join(sys.argv[1:] if argv is None
                                                                                            else argv),
           "settings": {"incidences_deg": args.incidences, "resolution": args.resolution,
                        "wavelengths": args.wavelengths, "noise": args.noise, "seed": args.seed,
                        "threads": args.threads, "bars": BARS},
           "results": results}
    text = json.dumps(json_ready(doc), indent=1, allow_nan=False)
    table = markdown(results, args)
    print(text)
    print()
    print(table)
    if args.notes:  # atomic: a failed run leaves the old notes as they were
        os.makedirs(os.path.dirname(os.path.abspath(args.notes)), exist_ok=True)
        atomic_write(args.notes, lambda f: f.write((table + "\n```json\n" + text + "\n```\n").encode("utf-8")))
    return 0


if __name__ == "__main__":
    sys.exit(main())
