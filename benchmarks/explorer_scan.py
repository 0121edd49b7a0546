"""Dense scan of the explorer page's materials against the page's bar (issue 37): every film and
every Bragg mirror on a grid over the sliders' whole ranges, the colour the page reads from its
shipped texture against the library's spectral colour (both clipped to sRGB), ΔE2000 mean and max
over the angles, per material; prints the worst and how many materials miss mean ≤ 1.0 / max ≤ 2.5.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/explorer_scan.py            # ~2 min on one core
    .venv/bin/python benchmarks/explorer_scan.py --film-steps 5,0.05 --angles 120   # the test's grid

tests/realtime/test_explorer_page.py::test_every_material_on_the_sliders_holds_the_page_bar holds
the bar on a coarser grid.
"""

from __future__ import annotations

import argparse
import time

import torch

from torchirid.app.explorer import BASES, BRAGG_CELLS, material_errors, slider_ranges


def _steps(lo_hi_step, step):
    lo, hi, _ = lo_hi_step
    return torch.linspace(lo, hi, round((hi - lo) / step) + 1, dtype=torch.float64)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--film-steps", default="5,0.025", help="d (nm), n steps")
    ap.add_argument("--bragg-steps", default="2,0.025", help="Λ (nm), δ steps")
    ap.add_argument("--angles", type=int, default=120, help="angles θ = (i + ½)/K · 90°")
    args = ap.parse_args(argv)
    r = slider_ranges()
    theta = (torch.arange(args.angles, dtype=torch.float64) + 0.5) / args.angles * 90.0
    print("| family | texture | materials | worst mean | worst max (at) | over the bar |\n|---|---|---:|---:|---:|---:|")
    for family, keys, axes, steps in (("film", list(BASES), ("thickness", "n_film"), args.film_steps),
                                      ("bragg", list(BRAGG_CELLS), ("period", "delta"), args.bragg_steps)):
        s1, s2 = (float(v) for v in steps.split(","))
        a, b = torch.meshgrid(_steps(r[axes[0]], s1), _steps(r[axes[1]], s2), indexing="ij")
        a, b = a.reshape(-1), b.reshape(-1)
        for key in keys:
            t = time.perf_counter()
            e = material_errors(family, key, a, b, theta)
            i = int(e[:, 1].argmax())
            bad = int(((e[:, 0] > 1.0) | (e[:, 1] > 2.5)).sum())
            name = BASES[key] if family == "film" else BRAGG_CELLS[key]
            print(f"| {family} | {name} | {e.shape[0]} | {float(e[:, 0].max()):.2f} | {float(e[i, 1]):.2f} "
                  f"({float(a[i]):g}, {float(b[i]):g}, θ {float(e[i, 2]):.1f}°) | {bad} | "
                  f"<!-- {time.perf_counter() - t:.0f} s -->", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
