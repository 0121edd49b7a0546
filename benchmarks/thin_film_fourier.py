#!/usr/bin/env python
"""Belcour–Barla Fourier thin-film colour (M terms) vs exact spectral integration: ΔE2000 and time.

Random films: thickness U(0, 1000) nm, film index U(1.2, 2.0), angle U(0, 89°), in air, on a
dielectric base (1.5) and a non-dispersive conductor (0.2 + 3i). Reference: spectrum_to_xyz of
thin_film_reflectance on a 1 nm grid 360–830 nm (CIE 1931 2°, D65). Times are per colour,
batched, float64, CPU, medians of interleaved repeats.

    PYTHONPATH=src python benchmarks/thin_film_fourier.py [--n 2000] [--repeats 7]
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time

import torch

from torchirid import thin_film_reflectance
from torchirid.color import spectrum_to_xyz
from torchirid.color.convert import xyz_to_lab
from torchirid.color.difference import delta_e_2000
from torchirid.ibl import thin_film_xyz_fourier

BASES = {"dielectric 1.5": 1.5, "conductor 0.2+3i": complex(0.2, 3.0)}
TERMS = (1, 2, 3, 4)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=2000)
    p.add_argument("--repeats", type=int, default=7)
    args = p.parse_args(argv)
    torch.manual_seed(0)
    f64 = torch.float64
    n = args.n
    cos_t = torch.cos(torch.rand(n, dtype=f64) * math.radians(89.0))
    d = torch.rand(n, dtype=f64) * 1000.0
    nf = 1.2 + 0.8 * torch.rand(n, dtype=f64)
    wl = torch.arange(360.0, 830.001, 1.0, dtype=f64)

    def exact(ns):
        return spectrum_to_xyz(thin_film_reflectance(wl, cos_t[:, None], nf[:, None], d[:, None], ns), wl)

    rows, times = [], {}
    for name, ns in BASES.items():
        ref = exact(ns)
        lab_ref = xyz_to_lab(ref)
        for M in TERMS:
            de = delta_e_2000(xyz_to_lab(thin_film_xyz_fourier(cos_t, nf, d, ns, terms=M)), lab_ref)
            q = torch.quantile(de, torch.tensor([0.5, 0.95], dtype=f64))
            rows.append((name, M, q[0].item(), q[1].item(), de.max().item()))
        # interleaved timing
        fns = {"exact (471 λ)": lambda ns=ns: exact(ns)}
        for M in TERMS:
            fns[f"M = {M}"] = lambda ns=ns, M=M: thin_film_xyz_fourier(cos_t, nf, d, ns, terms=M)
        samples = {k: [] for k in fns}
        for _ in range(args.repeats):
            for k, f in fns.items():
                t0 = time.perf_counter()
                f()
                samples[k].append((time.perf_counter() - t0) / n * 1e6)
        times[name] = {k: statistics.median(v) for k, v in samples.items()}

    cmd = "PYTHONPATH=src python benchmarks/thin_film_fourier.py " + " ".join(argv or sys.argv[1:])
    out = [f"`{cmd.strip()}` — {n} random films per base (d ∈ [0, 1000] nm, η₂ ∈ [1.2, 2.0], "
           "θ ∈ [0, 89°], air), CIE 1931 2°, D65, float64 CPU, "
           f"{torch.get_num_threads()} threads; reference: spectrum_to_xyz(thin_film_reflectance) on 1 nm, "
           "360–830 nm.", "",
           "| base | M | ΔE2000 median | p95 | max | µs / colour |", "|---|---|---|---|---|---|"]
    for name, M, med, p95, mx in rows:
        out.append(f"| {name} | {M} | {med:.3f} | {p95:.3f} | {mx:.3f} | {times[name][f'M = {M}']:.2f} |")
    for name in BASES:
        out.append(f"| {name} | exact | 0 | 0 | 0 | {times[name]['exact (471 λ)']:.2f} |")
    print("\n".join(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
